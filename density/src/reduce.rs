//! One-call helpers: fill a grid, run one read cycle, report the counts.

use crate::error::DensityError;
use crate::grid::DensityGrid;
use crate::spec::GridSpec;
use nalgebra::Point3;

/// Point counts through the two stages of a reduction.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ReduceCounts {
    /// Points offered.
    pub input: u64,
    /// Points skipped as NaN, infinite or out of range.
    pub rejected: u64,
    /// Points after the grid stage: one per non-empty cell.
    pub grid: u64,
    /// Points after elimination of close neighbours: the output.
    pub output: u64,
}

/// Reduce `points` with the closest-to-centre rule and one read cycle.
///
/// The output is a subset of the input in output order (ascending distance to the cell
/// centre); it does not depend on the input order.
pub fn reduce<const D: usize>(
    points: impl IntoIterator<Item = [f64; D]>,
    spec: GridSpec<D>,
) -> (Vec<[f64; D]>, ReduceCounts) {
    let mut grid = DensityGrid::new(spec);
    grid.extend(points);
    finish(grid)
}

/// One read cycle of a filled grid, with the counts.
fn finish<const D: usize>(mut grid: DensityGrid<D>) -> (Vec<[f64; D]>, ReduceCounts) {
    let c = grid.counts();
    let grid_len = grid.len() as u64;
    let (out, _) = grid.output_cycle();
    let counts = ReduceCounts {
        input: c.inserted + c.rejected,
        rejected: c.rejected,
        grid: grid_len,
        output: out.len() as u64,
    };
    (out, counts)
}

/// Reduce a 3D cloud with cell sizes `cell` (offset 0), also returning the counts.
///
/// Errors only for an invalid cell size; NaN/infinite points are skipped and counted.
pub fn reduce_points_counted(
    points: &[Point3<f32>],
    cell: [f64; 3],
) -> Result<(Vec<Point3<f32>>, ReduceCounts), DensityError> {
    let mut grid = DensityGrid::new(GridSpec::with_sizes(cell)?);
    grid.extend_rewalk(
        points
            .iter()
            .map(|p| [f64::from(p.x), f64::from(p.y), f64::from(p.z)]),
    );
    let (out, counts) = finish(grid);
    // f32 -> f64 -> f32 is exact, so the output points are input points bit for bit.
    let out = out
        .into_iter()
        .map(|p| Point3::new(p[0] as f32, p[1] as f32, p[2] as f32))
        .collect();
    Ok((out, counts))
}

/// Reduce a 3D cloud with cell sizes `cell` (offset 0): the pre-pass for `octoquant map
/// --reduce`. Errors only for an invalid cell size; NaN/infinite points are dropped.
pub fn reduce_points(
    points: &[Point3<f32>],
    cell: [f64; 3],
) -> Result<Vec<Point3<f32>>, DensityError> {
    reduce_points_counted(points, cell).map(|(p, _)| p)
}
