//! The replay of depth-image rays' skipped heads, [`REPLAY_RAYS`] rays at a time, through the
//! widest path the CPU has: eight lanes with AVX-512 ([`super::replay_avx512`]), four with
//! AVX2 ([`super::replay_avx2`]); without either the caller replays one ray at a time.

#[cfg(target_arch = "x86_64")]
use crate::cpu::{has_avx2, has_avx512};

pub(crate) use super::replay_batch::{Axes, REPLAY_RAYS};

/// The replay's paths, narrowest first.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum ReplayPath {
    /// One ray at a time, by the caller (only tests ask for it: otherwise it is what the
    /// CPU falls back to).
    #[cfg_attr(not(test), allow(dead_code))]
    Scalar,
    /// Four rays at a time.
    Avx2,
    /// Eight rays at a time.
    Avx512,
}

/// For [`REPLAY_RAYS`] rays at once, do what [`crate::pixel_grid::near_steps`] and
/// [`crate::pixel_grid::jump`] do one ray at a time:
/// - the DDA's steps before `until[l]` inside the 3x3x3 block around the origin voxel, with
///   the DDA's own comparisons (ties to z over y over x); their bits are returned, or-ed
///   over the rays, the origin voxel's bit included;
/// - each axis's `tMax` additions `t[a][l] += d[a][l]` while `t[a][l] < until[l]`, counted in
///   `n[a][l]`: the same `f64` additions in the same order as one by one.
///
/// Lanes without a ray get `until = −∞`. Takes the widest path the CPU has, `widest` at most;
/// `None` (nothing done) when that is [`ReplayPath::Scalar`], and off x86-64.
#[cfg_attr(not(target_arch = "x86_64"), allow(unused_variables))]
pub(crate) fn replay_rays(
    t: &mut Axes,
    d: &Axes,
    step: &Axes,
    until: &[f64; REPLAY_RAYS],
    n: &mut Axes,
    widest: ReplayPath,
) -> Option<u32> {
    #[cfg(target_arch = "x86_64")]
    if widest >= ReplayPath::Avx512 && has_avx512() {
        // SAFETY: `replay_avx512` needs AVX-512 Foundation, found just above; its loads and
        // stores are of whole arrays of eight.
        #[allow(unsafe_code)]
        return Some(unsafe { super::replay_avx512::replay_avx512(t, d, step, until, n) });
    }
    #[cfg(target_arch = "x86_64")]
    if widest >= ReplayPath::Avx2 && has_avx2() {
        // SAFETY: `replay_avx2` needs AVX2, found just above; its loads and stores are of
        // whole arrays of four.
        #[allow(unsafe_code)]
        return Some(unsafe { super::replay_avx2::replay_avx2(t, d, step, until, n) });
    }
    None
}
