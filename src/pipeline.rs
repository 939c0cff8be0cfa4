//! The mapping pipeline: frame -> (density reduction) -> (quantization) -> rays -> tree.
//!
//! [`Mapper`] owns the tree and the reusable buffers; feed it [`Frame`]s (world coordinates)
//! or sensor-frame points with a pose. Every mode except [`InsertMode::Simple`] updates each
//! voxel at most once per frame, occupied winning over free, exactly like OctoMap's
//! `insertPointCloud`; the resulting `.bt`/`.ot` files are byte-identical to OctoMap's.

use crate::checkpoint::{
    frame_digest, Checkpoint, CheckpointError, FramesFingerprint, RunIdentity,
};
use crate::filters::{count_zero_f32, PointFilters};
use crate::frame::{CameraPixels, Frame};
use nalgebra::{Isometry3, Point3, UnitQuaternion};
use octoquant_octree::{InnerNodes, KeyConverter, OcTree, OctreeError, Update};
use octoquant_quantize::{quantize_endpoints, QuantizeStats};
use octoquant_raycast::{
    apply_update, compute_discrete_update_f32, compute_ray_keys_f32, compute_update_clearing_f32,
    discretize_f32, ApplyOptions, KeyRay, PinholeCamera, PixelGrid, RayModel, ScanStats,
    ScanUpdate,
};
use std::borrow::Borrow;
use std::path::{Path, PathBuf};
use std::time::Instant;

// The options and statistics of a mapper are defined in modules of their own, because the
// checkpoint manifest records them too (the pipeline uses the checkpoint, and both use them);
// their public paths stay here, where users have always found them.
pub use crate::map_stats::{FrameStats, MapStats};
pub use crate::mapper_options::{InsertMode, MapperOptions};

/// Where and how often [`Mapper::insert_run`] saves checkpoints.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CheckpointOptions {
    /// The checkpoint directory (created if needed).
    pub dir: PathBuf,
    /// Save after every this many frames (at multiples of it, counted from the run's first
    /// frame) and after the last frame; 0 saves only after the last.
    pub every: usize,
}

/// Builds an occupancy tree from frames.
pub struct Mapper {
    tree: OcTree,
    options: MapperOptions,
    update: ScanUpdate,
    centres: Vec<Point3<f32>>,
    /// The second buffers of [`Mapper::insert_frames`]: the next frame's rays.
    next_update: ScanUpdate,
    next_centres: Vec<Point3<f32>>,
    /// The third and fourth buffers of [`Mapper::insert_frames`], once frames are cast in
    /// pairs.
    spare: Vec<Slot>,
    /// When [`Mapper::insert_frames`] casts two frames at once.
    frame_pairs: FramePairs,
    stats: MapStats,
    /// Fingerprint of every frame inserted so far (what a checkpoint records); `None` after
    /// [`Mapper::without_checkpoints`], when no frame is digested.
    fingerprint: Option<FramesFingerprint>,
    /// The checkpoint this mapper continues, for the error when the skipped frames differ.
    resumed_from: Option<PathBuf>,
}

/// When the pipelined insertion in steps (every run that is not free-running: see
/// [`FLOW_MIN_FRAMES`]; a free-running run casts every frame on a thread of its own) casts two
/// frames at once, each on a thread of its own, instead of one
/// frame at a time on all threads. Pairs keep both threads busy on frames whose casting is
/// short or has serial parts (depth images: about 5 ms a frame, where a split frame's second
/// thread joins late), at the cost of the working buffers (hash tables, sorted sets) of two
/// castings at once. The tree is the same, byte for byte, in every case.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FramePairs {
    /// One frame at a time.
    Never,
    /// Pairs once the frames just cast are small (under [`SMALL_FRAME_BRICKS`] bricks of
    /// voxels: the second casting's buffers then stay under about 8 MB) or, measured on the
    /// frames just applied, their tree updates took under half their casting. So not for
    /// LiDAR frames of many bricks whose tree update is half the work (norlab at 0.2 and 0.1
    /// m), where pairs would cost memory and gain nothing.
    #[default]
    Auto,
    /// From the first frames on.
    Always,
}

/// Frames whose voxel sets hold fewer bricks (of 4x4x4 voxels) than this are paired by
/// [`FramePairs::Auto`]: TUM depth images at 0.05 m and the Ouster recording at 0.1 m (a few
/// ten thousand), not norlab's LiDAR frames (about 180 000 at 0.2 m, 700 000 at 0.1 m).
pub const SMALL_FRAME_BRICKS: usize = 1 << 16;

/// Runs of this many frames in memory and more, and every stream, go through the free-running
/// pipeline ([`Mapper::insert_frames`]) in [`InsertMode::Exact`]: each thread casts whole
/// frames, so the first and last frames keep a thread each busy while the others wait;
/// shorter runs are cast frame by frame on all threads. On norlab's LiDAR frames at 0.2 m, two
/// threads, the free-running pipeline was as fast or faster from 5 frames on, mixed at 3.
///
/// Why `exact` only: it pays off where casting is the larger part of a frame, as an exact ray
/// for every point is. The other modes cast one ray per end voxel, and on LiDAR frames at 0.1
/// m their tree update is the larger part; there, a casting beside every tree update (instead
/// of a split casting that ends early) made the tree update a tenth slower, and two threads
/// gained less over one than in steps (1.5x against 1.75x; BENCHMARKS.md, history session 37).
pub const FLOW_MIN_FRAMES: usize = 4;

