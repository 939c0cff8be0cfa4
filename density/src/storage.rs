//! What a cell stores: only its kept point (the paper's one node per cell) or all its members.

/// What each cell of a [`DensityGrid`](crate::DensityGrid) stores.
///
/// Both storages keep the same point in every cell on an insert-only stream (the point ranked
/// best by the [`Selection`](crate::Selection) rule among all points that reached the cell),
/// so their read cycles emit the same points. They differ in memory and in what can be
/// deleted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Storage {
    /// The paper's storage: one node per non-empty cell, holding only the cell's current best
    /// point. A point that does not beat it is dropped on arrival, and a beaten one is
    /// overwritten, so memory grows with the number of cells, not of points (the streaming
    /// default: [`DensityGrid::streaming`](crate::DensityGrid::streaming)).
    ///
    /// Deletion ([`DensityGrid::remove`](crate::DensityGrid::remove)) works only on the kept
    /// point, and then removes the whole cell: the points it beat were not stored, so none
    /// can take over. Deleting any other point is a no-op that returns `false`. Not
    /// available with [`Selection::MeanClosest`](crate::Selection::MeanClosest), whose choice
    /// needs every member.
    OneNode,
    /// Every member of every cell is stored: any point can be deleted again, and the best
    /// remaining member then takes over, so inserting and deleting points restores the earlier
    /// state exactly. Memory grows with the number of points. The storage of
    /// [`DensityGrid::new`](crate::DensityGrid::new).
    AllMembers,
}

impl Storage {
    /// `true` for [`Storage::OneNode`].
    pub(crate) fn one_node(self) -> bool {
        matches!(self, Storage::OneNode)
    }
}
