//! The input stage for whole batches: sort the batch by cell (`batch_sort.rs`), then fill each
//! cell once.
//!
//! Into an empty grid the runs build the store in one pass: the sorted batch becomes the member
//! arena, slot order is index order (so the ordered index needs no tree), the distance order is
//! one bucket-sorted `Vec`, and under the closest-to-centre rule the cells' records stay packed.
//! Into a non-empty grid each run goes to its cell as in [`DensityGrid::insert`], one look-up
//! per cell.

use super::arena::widen_point;
use super::batch_sort::SortedBatch;
use super::distance_sort::DistanceSort;
use super::lookup::{hash_index, SlotTable};
use super::representative::centre_closest;
use super::store::{new_slot, to_u32, Cell, DensityGrid, Hot, PackedCell};
use crate::selection::Selection;

impl<const D: usize> DensityGrid<D> {
    /// Insert a batch of points; returns how many were rejected.
    ///
    /// The batch is sorted by cell index first (as PCL's VoxelGrid sorts), so each cell is
    /// looked up once per batch; the resulting state is the same as inserting one by one.
    /// The points are copied once; for a batch that can be walked again (a slice iterator,
    /// possibly mapped) [`DensityGrid::extend_rewalk`] avoids that copy.
    pub fn extend<I: IntoIterator<Item = [f64; D]>>(&mut self, points: I) -> u64 {
        let batch: Vec<[f64; D]> = points.into_iter().collect();
        self.extend_rewalk(batch.iter().copied())
    }

    /// [`DensityGrid::extend`] for an iterator that can be cloned and walked again: the batch
    /// is read three times (bounding box, cell ids, placement) instead of being copied first.
    /// Same result as [`DensityGrid::extend`].
    pub fn extend_rewalk<I>(&mut self, points: I) -> u64
    where
        I: IntoIterator<Item = [f64; D]>,
        I::IntoIter: Clone,
    {
        let points = points.into_iter();
        // a batch that could take the grid past its capacity goes in point by point, so that
        // exactly the points a one-by-one insertion would refuse are refused
        let room = self.max_points - self.point_count();
        let fits = match points.size_hint() {
            (_, Some(upper)) => upper as u64 <= room,
            (_, None) => points.clone().count() as u64 <= room,
        };
        if !fits {
            let before = self.counts.rejected;
            for p in points {
                self.insert(p);
            }
            return self.counts.rejected - before;
        }
        let (batch, rejected) = self.sort_batch(points);
        self.counts.rejected += rejected;
        self.counts.inserted += batch.len as u64;
        if self.is_empty() {
            self.build(batch);
        } else {
            let mut start = 0;
            for k in 0..batch.runs.len() {
                let (index, end) = batch.runs.get(k);
                self.insert_run(index, &batch.points[start..end]);
                start = end;
            }
            self.maybe_compact();
        }
        rejected
    }

