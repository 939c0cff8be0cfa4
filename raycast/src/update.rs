//! The key sets of one scan: OctoMap's `computeUpdate` and `computeDiscreteUpdate`, without
//! hash sets.
//!
//! A scan's update is two disjoint key sets: the voxels the rays cross (free) and the endpoint
//! voxels (occupied). OctoMap collects them in `std::unordered_set`s; here both go into
//! [`BrickSet`]s, one 64-bit mask per 4x4x4 brick of voxels, found by the brick's Morton
//! code (in a small hash table, or in pages of bricks for large frames). The bricks are then
//! listed in code order and the occupied bits masked out of the free ones; the
//! tree takes the sorted bricks as they are ([`octoquant_octree::OcTree::update_bricks`]), in
//! Morton order, which is its own depth-first order, so applying them touches the tree in one
//! cache-friendly sweep. Keys are listed one by one only when asked for.

use crate::brickset::{push_brick_keys, BrickSet, Subtract};
use crate::dda::{
    coded, is_finite, key_of, norm_f32, sub_f32, walk_ray_codes_f32, RaySetup, RayWalk,
};
use crate::discretize::discretize_into;
use crate::pixel_grid::{jump, near_key, PixelGrid, SkipPlan};
use crate::point_keys::{ChunkKeys, CHUNK};
use crate::setups::{set_up, Pending, Setups, Shared, PENDING};
use crate::stats::ScanStats;
use nalgebra::Point3;
use octoquant_octree::{Brick, Key, KeyConverter};
use std::sync::OnceLock;

/// The free and occupied keys of one scan, plus reusable scratch space.
///
/// Fill it with [`crate::compute_update`] or [`crate::compute_discrete_update`] (or their
/// `_f32` paths); all clear it first. Keep one per thread and reuse it from scan to scan to
/// avoid allocations. Both voxel sets are sorted in Morton order (the tree's depth-first child
/// order), hold each voxel once, and are disjoint; they are kept as bricks of 4x4x4 voxels,
/// and listed as keys on request.
#[derive(Debug, Clone, Default)]
pub struct ScanUpdate {
    /// The free voxels as keys, listed from `bricks` on first request.
    free: OnceLock<Vec<Key>>,
    /// The occupied voxels as keys, listed from `occ_bricks` on first request.
    occupied: OnceLock<Vec<Key>>,
    /// The free voxels: sorted bricks, occupied voxels masked out, no empty mask.
    bricks: Vec<Brick>,
    /// The occupied voxels: sorted bricks.
    occ_bricks: Vec<Brick>,
    /// Working buffers of the computation, not needed once the sets are listed (see
    /// [`ScanUpdate::pass_buffers`]).
    work: Buffers,
}

/// The working buffers of a [`ScanUpdate`]'s computation: hash tables, the threads' sets and
/// the rays' scratch, kept for reuse from scan to scan.
#[derive(Debug, Clone, Default)]
struct Buffers {
    free_set: BrickSet,
    occ_set: BrickSet,
    ray: RayScratch,
    /// Per-thread sets for frames split across rayon threads.
    workers: Vec<Worker>,
    /// What the rays of a depth-image frame may skip.
    plan: SkipPlan,
    centres: Vec<Point3<f32>>,
    order: Vec<(u64, usize)>,
    /// The points of the `f64` doors ([`crate::compute_update`]) narrowed to `f32`.
    narrowed: Vec<Point3<f32>>,
    /// Cast on the calling thread alone, whatever the rayon pool ([`ScanUpdate::set_serial`]).
    serial: bool,
    /// Leave a scan's sets in the tables until [`ScanUpdate::finish_pending`]
    /// ([`ScanUpdate::set_deferred`]).
    deferred: bool,
    /// The statistics of a scan cast with `deferred` and not yet finished.
    pending: Option<ScanStats>,
}

impl ScanUpdate {
    /// An empty update; buffers grow on first use.
    pub fn new() -> Self {
        Self::default()
    }

    /// Voxels to update as misses: each once, none occupied, in Morton order. Listed from
    /// [`ScanUpdate::free_bricks`] on the first call.
    pub fn free(&self) -> &[Key] {
        self.free.get_or_init(|| brick_keys(&self.bricks))
    }

    /// Voxels to update as hits: each once, in Morton order. Listed from
    /// [`ScanUpdate::occupied_bricks`] on the first call.
    pub fn occupied(&self) -> &[Key] {
        self.occupied.get_or_init(|| brick_keys(&self.occ_bricks))
    }

    /// The free voxels as bricks of 4x4x4 voxels, sorted by code, for
    /// [`octoquant_octree::OcTree::update_bricks`]: the same voxels as [`ScanUpdate::free`]
    /// without listing them one by one.
    pub fn free_bricks(&self) -> &[Brick] {
        &self.bricks
    }

    /// The occupied voxels as bricks of 4x4x4 voxels, sorted by code (see
    /// [`ScanUpdate::free_bricks`]).
    pub fn occupied_bricks(&self) -> &[Brick] {
        &self.occ_bricks
    }