/// Pools of more threads than this run in steps even in [`InsertMode::Exact`]: free-running,
/// every thread holds a table the size of a frame and every result slot a frame's sets (about
/// 43 MB a thread on norlab's frames at 0.1 m), where the steps split one frame's tables across
/// the threads; and with the tree update serial, a third or fourth thread casting whole frames
/// already leaves the tree the bottleneck on LiDAR frames, while the steps put every thread on
/// each frame's casting. Measured only with two threads (the development host has two cores).
pub const FLOW_MAX_THREADS: usize = 4;

/// Whether a run of `mode` on the current rayon pool goes free-running (see
/// [`FLOW_MIN_FRAMES`] and [`FLOW_MAX_THREADS`]; the frame count is checked by the caller).
fn free_running(mode: InsertMode) -> bool {
    mode == InsertMode::Exact && rayon::current_num_threads() <= FLOW_MAX_THREADS
}

/// The buffers of one frame in flight: its key sets and scratch, and its quantized end points.
type Slot = (ScanUpdate, Vec<Point3<f32>>);

/// Why [`Mapper::insert_stream`] stopped early.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RunError {
    /// The frame source failed (a reader error, which names the file and place).
    #[error(transparent)]
    Source(Box<dyn std::error::Error + Send + Sync>),
    /// Saving a checkpoint failed, or the frames a resume skips are not the checkpointed ones.
    #[error(transparent)]
    Checkpoint(#[from] CheckpointError),
}

/// Frames read ahead of insertion by [`Mapper::insert_stream`]'s reader thread, at most: with
/// the frames in the pipeline (see [`Mapper::insert_stream`]), the frames in memory at any
/// moment.
pub const READ_AHEAD: usize = 2;

impl Mapper {
    /// A mapper with an empty tree. Errors for an invalid resolution.
    pub fn new(options: MapperOptions) -> Result<Self, OctreeError> {
        let tree = OcTree::with_params(options.resolution, options.params)?;
        Ok(Self::with_tree(tree, options))
    }

    /// A mapper that continues an existing tree (its resolution and sensor model win).
    pub fn with_tree(tree: OcTree, mut options: MapperOptions) -> Self {
        options.resolution = tree.resolution();
        options.params = *tree.params();
        Mapper {
            tree,
            options,
            update: ScanUpdate::new(),
            centres: Vec::new(),
            next_update: ScanUpdate::new(),
            next_centres: Vec::new(),
            spare: Vec::new(),
            frame_pairs: FramePairs::default(),
            stats: MapStats::default(),
            fingerprint: Some(FramesFingerprint::new()),
            resumed_from: None,
        }
    }

    /// This mapper without the per-frame fingerprint that checkpoints record: a run that will
    /// never save one does not hash every point and pixel of every frame (about 0.4 ms for a
    /// 640 x 480 depth image, a tenth of a `quantized` frame's insertion). The tree is the same;
    /// [`Mapper::save_checkpoint`] then fails with [`CheckpointError::NotTracked`]. Call it
    /// before inserting: frames inserted earlier are forgotten by the fingerprint too.
    pub fn without_checkpoints(mut self) -> Self {
        self.fingerprint = None;
        self
    }

    /// This mapper with `pairs` as the policy for casting two frames at once in runs that are
    /// not free-running (see [`FLOW_MIN_FRAMES`] and [`FramePairs`]; the default is
    /// [`FramePairs::Auto`]). Free-running runs cast every frame on a thread of its own
    /// whatever the policy.
    pub fn with_frame_pairs(mut self, pairs: FramePairs) -> Self {
        self.frame_pairs = pairs;
        self
    }

    /// The options in force.
    pub fn options(&self) -> &MapperOptions {
        &self.options
    }

    /// Insert one frame (world coordinates). Never panics on bad points: they are counted.
    pub fn insert(&mut self, frame: &Frame) -> FrameStats {
        self.insert_oriented(frame, &UnitQuaternion::identity())
    }

    /// [`Mapper::insert`] for a frame whose sensor orientation is known (`rotation`, sensor to
    /// world): the sensor-frame crop box is then applied in the sensor's own axes.
    fn insert_oriented(&mut self, frame: &Frame, rotation: &UnitQuaternion<f64>) -> FrameStats {
        let start = Instant::now();
        if self.options.mode == InsertMode::Simple {
            let mut st = FrameStats {
                points: frame.points.len(),
                ..FrameStats::default()
            };
            let filtered = filter_frame(&self.options.filters, frame, rotation, &mut st);
            let kept: &[Point3<f32>] = filtered.as_ref().map_or(&frame.points, |(p, _)| p);
            st.reduced = kept.len();
            let (points, clearing) = match self.options.reduce {
                Some(cell) => per_part(kept, st.clearing, |part| reduce(part, cell, &mut st)),
                None => (kept.to_vec(), st.clearing),
            };
            st.reduced = points.len();
            let (hits, ground) = points.split_at(points.len() - clearing);
            let lazy = self.options.lazy;
            let s = octoquant_raycast::insert_point_cloud_rays_f32(
                &mut self.tree,
                hits,
                &frame.origin,
                &ApplyOptions { lazy },
            );
            st.non_finite += s.non_finite;
            st.outside_map = s.outside_map;
            st.rays = s.rays;
            st.free = s.free;
            st.occupied = s.occupied;
            // then the ground points kept to clear: each ray's misses, ray by ray, no hit
            let conv = self.tree.converter().clone();
            let mut ray = KeyRay::new();
            for p in ground {
                if compute_ray_keys_f32(&conv, &frame.origin, p, &mut ray) {
                    let inner = InnerNodes::from_lazy(lazy);
                    self.tree.update_keys(ray.keys(), Update::Miss, inner);
                    st.rays += 1;
                    st.free += ray.len();
                }
            }
            st.seconds = start.elapsed().as_secs_f64();
            self.account(self.digest(frame), &st);
            return st;
        }
        let conv = self.tree.converter().clone();
        let mut st = prepare(
            &conv,
            &self.options,
            frame,
            rotation,
            &mut self.update,
            &mut self.centres,
        );
        st.tree_seconds = apply(&mut self.tree, &self.update, self.options.lazy);
        st.seconds = start.elapsed().as_secs_f64();
        self.account(self.digest(frame), &st);
        st
    }

