//! OctoMap's `discretize` option: a scan reduced to one point per voxel, the voxel's centre,
//! before its rays are cast (see [`crate::compute_discrete_update_f32`]).

use crate::dda::is_finite;
use crate::stats::ScanStats;
use nalgebra::Point3;
use octoquant_octree::{Key, KeyConverter};

/// Reduce a scan to one point per voxel, as OctoMap's `computeDiscreteUpdate` does before its
/// `computeUpdate`: each point's key is taken unchecked (`coordToKey`; points outside the map
/// wrap around into it, as in OctoMap), and the centre (`f32`, OctoMap's `point3d`) of every
/// key not seen before is appended to `centres`, in first-seen order. The `f32` fast path of
/// [`crate::discretize()`].
///
/// Non-finite points are skipped and counted in the returned statistics (OctoMap would map a
/// NaN coordinate to key 32768; we refuse it instead); `outside_map` counts the wrapped ones
/// and `duplicates` the points whose voxel was already taken. `centres` is cleared first.
pub fn discretize_f32(
    conv: &KeyConverter,
    points: &[Point3<f32>],
    centres: &mut Vec<Point3<f32>>,
) -> ScanStats {
    let mut order = Vec::new();
    discretize_into(conv, points, centres, &mut order)
}

/// [`discretize_f32`] with a caller-owned scratch list `order` (each kept point's Morton code
/// and index), reused from scan to scan by [`crate::compute_discrete_update_f32`].
pub(crate) fn discretize_into(
    conv: &KeyConverter,
    points: &[Point3<f32>],
    centres: &mut Vec<Point3<f32>>,
    order: &mut Vec<(u64, usize)>,
) -> ScanStats {
    centres.clear();
    let stats = discretize_codes(conv, points, order);
    centres.extend(
        order
            .iter()
            .map(|&(c, _)| conv.key_to_point_f32(&Key::from_morton(c))),
    );
    stats
}

/// The voxels of [`discretize_f32`] without their centres: on return `order` holds the Morton
/// code and point index of the first point of every voxel, in first-seen order.
pub(crate) fn discretize_codes(
    conv: &KeyConverter,
    points: &[Point3<f32>],
    order: &mut Vec<(u64, usize)>,
) -> ScanStats {
    order.clear();
    let mut stats = ScanStats {
        points: points.len(),
        ..ScanStats::default()
    };
    for (i, p) in points.iter().enumerate() {
        if !is_finite(p) {
            stats.non_finite += 1;
            continue;
        }
        let pd = Point3::new(p.x as f64, p.y as f64, p.z as f64);
        if conv.point_to_key(&pd).is_none() {
            stats.outside_map += 1;
        }
        let k = conv.point_to_key_unchecked(&pd);
        order.push((k.morton(), i));
    }
    // first occurrence of every key: sort by (code, index), keep run heads, restore order
    order.sort_unstable();
    order.dedup_by_key(|e| e.0);
    let kept = order.len();
    stats.duplicates = points.len() - stats.non_finite - kept;
    order.sort_unstable_by_key(|e| e.1);
    stats
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn discretize_keeps_first_seen_centres() {
        let c = KeyConverter::new(0.1).unwrap();
        let pts = [
            Point3::new(0.31f32, 0.0, 0.0),
            Point3::new(-0.01, 0.0, 0.0),
            Point3::new(0.39, 0.05, 0.01),
            Point3::new(f32::NAN, 0.0, 0.0),
            Point3::new(-0.05, 0.02, 0.03),
        ];
        let mut centres = Vec::new();
        let s = discretize_f32(&c, &pts, &mut centres);
        assert_eq!(
            centres,
            vec![
                Point3::new(0.35f32, 0.05, 0.05),
                Point3::new(-0.05, 0.05, 0.05)
            ]
        );
        assert_eq!((s.points, s.non_finite, s.duplicates), (5, 1, 2));
        // outside the map the unchecked key wraps, as in OctoMap
        let s = discretize_f32(&c, &[Point3::new(3276.85f32, 0.0, 0.0)], &mut centres);
        assert_eq!(s.outside_map, 1);
        assert_eq!(centres, vec![Point3::new(-3276.75f32, 0.05, 0.05)]);
    }
}