    /// The narrowing buffer of the `f64` doors, taken out to be filled (give it back with
    /// [`ScanUpdate::keep_narrowed`]).
    pub(crate) fn take_narrowed(&mut self) -> Vec<Point3<f32>> {
        std::mem::take(&mut self.work.narrowed)
    }

    /// Keep the narrowing buffer for the next scan.
    pub(crate) fn keep_narrowed(&mut self, narrowed: Vec<Point3<f32>>) {
        self.work.narrowed = narrowed;
    }

    /// Bytes of the buffers this update holds (its results and its working buffers: hash
    /// tables, sorted lists, the threads' own sets), for memory accounting.
    pub fn heap_bytes(&self) -> usize {
        fn vec<T>(v: &Vec<T>) -> usize {
            v.capacity() * std::mem::size_of::<T>()
        }
        let w = &self.work;
        let workers: usize = w
            .workers
            .iter()
            .map(|w| w.free_set.heap_bytes() + w.occ_set.heap_bytes())
            .sum();
        vec(&self.bricks)
            + vec(&self.occ_bricks)
            + self.free.get().map_or(0, vec)
            + self.occupied.get().map_or(0, vec)
            + w.free_set.heap_bytes()
            + w.occ_set.heap_bytes()
            + workers
            + vec(&w.centres)
            + vec(&w.order)
            + vec(&w.narrowed)
    }

    /// Swap the working buffers (hash tables, the threads' sets, the rays' scratch) with
    /// `other`'s, each keeping its own results. A pipeline that computes the next scan into one
    /// update while the tree takes the sets of another passes the buffers on before each
    /// computation instead of holding two sets of them: only the results are needed while a
    /// scan is applied.
    pub fn pass_buffers(&mut self, other: &mut ScanUpdate) {
        std::mem::swap(&mut self.work, &mut other.work);
    }

    /// Cast the rays of later scans on the calling thread alone (`true`), or split a large
    /// scan's rays across the threads of the rayon pool it runs in (`false`, the default).
    /// For callers that cast several scans at once, a thread each, as [`ScanUpdate`]s of their
    /// own: a scan split across threads ends with a serial merge of the threads' sets, and a
    /// thread that joins a split scan late keeps working on it after it is needed elsewhere.
    /// The sets are the same either way. The setting belongs to the working buffers:
    /// [`ScanUpdate::pass_buffers`] hands it on with them.
    pub fn set_serial(&mut self, serial: bool) {
        self.work.serial = serial;
    }

    /// With `true`, a scan cast on one thread (see [`ScanUpdate::set_serial`]) leaves its sets
    /// in the working buffers' tables, unsorted, and its statistics without the free and
    /// occupied counts; [`ScanUpdate::finish_pending`] then lists them into an update's
    /// results. For a caller that casts a scan before it has results buffers to spare for it
    /// (the free-running pipeline casts the next frame while the buffers of the frames before
    /// are still the tree's), then hands the working buffers with [`ScanUpdate::pass_buffers`]
    /// to an update whose results are free. A scan split across threads is finished at once
    /// whatever the setting. Like `set_serial`, the setting travels with the working buffers.
    pub fn set_deferred(&mut self, deferred: bool) {
        self.work.deferred = deferred;
    }

    /// List the sets of the scan the working buffers hold unfinished (see
    /// [`ScanUpdate::set_deferred`]) into this update's results, as the scan would have, and
    /// return its statistics, counts included; `None` (and nothing changed) when no scan is
    /// pending.
    pub fn finish_pending(&mut self) -> Option<ScanStats> {
        let mut stats = self.work.pending.take()?;
        self.free = OnceLock::new();
        self.occupied = OnceLock::new();
        finish(self, &mut stats);
        Some(stats)
    }

    /// Empty both voxel sets, keeping the allocations of the sets.
    pub fn clear(&mut self) {
        self.free = OnceLock::new();
        self.occupied = OnceLock::new();
        self.bricks.clear();
        self.occ_bricks.clear();
        self.work.free_set.clear();
        self.work.occ_set.clear();
        self.work.pending = None;
    }
}

/// Which voxels a free-space ray clears.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RayModel {
    /// OctoMap's 3D DDA: every voxel the segment crosses, bit-exact with OctoMap.
    #[default]
    Dda,
    /// Integer Bresenham between the voxel keys (see [`crate::walk_bresenham_keys`]): fewer
    /// voxels per ray, not OctoMap's free space.
    Bresenham,
}

/// One thread's share of a frame: its own sets and ray scratch.
#[derive(Debug, Clone, Default)]
struct Worker {
    free_set: BrickSet,
    occ_set: BrickSet,
    ray: RayScratch,
    stats: ScanStats,
    /// How many bricks each set holds once sorted in place (its table's front), for the merge.
    free_sorted: usize,
    occ_sorted: usize,
}

