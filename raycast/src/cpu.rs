//! Run-time checks of the CPU's vector extensions: the one place that asks the CPU which of
//! the SIMD paths ([`crate::lanes`] and the AVX-512 build of [`crate::setups`]) it can run.
//!
//! The standard library caches what the CPU reports, so a check costs a load and a test;
//! callers ask once per batch of rays, not per ray. Every `unsafe` call of a
//! `#[target_feature]` function in this crate sits behind one of these checks.

/// Whether this CPU runs the four-lane walks: AVX2 (and the AVX it implies).
#[inline]
pub(crate) fn has_avx2() -> bool {
    std::arch::is_x86_feature_detected!("avx2")
}

/// Whether this CPU runs the eight-lane walks and the AVX-512 builds: AVX-512 Foundation,
/// and `popcnt` (which every such CPU has) for counting the bricks a step leaves.
#[inline]
pub(crate) fn has_avx512() -> bool {
    std::arch::is_x86_feature_detected!("avx512f") && std::arch::is_x86_feature_detected!("popcnt")
}
