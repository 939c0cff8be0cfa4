//! Rays and scan insertion for the octoquant octree, bit-identical to OctoMap 1.9.7.
//!
//! Precision convention: coordinates are `f64` everywhere in the public API, and the `f32`
//! fast paths, which compute in OctoMap's `float` `point3d` as OctoMap does, carry `_f32` in
//! their names.
//!
//! Entry points (each an `f64` front door over an `_f32` fast path):
//! - [`compute_ray_keys`] ([`compute_ray_keys_f32`], [`walk_ray_keys_f32`] into a visitor,
//!   [`walk_ray_codes_f32`] as Morton codes): the voxels a segment crosses, by OctoMap's 3D
//!   DDA (`computeRayKeys`), into a reusable [`KeyRay`].
//! - [`cast_ray`] ([`cast_ray_f32`]): the first occupied voxel along a ray (`castRay`) under
//!   [`CastOptions`], as a [`CastResult`]; [`insert_ray`] ([`insert_ray_f32`]): misses along
//!   one ray and a hit at its end (`insertRay`) under [`InsertRayOptions`].
//! - [`compute_update`] / [`compute_discrete_update`] (and their `_f32` paths;
//!   [`compute_update_with_f32`] for another [`RayModel`]): a scan's disjoint free and
//!   occupied key sets (`computeUpdate`, `computeDiscreteUpdate`) in a reusable
//!   [`ScanUpdate`], sorted by Morton code instead of hashed and kept as [`Brick`]s of 4x4x4
//!   voxels; [`discretize()`] ([`discretize_f32`]) alone. [`compute_update_grid_f32`]: the
//!   same sets for a depth image's points, faster, given their [`PixelGrid`].
//! - [`walk_rays_in_order_f32`]: the keys of many rays from one origin, ray by ray in order
//!   ([`RayKeys`]), walked in the SIMD lanes, for callers whose result depends on the order
//!   keys come in (octomap_server's colour scan).
//! - [`insert_point_cloud`] ([`insert_point_cloud_f32`], [`insert_point_cloud_reusing_f32`]
//!   with reused buffers): a scan into an [`OcTree`](octoquant_octree::OcTree) under
//!   [`InsertOptions`] (`insertPointCloud`); [`apply_update`] for sets already computed and
//!   [`insert_point_cloud_rays`] ([`insert_point_cloud_rays_f32`]) for graph2tree's `-simple`
//!   mode, under [`ApplyOptions`].
//!
//! The arithmetic is OctoMap's, in `f32`: the `f64` doors narrow their coordinates with
//! `as f32` (round to nearest; finite values beyond `f32`'s range become infinite and count as
//! non-finite), as OctoMap's C++ and Python callers do when they fill a `point3d`, and then
//! call the fast path, so a door and its `_f32` path give the same result for the same narrowed
//! input (point slices are copied to narrow them: callers holding `f32` points, like the
//! frames of octoquant's readers, call the `_f32` paths and skip the copy). Points are in the
//! map frame; nothing panics: NaN/infinite and out-of-map points are skipped and counted in
//! [`ScanStats`]. Optional ranges are `Option<f64>` (`None` for OctoMap's `-1`).
//!
//! Layout (`src/`), from the entry points down:
//! - `narrow.rs`: the `f64` front doors, narrowing to the `f32` paths below.
//! - `insert.rs`: a scan into a tree; `cast.rs`: one ray into or through a tree.
//! - `update.rs`: a scan's key sets; `discretize.rs`: OctoMap's `discretize` (one point per
//!   voxel); `stats.rs`: the counts of a scan; `brickset.rs`: the key sets as hashed bricks.
//! - `ray_order.rs`: many rays' keys handed on ray by ray, in order.
//! - `point_keys.rs`: the end points' keys, a block of points at a time;
//! - `pixel_grid.rs`: which stretch of a depth image's rays their neighbours cover;
//!   `setups.rs`: the DDA set-ups of many rays at once.
//! - `dda.rs`: OctoMap's DDA, one ray at a time, and the ray set-up every walk starts from;
//!   `bresenham.rs`: the opt-in Bresenham lines.
//! - `lanes/`: many walks at once in the lanes of SIMD registers (`dispatch.rs` picks the
//!   widest path: `avx512.rs`, `avx2.rs`, `sse2.rs` or `brick_walk.rs`, one at a time; the
//!   Bresenham lines in `bresenham_avx512.rs` or `bresenham_avx2.rs`; the depth-image replay
//!   in `replay.rs` over `replay_avx512.rs` and `replay_avx2.rs`; `refill.rs` and `runs.rs`
//!   shared by the AVX2 and AVX-512 lanes).
//! - `cpu.rs`: the run-time checks of the CPU's vector extensions, the one place that asks.
//!
//! ```
//! use nalgebra::{Point3, Vector3};
//! use octoquant_octree::OcTree;
//! use octoquant_raycast::{
//!     cast_ray, compute_ray_keys, insert_point_cloud, CastOptions, InsertOptions, KeyRay,
//! };
//!
//! let mut tree = OcTree::new(0.1).unwrap();
//! let origin = Point3::new(0.05, 0.05, 0.05);
//!
//! // the ray's voxels: origin voxel first, end voxel excluded
//! let mut ray = KeyRay::new();
//! assert!(compute_ray_keys(tree.converter(), &origin, &Point3::new(1.05, 0.05, 0.05), &mut ray));
//! assert_eq!(ray.len(), 10);
//!
//! // a wall of points 2 m away
//! let wall: Vec<Point3<f64>> = (0..400)
//!     .map(|i| Point3::new(2.0, 0.1 * (i % 20) as f64 - 0.95, 0.1 * (i / 20) as f64 - 0.95))
//!     .collect();
//! let stats = insert_point_cloud(&mut tree, &wall, &origin, &InsertOptions::default());
//! assert_eq!(stats.occupied, 400);
//!
//! let hit = cast_ray(&tree, &origin, &Vector3::x(), &CastOptions::default());
//! assert!(hit.hit);
//! // the hit voxel's centre, exact in f64
//! assert_eq!(hit.end, Some(tree.converter().key_to_point(&hit.key.unwrap())));
//! assert!((hit.end.unwrap() - Point3::new(2.05, 0.05, 0.05)).norm() < 1e-9);
//! ```
#![deny(missing_docs)]
// Audited exceptions: the calls into the AVX2 and AVX-512 code after the run-time checks of
// `cpu.rs` that the CPU has it: `lanes/avx2.rs` (`walk_quads`), `lanes/avx512.rs`
// (`walk_octs`), `lanes/bresenham_avx2.rs` and `lanes/bresenham_avx512.rs` (`walk_lines`),
// `lanes/replay.rs` (`replay_rays`' calls into `lanes/replay_avx512.rs` and
// `lanes/replay_avx2.rs`, and their loads and stores of whole arrays) and `setups.rs`
// (`set_up`'s calls of its AVX-512 and AVX2 builds); in tests, the calls of the AVX-512 run
// merge and of the AVX2 set-ups after the same checks (`lanes/avx512.rs`, `merge_runs_wide`;
// `setups_tests.rs`). Everything else is safe code.
#![deny(unsafe_code)]

