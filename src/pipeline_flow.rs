//! The free-running pipeline of [`Mapper::insert_frames`] and [`Mapper::insert_stream`] in
//! `exact` mode (see [`super::FLOW_MIN_FRAMES`] for why only there): every frame is cast whole
//! by one thread, and whichever thread finds the tree free and the next frame cast applies
//! it. No thread waits while there is a frame to cast or to apply.
//!
//! Why not each frame split across all threads, the tree update of one frame beside the
//! casting of the next, as in steps: a split frame ends with work only one thread can do (each
//! thread sorts its own set, the larger one last, then the sets are merged), and in lock step
//! each casting waited for the tree update beside it, and the other way round. On norlab's
//! LiDAR frames at 0.2 m (tree update about 17 ms, casting 26 ms on one thread) a step took
//! 24 ms, two of them with one thread idle. Cast whole, a frame needs no merge, and the two
//! kinds of work interleave freely: about (tree + casting) / threads per frame.
//!
//! Memory: each thread casts into working buffers of its own (a hash table the size of a
//! frame) and keeps the frame's sets there, unsorted, until one of the `n` result slots is
//! free ([`ScanUpdate::set_deferred`]); so a thread casts the next frame while the slots wait
//! for the tree, and only `n` frames' sorted sets exist at once. With a spare slot instead,
//! `map`'s peak memory on norlab's 14 frames at 0.1 m rose from 243 to 291 MB, beyond issue
//! 28's bound (273 MB); this way it is 262 MB. A frame takes a slot only if as many stay free
//! as frames before it still want one, so the frame the tree waits for always finds one.
//!
//! The tree takes the same key sets in the same order as [`Mapper::insert`] on each frame in
//! turn, so it is the same, byte for byte, for any number of threads. The caller's thread
//! reads the frames and runs `after` for each frame in order, once it is in the tree. When
//! `after` must see the tree with exactly the frames it is called for (checkpoints: `strict`),
//! only the caller's thread applies frames, and calls `after` before it applies the next.

use super::{apply, prepare, Mapper, RunError, Slot};
use crate::checkpoint::frame_digest;
use crate::frame::Frame;
use crate::map_stats::FrameStats;
use crate::mapper_options::MapperOptions;
use nalgebra::{Point3, UnitQuaternion};
use octoquant_octree::{KeyConverter, OcTree};
use octoquant_raycast::ScanUpdate;
use std::borrow::Borrow;
use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::sync::{Condvar, Mutex, MutexGuard};
use std::time::Instant;

/// A frame's statistics and digest (when the mapper keeps a fingerprint).
type Outcome = (FrameStats, Option<u64>);

/// What the threads share.
struct Flow<F> {
    /// Frames read and not yet taken by a thread, with their places in the run, in order.
    todo: VecDeque<(usize, F)>,
    /// Result buffers free for a frame cast.
    free: Vec<Slot>,
    /// Places of the frames taken and not yet in a slot (being cast, or cast and waiting for
    /// one).
    unslotted: BTreeSet<usize>,
    /// Frames cast, by place, waiting for the tree.
    cast: BTreeMap<usize, (Slot, Outcome)>,
    /// The tree, when no thread is applying a frame to it.
    tree: Option<OcTree>,
    /// The place of the next frame the tree takes.
    next: usize,
    /// Frames in the tree whose `after` has not run yet, in order.
    applied: VecDeque<Outcome>,
    /// When the last frame went into the tree (each frame's `seconds` runs from there).
    mark: Instant,
    /// Working buffers (hash tables, the rays' scratch) no thread is using.
    works: Vec<ScanUpdate>,
    /// No frame will be added to `todo`.
    end: bool,
    /// The run stops: threads leave without taking more work.
    stop: bool,
}

impl<F> Flow<F> {
    /// The tree has taken the next frame, whose buffers were `slot`: its `seconds` run from
    /// the previous frame's end to now, the tree waits for the frame after, and the slot is
    /// free again.
    fn took(&mut self, slot: Slot, st: &mut FrameStats) {
        st.seconds = self.mark.elapsed().as_secs_f64();
        self.mark = Instant::now();
        self.next += 1;
        self.free.push(slot);
    }

