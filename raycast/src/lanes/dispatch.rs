//! Many DDA walks at once: the brick walk of [`crate::dda`] for a batch of rays, as many rays
//! side by side as the CPU has lanes for.
//!
//! One walk's axis choice (OctoMap's `tMax` comparison chain) is a three-way branch the
//! predictor misses about one step in two when neighbouring rays differ, and made with masks
//! it is a chain of compare, mask and add that each step waits for. Independent walks in the
//! lanes of one register share those instructions and overlap their chains. [`walk_all`] picks
//! at run time the widest path the CPU has: eight lanes with AVX-512 ([`crate::lanes::avx512`]),
//! four with AVX2 ([`crate::lanes::avx2`]), two with SSE2 (here, through `safe_arch`), or one
//! walk after another. The comparisons, additions and tie rules are OctoMap's, lane by lane,
//! so every walk visits exactly the voxels of [`crate::dda::walk_ray_codes`]; only the order in
//! which bricks reach the set changes, and a set does not depend on it.

use crate::brickset::BrickSink;
pub(crate) use crate::dda::AXIS_MASK;
use crate::dda::{cmin, mirror_mask, RaySetup, RayWalk};

/// Per axis (and a harmless fourth entry): the axis's bits of a Morton code, their
/// complement and the axis's lowest bit; a step up is `((m | !mask) + low) & mask`.
const MASK4: [u64; 4] = [AXIS_MASK[0], AXIS_MASK[1], AXIS_MASK[2], 0];
const NOT_MASK4: [u64; 4] = [!AXIS_MASK[0], !AXIS_MASK[1], !AXIS_MASK[2], 0];
const LOW4: [u64; 4] = [1, 2, 4, 0];

/// One step up on axis `a` (0, 1 or 2) of a Morton code, wrapping within the axis, chosen by
/// table rather than by branch.
#[inline(always)]
fn step_up(m: u64, a: usize) -> u64 {
    let a = a & 3;
    let mask = MASK4[a];
    (((m | NOT_MASK4[a]).wrapping_add(LOW4[a])) & mask) | (m & !mask)
}

/// A walk's mirrored Morton code at its origin, its end's, and the mirror: the Morton bits of
/// the axes stepped downwards (`m ^ flip` is the true code).
#[inline]
pub(crate) fn lane_start(r: &RaySetup) -> (u64, u64, u64) {
    let flip = mirror_mask(r.step.map(|s| s < 0));
    (r.code_origin ^ flip, r.code_end ^ flip, flip)
}

/// Hand the bricks `(bricks[i], bits[i])` left by lanes to `flush`, each run of one brick
/// merged into one call. Neighbouring lanes walk neighbouring rays, so about three brick
/// entries in five repeat the one before; merged first (without a branch), they no longer
/// queue behind each other's update of one table slot.
#[cfg(target_arch = "x86_64")]
#[inline]
pub(crate) fn hand_on_runs<F: BrickSink>(bricks: &mut [u64], bits: &mut [u64], flush: &mut F) {
    let k = merge_runs(bricks, bits);
    flush.put_all(&bricks[..k], &bits[..k]);
}

/// Merge each run of one brick in `(bricks[i], bits[i])` into one entry (the union of its
/// bits), in place at the front, and return how many entries there are then.
#[cfg(target_arch = "x86_64")]
#[inline]
pub(crate) fn merge_runs(bricks: &mut [u64], bits: &mut [u64]) -> usize {
    let n = bricks.len().min(bits.len());
    let (bricks, bits) = (&mut bricks[..n], &mut bits[..n]);
    let (Some(&b0), Some(&m0)) = (bricks.first(), bits.first()) else {
        return 0;
    };
    merge_runs_from(bricks, bits, 1, 0, b0, m0)
}

