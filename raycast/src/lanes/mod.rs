//! Many ray walks at once, in the lanes of SIMD registers: the DDA brick walk of
//! [`crate::dda`] and the Bresenham lines of [`crate::bresenham`] for a batch of rays, as many
//! side by side as the CPU has lanes for, and the replay of depth-image rays' skipped heads.
//!
//! One walk's axis choice (OctoMap's `tMax` comparison chain) is a three-way branch the
//! predictor misses about one step in two when neighbouring rays differ, and made with masks
//! it is a chain of compare, mask and add that each step waits for. Independent walks in the
//! lanes of one register share those instructions and overlap their chains. [`walk_all`] picks
//! at run time (through [`crate::cpu`]) the widest path the CPU has. The comparisons, additions
//! and tie rules are OctoMap's, lane by lane, so every walk visits exactly the voxels of
//! [`crate::dda::walk_ray_codes_f32`]; only the order in which bricks reach the set changes, and a
//! set does not depend on it.
//!
//! - `dispatch`: [`walk_all`] and [`walk_lines`], and their per-thread [`LaneScratch`] and
//!   [`LineScratch`]: the choice of path; [`queue_setups`] and [`walk_queued`], exact walks
//!   queued straight from set-up columns where the CPU has the eight lanes.
//! - `brick_walk`: one walk at a time (the scalar path, and the state of each SSE2 lane).
//! - `sse2`: two walks at once with SSE2, through `safe_arch` (no unsafe code).
//! - `avx2`: four DDA walks at once with AVX2.
//! - `avx512`: eight DDA walks at once with AVX-512, the eight lanes' bricks
//!   ([`OctScratch`](avx512::OctScratch)) and the walks queued from set-up columns
//!   ([`QueuedWalks`](avx512::QueuedWalks)).
//! - `bresenham_avx2`: four Bresenham lines at once with AVX2.
//! - `bresenham_avx512`: eight Bresenham lines at once with AVX-512.
//! - `replay`: sixteen depth-image rays moved to the end of their heads at once
//!   ([`replay_rays`], for [`crate::pixel_grid`]), eight lanes at a time in `replay_avx512`,
//!   four in `replay_avx2`; `replay_batch` holds the batch's size and arrays they share.
//! - `refill`: what the AVX2 and AVX-512 lanes share: starting and restarting lanes on rays.
//!
//! The bricks the lanes leave go to the brick set as they come, repeats and all: merging
//! each run of one brick first (as the lanes did up to session 42) cost more than the set's
//! batch insert spends on the repeats (history, session 43).

mod brick_walk;
mod dispatch;
#[cfg(target_arch = "x86_64")]
mod refill;
#[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
mod sse2;

#[cfg(target_arch = "x86_64")]
mod avx2;
#[cfg(target_arch = "x86_64")]
mod avx512;
#[cfg(target_arch = "x86_64")]
mod bresenham_avx2;
#[cfg(target_arch = "x86_64")]
mod bresenham_avx512;
mod replay;
#[cfg(target_arch = "x86_64")]
mod replay_avx2;
#[cfg(target_arch = "x86_64")]
mod replay_avx512;
mod replay_batch;

#[cfg(test)]
pub(crate) use brick_walk::BrickWalk;
pub(crate) use dispatch::{
    queue_setups, queued, walk_all, walk_lines, walk_queued, LaneScratch, LineScratch,
};
#[cfg(test)]
pub(crate) use dispatch::{test_paths, LinePath};

pub(crate) use replay::{replay_rays, ReplayPath, REPLAY_RAYS};
