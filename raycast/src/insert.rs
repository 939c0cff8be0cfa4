//! Inserting a scan into a tree: OctoMap's `insertPointCloud` and `insertPointCloudRays`.

use crate::dda::key_of;
use crate::ray_order::{walk_rays_in_order_f32, RayKeys, RayOrderScratch};
use crate::stats::ScanStats;
use crate::update::{compute_discrete_update_f32, compute_update_f32, ScanUpdate};
use nalgebra::Point3;
use octoquant_octree::{InnerNodes, KeyConverter, OcTree, Update};

/// Statistics of one inserted scan (see [`ScanStats`]); `free` and `occupied` count the miss
/// and hit updates applied.
pub type InsertStats = ScanStats;

/// How [`insert_point_cloud`](crate::insert_point_cloud) and its `_f32` paths treat a scan;
/// `Default` gives OctoMap's defaults (`maxrange = -1`, `lazy_eval = false`,
/// `discretize = false`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct InsertOptions {
    /// Readings farther than this from the origin only clear space up to this distance and
    /// mark nothing occupied. `None` is OctoMap's `-1` (no limit). As in OctoMap, a negative
    /// value also means no limit and `Some(0.0)` is a real limit (only points exactly at the
    /// origin count as hits).
    pub max_range: Option<f64>,
    /// Reduce the scan to one ray per endpoint voxel, cast to the voxel centre (OctoMap's
    /// `discretize`; see [`discretize()`](crate::discretize())).
    pub discretize: bool,
    /// Skip pruning and inner-node updates (OctoMap's `lazy_eval`); call
    /// [`OcTree::update_inner_occupancy`] once after the last scan.
    pub lazy: bool,
}

/// How [`apply_update`] and [`insert_point_cloud_rays`](crate::insert_point_cloud_rays) (and
/// its `_f32` path) update the tree; `Default` gives OctoMap's default (`lazy_eval = false`).
/// Neither takes a range or `discretize`: the key sets of the first are computed already, and
/// OctoMap's `insertPointCloudRays` ignores its range.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ApplyOptions {
    /// Skip pruning and inner-node updates (OctoMap's `lazy_eval`); call
    /// [`OcTree::update_inner_occupancy`] once after the last scan.
    pub lazy: bool,
}

/// Apply a computed scan update: one miss per free voxel, then one hit per occupied voxel,
/// both in Morton order, through the tree's batched [`OcTree::update_bricks`].
///
/// The order differs from OctoMap's hash-set order, but within one scan the voxels are
/// disjoint and each is updated once, so the final tree is the same.
pub fn apply_update(tree: &mut OcTree, update: &ScanUpdate, options: &ApplyOptions) {
    let lazy = options.lazy;
    // batched by brick: consecutive bricks share their path from the root, which Morton
    // order maximises
    tree.update_bricks(
        update.free_bricks(),
        Update::Miss,
        InnerNodes::from_lazy(lazy),
    );
    tree.update_bricks(
        update.occupied_bricks(),
        Update::Hit,
        InnerNodes::from_lazy(lazy),
    );
}

/// OctoMap's `insertPointCloud(scan, sensor_origin, maxrange, lazy_eval, discretize)`: compute
/// the scan's free and occupied voxels ([`compute_update_f32`] or
/// [`compute_discrete_update_f32`]) and update each once, misses first.
///
/// Points are in the map frame, `origin` is the sensor position. Non-finite points are skipped
/// and counted, points outside the map dropped and counted; never panics. With `lazy`, inner
/// nodes are left stale: call [`OcTree::update_inner_occupancy`] before querying or writing.
///
/// The `f32` fast path: coordinates as OctoMap's `point3d`; [`crate::insert_point_cloud`] takes
/// `f64`.
pub fn insert_point_cloud_f32(
    tree: &mut OcTree,
    points: &[Point3<f32>],
    origin: &Point3<f32>,
    options: &InsertOptions,
) -> InsertStats {
    let mut buffers = ScanUpdate::new();
    insert_point_cloud_reusing_f32(tree, points, origin, options, &mut buffers)
}

/// [`insert_point_cloud_f32`] with caller-owned buffers, to avoid reallocating them for every
/// scan. After the call `buffers` holds the scan's key sets.
///
/// An `f32` path only: coordinates as OctoMap's `point3d` (the `f64` door is
/// [`crate::insert_point_cloud`]).
pub fn insert_point_cloud_reusing_f32(
    tree: &mut OcTree,
    points: &[Point3<f32>],
    origin: &Point3<f32>,
    options: &InsertOptions,
    buffers: &mut ScanUpdate,
) -> InsertStats {
    let conv = tree.converter().clone();
    let stats = compute_scan_update_f32(&conv, points, origin, options, buffers);
    apply_update(tree, buffers, &ApplyOptions { lazy: options.lazy });
    stats
}

/// The first half of [`insert_point_cloud_f32`]: the scan's free and occupied voxels into
/// `out` ([`compute_update_f32`], or [`compute_discrete_update_f32`] with
/// `options.discretize`), for trees that apply them their own way (the stamped tree's
/// `insert_bricks_at`). `options.lazy` is not read here.
pub fn compute_scan_update_f32(
    conv: &KeyConverter,
    points: &[Point3<f32>],
    origin: &Point3<f32>,
    options: &InsertOptions,
    out: &mut ScanUpdate,
) -> InsertStats {
    if options.discretize {
        compute_discrete_update_f32(conv, points, origin, options.max_range, out)
    } else {
        compute_update_f32(conv, points, origin, options.max_range, out)
    }
}