mod bresenham;
mod brickset;
mod cast;
#[cfg(target_arch = "x86_64")]
mod cpu;
mod dda;
mod discretize;
mod insert;
mod lanes;
mod narrow;
mod pixel_grid;
mod point_keys;
mod ray_order;
mod setups;
mod stats;
mod update;

pub use bresenham::walk_bresenham_keys;
pub use cast::{cast_ray_f32, insert_ray_f32, CastOptions, CastResult, CastStop, InsertRayOptions};
pub use dda::{
    compute_ray_keys_f32, walk_ray_codes_f32, walk_ray_keys_f32, KeyRay, RayWalk,
    OCTOMAP_KEY_RAY_CAPACITY,
};
pub use discretize::discretize_f32;
pub use insert::{
    apply_update, compute_scan_update_f32, insert_point_cloud_f32, insert_point_cloud_rays_f32,
    insert_point_cloud_reusing_f32, ApplyOptions, InsertOptions, InsertStats,
};
pub use narrow::{
    cast_ray, compute_discrete_update, compute_ray_keys, compute_update, discretize,
    insert_point_cloud, insert_point_cloud_rays, insert_ray,
};
pub use octoquant_octree::Brick;
pub use pixel_grid::{PinholeCamera, PixelGrid};
pub use ray_order::{walk_rays_in_order_f32, RayKeys, RayOrderScratch};
pub use stats::ScanStats;
pub use update::{
    compute_discrete_update_f32, compute_update_clearing_f32, compute_update_f32,
    compute_update_grid_f32, compute_update_with_f32, max_range_end_f32, RayModel, ScanUpdate,
};
