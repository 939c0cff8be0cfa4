//! Ray queries and single-ray insertion: OctoMap's `castRay` and `insertRay`.

use crate::dda::{compute_ray_keys_f32, key_of, min_axis, norm_f32, sub_f32, KeyRay};
use nalgebra::Point3;
use octoquant_octree::{InnerNodes, Key, KeyConverter, OcTree, Update, TREE_DEPTH};

/// Why a [`cast_ray`](crate::cast_ray) (or [`cast_ray_f32`]) stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CastStop {
    /// An occupied voxel was reached (the only case in which OctoMap returns `true`).
    Occupied,
    /// An unknown voxel was reached and `ignore_unknown` was off.
    Unknown,
    /// The next voxel's centre lies farther than `max_range` from the origin.
    MaxRange,
    /// The next step would leave the map.
    MapBoundary,
    /// The origin is outside the map (or not finite).
    OriginOutsideMap,
    /// The direction has no usable component (zero, NaN or infinite); OctoMap logs an error.
    BadDirection,
    /// The float arithmetic degenerated and the walk made no progress; OctoMap would loop
    /// forever here. Only possible with absurd resolutions or subnormal directions.
    Stalled,
}

/// The result of [`cast_ray`](crate::cast_ray) and [`cast_ray_f32`] (one type for both), with
/// OctoMap's return conventions.
///
/// The voxel centre is reported in `f64` whichever door was used: it is a property of the
/// voxel's key, exact in `f64` ([`KeyConverter::key_to_point`]), so the result carries no
/// rounding of its own. OctoMap's `float` end point is that centre narrowed to `f32`, bit for
/// bit: [`CastResult::end_f32`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CastResult {
    /// OctoMap's return value: `true` only when an occupied voxel was hit.
    pub hit: bool,
    /// The centre of the voxel where the cast stopped (the hit voxel, the unknown voxel, the
    /// first voxel beyond max range, or the last voxel before the map boundary), exact in
    /// `f64`; OctoMap writes it, as `f32`, into its `end` argument (see
    /// [`CastResult::end_f32`]). `None` when OctoMap leaves `end` untouched:
    /// [`CastStop::OriginOutsideMap`] and [`CastStop::BadDirection`].
    pub end: Option<Point3<f64>>,
    /// The key of the voxel whose centre is `end`.
    pub key: Option<Key>,
    /// Why the cast stopped.
    pub stop: CastStop,
}

impl CastResult {
    fn stop(stop: CastStop, key: Option<Key>, conv: &KeyConverter) -> Self {
        CastResult {
            hit: stop == CastStop::Occupied,
            end: key.map(|k| conv.key_to_point(&k)),
            key,
            stop,
        }
    }

    /// [`CastResult::end`] as OctoMap's `castRay` writes it into its `point3d& end`: the
    /// centre narrowed to `f32` (`as f32` per axis, which is OctoMap's `keyToCoord` cast).
    pub fn end_f32(&self) -> Option<Point3<f32>> {
        self.end
            .map(|p| Point3::new(p.x as f32, p.y as f32, p.z as f32))
    }
}

/// How [`cast_ray`](crate::cast_ray) and [`cast_ray_f32`] walk; `Default` gives OctoMap's
/// defaults (`ignoreUnknown = false`, `maxRange = -1`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CastOptions {
    /// Walk on through unknown voxels instead of stopping at the first (OctoMap's
    /// `ignoreUnknown`).
    pub ignore_unknown: bool,
    /// Stop at the first voxel whose centre is farther than this from the origin. `None` is
    /// OctoMap's `-1` (no limit); as OctoMap tests `maxRange > 0`, `Some` of zero, of a
    /// negative value or of NaN means no limit too.
    pub max_range: Option<f64>,
}

