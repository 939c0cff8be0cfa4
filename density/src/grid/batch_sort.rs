//! A batch sorted by cell, for [`DensityGrid::extend`].
//!
//! A counting sort. One pass gives each point a batch-local cell id through a hash table keyed
//! by the cell index packed into a `u64` (`key_table.rs`, `packing.rs`), relative to the first
//! finite point's cell (integer order = lexicographic order); the distinct cells' keys are
//! repacked relative to their own box and alone sorted (`octoquant-radix`); a last pass moves
//! each point into its cell's run. A batch reaching beyond the first pass's window is measured
//! first (its finite points' bounding box bounds its cells), and one whose box does not pack
//! into 63 bits is sorted by comparison.

use super::arena::narrow_point;
use super::key_table::KeyTable;
use super::packing::Packing;
use super::store::{to_u32, DensityGrid};
use crate::spec::{all_finite, floor_trunc, CellIndex, MAX_CELL_INDEX};

/// A batch sorted by cell: the points in cell order and its cells' runs.
pub(super) struct SortedBatch<const D: usize> {
    /// Accepted points.
    pub(super) len: usize,
    /// The points in cell order, unless they are in `narrow`.
    pub(super) points: Vec<[f64; D]>,
    /// The points in cell order as `f32`, when all are exact in `f32` and the batch goes into
    /// an empty grid (the narrow arena, see `arena.rs`).
    pub(super) narrow: Option<Vec<[f32; D]>>,
    pub(super) runs: Runs<D>,
    /// The key table's buckets, handed on as the hash index's storage (already faulted in).
    pub(super) spare: Vec<u64>,
}

/// The cells of a [`SortedBatch`] in index order, each with the end of its run in `points`.
pub(super) enum Runs<const D: usize> {
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
    pub(super) fn len(&self) -> usize {
        match self {
            Runs::Packed { order, .. } => order.len(),
            Runs::Listed(v) => v.len(),
        }
    }

    /// The `k`-th cell in index order and the end of its run.
    #[inline]
    pub(super) fn get(&self, k: usize) -> (CellIndex<D>, usize) {
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
    pub(super) fn sort_batch<It>(&self, points: It) -> (SortedBatch<D>, u64)
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
        // by the key bits alone (the keys are distinct, so the ids never decide)
        let mut scratch = vec![0u64; words.len()];
        octoquant_radix::sort_by_key(&mut words, &mut scratch, |&w| w >> id_bits);
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
