//! The `f64` front doors: coordinates in `f64`, narrowed to `f32` exactly as OctoMap's C++ and
//! Python callers narrow them into its `float` `point3d` (`as f32` per axis: round to nearest,
//! finite values beyond `f32`'s range become infinite, NaN stays NaN), then handed to the
//! `f32` fast path of the same name with `_f32`.
//!
//! The narrowing is the only thing a door adds: every door returns what its `_f32` path
//! returns for the narrowed input, bit for bit (the tests check it). A point slice is narrowed
//! into a copy first (a buffer reused from scan to scan inside [`ScanUpdate`] for
//! [`compute_update`] and [`compute_discrete_update`], a fresh `Vec` for the others); callers
//! whose points are `f32` already skip the copy with the `_f32` path.

use crate::cast::{cast_ray_f32, insert_ray_f32, CastOptions, CastResult, InsertRayOptions};
use crate::dda::{compute_ray_keys_f32, KeyRay};
use crate::discretize::discretize_codes;
use crate::insert::{
    insert_point_cloud_f32, insert_point_cloud_rays_f32, ApplyOptions, InsertOptions, InsertStats,
};
use crate::stats::ScanStats;
use crate::update::{compute_discrete_update_f32, compute_update_f32, ScanUpdate};
use nalgebra::{Point3, Vector3};
use octoquant_octree::{Key, KeyConverter, OcTree};

/// `p` narrowed to OctoMap's `point3d`: `as f32` per axis.
#[inline]
fn narrow(p: &Point3<f64>) -> Point3<f32> {
    Point3::new(p.x as f32, p.y as f32, p.z as f32)
}

/// `points` narrowed into `out` (cleared first), keeping its allocation.
fn narrow_into(points: &[Point3<f64>], out: &mut Vec<Point3<f32>>) {
    out.clear();
    out.extend(points.iter().map(narrow));
}

/// `points` narrowed into a fresh `Vec`.
fn narrowed(points: &[Point3<f64>]) -> Vec<Point3<f32>> {
    points.iter().map(narrow).collect()
}

/// OctoMap's `castRay(origin, direction, end, ignoreUnknown, maxRange)` for `f64`
/// coordinates: `origin` and `direction` narrowed to `f32` (see the [crate docs](crate)),
/// then [`cast_ray_f32`], which documents the walk. The result's
/// [`end`](CastResult::end) is the stopping voxel's centre, exact in `f64`.
pub fn cast_ray(
    tree: &OcTree,
    origin: &Point3<f64>,
    direction: &Vector3<f64>,
    options: &CastOptions,
) -> CastResult {
    let d = Point3::from(*direction);
    cast_ray_f32(tree, &narrow(origin), &narrow(&d), options)
}

/// OctoMap's `insertRay(origin, end, maxrange, lazy)` for `f64` coordinates: both ends narrowed
/// to `f32` (see the [crate docs](crate)), then [`insert_ray_f32`], which documents the
/// update. Returns `false`, changing nothing, when an end of the (cut) ray is outside the map
/// or not finite after narrowing.
pub fn insert_ray(
    tree: &mut OcTree,
    origin: &Point3<f64>,
    end: &Point3<f64>,
    options: &InsertRayOptions,
) -> bool {
    insert_ray_f32(tree, &narrow(origin), &narrow(end), options)
}

/// OctoMap's `computeRayKeys(origin, end, ray)` for `f64` coordinates: both ends narrowed to
/// `f32` (see the [crate docs](crate)), then [`compute_ray_keys_f32`], which documents the
/// walk: the voxels the segment crosses, origin voxel first, end voxel excluded; `false` with
/// an empty ray when an end is outside the map or not finite.
pub fn compute_ray_keys(
    conv: &KeyConverter,
    origin: &Point3<f64>,
    end: &Point3<f64>,
    ray: &mut KeyRay,
) -> bool {
    compute_ray_keys_f32(conv, &narrow(origin), &narrow(end), ray)
}