    /// Whether the frame at `place`, cast, may take a free slot: only if as many stay free as
    /// frames before it still want one, so that the frame the tree waits for always finds one.
    fn slot_for(&self, place: usize) -> bool {
        self.free.len() > self.unslotted.range(..place).count()
    }
}

/// The lock and the condition variable around a [`Flow`].
struct Shared<F> {
    flow: Mutex<Flow<F>>,
    /// Signalled whenever a frame is read, cast or applied, buffers are freed, or the run ends.
    changed: Condvar,
}

impl<F> Shared<F> {
    /// The flow, locked. A thread that panicked while holding the lock broke no invariant the
    /// others rely on (each step under the lock moves items between collections), so the lock
    /// is taken over rather than the panic spread.
    fn lock(&self) -> MutexGuard<'_, Flow<F>> {
        self.flow.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn wait<'a>(&self, g: MutexGuard<'a, Flow<F>>) -> MutexGuard<'a, Flow<F>> {
        self.changed.wait(g).unwrap_or_else(|e| e.into_inner())
    }
}

/// Stops the run when dropped: at the end of the caller's part, however it ends (so that a
/// panicking `after` does not leave the other threads waiting for work), and when a thread
/// of the pool unwinds (so that the caller does not wait for its frame; the scope then passes
/// the panic on).
struct StopOnDrop<'a, F> {
    shared: &'a Shared<F>,
    /// Stop only when unwinding (a thread of the pool that runs out of work just leaves).
    only_on_panic: bool,
}

impl<F> Drop for StopOnDrop<'_, F> {
    fn drop(&mut self) {
        if !self.only_on_panic || std::thread::panicking() {
            self.shared.lock().stop = true;
            self.shared.changed.notify_all();
        }
    }
}

/// What every thread needs besides the flow.
struct Worker<'a> {
    conv: &'a KeyConverter,
    options: &'a MapperOptions,
    /// Whether frames are digested for the mapper's fingerprint.
    track: bool,
}

/// What one step of a thread did.
enum Step<'a, F> {
    /// Applied, listed or cast a frame: the flow may have more.
    Worked(MutexGuard<'a, Flow<F>>),
    /// Nothing to do now.
    Idle(MutexGuard<'a, Flow<F>>),
}

/// A thread's own buffers: the working buffers it casts with, the end points of quantized
/// modes, and the frame it has cast and not yet listed into a slot (its sets still in the
/// working buffers' tables: see [`ScanUpdate::set_deferred`]).
struct Hand {
    work: ScanUpdate,
    centres: Vec<Point3<f32>>,
    held: Option<(usize, Outcome)>,
}

impl Hand {
    fn new<F>(shared: &Shared<F>) -> Self {
        let mut work = shared.lock().works.pop().unwrap_or_default();
        work.set_serial(true);
        work.set_deferred(true);
        Hand {
            work,
            centres: Vec::new(),
            held: None,
        }
    }

    /// Give the working buffers back for the mapper to keep.
    fn put_back<F>(self, shared: &Shared<F>) {
        shared.lock().works.push(self.work);
    }
}

impl Worker<'_> {
    /// One piece of work, the tree first: apply the next frame when it is cast and the tree is
    /// free (and `may_apply`); else list the frame in hand into a free slot, when it may take
    /// one; else cast the next frame read, when the hand is empty.
    fn step<'a, F: Borrow<Frame>>(
        &self,
        shared: &'a Shared<F>,
        mut g: MutexGuard<'a, Flow<F>>,
        hand: &mut Hand,
        may_apply: bool,
    ) -> Step<'a, F> {
        if may_apply && g.tree.is_some() && g.cast.contains_key(&g.next) {
            let next = g.next;
            let (Some(mut tree), Some((slot, (mut st, digest)))) =
                (g.tree.take(), g.cast.remove(&next))
            else {
                return Step::Idle(g);
            };
            drop(g);
            st.tree_seconds = apply(&mut tree, &slot.0, self.options.lazy);
            let mut g = shared.lock();
            g.tree = Some(tree);
            g.took(slot, &mut st);
            g.applied.push_back((st, digest));
            shared.changed.notify_all();
            return Step::Worked(g);
        }
        if let Some((place, _)) = hand.held {
            if !g.slot_for(place) {
                return Step::Idle(g);
            }
            let (Some(mut slot), Some((place, (mut st, digest)))) =
                (g.free.pop(), hand.held.take())
            else {
                return Step::Idle(g);
            };
            drop(g);
            let start = Instant::now();
            slot.0.pass_buffers(&mut hand.work);
            let done = slot.0.finish_pending();
            slot.0.pass_buffers(&mut hand.work);
            if let Some(done) = done {
                st.free = done.free;
                st.occupied = done.occupied;
            }
            st.ray_seconds += start.elapsed().as_secs_f64();
            let mut g = shared.lock();
            g.unslotted.remove(&place);
            g.cast.insert(place, (slot, (st, digest)));
            shared.changed.notify_all();
            return Step::Worked(g);
        }
        let Some((place, frame)) = g.todo.pop_front() else {
            return Step::Idle(g);
        };
        g.unslotted.insert(place);
        // the reader may top the queue up
        shared.changed.notify_all();
        drop(g);
        // files carry no sensor orientation: the filters' sensor frame has the world's axes
        let identity = UnitQuaternion::identity();
        let st = prepare(
            self.conv,
            self.options,
            frame.borrow(),
            &identity,
            &mut hand.work,
            &mut hand.centres,
        );
        let digest = self.track.then(|| frame_digest(frame.borrow()));
        drop(frame);
        hand.held = Some((place, (st, digest)));
        Step::Worked(shared.lock())
    }

    /// A thread of the pool: cast and apply until the run ends or stops.
    fn run<F: Borrow<Frame>>(&self, shared: &Shared<F>, may_apply: bool) {
        let _stop = StopOnDrop {
            shared,
            only_on_panic: true,
        };
        let mut hand = Hand::new(shared);
        let mut g = shared.lock();
        loop {
            let idle = hand.held.is_none() && g.todo.is_empty();
            if g.stop || (g.end && idle && (!may_apply || g.cast.is_empty())) {
                break;
            }
            g = match self.step(shared, g, &mut hand, may_apply) {
                Step::Worked(g) => g,
                Step::Idle(g) => shared.wait(g),
            };
        }
        drop(g);
        hand.put_back(shared);
    }
}

