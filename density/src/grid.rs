//! The density reducer's store and its input stage: insertion and deletion with local repair.

use crate::spec::{
    cmp_points, sanitize_score, scaled_distance, CellIndex, GridSpec, Rank, Selection,
};
use crate::arena::ArenaRef;
use crate::index::{hash_index, SlotTable};
use crate::error::DensityError;
use std::cmp::Ordering;
use std::collections::{BTreeMap, BTreeSet};

/// What [`DensityGrid::insert`] did with a point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InsertOutcome {
    /// The point opened a new cell and represents it.
    NewCell,
    /// The point joined a cell and now represents it.
    Selected,
    /// The point joined a cell whose representative did not change.
    Member,
    /// NaN or infinite coordinate, or outside the index range: skipped and counted.
    Rejected,
    /// The grid already holds [`DensityGrid::MAX_POINTS`] points: skipped and counted as
    /// rejected.
    Full,
}

/// Running counts of the input stage.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct GridCounts {
    /// Points accepted into a cell.
    pub inserted: u64,
    /// Points skipped as NaN, infinite or out of range.
    pub rejected: u64,
    /// Points deleted again.
    pub removed: u64,
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
    /// Scaled squared distance of the representative to the cell centre (the output order).
    pub fn distance(&self) -> f64 {
        self.cell.rank.centre
    }
    /// Number of points in the cell.
    pub fn len(&self) -> usize {
        self.cell.len as usize
    }
    /// Always `false`: empty cells are removed.
    pub fn is_empty(&self) -> bool {
        self.cell.len == 0
    }
    /// All points in the cell, in no particular order.
    pub fn members(&self) -> impl ExactSizeIterator<Item = [f64; D]> + Clone + 'a {
        self.arena.members(self.cell.span())
    }
    /// The mean of the cell's members (not an input point in general).
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
    /// Its scaled squared distance to the cell centre.
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

/// The density reducer's store: an ordered index of cells, each with its members and chosen
/// point, plus the cells sorted by the chosen point's distance to the cell centre.
///
/// * `index`: the ordered index (a B-tree, the paper's red-black tree), cell index -> slot, for
///   iteration in lexicographic order.
/// * `lookup`: a hash index over the same cells, for the point look-ups of insertion, deletion
///   and the read cycle's neighbour checks.
/// * Slot `s` is `hot[s]` (what the read cycle reads) and `slots[s]` (the rest; after a batch
///   into an empty grid under the closest-to-centre rule, `packed[s]` until the first change,
///   see `DensityGrid::cell`); the members
///   of all cells share one arena, `points`, one contiguous span per cell (or `narrow`, the
///   same arena in `f32`, after a batch of `f32`-exact points into an empty grid; see
///   `arena.rs`).
/// * `by_distance`: the output order.
/// * `built`: the compact form of both orders that a batch into an empty grid leaves (see
///   `order.rs`): while it is `Some`, slot order is index order and both B-trees are
///   empty; the first change that needs them builds them.
///
/// Insertion and deletion are the input stage; [`DensityGrid::begin_cycle`] starts the output
/// stage (see `output.rs`). For two threads wrap it in
/// [`SharedDensityGrid`](crate::SharedDensityGrid).
#[derive(Debug, Clone)]
pub struct DensityGrid<const D: usize> {
    pub(crate) spec: GridSpec<D>,
    pub(crate) selection: Selection<D>,
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
    /// An empty grid that keeps the point closest to each cell centre.
    pub fn new(spec: GridSpec<D>) -> Self {
        Self::with_selection(spec, Selection::CentreClosest)
    }

