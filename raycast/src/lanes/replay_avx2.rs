//! The replay of the skipped heads of depth-image rays four at a time in the 256-bit registers
//! of AVX2, on CPUs without AVX-512 (where [`super::replay_avx512`] takes eight): each ray's
//! DDA state at the end of its head (see [`crate::pixel_grid`]), with the very `f64` additions
//! of the walk one ray at a time.
//!
//! The same two phases as the AVX-512 replay, lane for lane: the steps inside the 3x3x3 block
//! around the origin voxel with the DDA's comparisons, then each axis's `tMax` additions, first
//! the ones surely made (no compare on the chain) and then the rest while below the stop.
//! AVX2 has no mask registers, so a lane that must not add keeps its value by a blend (never by
//! adding zero, which would turn −0 into +0); and with sixteen registers the axes are replayed
//! one after the other (their chains are independent), four groups of four rays side by side.

use super::replay_batch::{Axes, REPLAY_RAYS};
use core::arch::x86_64::{
    __m256d, __m256i, _mm256_add_pd, _mm256_and_pd, _mm256_and_si256, _mm256_andnot_pd,
    _mm256_blendv_pd, _mm256_castpd_si256, _mm256_cmp_pd, _mm256_cvtepi32_epi64,
    _mm256_cvtpd_epi32, _mm256_div_pd, _mm256_loadu_pd, _mm256_max_pd, _mm256_min_pd,
    _mm256_movemask_pd, _mm256_mul_pd, _mm256_or_pd, _mm256_or_si256, _mm256_round_pd,
    _mm256_set1_epi64x, _mm256_set1_pd, _mm256_setzero_pd, _mm256_setzero_si256, _mm256_sllv_epi64,
    _mm256_storeu_pd, _mm256_storeu_si256, _mm256_sub_pd, _CMP_GT_OQ, _CMP_LE_OQ, _CMP_LT_OQ,
    _CMP_ORD_Q, _MM_FROUND_NO_EXC, _MM_FROUND_TO_POS_INF,
};

/// Groups of four rays.
const G: usize = REPLAY_RAYS / 4;

