//! Fast building blocks of the density reducer's store: a compact hash index from cell index
//! to slot (the look-ups of insertion, deletion and the read cycle's neighbour checks), an
//! exact `floor` without a libm call, packing of cell indexes into one `u64` whose integer
//! order is the lexicographic order, an LSD radix sort on such keys (the sort of a batch's
//! distinct cells), and a bucket sort of `(distance, slot)` pairs (the distance order of a
//! build).

use crate::spec::CellIndex;

/// Hash of a cell index: multiply-rotate over the axes, then a 64-bit finaliser so that small,
/// dense indexes spread over all bits.
#[inline]
pub(crate) fn hash_index<const D: usize>(index: &CellIndex<D>) -> u64 {
    let mut h = 0u64;
    for &v in index {
        h = (h.rotate_left(23) ^ v as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    }
    h ^= h >> 31;
    h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    h ^ (h >> 29)
}

/// Hash index from cell index to slot: open addressing with linear probing over 8-byte buckets
/// `(hash low 32 bits) << 32 | slot`, at most half full. It does not hold the keys: a probe
/// whose hash bits match asks the caller whether the slot holds the key, which the caller
/// answers from the cell it then needs anyway. Deletion shifts the following entries back, so
/// there are no tombstones.
#[derive(Debug, Clone)]
pub(crate) struct SlotTable {
    buckets: Vec<u64>,
    len: usize,
}

/// An empty bucket (no slot is `u32::MAX`).
const EMPTY: u64 = u64::MAX;

impl Default for SlotTable {
    fn default() -> Self {
        SlotTable {
            buckets: vec![EMPTY; 16],
            len: 0,
        }
    }
}

impl SlotTable {
    /// Number of entries.
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    #[inline]
    fn mask(&self) -> usize {
        self.buckets.len() - 1
    }

    /// The slot with hash `h` for which `holds(slot)` is true.
    #[inline]
    pub(crate) fn find(&self, h: u64, mut holds: impl FnMut(u32) -> bool) -> Option<u32> {
        let mask = self.mask();
        let tag = h as u32;
        let mut i = h as usize & mask;
        loop {
            let e = self.buckets[i];
            if e == EMPTY {
                return None;
            }
            if (e >> 32) as u32 == tag && holds(e as u32) {
                return Some(e as u32);
            }
            i = (i + 1) & mask;
        }
    }

    /// The first bucket a look-up of hash `h` examines (to be passed to [`Self::find_from`]).
    #[inline]
    pub(crate) fn first_bucket(&self, h: u64) -> u64 {
        self.buckets[h as usize & self.mask()]
    }

    /// [`Self::find`], given the first bucket `e` already read by [`Self::first_bucket`].
    #[inline]
    pub(crate) fn find_from(
        &self,
        h: u64,
        e: u64,
        mut holds: impl FnMut(u32) -> bool,
    ) -> Option<u32> {
        if e == EMPTY {
            return None;
        }
        if (e >> 32) as u32 == h as u32 && holds(e as u32) {
            return Some(e as u32);
        }
        let mask = self.mask();
        let tag = h as u32;
        let mut i = (h as usize & mask).wrapping_add(1) & mask;
        loop {
            let e = self.buckets[i];
            if e == EMPTY {
                return None;
            }
            if (e >> 32) as u32 == tag && holds(e as u32) {
                return Some(e as u32);
            }
            i = (i + 1) & mask;
        }
    }

    /// An empty table with room for `entries` entries, in `buffer`'s storage when it is large
    /// enough (its content is discarded).
    pub(crate) fn with_buffer(mut buffer: Vec<u64>, entries: usize) -> Self {
        let want = (2 * entries).next_power_of_two().max(16);
        buffer.clear();
        buffer.resize(want, EMPTY);
        SlotTable {
            buckets: buffer,
            len: 0,
        }
    }

    /// Make room for `extra` more entries.
    pub(crate) fn reserve(&mut self, extra: usize) {
        let want = (2 * (self.len + extra)).next_power_of_two().max(16);
        if want > self.buckets.len() {
            let old = std::mem::replace(&mut self.buckets, vec![EMPTY; want]);
            for e in old {
                if e != EMPTY {
                    self.place(e);
                }
            }
        }
    }

    fn place(&mut self, e: u64) {
        let mask = self.mask();
        let mut i = (e >> 32) as usize & mask;
        while self.buckets[i] != EMPTY {
            i = (i + 1) & mask;
        }
        self.buckets[i] = e;
    }

    /// [`Self::insert`] when the table is known to have room (as sized by
    /// [`Self::with_buffer`]); grows anyway if it has not.
    #[inline]
    pub(crate) fn insert_with_room(&mut self, h: u64, slot: u32) {
        if 2 * (self.len + 1) > self.buckets.len() {
            self.reserve(1);
        }
        self.place(((h as u32 as u64) << 32) | u64::from(slot));
        self.len += 1;
    }

    /// Add `slot` with hash `h` (the key must not be present).
    pub(crate) fn insert(&mut self, h: u64, slot: u32) {
        debug_assert_ne!(slot, u32::MAX);
        self.reserve(1);
        self.place(((h as u32 as u64) << 32) | u64::from(slot));
        self.len += 1;
    }

    /// Remove `slot`, stored with hash `h`; returns whether it was there.
    pub(crate) fn remove(&mut self, h: u64, slot: u32) -> bool {
        let mask = self.mask();
        let want = ((h as u32 as u64) << 32) | u64::from(slot);
        let mut i = h as usize & mask;
        loop {
            let e = self.buckets[i];
            if e == EMPTY {
                return false;
            }
            if e == want {
                break;
            }
            i = (i + 1) & mask;
        }
        // Backward shift: move later entries of the cluster into the hole when their home
        // bucket does not lie cyclically in (hole, their position].
        let mut hole = i;
        let mut j = (i + 1) & mask;
        loop {
            let e = self.buckets[j];
            if e == EMPTY {
                break;
            }
            let home = (e >> 32) as usize & mask;
            let stays = if hole <= j {
                hole < home && home <= j
            } else {
                hole < home || home <= j
            };
            if !stays {
                self.buckets[hole] = e;
                hole = j;
            }
            j = (j + 1) & mask;
        }
        self.buckets[hole] = EMPTY;
        self.len -= 1;
        true
    }
}

/// `floor(q)` as an integer when `|floor(q)| <= limit` (`limit < 2^62`), else `None` (also for
/// NaN and infinities). Exactly `q.floor()`, without the libm call that `f64::floor` becomes on
/// x86-64 targets without SSE4.1.
#[inline]
pub(crate) fn floor_index(q: f64, limit: i64) -> Option<i64> {
    // 2^62: beyond it every f64 is an integer far out of range; NaN fails the comparison too.
    if q.is_nan() || q.abs() >= 4_611_686_018_427_387_904.0 {
        return None;
    }
    let t = floor_trunc(q);
    (t.abs() <= limit).then_some(t)
}

/// `floor(q)` as an `i64`, exact for `|q| < 2^63` (saturating beyond, 0 for NaN), inline.
///
/// Truncation toward zero is exact; at or above 2^52 `q` is already an integer, below it the
/// truncation converts back exactly, so one comparison decides floor vs. truncation.
#[inline(always)]
pub(crate) fn floor_trunc(q: f64) -> i64 {
    let t = q as i64;
    if (t as f64) > q {
        t.saturating_sub(1)
    } else {
        t
    }
}

/// `true` when no coordinate of `p` is NaN or infinite, with one branch: `x * 0` is (a signed)
/// 0 for a finite `x` and NaN otherwise.
#[inline]
pub(crate) fn all_finite<const D: usize>(p: &[f64; D]) -> bool {
    let mut z = 0.0;
    for v in p {
        z += v * 0.0;
    }
    z == 0.0
}

/// Packing of cell indexes within a box of cells into `u64` keys, axis 0 most significant, so
/// that the integer order of keys is the lexicographic order of the indexes.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Packing<const D: usize> {
    min: CellIndex<D>,
    shift: [u32; D],
    mask: [u64; D],
    /// Total key bits.
    pub bits: u32,
}