    /// Insert a sequence of frames, in order, with the same result as [`Mapper::insert`] on
    /// each in turn (the same key sets applied in the same order, so the same tree, byte for
    /// byte), but pipelined. In [`InsertMode::Exact`], from [`FLOW_MIN_FRAMES`] frames on and
    /// on at most [`FLOW_MAX_THREADS`] threads, each thread casts whole frames and whichever thread finds the tree free applies the next one
    /// (the free-running pipeline, module `pipeline_flow`); other runs cast frame by frame on
    /// all threads while one thread applies the frame before, or, for small frames or cheap
    /// tree updates, cast two frames at once, a thread each ([`FramePairs`]). With one rayon
    /// thread it is a plain loop.
    ///
    /// Each frame's `seconds` is its share of the wall time from the end of the previous
    /// tree update to the end of its own (the two of a pair share their step's: the sum over
    /// frames is the run's time); `ray_seconds` and `tree_seconds` are measured inside each
    /// stage and overlap between frames.
    pub fn insert_frames(&mut self, frames: &[Frame]) -> Vec<FrameStats> {
        if self.options.mode == InsertMode::Simple
            || rayon::current_num_threads() < 2
            || frames.len() < 2
        {
            return frames.iter().map(|f| self.insert(f)).collect();
        }
        let mut out = Vec::with_capacity(frames.len());
        let mut in_memory = frames.iter().map(Ok::<&Frame, RunError>);
        let done = self.pipeline(
            &mut in_memory,
            &mut |_, st| {
                out.push(*st);
                Ok(())
            },
            true,
            frames.len() >= FLOW_MIN_FRAMES && free_running(self.options.mode),
        );
        // frames in memory cannot fail to read, and collecting the stats cannot fail
        debug_assert!(done.is_ok());
        out
    }

    /// Insert points given in the sensor frame, with the sensor pose in the world
    /// (`world = pose * p`, computed in f64, narrowed once with `as f32` into the frame's `f32`
    /// storage); the origin is the pose's translation, and the
    /// [`crate::filters::PointFilters::crop_sensor`] box is taken in the pose's axes.
    pub fn insert_sensor_frame(
        &mut self,
        points: &[Point3<f64>],
        pose: &Isometry3<f64>,
    ) -> FrameStats {
        self.insert_sensor_frame_with(points.iter().copied(), pose)
    }

    /// [`Mapper::insert_sensor_frame`] for `f32` points: each is widened to `f64` (exactly),
    /// so the result is bit for bit that of the `f64` method on the widened points.
    pub fn insert_sensor_frame_f32(
        &mut self,
        points: &[Point3<f32>],
        pose: &Isometry3<f64>,
    ) -> FrameStats {
        self.insert_sensor_frame_with(points.iter().map(|p| p.cast::<f64>()), pose)
    }

    fn insert_sensor_frame_with(
        &mut self,
        points: impl Iterator<Item = Point3<f64>>,
        pose: &Isometry3<f64>,
    ) -> FrameStats {
        let frame = sensor_points_to_world(points, pose);
        self.insert_oriented(&frame, &pose.rotation)
    }

    /// Insert the rest of a run: `frames` are the whole run's frames, of which the first
    /// `stats().frames` are already in the tree (none for a new mapper, the checkpoint's
    /// position for a [`Mapper::resume`]d one). With `checkpoint`, a checkpoint of the run
    /// `identity` is saved every `every` frames and after the last, so that a killed run can be
    /// resumed and ends with the same tree, byte for byte. `progress` is called with the number
    /// of frames done as frames are inserted. The tree is left as inserted: call
    /// [`Mapper::finish`] after. [`Mapper::insert_stream`] with the frames in memory.
    pub fn insert_run(
        &mut self,
        frames: &[Frame],
        checkpoint: Option<(&CheckpointOptions, &RunIdentity)>,
        mut progress: impl FnMut(usize),
    ) -> Result<(), CheckpointError> {
        let stream = frames
            .iter()
            .cloned()
            .map(Ok::<Frame, std::convert::Infallible>);
        match self.insert_stream(stream, checkpoint, |s: &MapStats| progress(s.frames)) {
            Ok(()) => Ok(()),
            Err(RunError::Checkpoint(e)) => Err(e),
            Err(RunError::Source(e)) => unreachable!("an in-memory run cannot fail to read: {e}"),
        }
    }