/// OctoMap's `castRay(origin, direction, end, ignoreUnknown, maxRange)`: follow a ray from
/// `origin` along `direction` until the first occupied voxel.
///
/// The walk is OctoMap's DDA with two differences from [`crate::compute_ray_keys_f32`]: the voxel
/// border adds the half-resolution in `f64` (no `f32` narrowing), and the map bounds are
/// checked before every step. The origin voxel itself counts: if it is occupied the result is
/// a hit there, and if it is unknown (and `ignore_unknown` is off) the cast stops there. It
/// stops at an unknown voxel unless [`CastOptions::ignore_unknown`], and, when
/// [`CastOptions::max_range`] is `Some(m)` with `m > 0`, at the first voxel whose centre is
/// farther than `m` from the origin (distance squared, per-axis differences in `f32`).
/// `direction` need not be normalised. Never panics or loops forever.
///
/// The `f32` fast path: coordinates as OctoMap's `point3d`; [`crate::cast_ray`] takes
/// `f64`.
pub fn cast_ray_f32(
    tree: &OcTree,
    origin: &Point3<f32>,
    direction: &Point3<f32>,
    options: &CastOptions,
) -> CastResult {
    let ignore_unknown = options.ignore_unknown;
    // OctoMap's `-1`: no limit
    let max_range = options.max_range.unwrap_or(-1.0);
    let conv = tree.converter();
    let params = tree.params();
    let Some(mut current) = key_of(conv, origin) else {
        return CastResult::stop(CastStop::OriginOutsideMap, None, conv);
    };
    let centre = |k: &Key| conv.key_to_point_f32(k);

    match tree.search(current, TREE_DEPTH) {
        Some(n) if params.is_occupied(n.value) => {
            return CastResult::stop(CastStop::Occupied, Some(current), conv);
        }
        Some(_) => {}
        None if !ignore_unknown => {
            return CastResult::stop(CastStop::Unknown, Some(current), conv);
        }
        None => {}
    }

    // Vector3::normalized: divide by the f32 norm only when it is positive
    let mut dir = [direction.x, direction.y, direction.z];
    let len = norm_f32(dir);
    if len > 0.0 {
        for d in dir.iter_mut() {
            *d /= len as f32;
        }
    }
    let max_range_set = max_range > 0.0;
    let res = conv.resolution();
    let o = [origin.x, origin.y, origin.z];
    let mut step = [0i32; 3];
    let mut t_max = [f64::MAX; 3];
    let mut t_delta = [f64::MAX; 3];
    for i in 0..3 {
        step[i] = if dir[i] > 0.0 {
            1
        } else if dir[i] < 0.0 {
            -1
        } else {
            0
        };
        if step[i] != 0 {
            let border = conv.key_to_coord(current[i]) + step[i] as f64 * res * 0.5;
            t_max[i] = (border - o[i] as f64) / dir[i] as f64;
            t_delta[i] = res / dir[i].abs() as f64;
        }
    }
    if step == [0; 3] {
        return CastResult::stop(CastStop::BadDirection, None, conv);
    }
    let max_range_sq = max_range * max_range;

    // OctoMap would spin forever once an axis that cannot move is chosen again and again;
    // after three such iterations in a row nothing can change any more (see the unit tests).
    let mut idle = 0u32;
    loop {
        let dim = min_axis(&t_max);
        if (step[dim] < 0 && current[dim] == 0) || (step[dim] > 0 && current[dim] == u16::MAX) {
            return CastResult::stop(CastStop::MapBoundary, Some(current), conv);
        }
        current[dim] = (current[dim] as i32 + step[dim]) as u16;
        t_max[dim] += t_delta[dim];
        let end = centre(&current);

        if max_range_set {
            let e = [end.x, end.y, end.z];
            let mut dist_sq = 0.0f64;
            for j in 0..3 {
                let d = e[j] - o[j];
                dist_sq += (d * d) as f64;
            }
            if dist_sq > max_range_sq {
                return CastResult::stop(CastStop::MaxRange, Some(current), conv);
            }
        }

        match tree.search(current, TREE_DEPTH) {
            Some(n) if params.is_occupied(n.value) => {
                return CastResult::stop(CastStop::Occupied, Some(current), conv);
            }
            Some(_) => {}
            None if !ignore_unknown => {
                return CastResult::stop(CastStop::Unknown, Some(current), conv);
            }
            None => {}
        }

        if step[dim] == 0 {
            idle += 1;
            if idle >= 3 {
                return CastResult::stop(CastStop::Stalled, Some(current), conv);
            }
        } else {
            idle = 0;
        }
    }
}

/// How [`insert_ray`](crate::insert_ray) and [`insert_ray_f32`] update the tree; `Default`
/// gives OctoMap's defaults (`maxrange = -1`, `lazy_eval = false`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct InsertRayOptions {
    /// Cut rays longer than this: only their misses up to this distance are applied, without
    /// a hit. `None` is OctoMap's `-1` (no limit). OctoMap's test here is `maxrange > 0`, so
    /// `Some(0.0)` (or a negative value) means no limit too, unlike
    /// [`InsertOptions::max_range`](crate::InsertOptions::max_range) where `0` is a real
    /// limit.
    pub max_range: Option<f64>,
    /// Skip pruning and inner-node updates (OctoMap's `lazy_eval`); call
    /// [`OcTree::update_inner_occupancy`] once after the last ray.
    pub lazy: bool,
}

/// OctoMap's `insertRay(origin, end, maxrange, lazy)`: misses along the ray, then a hit at
/// `end`; the ray is not deduplicated against anything.
///
/// When [`InsertRayOptions::max_range`] is `Some(m)` with `m > 0` and the segment is longer
/// than `m`, only the misses along `origin -> origin + m·direction` are applied, without a
/// hit. Returns `false`, changing nothing, when an end of the (cut) ray is outside the map or
/// not finite.
///
/// The `f32` fast path: coordinates as OctoMap's `point3d`; [`crate::insert_ray`] takes
/// `f64`.
pub fn insert_ray_f32(
    tree: &mut OcTree,
    origin: &Point3<f32>,
    end: &Point3<f32>,
    options: &InsertRayOptions,
) -> bool {
    let (max_range, lazy) = (options.max_range, options.lazy);
    let diff = sub_f32(end, origin);
    let mut ray = KeyRay::new();
    let conv = tree.converter().clone();
    let m = max_range.unwrap_or(-1.0);
    if m > 0.0 && norm_f32(diff) > m {
        let cut = crate::update::cut_at_range(origin, diff, m);
        if !compute_ray_keys_f32(&conv, origin, &cut, &mut ray) {
            return false;
        }
        for k in ray.iter() {
            tree.update_node(*k, Update::Miss, InnerNodes::from_lazy(lazy));
        }
        return true;
    }
    if !compute_ray_keys_f32(&conv, origin, end, &mut ray) {
        return false;
    }
    for k in ray.iter() {
        tree.update_node(*k, Update::Miss, InnerNodes::from_lazy(lazy));
    }
    if let Some(k) = key_of(&conv, end) {
        tree.update_node(k, Update::Hit, InnerNodes::from_lazy(lazy));
    }
    true
}

#[cfg(test)]
#[path = "cast_tests.rs"]
mod tests;
