//! The replay of the skipped heads of depth-image rays eight at a time in the 512-bit
//! registers of AVX-512 (chosen at run time by [`super::replay`]): each ray's DDA state at the
//! end of its head (see [`crate::pixel_grid`]), with the very `f64` additions of the walk one
//! ray at a time.

use super::replay_batch::{Axes, REPLAY_RAYS};
use core::arch::x86_64::{
    __m512d, _mm512_abs_pd, _mm512_add_pd, _mm512_cmp_pd_mask, _mm512_cvtepi32_epi64,
    _mm512_cvtpd_epi32, _mm512_div_pd, _mm512_fmadd_pd, _mm512_loadu_pd, _mm512_mask_add_pd,
    _mm512_mask_blend_pd, _mm512_mask_or_epi64, _mm512_maskz_mov_pd, _mm512_max_pd, _mm512_min_pd,
    _mm512_reduce_max_pd, _mm512_reduce_or_epi64, _mm512_roundscale_pd, _mm512_set1_epi64,
    _mm512_set1_pd, _mm512_setzero_pd, _mm512_setzero_si512, _mm512_sllv_epi64, _mm512_storeu_pd,
    _mm512_sub_pd, _CMP_GT_OQ, _CMP_LE_OQ, _CMP_LT_OQ, _CMP_ORD_Q, _MM_FROUND_NO_EXC,
    _MM_FROUND_TO_POS_INF,
};

/// Eight-lane groups.
const G: usize = REPLAY_RAYS / 8;