impl<const D: usize> Packing<D> {
    /// The packing of the box `lo..=hi` (per axis), or `None` when it needs more than 64 bits.
    pub(crate) fn new(lo: &CellIndex<D>, hi: &CellIndex<D>) -> Option<Self> {
        let mut width = [0u32; D];
        for a in 0..D {
            // Both ends lie within +-2^53, so the span fits in u64.
            let span = hi[a].abs_diff(lo[a]);
            width[a] = 64 - span.leading_zeros();
        }
        let bits: u32 = width.iter().sum();
        if bits > 64 {
            return None;
        }
        let mut shift = [0u32; D];
        let mut mask = [0u64; D];
        let mut s = 0;
        for a in (0..D).rev() {
            shift[a] = s;
            mask[a] = if width[a] == 0 {
                0
            } else {
                u64::MAX >> (64 - width[a])
            };
            s += width[a];
        }
        Some(Packing {
            min: *lo,
            shift,
            mask,
            bits,
        })
    }

    /// The key of `index`, which must lie in the box.
    #[inline]
    pub(crate) fn pack(&self, index: &CellIndex<D>) -> u64 {
        let mut k = 0u64;
        for (a, &v) in index.iter().enumerate() {
            // `shift` is < 64 whenever the axis has a non-zero width; a zero-width axis adds 0.
            if self.mask[a] != 0 {
                k |= v.abs_diff(self.min[a]) << self.shift[a];
            }
        }
        k
    }