/// Per-thread buffers of one ray, reused from ray to ray.
#[derive(Debug, Clone, Default)]
struct RayScratch {
    /// The codes of a ray that may degenerate (dropped whole if it does).
    codes: Vec<u64>,
    /// Well-conditioned DDA rays waiting to be walked together.
    batch: Vec<RaySetup>,
    /// Depth-image rays waiting to skip their heads (up to the time given) and be walked.
    tails: Vec<(RaySetup, f64)>,
    /// The buffers of the lane walks.
    lanes: crate::lanes::LaneScratch,
    /// DDA rays waiting for their set-ups, and the set-ups.
    pending: Pending,
    setups: Setups,
    /// Queued walks that degenerated since the counts were last taken.
    degenerate: usize,
    /// Voxels of the 3x3x3 block around the origin voxel crossed by the skipped heads of
    /// depth-image rays (see [`crate::pixel_grid`]).
    near: u32,
    /// Bresenham lines (start and end keys, distinct) waiting to be walked together.
    lines: Vec<(Key, Key)>,
    /// The buffers of the Bresenham lanes.
    line_lanes: crate::lanes::LineScratch,
    /// The keys of the block of points being queued.
    keys: ChunkKeys,
}

/// DDA rays set up before their walks start together (see [`crate::lanes`]): the lanes idle
/// less at a batch's end in longer batches (256 against 64: norlab's exact casting 2 %
/// faster, the Ouster recording and TUM unchanged; 1 024 slowed the Ouster recording by 6 %:
/// history, session 43).
#[cfg(not(fuzzing))]
const RAY_BATCH: usize = 256;
/// In the fuzzing build, short batches: the fuzz targets' few dozen rays fill some.
#[cfg(fuzzing)]
const RAY_BATCH: usize = 16;

/// Frames with at least this many points are split across the rayon threads.
#[cfg(not(fuzzing))]
const PARALLEL_MIN_POINTS: usize = 4096;
/// Points per block handed to the threads in turn.
#[cfg(not(fuzzing))]
const PARALLEL_BLOCK: usize = 256;
/// In the fuzzing build, the split from a few points on, in blocks of a few: the fuzz
/// targets' scans of a few dozen points take it.
#[cfg(fuzzing)]
const PARALLEL_MIN_POINTS: usize = 16;
#[cfg(fuzzing)]
const PARALLEL_BLOCK: usize = 4;

/// The key's Morton code ([`Key::morton`]): sorting by it visits voxels in the tree's own
/// depth-first child order.
#[inline(always)]
pub(crate) fn morton(key: Key) -> u64 {
    key.morton()
}

/// The end of a max-range ray, as OctoMap computes it in `computeUpdate` and `insertRay`:
/// `origin + normalized(p - origin) * (float)max_range`, all in `f32` (the normalisation
/// divides by the `f32`-rounded norm, and only when it is positive).
#[inline]
pub(crate) fn cut_at_range(origin: &Point3<f32>, diff: [f32; 3], max_range: f64) -> Point3<f32> {
    let n = norm_f32(diff);
    let mut d = diff;
    if n > 0.0 {
        for v in d.iter_mut() {
            *v /= n as f32;
        }
    }
    let m = max_range as f32;
    Point3::new(
        origin.x + d[0] * m,
        origin.y + d[1] * m,
        origin.z + d[2] * m,
    )
}

/// Where a ray from `origin` towards `point` ends when a maximum range `max_range` applies:
/// `None` while the point is within range (or `max_range` is negative: no limit), else the
/// point at `max_range` along the ray, computed in `f32` exactly as OctoMap's `computeUpdate`
/// and octomap_server's `insertScan` compute it. Callers that reproduce one of those decide
/// what the cut end is (OctoMap leaves it out, octomap_server clears its voxel too).
pub fn max_range_end_f32(
    origin: &Point3<f32>,
    point: &Point3<f32>,
    max_range: f64,
) -> Option<Point3<f32>> {
    beyond_range(origin, sub_f32(point, origin), max_range)
}

/// The cut end of the ray `origin -> origin + diff` when it is longer than `max_range`
/// (negative: no limit), `None` when it keeps its end point.
#[inline(always)]
fn beyond_range(origin: &Point3<f32>, diff: [f32; 3], max_range: f64) -> Option<Point3<f32>> {
    let within = max_range < 0.0 || norm_f32(diff) <= max_range;
    (!within).then(|| cut_at_range(origin, diff, max_range))
}

/// Queue the Bresenham line between the keys of `origin` and `end` (both in the map, else
/// `false`: the ray fails, as a DDA ray would); lines are walked [`RAY_BATCH`] at a time.
fn push_line(
    origin_key: Option<(Key, u64)>,
    end_key: Option<(Key, u64)>,
    set: &mut BrickSet,
    scratch: &mut RayScratch,
) -> bool {
    let (Some((a, _)), Some((b, _))) = (origin_key, end_key) else {
        return false;
    };
    if a != b {
        scratch.lines.push((a, b));
        if scratch.lines.len() >= RAY_BATCH {
            walk_lines(set, scratch);
        }
    }
    true
}