    /// Insert a run's frames as they are read: `frames` yields the whole run's frames (or the
    /// first error of their source), of which the first `stats().frames` are already in the
    /// tree (none for a new mapper; the checkpoint's position for a resumed one, whose
    /// skipped frames must have the checkpoint's fingerprint). Only a few frames are in memory
    /// at any time: with `n` ≥ 2 rayon threads a reader thread reads at most [`READ_AHEAD`]
    /// frames ahead of the pipeline of [`Mapper::insert_frames`], which holds at most `2n + 1`
    /// frames between taking and counting them in [`InsertMode::Exact`] (free-running: one in
    /// each thread's hand, one in each of `n` result slots, one waiting) and at most four in
    /// the other modes (steps: one or two being cast, one or two waiting for the tree); a frame
    /// is dropped once cast, its key sets kept until it is in the tree. With one thread, frames
    /// are read, cast and applied in turn. The tree is the same, byte for byte, either way and
    /// for any number of frames.
    ///
    /// With `checkpoint`, a checkpoint of the run `identity` is saved every `every` frames and
    /// after the last, so that a killed run can be resumed ([`Mapper::resume`]) and ends with
    /// the same tree. `progress` is called with the statistics after each frame. On an error
    /// the tree holds the frames inserted before it and the last periodic checkpoint stands.
    /// The tree is left as inserted: call [`Mapper::finish`] after.
    pub fn insert_stream<I, E>(
        &mut self,
        frames: I,
        checkpoint: Option<(&CheckpointOptions, &RunIdentity)>,
        mut progress: impl FnMut(&MapStats),
    ) -> Result<(), RunError>
    where
        I: Iterator<Item = Result<Frame, E>> + Send,
        E: Into<Box<dyn std::error::Error + Send + Sync>> + Send,
    {
        let source = |e: E| RunError::Source(e.into());
        let threads = rayon::current_num_threads();
        if threads < 2 {
            let mut frames = frames.map(|r| r.map_err(source));
            return self.run_frames(&mut frames, checkpoint, &mut progress);
        }
        std::thread::scope(|scope| {
            let (tx, rx) = std::sync::mpsc::sync_channel(READ_AHEAD);
            scope.spawn(move || {
                for r in frames {
                    let stop = r.is_err();
                    // a closed channel: the inserter stopped (an error), so stop reading
                    if tx.send(r).is_err() || stop {
                        break;
                    }
                }
            });
            // the receiver is dropped when this returns, which ends the reader
            let mut frames = rx.into_iter().map(|r| r.map_err(source));
            self.run_frames(&mut frames, checkpoint, &mut progress)
        })
    }

    /// [`Mapper::insert_stream`] after the source: skip what is done, then insert (pipelined
    /// when there are threads to spare), checkpointing on the way.
    fn run_frames(
        &mut self,
        frames: &mut dyn Iterator<Item = Result<Frame, RunError>>,
        checkpoint: Option<(&CheckpointOptions, &RunIdentity)>,
        progress: &mut dyn FnMut(&MapStats),
    ) -> Result<(), RunError> {
        if let (Some((c, _)), None) = (checkpoint, &self.fingerprint) {
            return Err(CheckpointError::NotTracked { dir: c.dir.clone() }.into());
        }
        // frames already in the tree: read them again, and check they are the same ones (a
        // mapper without a fingerprint only skips them)
        let done = self.stats.frames;
        let mut skipped = FramesFingerprint::new();
        let mut n = 0;
        while n < done {
            match frames.next() {
                Some(f) => {
                    let f = f?;
                    if self.fingerprint.is_some() {
                        skipped.add(&f);
                    }
                }
                None => break,
            }
            n += 1;
        }
        // without a fingerprint only the count of the frames skipped can be checked
        let differs = self.fingerprint.is_some_and(|fp| skipped != fp);
        if n > 0 && (n < done || differs) {
            let dir = self.resumed_from.clone().unwrap_or_default();
            let fingerprint = |f: Option<FramesFingerprint>| match f {
                Some(f) => format!("fingerprint {:016x}", f.value()),
                None => "no fingerprint kept".into(),
            };
            return Err(CheckpointError::Mismatch {
                dir,
                what: if n < done {
                    "the number of frames".into()
                } else {
                    "the frames' content".into()
                },
                saved: format!("{done} frames done, {}", fingerprint(self.fingerprint)),
                now: format!(
                    "{n} frames read, {}",
                    fingerprint(self.fingerprint.map(|_| skipped))
                ),
            }
            .into());
        }
        let every = checkpoint.map_or(0, |(c, _)| c.every);
        let mut after = |m: &mut Mapper, _: &FrameStats| -> Result<(), RunError> {
            if let Some((c, identity)) = checkpoint {
                if every > 0 && m.stats.frames.is_multiple_of(every) {
                    m.save_checkpoint(&c.dir, identity)?;
                }
            }
            progress(&m.stats);
            Ok(())
        };
        if self.options.mode == InsertMode::Simple || rayon::current_num_threads() < 2 {
            for f in frames {
                let f = f?;
                let st = self.insert(&f);
                after(self, &st)?;
            }
        } else {
            // a checkpoint must hold exactly the frames counted, so frames are applied one per
            // step then
            let flow = free_running(self.options.mode);
            self.pipeline(frames, &mut after, checkpoint.is_none(), flow)?;
        }
        if let Some((c, identity)) = checkpoint {
            // the last frame (or a run with none, or resumed after its last) ends checkpointed
            let saved_here =
                every > 0 && self.stats.frames.is_multiple_of(every) && self.stats.frames > done;
            if !saved_here || !Checkpoint::exists(&c.dir) {
                self.save_checkpoint(&c.dir, identity)?;
            }
        }
        Ok(())
    }

