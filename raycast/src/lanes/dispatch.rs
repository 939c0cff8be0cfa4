//! The choice of lanes: [`walk_all`] walks a batch of DDA rays and [`walk_lines`] a batch of
//! Bresenham lines with the widest path the CPU has.

use crate::brickset::BrickSink;
use crate::dda::RaySetup;
use octoquant_octree::{Brick, Key};

/// Per-thread buffers of the lane walks, kept from batch to batch.
#[derive(Debug, Clone, Default)]
pub(crate) struct LaneScratch {
    /// The bricks of the walks in progress, one buffer per SSE2 lane (the first also serves
    /// the scalar walk).
    bufs: [Vec<Brick>; 2],
    #[cfg(target_arch = "x86_64")]
    quad: super::avx2::QuadScratch,
    #[cfg(target_arch = "x86_64")]
    oct: super::avx512::OctScratch,
    /// Walks queued from set-up columns ([`queue_setups`]).
    #[cfg(target_arch = "x86_64")]
    queued: super::avx512::QueuedWalks,
}

/// Queue the walks of the first `count` pending rays (all well-conditioned) from `origin`
/// (key and code) straight from their set-ups, for
/// [`walk_queued`]: where the CPU has AVX-512 (eight lanes), whose arrays are filled from the
/// columns without a [`RaySetup`] per ray. `false` (nothing queued) elsewhere, or when walks
/// from another origin are queued: the caller then walks [`crate::setups::Pending::ray`]s.
pub(crate) fn queue_setups(
    scratch: &mut LaneScratch,
    p: &crate::setups::Pending,
    s: &crate::setups::Setups,
    origin: (Key, u64),
    count: usize,
) -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        scratch.queued.queue(p, s, origin, count)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = (scratch, p, s, origin, count);
        false
    }
}

/// Walks queued by [`queue_setups`] and not yet walked.
pub(crate) fn queued(scratch: &LaneScratch) -> usize {
    #[cfg(target_arch = "x86_64")]
    {
        scratch.queued.len()
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = scratch;
        0
    }
}

/// Walk the walks queued by [`queue_setups`] into `flush` and empty the queue; returns how
/// many degenerated (none can: they are well-conditioned).
pub(crate) fn walk_queued<F: BrickSink>(scratch: &mut LaneScratch, flush: &mut F) -> usize {
    #[cfg(target_arch = "x86_64")]
    {
        scratch.queued.walk(&mut scratch.oct, flush)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = (scratch, flush);
        0
    }
}

/// Walk every ray of `rays` (all well-conditioned) and hand each brick the walks enter to
/// `flush` as `(brick, bits)`: eight at a time where the CPU has AVX-512, four with AVX2, two
/// with SSE2, else one after another. Returns how many walks degenerated (none can; they are
/// counted rather than trusted).
pub(crate) fn walk_all<F>(rays: &[RaySetup], scratch: &mut LaneScratch, flush: &mut F) -> usize
where
    F: BrickSink,
{
    #[cfg(target_arch = "x86_64")]
    {
        if let Some(degenerate) = super::avx512::walk_octs(rays, &mut scratch.oct, flush) {
            return degenerate;
        }
        if let Some(degenerate) = super::avx2::walk_quads(rays, &mut scratch.quad, flush) {
            return degenerate;
        }
    }
    walk_pairs_or_each(rays, &mut scratch.bufs, flush)
}

/// The per-thread buffers of the Bresenham lanes, kept from batch to batch.
#[derive(Debug, Clone, Default)]
pub(crate) struct LineScratch {
    #[cfg(target_arch = "x86_64")]
    quad: super::bresenham_avx2::QuadLineScratch,
    #[cfg(target_arch = "x86_64")]
    oct: super::avx512::OctScratch,
}

/// Which way a batch of Bresenham lines was walked.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum LinePath {
    /// One line after another ([`crate::bresenham::walk_bresenham_bricks`]).
    Scalar,
    /// Four at a time ([`crate::lanes::bresenham_avx2`]).
    Avx2,
    /// Eight at a time ([`crate::lanes::bresenham_avx512`]).
    Avx512,
}

/// Walk the Bresenham lines `start -> end` of `lines` and hand each brick they enter to
/// `flush`: eight at a time where the CPU has AVX-512, four with AVX2, else one after another.
/// Lines whose start and end are equal have no voxel. Returns the path taken.
pub(crate) fn walk_lines<F>(
    lines: &[(Key, Key)],
    scratch: &mut LineScratch,
    flush: &mut F,
) -> LinePath
where
    F: BrickSink,
{
    let path = walk_lines_up_to(lines, scratch, flush, widest_line_path());
    #[cfg(test)]
    test_paths::taken(path);
    path
}

