//! OctoMap's record of changed voxels (`KeyBoolMap`), kept in the order OctoMap iterates it
//! when built with GCC.
//!
//! Why the order matters: dynamicEDT3D's `update` takes the changed voxels in that order, and
//! where two obstacles are equally near a voxel, the one it reports is the one whose wave got
//! there first. Reproducing the reported obstacle after an update needs the same order.
//!
//! # The model
//!
//! Under GCC, OctoMap's `OcTreeKey.h` picks `std::tr1::unordered_map<OcTreeKey, bool,
//! OcTreeKey::KeyHash>` (not `std::unordered_map`), libstdc++'s TR1 hash table
//! (`tr1/hashtable.h`, `tr1/hashtable_policy.h`). What decides its order:
//!
//! - Each bucket is its own singly linked chain; iteration walks buckets 0, 1, 2, ... and each
//!   chain from its head. The bucket of a key is `KeyHash(key) % bucket_count` with OctoMap's
//!   `KeyHash = k0 + 1447·k1 + 345637·k2` in 64-bit `size_t` arithmetic.
//! - A new key goes to the head of its bucket's chain; inserting a key already present changes
//!   nothing (not its value either). Erasing unlinks it; the others keep their places.
//! - A fresh table has 11 buckets (the default hint 10 rounded up to a prime). Before an
//!   insertion that takes the count past `_M_next_resize` (the bucket count, maximum load
//!   factor 1), `_Prime_rehash_policy::_M_need_rehash` asks for `max(n + 1, 2 · buckets)`
//!   buckets, rounded up to libstdc++'s prime list, computed in `float` as the header does
//!   (which matters only beyond 2^24 buckets); [`BUCKET_COUNTS`] is the chain of counts that
//!   growth passes through. A rehash takes bucket 0's chain from its head, then bucket 1's, ...
//!   and pushes each element onto the head of its new bucket's chain (`_M_rehash`).
//! - `clear()` (OctoMap's `resetChangeDetection`) drops the elements but keeps the bucket
//!   count and the growth threshold: the table never shrinks.

use crate::key::Key;
use std::collections::HashMap;

/// The bucket counts a `std::tr1::unordered_map` passes through as it grows one insertion at
/// a time: 11 for a fresh table, then `_M_next_bkt(ceil(2.0f · count))` of libstdc++'s prime
/// list (measured with libstdc++ 12; the list is unchanged since GCC 4.3). Growth past the
/// last entry would need more elements than memory can hold.
const BUCKET_COUNTS: [u64; 47] = [
    11,
    23,
    47,
    97,
    199,
    409,
    823,
    1741,
    3739,
    7517,
    15173,
    30727,
    62233,
    126271,
    256279,
    520241,
    1056323,
    2144977,
    4355707,
    8844859,
    17961079,
    36473443,
    74066549,
    150406843,
    305431229,
    620239453,
    1259520799,
    2557710269,
    6442450933,
    17179869143,
    51539607367,
    137438953447,
    412316860387,
    1099511627689,
    3298534883309,
    8796093022151,
    26388279066581,
    70368744177643,
    211106232532861,
    562949953421231,
    2251799813685119,
    9007199254740881,
    36028797018963913,
    144115188075855859,
    576460752303423433,
    2305843009213693951,
    9223372036854775783,
];

/// No element (the end of a chain).
const NIL: u32 = u32::MAX;

/// OctoMap's `OcTreeKey::KeyHash`.
#[inline]
fn key_hash(k: Key) -> u64 {
    u64::from(k[0]) + 1447 * u64::from(k[1]) + 345_637 * u64::from(k[2])
}

/// `_M_next_bkt(n)` for the requests growth makes: the first count of the chain `>= n`.
fn next_bucket_count(n: u64) -> u64 {
    *BUCKET_COUNTS
        .iter()
        .find(|&&b| b >= n)
        .unwrap_or(&BUCKET_COUNTS[BUCKET_COUNTS.len() - 1])
}

/// `ceil(p * max_load_factor)` with the factor 1.0f: `p` rounded to `float` first.
fn resize_threshold(p: u64) -> u64 {
    (p as f32).ceil() as u64
}