/// [`merge_runs`] from entry `from` on, with `k` entries merged before it and the run of
/// brick `cb` (bits `cm`) still open.
#[cfg(target_arch = "x86_64")]
#[inline]
pub(crate) fn merge_runs_from(
    bricks: &mut [u64],
    bits: &mut [u64],
    from: usize,
    mut k: usize,
    mut cb: u64,
    mut cm: u64,
) -> usize {
    let n = bricks.len().min(bits.len());
    for i in from..n {
        let (b, m) = (bricks[i], bits[i]);
        let same = b == cb;
        // the open run is written at `k` every time and kept once the next entry differs
        bricks[k] = cb;
        bits[k] = cm;
        k += !same as usize;
        cm = (cm & (same as u64).wrapping_neg()) | m;
        cb = b;
    }
    bricks[k] = cb;
    bits[k] = cm;
    k + 1
}

/// One walk's state as scalars, for starting a SIMD lane on a new ray.
#[cfg(target_arch = "x86_64")]
pub(crate) struct LaneInit {
    pub(crate) t: [f64; 3],
    pub(crate) d: [f64; 3],
    pub(crate) len: f64,
    pub(crate) m: u64,
    pub(crate) end: u64,
    pub(crate) flip: u64,
    pub(crate) budget: i64,
    /// The code of the voxel the walk starts in.
    pub(crate) origin: u64,
}

#[cfg(target_arch = "x86_64")]
impl LaneInit {
    /// The walk of `r` at its origin voxel.
    pub(crate) fn new(r: &RaySetup) -> Self {
        let (m, end, flip) = lane_start(r);
        LaneInit {
            t: r.t_max,
            d: r.t_delta,
            len: r.length,
            m,
            end,
            flip,
            budget: r.budget as i64,
            origin: m ^ flip,
        }
    }

    /// The step at which this walk runs out of budget when it starts after step `now`, as a
    /// countdown from `budget` would (`u64::MAX` for idle lanes, in effect never).
    pub(crate) fn due(&self, now: u64) -> u64 {
        now.saturating_add(self.budget.max(0) as u64)
    }

    /// A lane without a ray: it never moves (its step mask is cleared by `active`), never
    /// ends, and keeps writing `code`, a voxel already recorded.
    pub(crate) fn idle(code: u64) -> Self {
        LaneInit {
            t: [0.0; 3],
            d: [0.0; 3],
            len: f64::INFINITY,
            m: code,
            end: !code,
            flip: 0,
            budget: i64::MAX,
            origin: code,
        }
    }
}

/// The first step at which a walk can stop, given the first step `due` at which one runs out
/// of budget (the Manhattan key distance plus [`crate::dda::STEP_MARGIN`] after its start).
///
/// A walk's key moves by one on one axis per step, so it reaches its end voxel no earlier than
/// the Manhattan distance. Its smallest `tMax` (where it leaves the current voxel) passes the
/// length only when the end point is within float error of that voxel; four steps or more
/// before that distance the voxel is at least two voxels from the end voxel on some axis, so
/// the ray still has a voxel's width of length ahead (the `f32` direction and length err by
/// at most 2 % of a voxel, at the map's edge). A ray along the diagonal through voxel corners
/// does stop three steps early. Until the returned step no lane needs its end checks; one
/// step of margin is kept. Tested in `dda_tests` (every walk) and `lanes` (the diagonals).
#[cfg(target_arch = "x86_64")]
pub(crate) fn first_stop(due: u64) -> u64 {
    due.saturating_sub(crate::dda::STEP_MARGIN as u64 + 4)
}

/// Restart the lanes whose walks stopped at this step (bit `l` of `stopped` for lane `l`) on
/// the next rays of `next`, through `set(lane, state, active)`: a lane's code becomes its new
/// walk's origin voxel, or `idle_code` (a voxel already recorded) when the rays are used up, and
/// `live` counts down. A walk that stopped without being done (bit clear in `done`) ran out of
/// budget: the voxel it just entered is handed to `flush` and it is counted as degenerate.
/// Returns that count.
#[cfg(target_arch = "x86_64")]
#[allow(clippy::too_many_arguments)]
pub(crate) fn restart<F, S>(
    codes: &mut [u64],
    stopped: u32,
    done: u32,
    next: &mut std::slice::Iter<'_, RaySetup>,
    idle_code: u64,
    live: &mut usize,
    flush: &mut F,
    mut set: S,
) -> usize
where
    F: BrickSink,
    S: FnMut(usize, &LaneInit, bool),
{
    let mut degenerate = 0;
    // only the stopped lanes, lowest first: a test of every lane's bit would be a branch
    // the predictor misses whenever neighbouring walks end at different steps
    let mut left = stopped;
    while left != 0 {
        let l = left.trailing_zeros() as usize;
        left &= left - 1;
        let Some(code) = codes.get_mut(l) else {
            break;
        };
        if done & (1 << l) == 0 {
            flush.put(*code >> 6, 1u64 << (*code & 63));
            degenerate += 1;
        }
        match next.next() {
            Some(r) => {
                let s = LaneInit::new(r);
                *code = s.origin;
                set(l, &s, true);
            }
            None => {
                *code = idle_code;
                set(l, &LaneInit::idle(idle_code), false);
                *live -= 1;
            }
        }
    }
    degenerate
}