/// Walk the ray `origin -> end` one voxel at a time into a buffer and add its keys to `set`
/// when it completes: the path of the rare rays that are not well-conditioned (see
/// [`RaySetup`]), whose keys are dropped whole if the walk degenerates, as OctoMap gets no
/// ray. Returns whether the ray could be computed.
fn walk_buffered(
    conv: &KeyConverter,
    origin: &Point3<f32>,
    end: &Point3<f32>,
    set: &mut BrickSet,
    scratch: &mut RayScratch,
) -> bool {
    let codes = &mut scratch.codes;
    codes.clear();
    let walk = walk_ray_codes_f32(conv, origin, end, |c| {
        // grows once to the longest ray, then never again
        if codes.len() == codes.capacity() {
            codes.reserve(codes.len().max(256));
        }
        codes.push(c);
    });
    match walk {
        RayWalk::Complete | RayWalk::SameVoxel => {
            for &c in codes.iter() {
                set.insert(c);
            }
            true
        }
        RayWalk::OutsideMap | RayWalk::Stopped | RayWalk::Degenerate => false,
    }
}

/// Set up the pending DDA rays together ([`crate::setups`]) and queue each: the rays that
/// skip their heads in `ray.tails`, the other well-conditioned ones in `ray.batch`; the rest
/// are walked at once ([`walk_buffered`]). Counts them and empties the pending columns.
fn flush_pending(
    conv: &KeyConverter,
    origin: &Point3<f32>,
    origin_key: (Key, u64),
    shared: &Shared,
    set: &mut BrickSet,
    ray: &mut RayScratch,
    stats: &mut ScanStats,
) {
    set_up(&ray.pending, shared, &mut ray.setups);
    // the well-conditioned rays walked whole, queued for the lanes from the columns at once
    let mut whole = 0u32;
    for i in 0..ray.pending.len() {
        if let Some(t) = ray.setups.head(i) {
            stats.rays += 1;
            stats.heads_skipped += 1;
            let r = ray.pending.ray(&ray.setups, i, origin_key);
            ray.tails.push((r, t));
            if ray.tails.len() >= RAY_BATCH {
                walk_tails(set, ray);
            }
        } else if ray.setups.is_well_conditioned(i) {
            // well-conditioned walks cannot degenerate: counted as computed now
            stats.rays += 1;
            whole |= 1 << i;
        } else if walk_buffered(conv, origin, &ray.pending.end(i), set, ray) {
            stats.rays += 1;
        } else {
            stats.failed_rays += 1;
        }
    }
    if whole != 0 {
        // queued from the columns when they are the first ones (a LiDAR frame's rays, all
        // walked whole)
        let count = whole.trailing_ones() as usize;
        let queued = whole.count_ones() as usize == count
            && crate::lanes::queue_setups(
                &mut ray.lanes,
                &ray.pending,
                &ray.setups,
                origin_key,
                count,
            );
        if !queued {
            // the lanes' arrays are filled from set-ups one ray at a time
            let mut bits = whole;
            while bits != 0 {
                let i = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                ray.batch.push(ray.pending.ray(&ray.setups, i, origin_key));
                if ray.batch.len() >= RAY_BATCH {
                    walk_batch(set, ray);
                }
            }
        } else if crate::lanes::queued(&ray.lanes) >= RAY_BATCH {
            walk_queue(set, ray);
        }
    }
    ray.pending.clear();
}

/// Walk the queued rays into `set` and empty the queue, counting in `scratch.degenerate` the
/// walks that degenerated (none can: see `RaySetup::well_conditioned`).
fn walk_batch(set: &mut BrickSet, scratch: &mut RayScratch) {
    scratch.degenerate += crate::lanes::walk_all(&scratch.batch, &mut scratch.lanes, set);
    scratch.batch.clear();
}

/// Walk the rays queued straight from their set-ups ([`crate::lanes::queue_setups`]) into
/// `set`, counting in `scratch.degenerate` the walks that degenerated (none can).
fn walk_queue(set: &mut BrickSet, scratch: &mut RayScratch) {
    scratch.degenerate += crate::lanes::walk_queued(&mut scratch.lanes, set);
}

/// Move the queued skipping rays to their states at the end of their heads and walk them.
fn walk_tails(set: &mut BrickSet, scratch: &mut RayScratch) {
    scratch.near |= jump(&scratch.tails, &mut scratch.batch);
    scratch.tails.clear();
    walk_batch(set, scratch);
}

/// Walk the queued Bresenham lines into `set` and empty the queue, as many at a time as the
/// CPU has lanes for ([`crate::lanes::walk_lines`]).
fn walk_lines(set: &mut BrickSet, scratch: &mut RayScratch) {
    crate::lanes::walk_lines(&scratch.lines, &mut scratch.line_lanes, set);
    scratch.lines.clear();
}

