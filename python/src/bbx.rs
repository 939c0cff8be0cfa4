//! OctoMap's query bounding box (`setBBXMin`/`setBBXMax`/`useBBXLimit`) and the scan
//! insertion it limits (the BBX branch of `computeUpdate`).

use crate::engine::{self, Key, KeyConverter, OcTree, Update};
use nalgebra::Point3;

/// The box: metric corners as OctoMap stores them (`point3d`) and their keys.
#[derive(Clone, Copy, Default)]
pub struct Bbx {
    /// `useBBXLimit`: whether insertion is limited to the box.
    pub enabled: bool,
    /// Lower corner.
    pub min: Point3<f32>,
    /// Upper corner.
    pub max: Point3<f32>,
    /// Key of the lower corner (kept when the corner is outside the map, as in OctoMap).
    pub min_key: Key,
    /// Key of the upper corner.
    pub max_key: Key,
}

impl Bbx {
    /// `setBBXMin`: the corner is stored; its key only when it lies inside the map.
    pub fn set_min(&mut self, conv: &KeyConverter, p: Point3<f32>) -> bool {
        self.min = p;
        match conv.point_to_key(&p.cast::<f64>()) {
            Some(k) => {
                self.min_key = k;
                true
            }
            None => false,
        }
    }

    /// `setBBXMax`, like [`Bbx::set_min`].
    pub fn set_max(&mut self, conv: &KeyConverter, p: Point3<f32>) -> bool {
        self.max = p;
        match conv.point_to_key(&p.cast::<f64>()) {
            Some(k) => {
                self.max_key = k;
                true
            }
            None => false,
        }
    }

    /// `inBBX(point3d)`: inside the metric box, borders included.
    pub fn contains(&self, p: &Point3<f32>) -> bool {
        (0..3).all(|a| p[a] >= self.min[a] && p[a] <= self.max[a])
    }

    /// `inBBX(OcTreeKey)`: inside the key box, borders included.
    pub fn contains_key(&self, k: &Key) -> bool {
        (0..3).all(|a| k[a] >= self.min_key[a] && k[a] <= self.max_key[a])
    }
}

/// OctoMap's `insertPointCloud` while the BBX limit is on: only end points inside the box
/// (and within `max_range`, negative = none) count; each marks its voxel occupied and frees
/// its ray's voxels walking back from the end until the ray leaves the box. Occupied wins over
/// free; every voxel is updated once, misses first.
pub fn insert_point_cloud(
    tree: &mut OcTree,
    bbx: &Bbx,
    points: &[Point3<f32>],
    origin: &Point3<f32>,
    max_range: f64,
    lazy: bool,
    discretize: bool,
) {
    let discretized;
    let points = if discretize {
        discretized = engine::discretize(tree, points);
        &discretized[..]
    } else {
        points
    };
    let conv = tree.converter().clone();
    let mut free = Vec::new();
    let mut occupied = Vec::new();
    let mut ray = Vec::new();
    for p in points {
        if !bbx.contains(p) {
            continue;
        }
        if max_range >= 0.0 {
            // octomath's norm: the squares summed in float, the root in double
            let d = [p.x - origin.x, p.y - origin.y, p.z - origin.z];
            let sq = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            if (sq as f64).sqrt() > max_range {
                continue;
            }
        }
        if let Some(k) = conv.point_to_key(&p.cast::<f64>()) {
            occupied.push(k);
        }
        if engine::ray_keys(tree, origin, p, &mut ray) {
            for k in ray.iter().rev() {
                if !bbx.contains_key(k) {
                    break;
                }
                free.push(*k);
            }
        }
    }
    let by_morton = |a: &Key, b: &Key| a.morton().cmp(&b.morton());
    occupied.sort_unstable_by(by_morton);
    occupied.dedup();
    free.sort_unstable_by(by_morton);
    free.dedup();
    free.retain(|k| occupied.binary_search_by(|o| by_morton(o, k)).is_err());
    tree.update_keys(&free, Update::Miss, lazy);
    tree.update_keys(&occupied, Update::Hit, lazy);
}
