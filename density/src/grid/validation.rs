//! The store's invariant checks ([`DensityGrid::validate`]): both indexes, the cells' records,
//! the member arena and both orders agree. The tests run them after every kind of change.

use super::store::{Cell, DensityGrid};
use crate::error::DensityError;
use crate::selection::mean;
use crate::spec::{cmp_points, CellIndex};
use std::cmp::Ordering;

impl<const D: usize> DensityGrid<D> {
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

    /// The record of slot `s`, if the slot exists.
    fn cell_opt(&self, s: usize) -> Option<Cell> {
        (s < self.hot.len()).then(|| self.cell(s))
    }

    /// Check the compact form's own invariants (the trees are checked by the caller): every
    /// slot once, both orders strictly ascending, no free slot.
    fn validate_orders(&self) -> Result<(), String> {
        let Some(by_distance) = &self.built else {
            return Ok(());
        };
        if !self.index.is_empty() || !self.by_distance.is_empty() {
            return Err("compact order beside non-empty trees".to_string());
        }
        if by_distance.len() != self.hot.len() || !self.free.is_empty() {
            return Err(format!(
                "compact order of {} cells over {} slots ({} free)",
                by_distance.len(),
                self.hot.len(),
                self.free.len()
            ));
        }
        if self.hot.windows(2).any(|w| w[0].index >= w[1].index) {
            return Err("compact order: slots not in index order".to_string());
        }
        if by_distance.windows(2).any(|w| w[0] >= w[1]) {
            return Err("compact order: distances not ascending".to_string());
        }
        let mut seen = vec![false; by_distance.len()];
        for &(_, s) in by_distance {
            match seen.get_mut(s as usize) {
                Some(f) if !*f => *f = true,
                _ => return Err(format!("compact order: slot {s} missing or repeated")),
            }
        }
        Ok(())
    }
}