    /// The key of the cell holding the finite point `p` (`None` for a NaN or infinite
    /// coordinate), for a packing whose box holds the cells of every finite point of a batch
    /// (`lo..=hi` the cells of the batch's coordinate-wise minimum and maximum, `bits < 64`).
    ///
    /// Same cell as [`GridSpec::cell_index`](crate::GridSpec::cell_index) then `pack`, without
    /// the range checks: `(x - offset) / size` is monotone in `x`, so a finite coordinate's
    /// quotient lies between those of the box's corners, whose floors are in range.
    #[inline]
    pub(crate) fn key_in_box(
        &self,
        p: &[f64; D],
        size: &[f64; D],
        offset: &[f64; D],
    ) -> Option<u64> {
        if !all_finite(p) {
            return None;
        }
        let mut k = 0u64;
        for a in 0..D {
            // Exact floor (|q| <= 2^53 + 1 here).
            let t = floor_trunc((p[a] - offset[a]) / size[a]);
            // `t >= min[a]` by monotonicity, and `shift[a] < bits < 64`; a zero-width axis
            // adds 0 (there `t == min[a]`). Wrapping keeps a violated assumption panic-free.
            k |= (t.wrapping_sub(self.min[a]) as u64) << (self.shift[a] & 63);
        }
        Some(k)
    }

    /// The index of key `k`.
    #[inline]
    pub(crate) fn unpack(&self, k: u64) -> CellIndex<D> {
        let mut index = self.min;
        for (a, v) in index.iter_mut().enumerate() {
            if self.mask[a] != 0 {
                *v += ((k >> self.shift[a]) & self.mask[a]) as i64;
            }
        }
        index
    }
}

/// Stable LSD radix sort of `v` by bits `lo..hi` of each word, in as few passes of at most
/// 11-bit digits as the range needs; digits on which every word agrees are skipped. `scratch`
/// is reused between calls.
pub(crate) fn radix_sort_bits(v: &mut Vec<u64>, scratch: &mut Vec<u64>, lo: u32, hi: u32) {
    radix_sort_by_key(v, scratch, |&x| x, lo, hi);
}

/// Stable LSD radix sort of `v` by bits `lo..hi` of `key(element)`, as [`radix_sort_bits`].
pub(crate) fn radix_sort_by_key<T: Copy>(
    v: &mut Vec<T>,
    scratch: &mut Vec<T>,
    key: impl Fn(&T) -> u64,
    lo: u32,
    hi: u32,
) {
    if v.len() < 2 || hi <= lo {
        return;
    }
    let passes = (hi - lo).div_ceil(11);
    let width = (hi - lo).div_ceil(passes);
    let buckets = 1usize << width;
    let digit_mask = buckets as u64 - 1;
    // Histograms of every digit in one pass.
    let mut counts = vec![0usize; buckets * passes as usize];
    for x in v.iter() {
        let y = key(x) >> lo;
        for d in 0..passes {
            counts[d as usize * buckets + ((y >> (width * d)) & digit_mask) as usize] += 1;
        }
    }
    scratch.clear();
    scratch.resize(v.len(), v[0]);
    for (d, c) in counts.chunks_exact_mut(buckets).enumerate() {
        if c.contains(&v.len()) {
            continue;
        }
        // Counts become start positions.
        let mut sum = 0;
        for n in c.iter_mut() {
            let here = *n;
            *n = sum;
            sum += here;
        }
        let s = lo + width * d as u32;
        for x in v.iter() {
            let b = ((key(x) >> s) & digit_mask) as usize;
            scratch[c[b]] = *x;
            c[b] += 1;
        }
        std::mem::swap(v, scratch);
    }
}