#[derive(Debug, Clone, Copy)]
struct Entry {
    key: Key,
    value: bool,
    next: u32,
}

/// OctoMap's changed-keys map with its iteration order under GCC (see the module docs).
#[derive(Debug, Clone)]
pub(crate) struct ChangeSet {
    /// Elements by slot; freed slots are reused.
    entries: Vec<Entry>,
    free: Vec<u32>,
    /// Slot of each key present.
    slots: HashMap<Key, u32>,
    /// Head of each bucket's chain (`NIL` when empty); the length is the bucket count.
    heads: Vec<u32>,
    /// `_M_next_resize`: the policy is asked for growth when the count would pass it.
    next_resize: u64,
}

impl Default for ChangeSet {
    fn default() -> Self {
        ChangeSet {
            entries: Vec::new(),
            free: Vec::new(),
            slots: HashMap::new(),
            heads: vec![NIL; BUCKET_COUNTS[0] as usize],
            next_resize: resize_threshold(BUCKET_COUNTS[0]),
        }
    }
}

impl ChangeSet {
    /// Number of keys.
    pub(crate) fn len(&self) -> usize {
        self.slots.len()
    }

    /// The value of `key`, if present.
    pub(crate) fn get(&self, key: &Key) -> Option<bool> {
        self.slots.get(key).map(|&s| self.entries[s as usize].value)
    }

    fn bucket(&self, key: Key) -> usize {
        (key_hash(key) % self.heads.len() as u64) as usize
    }

    /// `insert({key, value})`: adds the key at the head of its bucket unless present (a
    /// present key keeps its value and place).
    pub(crate) fn insert(&mut self, key: Key, value: bool) {
        if self.slots.contains_key(&key) {
            return;
        }
        if let Some(n) = self.need_rehash() {
            self.rehash(n);
        }
        let b = self.bucket(key);
        let e = Entry {
            key,
            value,
            next: self.heads[b],
        };
        let slot = match self.free.pop() {
            Some(s) => {
                self.entries[s as usize] = e;
                s
            }
            None => {
                self.entries.push(e);
                (self.entries.len() - 1) as u32
            }
        };
        self.heads[b] = slot;
        self.slots.insert(key, slot);
    }

    /// `_M_need_rehash(bucket_count, size, 1)` in its `float` arithmetic: the new bucket
    /// count, or `None` (possibly moving the threshold).
    fn need_rehash(&mut self) -> Option<u64> {
        let n_bkt = self.heads.len() as u64;
        let n_elt = self.len() as u64;
        if n_elt < self.next_resize {
            return None;
        }
        let min_bkts = 1.0f32 + n_elt as f32;
        if min_bkts > n_bkt as f32 {
            let want = min_bkts.max(2.0f32 * n_bkt as f32);
            let n = next_bucket_count(f64::from(want).ceil() as u64);
            self.next_resize = resize_threshold(n);
            Some(n)
        } else {
            self.next_resize = resize_threshold(n_bkt);
            None
        }
    }

    /// `_M_rehash`: bucket by bucket, each chain from its head, every element pushed onto the
    /// head of its new bucket's chain.
    fn rehash(&mut self, buckets: u64) {
        let old = std::mem::replace(&mut self.heads, vec![NIL; buckets as usize]);
        for head in old {
            let mut s = head;
            while s != NIL {
                let e = self.entries[s as usize];
                let b = self.bucket(e.key);
                self.entries[s as usize].next = self.heads[b];
                self.heads[b] = s;
                s = e.next;
            }
        }
    }

    /// `erase(key)`: unlinks the key; the others keep their order.
    pub(crate) fn remove(&mut self, key: &Key) {
        let Some(slot) = self.slots.remove(key) else {
            return;
        };
        let b = self.bucket(*key);
        let next = self.entries[slot as usize].next;
        if self.heads[b] == slot {
            self.heads[b] = next;
        } else {
            let mut s = self.heads[b];
            while self.entries[s as usize].next != slot {
                s = self.entries[s as usize].next;
            }
            self.entries[s as usize].next = next;
        }
        self.free.push(slot);
    }