/// [`super::replay::replay_rays`] with AVX2 (the caller checked that the CPU has it).
#[target_feature(enable = "avx2")]
pub(super) fn replay_avx2(
    t: &mut Axes,
    d: &Axes,
    step: &Axes,
    until: &[f64; REPLAY_RAYS],
    n: &mut Axes,
) -> u32 {
    // SAFETY (every load and store below): the pointer is to four consecutive `f64` of an
    // array of sixteen, at offset 0, 4, 8 or 12 (`g < G`).
    #[allow(unsafe_code)]
    let load = |v: &[f64; REPLAY_RAYS], g: usize| unsafe { _mm256_loadu_pd(v[4 * g..].as_ptr()) };
    #[allow(unsafe_code)]
    let store = |v: &mut [f64; REPLAY_RAYS], g: usize, x: __m256d| unsafe {
        _mm256_storeu_pd(v[4 * g..].as_mut_ptr(), x)
    };
    let stop: [__m256d; G] = std::array::from_fn(|g| load(until, g));
    let zero = _mm256_setzero_pd();
    let one = _mm256_set1_pd(1.0);
    let sign = _mm256_set1_pd(-0.0);
    // lane masks are all ones or all zeros: the near bits are kept with an `and`
    let keep = |m: __m256d, v: __m256i| _mm256_and_si256(_mm256_castpd_si256(m), v);
    let mut near = _mm256_setzero_si256();
    for (g, &stop) in stop.iter().enumerate() {
        let st = [0, 1, 2].map(|a| load(&step[a], g));
        let dd = [0, 1, 2].map(|a| load(&d[a], g));
        let mut tt = [0, 1, 2].map(|a| load(&t[a], g));
        let mut off = [zero; 3];
        let mut alive = _mm256_cmp_pd::<_CMP_LT_OQ>(_mm256_set1_pd(f64::NEG_INFINITY), stop);
        near = _mm256_or_si256(near, keep(alive, _mm256_set1_epi64x(1 << 13)));
        // the steps inside the block: at most three, as the fourth leaves it
        for _ in 0..3 {
            let m01 = _mm256_cmp_pd::<_CMP_LT_OQ>(tt[0], tt[1]);
            let m02 = _mm256_cmp_pd::<_CMP_LT_OQ>(tt[0], tt[2]);
            let m12 = _mm256_cmp_pd::<_CMP_LT_OQ>(tt[1], tt[2]);
            // ties go to z over y over x, as the DDA's comparison chain
            let s0 = _mm256_and_pd(m01, m02);
            let s1 = _mm256_andnot_pd(m01, m12);
            let s2 = _mm256_andnot_pd(_mm256_or_pd(s0, s1), _mm256_cmp_pd::<_CMP_ORD_Q>(one, one));
            let tmin = _mm256_blendv_pd(_mm256_blendv_pd(tt[2], tt[1], s1), tt[0], s0);
            let go = _mm256_and_pd(alive, _mm256_cmp_pd::<_CMP_LT_OQ>(tmin, stop));
            for (a, s) in [s0, s1, s2].into_iter().enumerate() {
                let m = _mm256_and_pd(s, go);
                off[a] = _mm256_blendv_pd(off[a], _mm256_add_pd(off[a], st[a]), m);
                tt[a] = _mm256_blendv_pd(tt[a], _mm256_add_pd(tt[a], dd[a]), m);
            }
            let inside = off.map(|o| _mm256_cmp_pd::<_CMP_LE_OQ>(_mm256_andnot_pd(sign, o), one));
            alive = _mm256_and_pd(
                go,
                _mm256_and_pd(inside[0], _mm256_and_pd(inside[1], inside[2])),
            );
            // bit 9·(dz+1) + 3·(dy+1) + (dx+1), a whole number in f64 (exact), then shifted in
            let bit = _mm256_add_pd(
                _mm256_mul_pd(off[2], _mm256_set1_pd(9.0)),
                _mm256_add_pd(
                    _mm256_mul_pd(off[1], _mm256_set1_pd(3.0)),
                    _mm256_add_pd(off[0], _mm256_set1_pd(13.0)),
                ),
            );
            let bit = _mm256_cvtepi32_epi64(_mm256_cvtpd_epi32(bit));
            let shifted = _mm256_sllv_epi64(_mm256_set1_epi64x(1), bit);
            near = _mm256_or_si256(near, keep(alive, shifted));
        }
    }
    for a in 0..3 {
        let mut x: [__m256d; G] = std::array::from_fn(|g| load(&t[a], g));
        let dd: [__m256d; G] = std::array::from_fn(|g| load(&d[a], g));
        // Phase one, without a compare on the chain: `ceil((until − t)/d) − 2` additions,
        // which the plain loop surely makes (that many leave `t` a step below `until`, since
        // the additions' rounding stays far below a step). Clamped to [0, 2^20]; NaN (from
        // infinite or huge values) counts as none.
        let mut sure = [zero; G];
        let mut most = 0.0f64;
        for g in 0..G {
            let est = _mm256_round_pd::<{ _MM_FROUND_TO_POS_INF | _MM_FROUND_NO_EXC }>(
                _mm256_div_pd(_mm256_sub_pd(stop[g], x[g]), dd[g]),
            );
            let est = _mm256_min_pd(
                _mm256_max_pd(_mm256_sub_pd(est, _mm256_set1_pd(2.0)), zero),
                _mm256_set1_pd((1u64 << 20) as f64),
            );
            sure[g] = _mm256_and_pd(_mm256_cmp_pd::<_CMP_ORD_Q>(est, est), est);
            let mut lanes = [0.0; 4];
            // SAFETY: four `f64` into an array of four.
            #[allow(unsafe_code)]
            unsafe {
                _mm256_storeu_pd(lanes.as_mut_ptr(), sure[g])
            };
            most = lanes.iter().fold(most, |m, &v| m.max(v));
        }
        let mut j = zero;
        for _ in 0..most as u64 {
            for g in 0..G {
                let m = _mm256_cmp_pd::<_CMP_GT_OQ>(sure[g], j);
                x[g] = _mm256_blendv_pd(x[g], _mm256_add_pd(x[g], dd[g]), m);
            }
            j = _mm256_add_pd(j, one);
        }
        let mut count = sure;
        loop {
            let mut any = 0;
            for g in 0..G {
                let m = _mm256_cmp_pd::<_CMP_LT_OQ>(x[g], stop[g]);
                any |= _mm256_movemask_pd(m);
                x[g] = _mm256_blendv_pd(x[g], _mm256_add_pd(x[g], dd[g]), m);
                count[g] = _mm256_add_pd(count[g], _mm256_and_pd(m, one));
            }
            if any == 0 {
                break;
            }
        }
        for g in 0..G {
            store(&mut t[a], g, x[g]);
            store(&mut n[a], g, count[g]);
        }
    }
    let mut bits = [0u64; 4];
    // SAFETY: four `u64` into an array of four.
    #[allow(unsafe_code)]
    unsafe {
        _mm256_storeu_si256(bits.as_mut_ptr().cast(), near)
    };
    bits.iter().fold(0, |acc, &b| acc | b) as u32
}