/// OctoMap's `insertPointCloud(scan, sensor_origin, maxrange, lazy_eval, discretize)` for
/// `f64` coordinates: the points are narrowed into a fresh `Vec<Point3<f32>>` and the origin
/// to `f32` (see the [crate docs](crate)), then [`insert_point_cloud_f32`], which documents
/// the insertion. Points that narrowing makes infinite are counted as non-finite.
pub fn insert_point_cloud(
    tree: &mut OcTree,
    points: &[Point3<f64>],
    origin: &Point3<f64>,
    options: &InsertOptions,
) -> InsertStats {
    insert_point_cloud_f32(tree, &narrowed(points), &narrow(origin), options)
}

/// OctoMap's `insertPointCloudRays` for `f64` coordinates: the points are narrowed into a
/// fresh `Vec<Point3<f32>>` and the origin to `f32` (see the [crate docs](crate)), then
/// [`insert_point_cloud_rays_f32`], which documents the updates.
pub fn insert_point_cloud_rays(
    tree: &mut OcTree,
    points: &[Point3<f64>],
    origin: &Point3<f64>,
    options: &ApplyOptions,
) -> InsertStats {
    insert_point_cloud_rays_f32(tree, &narrowed(points), &narrow(origin), options)
}

/// OctoMap's `computeUpdate(scan, origin, free, occupied, maxrange)` for `f64` coordinates:
/// the points are narrowed into a buffer of `out` (kept from call to call) and the origin to
/// `f32` (see the [crate docs](crate)), then [`compute_update_f32`], which documents the key
/// sets. Clears `out` first.
pub fn compute_update(
    conv: &KeyConverter,
    points: &[Point3<f64>],
    origin: &Point3<f64>,
    max_range: Option<f64>,
    out: &mut ScanUpdate,
) -> ScanStats {
    let mut pts = out.take_narrowed();
    narrow_into(points, &mut pts);
    let stats = compute_update_f32(conv, &pts, &narrow(origin), max_range, out);
    out.keep_narrowed(pts);
    stats
}

/// OctoMap's `computeDiscreteUpdate` for `f64` coordinates: the points are narrowed into a
/// buffer of `out` (kept from call to call) and the origin to `f32` (see the
/// [crate docs](crate)), then [`compute_discrete_update_f32`], which documents the key sets.
/// Clears `out` first.
pub fn compute_discrete_update(
    conv: &KeyConverter,
    points: &[Point3<f64>],
    origin: &Point3<f64>,
    max_range: Option<f64>,
    out: &mut ScanUpdate,
) -> ScanStats {
    let mut pts = out.take_narrowed();
    narrow_into(points, &mut pts);
    let stats = compute_discrete_update_f32(conv, &pts, &narrow(origin), max_range, out);
    out.keep_narrowed(pts);
    stats
}

/// OctoMap's `discretize` for `f64` coordinates: the points are narrowed into a fresh
/// `Vec<Point3<f32>>` (see the [crate docs](crate)) and reduced to one per voxel as
/// [`discretize_f32`](crate::discretize_f32) does, which documents it; the centres appended to
/// `centres` (cleared first) are exact in `f64` ([`KeyConverter::key_to_point`]): narrowed
/// with `as f32` they are, bit for bit, the `f32` centres of the fast path.
pub fn discretize(
    conv: &KeyConverter,
    points: &[Point3<f64>],
    centres: &mut Vec<Point3<f64>>,
) -> ScanStats {
    let mut order = Vec::new();
    let stats = discretize_codes(conv, &narrowed(points), &mut order);
    centres.clear();
    centres.extend(
        order
            .iter()
            .map(|&(c, _)| conv.key_to_point(&Key::from_morton(c))),
    );
    stats
}

#[cfg(test)]
#[path = "narrow_tests.rs"]
mod tests;
