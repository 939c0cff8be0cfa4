//! The input stage for whole batches: sort the batch by cell, then fill each cell once.
//!
//! A counting sort. The bounding box of the batch's finite points bounds its cells, whose
//! indexes therefore pack into `u64` keys relative to that box (integer order = lexicographic
//! order). One pass gives each point a batch-local cell id through a hash table keyed by the
//! packed key; the distinct cells alone are sorted (radix sort of their keys); a last pass
//! moves each point into its cell's run. A batch whose box does not pack into 63 bits is
//! sorted by comparison instead. Into an empty grid the runs build the store in one pass: the
//! sorted batch becomes the member arena, slot order is index order (so the ordered index needs
//! no tree), and the distance order is one radix-sorted `Vec`. Into a non-empty grid each run goes to its cell as in
//! [`DensityGrid::insert`], one look-up per cell.

use crate::density::CellIndex;
use crate::density_grid::{new_slot, to_u32, Cell, DensityGrid, Hot};
use crate::density_index::{hash_index, radix_sort_bits, radix_sort_by_key, Packing};

/// A batch sorted by cell: the points in cell order and, per cell, its index and the end of
/// its run in `points`.
struct SortedBatch<const D: usize> {
    points: Vec<[f64; D]>,
    runs: Vec<(CellIndex<D>, usize)>,
}

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
        let (batch, rejected) = self.sort_batch(points.into_iter());
        self.counts.rejected += rejected;
        self.counts.inserted += batch.points.len() as u64;
        if self.is_empty() {
            self.build(batch);
        } else {
            let mut start = 0;
            for &(index, end) in &batch.runs {
                self.insert_run(index, &batch.points[start..end]);
                start = end;
            }
            self.maybe_compact();
        }
        rejected
    }

    /// Counting sort of a batch by cell, dropping (and counting) the rejected points.
    ///
    /// A first pass finds the bounding box of the finite points; the cell index is monotone in
    /// each coordinate, so the cells of the box's corners bound every accepted point's cell,
    /// and the cell indexes pack into `u64` keys relative to that box (integer order =
    /// lexicographic order). A second pass gives each point a batch-local cell id through a
    /// hash table keyed by the packed key (consecutive points often share a cell); only the
    /// distinct cells are then sorted, and a last pass moves every point into its cell's run,
    /// keeping the input order within a run. A batch whose box does not pack into 63 bits is
    /// sorted by comparison instead.
    fn sort_batch<It>(&self, points: It) -> (SortedBatch<D>, u64)
    where
        It: Iterator<Item = [f64; D]> + Clone,
    {
        let mut lo = [f64::INFINITY; D];
        let mut hi = [f64::NEG_INFINITY; D];
        for p in points.clone() {
            if p.iter().all(|v| v.is_finite()) {
                for a in 0..D {
                    lo[a] = lo[a].min(p[a]);
                    hi[a] = hi[a].max(p[a]);
                }
            }
        }
        let packing = match (self.spec.cell_index(&lo), self.spec.cell_index(&hi)) {
            (Some(l), Some(h)) => Packing::new(&l, &h).filter(|p| p.bits < 64),
            _ => None,
        };
        let Some(packing) = packing else {
            return self.sort_general(points);
        };
        let mut ids: Vec<u32> = Vec::with_capacity(points.size_hint().0);
        let mut keys: Vec<u64> = Vec::new();
        let mut counts: Vec<usize> = Vec::new();
        let mut table = KeyTable::default();
        let mut last = (u64::MAX, 0u32);
        let mut rejected = 0;
        for p in points.clone() {
            let Some(index) = self.spec.cell_index(&p) else {
                rejected += 1;
                ids.push(u32::MAX);
                continue;
            };
            let key = packing.pack(&index);
            let id = if key == last.0 {
                last.1
            } else {
                let id = table.get_or_insert(key, || {
                    keys.push(key);
                    counts.push(0);
                    new_slot(keys.len() - 1)
                });
                last = (key, id);
                id
            };
            counts[id as usize] += 1;
            ids.push(id);
        }
        drop(table);
        // Start of each cell's run, in cell order; `runs` ends each run.
        let mut next = vec![0usize; keys.len()];
        let mut runs = Vec::with_capacity(keys.len());
        let mut end = 0;
        for id in sort_keys(&keys) {
            next[id as usize] = end;
            end += counts[id as usize];
            runs.push((packing.unpack(keys[id as usize]), end));
        }
        let mut sorted = vec![[0.0; D]; end];
        for (p, &id) in points.zip(&ids) {
            if id != u32::MAX {
                let at = &mut next[id as usize];
                sorted[*at] = p;
                *at += 1;
            }
        }
        (
            SortedBatch {
                points: sorted,
                runs,
            },
            rejected,
        )
    }

    /// Comparison sort of `(cell index, position)` pairs, for batches spread too wide to pack.
    fn sort_general(&self, points: impl Iterator<Item = [f64; D]>) -> (SortedBatch<D>, u64) {
        let mut tagged: Vec<(CellIndex<D>, [f64; D])> = Vec::new();
        let mut rejected = 0;
        for p in points {
            match self.spec.cell_index(&p) {
                Some(i) => tagged.push((i, p)),
                None => rejected += 1,
            }
        }
        tagged.sort_unstable_by_key(|a| a.0);
        let mut sorted = Vec::with_capacity(tagged.len());
        let mut runs: Vec<(CellIndex<D>, usize)> = Vec::new();
        for &(i, p) in &tagged {
            match runs.last_mut() {
                Some(last) if last.0 == i => {}
                _ => runs.push((i, 0)),
            }
            sorted.push(p);
            if let Some(last) = runs.last_mut() {
                last.1 = sorted.len();
            }
        }
        (
            SortedBatch {
                points: sorted,
                runs,
            },
            rejected,
        )
    }

    /// Build the store of an empty grid from a sorted batch in one pass.
    fn build(&mut self, batch: SortedBatch<D>) {
        debug_assert!(self.is_empty());
        self.hot.clear();
        self.slots.clear();
        self.free.clear();
        self.lookup.clear();
        self.index.clear();
        self.by_distance.clear();
        self.last = None;
        self.points = batch.points;
        self.reserved = self.points.len();
        let cells = batch.runs.len();
        self.hot.reserve(cells);
        self.slots.reserve(cells);
        self.lookup.reserve(cells);
        // Slots are created in index order, so slot order is index order.
        let mut distance: Vec<(u64, u32)> = Vec::with_capacity(cells);
        let mut start = 0;
        for (slot, &(index, end)) in batch.runs.iter().enumerate() {
            let slot = new_slot(slot);
            let (sel, rank) = self.best_in(&index, &self.points[start..end]);
            self.generation += 1;
            self.hot.push(Hot {
                index,
                point: self.points[start + sel],
                stamp: self.generation,
                mark: 0,
            });
            self.slots.push(Cell {
                start,
                len: to_u32(end - start),
                cap: to_u32(end - start),
                selected: to_u32(sel),
                rank,
            });
            self.lookup.insert(hash_index(&index), slot);
            distance.push((rank.centre.to_bits(), slot));
            start = end;
        }
        // Ascending distance, ties by index (= by slot here: the sort is stable and `distance`
        // is in slot order). Distances are non-negative, so their bits sort as the values do.
        let max = distance.iter().map(|e| e.0).max().unwrap_or(0);
        radix_sort_by_key(
            &mut distance,
            &mut Vec::new(),
            |e| e.0,
            0,
            u64::BITS - max.leading_zeros(),
        );
        // The ordered index is the slot order: both orders stay in this compact form until a
        // change needs the B-trees.
        self.built = Some(distance);
    }
}

