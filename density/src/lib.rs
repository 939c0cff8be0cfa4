//! The **online grid density reducer** ("An online density reduction algorithm for
//! non-homogenous multidimensional datasets"): dense regions are thinned to about one point per
//! grid cell, sparse regions keep their points, and no point is invented.
//!
//! * [`GridSpec`]: per-axis cell sizes and offsets; cell index `floor((x - offset) / size)`.
//! * [`DensityGrid`]: the store. [`DensityGrid::insert`] and [`DensityGrid::remove`] are the
//!   input stage, [`DensityGrid::extend`] (or [`DensityGrid::extend_rewalk`]) its batch form;
//!   [`Selection`] picks each cell's point (closest to the centre, closest to the mean, or a
//!   caller's score).
//! * [`OutputCycle`]: the output stage, one read cycle at a time, eliminating a neighbour whose
//!   point is within half a cell on every axis of an emitted one.
//! * [`SharedDensityGrid`]: both stages on two threads over one store.
//! * [`reduce`], [`reduce_points`]: one call for a whole cloud.
//!
//! ```
//! use octoquant_density::{DensityGrid, GridSpec};
//!
//! let mut grid = DensityGrid::new(GridSpec::with_sizes([1.0, 1.0]).unwrap());
//! for p in [[0.1, 0.1], [0.6, 0.45], [1.05, 0.5], [3.5, 3.5], [f64::NAN, 0.0]] {
//!     grid.insert(p);
//! }
//! assert_eq!(grid.counts().rejected, 1);
//! assert_eq!(grid.len(), 3); // cells (0,0), (1,0), (3,3)
//! let (out, counts) = grid.output_cycle();
//! // (3.5, 3.5) sits on its centre and goes first, then (0.6, 0.45); (1.05, 0.5) in the next cell is
//! // closer than half a cell on both axes, so it is eliminated.
//! assert_eq!(out, vec![[3.5, 3.5], [0.6, 0.45]]);
//! assert_eq!(counts.eliminated, 1);
//! ```
#![deny(missing_docs)]
#![forbid(unsafe_code)]

mod arena;
mod batch;
mod error;
mod grid;
mod index;
mod order;
mod output;
mod reduce;
mod shared;
mod spec;

pub use error::DensityError;
pub use grid::{CellState, CellView, DensityGrid, GridCounts, GridState, InsertOutcome};
pub use output::{CycleCounts, OutputCycle};
pub use reduce::{reduce, reduce_points, reduce_points_counted, ReduceCounts};
pub use shared::SharedDensityGrid;
pub use spec::{CellIndex, GridSpec, ScoreFn, Selection, MAX_CELL_INDEX};

#[cfg(test)]
mod tests;
