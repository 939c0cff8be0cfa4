//! The density reducer's store: the [`DensityGrid`] struct, its cells' records, construction,
//! counts and the look-up of a cell's slot.

use super::lookup::{hash_index, SlotTable};
use crate::error::DensityError;
use crate::selection::{Rank, Selection};
use crate::spec::{CellIndex, GridSpec};
use crate::storage::Storage;
use std::collections::{BTreeMap, BTreeSet};

/// Running counts of the input stage.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct GridCounts {
    /// Points accepted into a cell.
    pub inserted: u64,
    /// Points skipped as NaN, infinite or out of range.
    pub rejected: u64,
    /// Points deleted again.
    pub removed: u64,
    /// Points no longer stored because a better point holds their cell: under
    /// [`Storage::OneNode`] every accepted point except the cells' kept ones; always 0 under
    /// [`Storage::AllMembers`].
    pub discarded: u64,
}

/// The part of a cell that the read cycle touches (one cache line for D = 3): its index for the
/// hash index's key check, a copy of its representative, and the stamps.
#[derive(Debug, Clone, Copy)]
#[repr(align(64))]
pub(crate) struct Hot<const D: usize> {
    pub index: CellIndex<D>,
    /// The representative (a copy of member `selected`).
    pub point: [f64; D],
    /// Input generation at which the cell was created or its representative last changed.
    pub stamp: u64,
    /// Id of the last output cycle that emitted or eliminated this cell.
    pub mark: u64,
}

/// The rest of a cell. Its members live in the grid's member arena at `start..start + len`;
/// the arena holds `cap >= len` places for it.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Cell {
    /// First member in the arena.
    pub start: usize,
    /// Number of members (0 only for a free slot).
    pub len: u32,
    /// Places reserved in the arena from `start`.
    pub cap: u32,
    /// Position of the representative among the members.
    pub selected: u32,
    /// The representative's rank under the selection rule.
    pub rank: Rank,
}

/// A cell's record in the packed form that a batch into an empty grid leaves under the
/// closest-to-centre rule (16 bytes instead of a [`Cell`]'s 40; see
/// [`DensityGrid::cell`]): spans are back to back in slot order, each with no spare room, and
/// the rank's primary criterion is the centre distance.
#[derive(Debug, Clone, Copy)]
pub(crate) struct PackedCell {
    /// End of the span (the next slot's start); below 2^31 as the arena holds one batch.
    pub end: u32,
    /// Position of the representative among the members.
    pub selected: u32,
    /// The representative's centre distance.
    pub centre: f64,
}

impl Cell {
    /// Arena position of the representative.
    #[inline]
    pub(crate) fn point_at(&self) -> usize {
        self.start + self.selected as usize
    }

    /// Arena range of the members.
    #[inline]
    pub(crate) fn span(&self) -> std::ops::Range<usize> {
        self.start..self.start + self.len as usize
    }
}

/// A member count or position as the `u32` a cell stores. Never fails: a grid holds at most
/// [`DensityGrid::MAX_POINTS`] (2^31 - 1) points, so a count, and a capacity of at most twice
/// one, stays below 2^32.
pub(crate) fn to_u32(n: usize) -> u32 {
    u32::try_from(n).expect("more than 2^32 - 1 points in one cell")
}