/// List both sets in Morton order, the occupied first, then the free ones with the occupied
/// voxels taken out as they are listed (occupied wins), and count both.
fn finish(out: &mut ScanUpdate, stats: &mut ScanStats) {
    out.work.occ_set.sorted_into(&mut out.occ_bricks);
    let mut free = Subtract::new(&out.occ_bricks);
    out.work
        .free_set
        .sorted_into_kept(&mut out.bricks, |b| free.keep(b));
    stats.free = free.voxels;
    stats.occupied = voxel_count(&out.occ_bricks);
}

/// Mask the occupied voxels out of the sorted free bricks `out.bricks` (occupied wins),
/// dropping bricks left empty, and count both sets: [`finish`] for the sets merged from the
/// threads of a split frame.
fn emit(out: &mut ScanUpdate, stats: &mut ScanStats) {
    let mut free = Subtract::new(&out.occ_bricks);
    out.bricks.retain_mut(|b| free.keep(b));
    stats.free = free.voxels;
    stats.occupied = voxel_count(&out.occ_bricks);
}

/// Voxels in `bricks`.
fn voxel_count(bricks: &[Brick]) -> usize {
    bricks.iter().map(|b| b.voxels.count_ones() as usize).sum()
}

/// The keys of sorted bricks, in Morton order.
fn brick_keys(bricks: &[Brick]) -> Vec<Key> {
    let mut keys = Vec::new();
    for &b in bricks {
        push_brick_keys(b, &mut keys);
    }
    keys
}

/// `out := ⋃ lists` for brick lists each sorted by brick code (each brick once per list),
/// OR-ing the bits of a brick found in several; one pass over all lists, so no list is copied
/// before the merge and no second output buffer is needed. The lists are the threads' shares
/// (as many as threads), so the smallest head is found by a scan.
fn merge_sorted<'a>(lists: impl Iterator<Item = &'a [Brick]>, out: &mut Vec<Brick>) {
    let mut lists: Vec<&[Brick]> = lists.filter(|l| !l.is_empty()).collect();
    out.clear();
    out.reserve(lists.iter().map(|l| l.len()).max().unwrap_or(0));
    if let [a, b] = lists[..] {
        // two threads, the common case: the plain two-way merge
        let (mut i, mut j) = (0, 0);
        while i < a.len() && j < b.len() {
            let (x, y) = (a[i], b[j]);
            if x.code < y.code {
                out.push(x);
                i += 1;
            } else if y.code < x.code {
                out.push(y);
                j += 1;
            } else {
                out.push(Brick {
                    code: x.code,
                    voxels: x.voxels | y.voxels,
                });
                i += 1;
                j += 1;
            }
        }
        out.extend_from_slice(&a[i..]);
        out.extend_from_slice(&b[j..]);
        return;
    }
    while lists.len() > 1 {
        let code = lists.iter().map(|l| l[0].code).min().unwrap_or(0);
        let mut voxels = 0;
        for l in lists.iter_mut() {
            if l[0].code == code {
                voxels |= l[0].voxels;
                *l = &l[1..];
            }
        }
        out.push(Brick { code, voxels });
        lists.retain(|l| !l.is_empty());
    }
    if let Some(rest) = lists.first() {
        out.extend_from_slice(rest);
    }
}

/// The pixel of each point and what its ray may skip, for depth-image frames.
type Skips<'a> = Option<(&'a SkipPlan, &'a [u32])>;

