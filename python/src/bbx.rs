//! OctoMap's query bounding box (`setBBXMin`/`setBBXMax`/`useBBXLimit`) and the scan
//! insertion it limits (the BBX branch of `computeUpdate`).

use crate::engine::{self, InnerNodes, Key, KeyConverter, OcTree, Update};
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

/// octomath's `norm()`: the squares summed in float, the root taken in double.
fn norm(d: [f32; 3]) -> f64 {
    ((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) as f64).sqrt()
}

/// The keys OctoMap 1.10's `computeUpdate` inserts into its two `KeySet`s while the BBX
/// limit is on (octomap-python bundles 1.10; 1.9 differed), one `insert` each, in its order,
/// repeats kept: an end point inside the box and within `max_range` (negative = none) gives
/// its voxel to the occupied set; every ray, cut to `max_range`, gives its voxels from the
/// origin until the first voxel outside the box to the free set. With `discretize`, the rays
/// go to the end-point voxels' centres, one per voxel (`computeDiscreteUpdate`).
pub fn key_sequences(
    conv: &KeyConverter,
    bbx: &Bbx,
    points: &[Point3<f32>],
    origin: &Point3<f32>,
    max_range: f64,
    discretize: bool,
) -> (Vec<Key>, Vec<Key>) {
    let discretized;
    let points = if discretize {
        discretized = engine::discretize(conv, points);
        &discretized[..]
    } else {
        points
    };
    let mut free = Vec::new();
    let mut occupied = Vec::new();
    let mut ray = Vec::new();
    for p in points {
        let d = [p.x - origin.x, p.y - origin.y, p.z - origin.z];
        let beyond = max_range >= 0.0 && norm(d) > max_range;
        if bbx.contains(p) && !beyond {
            if let Some(k) = conv.point_to_key(&p.cast::<f64>()) {
                occupied.push(k);
            }
        }
        let end = if beyond {
            // Vector3::normalized divides by the float of the double norm
            let len = norm(d) as f32;
            let dir = if len > 0.0 { d.map(|c| c / len) } else { d };
            let m = max_range as f32;
            Point3::new(
                origin.x + dir[0] * m,
                origin.y + dir[1] * m,
                origin.z + dir[2] * m,
            )
        } else {
            *p
        };
        if engine::ray_keys(conv, origin, &end, &mut ray) {
            free.extend(ray.iter().take_while(|k| bbx.contains_key(k)));
        }
    }
    (free, occupied)
}

/// OctoMap 1.10's `insertPointCloud` while the BBX limit is on, into a plain tree: the sets of
/// [`key_sequences`], occupied winning over free, every voxel updated once, misses first.
pub fn insert_point_cloud(
    tree: &mut OcTree,
    bbx: &Bbx,
    points: &[Point3<f32>],
    origin: &Point3<f32>,
    max_range: f64,
    lazy: bool,
    discretize: bool,
) {
    let (free, occupied) =
        sorted_sets(tree.converter(), bbx, points, origin, max_range, discretize);
    tree.update_keys(&free, Update::Miss, InnerNodes::from_lazy(lazy));
    tree.update_keys(&occupied, Update::Hit, InnerNodes::from_lazy(lazy));
}

/// The sets of [`key_sequences`] in Morton order, each key once, the occupied keys left out
/// of the free ones: for trees whose result does not depend on the order (all but
/// `ColorOcTree`).
pub fn sorted_sets(
    conv: &KeyConverter,
    bbx: &Bbx,
    points: &[Point3<f32>],
    origin: &Point3<f32>,
    max_range: f64,
    discretize: bool,
) -> (Vec<Key>, Vec<Key>) {
    let (mut free, mut occupied) = key_sequences(conv, bbx, points, origin, max_range, discretize);
    let by_morton = |a: &Key, b: &Key| a.morton().cmp(&b.morton());
    occupied.sort_unstable_by(by_morton);
    occupied.dedup();
    free.sort_unstable_by(by_morton);
    free.dedup();
    free.retain(|k| occupied.binary_search_by(|o| by_morton(o, k)).is_err());
    (free, occupied)
}