/// The density reducer's store: an ordered index of cells, each with its members and chosen
/// point, plus the cells sorted by the chosen point's distance to the cell centre.
///
/// * `index`: the ordered index (a B-tree, the paper's red-black tree), cell index -> slot, for
///   iteration in lexicographic order.
/// * `lookup`: a hash index over the same cells, for the point look-ups of insertion, deletion
///   and the read cycle's neighbour checks.
/// * Slot `s` is `hot[s]` (what the read cycle reads) and `slots[s]` (the rest; after a batch
///   into an empty grid under the closest-to-centre rule, `packed[s]` until the first change,
///   see `DensityGrid::cell`); the members of all cells share one arena, `points`, one
///   contiguous span per cell (or `narrow`, the same arena in `f32`, after a batch of
///   `f32`-exact points into an empty grid; see `grid/arena.rs`).
/// * `by_distance`: the output order.
/// * `built`: the compact form of both orders that a batch into an empty grid leaves (see
///   `grid/order.rs`): while it is `Some`, slot order is index order and both B-trees are
///   empty; the first change that needs them builds them.
///
/// Insertion and deletion are the input stage; [`DensityGrid::begin_cycle`] starts the output
/// stage (see `output.rs`). The `impl` is split by concern over the files of `grid/` (see its
/// `mod.rs`). For two threads wrap it in [`SharedDensityGrid`](crate::SharedDensityGrid).
#[derive(Debug, Clone)]
pub struct DensityGrid<const D: usize> {
    pub(crate) spec: GridSpec<D>,
    pub(crate) selection: Selection<D>,
    /// What a cell stores: its kept point only, or all its members.
    pub(crate) storage: Storage,
    /// Ordered index: cell index -> slot.
    pub(crate) index: BTreeMap<CellIndex<D>, u32>,
    /// Hash index: cell index -> slot.
    pub(crate) lookup: SlotTable,
    pub(crate) hot: Vec<Hot<D>>,
    pub(crate) slots: Vec<Cell>,
    /// The cells' records in packed form, when `Some` (`slots` is then empty); see
    /// [`DensityGrid::cell`].
    pub(crate) packed: Option<Vec<PackedCell>>,
    pub(crate) free: Vec<u32>,
    /// Member arena: every cell's members, one contiguous span per cell.
    pub(crate) points: Vec<[f64; D]>,
    /// The arena in `f32` form, when `Some` (`points` is then empty; see `arena.rs`).
    pub(crate) narrow: Option<Vec<[f32; D]>>,
    /// Sum of the live cells' `cap`: the arena beyond it is abandoned spans.
    pub(crate) reserved: usize,
    /// `(distance bits, cell index, slot)`: ascending distance, ties by index.
    pub(crate) by_distance: BTreeSet<(u64, CellIndex<D>, u32)>,
    /// Compact form of both orders: `(distance bits, slot)` ascending, slots in index order.
    pub(crate) built: Option<Vec<(u64, u32)>>,
    /// Last cell touched: consecutive scan points often share a cell.
    pub(crate) last: Option<(CellIndex<D>, u32)>,
    pub(crate) generation: u64,
    pub(crate) cycle: u64,
    pub(crate) counts: GridCounts,
    /// Most points the grid holds at once ([`DensityGrid::MAX_POINTS`]; lower in tests).
    pub(crate) max_points: u64,
}

impl<const D: usize> DensityGrid<D> {
    /// An empty grid that keeps the point closest to each cell centre and stores every member
    /// ([`Storage::AllMembers`]: any point can be deleted again).
    pub fn new(spec: GridSpec<D>) -> Self {
        Self::with_selection(spec, Selection::CentreClosest)
    }

    /// The paper's streaming store: the point closest to each cell centre, one node per
    /// non-empty cell ([`Storage::OneNode`]): memory grows with the cells, not the points;
    /// only kept points can be deleted.
    pub fn streaming(spec: GridSpec<D>) -> Self {
        DensityGrid {
            storage: Storage::OneNode,
            ..Self::new(spec)
        }
    }

    /// An empty grid with the given selection rule, storing every member
    /// ([`Storage::AllMembers`]).
    pub fn with_selection(spec: GridSpec<D>, selection: Selection<D>) -> Self {
        DensityGrid {
            spec,
            selection,
            storage: Storage::AllMembers,
            index: BTreeMap::new(),
            lookup: SlotTable::default(),
            hot: Vec::new(),
            slots: Vec::new(),
            packed: None,
            free: Vec::new(),
            points: Vec::new(),
            narrow: None,
            reserved: 0,
            by_distance: BTreeSet::new(),
            built: None,
            last: None,
            generation: 0,
            cycle: 0,
            counts: GridCounts::default(),
            max_points: Self::MAX_POINTS,
        }
    }

    /// Most points a grid holds at once (2^31 - 1): cells store member counts, capacities and
    /// slots as `u32`, and a cell's capacity may double. Points beyond it are refused
    /// ([`InsertOutcome::Full`](crate::InsertOutcome::Full)) instead of overflowing.
    pub const MAX_POINTS: u64 = (1 << 31) - 1;

