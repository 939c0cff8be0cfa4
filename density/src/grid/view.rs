//! Read access to the store: a view of one cell, the cells in index or output order, and the
//! order-independent content of a whole grid ([`GridState`]).

use super::arena::ArenaRef;
use super::store::{Cell, DensityGrid, Hot};
use crate::selection::mean;
use crate::spec::{cmp_points, CellIndex};

/// Read-only view of one cell.
#[derive(Debug, Clone, Copy)]
pub struct CellView<'a, const D: usize> {
    hot: &'a Hot<D>,
    cell: Cell,
    arena: ArenaRef<'a, D>,
}

impl<'a, const D: usize> CellView<'a, D> {
    /// The cell's index.
    pub fn index(&self) -> CellIndex<D> {
        self.hot.index
    }
    /// The point representing the cell (always one of its members).
    pub fn point(&self) -> [f64; D] {
        self.hot.point
    }
    /// Squared distance of the representative to the cell centre (the output order), as the
    /// grid's [`crate::CentreDistance`] measures it.
    pub fn distance(&self) -> f64 {
        self.cell.rank.centre
    }
    /// Number of points the cell stores (1 under [`crate::Storage::OneNode`]).
    pub fn len(&self) -> usize {
        self.cell.len as usize
    }
    /// Always `false`: empty cells are removed.
    pub fn is_empty(&self) -> bool {
        self.cell.len == 0
    }
    /// All points the cell stores, in no particular order (only the kept point under
    /// [`crate::Storage::OneNode`]).
    pub fn members(&self) -> impl ExactSizeIterator<Item = [f64; D]> + Clone + 'a {
        self.arena.members(self.cell.span())
    }
    /// The mean of the cell's stored members (not an input point in general).
    pub fn mean(&self) -> [f64; D] {
        mean(self.members())
    }
}

/// One cell of a [`GridState`].
#[derive(Debug, Clone, PartialEq)]
pub struct CellState<const D: usize> {
    /// The cell index.
    pub index: CellIndex<D>,
    /// The representative point.
    pub point: [f64; D],
    /// Its squared distance to the cell centre, as the grid's
    /// [`crate::CentreDistance`] measures it.
    pub distance: f64,
    /// All members, sorted lexicographically.
    pub members: Vec<[f64; D]>,
}

/// The order-independent content of a grid, for comparing two grids.
///
/// Holds every cell with its sorted members, representative and distance, and the distance
/// order; leaves out bookkeeping that no output depends on once no cycle runs (stamps, cycle
/// ids, counters, arena layout).
#[derive(Debug, Clone, PartialEq)]
pub struct GridState<const D: usize> {
    /// Every cell, in index order.
    pub cells: Vec<CellState<D>>,
    /// Cell indexes in output (ascending distance) order.
    pub distance_order: Vec<CellIndex<D>>,
}

impl<const D: usize> DensityGrid<D> {
    /// The view of the cell in `slot`.
    fn view(&self, slot: u32) -> CellView<'_, D> {
        CellView {
            hot: &self.hot[slot as usize],
            cell: self.cell(slot as usize),
            arena: self.arena(),
        }
    }

    /// The cell `index`, if it holds a point.
    pub fn get(&self, index: &CellIndex<D>) -> Option<CellView<'_, D>> {
        self.find_slot(index).map(|s| self.view(s))
    }

    /// All cells in lexicographic index order.
    pub fn cells(&self) -> impl Iterator<Item = CellView<'_, D>> + '_ {
        self.index_slots().map(move |s| self.view(s))
    }

    /// All cells in output order: ascending distance of their point to the centre.
    pub fn cells_by_distance(&self) -> impl Iterator<Item = CellView<'_, D>> + '_ {
        self.distance_slots_after(None)
            .map(move |(_, s)| self.view(s))
    }

    /// The grid stage's result: one point per cell, in index order.
    pub fn selected_points(&self) -> Vec<[f64; D]> {
        self.cells().map(|c| c.point()).collect()
    }

    /// The order-independent content, for comparing grids (see [`GridState`]).
    pub fn state(&self) -> GridState<D> {
        let cells = self
            .cells()
            .map(|c| {
                let mut m: Vec<[f64; D]> = c.members().collect();
                m.sort_by(cmp_points);
                CellState {
                    index: c.index(),
                    point: c.point(),
                    distance: c.distance(),
                    members: m,
                }
            })
            .collect();
        let distance_order = self
            .distance_slots_after(None)
            .map(|(_, s)| self.hot[s as usize].index)
            .collect();
        GridState {
            cells,
            distance_order,
        }
    }
}