    /// Build the store of an empty grid from a sorted batch in one pass.
    fn build(&mut self, batch: SortedBatch<D>) {
        debug_assert!(self.is_empty());
        self.hot.clear();
        self.slots.clear();
        self.packed = None;
        self.free.clear();
        self.index.clear();
        self.by_distance.clear();
        self.last = None;
        self.points = batch.points;
        self.narrow = batch.narrow;
        self.reserved = batch.len;
        let cells = batch.runs.len();
        self.hot.reserve(cells);
        // Under the closest-to-centre rule the cells' records are kept packed (the rank's
        // primary criterion is the centre distance; spans are back to back, without room).
        let mut packed: Option<Vec<PackedCell>> =
            matches!(self.selection, Selection::CentreClosest).then(|| Vec::with_capacity(cells));
        if packed.is_none() {
            self.slots.reserve(cells);
        }
        self.lookup = SlotTable::with_buffer(batch.spare, cells);
        // Fill the hash index first, in its own pass, while its freshly cleared buckets are
        // still in cache (the cell loop below streams the arena and the new records).
        for k in 0..cells {
            let (index, _) = batch.runs.get(k);
            self.lookup
                .insert_with_room(hash_index(&index), new_slot(k));
        }
        // Slots are created in index order, so slot order is index order. The distance order
        // is counted here and placed from the cells' ranks below (no list of pairs in between);
        // a representative lies in its cell, so its distance is at most about the corner's.
        let mut distance = DistanceSort::new(cells, self.spec.max_centre_distance());
        let mut start = 0;
        for k in 0..cells {
            let (index, end) = batch.runs.get(k);
            let (sel, rank) = match (&self.selection, &self.narrow) {
                // The usual case, without the arena form's dispatch per member.
                (Selection::CentreClosest, Some(arena)) => centre_closest(
                    &self.spec.cell_centre(&index),
                    &self.spec,
                    arena[start..end].iter().map(widen_point),
                ),
                _ => self.best_of(&index, self.arena().members(start..end)),
            };
            self.generation += 1;
            self.hot.push(Hot {
                index,
                point: self.arena().get(start + sel),
                stamp: self.generation,
                mark: 0,
            });
            match &mut packed {
                Some(packed) => packed.push(PackedCell {
                    end: to_u32(end),
                    selected: to_u32(sel),
                    centre: rank.centre,
                }),
                None => self.slots.push(Cell {
                    start,
                    len: to_u32(end - start),
                    cap: to_u32(end - start),
                    selected: to_u32(sel),
                    rank,
                }),
            }
            distance.count(rank.centre.to_bits());
            start = end;
        }
        // Ascending distance, ties by slot (= by index here). Distances are non-negative, so
        // their bits sort as the values do.
        let distance = match &packed {
            Some(packed) => distance.place(
                packed
                    .iter()
                    .enumerate()
                    .map(|(s, c)| (c.centre.to_bits(), s as u32)),
            ),
            None => distance.place(
                self.slots
                    .iter()
                    .enumerate()
                    .map(|(s, c)| (c.rank.centre.to_bits(), s as u32)),
            ),
        };
        self.packed = packed;
        // The ordered index is the slot order: both orders stay in this compact form until a
        // change needs the B-trees.
        self.built = Some(distance);
        if self.storage.one_node() {
            self.keep_representatives_only();
        }
    }

    /// [`Storage::OneNode`](crate::Storage::OneNode) after a build: the arena shrinks to the
    /// cells' kept points, one per slot in slot order, and the other members are discarded.
    fn keep_representatives_only(&mut self) {
        let cells = self.hot.len();
        self.counts.discarded += self.arena().len() as u64 - cells as u64;
        match &mut self.narrow {
            Some(narrow) => {
                let kept: Vec<[f32; D]> = (0..cells)
                    .map(|s| narrow[representative_at(&self.packed, &self.slots, s)])
                    .collect();
                *narrow = kept;
            }
            None => {
                let kept: Vec<[f64; D]> = (0..cells)
                    .map(|s| self.points[representative_at(&self.packed, &self.slots, s)])
                    .collect();
                self.points = kept;
            }
        }
        match &mut self.packed {
            Some(packed) => {
                for (s, c) in packed.iter_mut().enumerate() {
                    c.end = to_u32(s + 1);
                    c.selected = 0;
                }
            }
            None => {
                for (s, c) in self.slots.iter_mut().enumerate() {
                    c.start = s;
                    c.len = 1;
                    c.cap = 1;
                    c.selected = 0;
                }
            }
        }
        self.reserved = cells;
    }
}

/// Arena position of slot `s`'s representative, from whichever record form is in use.
fn representative_at(packed: &Option<Vec<PackedCell>>, slots: &[Cell], s: usize) -> usize {
    match packed {
        Some(packed) => {
            let start = s.checked_sub(1).map_or(0, |p| packed[p].end as usize);
            start + packed[s].selected as usize
        }
        None => slots[s].point_at(),
    }
}
