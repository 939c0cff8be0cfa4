//! Many ray walks at once in the lanes of SIMD registers.

#[cfg(target_arch = "x86_64")]
pub(crate) mod avx2;
#[cfg(target_arch = "x86_64")]
pub(crate) mod avx512;
#[cfg(target_arch = "x86_64")]
pub(crate) mod bresenham_avx512;
pub(crate) mod dispatch;