    /// `clear()`: no keys; the bucket count and growth threshold stay.
    pub(crate) fn clear(&mut self) {
        self.entries.clear();
        self.free.clear();
        self.slots.clear();
        self.heads.fill(NIL);
    }

    /// The keys and values in OctoMap's iteration order.
    pub(crate) fn iter(&self) -> impl Iterator<Item = (Key, bool)> + '_ {
        self.heads.iter().flat_map(move |&h| {
            std::iter::successors((h != NIL).then_some(h), move |&s| {
                let n = self.entries[s as usize].next;
                (n != NIL).then_some(n)
            })
            .map(move |s| {
                let e = &self.entries[s as usize];
                (e.key, e.value)
            })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A naive model: buckets as vectors (head first), everything recomputed by scanning.
    struct Naive {
        buckets: Vec<Vec<Key>>,
        next_resize: usize,
    }

    impl Naive {
        fn new() -> Self {
            Naive {
                buckets: vec![Vec::new(); 11],
                next_resize: 11,
            }
        }

        fn len(&self) -> usize {
            self.buckets.iter().map(Vec::len).sum()
        }

        fn insert(&mut self, k: Key) {
            if self.buckets.iter().any(|b| b.contains(&k)) {
                return;
            }
            if self.len() + 1 > self.next_resize {
                let n = self.buckets.len();
                let new = *BUCKET_COUNTS.iter().find(|&&b| b >= 2 * n as u64).unwrap() as usize;
                let old = std::mem::replace(&mut self.buckets, vec![Vec::new(); new]);
                for x in old.into_iter().flatten() {
                    self.buckets[(key_hash(x) % new as u64) as usize].insert(0, x);
                }
                self.next_resize = new;
            }
            let n = self.buckets.len() as u64;
            self.buckets[(key_hash(k) % n) as usize].insert(0, k);
        }
    }

    #[test]
    fn matches_naive_buckets_through_growth_and_erasure() {
        let mut m = ChangeSet::default();
        let mut n = Naive::new();
        let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
        for i in 0..3000u32 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            // a small key space, so keys collide in buckets and repeat
            let k = Key::new((x % 40) as u16, (x >> 8) as u16 % 30, (x >> 16) as u16 % 5);
            if i % 7 == 3 {
                m.remove(&k);
                n.buckets.iter_mut().for_each(|b| b.retain(|y| *y != k));
            } else {
                m.insert(k, i % 2 == 0);
                n.insert(k);
            }
            if i == 2000 {
                m.clear();
                n.buckets.iter_mut().for_each(Vec::clear);
            }
            let got: Vec<Key> = m.iter().map(|e| e.0).collect();
            let want: Vec<Key> = n.buckets.iter().flatten().copied().collect();
            assert_eq!(got, want, "after step {i}");
        }
        assert!(m.heads.len() > 11);
    }

    #[test]
    fn growth_starts_at_11_buckets_and_a_present_key_keeps_its_value() {
        let mut m = ChangeSet::default();
        m.insert(Key::new(1, 2, 3), false);
        m.insert(Key::new(1, 2, 3), true);
        assert_eq!(m.get(&Key::new(1, 2, 3)), Some(false));
        for i in 0..10 {
            m.insert(Key::new(100 + i, 0, 0), true);
        }
        assert_eq!((m.len(), m.heads.len()), (11, 11));
        m.insert(Key::new(7, 7, 7), true);
        assert_eq!(m.heads.len(), 23);
    }

    #[test]
    fn float_threshold_past_2_pow_24_buckets() {
        // 17961079 buckets: its float is 17961080, so 17961080 elements fit before growth
        assert_eq!(resize_threshold(17_961_079), 17_961_080);
        // 1 + 17961080 rounds back to 17961080 in float: not more than the buckets
        assert!(1.0f32 + 17_961_080u64 as f32 <= 17_961_079u64 as f32);
        assert!(1.0f32 + 17_961_082u64 as f32 > 17_961_079u64 as f32);
    }
}
