//! The **online grid density reducer** ("An online density reduction algorithm for
//! non-homogenous multidimensional datasets"): dense regions are thinned to about one point per
//! grid cell, sparse regions keep their points, and no point is invented.
//!
//! * [`GridSpec`]: per-axis cell sizes and offsets; cell index `floor((x - offset) / size)`;
//!   distances to a cell's centre are Euclidean in the input's units, the paper's Eq. 3
//!   ([`CentreDistance::Euclidean`]), or optionally in cell units per axis
//!   ([`CentreDistance::CellUnits`]; the same order when all sizes are equal).
//! * [`DensityGrid`]: the store, in one of two [`Storage`]s: the paper's one node per non-empty
//!   cell holding only its best point ([`Storage::OneNode`], [`DensityGrid::streaming`]: memory
//!   grows with the cells, not the points; only a kept point can be deleted, and that removes
//!   its cell), or all members of every cell ([`Storage::AllMembers`], [`DensityGrid::new`]:
//!   any point can be deleted and the next best takes over). Both keep the same points on an
//!   insert-only stream. [`DensityGrid::insert`] and [`DensityGrid::remove`] are the
//!   input stage, [`DensityGrid::extend`] (or [`DensityGrid::extend_rewalk`]) its batch form;
//!   [`Selection`] picks each cell's point (closest to the centre, closest to the mean, or a
//!   caller's score).
//! * [`OutputCycle`]: the output stage, one read cycle at a time, eliminating a neighbour whose
//!   point is within half a cell on every axis of an emitted one.
//! * [`SharedDensityGrid`]: both stages on two threads over one store.
//! * [`reduce()`], [`reduce_points`]: one call for a whole cloud.
//!
//! The two stages may overlap in time:
//!
//! * **input** ([`DensityGrid::insert`], [`DensityGrid::remove`]): each point goes to the cell
//!   `floor((x - offset) / size)` per axis. The cells sit in an ordered index (a `BTreeMap`
//!   keyed by the cell index, the paper's red-black tree; after a batch into an empty grid
//!   simply the slot order until the first change) and, for look-ups, in a hash index over
//!   the same keys. A cell keeps the member chosen by its [`Selection`] rule, and all
//!   cells stay sorted by the distance of that point to the cell centre. Deleting a point
//!   repairs only its own cell.
//! * **output** ([`DensityGrid::begin_cycle`], [`DensityGrid::step_cycle`]): a read cycle with
//!   its own id visits the cells in ascending distance; each visited point is emitted, and a
//!   point of any of the 3^D - 1 neighbouring cells that lies closer than half a cell size on
//!   every axis is skipped for this cycle. Cells created or changed after the cycle began are
//!   left to the next cycle.
//!
//! **The guarantee** of a read cycle over a grid that did not change during it, exactly: no two emitted points lie within half
//! a cell of each other on every axis at once (`|a_k - b_k| < size_k / 2` for all `k`, the
//! paper's Eq. 4). It is not a minimum spacing on each axis: two emitted points may be close
//! on some axes as long as they are at least half a cell apart on one. Points of cells that
//! are not neighbours are at least a full cell apart on some axis, so only the 3^D - 1
//! neighbours need checking.
//!
//! Files: `spec.rs` the grid geometry ([`GridSpec`]), `selection.rs` the selection rules,
//! `storage.rs` what a cell stores ([`Storage`]),
//! `grid/` the store and its input stage (one file per concern, see its `mod.rs`), `output.rs`
//! the read cycles, `shared.rs` the two-thread wrapper, `reduce.rs` the one-call helpers and
//! `error.rs` the crate's error type.
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

mod error;
mod grid;
mod output;
mod reduce;
mod selection;
mod shared;
mod spec;
mod storage;

pub use error::DensityError;
pub use grid::{CellState, CellView, DensityGrid, GridCounts, GridState, InsertOutcome};
pub use output::{CycleCounts, OutputCycle};
pub use reduce::{reduce, reduce_points, reduce_points_counted, ReduceCounts};
pub use selection::{ScoreFn, Selection};
pub use shared::SharedDensityGrid;
pub use spec::{CellIndex, CentreDistance, GridSpec, MAX_CELL_INDEX};
pub use storage::Storage;

#[cfg(test)]
mod tests;