    /// An empty grid with the given selection rule and storage.
    ///
    /// Errors with [`DensityError::SelectionNeedsMembers`] for [`Storage::OneNode`] with
    /// [`Selection::MeanClosest`] (the mean of a cell needs all its members).
    pub fn with_storage(
        spec: GridSpec<D>,
        selection: Selection<D>,
        storage: Storage,
    ) -> Result<Self, DensityError> {
        if storage.one_node() && selection.needs_members() {
            return Err(DensityError::SelectionNeedsMembers);
        }
        Ok(DensityGrid {
            storage,
            ..Self::with_selection(spec, selection)
        })
    }

    /// A grid that holds at most `max` points, to test the refusal without 2^31 of them.
    #[cfg(test)]
    pub(crate) fn with_max_points(spec: GridSpec<D>, max: u64) -> Self {
        DensityGrid {
            max_points: max.min(Self::MAX_POINTS),
            ..Self::new(spec)
        }
    }

    /// The grid geometry.
    pub fn spec(&self) -> &GridSpec<D> {
        &self.spec
    }

    /// The selection rule.
    pub fn selection(&self) -> &Selection<D> {
        &self.selection
    }

    /// What each cell stores.
    pub fn storage(&self) -> Storage {
        self.storage
    }

    /// Number of non-empty cells (the size of the grid stage's output).
    pub fn len(&self) -> usize {
        self.cell_count()
    }

    /// `true` when no cell holds a point.
    pub fn is_empty(&self) -> bool {
        self.cell_count() == 0
    }

    /// Running input counts.
    pub fn counts(&self) -> GridCounts {
        self.counts
    }

    /// Points currently stored: inserted minus removed minus discarded (under
    /// [`Storage::OneNode`] the number of cells).
    pub fn point_count(&self) -> u64 {
        self.counts.inserted - self.counts.removed - self.counts.discarded
    }

    /// The record of slot `s`, from `slots` or derived from the packed form.
    #[inline]
    pub(crate) fn cell(&self, s: usize) -> Cell {
        match &self.packed {
            None => self.slots[s],
            Some(packed) => {
                let start = match s.checked_sub(1) {
                    Some(prev) => packed[prev].end as usize,
                    None => 0,
                };
                let c = &packed[s];
                let len = c.end - start as u32;
                Cell {
                    start,
                    len,
                    cap: len,
                    selected: c.selected,
                    rank: Rank {
                        primary: c.centre,
                        centre: c.centre,
                    },
                }
            }
        }
    }

    /// Switch the cells' records to `slots` (a no-op when already there): before any change to
    /// a cell.
    pub(crate) fn unpack_cells(&mut self) {
        if self.packed.is_some() {
            let cells = (0..self.hot.len()).map(|s| self.cell(s)).collect();
            self.slots = cells;
            self.packed = None;
        }
    }

    /// The slot of cell `index`, through the hash index.
    #[inline]
    pub(crate) fn find_slot(&self, index: &CellIndex<D>) -> Option<u32> {
        let hot = &self.hot;
        self.lookup
            .find(hash_index(index), |s| hot[s as usize].index == *index)
    }

    /// [`Self::find_slot`] that remembers the cell as the last one touched, and asks that first
    /// (consecutive scan points often share a cell).
    pub(super) fn slot_of(&mut self, index: &CellIndex<D>) -> Option<u32> {
        if let Some((i, s)) = &self.last {
            if i == index {
                return Some(*s);
            }
        }
        let s = self.find_slot(index)?;
        self.last = Some((*index, s));
        Some(s)
    }
}

/// Slot number `n` (slot `u32::MAX` is reserved for the hash index's empty bucket). Never
/// fails: live cells, and a batch's distinct cells, number at most
/// [`DensityGrid::MAX_POINTS`].
pub(crate) fn new_slot(n: usize) -> u32 {
    match u32::try_from(n) {
        Ok(s) if s != u32::MAX => s,
        _ => panic!("more than 2^32 - 2 cells"),
    }
}
