//! Four DDA brick walks at once in the 256-bit registers of AVX2, chosen at run time.
//!
//! Each step is done for four rays with one instruction per operation: OctoMap's `tMax`
//! comparison chain as compare masks (as in the SSE2 lanes of [`crate::lanes`]), with the sums
//! made beside the comparisons and picked by mask so that the chain carried from step to step
//! stays short; the step of the mirrored Morton code as integer masks (the chosen axis's bits
//! and their lowest bit); the end tests; and the brick bookkeeping. Each lane's open brick and
//! the voxels met in it stay in registers; the bricks the lanes leave at a step are moved to
//! the front of a register by a permutation looked up by the set of lanes, appended with one
//! store, and handed on to the brick set in batches.
//!
//! A lane whose walk ends starts the next ray in the same step, its origin voxel standing in
//! for the step's voxel (a walk's first voxel is free too); when the rays run out, the lane
//! idles on a voxel already recorded. Only the steps where walks end take a branch.
//!
//! The comparisons, additions and tie rules are OctoMap's, lane by lane, so every walk visits
//! exactly the voxels of [`crate::dda::walk_ray_codes_f32`]. The module's one `unsafe` is the call
//! into [`walk_quads_avx2`] after the run-time check for AVX2.

use super::refill::{first_stop, restart, LaneInit, VOXEL_CODE};
use crate::brickset::BrickSink;
use crate::dda::{RaySetup, AXIS_MASK};
use core::arch::x86_64::{
    __m256d, __m256i, _mm256_add_epi64, _mm256_add_pd, _mm256_and_pd, _mm256_and_si256,
    _mm256_andnot_pd, _mm256_andnot_si256, _mm256_blendv_epi8, _mm256_blendv_pd,
    _mm256_castpd_si256, _mm256_castsi256_pd, _mm256_cmp_pd, _mm256_cmpeq_epi64, _mm256_min_pd,
    _mm256_movemask_pd, _mm256_or_pd, _mm256_or_si256, _mm256_permutevar8x32_epi32,
    _mm256_set1_epi64x, _mm256_set1_pd, _mm256_setzero_si256, _mm256_sllv_epi64, _mm256_srli_epi64,
    _mm256_sub_epi64, _mm256_xor_si256, _CMP_GT_OQ, _CMP_LT_OQ,
};
use octoquant_octree::Brick;

/// Bricks left by the lanes that are collected before they are handed on.
const LEFT: usize = 1024;

/// The per-thread buffers of the four-lane walk, kept from batch to batch: the bricks the
/// lanes left and their voxels, side by side, with room for one more step's four.
#[derive(Debug, Clone)]
pub(crate) struct QuadScratch {
    bricks: Vec<u64>,
    bits: Vec<u64>,
}

impl Default for QuadScratch {
    fn default() -> Self {
        QuadScratch {
            bricks: vec![0; LEFT + 4],
            bits: vec![0; LEFT + 4],
        }
    }
}

/// For each set of lanes (bit `l` for lane `l`), the 32-bit lane indices that move those
/// 64-bit lanes to the front, in order, and their number. Shared with the Bresenham lanes
/// ([`crate::lanes::bresenham_avx2`]).
pub(super) static COMPRESS: [([u32; 8], usize); 16] = {
    let mut t = [([0u32; 8], 0usize); 16];
    let mut set = 0;
    while set < 16 {
        let mut k = 0;
        let mut l = 0;
        while l < 4 {
            if set & (1 << l) != 0 {
                t[set].0[2 * k] = 2 * l as u32;
                t[set].0[2 * k + 1] = 2 * l as u32 + 1;
                k += 1;
            }
            l += 1;
        }
        t[set].1 = k;
        set += 1;
    }
    t
};

/// Walk `rays` four at a time when this CPU has AVX2 and return the number of degenerate walks,
/// or `None` (nothing done) on CPUs without it.
pub(crate) fn walk_quads<F>(
    rays: &[RaySetup],
    scratch: &mut QuadScratch,
    flush: &mut F,
) -> Option<usize>
where
    F: BrickSink,
{
    if !crate::cpu::has_avx2() {
        return None;
    }
    // SAFETY: `walk_quads_avx2` needs AVX2 (and the AVX it implies), and the CPU has been
    // found to support AVX2 just above. Nothing else in it is unsafe.
    #[allow(unsafe_code)]
    let degenerate = unsafe { walk_quads_avx2(rays, scratch, flush) };
    Some(degenerate)
}

