//! The hash table of a batch sort: packed cell key -> batch-local cell id.

use super::store::new_slot;

/// Hash table from a packed cell key to a batch-local id (`keys[id]` is the key): open
/// addressing, linear probing, at most half full, over 8-byte buckets `fingerprint | id`
/// (the id in the low `id_bits`, hash bits above). A bucket whose fingerprint matches is
/// confirmed against `keys`.
pub(super) struct KeyTable {
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
    pub(super) fn new(n: usize) -> Self {
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
    pub(super) fn expected(&self) -> usize {
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
    pub(super) fn get_or_insert(&mut self, key: u64, keys: &mut Vec<u64>) -> u32 {
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
    pub(super) fn into_buffer(self) -> Vec<u64> {
        self.buckets
    }
}