/// OctoMap's `computeUpdate` loop body (no bounding box) for every finite point of `points`:
/// its ray, cut at `max_range` when it is longer (and then without an occupied end), and its
/// end point's voxel; non-finite points are counted. With `skips`, DDA rays through pixels
/// that other rays cover start where [`SkipPlan::cap`] and their set-ups allow. The points
/// from `clear_from` on only clear: their rays are cast, their end voxels not marked.
#[allow(clippy::too_many_arguments)]
#[inline]
fn add_points(
    conv: &KeyConverter,
    points: &[Point3<f32>],
    clear_from: usize,
    skips: Skips<'_>,
    origin: &Point3<f32>,
    origin_key: Option<(Key, u64)>,
    max_range: f64,
    free_set: &mut BrickSet,
    occ_set: &mut BrickSet,
    ray: &mut RayScratch,
    stats: &mut ScanStats,
    model: RayModel,
) {
    let skips = skips.filter(|_| model == RayModel::Dda);
    let shared = origin_key.map(|(k, _)| Shared::new(conv, origin, k, skips.map(|s| s.0)));
    for (i, p) in points.iter().enumerate() {
        // the keys of the next block of points, found together
        let j = i % CHUNK;
        if j == 0 {
            ray.keys.fill(conv, &points[i..]);
        }
        if !ray.keys.finite(j) {
            stats.non_finite += 1;
            continue;
        }
        let diff = sub_f32(p, origin);
        let hit = ray.keys.hit(j);
        if hit.is_none() {
            stats.outside_map += 1;
        }
        let (end, end_key) = match beyond_range(origin, diff, max_range) {
            None => {
                // points from `clear_from` on only clear their rays
                if let Some((_, code)) = hit.filter(|_| i < clear_from) {
                    occ_set.insert(code);
                }
                (*p, hit)
            }
            Some(e) => {
                stats.max_range_rays += 1;
                (e, key_of(conv, &e).map(coded))
            }
        };
        if model == RayModel::Bresenham {
            match push_line(origin_key, end_key, free_set, ray) {
                true => stats.rays += 1,
                false => stats.failed_rays += 1,
            }
            continue;
        }
        // OctoMap's checks before its loop: both ends in the map (else no ray), in different
        // voxels (else a ray without keys)
        let (Some(okey), Some(ekey), Some(shared)) = (origin_key, end_key, shared.as_ref()) else {
            stats.failed_rays += 1;
            continue;
        };
        if okey.0 == ekey.0 {
            stats.rays += 1;
            continue;
        }
        ray.pending.push(&end, ekey);
        if let Some((plan, pixels)) = skips {
            if let Some((cap, col, row)) = plan.locate(pixels[i]).and_then(|at| plan.cap(at)) {
                ray.pending.may_skip(cap, col, row);
            }
        }
        if ray.pending.is_full() {
            flush_pending(conv, origin, okey, shared, free_set, ray, stats);
        }
    }
    if let (Some(okey), Some(shared)) = (origin_key, shared.as_ref()) {
        if ray.pending.len() > 0 {
            flush_pending(conv, origin, okey, shared, free_set, ray, stats);
        }
    }
    if !ray.tails.is_empty() {
        walk_tails(free_set, ray);
    }
    if !ray.batch.is_empty() {
        walk_batch(free_set, ray);
    }
    if crate::lanes::queued(&ray.lanes) > 0 {
        walk_queue(free_set, ray);
    }
    if !ray.lines.is_empty() {
        walk_lines(free_set, ray);
    }
    if let (Some((okey, _)), near) = (origin_key, std::mem::take(&mut ray.near)) {
        let mut bits = near;
        while bits != 0 {
            let bit = bits.trailing_zeros();
            bits &= bits - 1;
            free_set.insert(morton(near_key(okey, bit)));
        }
    }
    // queued rays were counted as computed; one that degenerated was not
    stats.rays -= ray.degenerate;
    stats.failed_rays += ray.degenerate;
    ray.degenerate = 0;
}

/// Record the length of every sampled ray of a depth-image frame in `plan` (0 for rays that
/// will not surely be walked or do not point along their pixel), then finish the plan. The
/// lengths are found on the rayon threads when `parallel`.
///
/// A sampled ray counts when it is queued as a lane walk by [`add_points`]: both ends in the
/// map, in different voxels, and well-conditioned ([`RaySetup`]), so that its voxels are all
/// in the union (whole, or its head covered by the coarser level and its tail walked).
#[allow(clippy::too_many_arguments)]
fn sample_lengths(
    conv: &KeyConverter,
    plan: &mut SkipPlan,
    points: &[Point3<f32>],
    pixels: &[u32],
    origin: &Point3<f32>,
    origin_key: Option<(Key, u64)>,
    max_range: f64,
    parallel: bool,
) {
    let Some((okey, _)) = origin_key else {
        return;
    };
    let found = |ps: &[Point3<f32>], px: &[u32], plan: &SkipPlan| {
        // the sampled rays' lengths and direction checks are found with their set-ups, in
        // columns (see [`crate::setups`]); the other checks are made here
        let shared = Shared::new(conv, origin, okey, Some(plan));
        let (mut pending, mut out) = (Pending::default(), Setups::default());
        let mut ats = [(0, 0); PENDING];
        let mut found = Vec::new();
        let mut flush = |pending: &mut Pending, ats: &[(usize, usize)], found: &mut Vec<_>| {
            set_up(pending, &shared, &mut out);
            found.extend((0..pending.len()).map(|i| (ats[i], out.walked_length(i))));
            pending.clear();
        };
        for (p, &pixel) in ps.iter().zip(px) {
            let Some(at) = plan.locate(pixel).filter(|&at| plan.sampled(at)) else {
                continue;
            };
            // not walked: not finite, an end outside the map or in the origin's voxel
            let end = is_finite(p)
                .then(|| beyond_range(origin, sub_f32(p, origin), max_range).unwrap_or(*p));
            let key = end.and_then(|e| key_of(conv, &e)).filter(|&k| k != okey);
            let (Some(end), Some(key)) = (end, key) else {
                found.push((at, 0.0));
                continue;
            };
            ats[pending.len()] = at;
            pending.push(&end, (key, 0));
            let (a, b) = plan.factors(at);
            pending.may_skip(f64::INFINITY, a, b);
            if pending.is_full() {
                flush(&mut pending, &ats, &mut found);
            }
        }
        flush(&mut pending, &ats, &mut found);
        found
    };
    if parallel {
        use rayon::prelude::*;
        let shares: Vec<Vec<_>> = points
            .par_chunks(PARALLEL_BLOCK * 16)
            .zip(pixels.par_chunks(PARALLEL_BLOCK * 16))
            .map(|(ps, px)| found(ps, px, plan))
            .collect();
        for (at, length) in shares.into_iter().flatten() {
            plan.record(at, length);
        }
    } else {
        for (at, length) in found(points, pixels, plan) {
            plan.record(at, length);
        }
    }
    plan.finish();
}