    /// The pipelined loop of [`Mapper::insert_frames`] and [`Mapper::insert_stream`] (frames
    /// owned or borrowed): with `flow` the free-running pipeline (module `pipeline_flow`),
    /// else in steps: while frame `i` is applied to the tree, the rays of frame `i + 1` are
    /// cast (or, in pairs, frames `i` and `i + 1` are applied while `i + 2` and `i + 3` are
    /// cast; see [`FramePairs`]). `after` runs with each frame's stats once it is in the tree.
    /// Without `pairs` the tree then holds exactly the frames counted (checkpoints need that);
    /// with them, other frames may be in it too.
    fn pipeline<F: Borrow<Frame> + Send + Sync>(
        &mut self,
        frames: &mut dyn Iterator<Item = Result<F, RunError>>,
        after: &mut dyn FnMut(&mut Mapper, &FrameStats) -> Result<(), RunError>,
        pairs: bool,
        flow: bool,
    ) -> Result<(), RunError> {
        // the buffers of the frames in flight: the mapper's two, and those kept from pairs
        // before (the steps make more when pairs need them)
        let spare = std::mem::take(&mut self.spare);
        let mut slots: Vec<Option<Slot>> = [
            (
                std::mem::take(&mut self.update),
                std::mem::take(&mut self.centres),
            ),
            (
                std::mem::take(&mut self.next_update),
                std::mem::take(&mut self.next_centres),
            ),
        ]
        .into_iter()
        .chain(spare)
        .map(Some)
        .collect();
        let policy = if pairs {
            self.frame_pairs
        } else {
            FramePairs::Never
        };
        let done = if flow {
            self.pipeline_flow(frames, after, !pairs, &mut slots)
        } else {
            self.pipeline_steps(frames, after, policy, &mut slots)
        };
        // every slot is back in `slots` (the steps return them before any error)
        let mut back = slots.into_iter().flatten();
        let mut put = |u: &mut ScanUpdate, c: &mut Vec<Point3<f32>>| {
            if let Some((bu, bc)) = back.next() {
                *u = bu;
                *c = bc;
            }
        };
        put(&mut self.update, &mut self.centres);
        put(&mut self.next_update, &mut self.next_centres);
        self.spare = back.collect();
        done
    }

    /// The steps of [`Mapper::pipeline`]: each applies the frames cast in the step before (in
    /// order, on one thread) while the next frames are cast, one at a time on all threads, or
    /// two at once, each on a thread of its own, as [`FramePairs`] decides after each step:
    /// then a frame's casting no longer waits for its serial parts (set-up, merge, sort) or for
    /// a worker to wake, as the rays of a cheap depth image did on two threads. Which frames go
    /// together changes only the timing: the tree takes the same key sets in the same order.
    /// `pairs` is [`FramePairs::Never`] when `after` must see the tree with exactly the frames
    /// it is called for (checkpoints): a step applies two frames before calling it for either.
    fn pipeline_steps<F: Borrow<Frame> + Sync>(
        &mut self,
        frames: &mut dyn Iterator<Item = Result<F, RunError>>,
        after: &mut dyn FnMut(&mut Mapper, &FrameStats) -> Result<(), RunError>,
        pairs: FramePairs,
        slots: &mut Vec<Option<Slot>>,
    ) -> Result<(), RunError> {
        let conv = self.tree.converter().clone();
        let lazy = self.options.lazy;
        // files carry no sensor orientation: the filters' sensor frame has the world's axes
        let identity = UnitQuaternion::identity();
        let track = self.fingerprint.is_some();
        // frames cast and waiting for the tree, in order: their slot, stats and digest
        let mut ready: Vec<(usize, FrameStats, Option<u64>)> = Vec::new();
        let mut idle: Vec<usize> = (0..slots.len()).rev().collect();
        let mut failed = None;
        let mut width = if pairs == FramePairs::Always { 2 } else { 1 };
        let mut mark = Instant::now();
        loop {
            // a source error ends the run after the frames in hand, as without pipelining
            let mut new = Vec::with_capacity(width);
            while failed.is_none() && new.len() < width {
                match frames.next() {
                    Some(Ok(f)) => new.push(f),
                    Some(Err(e)) => failed = Some(e),
                    None => break,
                }
            }
            if ready.is_empty() && new.is_empty() {
                return failed.map_or(Ok(()), Err);
            }
            let mut applying: Vec<(usize, Slot)> = ready
                .iter()
                .filter_map(|&(i, ..)| Some((i, slots[i].take()?)))
                .collect();
            // a slot for each new frame: an idle one, or a new one (pairs need four in all)
            let mut casting: Vec<(usize, Slot)> = Vec::with_capacity(new.len());
            for _ in &new {
                let i = idle.pop().unwrap_or_else(|| {
                    slots.push(None);
                    slots.len() - 1
                });
                casting.push((i, slots[i].take().unwrap_or_default()));
            }
            // the tree needs only the sets of a frame: its working buffers (hash tables, the
            // threads' sets) go to a frame being cast, so that no more of them exist than
            // frames are cast at once
            for ((_, c), (_, a)) in casting.iter_mut().zip(applying.iter_mut()) {
                c.0.pass_buffers(&mut a.0);
            }
            let (tree, options) = (&mut self.tree, &self.options);
            let (tree_s, cast) = rayon::join(
                || {
                    applying
                        .iter()
                        .map(|(_, (u, _))| apply(tree, u, lazy))
                        .collect::<Vec<f64>>()
                },
                || {
                    let one = |f: &F, (u, c): &mut Slot| {
                        // the checkpoints' frame digest too is found off the serial path
                        rayon::join(
                            || prepare(&conv, options, f.borrow(), &identity, u, c),
                            || track.then(|| frame_digest(f.borrow())),
                        )
                    };
                    match (&new[..], &mut casting[..]) {
                        ([a, b], [(_, sa), (_, sb)]) => {
                            let (x, y) = rayon::join(|| one(a, sa), || one(b, sb));
                            vec![x, y]
                        }
                        _ => new
                            .iter()
                            .zip(casting.iter_mut())
                            .map(|(f, (_, s))| one(f, s))
                            .collect(),
                    }
                },
            );
            drop(new);
            // every slot goes back: those cast wait for the tree, those applied are free
            let cast_slots: Vec<usize> = casting.iter().map(|&(i, _)| i).collect();
            for (i, slot) in casting {
                slots[i] = Some(slot);
            }
            let n = applying.len();
            for (i, slot) in applying {
                slots[i] = Some(slot);
                idle.push(i);
            }
            let done = std::mem::replace(
                &mut ready,
                cast_slots
                    .into_iter()
                    .zip(cast)
                    .map(|(i, (st, digest))| (i, st, digest))
                    .collect(),
            );
            // the frames just cast are small: a second casting's buffers cost little
            let small = ready.iter().all(|&(i, ..)| {
                slots[i].as_ref().is_some_and(|(u, _)| {
                    u.free_bricks().len() + u.occupied_bricks().len() < SMALL_FRAME_BRICKS
                })
            });
            if n == 0 {
                // the first frames' casting counts towards the first frame's time
                if pairs == FramePairs::Auto {
                    width = if small { 2 } else { 1 };
                }
                continue;
            }
            // each frame applied in this step gets an equal share of its time
            let share = mark.elapsed().as_secs_f64() / n as f64;
            mark = Instant::now();
            let (mut tree_total, mut ray_total) = (0.0, 0.0);
            for ((_, mut st, digest), t) in done.into_iter().zip(tree_s) {
                st.tree_seconds = t;
                st.seconds = share;
                tree_total += t;
                ray_total += st.ray_seconds;
                self.account(digest, &st);
                after(self, &st)?;
            }
            if pairs == FramePairs::Auto {
                width = if small || tree_total < 0.5 * ray_total {
                    2
                } else {
                    1
                };
            }
        }
    }