impl Mapper {
    /// The free-running pipeline (see the module docs): workers on the other threads of the
    /// rayon pool (on all of them when the caller is not one of its threads), the source and
    /// `after` on this one, which works too. `slots` are the buffers the mapper keeps between
    /// runs; they come back there, as many as the run used.
    pub(super) fn pipeline_flow<F: Borrow<Frame> + Send + Sync>(
        &mut self,
        frames: &mut dyn Iterator<Item = Result<F, RunError>>,
        after: &mut dyn FnMut(&mut Mapper, &FrameStats) -> Result<(), RunError>,
        strict: bool,
        slots: &mut Vec<Option<Slot>>,
    ) -> Result<(), RunError> {
        let threads = rayon::current_num_threads().max(1);
        let helpers = if rayon::current_thread_index().is_some() {
            threads - 1
        } else {
            threads
        };
        // a slot of results per thread: a thread casts into its own working buffers and lists
        // the frame into a slot once one is free, so the threads cast on while the slots wait
        // for the tree (and the results of no more frames than threads are in memory)
        let mut free: Vec<Slot> = slots.drain(..).flatten().collect();
        free.resize_with(threads.max(2), Slot::default);
        // the working buffers go to the threads; the slots keep only results
        let works: Vec<ScanUpdate> = free
            .iter_mut()
            .map(|s| {
                let mut w = ScanUpdate::new();
                w.pass_buffers(&mut s.0);
                w
            })
            .collect();
        let conv = self.tree.converter().clone();
        // the tree goes where every thread can apply frames, unless `after` needs it here
        let stand_in = OcTree::with_params(self.tree.resolution(), *self.tree.params());
        let (tree, strict) = match stand_in {
            Ok(t) if !strict => (Some(std::mem::replace(&mut self.tree, t)), false),
            _ => (None, true),
        };
        let shared = Shared {
            flow: Mutex::new(Flow {
                todo: VecDeque::new(),
                free,
                unslotted: BTreeSet::new(),
                cast: BTreeMap::new(),
                tree,
                next: 0,
                applied: VecDeque::new(),
                mark: Instant::now(),
                works,
                end: false,
                stop: false,
            }),
            changed: Condvar::new(),
        };
        let options = self.options.clone();
        let worker = Worker {
            conv: &conv,
            options: &options,
            track: self.fingerprint.is_some(),
        };
        let done = rayon::in_place_scope(|s| {
            for _ in 0..helpers {
                s.spawn(|_| worker.run(&shared, !strict));
            }
            let _stop = StopOnDrop {
                shared: &shared,
                only_on_panic: false,
            };
            // frames between reading and counting: one in each thread's hand, one in each
            // slot, and one waiting to be taken
            self.lead(frames, after, &shared, &worker, 2 * threads + 1, strict)
        });
        // the helpers have left: every slot, working buffer and the tree are back
        let mut flow = shared.lock();
        if let Some(tree) = flow.tree.take() {
            self.tree = tree;
        }
        let mut works = std::mem::take(&mut flow.works);
        let mut back: Vec<Slot> = std::mem::take(&mut flow.free);
        back.extend(std::mem::take(&mut flow.cast).into_values().map(|c| c.0));
        for slot in &mut back {
            if let Some(mut w) = works.pop() {
                slot.0.pass_buffers(&mut w);
            }
            slot.0.set_serial(false);
            slot.0.set_deferred(false);
        }
        slots.extend(back.into_iter().map(Some));
        done
    }