/// Sort `(distance bits, slot)` pairs ascending (by bits, then slot), where every bits value is
/// that of a non-negative `f64` (so the bits order is the value order), with buckets spread
/// over the data's own range. See [`DistanceSort`].
#[cfg(test)]
pub(crate) fn sort_by_distance(v: &mut Vec<(u64, u32)>) {
    let max = v
        .iter()
        .map(|e| f64::from_bits(e.0))
        .fold(0.0f64, |m, d| if d > m { d } else { m });
    let mut sort = DistanceSort::new(v.len(), max);
    for e in v.iter() {
        sort.count(e.0);
    }
    *v = sort.place(v.iter().copied());
}

/// A bucket sort of `(distance bits, slot)` pairs on the distance value (bits of non-negative
/// `f64`s), fed in two passes so that the caller need not hold the pairs in between: first
/// [`DistanceSort::count`] every distance, then [`DistanceSort::place`] the pairs.
///
/// Each pair goes to bucket `floor(value * scale)` (monotone in the value; values beyond the
/// expected maximum go to the last bucket), the buckets are filled in one pass, and each bucket
/// is then sorted on the full pair (insertion sort when small, else a comparison sort). About
/// three passes over the pairs for any spread of distances; no quadratic case. The pairs are
/// distinct when the slots are, so the result is the unique sorted order.
pub(crate) struct DistanceSort {
    scale: f64,
    /// Per bucket: the count, then (after `place`) the end of its run.
    ends: Vec<u32>,
}

impl DistanceSort {
    /// A sort of `n` pairs whose distances mostly lie in `0..=max`.
    pub(crate) fn new(n: usize, max: f64) -> Self {
        let buckets = n.clamp(1, 1 << 20);
        let top = (buckets - 1) as f64;
        // `scale` is finite and non-negative (0 when `max` is 0 or not finite), so
        // `value * scale` is monotone in the value.
        let scale = if max > 0.0 && max.is_finite() {
            top / max
        } else {
            0.0
        };
        DistanceSort {
            scale,
            ends: vec![0; buckets],
        }
    }

    #[inline]
    fn bucket_of(&self, bits: u64) -> usize {
        // The saturating cast maps NaN to 0 and the clamp keeps large values in range.
        ((f64::from_bits(bits) * self.scale) as usize).min(self.ends.len() - 1)
    }

    /// First pass: count one pair's distance.
    #[inline]
    pub(crate) fn count(&mut self, bits: u64) {
        let b = self.bucket_of(bits);
        self.ends[b] += 1;
    }