    /// An empty grid with the given selection rule.
    pub fn with_selection(spec: GridSpec<D>, selection: Selection<D>) -> Self {
        DensityGrid {
            spec,
            selection,
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
    /// ([`InsertOutcome::Full`]) instead of overflowing.
    pub const MAX_POINTS: u64 = (1 << 31) - 1;

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

    /// Points currently stored (inserted minus removed).
    pub fn point_count(&self) -> u64 {
        self.counts.inserted - self.counts.removed
    }

    fn view(&self, slot: u32) -> CellView<'_, D> {
        CellView {
            hot: &self.hot[slot as usize],
            cell: self.cell(slot as usize),
            arena: self.arena(),
        }
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

    /// The record of slot `s`, if the slot exists.
    fn cell_opt(&self, s: usize) -> Option<Cell> {
        (s < self.hot.len()).then(|| self.cell(s))
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

    pub(crate) fn rank_of(
        &self,
        p: &[f64; D],
        index: &CellIndex<D>,
        mean: Option<&[f64; D]>,
    ) -> Rank {
        self.rank_near(p, &self.spec.cell_centre(index), mean)
    }

    /// [`Self::rank_of`] with the cell centre `c` already computed (same arithmetic).
    #[inline]
    pub(crate) fn rank_near(&self, p: &[f64; D], c: &[f64; D], mean: Option<&[f64; D]>) -> Rank {
        let centre = scaled_distance(p, c, self.spec.size());
        let primary = match &self.selection {
            Selection::CentreClosest => centre,
            Selection::MeanClosest => match mean {
                Some(m) => scaled_distance(p, m, self.spec.size()),
                None => centre,
            },
            Selection::Score(f) => sanitize_score(f(p)),
        };
        Rank { primary, centre }
    }

    fn slot_of(&mut self, index: &CellIndex<D>) -> Option<u32> {
        if let Some((i, s)) = &self.last {
            if i == index {
                return Some(*s);
            }
        }
        let s = self.find_slot(index)?;
        self.last = Some((*index, s));
        Some(s)
    }

    /// Open cell `index` with members `run` (copied to the end of the arena), representative
    /// `selected` ranked `rank`, in every index and the distance order; returns its slot.
    pub(crate) fn open_cell(
        &mut self,
        index: CellIndex<D>,
        run: &[[f64; D]],
        selected: usize,
        rank: Rank,
    ) -> u32 {
        self.widen();
        let start = self.points.len();
        self.points.extend_from_slice(run);
        let len = to_u32(run.len());
        self.reserved += run.len();
        self.generation += 1;
        let hot = Hot {
            index,
            point: run[selected],
            stamp: self.generation,
            mark: 0,
        };
        let cell = Cell {
            start,
            len,
            cap: len,
            selected: to_u32(selected),
            rank,
        };
        let slot = match self.free.pop() {
            Some(s) => {
                self.hot[s as usize] = hot;
                self.slots[s as usize] = cell;
                s
            }
            None => {
                self.hot.push(hot);
                self.slots.push(cell);
                new_slot(self.slots.len() - 1)
            }
        };
        let (ordered, by_distance) = self.trees();
        ordered.insert(index, slot);
        by_distance.insert((rank.centre.to_bits(), index, slot));
        self.lookup.insert(hash_index(&index), slot);
        slot
    }

    /// Append `run` to the members of slot `s`, moving the cell's span to the end of the arena
    /// (with room to double) when it is full.
    pub(crate) fn push_members(&mut self, s: usize, run: &[[f64; D]]) {
        self.widen();
        let (start, len, cap) = {
            let c = &self.slots[s];
            (c.start, c.len as usize, c.cap as usize)
        };
        let need = len + run.len();
        if start + cap == self.points.len() {
            // Last span of the arena: grow in place.
            self.points.truncate(start + len);
            self.points.extend_from_slice(run);
            self.reserved = self.reserved - cap + need;
            let c = &mut self.slots[s];
            c.len = to_u32(need);
            c.cap = c.len;
        } else if need <= cap {
            self.points[start + len..start + need].copy_from_slice(run);
            self.slots[s].len = to_u32(need);
        } else {
            let new_cap = need.max(2 * len);
            let new_start = self.points.len();
            self.points.extend_from_within(start..start + len);
            self.points.extend_from_slice(run);
            let pad = self.points[new_start];
            self.points.resize(new_start + new_cap, pad);
            self.reserved = self.reserved - cap + new_cap;
            let c = &mut self.slots[s];
            c.start = new_start;
            c.len = to_u32(need);
            c.cap = to_u32(new_cap);
        }
    }

    /// Rewrite the arena without abandoned spans and spare room once they make up most of it.
    pub(crate) fn maybe_compact(&mut self) {
        let live = self.point_count() as usize;
        if self.arena().len() <= 2 * live + 4096 {
            return;
        }
        self.widen();
        let mut arena = Vec::with_capacity(live);
        let order: Vec<u32> = self.index_slots().collect();
        for slot in order {
            let c = &mut self.slots[slot as usize];
            let start = arena.len();
            arena.extend_from_slice(&self.points[c.span()]);
            c.start = start;
            c.cap = c.len;
        }
        self.points = arena;
        self.reserved = live;
    }

    /// Input stage: add one point.
    ///
    /// NaN/infinite coordinates and points beyond the index range are skipped and counted in
    /// [`GridCounts::rejected`], and so are points beyond [`DensityGrid::MAX_POINTS`]. The
    /// result does not depend on insertion order.
    pub fn insert(&mut self, p: [f64; D]) -> InsertOutcome {
        let Some(index) = self.spec.cell_index(&p) else {
            self.counts.rejected += 1;
            return InsertOutcome::Rejected;
        };
        if self.point_count() >= self.max_points {
            self.counts.rejected += 1;
            return InsertOutcome::Full;
        }
        self.counts.inserted += 1;
        match self.slot_of(&index) {
            None => {
                let rank = self.rank_of(&p, &index, Some(&p));
                let slot = self.open_cell(index, &[p], 0, rank);
                self.last = Some((index, slot));
                InsertOutcome::NewCell
            }
            Some(slot) => {
                let s = slot as usize;
                self.push_members(s, &[p]);
                let outcome = if self.selection.needs_members() {
                    if self.reselect(s) {
                        InsertOutcome::Selected
                    } else {
                        InsertOutcome::Member
                    }
                } else {
                    let rank = self.rank_of(&p, &index, None);
                    if rank.cmp_with(&p, &self.slots[s].rank, &self.hot[s].point) == Ordering::Less
                    {
                        let new_sel = self.slots[s].len as usize - 1;
                        self.set_selected(s, new_sel, rank);
                        InsertOutcome::Selected
                    } else {
                        InsertOutcome::Member
                    }
                };
                self.maybe_compact();
                outcome
            }
        }
    }

    /// Add points that all lie in cell `index` (already counted as inserted) to the grid.
    pub(crate) fn insert_run(&mut self, index: CellIndex<D>, run: &[[f64; D]]) {
        match self.find_slot(&index) {
            None => {
                let (sel, rank) = self.best_in(&index, run);
                self.open_cell(index, run, sel, rank);
            }
            Some(slot) => {
                let s = slot as usize;
                if self.selection.needs_members() {
                    self.push_members(s, run);
                    self.reselect(s);
                    return;
                }
                let (k, rank) = self.best_in(&index, run);
                let base = self.cell(s).len as usize;
                self.push_members(s, run);
                let p = run[k];
                if rank.cmp_with(&p, &self.slots[s].rank, &self.hot[s].point) == Ordering::Less {
                    self.set_selected(s, base + k, rank);
                }
            }
        }
    }

    /// The best of `members` (all in cell `index`, at least one) under the selection rule, with
    /// its rank; the mean rule takes the mean of `members`.
    pub(crate) fn best_in(&self, index: &CellIndex<D>, members: &[[f64; D]]) -> (usize, Rank) {
        self.best_of(index, members.iter().copied())
    }

    /// [`Self::best_in`] over members given as an iterator (at least one).
    pub(crate) fn best_of<I>(&self, index: &CellIndex<D>, members: I) -> (usize, Rank)
    where
        I: Iterator<Item = [f64; D]> + Clone,
    {
        let c = self.spec.cell_centre(index);
        if let Selection::CentreClosest = self.selection {
            return centre_closest(&c, self.spec.size(), members);
        }
        let m = self
            .selection
            .needs_members()
            .then(|| mean(members.clone()));
        let mut it = members;
        let Some(first) = it.next() else {
            return (0, self.rank_near(&c, &c, m.as_ref()));
        };
        let mut best = (0, self.rank_near(&first, &c, m.as_ref()));
        let mut best_point = first;
        for (k, p) in it.enumerate() {
            let r = self.rank_near(&p, &c, m.as_ref());
            if r.cmp_with(&p, &best.1, &best_point) == Ordering::Less {
                best = (k + 1, r);
                best_point = p;
            }
        }
        best
    }

    /// Record member `sel` ranked `rank` as the representative of slot `s` (no bookkeeping).
    fn choose(&mut self, s: usize, sel: usize, rank: Rank) {
        self.unpack_cells();
        let cell = &mut self.slots[s];
        cell.selected = to_u32(sel);
        cell.rank = rank;
        let at = cell.point_at();
        self.hot[s].point = self.arena().get(at);
    }

    /// Make member `sel` the representative of slot `s`, keeping the distance order.
    fn set_selected(&mut self, s: usize, sel: usize, rank: Rank) {
        self.unpack_cells();
        self.generation += 1;
        let index = self.hot[s].index;
        let old = (self.slots[s].rank.centre.to_bits(), index, s as u32);
        let new = (rank.centre.to_bits(), index, s as u32);
        self.choose(s, sel, rank);
        self.hot[s].stamp = self.generation;
        if old != new {
            let (_, by_distance) = self.trees();
            by_distance.remove(&old);
            by_distance.insert(new);
        }
    }

    /// The best member of slot `s` under the selection rule, with its rank.
    pub(crate) fn best_member(&self, s: usize) -> (usize, Rank) {
        self.best_of(&self.hot[s].index, self.members_of(s))
    }

    /// Local repair: choose the representative of slot `s` again from its members.
    /// Returns `true` when the representative changed.
    fn reselect(&mut self, s: usize) -> bool {
        let (k, r) = self.best_member(s);
        let cell = self.cell(s);
        let changed = cmp_points(&self.arena().get(cell.start + k), &self.hot[s].point)
            != Ordering::Equal
            || r.centre.to_bits() != cell.rank.centre.to_bits();
        if changed {
            self.set_selected(s, k, r);
        } else {
            // Same point (perhaps a duplicate at another position): keep the rank fresh.
            self.choose(s, k, r);
        }
        changed
    }

    /// Input stage: delete one point equal (bit for bit) to `p`, repairing only its cell.
    ///
    /// When the deleted point represented the cell, the best remaining member takes over; when
    /// it was the last member, the cell is removed. Returns `false` when no such point is
    /// stored. Inserting points and deleting them again restores the earlier
    /// [`GridState`].
    pub fn remove(&mut self, p: &[f64; D]) -> bool {
        let Some(index) = self.spec.cell_index(p) else {
            return false;
        };
        let Some(slot) = self.slot_of(&index) else {
            return false;
        };
        let s = slot as usize;
        let Some(k) = self
            .members_of(s)
            .position(|m| cmp_points(&m, p) == Ordering::Equal)
        else {
            return false;
        };
        self.counts.removed += 1;
        self.trees();
        self.widen();
        let cell = &mut self.slots[s];
        let key = (cell.rank.centre.to_bits(), index, slot);
        if cell.len == 1 {
            self.reserved -= cell.cap as usize;
            cell.len = 0;
            cell.cap = 0;
            self.by_distance.remove(&key);
            self.index.remove(&index);
            self.lookup.remove(hash_index(&index), slot);
            // A free slot's record must never match a look-up by index (cell indexes are
            // within +-2^53, neighbours of them within +-(2^53 + 1)).
            self.hot[s].index = [i64::MIN; D];
            self.free.push(slot);
            self.last = None;
            self.generation += 1;
            if self.index.is_empty() {
                self.points.clear();
                self.reserved = 0;
            }
            self.maybe_compact();
            return true;
        }
        // Swap-remove member k within the span.
        let last = cell.len as usize - 1;
        let (start, was_selected) = (cell.start, cell.selected as usize == k);
        self.points[start + k] = self.points[start + last];
        cell.len -= 1;
        if was_selected {
            // The representative leaves: the best remaining member takes over.
            self.by_distance.remove(&key);
            let (sel, rank) = self.best_member(s);
            self.generation += 1;
            self.choose(s, sel, rank);
            self.hot[s].stamp = self.generation;
            self.by_distance
                .insert((rank.centre.to_bits(), index, slot));
        } else {
            if cell.selected as usize == last {
                cell.selected = to_u32(k);
            }
            if self.selection.needs_members() {
                self.reselect(s);
            }
        }
        self.maybe_compact();
        true
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

    /// Check every store invariant: both indexes, the cells, the arena and the distance order
    /// agree, spans do not overlap, every member lies in its cell, and each representative is
    /// the best member under the selection rule.
    pub fn validate(&self) -> Result<(), DensityError> {
        let bad = |what: String| Err(DensityError::Invariant { what });
        self.validate_orders().or_else(bad)?;
        let cells = self.cell_count();
        let distance_entries = match &self.built {
            Some(order) => order.len(),
            None => self.by_distance.len(),
        };
        if distance_entries != cells || self.lookup.len() != cells {
            return bad(format!(
                "{distance_entries} distance entries and {} hash entries for {cells} cells",
                self.lookup.len(),
            ));
        }
        if self.narrow.is_some() && !self.points.is_empty() {
            return bad("both arena forms hold points".to_string());
        }
        let slot_count = match &self.packed {
            Some(p) => p.len(),
            None => self.slots.len(),
        };
        if self.hot.len() != slot_count {
            return bad(format!(
                "{} hot records for {slot_count} slots",
                self.hot.len(),
            ));
        }
        if self.packed.is_some() && !self.slots.is_empty() {
            return bad("both cell record forms hold cells".to_string());
        }
        let mut points = 0u64;
        let mut reserved = 0usize;
        let mut spans = Vec::with_capacity(cells);
        // (index, slot) in index order: the compact form takes the index from the slot's
        // record (its slot order was checked to be index order).
        let entries: Vec<(CellIndex<D>, u32)> = match &self.built {
            Some(_) => self
                .index_slots()
                .map(|s| (self.hot[s as usize].index, s))
                .collect(),
            None => self.index.iter().map(|(i, &s)| (*i, s)).collect(),
        };
        for (index, slot) in &entries {
            let (index, slot) = (index, *slot);
            let (Some(cell), Some(hot)) =
                (self.cell_opt(slot as usize), self.hot.get(slot as usize))
            else {
                return bad(format!("cell {index:?} points to missing slot {slot}"));
            };
            if &hot.index != index {
                return bad(format!("slot {slot} holds {:?}, not {index:?}", hot.index));
            }
            if self.find_slot(index) != Some(slot) {
                return bad(format!("cell {index:?} missing from the hash index"));
            }
            if cell.len == 0 || cell.selected >= cell.len || cell.cap < cell.len {
                return bad(format!("cell {index:?} empty or bad selection"));
            }
            if cell.start + cell.cap as usize > self.arena().len() {
                return bad(format!("cell {index:?} reaches beyond the arena"));
            }
            spans.push((cell.start, cell.start + cell.cap as usize));
            points += u64::from(cell.len);
            reserved += cell.cap as usize;
            let members = self.members_of(slot as usize);
            for m in members.clone() {
                if self.spec.cell_index(&m).as_ref() != Some(index) {
                    return bad(format!("member {m:?} is not in cell {index:?}"));
                }
            }
            let chosen = &self.arena().get(cell.point_at());
            if cmp_points(chosen, &hot.point) != Ordering::Equal {
                return bad(format!("cell {index:?}: stale copy of the chosen point"));
            }
            let mean_pt = mean(members.clone());
            let m = self.selection.needs_members().then_some(&mean_pt);
            let sel_rank = self.rank_of(chosen, index, m);
            if sel_rank.centre.to_bits() != cell.rank.centre.to_bits() {
                return bad(format!("cell {index:?} has a stale distance"));
            }
            for p in members {
                let r = self.rank_of(&p, index, m);
                if r.cmp_with(&p, &sel_rank, chosen) == Ordering::Less {
                    return bad(format!(
                        "cell {index:?}: member {p:?} beats the chosen point"
                    ));
                }
            }
            if !self.distance_order_has(cell.rank.centre.to_bits(), index, slot) {
                return bad(format!("cell {index:?} missing from the distance order"));
            }
        }
        for &f in &self.free {
            let free_ok = self.cell_opt(f as usize).is_some_and(|c| c.len == 0)
                && self
                    .hot
                    .get(f as usize)
                    .is_some_and(|h| h.index == [i64::MIN; D]);
            if !free_ok {
                return bad(format!("free slot {f} is in use or still matches a cell"));
            }
        }
        if self.free.len() + cells != self.hot.len() {
            return bad(format!(
                "{} free and {cells} used slots of {}",
                self.free.len(),
                self.hot.len()
            ));
        }
        spans.sort_unstable();
        if spans.windows(2).any(|w| w[0].1 > w[1].0) {
            return bad("two cells share arena places".to_string());
        }
        if reserved != self.reserved {
            return bad(format!(
                "{reserved} arena places reserved, the store says {}",
                self.reserved
            ));
        }
        if points != self.point_count() {
            return bad(format!(
                "{points} points stored, counts say {}",
                self.point_count()
            ));
        }
        Ok(())
    }
}

/// The [`Selection::CentreClosest`] choice among `members` (at least one; cell centre `c`,
/// axes scaled by `size`): the rank's primary criterion is the centre distance itself, so one
/// comparison of distances, then of coordinates (the same order as `Rank::cmp_with`).
#[inline]
pub(crate) fn centre_closest<const D: usize>(
    c: &[f64; D],
    size: &[f64; D],
    members: impl Iterator<Item = [f64; D]>,
) -> (usize, Rank) {
    let mut best = (0, f64::INFINITY, *c);
    for (k, p) in members.enumerate() {
        let d = scaled_distance(&p, c, size);
        if k == 0
            || d.total_cmp(&best.1)
                .then_with(|| cmp_points(&p, &best.2))
                .is_lt()
        {
            best = (k, d, p);
        }
    }
    let rank = Rank {
        primary: best.1,
        centre: best.1,
    };
    (best.0, rank)
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

/// The mean of some points (zeros for none), summed in their order.
pub(crate) fn mean<const D: usize>(points: impl IntoIterator<Item = [f64; D]>) -> [f64; D] {
    let mut m = [0.0; D];
    let mut n = 0usize;
    for p in points {
        for k in 0..D {
            m[k] += p[k];
        }
        n += 1;
    }
    if n == 0 {
        return m;
    }
    let n = n as f64;
    for v in &mut m {
        *v /= n;
    }
    m
}
