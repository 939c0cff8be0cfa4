//! The input stage, one point at a time: insertion into a new or an existing cell.

use super::lookup::hash_index;
use super::store::{new_slot, to_u32, Cell, DensityGrid, Hot};
use crate::selection::Rank;
use crate::spec::CellIndex;
use std::cmp::Ordering;

/// What [`DensityGrid::insert`] did with a point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InsertOutcome {
    /// The point opened a new cell and represents it.
    NewCell,
    /// The point joined a cell and now represents it (under
    /// [`Storage::OneNode`](crate::Storage::OneNode): it replaced the cell's point).
    Selected,
    /// The point joined a cell whose representative did not change (under
    /// [`Storage::OneNode`](crate::Storage::OneNode): it was dropped).
    Member,
    /// NaN or infinite coordinate, or outside the index range: skipped and counted.
    Rejected,
    /// The grid already holds [`DensityGrid::MAX_POINTS`] points: skipped and counted as
    /// rejected.
    Full,
}

impl<const D: usize> DensityGrid<D> {
    /// Input stage: add one point.
    ///
    /// NaN/infinite coordinates and points beyond the index range are skipped and counted in
    /// [`GridCounts::rejected`](crate::GridCounts::rejected), and so are points beyond [`DensityGrid::MAX_POINTS`]. The
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
            Some(slot) if self.storage.one_node() => {
                let s = slot as usize;
                if self.keep_if_better(s, &index, &p) {
                    InsertOutcome::Selected
                } else {
                    InsertOutcome::Member
                }
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
                if self.storage.one_node() {
                    self.counts.discarded += run.len() as u64 - 1;
                    self.open_cell(index, &run[sel..=sel], 0, rank);
                } else {
                    self.open_cell(index, run, sel, rank);
                }
            }
            Some(slot) if self.storage.one_node() => {
                let (k, _) = self.best_in(&index, run);
                self.counts.discarded += run.len() as u64 - 1;
                self.keep_if_better(slot as usize, &index, &run[k]);
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

    /// [`Storage::OneNode`](crate::Storage::OneNode): `p`, which lies in the cell `index` of
    /// slot `s`, overwrites the cell's one point when it ranks better, and is dropped
    /// otherwise; either way one point is discarded. Returns `true` when `p` is kept.
    fn keep_if_better(&mut self, s: usize, index: &CellIndex<D>, p: &[f64; D]) -> bool {
        self.counts.discarded += 1;
        let rank = self.rank_of(p, index, None);
        if rank.cmp_with(p, &self.cell(s).rank, &self.hot[s].point) != Ordering::Less {
            return false;
        }
        self.widen();
        let at = self.slots[s].start;
        self.points[at] = *p;
        self.set_selected(s, 0, rank);
        true
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
}