    /// Second pass: the counted pairs (the same distances, in any order), sorted.
    pub(crate) fn place(mut self, pairs: impl Iterator<Item = (u64, u32)>) -> Vec<(u64, u32)> {
        // Counts become starts.
        let mut sum = 0u32;
        for e in self.ends.iter_mut() {
            let here = *e;
            *e = sum;
            sum = sum.wrapping_add(here);
        }
        let n = sum as usize;
        let mut out = vec![(0u64, 0u32); n];
        for e in pairs {
            let b = self.bucket_of(e.0);
            let at = &mut self.ends[b];
            if let Some(slot) = out.get_mut(*at as usize) {
                *slot = e;
            }
            *at += 1;
        }
        // Starts have become ends; bucket b is `ends[b - 1]..ends[b]`.
        let mut from = 0usize;
        for &end in &self.ends {
            let end = (end as usize).min(n);
            let run = &mut out[from.min(end)..end];
            from = end;
            if run.len() <= 16 {
                for i in 1..run.len() {
                    let mut j = i;
                    while j > 0 && run[j] < run[j - 1] {
                        run.swap(j, j - 1);
                        j -= 1;
                    }
                }
            } else {
                run.sort_unstable();
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floor_index_is_floor() {
        let limit = 1i64 << 53;
        let cases = [
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            -1.0000001,
            2.9999999,
            -7.5,
            4503599627370495.5,
            -4503599627370495.5,
            9007199254740992.0,
            -9007199254740992.0,
            9007199254740994.0,
            1e17,
            -1e300,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
        ];
        for q in cases {
            let f = q.floor();
            let want = (f.is_finite() && f.abs() <= limit as f64).then_some(f as i64);
            assert_eq!(floor_index(q, limit), want, "{q}");
        }
    }

    #[test]
    fn all_finite_is_is_finite_on_every_axis() {
        let vals = [
            0.0,
            -0.0,
            1.5,
            -1e300,
            f64::MAX,
            f64::MIN,
            f64::MIN_POSITIVE / 4.0,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        for &a in &vals {
            for &b in &vals {
                for &c in &vals {
                    let p = [a, b, c];
                    assert_eq!(all_finite(&p), p.iter().all(|v| v.is_finite()), "{p:?}");
                }
            }
        }
    }

    #[test]
    fn packing_keeps_lexicographic_order() {
        let lo = [-3i64, 5, -100];
        let hi = [4i64, 5, 27];
        let p = Packing::new(&lo, &hi).unwrap();
        assert_eq!(p.bits, 3 + 7);
        let mut all = Vec::new();
        for x in lo[0]..=hi[0] {
            for z in lo[2]..=hi[2] {
                all.push([x, 5, z]);
            }
        }
        for w in all.windows(2) {
            assert!(p.pack(&w[0]) < p.pack(&w[1]));
            assert_eq!(p.unpack(p.pack(&w[0])), w[0]);
        }
        let big = 1i64 << 53;
        assert!(Packing::new(&[-big, 0], &[big, 0]).is_some());
        assert!(Packing::new(&[-big, -big], &[big, big]).is_none());
        assert!(Packing::new(&[7i64; 4], &[7i64; 4]).unwrap().bits == 0);
    }

    /// Random inserts and deletes against a `HashMap`, with a weak hash so that clusters form
    /// and wrap around the table's end.
    #[test]
    fn slot_table_matches_a_hash_map() {
        use std::collections::HashMap;
        let mut t = SlotTable::default();
        let mut m: HashMap<u32, u64> = HashMap::new();
        let mut x = 99u64;
        for step in 0..20_000u32 {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let slot = ((x >> 40) % 3000) as u32;
            // Few distinct hashes, many equal tags: probing must ask `holds`.
            let h = u64::from(slot % 37) * 0x1_0000_0001 + 0xFFF0;
            if let std::collections::hash_map::Entry::Vacant(e) = m.entry(slot) {
                if step % 3 != 0 {
                    t.insert(h, slot);
                    e.insert(h);
                }
            } else if step % 2 == 0 {
                assert!(t.remove(h, slot));
                m.remove(&slot);
            }
            assert_eq!(t.len(), m.len());
            if step % 97 == 0 {
                for s in 0..3000u32 {
                    let h = u64::from(s % 37) * 0x1_0000_0001 + 0xFFF0;
                    let want = m.contains_key(&s).then_some(s);
                    assert_eq!(t.find(h, |c| c == s), want, "slot {s}");
                }
            }
        }
        assert!(!t.remove(5, 4000));
    }

    #[test]
    fn radix_sort_sorts_stably_by_the_bit_range() {
        let mut x = 12345u64;
        let mut v: Vec<u64> = (0..5000u64)
            .map(|i| {
                x = x
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((x >> 40) << 13) | i
            })
            .collect();
        let mut want = v.clone();
        want.sort_by_key(|w| w >> 13);
        radix_sort_bits(&mut v, &mut Vec::new(), 13, 13 + 24);
        assert_eq!(v, want);
    }

    #[test]
    fn distance_sort_matches_a_comparison_sort() {
        let mut x = 777u64;
        let mut next = || {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            x >> 11
        };
        let cases: Vec<Vec<f64>> = vec![
            vec![],
            vec![0.3],
            vec![0.0; 100],
            (0..5000).map(|_| (next() % 1000) as f64 / 1333.0).collect(),
            (0..3000).map(|_| (next() % 7) as f64 * 0.1).collect(),
            (0..2000)
                .map(|i| {
                    if i % 500 == 0 {
                        f64::INFINITY
                    } else {
                        (next() % 100) as f64
                    }
                })
                .collect(),
            (0..2000)
                .map(|i| {
                    if i == 7 {
                        1e300
                    } else {
                        (next() % 1000) as f64 * 1e-6
                    }
                })
                .collect(),
            (0..2000).map(|_| f64::from_bits(next() >> 2)).collect(),
        ];
        for d in cases {
            let mut v: Vec<(u64, u32)> = d
                .iter()
                .enumerate()
                .map(|(i, &d)| (d.to_bits(), (i as u32).wrapping_mul(2654435761) % 100_000))
                .collect();
            let mut want = v.clone();
            want.sort();
            // Buckets over a fixed range that may be far too small or too large.
            for max in [0.75, 1e-9, 1e9] {
                let mut sort = DistanceSort::new(v.len(), max);
                for e in &v {
                    sort.count(e.0);
                }
                assert_eq!(sort.place(v.iter().rev().copied()), want);
            }
            sort_by_distance(&mut v);
            assert_eq!(v, want);
        }
    }
}
