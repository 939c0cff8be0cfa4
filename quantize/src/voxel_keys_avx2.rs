//! The key pass of the quantization pre-pass four points at a time with AVX2, chosen at run
//! time: the same packed keys, key box and non-finite count as [`KeyBounds::pack`].
//!
//! Per axis, four coordinates are widened to `f64`, scaled by the converter's factor, floored
//! (`roundpd`, exactly `floor`) and truncated to `i32` (`cvttpd2dq`, whose answer outside
//! `i32` and for NaN is `i32::MIN`, the value [`KeyConverter`]'s scalar conversion gives), then
//! offset by the key centre and wrapped to 16 bits, as OctoMap's unchecked `coordToKey`.
//! Points with a non-finite coordinate get [`NO_KEY`] and stay out of the box.

use super::{KeyBounds, NO_KEY};
use core::arch::x86_64::{
    __m128i, __m256d, __m256i, _mm256_and_pd, _mm256_blendv_epi8, _mm256_castsi256_pd,
    _mm256_cmp_pd, _mm256_cvtepi32_epi64, _mm256_cvtepu32_epi64, _mm256_cvtps_pd,
    _mm256_cvttpd_epi32, _mm256_floor_pd, _mm256_movemask_pd, _mm256_mul_pd, _mm256_or_si256,
    _mm256_set1_epi64x, _mm256_set1_pd, _mm256_slli_epi64, _mm_add_epi32, _mm_and_si128,
    _mm_blendv_epi8, _mm_max_epu32, _mm_min_epu32, _mm_set1_epi32, _mm_setr_ps, _mm_setzero_si128,
    _CMP_LT_OQ,
};
use nalgebra::Point3;
use octoquant_octree::KeyConverter;

/// [`KeyBounds::pack`] four points at a time when this CPU has AVX2, or `None` (nothing
/// written) on CPUs without it.
pub(super) fn pack(
    conv: &KeyConverter,
    points: &[Point3<f32>],
    out: &mut [u64],
) -> Option<KeyBounds> {
    if !std::arch::is_x86_feature_detected!("avx2") {
        return None;
    }
    // SAFETY: `pack_avx2` needs AVX2 (and the SSE4.1 and AVX it implies), and the CPU has
    // been found to support AVX2 just above. Nothing else in it is unsafe.
    #[allow(unsafe_code)]
    let b = unsafe { pack_avx2(conv, points, out) };
    Some(b)
}

/// For each set of lanes (bit `l` for lane `l`), a 32-bit mask with those lanes set.
static LANES32: [[u32; 4]; 16] = {
    let mut t = [[0u32; 4]; 16];
    let mut set = 0;
    while set < 16 {
        let mut l = 0;
        while l < 4 {
            if set & (1 << l) != 0 {
                t[set][l] = u32::MAX;
            }
            l += 1;
        }
        set += 1;
    }
    t
};

/// [`pack`] once AVX2 is known to be there.
#[target_feature(enable = "avx2")]
fn pack_avx2(conv: &KeyConverter, points: &[Point3<f32>], out: &mut [u64]) -> KeyBounds {
    let factor = _mm256_set1_pd(conv.resolution_factor());
    let abs = _mm256_castsi256_pd(_mm256_set1_epi64x(i64::MAX));
    let inf = _mm256_set1_pd(f64::INFINITY);
    let centre = _mm_set1_epi32(1 << 15);
    let low16 = _mm_set1_epi32(0xFFFF);
    let no_key = _mm256_set1_epi64x(NO_KEY as i64);
    let mut lo = [low16; 3];
    let mut hi = [_mm_setzero_si128(); 3];
    let mut non_finite = 0;
    let n = points.len().min(out.len());
    let whole = n - n % 4;
    for (p, o) in points[..whole]
        .chunks_exact(4)
        .zip(out[..whole].chunks_exact_mut(4))
    {
        let mut finite = 0xF;
        let keys: [__m128i; 3] = core::array::from_fn(|a| {
            let c: __m256d = _mm256_cvtps_pd(_mm_setr_ps(p[0][a], p[1][a], p[2][a], p[3][a]));
            finite &= _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_LT_OQ>(_mm256_and_pd(c, abs), inf));
            let s = _mm256_cvttpd_epi32(_mm256_floor_pd(_mm256_mul_pd(factor, c)));
            _mm_and_si128(_mm_add_epi32(s, centre), low16)
        });
        let fin32: __m128i = bytemuck::cast(LANES32[finite as usize]);
        for a in 0..3 {
            lo[a] = _mm_min_epu32(lo[a], _mm_blendv_epi8(low16, keys[a], fin32));
            hi[a] = _mm_max_epu32(hi[a], _mm_and_si128(keys[a], fin32));
        }
        let code: __m256i = _mm256_or_si256(
            _mm256_or_si256(
                _mm256_cvtepu32_epi64(keys[0]),
                _mm256_slli_epi64::<16>(_mm256_cvtepu32_epi64(keys[1])),
            ),
            _mm256_slli_epi64::<32>(_mm256_cvtepu32_epi64(keys[2])),
        );
        let fin64 = _mm256_cvtepi32_epi64(fin32);
        let code: [u64; 4] = bytemuck::cast(_mm256_blendv_epi8(no_key, code, fin64));
        o.copy_from_slice(&code);
        non_finite += 4 - (finite as u32).count_ones() as usize;
    }
    let lanes = |v: __m128i| -> [u32; 4] { bytemuck::cast(v) };
    let b = KeyBounds {
        lo: core::array::from_fn(|a| lanes(lo[a]).into_iter().min().unwrap_or(0xFFFF) as u16),
        hi: core::array::from_fn(|a| lanes(hi[a]).into_iter().max().unwrap_or(0) as u16),
        non_finite,
    };
    // with no finite point the corners stay the empty box's (`lo` 0xFFFF, `hi` 0)
    KeyBounds::union(
        b,
        KeyBounds::pack_scalar(conv, &points[whole..n], &mut out[whole..n]),
    )
}
