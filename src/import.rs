//! Voxel grids into occupancy trees: OctoMap's `binvox2bt`.
//!
//! Each cell of a binvox grid ([`crate::formats::binvox`]) becomes a point exactly as
//! binvox2bt computes it: the grid coordinates times the resolution plus the grid's corner plus
//! 1e-6 m, in `f64`, stored as `f32`; optionally turned a quarter about x ([`BinvoxImport::rotate`],
//! OctoMap's `Vector3::rotate_IP(π/2, 0, 0)`), then shifted ([`BinvoxImport::offset`], in `f32`)
//! and kept only inside a box ([`BinvoxImport::bbx`]). Voxel cells (value 1) update their
//! voxel as a hit; other cells update it as a miss with [`BinvoxImport::mark_free`] and are left
//! unknown without. Updates defer the inner nodes, as binvox2bt's lazy `updateNode`; call
//! [`finish_import`] (inner occupancy, then prune) before writing, as binvox2bt does before its
//! `writeBinary`.
//!
//! The resolution is the first grid's `scale / longest side`; later grids go into the same
//! tree, their cells placed by their own resolution, as binvox2bt composes several files.

use crate::formats::binvox::Binvox;
use nalgebra::{Point3, Vector3};
use octoquant_octree::{InnerNodes, OcTree, OctreeError, Update};

/// How [`import_binvox`] places and marks the cells; `Default` is binvox2bt's: occupied cells
/// only, no rotation, no box, no offset.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BinvoxImport {
    /// Mark the cells that are not voxels free (binvox2bt `--mark-free`); otherwise they stay
    /// unknown.
    pub mark_free: bool,
    /// Turn the points a quarter turn about x (binvox2bt `--rotate`, for Webots exports).
    pub rotate: bool,
    /// Keep only points inside this box, bounds included (binvox2bt `--bb`): `(min, max)`,
    /// compared with the final (rotated, shifted) `f32` point.
    pub bbx: Option<(Point3<f64>, Point3<f64>)>,
    /// Add this to every point, in `f32` (binvox2bt `--offset`).
    pub offset: Option<Vector3<f32>>,
}

/// What [`import_binvox`] did with a grid (binvox2bt's "read N voxels, skipped M").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ImportStats {
    /// Cells with a non-zero value (binvox2bt's voxel count, box or not).
    pub voxels: u64,
    /// Cells whose point lies outside the box (of any value).
    pub outside_box: u64,
    /// Voxels updated as hits.
    pub hits: u64,
    /// Voxels updated as misses.
    pub misses: u64,
    /// Updates dropped because the point is outside the tree's addressable cube.
    pub outside_map: u64,
}

/// The leaf size binvox2bt gives a grid: `scale / longest side`, in `f64`.
pub fn binvox_resolution(grid: &Binvox) -> f64 {
    f64::from(grid.scale) / grid.max_side() as f64
}

/// A new empty tree at the grid's resolution ([`binvox_resolution`]); an error when that is
/// not a usable resolution (a scale of zero, say).
pub fn tree_for_binvox(grid: &Binvox) -> Result<OcTree, OctreeError> {
    OcTree::new(binvox_resolution(grid))
}

/// OctoMap's `Vector3::rotate_IP(roll, pitch, yaw)`: pitch about y, then yaw about z, then
/// roll about x, each step computed in `f64` from the `f32` components and stored as `f32`.
pub fn rotate_ip(p: &mut [f32; 3], roll: f64, pitch: f64, yaw: f64) {
    let (x, z) = (f64::from(p[0]), f64::from(p[2]));
    p[0] = (z * pitch.sin() + x * pitch.cos()) as f32;
    p[2] = (z * pitch.cos() - x * pitch.sin()) as f32;
    let (x, y) = (f64::from(p[0]), f64::from(p[1]));
    p[0] = (x * yaw.cos() - y * yaw.sin()) as f32;
    p[1] = (x * yaw.sin() + y * yaw.cos()) as f32;
    let (y, z) = (f64::from(p[1]), f64::from(p[2]));
    p[1] = (y * roll.cos() - z * roll.sin()) as f32;
    p[2] = (y * roll.sin() + z * roll.cos()) as f32;
}

