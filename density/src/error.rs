//! The crate's one error type.

/// Errors from building or driving a density grid.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum DensityError {
    /// A grid needs at least one axis.
    #[error("a grid needs at least one axis")]
    NoAxes,
    /// A cell size is zero, negative, NaN or infinite.
    #[error("cell size on axis {axis} must be finite and > 0, got {value}")]
    InvalidCellSize {
        /// Axis number, from 0.
        axis: usize,
        /// The rejected size.
        value: f64,
    },
    /// A grid offset is NaN or infinite.
    #[error("grid offset on axis {axis} must be finite, got {value}")]
    InvalidOffset {
        /// Axis number, from 0.
        axis: usize,
        /// The rejected offset.
        value: f64,
    },
    /// An output cycle was stepped after a newer cycle had begun on the same grid.
    #[error("output cycle {cycle} is stale: cycle {current} has begun since")]
    StaleCycle {
        /// The cycle that was stepped.
        cycle: u64,
        /// The grid's current cycle.
        current: u64,
    },
    /// [`Storage::OneNode`](crate::Storage::OneNode) with a selection rule that needs every
    /// member of a cell ([`Selection::MeanClosest`](crate::Selection::MeanClosest)).
    #[error("the one-node storage keeps one point per cell; the mean rule needs all members")]
    SelectionNeedsMembers,
    /// A store invariant does not hold (found by `DensityGrid::validate`; a bug).
    #[error("density grid invariant violated: {what}")]
    Invariant {
        /// What was wrong.
        what: String,
    },
}