/// OctoMap's `computeUpdate(scan, origin, free, occupied, maxrange)` (no bounding box).
///
/// For each point: if it is within `max_range` of `origin` (Euclidean, `f32` differences,
/// `<=`), the keys of the ray `origin -> point` become free and the point's voxel occupied;
/// otherwise the ray is cut at `max_range` (`origin + max_range·direction`, in `f32`): its keys
/// become free, the voxel containing the cut end does not (it is the ray's excluded end), and
/// nothing becomes occupied. Finally every occupied voxel is removed from the free ones:
/// occupied wins. Each voxel appears once.
///
/// `max_range`: `None` means no limit (OctoMap's `-1`). Like OctoMap, `Some(m)` with a negative
/// `m` also means no limit, `Some(0.0)` is a real limit (only points exactly at the origin are
/// hits), and `Some(NaN)` turns every point into a max-range ray that cannot be cast.
///
/// Points with a NaN or infinite coordinate are skipped and counted (OctoMap drops them
/// too, since their keys fail the range check). Points outside the map are dropped, also like
/// OctoMap; when the origin is outside the map no ray can be cast, but endpoints inside the
/// map still become occupied. Clears `out` first.
///
/// The `f32` fast path: coordinates as OctoMap's `point3d`; [`crate::compute_update`] takes
/// `f64`.
pub fn compute_update_f32(
    conv: &KeyConverter,
    points: &[Point3<f32>],
    origin: &Point3<f32>,
    max_range: Option<f64>,
    out: &mut ScanUpdate,
) -> ScanStats {
    compute_update_with_f32(conv, points, origin, max_range, RayModel::Dda, out)
}

/// [`compute_update_f32`] with a choice of ray model: [`RayModel::Dda`] is OctoMap's
/// `computeUpdate`; [`RayModel::Bresenham`] keeps its set semantics (occupied wins, each key
/// once, max-range rays cut without an occupied end) but clears the Bresenham line's voxels.
///
/// An `f32` path only: coordinates as OctoMap's `point3d` (the `f64` door is
/// [`crate::compute_update`]).
pub fn compute_update_with_f32(
    conv: &KeyConverter,
    points: &[Point3<f32>],
    origin: &Point3<f32>,
    max_range: Option<f64>,
    model: RayModel,
    out: &mut ScanUpdate,
) -> ScanStats {
    compute(
        conv,
        points,
        points.len(),
        None,
        origin,
        max_range,
        model,
        out,
    )
}

/// [`compute_update_with_f32`] (or, with a `grid` and [`RayModel::Dda`],
/// [`compute_update_grid_f32`]) for a scan whose last `clearing` points only clear space:
/// their rays' voxels become free as every ray's, but their end voxels are not marked
/// occupied (octomap_server's ground points, which it inserts as free space). The other
/// points are hits as always, and occupied still wins over free. With `clearing` 0 this is
/// the plain update.
#[allow(clippy::too_many_arguments)]
pub fn compute_update_clearing_f32(
    conv: &KeyConverter,
    points: &[Point3<f32>],
    clearing: usize,
    grid: Option<&PixelGrid<'_>>,
    origin: &Point3<f32>,
    max_range: Option<f64>,
    model: RayModel,
    out: &mut ScanUpdate,
) -> ScanStats {
    let grid = grid.filter(|_| model == RayModel::Dda);
    let clear_from = points.len().saturating_sub(clearing);
    compute(
        conv, points, clear_from, grid, origin, max_range, model, out,
    )
}

/// [`compute_update_f32`] for the points of a depth image: the same key sets, bit for bit, found
/// faster by walking most rays only from where their neighbours stop covering them (see
/// [`PixelGrid`]). A `grid` that does not describe the points (another length, pixels out of
/// range, directions that do not match) makes it slower, never different.
///
/// An `f32` path only: coordinates as OctoMap's `point3d` (the `f64` door is
/// [`crate::compute_update`]).
pub fn compute_update_grid_f32(
    conv: &KeyConverter,
    points: &[Point3<f32>],
    grid: &PixelGrid<'_>,
    origin: &Point3<f32>,
    max_range: Option<f64>,
    out: &mut ScanUpdate,
) -> ScanStats {
    let dda = RayModel::Dda;
    compute_update_clearing_f32(conv, points, 0, Some(grid), origin, max_range, dda, out)
}

