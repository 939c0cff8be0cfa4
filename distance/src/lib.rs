//! Distance maps over an OctoMap-compatible occupancy tree, with the numbers of OctoMap's
//! dynamicEDT3D (`DynamicEDTOctomap`, exposed by octomap-python as `dynamicEDT_*`).
//!
//! A [`DistanceMap`] covers the voxels of a key box of an [`OcTree`](octoquant_octree::OcTree).
//! For each voxel it holds the voxel centre's distance to the nearest obstacle voxel's centre,
//! clamped at a maximum, and which obstacle that is. Obstacles are the occupied voxels, plus
//! the unknown ones when asked. Distances are computed by dynamicEDT3D's brushfire (a
//! wavefront over the 26-neighbourhood ordered by squared distance) with its propagation
//! order, tie rules and rounding, so every query returns the same `f32` as OctoMap.
//!
//! # Special values
//!
//! - Outside the box: [`DISTANCE_OUTSIDE`] (-1.0), no obstacle.
//! - Beyond the maximum: the clamp [`DistanceMap::max_dist`], which is
//!   `trunc(max_dist/res + 1)` voxels (so slightly more than asked), usually no obstacle.
//! - Unknown voxels: no special value; they are free or obstacles per
//!   [`DistanceOptions::unknown_occupied`].
//!
//! # How it relates to the exact Euclidean distance
//!
//! Let `d*` be the exact distance in voxels from a voxel to the nearest obstacle voxel of the
//! box (brute force) and `m` the clamp in voxels. The brushfire's squared distance `s` always
//! is the exact squared distance from the voxel to the obstacle it reports, clamped at `m²`,
//! and that obstacle is an obstacle voxel of the box, so `s >= min(d*², m²)`: the answer is
//! never too small. It can be too large: a lower step only moves away from the obstacle it
//! carries, and a voxel keeps the first of equally near offers, so an obstacle can be cut
//! off behind a nearer one's wave. The property tests check both facts on random maps and
//! the measured bound `sqrt(s) - d* < 1` voxel, see `tests/brute_force.rs` and
//! `docs/distance.md`.

#![deny(missing_docs)]

mod error;
mod grid;
mod map;
mod queue;

pub use error::DistanceError;
pub use map::{DistanceMap, DistanceOptions, DISTANCE_OUTSIDE, MAX_CELLS, SQ_CELLS_OUTSIDE};