/// OctoMap's `insertPointCloudRays` (graph2tree's `-simple` mode): for each point in order,
/// a miss on every key of its ray, then a hit on its voxel. No deduplication: a voxel may be
/// updated many times, and a miss may follow a hit. There is no maximum range (OctoMap ignores
/// its `maxrange` argument here).
///
/// A point whose ray cannot be computed (an end outside the map) changes nothing, not even its
/// hit. `free`/`occupied` in the result count the updates applied.
///
/// The `f32` fast path: coordinates as OctoMap's `point3d`;
/// [`crate::insert_point_cloud_rays`] takes `f64`.
pub fn insert_point_cloud_rays_f32(
    tree: &mut OcTree,
    points: &[Point3<f32>],
    origin: &Point3<f32>,
    options: &ApplyOptions,
) -> InsertStats {
    let inner = InnerNodes::from_lazy(options.lazy);
    let conv = tree.converter().clone();
    let mut stats = InsertStats {
        points: points.len(),
        ..InsertStats::default()
    };
    // the rays walked many at a time and handed on in order, each as its bricks: a ray enters
    // a brick once, so its bricks are the runs of one brick that `update_keys` makes of its
    // keys, and the tree takes the same updates in the same order
    let mut scratch = RayOrderScratch::default();
    walk_rays_in_order_f32(&conv, origin, points, &mut scratch, |i, ray| {
        let p = &points[i];
        if !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()) {
            stats.non_finite += 1;
            return;
        }
        let Some(end_key) = key_of(&conv, p) else {
            stats.outside_map += 1;
            stats.failed_rays += 1;
            return;
        };
        let Ok(keys) = ray else {
            stats.failed_rays += 1;
            return;
        };
        stats.rays += 1;
        match keys {
            RayKeys::Bricks { bricks, .. } => {
                tree.update_bricks(bricks, Update::Miss, inner);
                stats.free += bricks
                    .iter()
                    .map(|b| b.voxels.count_ones() as usize)
                    .sum::<usize>();
            }
            RayKeys::Keys(keys) => {
                tree.update_keys(keys, Update::Miss, inner);
                stats.free += keys.len();
            }
        }
        tree.update_node(end_key, Update::Hit, inner);
        stats.occupied += 1;
    });
    stats
}

#[cfg(test)]
mod tests {
    use super::*;
    use octoquant_octree::validate::assert_well_formed;

    fn scan() -> Vec<Point3<f32>> {
        let mut pts = Vec::new();
        for i in 0..40 {
            for j in 0..10 {
                let a = i as f32 * 0.15;
                let b = j as f32 * 0.1 - 0.5;
                pts.push(Point3::new(3.0 * a.cos(), 3.0 * a.sin(), b));
            }
        }
        pts.push(Point3::new(f32::NAN, 0.0, 0.0));
        pts.push(Point3::new(1e9, 0.0, 0.0));
        pts
    }

    #[test]
    fn applies_each_key_once_and_matches_the_sets() {
        let mut tree = OcTree::new(0.1).unwrap();
        let origin = Point3::new(0.01f32, 0.02, 0.03);
        let mut buf = ScanUpdate::new();
        let s = insert_point_cloud_reusing_f32(
            &mut tree,
            &scan(),
            &origin,
            &InsertOptions::default(),
            &mut buf,
        );
        assert_eq!(s.non_finite, 1);
        assert_eq!(s.outside_map, 1);
        assert_eq!(s.failed_rays, 1);
        assert_eq!(s.rays, 400);
        assert_well_formed(&tree, InnerNodes::Refresh);
        let p = tree.params();
        for &k in buf.free() {
            assert_eq!(tree.search(k, 16).map(|n| n.value), Some(p.miss));
        }
        for &k in buf.occupied() {
            assert_eq!(tree.search(k, 16).map(|n| n.value), Some(p.hit));
        }
        assert_eq!(s.free, buf.free().len());
        assert_eq!(s.occupied, buf.occupied().len());
    }

    #[test]
    fn lazy_then_inner_equals_eager_after_ml() {
        let origin = Point3::new(0.0f32, 0.0, 0.0);
        let mut eager = OcTree::new(0.2).unwrap();
        let mut lazy = OcTree::new(0.2).unwrap();
        let opts = InsertOptions {
            max_range: Some(2.5),
            ..Default::default()
        };
        for _ in 0..3 {
            insert_point_cloud_f32(&mut eager, &scan(), &origin, &opts);
            insert_point_cloud_f32(
                &mut lazy,
                &scan(),
                &origin,
                &InsertOptions { lazy: true, ..opts },
            );
        }
        lazy.update_inner_occupancy();
        assert_well_formed(&lazy, InnerNodes::Defer);
        let (mut a, mut b) = (Vec::new(), Vec::new());
        octoquant_octree::io::write_bt(&mut eager, &mut a).unwrap();
        octoquant_octree::io::write_bt(&mut lazy, &mut b).unwrap();
        assert_eq!(a, b);
    }

    #[test]
    fn rays_mode_updates_repeatedly() {
        let mut tree = OcTree::new(0.1).unwrap();
        let origin = Point3::new(0.05f32, 0.05, 0.05);
        let pts = vec![Point3::new(0.55f32, 0.05, 0.05); 3];
        let s = insert_point_cloud_rays_f32(&mut tree, &pts, &origin, &ApplyOptions::default());
        assert_eq!(s.rays, 3);
        assert_eq!(s.free, 15);
        let conv = tree.converter().clone();
        let first = key_of(&conv, &origin).unwrap();
        let end = key_of(&conv, &pts[0]).unwrap();
        let p = *tree.params();
        assert_eq!(tree.search(first, 16).unwrap().value, 3.0 * p.miss);
        let hit = tree.search(end, 16).unwrap().value;
        assert_eq!(hit, p.hit + p.hit + p.hit);
    }
}