/// The point of grid cell `(x, y, z)` as binvox2bt computes it (see the [module docs](self)).
pub fn cell_point(
    grid: &Binvox,
    res: f64,
    cell: [usize; 3],
    options: &BinvoxImport,
) -> Point3<f32> {
    let t = grid.translate;
    let mut p = [0f32; 3];
    for a in 0..3 {
        p[a] = (cell[a] as f64 * res + f64::from(t[a]) + 0.000001) as f32;
    }
    if options.rotate {
        rotate_ip(&mut p, std::f64::consts::FRAC_PI_2, 0.0, 0.0);
    }
    if let Some(o) = options.offset {
        for a in 0..3 {
            p[a] += o[a];
        }
    }
    Point3::from(p)
}

/// Insert a grid's cells into `tree` (see the [module docs](self)); inner nodes are left for
/// [`finish_import`].
pub fn import_binvox(tree: &mut OcTree, grid: &Binvox, options: &BinvoxImport) -> ImportStats {
    let res = binvox_resolution(grid);
    let mut st = ImportStats::default();
    let inside = |p: &Point3<f32>| match &options.bbx {
        None => true,
        Some((lo, hi)) => (0..3).all(|a| {
            let v = f64::from(p[a]);
            v <= hi[a] && v >= lo[a]
        }),
    };
    for (cell, value) in grid.cells_iter() {
        if value != 0 {
            st.voxels += 1;
        }
        let marks = options.mark_free || value == 1;
        if !marks && options.bbx.is_none() {
            continue;
        }
        let p = cell_point(grid, res, cell, options);
        if !inside(&p) {
            st.outside_box += 1;
            continue;
        }
        if !marks {
            continue;
        }
        let update = if value == 1 {
            Update::Hit
        } else {
            Update::Miss
        };
        let point = Point3::new(f64::from(p.x), f64::from(p.y), f64::from(p.z));
        match tree.update_point(&point, update, InnerNodes::Defer) {
            Ok(_) if value == 1 => st.hits += 1,
            Ok(_) => st.misses += 1,
            Err(_) => st.outside_map += 1,
        }
    }
    st
}

/// Bring the inner nodes up to date and prune, as binvox2bt does after the last grid.
pub fn finish_import(tree: &mut OcTree) {
    tree.update_inner_occupancy();
    tree.prune();
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::binvox::{parse_binvox, write_binvox};
    use std::path::Path;

    #[test]
    fn quarter_turn_about_x_maps_y_to_z() {
        let mut p = [1.0f32, 2.0, 3.0];
        rotate_ip(&mut p, std::f64::consts::FRAC_PI_2, 0.0, 0.0);
        assert_eq!(p[0], 1.0);
        assert!(
            (p[1] + 3.0).abs() < 1e-6 && (p[2] - 2.0).abs() < 1e-6,
            "{p:?}"
        );
    }

    #[test]
    fn voxels_become_hits_and_free_cells_misses_inside_the_box() {
        // 4 x 4 x 4 grid of 1 m: the voxel cells where x == y
        let dims = [4, 4, 4];
        let cells: Vec<u8> = (0..64).map(|j| u8::from(j / 16 == j % 4)).collect();
        let bytes = write_binvox(dims, [0.0, 0.0, 0.0], 4.0, &cells);
        let grid = parse_binvox(Path::new("g.binvox"), &bytes).unwrap();
        let mut tree = tree_for_binvox(&grid).unwrap();
        assert_eq!(tree.resolution(), 1.0);
        let st = import_binvox(&mut tree, &grid, &BinvoxImport::default());
        assert_eq!(
            (st.voxels, st.hits, st.misses, st.outside_box),
            (16, 16, 0, 0)
        );
        finish_import(&mut tree);
        for j in 0..64usize {
            let (x, y, z) = (j / 16, j % 4, (j / 4) % 4);
            let p = Point3::new(x as f64 + 0.5, y as f64 + 0.5, z as f64 + 0.5);
            assert_eq!(
                tree.probability_at(&p).map(|pr| pr > 0.5),
                (x == y).then_some(true)
            );
        }
        let opts = BinvoxImport {
            mark_free: true,
            bbx: Some((Point3::new(-1.0, -1.0, -1.0), Point3::new(1.5, 9.0, 9.0))),
            ..BinvoxImport::default()
        };
        let mut tree = tree_for_binvox(&grid).unwrap();
        let st = import_binvox(&mut tree, &grid, &opts);
        // x = 0 and 1 are inside: 32 cells, 8 of them voxels
        assert_eq!((st.hits, st.misses, st.outside_box), (8, 24, 32));
    }
}