/// The four lanes' registers.
struct Lanes {
    t: [__m256d; 3],
    d: [__m256d; 3],
    len: __m256d,
    m: __m256i,
    end: __m256i,
    flip: __m256i,
    /// The step at which each lane's walk runs out of budget (`u64::MAX`: never).
    due: __m256i,
    /// All ones in a lane that walks a ray, zero in an idle lane.
    active: __m256i,
}

type U4 = [u64; 4];

impl Lanes {
    /// Overwrite lane `l` with `s` (once per walk, at step `now`), by blending broadcasts
    /// under the lane's mask `lane[l]` (all ones in lane `l` only).
    #[target_feature(enable = "avx2")]
    fn set(&mut self, lane: &[__m256i; 4], l: usize, s: &LaneInit, active: bool, now: u64) {
        let mi = lane[l & 3];
        let mf = _mm256_castsi256_pd(mi);
        let put_f = |v: &mut __m256d, x: f64| *v = _mm256_blendv_pd(*v, _mm256_set1_pd(x), mf);
        let put_u =
            |v: &mut __m256i, x: u64| *v = _mm256_blendv_epi8(*v, _mm256_set1_epi64x(x as i64), mi);
        for i in 0..3 {
            put_f(&mut self.t[i], s.t[i]);
            put_f(&mut self.d[i], s.d[i]);
        }
        put_f(&mut self.len, s.len);
        put_u(&mut self.m, s.m);
        put_u(&mut self.end, s.end);
        put_u(&mut self.flip, s.flip);
        put_u(&mut self.due, s.due(now));
        put_u(&mut self.active, if active { u64::MAX } else { 0 });
    }

    /// The first step at which some lane runs out of budget.
    fn next_due(&self) -> u64 {
        let due: U4 = bytemuck::cast(self.due);
        due.into_iter().min().unwrap_or(u64::MAX)
    }
}