/// The state of one brick walk between two steps.
///
/// Axes stepped downwards are mirrored (their Morton bits inverted) so that every step is an
/// increment; `m ^ flip` is the true code. Bricks are written to the walk's buffer as the walk
/// leaves them: `(brick, bits)` for the bricks before `n`, and the current one in `brick` and
/// `bits`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BrickWalk {
    m: u64,
    end: u64,
    flip: u64,
    t: [f64; 3],
    d: [f64; 3],
    len: f64,
    brick: u64,
    bits: u64,
    n: usize,
    budget: u32,
}

impl BrickWalk {
    /// The walk of a well-conditioned ray at its origin voxel; `buf` is made long enough for
    /// every brick the walk can enter (one per step, plus the origin's).
    pub(crate) fn start(r: &RaySetup, buf: &mut Vec<(u64, u64)>) -> Self {
        let need = r.budget as usize + 1;
        if buf.len() < need {
            buf.resize(need, (0, 0));
        }
        let (m, end, flip) = lane_start(r);
        BrickWalk {
            m,
            end,
            flip,
            t: r.t_max,
            d: r.t_delta,
            len: r.length,
            brick: (m ^ flip) >> 6,
            bits: 1u64 << ((m ^ flip) & 63),
            n: 0,
            budget: r.budget,
        }
    }

    /// Record the voxel just stepped into, without a branch: the current brick is written at
    /// `n` every time and kept (`n` advanced) only when the walk left it.
    #[inline(always)]
    fn record(&mut self, out: &mut [(u64, u64)]) {
        let code = self.m ^ self.flip;
        let b = code >> 6;
        let moved = b != self.brick;
        if let Some(slot) = out.get_mut(self.n) {
            *slot = (self.brick, self.bits);
        }
        self.n += moved as usize;
        self.bits = (self.bits & (moved as u64).wrapping_sub(1)) | (1u64 << (code & 63));
        self.brick = b;
    }

    /// Write the current brick and return the number of bricks in `out`.
    #[inline(always)]
    fn close(&mut self, out: &mut [(u64, u64)]) -> usize {
        if let Some(slot) = out.get_mut(self.n) {
            *slot = (self.brick, self.bits);
            self.n += 1;
        }
        self.n
    }

    /// Walk to the end one step at a time (OctoMap's comparison chain as branches, which
    /// costs little when the steps are predictable); returns the outcome and the bricks.
    pub(crate) fn finish(&mut self, out: &mut [(u64, u64)]) -> (RayWalk, usize) {
        let [mut t0, mut t1, mut t2] = self.t;
        let [d0, d1, d2] = self.d;
        let mut walk = RayWalk::Degenerate;
        while self.budget > 0 {
            self.budget -= 1;
            let a = if t0 < t1 {
                if t0 < t2 {
                    t0 += d0;
                    0
                } else {
                    t2 += d2;
                    2
                }
            } else if t1 < t2 {
                t1 += d1;
                1
            } else {
                t2 += d2;
                2
            };
            self.m = step_up(self.m, a);
            if self.m == self.end || cmin(cmin(t0, t1), t2) > self.len {
                walk = RayWalk::Complete;
                break;
            }
            self.record(out);
        }
        self.t = [t0, t1, t2];
        debug_assert!(
            walk == RayWalk::Complete,
            "a well-conditioned ray exhausted its budget"
        );
        (walk, self.close(out))
    }