    /// Save a checkpoint of the run `identity` into `dir`: the tree as it is (inner nodes
    /// stale after lazy insertion, exactly as in memory) and the position, which is the
    /// number of frames this mapper has inserted (`stats().frames`). Atomic: a kill at any
    /// moment leaves the previous checkpoint or this one.
    pub fn save_checkpoint(
        &self,
        dir: &Path,
        identity: &RunIdentity,
    ) -> Result<(), CheckpointError> {
        let Some(fingerprint) = &self.fingerprint else {
            return Err(CheckpointError::NotTracked {
                dir: dir.to_path_buf(),
            });
        };
        Checkpoint::save(dir, &self.tree, &self.stats, fingerprint.value(), identity)
    }

    /// Continue the run checkpointed in `dir`. `identity` is this run's (the same options,
    /// inputs and frames) and must equal the checkpoint's, else the error names the first
    /// difference. The mapper's `stats().frames` is the position to continue from; feed it
    /// the same frames with [`Mapper::insert_run`].
    pub fn resume(dir: &Path, identity: &RunIdentity) -> Result<Mapper, CheckpointError> {
        let c = Checkpoint::load(dir)?;
        identity.check_same(&c.identity, dir)?;
        Mapper::from_checkpoint(&c)
    }

    /// The mapper a loaded checkpoint stands for: its tree, options and statistics (no
    /// identity check; see [`Mapper::resume`]).
    pub fn from_checkpoint(c: &Checkpoint) -> Result<Mapper, CheckpointError> {
        let tree = c.load_tree()?;
        let mut m = Mapper::with_tree(tree, c.identity.options.clone());
        m.stats = c.stats;
        m.fingerprint = Some(FramesFingerprint::from_value(c.done_hash));
        m.resumed_from = Some(c.dir.clone());
        Ok(m)
    }

    /// The [`frame_digest`] of `frame` when this mapper keeps a fingerprint.
    fn digest(&self, frame: &Frame) -> Option<u64> {
        self.fingerprint.is_some().then(|| frame_digest(frame))
    }

    /// Count a frame inserted: its [`frame_digest`] (when fingerprinted) and its stats.
    fn account(&mut self, digest: Option<u64>, st: &FrameStats) {
        if let (Some(fp), Some(d)) = (&mut self.fingerprint, digest) {
            fp.add_digest(d);
        }
        self.stats.add(st);
    }

    /// Bring inner nodes up to date after lazy insertion (a no-op otherwise).
    pub fn finish(&mut self) {
        if self.options.lazy {
            self.tree.update_inner_occupancy();
        }
    }

    /// Totals over all frames.
    pub fn stats(&self) -> &MapStats {
        &self.stats
    }

    /// The tree (call [`Mapper::finish`] first after lazy insertion).
    pub fn tree(&self) -> &OcTree {
        &self.tree
    }

    /// The tree, mutably.
    pub fn tree_mut(&mut self) -> &mut OcTree {
        &mut self.tree
    }

    /// Finish and hand over the tree.
    pub fn into_tree(mut self) -> OcTree {
        self.finish();
        self.tree
    }
}

/// One frame's rays without a tree: the ray stage of [`Mapper`] on its own, for builds that
/// apply the voxel sets elsewhere (the tiled build of `octoquant_tiles`, on other threads or
/// machines). [`FrameCaster::cast`] fills the same free and occupied sets that
/// [`Mapper::insert`] applies for the same options and frame (filters, density reduction,
/// quantization, mode).
pub struct FrameCaster {
    conv: KeyConverter,
    options: MapperOptions,
    update: ScanUpdate,
    centres: Vec<Point3<f32>>,
}