/// The widest path [`walk_lines`] may take: all of them, except in tests that ask for less.
#[cfg(not(test))]
#[inline]
fn widest_line_path() -> LinePath {
    LinePath::Avx512
}

/// The widest path [`walk_lines`] may take: all of them, except in tests that ask for less.
#[cfg(test)]
fn widest_line_path() -> LinePath {
    test_paths::widest()
}

/// [`walk_lines`] through the widest path the CPU has, `widest` at most.
#[cfg_attr(not(target_arch = "x86_64"), allow(unused_variables))]
fn walk_lines_up_to<F>(
    lines: &[(Key, Key)],
    scratch: &mut LineScratch,
    flush: &mut F,
    widest: LinePath,
) -> LinePath
where
    F: BrickSink,
{
    #[cfg(target_arch = "x86_64")]
    {
        let nonempty = || lines.iter().copied().filter(|(a, b)| a != b);
        if widest >= LinePath::Avx512 && crate::cpu::has_avx512() {
            // the eight lanes need lines with voxels; most batches have only those
            let done = if lines.iter().all(|(a, b)| a != b) {
                super::bresenham_avx512::walk_lines(lines, &mut scratch.oct, flush)
            } else {
                let kept: Vec<(Key, Key)> = nonempty().collect();
                super::bresenham_avx512::walk_lines(&kept, &mut scratch.oct, flush)
            };
            if done.is_some() {
                return LinePath::Avx512;
            }
        }
        if widest >= LinePath::Avx2
            && super::bresenham_avx2::walk_lines(lines, &mut scratch.quad, flush).is_some()
        {
            return LinePath::Avx2;
        }
    }
    for &(a, b) in lines {
        crate::bresenham::walk_bresenham_bricks(a, b, &mut *flush);
    }
    LinePath::Scalar
}

/// Test hooks of [`walk_lines`]: cap the path it may take on this thread, and count the
/// batches each path walked, so tests can compare the paths and prove which one ran.
#[cfg(test)]
pub(crate) mod test_paths {
    use super::LinePath;
    use std::cell::Cell;

    thread_local! {
        static WIDEST: Cell<LinePath> = const { Cell::new(LinePath::Avx512) };
        static TAKEN: Cell<[usize; 3]> = const { Cell::new([0; 3]) };
    }

    pub(super) fn widest() -> LinePath {
        WIDEST.with(Cell::get)
    }

    pub(super) fn taken(path: LinePath) {
        TAKEN.with(|t| {
            let mut n = t.get();
            n[path as usize] += 1;
            t.set(n);
        });
    }

    /// Run `f` on this thread with [`super::walk_lines`] taking `widest` at most, and return
    /// its result and how many batches each path walked meanwhile (indexed by
    /// `LinePath as usize`).
    pub(crate) fn capped<R>(widest: LinePath, f: impl FnOnce() -> R) -> (R, [usize; 3]) {
        let old = WIDEST.with(|w| w.replace(widest));
        let before = TAKEN.with(Cell::get);
        let r = f();
        let after = TAKEN.with(Cell::get);
        WIDEST.with(|w| w.set(old));
        (r, [0, 1, 2].map(|i| after[i] - before[i]))
    }
}

