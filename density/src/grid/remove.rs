//! The input stage's deletion: one point out, repairing only its own cell.

use super::lookup::hash_index;
use super::store::{to_u32, DensityGrid};
use crate::spec::cmp_points;
use std::cmp::Ordering;

impl<const D: usize> DensityGrid<D> {
    /// Input stage: delete one point equal (bit for bit) to `p`, repairing only its cell.
    ///
    /// When the deleted point represented the cell, the best remaining member takes over; when
    /// it was the last member, the cell is removed. Returns `false` when no such point is
    /// stored. Under [`Storage::AllMembers`](crate::Storage::AllMembers) inserting points and
    /// deleting them again restores the earlier [`GridState`](crate::GridState).
    ///
    /// Under [`Storage::OneNode`](crate::Storage::OneNode) a cell stores only its kept point,
    /// so only that point can be deleted, and deleting it removes the cell (the points it beat
    /// were dropped and cannot take over, the paper's rule); deleting any other point changes
    /// nothing and returns `false`.
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
}