#[allow(clippy::too_many_arguments)]
fn compute(
    conv: &KeyConverter,
    points: &[Point3<f32>],
    clear_from: usize,
    grid: Option<&PixelGrid<'_>>,
    origin: &Point3<f32>,
    max_range: Option<f64>,
    model: RayModel,
    out: &mut ScanUpdate,
) -> ScanStats {
    out.clear();
    let mut stats = ScanStats {
        points: points.len(),
        ..ScanStats::default()
    };
    let m = max_range.unwrap_or(-1.0);
    let origin_key = key_of(conv, origin).map(coded);
    let mut plan = std::mem::take(&mut out.work.plan);
    let threads = rayon::current_num_threads();
    let parallel = !out.work.serial && threads > 1 && points.len() >= PARALLEL_MIN_POINTS;
    let skips: Skips<'_> = match grid {
        Some(g)
            if model == RayModel::Dda
                && origin_key.is_some()
                && plan.prepare(g, points.len(), conv.resolution()) =>
        {
            sample_lengths(
                conv, &mut plan, points, g.pixels, origin, origin_key, m, parallel,
            );
            Some((&plan, g.pixels))
        }
        _ => None,
    };
    if parallel {
        // each thread casts a contiguous share of the rays into its own sets; the union is
        // the same set whatever the split, so the output does not depend on the thread count
        out.work.workers.resize_with(threads, Worker::default);
        // the workers take the blocks of points in turn, each the next one not yet taken:
        // a worker that starts late or meets long rays takes fewer, so none waits for
        // another at the end (which worker took a block does not change the union)
        let next = std::sync::atomic::AtomicUsize::new(0);
        let take = || {
            let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            let at = i.checked_mul(PARALLEL_BLOCK)?;
            points
                .get(at..)
                .filter(|rest| !rest.is_empty())
                .map(|rest| (at, &rest[..rest.len().min(PARALLEL_BLOCK)]))
        };
        use rayon::prelude::*;
        out.work.workers.par_iter_mut().for_each(|w| {
            w.free_set.clear();
            w.occ_set.clear();
            w.stats = ScanStats::default();
            while let Some((at, pts)) = take() {
                let block_skips = skips.map(|(plan, pixels)| (plan, &pixels[at..at + pts.len()]));
                add_points(
                    conv,
                    pts,
                    clear_from.saturating_sub(at),
                    block_skips,
                    origin,
                    origin_key,
                    m,
                    &mut w.free_set,
                    &mut w.occ_set,
                    &mut w.ray,
                    &mut w.stats,
                    model,
                );
            }
            // sorted in their own tables: no copy of the sets
            w.free_sorted = w.free_set.sort_in_place();
            w.occ_sorted = w.occ_set.sort_in_place();
        });
        // each worker's sets were sorted on its own thread; merging sorted lists replaces a
        // serial hash union and a sort of the whole frame
        let workers = &out.work.workers[..threads];
        merge_sorted(
            workers
                .iter()
                .map(|w| w.free_set.sorted_front(w.free_sorted)),
            &mut out.bricks,
        );
        merge_sorted(
            workers.iter().map(|w| w.occ_set.sorted_front(w.occ_sorted)),
            &mut out.occ_bricks,
        );
        for w in workers {
            stats.non_finite += w.stats.non_finite;
            stats.outside_map += w.stats.outside_map;
            stats.rays += w.stats.rays;
            stats.failed_rays += w.stats.failed_rays;
            stats.max_range_rays += w.stats.max_range_rays;
            stats.heads_skipped += w.stats.heads_skipped;
        }
        out.work.plan = plan;
        emit(out, &mut stats);
        return stats;
    }
    add_points(
        conv,
        points,
        clear_from,
        skips,
        origin,
        origin_key,
        m,
        &mut out.work.free_set,
        &mut out.work.occ_set,
        &mut out.work.ray,
        &mut stats,
        model,
    );
    out.work.plan = plan;
    if out.work.deferred {
        out.work.pending = Some(stats);
        return stats;
    }
    finish(out, &mut stats);
    stats
}

/// OctoMap's `computeDiscreteUpdate`: [`discretize`](crate::discretize()) the points, then
/// [`compute_update_f32`] on the voxel centres with the same, un-discretized origin (so rays go to
/// centres and `max_range` is measured to the centre). Clears `out` first.
///
/// The `f32` fast path: coordinates as OctoMap's `point3d`;
/// [`crate::compute_discrete_update`] takes `f64`.
pub fn compute_discrete_update_f32(
    conv: &KeyConverter,
    points: &[Point3<f32>],
    origin: &Point3<f32>,
    max_range: Option<f64>,
    out: &mut ScanUpdate,
) -> ScanStats {
    let mut centres = std::mem::take(&mut out.work.centres);
    let mut order = std::mem::take(&mut out.work.order);
    let mut stats = discretize_into(conv, points, &mut centres, &mut order);
    let inner = compute_update_f32(conv, &centres, origin, max_range, out);
    out.work.centres = centres;
    out.work.order = order;
    stats.rays = inner.rays;
    stats.failed_rays = inner.failed_rays;
    stats.max_range_rays = inner.max_range_rays;
    stats.free = inner.free;
    stats.occupied = inner.occupied;
    stats
}

#[cfg(test)]
#[path = "update_tests.rs"]
mod tests;