/// [`super::replay::replay_rays`] with AVX-512 (the caller checked that the CPU has it): the
/// sixteen rays in two interleaved groups of eight, so that the additions' latency overlaps.
#[target_feature(enable = "avx512f")]
pub(super) fn replay_avx512(
    t: &mut Axes,
    d: &Axes,
    step: &Axes,
    until: &[f64; REPLAY_RAYS],
    n: &mut Axes,
) -> u32 {
    // SAFETY (every load and store below): the pointer is to eight consecutive `f64` of an
    // array of sixteen, at offset 0 or 8.
    #[allow(unsafe_code)]
    let load = |v: &[f64; REPLAY_RAYS], g: usize| unsafe { _mm512_loadu_pd(v[8 * g..].as_ptr()) };
    let mut x: [[__m512d; 3]; G] = std::array::from_fn(|g| [0, 1, 2].map(|a| load(&t[a], g)));
    let dd: [[__m512d; 3]; G] = std::array::from_fn(|g| [0, 1, 2].map(|a| load(&d[a], g)));
    let stop: [__m512d; G] = std::array::from_fn(|g| load(until, g));
    let zero = _mm512_setzero_pd();
    let one = _mm512_set1_pd(1.0);
    // the steps inside the block: at most three, as the fourth leaves it
    let mut near = _mm512_setzero_si512();
    for g in 0..G {
        let st = [0, 1, 2].map(|a| load(&step[a], g));
        let mut tt = x[g];
        let mut off = [zero; 3];
        let mut alive =
            _mm512_cmp_pd_mask::<_CMP_LT_OQ>(_mm512_set1_pd(f64::NEG_INFINITY), stop[g]);
        near = _mm512_mask_or_epi64(near, alive, near, _mm512_set1_epi64(1 << 13));
        for _ in 0..3 {
            let m01 = _mm512_cmp_pd_mask::<_CMP_LT_OQ>(tt[0], tt[1]);
            let m02 = _mm512_cmp_pd_mask::<_CMP_LT_OQ>(tt[0], tt[2]);
            let m12 = _mm512_cmp_pd_mask::<_CMP_LT_OQ>(tt[1], tt[2]);
            let s0 = m01 & m02;
            let s1 = !m01 & m12;
            let s2 = !(s0 | s1);
            let tmin = _mm512_mask_blend_pd(s0, _mm512_mask_blend_pd(s1, tt[2], tt[1]), tt[0]);
            let go = alive & _mm512_cmp_pd_mask::<_CMP_LT_OQ>(tmin, stop[g]);
            for (a, s) in [s0, s1, s2].into_iter().enumerate() {
                off[a] = _mm512_mask_add_pd(off[a], s & go, off[a], st[a]);
                tt[a] = _mm512_mask_add_pd(tt[a], s & go, tt[a], dd[g][a]);
            }
            let inside =
                [0, 1, 2].map(|a| _mm512_cmp_pd_mask::<_CMP_LE_OQ>(_mm512_abs_pd(off[a]), one));
            alive = go & inside[0] & inside[1] & inside[2];
            // bit 9·(dz+1) + 3·(dy+1) + (dx+1), as a whole number in f64, then shifted in
            let bit = _mm512_fmadd_pd(
                off[2],
                _mm512_set1_pd(9.0),
                _mm512_fmadd_pd(
                    off[1],
                    _mm512_set1_pd(3.0),
                    _mm512_add_pd(off[0], _mm512_set1_pd(13.0)),
                ),
            );
            let bit = _mm512_cvtpd_epi32(bit);
            let shifted = _mm512_sllv_epi64(_mm512_set1_epi64(1), _mm512_cvtepi32_epi64(bit));
            near = _mm512_mask_or_epi64(near, alive, near, shifted);
        }
    }
    // Phase one, without a compare on the chain: `ceil((until − t)/d) − 2` additions, which
    // the plain loop surely makes (that many leave `t` a step below `until`, since the
    // additions' rounding stays far below a step). Clamped to [0, 2^20]; NaN (from infinite
    // or huge values) counts as none.
    let mut sure = [[zero; 3]; G];
    let mut most = 0.0f64;
    for g in 0..G {
        for a in 0..3 {
            let est = _mm512_roundscale_pd::<{ _MM_FROUND_TO_POS_INF | _MM_FROUND_NO_EXC }>(
                _mm512_div_pd(_mm512_sub_pd(stop[g], x[g][a]), dd[g][a]),
            );
            let est = _mm512_min_pd(
                _mm512_max_pd(_mm512_sub_pd(est, _mm512_set1_pd(2.0)), zero),
                _mm512_set1_pd((1u64 << 20) as f64),
            );
            sure[g][a] = _mm512_maskz_mov_pd(_mm512_cmp_pd_mask::<_CMP_ORD_Q>(est, est), est);
            most = most.max(_mm512_reduce_max_pd(sure[g][a]));
        }
    }
    let mut j = zero;
    for _ in 0..most as u64 {
        for g in 0..G {
            for a in 0..3 {
                let m = _mm512_cmp_pd_mask::<_CMP_GT_OQ>(sure[g][a], j);
                x[g][a] = _mm512_mask_add_pd(x[g][a], m, x[g][a], dd[g][a]);
            }
        }
        j = _mm512_add_pd(j, one);
    }
    let mut count = sure;
    loop {
        let mut any = 0;
        for g in 0..G {
            for a in 0..3 {
                let m = _mm512_cmp_pd_mask::<_CMP_LT_OQ>(x[g][a], stop[g]);
                any |= m;
                x[g][a] = _mm512_mask_add_pd(x[g][a], m, x[g][a], dd[g][a]);
                count[g][a] = _mm512_mask_add_pd(count[g][a], m, count[g][a], one);
            }
        }
        if any == 0 {
            break;
        }
    }
    for g in 0..G {
        for a in 0..3 {
            // SAFETY: as for the loads.
            #[allow(unsafe_code)]
            unsafe {
                _mm512_storeu_pd(t[a][8 * g..].as_mut_ptr(), x[g][a]);
                _mm512_storeu_pd(n[a][8 * g..].as_mut_ptr(), count[g][a]);
            }
        }
    }
    _mm512_reduce_or_epi64(near) as u32
}