/// Why a [`FrameCaster`] cannot be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CasterError {
    /// [`InsertMode::Simple`] updates voxels ray by ray, several times per frame: it has no
    /// per-frame voxel sets.
    #[error("mode {0} updates voxels ray by ray and has no per-frame voxel sets")]
    NoFrameSets(&'static str),
    /// The resolution is invalid.
    #[error(transparent)]
    Octree(#[from] OctreeError),
}

impl FrameCaster {
    /// A caster for `options` (any mode but [`InsertMode::Simple`]; `lazy` plays no part).
    pub fn new(options: MapperOptions) -> Result<Self, CasterError> {
        if options.mode == InsertMode::Simple {
            return Err(CasterError::NoFrameSets(options.mode.name()));
        }
        Ok(FrameCaster {
            conv: KeyConverter::new(options.resolution)?,
            options,
            update: ScanUpdate::new(),
            centres: Vec::new(),
        })
    }

    /// The options in force.
    pub fn options(&self) -> &MapperOptions {
        &self.options
    }

    /// Cast `frame` (world coordinates; a file's frame, so the sensor-frame crop box has the
    /// world's axes, as in [`Mapper::insert`]): its voxel sets and statistics
    /// (`tree_seconds` is 0, `seconds` the ray stage's).
    pub fn cast(&mut self, frame: &Frame) -> (&ScanUpdate, FrameStats) {
        self.cast_oriented(frame, &UnitQuaternion::identity())
    }

    /// [`FrameCaster::cast`] for a frame whose sensor orientation is known (`rotation`, sensor
    /// to world): the sensor-frame crop box is then applied in the sensor's own axes, as
    /// [`Mapper::insert_sensor_frame_f32`] applies it.
    pub(crate) fn cast_oriented(
        &mut self,
        frame: &Frame,
        rotation: &UnitQuaternion<f64>,
    ) -> (&ScanUpdate, FrameStats) {
        let FrameCaster {
            conv,
            options,
            update,
            centres,
        } = self;
        let mut st = prepare(conv, options, frame, rotation, update, centres);
        st.seconds = st.ray_seconds;
        (&self.update, st)
    }

    /// [`FrameCaster::cast`] into buffers of the caller's (a pipeline casts the next frame into
    /// a second update while the tree takes the sets of the first): the frame's sets go into
    /// `update`, `centres` is scratch. Takes `&self`, so it can run beside a reader of
    /// another update.
    pub(crate) fn cast_into(
        &self,
        frame: &Frame,
        update: &mut ScanUpdate,
        centres: &mut Vec<Point3<f32>>,
    ) -> FrameStats {
        let identity = UnitQuaternion::identity();
        let mut st = prepare(&self.conv, &self.options, frame, &identity, update, centres);
        st.seconds = st.ray_seconds;
        st
    }
}

/// Sensor-frame `points` moved into the world by the sensor `pose` (sensor to world): each
/// `pose * p` computed in `f64` and narrowed once with `as f32` into the frame's storage, the
/// origin the pose's translation narrowed the same way. The one definition of a sensor frame's
/// world coordinates, so that every mapper's sensor-frame insertion ([`Mapper`]'s,
/// [`crate::color_map::ColorMapper`]'s, [`crate::stamped_map::StampedMapper`]'s) builds the
/// same frame from the same points and pose. No stamp, colours or camera.
pub(crate) fn sensor_points_to_world(
    points: impl Iterator<Item = Point3<f64>>,
    pose: &Isometry3<f64>,
) -> Frame {
    Frame::new_f32(
        Point3::from(pose.translation.vector.cast::<f32>()),
        points.map(|p| (pose * p).cast::<f32>()).collect(),
    )
}

/// A frame whose `f32` points are in the sensor frame, moved into the world by `pose` as
/// [`sensor_points_to_world`] moves them (each point widened to `f64`, exactly), keeping its
/// time stamp, colours and depth camera. Its `origin` is not used (the sensor is at the pose's
/// translation). The camera, whose orientation is given in the sensor frame, is turned by the
/// pose with its points, so a depth image keeps its pixel grid and `exact` mode its head skip
/// (a grid only ever speeds the walk: points that do not match their pixel are walked whole,
/// so the map is the same either way).
pub(crate) fn sensor_frame_to_world(frame: &Frame, pose: &Isometry3<f64>) -> Frame {
    let turn = pose.rotation.to_rotation_matrix();
    Frame {
        stamp: frame.stamp,
        colors: frame.colors.clone(),
        camera: frame.camera.as_ref().map(|c| CameraPixels {
            camera: PinholeCamera {
                rotation: turn * c.camera.rotation,
                ..c.camera
            },
            pixels: c.pixels.clone(),
        }),
        ..sensor_points_to_world(frame.points.iter().map(|p| p.cast::<f64>()), pose)
    }
}

/// Thin `points` with the online density reducer, counting non-finite points in `st`.
fn reduce(points: &[Point3<f32>], cell: [f64; 3], st: &mut FrameStats) -> Vec<Point3<f32>> {
    let finite = points
        .iter()
        .filter(|p| p.iter().all(|c| c.is_finite()))
        .count();
    st.non_finite += points.len() - finite;
    // cell sizes were validated when the options were built; fall back to no reduction
    let out = octoquant_density::reduce_points(points, cell).unwrap_or_else(|_| points.to_vec());
    st.reduced = out.len();
    out
}

/// The frame's points that `filters` keep (and their camera pixels, if any), with the counts
/// in `st`; `None` (and only the zero points counted, one comparison per point) when no
/// filter is set, so that the unfiltered path costs nothing more.
fn filter_frame(
    filters: &PointFilters,
    frame: &Frame,
    rotation: &UnitQuaternion<f64>,
    st: &mut FrameStats,
) -> Option<(Vec<Point3<f32>>, Vec<u32>)> {
    if !filters.is_active() {
        st.zero = count_zero_f32(&frame.origin, &frame.points);
        return None;
    }
    let mut points = Vec::with_capacity(frame.points.len());
    let mut pixels = Vec::new();
    let c = filters.apply(
        &frame.origin,
        rotation,
        &frame.points,
        frame.camera.as_ref().map(|c| &c.pixels[..]),
        &mut points,
        &mut pixels,
    );
    st.non_finite += c.non_finite;
    st.zero = c.zero;
    st.dropped = c.dropped;
    st.clearing = c.clearing;
    Some((points, pixels))
}

/// `points` made from a frame's hits (`points[..len - clearing]`) and clearing points (the
/// last `clearing`) by `f` on each part apart, the clearing ones last again: the points and
/// how many of them clear. One call of `f` when nothing clears.
fn per_part(
    points: &[Point3<f32>],
    clearing: usize,
    mut f: impl FnMut(&[Point3<f32>]) -> Vec<Point3<f32>>,
) -> (Vec<Point3<f32>>, usize) {
    let (hits, ground) = points.split_at(points.len() - clearing);
    let mut out = f(hits);
    if clearing == 0 {
        return (out, 0);
    }
    let ground = f(ground);
    out.extend_from_slice(&ground);
    (out, ground.len())
}

/// Everything of a frame's insertion except the tree: filters, reduction, quantization and
/// rays into `update`'s key sets. Fills the statistics but `tree_seconds` and `seconds`.
fn prepare(
    conv: &KeyConverter,
    options: &MapperOptions,
    frame: &Frame,
    rotation: &UnitQuaternion<f64>,
    update: &mut ScanUpdate,
    centres: &mut Vec<Point3<f32>>,
) -> FrameStats {
    let start = Instant::now();
    let mut st = FrameStats {
        points: frame.points.len(),
        ..FrameStats::default()
    };
    let filtered = filter_frame(&options.filters, frame, rotation, &mut st);
    let grid = frame.camera.as_ref().map(|c| PixelGrid {
        camera: c.camera,
        pixels: filtered.as_ref().map_or(&c.pixels[..], |(_, px)| px),
    });
    let reduced;
    let mut points: &[Point3<f32>] = filtered.as_ref().map_or(&frame.points, |(p, _)| p);
    // the last `clearing` points (ground points kept to clear space) mark nothing occupied;
    // the reduction and quantization keep them apart from the hits
    let mut clearing = st.clearing;
    st.reduced = points.len();
    if let Some(cell) = options.reduce {
        (reduced, clearing) = per_part(points, clearing, |part| reduce(part, cell, &mut st));
        points = &reduced;
        st.reduced = points.len();
    }
    let origin = frame.origin;
    let max_range = options.max_range;
    let scan: ScanStats = match options.mode {
        InsertMode::Exact | InsertMode::Simple => {
            // a reduced frame has lost the pixel order
            let grid = grid.as_ref().filter(|_| options.reduce.is_none());
            let dda = RayModel::Dda;
            compute_update_clearing_f32(
                conv, points, clearing, grid, &origin, max_range, dda, update,
            )
        }
        InsertMode::Discretize if clearing == 0 => {
            compute_discrete_update_f32(conv, points, &origin, max_range, update)
        }
        InsertMode::Discretize => {
            // each part discretized apart (the filters left only finite points)
            let (centres, clearing) = per_part(points, clearing, |part| {
                let mut c = Vec::new();
                discretize_f32(conv, part, &mut c);
                c
            });
            let dda = RayModel::Dda;
            let mut s = compute_update_clearing_f32(
                conv, &centres, clearing, None, &origin, max_range, dda, update,
            );
            s.points = points.len();
            s
        }
        InsertMode::Quantized | InsertMode::QuantizedBresenham => {
            let mut q = QuantizeStats::default();
            let (c, clearing) = per_part(points, clearing, |part| {
                let s = quantize_endpoints(conv, part, &options.quantize, centres);
                q.points += s.points;
                q.non_finite += s.non_finite;
                std::mem::take(centres)
            });
            *centres = c;
            let model = if options.mode == InsertMode::Quantized {
                RayModel::Dda
            } else {
                RayModel::Bresenham
            };
            let mut s = compute_update_clearing_f32(
                conv, centres, clearing, None, &origin, max_range, model, update,
            );
            s.points = q.points;
            s.non_finite += q.non_finite;
            s
        }
    };
    st.ray_seconds = start.elapsed().as_secs_f64();
    st.non_finite += scan.non_finite;
    st.outside_map = scan.outside_map;
    st.rays = scan.rays;
    st.heads_skipped = scan.heads_skipped;
    st.free = scan.free;
    st.occupied = scan.occupied;
    st
}

/// Apply a frame's key sets to the tree (free first, then occupied, as OctoMap); returns the
/// seconds it took.
fn apply(tree: &mut OcTree, update: &ScanUpdate, lazy: bool) -> f64 {
    let start = Instant::now();
    apply_update(tree, update, &ApplyOptions { lazy });
    start.elapsed().as_secs_f64()
}

/// The coloured and stamped mappers' sensor-frame insertions against their naive definition:
/// the points outside the crop box in the sensor's own axes, moved into the world by
/// `pose * p` in `f64` narrowed once, inserted from the pose's translation.
#[path = "pipeline_flow.rs"]
mod flow;

#[cfg(test)]
#[path = "pipeline_sensor_tests.rs"]
mod sensor_frame_tests;
