//! The input stage for whole batches: sort the batch by cell, then fill each cell once.
//!
//! A counting sort. One pass gives each point a batch-local cell id through a hash table keyed
//! by the cell index packed into a `u64`, relative to the first finite point's cell (integer
//! order = lexicographic order); the distinct cells' keys are repacked relative to their own
//! box and alone sorted (radix sort); a last pass moves each point into its cell's run. A batch
//! reaching beyond the first pass's window is measured first (its finite points' bounding box
//! bounds its cells), and one whose box does not pack into 63 bits is sorted by comparison.
//! Into an empty grid the runs build the store in one pass: the sorted batch becomes the member
//! arena, slot order is index order (so the ordered index needs no tree), the distance order is
//! one bucket-sorted `Vec`, and under the closest-to-centre rule the cells' records stay packed.
//! Into a non-empty grid each run goes to its cell as in [`DensityGrid::insert`], one look-up
//! per cell.

use crate::spec::{CellIndex, Selection, MAX_CELL_INDEX};
use crate::arena::{narrow_point, widen_point};
use crate::grid::{centre_closest, new_slot, to_u32, Cell, DensityGrid, Hot, PackedCell};
use crate::index::{
    all_finite, floor_trunc, hash_index, radix_sort_bits, DistanceSort, Packing, SlotTable,
};

/// A batch sorted by cell: the points in cell order and its cells' runs.
struct SortedBatch<const D: usize> {
    /// Accepted points.
    len: usize,
    /// The points in cell order, unless they are in `narrow`.
    points: Vec<[f64; D]>,
    /// The points in cell order as `f32`, when all are exact in `f32` and the batch goes into
    /// an empty grid (the narrow arena, see `arena.rs`).
    narrow: Option<Vec<[f32; D]>>,
    runs: Runs<D>,
    /// The key table's buckets, handed on as the hash index's storage (already faulted in).
    spare: Vec<u64>,
}

/// The cells of a [`SortedBatch`] in index order, each with the end of its run in `points`.
enum Runs<const D: usize> {
    /// From the counting sort: `order` lists the batch-local cell ids in index order; cell `id`
    /// has the packed key `keys[id]` and its run ends at `ends[id]`.
    Packed {
        packing: Packing<D>,
        keys: Vec<u64>,
        order: Vec<u32>,
        ends: Vec<u32>,
    },
    /// From the comparison sort: `(cell index, run end)`.
    Listed(Vec<(CellIndex<D>, usize)>),
}

impl<const D: usize> Runs<D> {
    /// Number of cells.
    fn len(&self) -> usize {
        match self {
            Runs::Packed { order, .. } => order.len(),
            Runs::Listed(v) => v.len(),
        }
    }

    /// The `k`-th cell in index order and the end of its run.
    #[inline]
    fn get(&self, k: usize) -> (CellIndex<D>, usize) {
        match self {
            Runs::Packed {
                packing,
                keys,
                order,
                ends,
            } => {
                let id = order[k] as usize;
                (packing.unpack(keys[id]), ends[id] as usize)
            }
            Runs::Listed(v) => v[k],
        }
    }
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