/// [`walk_quads`] once AVX2 is known to be there.
#[target_feature(enable = "avx2")]
fn walk_quads_avx2<F>(rays: &[RaySetup], scratch: &mut QuadScratch, flush: &mut F) -> usize
where
    F: BrickSink,
{
    let Some(first) = rays.first() else {
        return 0;
    };
    let mut next = rays.iter();
    let zero_f = _mm256_set1_pd(0.0);
    let zero_i = _mm256_setzero_si256();
    let mut q = Lanes {
        t: [zero_f; 3],
        d: [zero_f; 3],
        len: zero_f,
        m: zero_i,
        end: zero_i,
        flip: zero_i,
        due: zero_i,
        active: zero_i,
    };
    // idle lanes repeat the first walk's origin voxel, which is recorded
    let idle_code = LaneInit::new(first).origin & VOXEL_CODE;
    let lane: [__m256i; 4] = core::array::from_fn(|l| {
        bytemuck::cast(core::array::from_fn::<u64, 4, _>(|k| {
            if k == l {
                u64::MAX
            } else {
                0
            }
        }))
    });
    let mut first_code = [idle_code; 4];
    let mut live = 4;
    // the steps taken so far; each lane's budget is the step it runs out at (`LaneInit::due`)
    let mut now = 0u64;
    restart(
        &mut first_code,
        0xF,
        0xF,
        &mut next,
        idle_code,
        &mut live,
        flush,
        |l, s, a| q.set(&lane, l, s, a, 0),
    );
    let mut due = q.next_due();
    let mut near = first_stop(due);
    let ones_f = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
    let ones_i = _mm256_set1_epi64x(-1);
    let one = _mm256_set1_epi64x(1);
    let axis = AXIS_MASK.map(|m| _mm256_set1_epi64x(m as i64));
    let [mut t0, mut t1, mut t2] = q.t;
    // each lane's open brick and the voxels met in it, starting with its origin voxel
    let c63 = _mm256_set1_epi64x(63);
    let first: __m256i = bytemuck::cast(first_code);
    let mut brick = _mm256_srli_epi64::<6>(first);
    let mut bits = _mm256_sllv_epi64(one, _mm256_and_si256(first, c63));
    let mut degenerate = 0;
    let mut left = 0;
    loop {
        now += 1;
        let [d0, d1, d2] = q.d;
        // OctoMap's chain per lane: x when t0 < t1 and t0 < t2, else y when t1 < t2, else z;
        // the sums are made beside the comparisons and picked by mask, which keeps the chain
        // that carries `tMax` from step to step short
        let (n0, n1, n2) = (
            _mm256_add_pd(t0, d0),
            _mm256_add_pd(t1, d1),
            _mm256_add_pd(t2, d2),
        );
        let lt01 = _mm256_cmp_pd::<_CMP_LT_OQ>(t0, t1);
        let s0 = _mm256_and_pd(lt01, _mm256_cmp_pd::<_CMP_LT_OQ>(t0, t2));
        let s1 = _mm256_andnot_pd(lt01, _mm256_cmp_pd::<_CMP_LT_OQ>(t1, t2));
        let s01 = _mm256_or_pd(s0, s1);
        let s2 = _mm256_andnot_pd(s01, ones_f);
        t0 = _mm256_or_pd(_mm256_and_pd(s0, n0), _mm256_andnot_pd(s0, t0));
        t1 = _mm256_or_pd(_mm256_and_pd(s1, n1), _mm256_andnot_pd(s1, t1));
        t2 = _mm256_or_pd(_mm256_andnot_pd(s01, n2), _mm256_and_pd(s01, t2));
        // the chosen axis's Morton bits, and their lowest bit: a step up is
        // `((m | !mask) + low) & mask` on those bits, the others kept
        let mask = _mm256_and_si256(
            q.active,
            _mm256_or_si256(
                _mm256_or_si256(
                    _mm256_and_si256(_mm256_castpd_si256(s0), axis[0]),
                    _mm256_and_si256(_mm256_castpd_si256(s1), axis[1]),
                ),
                _mm256_and_si256(_mm256_castpd_si256(s2), axis[2]),
            ),
        );
        let low = _mm256_and_si256(mask, _mm256_sub_epi64(zero_i, mask));
        let up = _mm256_add_epi64(_mm256_or_si256(q.m, _mm256_xor_si256(mask, ones_i)), low);
        q.m = _mm256_or_si256(_mm256_and_si256(up, mask), _mm256_andnot_si256(mask, q.m));
        let mut codes = _mm256_xor_si256(q.m, q.flip);
        let mut finished = false;
        // no walk can stop before step `near` (see `first_stop`)
        if now >= near {
            // a walk is over on its end voxel or once the smallest tMax passes the length (no
            // lane holds a NaN); it is cut off (degenerate) when its budget runs out
            let tmin = _mm256_min_pd(_mm256_min_pd(t0, t1), t2);
            let done = _mm256_or_pd(
                _mm256_castsi256_pd(_mm256_cmpeq_epi64(q.m, q.end)),
                _mm256_cmp_pd::<_CMP_GT_OQ>(tmin, q.len),
            );
            let out_of_budget = _mm256_cmpeq_epi64(q.due, _mm256_set1_epi64x(now as i64));
            let stopped =
                _mm256_movemask_pd(_mm256_or_pd(done, _mm256_castsi256_pd(out_of_budget)));
            if stopped != 0 {
                // the rare step where walks end: restart those lanes on the next rays
                let done = _mm256_movemask_pd(done);
                let mut written: U4 = bytemuck::cast(codes);
                q.t = [t0, t1, t2];
                degenerate += restart(
                    &mut written,
                    stopped as u32,
                    done as u32,
                    &mut next,
                    idle_code,
                    &mut live,
                    flush,
                    |l, s, a| q.set(&lane, l, s, a, now),
                );
                due = q.next_due();
                near = first_stop(due);
                [t0, t1, t2] = q.t;
                codes = bytemuck::cast(written);
                finished = live == 0;
            }
        }
        // the voxel entered joins its lane's open brick, or the lane leaves that brick,
        // which is appended to the bricks left (the lanes that left moved to the front)
        let b = _mm256_srli_epi64::<6>(codes);
        let same = _mm256_cmpeq_epi64(b, brick);
        let (order, count) =
            COMPRESS[(_mm256_movemask_pd(_mm256_castsi256_pd(same)) ^ 0xF) as usize];
        let order: __m256i = bytemuck::cast(order);
        let left_b: U4 = bytemuck::cast(_mm256_permutevar8x32_epi32(brick, order));
        let left_m: U4 = bytemuck::cast(_mm256_permutevar8x32_epi32(bits, order));
        if let (Some(db), Some(dm)) = (
            scratch.bricks.get_mut(left..left + 4),
            scratch.bits.get_mut(left..left + 4),
        ) {
            db.copy_from_slice(&left_b);
            dm.copy_from_slice(&left_m);
        }
        left += count;
        bits = _mm256_or_si256(
            _mm256_and_si256(bits, same),
            _mm256_sllv_epi64(one, _mm256_and_si256(codes, c63)),
        );
        brick = b;
        if finished || left >= LEFT {
            flush.put_all(&scratch.bricks[..left], &scratch.bits[..left]);
            left = 0;
        }
        if finished {
            let (brick, bits): (U4, U4) = (bytemuck::cast(brick), bytemuck::cast(bits));
            for (code, voxels) in brick.into_iter().zip(bits) {
                flush.put(Brick { code, voxels });
            }
            return degenerate;
        }
    }
}