    /// [`BrickWalk::finish`], then hand every brick of the walk to `flush`.
    pub(crate) fn finish_into<F>(&mut self, buf: &mut [(u64, u64)], flush: &mut F) -> RayWalk
    where
        F: BrickSink,
    {
        let (walk, n) = self.finish(buf);
        for &(b, m) in &buf[..n] {
            flush.put(b, m);
        }
        walk
    }
}

/// Per-thread buffers of the lane walks, kept from batch to batch.
#[derive(Debug, Clone, Default)]
pub(crate) struct LaneScratch {
    /// The bricks of the walks in progress, one buffer per SSE2 lane (the first also serves
    /// the scalar walk).
    bufs: [Vec<(u64, u64)>; 2],
    #[cfg(target_arch = "x86_64")]
    quad: crate::lanes::avx2::QuadScratch,
    #[cfg(target_arch = "x86_64")]
    oct: crate::lanes::avx512::OctScratch,
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
        if let Some(degenerate) = crate::lanes::avx512::walk_octs(rays, &mut scratch.oct, flush) {
            return degenerate;
        }
        if let Some(degenerate) = crate::lanes::avx2::walk_quads(rays, &mut scratch.quad, flush) {
            return degenerate;
        }
    }
    walk_pairs_or_each(rays, &mut scratch.bufs, flush)
}

/// [`walk_all`] without AVX2: two at a time with SSE2, else one after another.
fn walk_pairs_or_each<F>(rays: &[RaySetup], bufs: &mut [Vec<(u64, u64)>; 2], flush: &mut F) -> usize
where
    F: BrickSink,
{
    #[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
    {
        sse2::walk_pairs(rays, bufs, flush)
    }
    #[cfg(not(all(target_arch = "x86_64", target_feature = "sse2")))]
    {
        walk_each(rays, &mut bufs[0], flush)
    }
}

/// [`walk_all`] one ray after another: the path of targets without SSE2, and of batches of
/// fewer than two rays.
fn walk_each<F>(rays: &[RaySetup], buf: &mut Vec<(u64, u64)>, flush: &mut F) -> usize
where
    F: BrickSink,
{
    rays.iter()
        .filter(|r| BrickWalk::start(r, buf).finish_into(buf, flush) != RayWalk::Complete)
        .count()
}

#[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
mod sse2 {
    use super::{step_up, walk_each, BrickSink, BrickWalk};
    use crate::dda::{RaySetup, RayWalk};
    use safe_arch::{
        add_m128d, bitand_m128d, bitandnot_m128d, bitor_m128d, cmp_eq_mask_m128d,
        cmp_gt_mask_m128d, cmp_lt_mask_m128d, m128d, min_m128d, move_mask_m128d,
    };

    /// The lanes' `tMax` of one axis as a register.
    #[inline(always)]
    fn lanes(a: &BrickWalk, b: &BrickWalk, f: impl Fn(&BrickWalk) -> f64) -> m128d {
        m128d::from_array([f(a), f(b)])
    }

