//! The store's two orders: the ordered index (cells in lexicographic index order) and the
//! distance order (the read cycle's order).
//!
//! A batch into an empty grid sorts its cells by index and creates their slots in that order,
//! so its ordered index is simply the slot order, and its distance order is one sorted `Vec` of
//! `(distance bits, slot)`, ties by slot (= by index). The store keeps that compact form (its
//! field `built`, the B-trees `index` and `by_distance` then empty) until the first change that
//! adds, removes or re-ranks a cell, and only then builds the B-trees, which support changes in
//! O(log n). A one-shot reduction (one batch, one read cycle) never builds a tree.

use super::store::{DensityGrid, Hot};
use crate::spec::CellIndex;
use std::collections::{btree_map, btree_set, BTreeMap, BTreeSet};
use std::iter::{Copied, Map};
use std::ops::{Bound, Range};
use std::slice;

/// The ordered index in B-tree form: cell index -> slot.
pub(crate) type IndexTree<const D: usize> = BTreeMap<CellIndex<D>, u32>;

/// The distance order in B-tree form: `(distance bits, cell index, slot)`, ascending.
pub(crate) type DistanceTree<const D: usize> = BTreeSet<(u64, CellIndex<D>, u32)>;

/// Slots in index order.
pub(crate) enum IndexSlots<'a, const D: usize> {
    Built(Range<u32>),
    Trees(btree_map::Values<'a, CellIndex<D>, u32>),
}

impl<const D: usize> Iterator for IndexSlots<'_, D> {
    type Item = u32;

    #[inline]
    fn next(&mut self) -> Option<u32> {
        match self {
            IndexSlots::Built(r) => r.next(),
            IndexSlots::Trees(v) => v.next().copied(),
        }
    }
}

type SlotOfTriple<const D: usize> = fn(&(u64, CellIndex<D>, u32)) -> (u64, u32);

/// `(distance bits, slot)` in distance order.
pub(crate) enum DistanceSlots<'a, const D: usize> {
    Built(Copied<slice::Iter<'a, (u64, u32)>>),
    Trees(Map<btree_set::Range<'a, (u64, CellIndex<D>, u32)>, SlotOfTriple<D>>),
}

impl<const D: usize> Iterator for DistanceSlots<'_, D> {
    type Item = (u64, u32);

    #[inline]
    fn next(&mut self) -> Option<(u64, u32)> {
        match self {
            DistanceSlots::Built(it) => it.next(),
            DistanceSlots::Trees(it) => it.next(),
        }
    }
}

impl<const D: usize> DensityGrid<D> {
    /// Number of cells.
    #[inline]
    pub(crate) fn cell_count(&self) -> usize {
        match &self.built {
            Some(by_distance) => by_distance.len(),
            None => self.index.len(),
        }
    }

    /// Slots of all cells in lexicographic index order.
    pub(crate) fn index_slots(&self) -> IndexSlots<'_, D> {
        match &self.built {
            Some(by_distance) => IndexSlots::Built(0..by_distance.len() as u32),
            None => IndexSlots::Trees(self.index.values()),
        }
    }

    /// `(distance bits, slot)` of the cells after `cursor` (a `(distance bits, index)` pair;
    /// all cells for `None`) in distance order, ties by index.
    pub(crate) fn distance_slots_after(
        &self,
        cursor: Option<(u64, CellIndex<D>)>,
    ) -> DistanceSlots<'_, D> {
        distance_slots_after(&self.built, &self.by_distance, &self.hot, cursor)
    }

    /// Switch to the B-tree form (a no-op when already there) and return both trees.
    pub(crate) fn trees(&mut self) -> (&mut IndexTree<D>, &mut DistanceTree<D>) {
        if let Some(order) = self.built.take() {
            let hot = &self.hot;
            // Both sequences are sorted already: the collections build them in bulk.
            self.index = (0..order.len() as u32)
                .map(|s| (hot[s as usize].index, s))
                .collect();
            self.by_distance = order
                .iter()
                .map(|&(d, s)| (d, hot[s as usize].index, s))
                .collect();
        }
        (&mut self.index, &mut self.by_distance)
    }

    /// Whether `(distance bits, index, slot)` is in the distance order.
    pub(crate) fn distance_order_has(&self, d: u64, index: &CellIndex<D>, slot: u32) -> bool {
        match &self.built {
            Some(by_distance) => {
                by_distance.binary_search(&(d, slot)).is_ok()
                    && self
                        .hot
                        .get(slot as usize)
                        .is_some_and(|h| h.index == *index)
            }
            None => self.by_distance.contains(&(d, *index, slot)),
        }
    }
}

/// [`DensityGrid::distance_slots_after`] on the store's fields, so that the caller may change
/// other fields (the cells' records) while walking; `hot` is only read before this returns.
pub(crate) fn distance_slots_after<'a, const D: usize>(
    built: &'a Option<Vec<(u64, u32)>>,
    by_distance: &'a DistanceTree<D>,
    hot: &[Hot<D>],
    cursor: Option<(u64, CellIndex<D>)>,
) -> DistanceSlots<'a, D> {
    match built {
        Some(order) => {
            let from = match cursor {
                None => 0,
                Some(c) => order.partition_point(|&(d, s)| (d, hot[s as usize].index) <= c),
            };
            DistanceSlots::Built(order[from..].iter().copied())
        }
        None => {
            // `u32::MAX` bounds every slot of the cursor cell.
            let lower = match cursor {
                None => Bound::Unbounded,
                Some((d, i)) => Bound::Excluded((d, i, u32::MAX)),
            };
            DistanceSlots::Trees(
                by_distance
                    .range((lower, Bound::Unbounded))
                    .map(|&(d, _, s)| (d, s)),
            )
        }
    }
}