/// The ids `0..keys.len()` in ascending order of their (distinct) keys: radix sorted with the
/// id in the low bits when both fit one word, else a comparison sort.
fn sort_keys(keys: &[u64]) -> Vec<u32> {
    if keys.is_empty() {
        return Vec::new();
    }
    let max = keys.iter().copied().max().unwrap_or(0);
    let key_bits = u64::BITS - max.leading_zeros();
    let id_bits = usize::BITS - (keys.len() - 1).leading_zeros();
    if key_bits + id_bits <= 64 {
        let mut words: Vec<u64> = keys
            .iter()
            .enumerate()
            .map(|(id, &k)| (k << id_bits) | id as u64)
            .collect();
        radix_sort_bits(&mut words, &mut Vec::new(), id_bits, id_bits + key_bits);
        let id_mask = if id_bits == 0 {
            0
        } else {
            u64::MAX >> (64 - id_bits)
        };
        words.into_iter().map(|w| (w & id_mask) as u32).collect()
    } else {
        let mut ids: Vec<u32> = (0..keys.len() as u32).collect();
        ids.sort_unstable_by_key(|&id| keys[id as usize]);
        ids
    }
}

/// Hash table from a packed cell key (`< u64::MAX`) to a batch-local id: open addressing,
/// linear probing, the key in the bucket, at most half full.
struct KeyTable {
    buckets: Vec<(u64, u32)>,
    len: usize,
    shift: u32,
}

impl Default for KeyTable {
    fn default() -> Self {
        KeyTable {
            buckets: vec![(u64::MAX, 0); 1 << 10],
            len: 0,
            shift: 64 - 10,
        }
    }
}

impl KeyTable {
    #[inline]
    fn home(&self, key: u64) -> usize {
        ((key ^ (key >> 29)).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> self.shift) as usize
    }

    /// The id of `key`, inserting the id `make()` gives when it is new.
    #[inline]
    fn get_or_insert(&mut self, key: u64, make: impl FnOnce() -> u32) -> u32 {
        let mask = self.buckets.len() - 1;
        let mut i = self.home(key);
        loop {
            let (k, id) = self.buckets[i];
            if k == key {
                return id;
            }
            if k == u64::MAX {
                let id = make();
                self.buckets[i] = (key, id);
                self.len += 1;
                if 2 * self.len > self.buckets.len() {
                    self.grow();
                }
                return id;
            }
            i = (i + 1) & mask;
        }
    }

    fn grow(&mut self) {
        let size = 2 * self.buckets.len();
        let old = std::mem::replace(&mut self.buckets, vec![(u64::MAX, 0); size]);
        self.shift -= 1;
        let mask = self.buckets.len() - 1;
        for (k, id) in old {
            if k != u64::MAX {
                let mut i = self.home(k);
                while self.buckets[i].0 != u64::MAX {
                    i = (i + 1) & mask;
                }
                self.buckets[i] = (k, id);
            }
        }
    }
}