    /// [`super::walk_all`] with two walks in the lanes of each register. A lane whose walk
    /// ends is flushed and refilled with the next ray; the last walk finishes alone.
    pub(super) fn walk_pairs<F>(
        rays: &[RaySetup],
        bufs: &mut [Vec<(u64, u64)>; 2],
        flush: &mut F,
    ) -> usize
    where
        F: BrickSink,
    {
        let mut degenerate = 0;
        let mut next = rays.iter();
        let (Some(ra), Some(rb)) = (next.next(), next.next()) else {
            return walk_each(rays, &mut bufs[0], flush);
        };
        let [buf0, buf1] = bufs;
        let mut w = [BrickWalk::start(ra, buf0), BrickWalk::start(rb, buf1)];
        loop {
            let mut t0 = lanes(&w[0], &w[1], |x| x.t[0]);
            let mut t1 = lanes(&w[0], &w[1], |x| x.t[1]);
            let mut t2 = lanes(&w[0], &w[1], |x| x.t[2]);
            let d0 = lanes(&w[0], &w[1], |x| x.d[0]);
            let d1 = lanes(&w[0], &w[1], |x| x.d[1]);
            let d2 = lanes(&w[0], &w[1], |x| x.d[2]);
            let len = lanes(&w[0], &w[1], |x| x.len);
            // all bits set: x == x for the finite lengths of well-conditioned rays
            let ones = cmp_eq_mask_m128d(len, len);
            // the walks' integer state in locals (kept in registers); both lanes step
            // together, so one counter stands for the smaller budget
            let [mut a, mut b] = w;
            let steps = a.budget.min(b.budget);
            let mut left = steps;
            let ended = loop {
                // OctoMap's chain per lane: x when t0 < t1 and t0 < t2, else y when t1 < t2,
                // else z (ties to z, then y)
                let lt01 = cmp_lt_mask_m128d(t0, t1);
                let s0 = bitand_m128d(lt01, cmp_lt_mask_m128d(t0, t2));
                let s1 = bitandnot_m128d(lt01, cmp_lt_mask_m128d(t1, t2));
                let s2 = bitandnot_m128d(bitor_m128d(s0, s1), ones);
                t0 = add_m128d(t0, bitand_m128d(s0, d0));
                t1 = add_m128d(t1, bitand_m128d(s1, d1));
                t2 = add_m128d(t2, bitand_m128d(s2, d2));
                let a1 = move_mask_m128d(s1) as usize;
                let a2 = move_mask_m128d(s2) as usize;
                a.m = step_up(a.m, (a1 & 1) | ((a2 & 1) << 1));
                b.m = step_up(b.m, (a1 >> 1) | (a2 & 2));
                left -= 1;
                // the smallest tMax beyond the length, per lane (no lane holds a NaN)
                let past =
                    move_mask_m128d(cmp_gt_mask_m128d(min_m128d(min_m128d(t0, t1), t2), len));
                let e0 = (a.m == a.end) | (past & 1 != 0);
                let e1 = (b.m == b.end) | (past & 2 != 0);
                if e0 | e1 | (left == 0) {
                    break [e0, e1];
                }
                a.record(buf0);
                b.record(buf1);
            };
            a.budget -= steps - left;
            b.budget -= steps - left;
            w = [a, b];
            let [x0, x1] = [t0.to_array(), t1.to_array()];
            let x2 = t2.to_array();
            let mut live = [true, true];
            for (l, (walk, buf)) in w.iter_mut().zip([&mut *buf0, &mut *buf1]).enumerate() {
                walk.t = [x0[l], x1[l], x2[l]];
                if !ended[l] {
                    walk.record(buf);
                    if walk.budget > 0 {
                        continue;
                    }
                    debug_assert!(false, "a well-conditioned ray exhausted its budget");
                    degenerate += 1;
                }
                let n = walk.close(buf);
                for &(b, m) in &buf[..n] {
                    flush.put(b, m);
                }
                match next.next() {
                    Some(r) => *walk = BrickWalk::start(r, buf),
                    None => live[l] = false,
                }
            }
            match live {
                [true, true] => continue,
                [false, false] => return degenerate,
                _ => {
                    // the rays are used up: the remaining walk ends alone
                    let l = if live[0] { 0 } else { 1 };
                    let buf = if l == 0 { &mut *buf0 } else { &mut *buf1 };
                    let walk = w[l].finish_into(buf, flush);
                    return degenerate + (walk != RayWalk::Complete) as usize;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dda::{key_of, setup_from, walk_ray_codes};
    use nalgebra::Point3;
    use octoquant_octree::KeyConverter;
    use proptest::prelude::*;
    use std::collections::BTreeSet;

    /// The keys of every ray by the reference walk, as a set.
    fn want(conv: &KeyConverter, o: &Point3<f32>, ends: &[Point3<f32>]) -> BTreeSet<u64> {
        let mut s = BTreeSet::new();
        for e in ends {
            walk_ray_codes(conv, o, e, |c| {
                s.insert(c);
            });
        }
        s
    }

    /// The well-conditioned set-ups of the rays `o -> e`.
    fn setups(conv: &KeyConverter, o: &Point3<f32>, ends: &[Point3<f32>]) -> Vec<RaySetup> {
        let ok = key_of(conv, o);
        ends.iter()
            .filter_map(|e| setup_from(conv, o, ok, e).ok())
            .filter(|r| r.well_conditioned)
            .collect()
    }

    /// The voxels each way of walking a batch visits, as sets: [`walk_all`] (the fastest path
    /// the CPU has), the AVX2 and AVX-512 lanes where the CPU has them, the SSE2 lanes and
    /// [`walk_each`];
    /// none may report a degenerate walk.
    fn all_paths(rays: &[RaySetup]) -> Vec<BTreeSet<u64>> {
        fn add(set: &mut BTreeSet<u64>, b: u64, mut m: u64) {
            while m != 0 {
                set.insert((b << 6) | m.trailing_zeros() as u64);
                m &= m - 1;
            }
        }
        let mut sets = Vec::new();
        let mut scratch = LaneScratch::default();
        let mut s = BTreeSet::new();
        assert_eq!(
            walk_all(rays, &mut scratch, &mut |b, m| add(&mut s, b, m)),
            0
        );
        sets.push(s);
        #[cfg(target_arch = "x86_64")]
        {
            let mut s = BTreeSet::new();
            let mut quad = crate::lanes::avx2::QuadScratch::default();
            if let Some(d) =
                crate::lanes::avx2::walk_quads(rays, &mut quad, &mut |b, m| add(&mut s, b, m))
            {
                assert_eq!(d, 0);
                sets.push(s);
            }
            let mut s = BTreeSet::new();
            let mut oct = crate::lanes::avx512::OctScratch::default();
            if let Some(d) =
                crate::lanes::avx512::walk_octs(rays, &mut oct, &mut |b, m| add(&mut s, b, m))
            {
                assert_eq!(d, 0);
                sets.push(s);
            }
        }
        let mut s = BTreeSet::new();
        assert_eq!(
            walk_pairs_or_each(rays, &mut scratch.bufs, &mut |b, m| add(&mut s, b, m)),
            0
        );
        sets.push(s);
        let mut s = BTreeSet::new();
        assert_eq!(
            walk_each(rays, &mut scratch.bufs[0], &mut |b, m| add(&mut s, b, m)),
            0
        );
        sets.push(s);
        sets
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

    proptest! {
        /// Merging runs keeps every brick's voxels and leaves no run of one brick.
        #[test]
        #[cfg(target_arch = "x86_64")]
        fn merged_runs_keep_every_voxel(
            entries in prop::collection::vec((0u64..4, any::<u64>()), 0..60),
        ) {
            let (mut bricks, mut bits): (Vec<u64>, Vec<u64>) = entries.iter().copied().unzip();
            let mut got = Vec::new();
            hand_on_runs(&mut bricks, &mut bits, &mut |b, m| got.push((b, m)));
            prop_assert!(got.windows(2).all(|w| w[0].0 != w[1].0));
            let union = |v: &[(u64, u64)]| {
                let mut u = std::collections::BTreeMap::new();
                for &(b, m) in v {
                    *u.entry(b).or_insert(0u64) |= m;
                }
                u
            };
            prop_assert_eq!(union(&got), union(&entries));
            let runs = 1 + entries.windows(2).filter(|w| w[0].0 != w[1].0).count();
            prop_assert_eq!(got.len(), if entries.is_empty() { 0 } else { runs });
        }
    }

    proptest! {
        /// The eight-lane merge gives the scalar merge's entries, in order.
        #[test]
        #[cfg(target_arch = "x86_64")]
        fn wide_merge_matches_the_scalar_merge(
            entries in prop::collection::vec((0u64..3, any::<u64>()), 0..80),
        ) {
            let (mut b1, mut m1): (Vec<u64>, Vec<u64>) = entries.iter().copied().unzip();
            let (mut b2, mut m2) = (b1.clone(), m1.clone());
            let k1 = merge_runs(&mut b1, &mut m1);
            match crate::lanes::avx512::merge_runs_wide(&mut b2, &mut m2) {
                Some(k2) => {
                    prop_assert_eq!(k2, k1);
                    prop_assert_eq!(&b2[..k2], &b1[..k1]);
                    prop_assert_eq!(&m2[..k2], &m1[..k1]);
                }
                None => prop_assert!(!crate::cpu::has_avx512()),
            }
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
    }
}