    /// The caller's thread: keep frames queued for the helpers, run `after` for each frame in
    /// the tree, in order, and work as they do; in `strict` runs it alone applies frames, with
    /// the tree in the mapper, and runs `after` before the next one.
    fn lead<F: Borrow<Frame> + Send + Sync>(
        &mut self,
        frames: &mut dyn Iterator<Item = Result<F, RunError>>,
        after: &mut dyn FnMut(&mut Mapper, &FrameStats) -> Result<(), RunError>,
        shared: &Shared<F>,
        worker: &Worker<'_>,
        in_flight: usize,
        strict: bool,
    ) -> Result<(), RunError> {
        let mut hand = Hand::new(shared);
        // frames read, and counted (in the tree, `after` run)
        let (mut read, mut counted) = (0, 0);
        let mut failed = None;
        let mut source_done = false;
        let done = 'run: loop {
            // at most `in_flight` frames between reading and counting (see `pipeline_flow`).
            // The source may block, so it is read without the lock.
            while !source_done && failed.is_none() && read - counted < in_flight {
                match frames.next() {
                    Some(Ok(f)) => {
                        shared.lock().todo.push_back((read, f));
                        read += 1;
                        shared.changed.notify_all();
                    }
                    // a source error ends the run after the frames in hand
                    Some(Err(e)) => failed = Some(e),
                    None => source_done = true,
                }
            }
            let mut g = shared.lock();
            if g.stop {
                // a thread of the pool panicked: the scope passes its panic on
                break Ok(());
            }
            if (source_done || failed.is_some()) && !g.end {
                g.end = true;
                shared.changed.notify_all();
            }
            if strict && g.cast.contains_key(&g.next) {
                // the tree is here: apply, count, `after`, then the next
                let next = g.next;
                let Some((slot, (mut st, digest))) = g.cast.remove(&next) else {
                    continue;
                };
                drop(g);
                st.tree_seconds = apply(&mut self.tree, &slot.0, self.options.lazy);
                shared.lock().took(slot, &mut st);
                shared.changed.notify_all();
                self.account(digest, &st);
                counted += 1;
                if let Err(e) = after(self, &st) {
                    break Err(e);
                }
                continue;
            }
            // the frames other threads applied: counted and `after`, in order
            if !g.applied.is_empty() {
                let applied = std::mem::take(&mut g.applied);
                drop(g);
                for (st, digest) in applied {
                    self.account(digest, &st);
                    counted += 1;
                    if let Err(e) = after(self, &st) {
                        break 'run Err(e);
                    }
                }
                continue;
            }
            if g.next == read && g.end {
                break failed.map_or(Ok(()), Err);
            }
            match worker.step(shared, g, &mut hand, !strict) {
                Step::Worked(_) => {}
                Step::Idle(g) => drop(shared.wait(g)),
            }
        };
        hand.put_back(shared);
        done
    }
}
