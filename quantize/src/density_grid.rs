//! The density reducer's store and its input stage: insertion and deletion with local repair.

use crate::density::{
    cmp_points, sanitize_score, scaled_distance, CellIndex, GridSpec, Rank, Selection,
};
use crate::error::QuantizeError;
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

/// One cell of the store.
#[derive(Debug, Clone)]
pub(crate) struct Cell<const D: usize> {
    pub index: CellIndex<D>,
    /// Every point in the cell, kept so that deletion can repair the cell locally.
    pub members: Vec<[f64; D]>,
    /// Position of the representative in `members`.
    pub selected: usize,
    /// The representative's rank under the selection rule.
    pub rank: Rank,
    /// Input generation at which the cell was created or its representative last changed.
    pub stamp: u64,
    /// Id of the last output cycle that emitted or eliminated this cell.
    pub mark: u64,
}

impl<const D: usize> Cell<D> {
    pub(crate) fn point(&self) -> &[f64; D] {
        &self.members[self.selected]
    }
}

/// Read-only view of one cell.
#[derive(Debug, Clone, Copy)]
pub struct CellView<'a, const D: usize> {
    cell: &'a Cell<D>,
}

impl<'a, const D: usize> CellView<'a, D> {
    /// The cell's index.
    pub fn index(&self) -> CellIndex<D> {
        self.cell.index
    }
    /// The point representing the cell (always one of its members).
    pub fn point(&self) -> [f64; D] {
        *self.cell.point()
    }
    /// Scaled squared distance of the representative to the cell centre (the output order).
    pub fn distance(&self) -> f64 {
        self.cell.rank.centre
    }
    /// Number of points in the cell.
    pub fn len(&self) -> usize {
        self.cell.members.len()
    }
    /// Always `false`: empty cells are removed.
    pub fn is_empty(&self) -> bool {
        self.cell.members.is_empty()
    }
    /// All points in the cell, in no particular order.
    pub fn members(&self) -> &'a [[f64; D]] {
        &self.cell.members
    }
    /// The mean of the cell's members (not an input point in general).
    pub fn mean(&self) -> [f64; D] {
        mean(&self.cell.members)
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
/// Insertion and deletion are the input stage; [`DensityGrid::begin_cycle`] starts the output
/// stage (see `density_output.rs`). For two threads wrap it in
/// [`SharedDensityGrid`](crate::SharedDensityGrid).
#[derive(Debug, Clone)]
pub struct DensityGrid<const D: usize> {
    pub(crate) spec: GridSpec<D>,
    pub(crate) selection: Selection<D>,
    /// Ordered index: cell index -> slot in `slots`.
    pub(crate) index: BTreeMap<CellIndex<D>, u32>,
    pub(crate) slots: Vec<Cell<D>>,
    free: Vec<u32>,
    /// `(distance bits, cell index)`: ascending distance, ties by index.
    pub(crate) by_distance: BTreeSet<(u64, CellIndex<D>)>,
    /// Last cell touched: consecutive scan points often share a cell.
    last: Option<(CellIndex<D>, u32)>,
    pub(crate) generation: u64,
    pub(crate) cycle: u64,
    /// Neighbour offsets, 3^D - 1 of them.
    pub(crate) neighbours: Vec<[i64; D]>,
    counts: GridCounts,
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
            slots: Vec::new(),
            free: Vec::new(),
            by_distance: BTreeSet::new(),
            last: None,
            generation: 0,
            cycle: 0,
            neighbours: neighbour_offsets::<D>(),
            counts: GridCounts::default(),
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
        self.index.len()
    }

    /// `true` when no cell holds a point.
    pub fn is_empty(&self) -> bool {
        self.index.is_empty()
    }

    /// Running input counts.
    pub fn counts(&self) -> GridCounts {
        self.counts
    }

    /// Points currently stored (inserted minus removed).
    pub fn point_count(&self) -> u64 {
        self.counts.inserted - self.counts.removed
    }

    /// The cell `index`, if it holds a point.
    pub fn get(&self, index: &CellIndex<D>) -> Option<CellView<'_, D>> {
        self.index.get(index).map(|&s| CellView {
            cell: &self.slots[s as usize],
        })
    }

    /// All cells in lexicographic index order.
    pub fn cells(&self) -> impl Iterator<Item = CellView<'_, D>> + '_ {
        self.index.values().map(move |&s| CellView {
            cell: &self.slots[s as usize],
        })
    }

    /// All cells in output order: ascending distance of their point to the centre.
    pub fn cells_by_distance(&self) -> impl Iterator<Item = CellView<'_, D>> + '_ {
        self.by_distance.iter().map(move |(_, i)| CellView {
            cell: &self.slots[self.index[i] as usize],
        })
    }

    /// The grid stage's result: one point per cell, in index order.
    pub fn selected_points(&self) -> Vec<[f64; D]> {
        self.cells().map(|c| c.point()).collect()
    }

    fn rank_of(&self, p: &[f64; D], index: &CellIndex<D>, mean: Option<&[f64; D]>) -> Rank {
        let centre = self.spec.centre_distance(p, index);
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
        let s = *self.index.get(index)?;
        self.last = Some((*index, s));
        Some(s)
    }

    /// Input stage: add one point.
    ///
    /// NaN/infinite coordinates and points beyond the index range are skipped and counted in
    /// [`GridCounts::rejected`]. The result does not depend on insertion order.
    pub fn insert(&mut self, p: [f64; D]) -> InsertOutcome {
        let Some(index) = self.spec.cell_index(&p) else {
            self.counts.rejected += 1;
            return InsertOutcome::Rejected;
        };
        self.counts.inserted += 1;
        match self.slot_of(&index) {
            None => {
                let rank = self.rank_of(&p, &index, Some(&p));
                self.generation += 1;
                let cell = Cell {
                    index,
                    members: vec![p],
                    selected: 0,
                    rank,
                    stamp: self.generation,
                    mark: 0,
                };
                let slot = match self.free.pop() {
                    Some(s) => {
                        self.slots[s as usize] = cell;
                        s
                    }
                    None => {
                        self.slots.push(cell);
                        (self.slots.len() - 1) as u32
                    }
                };
                self.index.insert(index, slot);
                self.by_distance.insert((rank.centre.to_bits(), index));
                self.last = Some((index, slot));
                InsertOutcome::NewCell
            }
            Some(slot) => {
                let s = slot as usize;
                self.slots[s].members.push(p);
                if self.selection.needs_members() {
                    return if self.reselect(s) {
                        InsertOutcome::Selected
                    } else {
                        InsertOutcome::Member
                    };
                }
                let rank = self.rank_of(&p, &index, None);
                let cell = &self.slots[s];
                if rank.cmp_with(&p, &cell.rank, cell.point()) == Ordering::Less {
                    let new_sel = cell.members.len() - 1;
                    self.set_selected(s, new_sel, rank);
                    InsertOutcome::Selected
                } else {
                    InsertOutcome::Member
                }
            }
        }
    }

    /// Insert a batch of points; returns how many were rejected.
    ///
    /// The batch is sorted by cell index first (as PCL's VoxelGrid sorts), so each cell is
    /// looked up once per batch; the resulting state is the same as inserting one by one.
    pub fn extend<I: IntoIterator<Item = [f64; D]>>(&mut self, points: I) -> u64 {
        let mut batch: Vec<(CellIndex<D>, [f64; D])> = Vec::new();
        let mut rejected = 0;
        for p in points {
            match self.spec.cell_index(&p) {
                Some(i) => batch.push((i, p)),
                None => rejected += 1,
            }
        }
        self.counts.rejected += rejected;
        self.counts.inserted += batch.len() as u64;
        batch.sort_unstable_by_key(|a| a.0);
        let mut start = 0;
        while start < batch.len() {
            let index = batch[start].0;
            let mut end = start + 1;
            while end < batch.len() && batch[end].0 == index {
                end += 1;
            }
            self.insert_run(index, &batch[start..end]);
            start = end;
        }
        rejected
    }

    /// Add points that all lie in cell `index` (already counted as inserted).
    fn insert_run(&mut self, index: CellIndex<D>, run: &[(CellIndex<D>, [f64; D])]) {
        let best_of_run = |g: &Self| {
            let mut best = (0, g.rank_of(&run[0].1, &index, None));
            for (k, (_, p)) in run.iter().enumerate().skip(1) {
                let r = g.rank_of(p, &index, None);
                if r.cmp_with(p, &best.1, &run[best.0].1) == Ordering::Less {
                    best = (k, r);
                }
            }
            best
        };
        match self.index.get(&index).copied() {
            None => {
                let members: Vec<[f64; D]> = run.iter().map(|(_, p)| *p).collect();
                let (sel, rank) = if self.selection.needs_members() {
                    (
                        0,
                        Rank {
                            primary: 0.0,
                            centre: 0.0,
                        },
                    )
                } else {
                    best_of_run(self)
                };
                self.generation += 1;
                let cell = Cell {
                    index,
                    members,
                    selected: sel,
                    rank,
                    stamp: self.generation,
                    mark: 0,
                };
                let slot = match self.free.pop() {
                    Some(s) => {
                        self.slots[s as usize] = cell;
                        s
                    }
                    None => {
                        self.slots.push(cell);
                        (self.slots.len() - 1) as u32
                    }
                };
                self.index.insert(index, slot);
                if self.selection.needs_members() {
                    let (sel, rank) = self.best_member(slot as usize);
                    let cell = &mut self.slots[slot as usize];
                    cell.selected = sel;
                    cell.rank = rank;
                }
                let rank = self.slots[slot as usize].rank;
                self.by_distance.insert((rank.centre.to_bits(), index));
            }
            Some(slot) => {
                let s = slot as usize;
                if self.selection.needs_members() {
                    self.slots[s].members.extend(run.iter().map(|(_, p)| *p));
                    self.reselect(s);
                    return;
                }
                let (k, rank) = best_of_run(self);
                let cell = &mut self.slots[s];
                let base = cell.members.len();
                cell.members.extend(run.iter().map(|(_, p)| *p));
                let p = run[k].1;
                if rank.cmp_with(&p, &cell.rank, cell.point()) == Ordering::Less {
                    self.set_selected(s, base + k, rank);
                }
            }
        }
    }

    /// Make member `sel` the representative of slot `s`, keeping the distance order.
    fn set_selected(&mut self, s: usize, sel: usize, rank: Rank) {
        self.generation += 1;
        let cell = &mut self.slots[s];
        let old = (cell.rank.centre.to_bits(), cell.index);
        let new = (rank.centre.to_bits(), cell.index);
        cell.selected = sel;
        cell.rank = rank;
        cell.stamp = self.generation;
        if old != new {
            self.by_distance.remove(&old);
            self.by_distance.insert(new);
        }
    }

    /// The best member of slot `s` under the selection rule, with its rank.
    fn best_member(&self, s: usize) -> (usize, Rank) {
        let cell = &self.slots[s];
        let m = self.selection.needs_members().then(|| mean(&cell.members));
        let mut best = (0, self.rank_of(&cell.members[0], &cell.index, m.as_ref()));
        for (k, p) in cell.members.iter().enumerate().skip(1) {
            let r = self.rank_of(p, &cell.index, m.as_ref());
            if r.cmp_with(p, &best.1, &cell.members[best.0]) == Ordering::Less {
                best = (k, r);
            }
        }
        best
    }

    /// Local repair: choose the representative of slot `s` again from its members.
    /// Returns `true` when the representative changed.
    fn reselect(&mut self, s: usize) -> bool {
        let (k, r) = self.best_member(s);
        let cell = &self.slots[s];
        let changed = cmp_points(&cell.members[k], cell.point()) != Ordering::Equal
            || r.centre.to_bits() != cell.rank.centre.to_bits();
        if changed {
            self.set_selected(s, k, r);
        } else {
            // Same point (perhaps a duplicate at another position): keep the rank fresh.
            let cell = &mut self.slots[s];
            cell.selected = k;
            cell.rank = r;
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
        let cell = &mut self.slots[s];
        let Some(k) = cell
            .members
            .iter()
            .position(|m| cmp_points(m, p) == Ordering::Equal)
        else {
            return false;
        };
        self.counts.removed += 1;
        if cell.members.len() == 1 {
            let key = (cell.rank.centre.to_bits(), cell.index);
            cell.members = Vec::new();
            self.by_distance.remove(&key);
            self.index.remove(&index);
            self.free.push(slot);
            self.last = None;
            self.generation += 1;
            return true;
        }
        let last = cell.members.len() - 1;
        if cell.selected == k {
            // The representative leaves: the best remaining member takes over.
            let old_key = (cell.rank.centre.to_bits(), cell.index);
            cell.members.swap_remove(k);
            self.by_distance.remove(&old_key);
            let (sel, rank) = self.best_member(s);
            self.generation += 1;
            let cell = &mut self.slots[s];
            cell.selected = sel;
            cell.rank = rank;
            cell.stamp = self.generation;
            self.by_distance.insert((rank.centre.to_bits(), index));
        } else {
            cell.members.swap_remove(k);
            if cell.selected == last {
                cell.selected = k;
            }
            if self.selection.needs_members() {
                self.reselect(s);
            }
        }
        true
    }

    /// The order-independent content, for comparing grids (see [`GridState`]).
    pub fn state(&self) -> GridState<D> {
        let cells = self
            .cells()
            .map(|c| {
                let mut m = c.members().to_vec();
                m.sort_by(cmp_points);
                CellState {
                    index: c.index(),
                    point: c.point(),
                    distance: c.distance(),
                    members: m,
                }
            })
            .collect();
        let distance_order = self.by_distance.iter().map(|(_, i)| *i).collect();
        GridState {
            cells,
            distance_order,
        }
    }

    /// Check every store invariant: index, arena and distance order agree, every member lies
    /// in its cell, and each representative is the best member under the selection rule.
    pub fn validate(&self) -> Result<(), QuantizeError> {
        let bad = |what: String| Err(QuantizeError::Invariant { what });
        if self.by_distance.len() != self.index.len() {
            return bad(format!(
                "{} distance entries for {} cells",
                self.by_distance.len(),
                self.index.len()
            ));
        }
        let mut points = 0u64;
        for (index, &slot) in &self.index {
            let Some(cell) = self.slots.get(slot as usize) else {
                return bad(format!("cell {index:?} points to missing slot {slot}"));
            };
            if &cell.index != index {
                return bad(format!("slot {slot} holds {:?}, not {index:?}", cell.index));
            }
            if cell.members.is_empty() || cell.selected >= cell.members.len() {
                return bad(format!("cell {index:?} empty or bad selection"));
            }
            points += cell.members.len() as u64;
            for m in &cell.members {
                if self.spec.cell_index(m).as_ref() != Some(index) {
                    return bad(format!("member {m:?} is not in cell {index:?}"));
                }
            }
            let mean_pt = mean(&cell.members);
            let m = self.selection.needs_members().then_some(&mean_pt);
            let sel_rank = self.rank_of(cell.point(), index, m);
            if sel_rank.centre.to_bits() != cell.rank.centre.to_bits() {
                return bad(format!("cell {index:?} has a stale distance"));
            }
            for p in &cell.members {
                let r = self.rank_of(p, index, m);
                if r.cmp_with(p, &sel_rank, cell.point()) == Ordering::Less {
                    return bad(format!(
                        "cell {index:?}: member {p:?} beats the chosen point"
                    ));
                }
            }
            if !self
                .by_distance
                .contains(&(cell.rank.centre.to_bits(), *index))
            {
                return bad(format!("cell {index:?} missing from the distance order"));
            }
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

/// The mean of some points (zeros for none).
pub(crate) fn mean<const D: usize>(points: &[[f64; D]]) -> [f64; D] {
    let mut m = [0.0; D];
    if points.is_empty() {
        return m;
    }
    for p in points {
        for k in 0..D {
            m[k] += p[k];
        }
    }
    let n = points.len() as f64;
    for v in &mut m {
        *v /= n;
    }
    m
}

/// All offsets in {-1, 0, 1}^D except the zero offset, in lexicographic order.
fn neighbour_offsets<const D: usize>() -> Vec<[i64; D]> {
    let total = 3usize.saturating_pow(D as u32);
    let mut out = Vec::with_capacity(total.saturating_sub(1));
    for n in 0..total {
        let mut o = [0i64; D];
        let mut r = n;
        for k in (0..D).rev() {
            o[k] = (r % 3) as i64 - 1;
            r /= 3;
        }
        if o.iter().any(|&v| v != 0) {
            out.push(o);
        }
    }
    out
}