/// [`walk_all`] without AVX2: two at a time with SSE2, else one after another.
fn walk_pairs_or_each<F>(rays: &[RaySetup], bufs: &mut [Vec<Brick>; 2], flush: &mut F) -> usize
where
    F: BrickSink,
{
    #[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
    {
        super::sse2::walk_pairs(rays, bufs, flush)
    }
    #[cfg(not(all(target_arch = "x86_64", target_feature = "sse2")))]
    {
        super::brick_walk::walk_each(rays, &mut bufs[0], flush)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dda::{key_of, setup_from, walk_ray_codes_f32};
    use crate::lanes::brick_walk::walk_each;
    use nalgebra::Point3;
    use octoquant_octree::KeyConverter;
    use proptest::prelude::*;
    use std::collections::BTreeSet;

    /// The keys of every ray by the reference walk, as a set.
    fn want(conv: &KeyConverter, o: &Point3<f32>, ends: &[Point3<f32>]) -> BTreeSet<u64> {
        let mut s = BTreeSet::new();
        for e in ends {
            walk_ray_codes_f32(conv, o, e, |c| {
                s.insert(c);
            });
        }
        s
    }

    /// Add the voxels of brick `b` to `set`, as Morton codes.
    fn add(set: &mut BTreeSet<u64>, b: Brick) {
        let mut m = b.voxels;
        while m != 0 {
            set.insert((b.code << 6) | m.trailing_zeros() as u64);
            m &= m - 1;
        }
    }

    /// The well-conditioned set-ups of the rays `o -> e`.
    fn setups(conv: &KeyConverter, o: &Point3<f32>, ends: &[Point3<f32>]) -> Vec<RaySetup> {
        let ok = key_of(conv, o);
        ends.iter()
            .filter_map(|e| setup_from(conv, o, ok, e).ok())
            .filter(|r| r.well_conditioned)
            .collect()
    }

    /// The bricks each way of walking a batch hands on, in the order it hands them on:
    /// [`walk_all`] (the fastest path the CPU has), the AVX2 and AVX-512 lanes where the CPU
    /// has them, the SSE2 lanes and [`walk_each`]; none may report a degenerate walk.
    fn all_path_bricks(rays: &[RaySetup]) -> Vec<Vec<Brick>> {
        let mut out = Vec::new();
        let mut scratch = LaneScratch::default();
        let mut v = Vec::new();
        assert_eq!(walk_all(rays, &mut scratch, &mut |b| v.push(b)), 0);
        out.push(v);
        #[cfg(target_arch = "x86_64")]
        {
            let mut v = Vec::new();
            let mut quad = crate::lanes::avx2::QuadScratch::default();
            if let Some(d) = crate::lanes::avx2::walk_quads(rays, &mut quad, &mut |b| v.push(b)) {
                assert_eq!(d, 0);
                out.push(v);
            }
            let mut v = Vec::new();
            let mut oct = crate::lanes::avx512::OctScratch::default();
            if let Some(d) = crate::lanes::avx512::walk_octs(rays, &mut oct, &mut |b| v.push(b)) {
                assert_eq!(d, 0);
                out.push(v);
            }
        }
        let mut v = Vec::new();
        assert_eq!(
            walk_pairs_or_each(rays, &mut scratch.bufs, &mut |b| v.push(b)),
            0
        );
        out.push(v);
        let mut v = Vec::new();
        assert_eq!(walk_each(rays, &mut scratch.bufs[0], &mut |b| v.push(b)), 0);
        out.push(v);
        out
    }

    /// The voxels each way of walking a batch visits ([`all_path_bricks`]), as sets.
    fn all_paths(rays: &[RaySetup]) -> Vec<BTreeSet<u64>> {
        all_path_bricks(rays)
            .into_iter()
            .map(|bricks| {
                let mut s = BTreeSet::new();
                bricks.into_iter().for_each(|b| add(&mut s, b));
                s
            })
            .collect()
    }

    /// Rays whose codes carry a mark above their 48 bits (as `crate::ray_order` marks them):
    /// on every path each brick handed on carries its ray's mark, and a ray's bricks hold
    /// exactly its reference voxels, each once; the only bricks without a mark are the idle
    /// lanes', and they hold the first ray's origin voxel alone.
    #[test]
    fn marked_rays_keep_their_marks_on_every_path() {
        let conv = KeyConverter::new(0.1).unwrap();
        let o = Point3::new(0.03f32, -0.41, 0.17);
        let ends: Vec<Point3<f32>> = (0..45)
            .map(|i| {
                let a = i as f32 * 0.61;
                let r = 0.2 + (i % 7) as f32;
                Point3::new(r * a.cos(), r * a.sin(), 0.3 * (i % 5) as f32 - 0.6)
            })
            .collect();
        let mut rays = setups(&conv, &o, &ends);
        assert_eq!(rays.len(), ends.len());
        for (i, r) in rays.iter_mut().enumerate() {
            let mark = (i as u64 + 1) << 48;
            r.code_origin |= mark;
            r.code_end |= mark;
        }
        let first_origin = key_of(&conv, &o).unwrap().morton();
        for bricks in all_path_bricks(&rays) {
            let mut got = vec![BTreeSet::new(); ends.len() + 1];
            let mut count = vec![0; ends.len() + 1];
            for b in bricks {
                let mark = (b.code >> 42) as usize;
                assert!(mark <= ends.len(), "mark {mark}");
                count[mark] += b.voxels.count_ones() as usize;
                let mut s = BTreeSet::new();
                add(
                    &mut s,
                    Brick {
                        code: b.code & ((1 << 42) - 1),
                        ..b
                    },
                );
                got[mark].extend(s);
            }
            assert!(got[0].iter().all(|&c| c == first_origin), "idle lanes");
            for (i, e) in ends.iter().enumerate() {
                let want = want(&conv, &o, std::slice::from_ref(e));
                assert_eq!(got[i + 1], want, "ray {i}");
                assert_eq!(count[i + 1], want.len(), "ray {i}: a voxel twice");
            }
        }
    }

    /// Rays from a voxel centre to voxel centres cross voxel corners and edges, where the
    /// tie rules decide: every lane must follow them.
    #[test]
    fn lattice_rays_keep_the_tie_rules() {
        let conv = KeyConverter::new(0.1).unwrap();
        let o = Point3::new(0.05f32, 0.05, 0.05);
        let c = |i: i32| i as f32 * 0.1 + 0.05;
        let ends: Vec<Point3<f32>> = (-6..6)
            .flat_map(|i| {
                (-6..6).flat_map(move |j| (-6..6).map(move |k| Point3::new(c(i), c(j), c(k))))
            })
            .collect();
        let want = want(&conv, &o, &ends);
        assert!(want.len() > 1000);
        for got in all_paths(&setups(&conv, &o, &ends)) {
            assert_eq!(got, want);
        }
    }

    /// Rays that stop on their length three steps before the Manhattan distance (the
    /// diagonal across the map through voxel corners, at each resolution), next to rays that
    /// stop on their end voxel: every lane must stop where the reference does, although the
    /// eight lanes skip their end checks until shortly before.
    #[test]
    fn lanes_stop_where_the_reference_stops() {
        for res in [0.01, 0.1, 1.0] {
            let conv = KeyConverter::new(res).unwrap();
            let edge = (32767.0 * res) as f32;
            let o = Point3::new(-edge, -edge, -edge);
            let mut ends = vec![Point3::new(edge, edge, edge)];
            for i in 1..12 {
                let f = edge * (i as f32 / 12.0);
                ends.push(Point3::new(f, f, f));
                ends.push(Point3::new(f, -f * 0.5, f * 0.25));
            }
            let rays = setups(&conv, &o, &ends);
            assert_eq!(rays.len(), ends.len());
            let want = want(&conv, &o, &ends);
            for got in all_paths(&rays) {
                assert_eq!(got, want);
            }
        }
    }

    /// Walks cut off by their budget. Only ill-conditioned rays can run out, and those are
    /// walked one at a time; the scalar and SSE2 walks assert as much in debug builds. The
    /// AVX2 and AVX-512 lanes still handle a walk that runs out (here budgets are shortened on
    /// purpose): each counts one degenerate walk per ray whose budget is below its step count
    /// (its free voxels plus the step into its end voxel) and hands on the reference walk's
    /// first `budget` steps and its origin.
    #[test]
    #[cfg(target_arch = "x86_64")]
    fn lanes_cut_off_by_their_budget_keep_the_reference_voxels() {
        let conv = KeyConverter::new(0.1).unwrap();
        let o = Point3::new(0.03f32, -0.41, 0.17);
        let ends: Vec<Point3<f32>> = (0..37)
            .map(|i| {
                let a = i as f32 * 0.37;
                Point3::new(3.0 * a.cos(), 2.0 * a.sin(), 0.1 * i as f32 - 1.5)
            })
            .collect();
        let mut rays = setups(&conv, &o, &ends);
        assert_eq!(rays.len(), ends.len());
        // the reference: each ray's codes, cut after its first `budget` steps
        let mut want = BTreeSet::new();
        let mut cut = 0;
        for (i, r) in rays.iter_mut().enumerate() {
            let mut codes = Vec::new();
            walk_ray_codes_f32(&conv, &o, &ends[i], |c| codes.push(c));
            if i % 3 != 0 {
                // a walk's last step enters its end voxel (not a free voxel, not in
                // `codes`): a whole walk takes one step more than it has free voxels
                let steps = codes.len() - 1;
                r.budget = (steps / (1 + i % 4)) as u32;
                if (r.budget as usize) <= steps {
                    cut += 1;
                    codes.truncate(r.budget as usize + 1);
                }
            }
            want.extend(codes);
        }
        assert!(cut > 10);
        let mut got = Vec::new();
        let mut s = BTreeSet::new();
        let mut quad = crate::lanes::avx2::QuadScratch::default();
        if let Some(d) = crate::lanes::avx2::walk_quads(&rays, &mut quad, &mut |b| add(&mut s, b)) {
            got.push((d, s));
        }
        let mut s = BTreeSet::new();
        let mut oct = crate::lanes::avx512::OctScratch::default();
        if let Some(d) = crate::lanes::avx512::walk_octs(&rays, &mut oct, &mut |b| add(&mut s, b)) {
            got.push((d, s));
        }
        // every CPU with AVX2 checks at least one path
        assert_eq!(got.is_empty(), !crate::cpu::has_avx2());
        for (d, s) in got {
            assert_eq!(d, cut);
            assert_eq!(s, want);
        }
    }

    proptest! {
        #[test]
        fn batches_visit_the_reference_voxels(
            o in prop::array::uniform3(-3.0f32..3.0),
            ends in prop::collection::vec(prop::array::uniform3(-6.0f32..6.0), 0..40),
            res in prop::sample::select(vec![0.05, 0.1, 0.2]),
        ) {
            let conv = KeyConverter::new(res).unwrap();
            let o = Point3::from(o);
            let ends: Vec<Point3<f32>> = ends.into_iter().map(Point3::from).collect();
            let setups = setups(&conv, &o, &ends);
            let want = want(&conv, &o, &ends);
            for got in all_paths(&setups) {
                prop_assert_eq!(&got, &want);
            }
        }

        /// Walks queued straight from set-up columns ([`queue_setups`], several columns'
        /// worth before one [`walk_queued`] or a walk after each) visit the reference
        /// voxels; a queue takes no rays of another origin; CPUs without the eight lanes
        /// queue nothing.
        #[test]
        fn queued_walks_visit_the_reference_voxels(
            o in prop::array::uniform3(-3.0f32..3.0),
            ends in prop::collection::vec(prop::array::uniform3(-6.0f32..6.0), 0..100),
            res in prop::sample::select(vec![0.05, 0.1, 0.2]),
            walk_each_chunk in any::<bool>(),
        ) {
            use crate::setups::{set_up, Pending, Setups, Shared, PENDING};
            let conv = KeyConverter::new(res).unwrap();
            let o = Point3::from(o);
            let okey = key_of(&conv, &o).unwrap();
            let origin = (okey, okey.morton());
            // the ends whose rays are walked whole, as the scan queues them
            let ends: Vec<Point3<f32>> = ends
                .into_iter()
                .map(Point3::from)
                .filter(|e| setup_from(&conv, &o, Some(okey), e).is_ok_and(|r| r.well_conditioned))
                .collect();
            let want = want(&conv, &o, &ends);
            let shared = Shared::new(&conv, &o, okey, None);
            let (mut scratch, mut got) = (LaneScratch::default(), BTreeSet::new());
            let (mut pending, mut out) = (Pending::default(), Setups::default());
            let mut degenerate = 0;
            let mut queued_any = false;
            for chunk in ends.chunks(PENDING) {
                pending.clear();
                for e in chunk {
                    let k = key_of(&conv, e).unwrap();
                    pending.push(e, (k, k.morton()));
                }
                set_up(&pending, &shared, &mut out);
                let took = queue_setups(&mut scratch, &pending, &out, origin, chunk.len());
                prop_assert_eq!(took, crate::cpu::has_avx512());
                queued_any |= took;
                if walk_each_chunk {
                    degenerate += walk_queued(&mut scratch, &mut |b| add(&mut got, b));
                    prop_assert_eq!(queued(&scratch), 0);
                }
            }
            if queued_any && !walk_each_chunk && !ends.is_empty() {
                // another origin's rays wait until the queue is walked
                let other = Key::new(okey[0] ^ 1, okey[1], okey[2]);
                prop_assert!(!queue_setups(&mut scratch, &pending, &out, (other, other.morton()), 1));
            }
            degenerate += walk_queued(&mut scratch, &mut |b| add(&mut got, b));
            prop_assert_eq!(queued(&scratch), 0);
            prop_assert_eq!(degenerate, 0);
            if crate::cpu::has_avx512() {
                prop_assert_eq!(&got, &want);
            } else {
                prop_assert!(got.is_empty());
            }
        }
    }
}
