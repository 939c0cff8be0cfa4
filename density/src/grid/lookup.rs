//! The store's hash index from cell index to slot: the look-ups of insertion, deletion and the
//! read cycle's neighbour checks.

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
    pub(crate) fn find(&self, h: u64, holds: impl FnMut(u32) -> bool) -> Option<u32> {
        self.probe(h, h as usize & self.mask(), holds)
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
        self.probe(h, (h as usize & mask).wrapping_add(1) & mask, holds)
    }

    /// The look-up of [`Self::find`] from bucket `i` on, up to the first empty bucket.
    #[inline]
    fn probe(&self, h: u64, mut i: usize, mut holds: impl FnMut(u32) -> bool) -> Option<u32> {
        let mask = self.mask();
        let tag = h as u32;
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
