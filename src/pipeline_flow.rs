//! The free-running pipeline of [`Mapper::insert_frames`] and [`Mapper::insert_stream`]: every
//! frame is cast whole by one thread, and whichever thread finds the tree free and the next
//! frame cast applies it. No thread waits while there is a frame to cast or to apply.
//!
//! Why not each frame split across all threads, the tree update of one frame beside the
//! casting of the next, as before: a split frame ends with work only one thread can do (each
//! thread sorts its own set, the larger one last, then the sets are merged), and in lock step
//! each casting waited for the tree update beside it, and the other way round. On norlab's
//! LiDAR frames at 0.2 m (tree update about 17 ms, casting 26 ms on one thread) a step took
//! 24 ms, two of them with one thread idle. Cast whole, a frame needs no merge, and the two
//! kinds of work interleave freely: about (tree + casting) / threads per frame.
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
use nalgebra::UnitQuaternion;
use octoquant_octree::{KeyConverter, OcTree};
use octoquant_raycast::ScanUpdate;
use std::borrow::Borrow;
use std::collections::{BTreeMap, VecDeque};
use std::sync::{Condvar, Mutex, MutexGuard};
use std::time::Instant;

/// A frame's statistics and digest (when the mapper keeps a fingerprint).
type Outcome = (FrameStats, Option<u64>);

/// What the threads share.
struct Flow<F> {
    /// Frames read and not yet taken by a thread, with their places in the run, in order.
    todo: VecDeque<(usize, F)>,
    /// Buffers free for a casting.
    free: Vec<Slot>,
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
    /// Slots to free rather than reuse, once frames turn out large (see [`LARGE_FRAME_BRICKS`]).
    surplus: usize,
    /// A frame of at least [`LARGE_FRAME_BRICKS`] bricks has been cast.
    large: bool,
}

/// Frames of this many bricks (of 4x4x4 voxels) or more keep one slot fewer in circulation: a
/// slot per thread instead of one more. Each thread keeps a hash table the size of a whole
/// frame (as a frame split across threads does not), and each slot a frame's key sets; with
/// norlab's frames at 0.1 m (about 700 000 bricks: a 32 MB table and 11 MB of sets) the spare
/// slot and the second table took `map`'s peak memory on its 14 frames from 243 to 291 MB,
/// beyond issue 28's bound for it (1.5x the tree plus 64 MB, 273 MB), and without the slot it
/// is 258 MB. Without it a thread that has cast a frame waits, while the tree takes the one
/// before, for the slot that frame frees; on those frames that costs what the spare slot
/// gained (BENCHMARKS.md, history session 37). Frames at 0.2 m (about 180 000 bricks) and
/// depth images keep it.
pub const LARGE_FRAME_BRICKS: usize = 1 << 19;

impl<F> Flow<F> {
    /// A frame was cast into `slot`: if it is the first large one, one slot goes.
    /// (Runs of one thread do not come here; with two or more there are always two slots
    /// left.)
    fn note_cast(&mut self, slot: &Slot) {
        let bricks = slot.0.free_bricks().len() + slot.0.occupied_bricks().len();
        if !self.large && bricks >= LARGE_FRAME_BRICKS {
            self.large = true;
            // a free slot goes now, else the next one the tree frees
            if self.free.pop().is_none() {
                self.surplus = 1;
            }
        }
    }