    /// Counting sort of a batch by cell, dropping (and counting) the rejected points.
    ///
    /// Usually one pass gives each point a batch-local cell id through a hash table keyed by
    /// the cell index packed into a `u64` (consecutive points often share a cell): indexes
    /// relative to the first finite point's cell, `min(63 / D, 48)` bits per axis (see
    /// [`Self::ids_in_window`]). The distinct cells' keys are then repacked relative to their
    /// own box and sorted, and a last pass moves every point into its cell's run, keeping the
    /// input order within a run. A batch reaching beyond that window is measured first
    /// instead: its finite points' bounding box bounds its cells (the cell index is monotone in
    /// each coordinate), whose indexes then pack relative to that box; a box that does not
    /// pack into 63 bits is sorted by comparison.
    fn sort_batch<It>(&self, points: It) -> (SortedBatch<D>, u64)
    where
        It: Iterator<Item = [f64; D]> + Clone,
    {
        let n_hint = match points.size_hint() {
            (_, Some(upper)) => upper,
            (lower, None) => lower,
        };
        if let Some(ids) = self.ids_in_window(points.clone(), n_hint) {
            return self.finish_sort(points, ids);
        }
        let mut lo = [f64::INFINITY; D];
        let mut hi = [f64::NEG_INFINITY; D];
        let mut n = 0;
        // Only a build (batch into an empty grid) takes the narrow arena.
        let mut narrow = self.is_empty();
        for p in points.clone() {
            n += 1;
            if all_finite(&p) {
                if narrow {
                    narrow = narrow_point(&p).is_some();
                }
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
        let mut ids = CellIds::new(n, packing);
        ids.narrow = narrow;
        let (size, offset) = (self.spec.size(), self.spec.offset());
        for p in points.clone() {
            let Some(key) = packing.key_in_box(&p, size, offset) else {
                ids.reject();
                continue;
            };
            debug_assert_eq!(
                self.spec.cell_index(&p).map(|i| packing.pack(&i)),
                Some(key)
            );
            ids.push(key);
        }
        self.finish_sort(points, ids)
    }

    /// The cell ids of a batch whose finite points' cells all lie within `2^(W - 1)` cells of
    /// the first finite point's cell on every axis (`W = min(63 / D, 48)` bits per axis), in one
    /// pass;
    /// `None` (work discarded) as soon as one does not, or when `D > 21`. Keys are packed
    /// relative to the window first and repacked relative to the distinct cells' box at the
    /// end (both keep the lexicographic order).
    fn ids_in_window<It>(&self, points: It, n_hint: usize) -> Option<CellIds<D>>
    where
        It: Iterator<Item = [f64; D]> + Clone,
    {
        if D == 0 || D > 21 {
            return None;
        }
        let w = (63 / D as u32).min(48);
        let half = 1i64 << (w - 1);
        let field = (1u64 << w) - 1;
        let first = points.clone().find(all_finite)?;
        let base = self.spec.cell_index(&first)?;
        // Every index within the window is then within `MAX_CELL_INDEX`, as `cell_index` wants.
        if base.iter().any(|b| b.abs() > MAX_CELL_INDEX - half) {
            return None;
        }
        // Window position of axis `a`'s field in a key.
        let shift = |a: usize| w * (D - 1 - a) as u32;
        // The cell of window fields `f`, and of a window key.
        let to_index = |f: &[u64; D]| -> CellIndex<D> {
            std::array::from_fn(|a| base[a] - half + f[a] as i64)
        };
        let index_of = |k: u64| to_index(&std::array::from_fn(|a| (k >> shift(a)) & field));
        let wide = Packing::new(&base, &base)?;
        let mut ids = CellIds::new(n_hint, wide);
        ids.narrow = self.is_empty();
        let (size, offset) = (self.spec.size(), self.spec.offset());
        for p in points {
            if !all_finite(&p) {
                ids.reject();
                continue;
            }
            if ids.narrow {
                ids.narrow = narrow_point(&p).is_some();
            }
            let mut key = 0u64;
            for a in 0..D {
                // Exact floor within the window; beyond it the saturated value fails the
                // window test.
                let t = floor_trunc((p[a] - offset[a]) / size[a]);
                let f = t.wrapping_sub(base[a]).wrapping_add(half) as u64;
                if f > field {
                    return None;
                }
                key |= f << shift(a);
            }
            debug_assert_eq!(self.spec.cell_index(&p), Some(index_of(key)));
            ids.push(key);
        }
        // Repack relative to the box of the distinct cells.
        let mut lo = [u64::MAX; D];
        let mut hi = [0u64; D];
        for &k in &ids.keys {
            for a in 0..D {
                let f = (k >> shift(a)) & field;
                lo[a] = lo[a].min(f);
                hi[a] = hi[a].max(f);
            }
        }
        if ids.keys.is_empty() {
            lo = [half as u64; D];
            hi = lo;
        }
        let packing = Packing::new(&to_index(&lo), &to_index(&hi))?;
        for k in ids.keys.iter_mut() {
            *k = packing.pack(&index_of(*k));
        }
        ids.packing = packing;
        Some(ids)
    }

    /// Sort the cells of `ids` by key and move `points` (the batch again) into their runs.
    fn finish_sort<It>(&self, points: It, ids: CellIds<D>) -> (SortedBatch<D>, u64)
    where
        It: Iterator<Item = [f64; D]>,
    {
        let CellIds {
            packing,
            ids,
            table,
            keys,
            mut counts,
            rejected,
            narrow,
            ..
        } = ids;
        let order = sort_keys(&keys);
        let mut end = 0;
        for &id in &order {
            let c = &mut counts[id as usize];
            let here = *c as usize;
            *c = to_u32(end);
            end += here;
        }
        let (sorted, sorted32) = if narrow {
            let conv = |p: [f64; D]| p.map(|v| v as f32);
            (
                Vec::new(),
                Some(scatter(points, &ids, &mut counts, end, conv)),
            )
        } else {
            (scatter(points, &ids, &mut counts, end, |p| p), None)
        };
        (
            SortedBatch {
                len: end,
                points: sorted,
                narrow: sorted32,
                runs: Runs::Packed {
                    packing,
                    keys,
                    order,
                    ends: counts,
                },
                spare: table.into_buffer(),
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
                len: sorted.len(),
                points: sorted,
                narrow: None,
                runs: Runs::Listed(runs),
                spare: Vec::new(),
            },
            rejected,
        )
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
        // a representative lies in its cell, so its distance is at most about D / 4.
        let mut distance = DistanceSort::new(cells, D as f64 / 4.0);
        let mut start = 0;
        for k in 0..cells {
            let (index, end) = batch.runs.get(k);
            let (sel, rank) = match (&self.selection, &self.narrow) {
                // The usual case, without the arena form's dispatch per member.
                (Selection::CentreClosest, Some(arena)) => centre_closest(
                    &self.spec.cell_centre(&index),
                    self.spec.size(),
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
    }
}

/// A batch's points' cell ids being assigned: one per point (`u32::MAX` for a rejected point),
/// ids numbered by first appearance, with each id's packed key and point count.
struct CellIds<const D: usize> {
    packing: Packing<D>,
    ids: Vec<u32>,
    table: KeyTable,
    keys: Vec<u64>,
    /// Points per cell id; later the start, then the end, of each cell's run (a batch holds
    /// at most `MAX_POINTS` < 2^31 points, so these fit `u32`).
    counts: Vec<u32>,
    last: (u64, u32),
    rejected: u64,
    /// Whether every accepted point so far is exact in `f32` (and the batch builds a grid).
    narrow: bool,
}

impl<const D: usize> CellIds<D> {
    /// For a batch of about `n` points.
    fn new(n: usize, packing: Packing<D>) -> Self {
        let table = KeyTable::new(n);
        CellIds {
            packing,
            ids: Vec::with_capacity(n),
            keys: Vec::with_capacity(table.expected()),
            counts: Vec::with_capacity(table.expected()),
            table,
            last: (u64::MAX, 0),
            rejected: 0,
            narrow: false,
        }
    }

    /// The next point lies in the cell with packed key `key`.
    #[inline]
    fn push(&mut self, key: u64) {
        let id = if key == self.last.0 {
            self.last.1
        } else {
            let id = self.table.get_or_insert(key, &mut self.keys);
            if id as usize == self.counts.len() {
                self.counts.push(0);
            }
            self.last = (key, id);
            id
        };
        self.counts[id as usize] += 1;
        self.ids.push(id);
    }

    /// The next point is rejected.
    #[inline]
    fn reject(&mut self) {
        self.rejected += 1;
        self.ids.push(u32::MAX);
    }
}

/// Move each point with a cell id (`ids`, `u32::MAX` for none) to its cell's run, converted by
/// `conv`; `next[id]` holds the start of cell `id`'s run and ends at its end. `len` points.
fn scatter<const D: usize, T: Copy + Default>(
    points: impl Iterator<Item = [f64; D]>,
    ids: &[u32],
    next: &mut [u32],
    len: usize,
    conv: impl Fn([f64; D]) -> [T; D],
) -> Vec<[T; D]> {
    let mut sorted = vec![[T::default(); D]; len];
    for (p, &id) in points.zip(ids) {
        if id != u32::MAX {
            let at = &mut next[id as usize];
            sorted[*at as usize] = conv(p);
            *at += 1;
        }
    }
    sorted
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

/// Hash table from a packed cell key to a batch-local id (`keys[id]` is the key): open
/// addressing, linear probing, at most half full, over 8-byte buckets `fingerprint | id`
/// (the id in the low `id_bits`, hash bits above). A bucket whose fingerprint matches is
/// confirmed against `keys`.
struct KeyTable {
    buckets: Vec<u64>,
    len: usize,
    shift: u32,
    id_mask: u64,
    /// About how many points the batch has (sizes the growth).
    points: usize,
}

/// An empty [`KeyTable`] bucket: no id reaches `id_mask`, so no entry is all ones.
const FREE: u64 = u64::MAX;

impl KeyTable {
    /// A table for the ids of a batch of about `n` points (`n` only sizes it).
    fn new(n: usize) -> Self {
        // Ids are `u32` below `u32::MAX` (see `new_slot`), so `id < id_mask` and no entry
        // equals `FREE`; 32 fingerprint bits remain.
        let id_bits = 32;
        // Room for n / 16 cells at first (real scans hold 5-30 % as many cells as points), so
        // that the table rarely grows; between 2^10 and 2^22 buckets.
        let log = (n / 8).next_power_of_two().trailing_zeros().clamp(10, 22);
        KeyTable {
            buckets: vec![FREE; 1 << log],
            len: 0,
            shift: 64 - log,
            id_mask: (1u64 << id_bits) - 1,
            points: n,
        }
    }

    /// Number of keys the table holds before it first grows.
    fn expected(&self) -> usize {
        self.buckets.len() / 2
    }

    #[inline]
    fn hash(key: u64) -> u64 {
        (key ^ (key >> 29)).wrapping_mul(0x9E37_79B9_7F4A_7C15)
    }

    /// Home bucket (high hash bits) and fingerprint (other hash bits, above the id).
    #[inline]
    fn place_of(&self, key: u64) -> (usize, u64) {
        let h = Self::hash(key);
        (
            (h >> self.shift) as usize,
            h.rotate_right(32) & !self.id_mask,
        )
    }

    /// The id of `key`; a new key gets the id `keys.len()` and is appended to `keys`.
    #[inline]
    fn get_or_insert(&mut self, key: u64, keys: &mut Vec<u64>) -> u32 {
        let mask = self.buckets.len() - 1;
        let (mut i, fp) = self.place_of(key);
        loop {
            let e = self.buckets[i];
            if e == FREE {
                let id = new_slot(keys.len());
                keys.push(key);
                self.buckets[i] = fp | u64::from(id);
                self.len += 1;
                if 2 * self.len > self.buckets.len() {
                    self.grow(keys);
                }
                return id;
            }
            if e & !self.id_mask == fp {
                let id = (e & self.id_mask) as u32;
                if keys[id as usize] == key {
                    return id;
                }
            }
            i = (i + 1) & mask;
        }
    }

    /// Double the table, or quadruple it while it is small next to the batch (fewer rehashes
    /// for batches with many cells per point).
    fn grow(&mut self, keys: &[u64]) {
        let step = if self.buckets.len().saturating_mul(4) <= self.points && self.shift > 2 {
            2
        } else {
            1
        };
        let size = self.buckets.len() << step;
        let old = std::mem::replace(&mut self.buckets, vec![FREE; size]);
        self.shift -= step;
        let mask = size - 1;
        for e in old {
            if e != FREE {
                let (mut i, _) = self.place_of(keys[(e & self.id_mask) as usize]);
                while self.buckets[i] != FREE {
                    i = (i + 1) & mask;
                }
                // The fingerprint does not depend on the table size.
                self.buckets[i] = e;
            }
        }
    }

    /// The bucket storage, for reuse.
    fn into_buffer(self) -> Vec<u64> {
        self.buckets
    }
}
