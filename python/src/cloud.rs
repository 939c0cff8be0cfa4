//! Whole-tree and many-point queries that return arrays: `extractPointCloud`, `getLabels`,
//! occupancy per point, voxel lists. Pure Rust (called without the GIL).

use crate::engine::{OcTree, TREE_DEPTH};
use nalgebra::Point3;

/// Rows of points.
pub type Rows = Vec<[f64; 3]>;

/// Not enough memory for a result; the caller raises `MemoryError`.
#[derive(Debug)]
pub struct TooLarge(pub u128);

/// octomap-python's `extractPointCloud`: every leaf as the centres of the voxels it covers,
/// occupied and free apart, in leaf order, with its exact floating-point arithmetic (the
/// resolution as float32, centres as float32, then double maths).
pub fn extract_point_cloud(tree: &OcTree) -> Result<(Rows, Rows), TooLarge> {
    let conv = tree.converter();
    let res = conv.resolution() as f32 as f64;
    let thres = tree.params().occupancy_threshold;
    let dims = |depth: u8| -> u64 {
        let d = (conv.node_size(depth) / res).round_ties_even();
        if d.is_finite() && d >= 1.0 {
            d as u64
        } else {
            1
        }
    };
    let (mut n_occ, mut n_free) = (0u128, 0u128);
    for leaf in tree.leaves() {
        let d = dims(leaf.depth) as u128;
        if leaf.value >= thres {
            n_occ += d * d * d;
        } else {
            n_free += d * d * d;
        }
    }
    let alloc = |n: u128| -> Result<Rows, TooLarge> {
        let mut v = Vec::new();
        let len = usize::try_from(n).map_err(|_| TooLarge(n))?;
        v.try_reserve_exact(len).map_err(|_| TooLarge(n))?;
        Ok(v)
    };
    let mut occupied = alloc(n_occ)?;
    let mut free = alloc(n_free)?;
    for leaf in tree.leaves() {
        let d = dims(leaf.depth);
        let half = d as f64 / 2.0 - 0.5;
        let mut o = [0.0; 3];
        for (a, v) in o.iter_mut().enumerate() {
            let centre = conv.key_to_coord_at_depth(leaf.key[a], leaf.depth) as f32 as f64;
            *v = centre - half * res;
        }
        let out = if leaf.value >= thres {
            &mut occupied
        } else {
            &mut free
        };
        for i in 0..d {
            for j in 0..d {
                for k in 0..d {
                    out.push([
                        o[0] + i as f64 * res,
                        o[1] + j as f64 * res,
                        o[2] + k as f64 * res,
                    ]);
                }
            }
        }
    }
    Ok((occupied, free))
}

/// Label per point: 1 occupied, 0 free, -1 unknown (also for NaN and out-of-map points).
/// Points are taken as float32, as octomap-python's `getLabels` does.
pub fn labels(tree: &OcTree, points: &[Point3<f32>]) -> Vec<i32> {
    let conv = tree.converter();
    let params = tree.params();
    points
        .iter()
        .map(|p| {
            conv.point_to_key(&p.cast::<f64>())
                .and_then(|k| tree.search(k, TREE_DEPTH))
                .map_or(-1, |n| params.is_occupied(n.value) as i32)
        })
        .collect()
}

/// Occupancy probability per point, NaN in unknown space and outside the map.
pub fn occupancy(tree: &OcTree, points: &[Point3<f64>]) -> Vec<f64> {
    points
        .iter()
        .map(|p| tree.probability_at(p).unwrap_or(f64::NAN))
        .collect()
}

/// Centres (double precision) and edge lengths of the occupied (or free) leaves.
pub fn voxels(tree: &OcTree, occupied: bool) -> (Vec<[f64; 3]>, Vec<f64>) {
    let conv = tree.converter();
    let thres = tree.params().occupancy_threshold;
    let mut centres = Vec::new();
    let mut sizes = Vec::new();
    for leaf in tree.leaves() {
        if (leaf.value >= thres) == occupied {
            centres.push([0, 1, 2].map(|a| conv.key_to_coord_at_depth(leaf.key[a], leaf.depth)));
            sizes.push(conv.node_size(leaf.depth));
        }
    }
    (centres, sizes)
}