    /// The tree is done with `slot`: it is free again, unless one slot is to go.
    fn release(&mut self, slot: Slot) {
        if self.surplus > 0 {
            self.surplus -= 1;
        } else {
            self.free.push(slot);
        }
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
    /// Applied a frame or cast one: the flow may have more.
    Worked(MutexGuard<'a, Flow<F>>),
    /// Nothing to do now.
    Idle(MutexGuard<'a, Flow<F>>),
}

impl Worker<'_> {
    /// Cast `frame` into `slot` with the working buffers of `work`, on this thread alone.
    fn cast<F: Borrow<Frame>>(&self, frame: &F, slot: &mut Slot, work: &mut ScanUpdate) -> Outcome {
        // files carry no sensor orientation: the filters' sensor frame has the world's axes
        let identity = UnitQuaternion::identity();
        slot.0.pass_buffers(work);
        let st = prepare(
            self.conv,
            self.options,
            frame.borrow(),
            &identity,
            &mut slot.0,
            &mut slot.1,
        );
        slot.0.pass_buffers(work);
        (st, self.track.then(|| frame_digest(frame.borrow())))
    }

    /// One piece of work, the tree first: apply the next frame when it is cast and the tree is
    /// free (and `may_apply`), else cast the next frame read when buffers are free.
    fn step<'a, F: Borrow<Frame>>(
        &self,
        shared: &'a Shared<F>,
        mut g: MutexGuard<'a, Flow<F>>,
        work: &mut ScanUpdate,
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
            st.seconds = g.mark.elapsed().as_secs_f64();
            g.mark = Instant::now();
            g.tree = Some(tree);
            g.next += 1;
            g.applied.push_back((st, digest));
            g.release(slot);
            shared.changed.notify_all();
            return Step::Worked(g);
        }
        if g.todo.is_empty() || g.free.is_empty() {
            return Step::Idle(g);
        }
        let (Some((place, frame)), Some(mut slot)) = (g.todo.pop_front(), g.free.pop()) else {
            return Step::Idle(g);
        };
        drop(g);
        let outcome = self.cast(&frame, &mut slot, work);
        drop(frame);
        let mut g = shared.lock();
        g.note_cast(&slot);
        g.cast.insert(place, (slot, outcome));
        shared.changed.notify_all();
        Step::Worked(g)
    }

    /// A thread of the pool: cast and apply until the run ends or stops.
    fn run<F: Borrow<Frame>>(&self, shared: &Shared<F>, may_apply: bool) {
        let _stop = StopOnDrop {
            shared,
            only_on_panic: true,
        };
        let mut g = shared.lock();
        let mut work = g.works.pop().unwrap_or_default();
        work.set_serial(true);
        loop {
            if g.stop || (g.end && g.todo.is_empty() && (!may_apply || g.cast.is_empty())) {
                break;
            }
            g = match self.step(shared, g, &mut work, may_apply) {
                Step::Worked(g) => g,
                Step::Idle(g) => shared.wait(g),
            };
        }
        g.works.push(work);
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
        // a slot per thread casting, and one for the frame the tree takes
        let slots_used = threads + 1;
        let mut free: Vec<Slot> = slots.drain(..).flatten().collect();
        free.resize_with(slots_used, Slot::default);
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
                cast: BTreeMap::new(),
                tree,
                next: 0,
                applied: VecDeque::new(),
                mark: Instant::now(),
                works,
                end: false,
                stop: false,
                surplus: 0,
                large: false,
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
            self.lead(frames, after, &shared, &worker, slots_used + 1, strict)
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
        let mut work = shared.lock().works.pop().unwrap_or_default();
        work.set_serial(true);
        // frames read, and counted (in the tree, `after` run)
        let (mut read, mut counted) = (0, 0);
        let mut failed = None;
        let mut source_done = false;
        let done = 'run: loop {
            // at most `in_flight` frames between reading and counting: a slot's worth for
            // every thread, the tree's, and one waiting for the next free slot. The source may
            // block, so it is read without the lock.
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
                let mut g = shared.lock();
                st.seconds = g.mark.elapsed().as_secs_f64();
                g.mark = Instant::now();
                g.next += 1;
                g.release(slot);
                shared.changed.notify_all();
                drop(g);
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
            match worker.step(shared, g, &mut work, !strict) {
                Step::Worked(_) => {}
                Step::Idle(g) => drop(shared.wait(g)),
            }
        };
        shared.lock().works.push(work);
        done
    }
}
