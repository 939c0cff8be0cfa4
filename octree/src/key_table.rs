//! OctoMap's hashed key containers (`KeySet`, `KeyBoolMap`) with the iteration order they have
//! when OctoMap is built with GCC: [`KeyTable`].
//!
//! Why the order matters: OctoMap's occupancy gives the same tree in any update order, but two
//! things depend on it. A `ColorOcTree`'s colours: an eager update can prune a node (its colour
//! becomes the children's average) that a later update of the same scan expands again, while
//! another order never prunes it; so octomap_server's colours need its `KeySet` order. And
//! dynamicEDT3D's `update`, which takes the changed voxels (`KeyBoolMap`) in their order: where
//! two obstacles are equally near a voxel, the one it reports is the one whose wave got there
//! first.
//!
//! # The model
//!
//! Under GCC, OctoMap's `OcTreeKey.h` picks `std::tr1::unordered_set<OcTreeKey,
//! OcTreeKey::KeyHash>` and `std::tr1::unordered_map<OcTreeKey, bool, OcTreeKey::KeyHash>`
//! (not the `std::` ones), libstdc++'s TR1 hash table (`tr1/hashtable.h`,
//! `tr1/hashtable_policy.h`; header-only, unchanged since GCC 4.3; checked against GCC 12 by
//! the reference program). What decides its order:
//!
//! - Each bucket is its own singly linked chain; iteration walks buckets 0, 1, 2, ... and each
//!   chain from its head. The bucket of a key is `KeyHash(key) % bucket_count` with OctoMap's
//!   `KeyHash = k0 + 1447·k1 + 345637·k2` in 64-bit `size_t` arithmetic.
//! - A new key goes to the head of its bucket's chain; inserting a key already present changes
//!   nothing (not its value either). Erasing unlinks it; the others keep their places.
//! - A fresh table has `_M_next_bkt(10)` = 11 buckets. Before an insertion of `n` keys that
//!   takes the count past `_M_next_resize` (the bucket count, maximum load factor 1),
//!   `_Prime_rehash_policy::_M_need_rehash` asks for `max(count + n, 2 · buckets)` buckets,
//!   rounded up to libstdc++'s prime list ([`PRIMES`]), computed in `float` as the header does
//!   (which matters only beyond 2^24 buckets). A rehash takes bucket 0's chain from its head,
//!   then bucket 1's, ... and pushes each element onto the head of its new bucket's chain.
//! - Inserting a range (`insert(first, last)`, how octomap_server adds a ray's keys) first
//!   makes room for the whole range, duplicates included, then inserts key by key.
//! - `clear()` (OctoMap's `resetChangeDetection`) drops the elements but keeps the bucket
//!   count and the growth threshold: the table never shrinks.
//!
//! A table that only grows, such as a scan's `KeySet` of ray voxels (millions of insertions,
//! a few new keys), is cheaper kept as its history and replayed into this model once:
//! [`crate::KeySetLog`].

use crate::free_list::place;
use crate::key::Key;
use crate::key_hasher::KeyHashing;
use std::collections::HashMap;

/// libstdc++'s `std::tr1::__detail::__prime_list` (64-bit), up to 2^32: the bucket counts of
/// the TR1 hash table.
pub const PRIMES: [u64; 256] = [
    2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37, 41, 43, 47, 53, 59, 61, 67, 71, 73, 79, 83, 89, 97,
    103, 109, 113, 127, 137, 139, 149, 157, 167, 179, 193, 199, 211, 227, 241, 257, 277, 293, 313,
    337, 359, 383, 409, 439, 467, 503, 541, 577, 619, 661, 709, 761, 823, 887, 953, 1031, 1109,
    1193, 1289, 1381, 1493, 1613, 1741, 1879, 2029, 2179, 2357, 2549, 2753, 2971, 3209, 3469, 3739,
    4027, 4349, 4703, 5087, 5503, 5953, 6427, 6949, 7517, 8123, 8783, 9497, 10273, 11113, 12011,
    12983, 14033, 15173, 16411, 17749, 19183, 20753, 22447, 24281, 26267, 28411, 30727, 33223,
    35933, 38873, 42043, 45481, 49201, 53201, 57557, 62233, 67307, 72817, 78779, 85229, 92203,
    99733, 107897, 116731, 126271, 136607, 147793, 159871, 172933, 187091, 202409, 218971, 236897,
    256279, 277261, 299951, 324503, 351061, 379787, 410857, 444487, 480881, 520241, 562841, 608903,
    658753, 712697, 771049, 834181, 902483, 976369, 1056323, 1142821, 1236397, 1337629, 1447153,
    1565659, 1693859, 1832561, 1982627, 2144977, 2320627, 2510653, 2716249, 2938679, 3179303,
    3439651, 3721303, 4026031, 4355707, 4712381, 5098259, 5515729, 5967347, 6456007, 6984629,
    7556579, 8175383, 8844859, 9569143, 10352717, 11200489, 12117689, 13109983, 14183539, 15345007,
    16601593, 17961079, 19431899, 21023161, 22744717, 24607243, 26622317, 28802401, 31160981,
    33712729, 36473443, 39460231, 42691603, 46187573, 49969847, 54061849, 58488943, 63278561,
    68460391, 74066549, 80131819, 86693767, 93793069, 101473717, 109783337, 118773397, 128499677,
    139022417, 150406843, 162723577, 176048909, 190465427, 206062531, 222936881, 241193053,
    260944219, 282312799, 305431229, 330442829, 357502601, 386778277, 418451333, 452718089,
    489790921, 529899637, 573292817, 620239453, 671030513, 725980837, 785430967, 849749479,
    919334987, 994618837, 1076067617, 1164186217, 1259520799, 1362662261, 1474249943, 1594975441,
    1725587117, 1866894511, 2019773507, 2185171673, 2364114217, 2557710269, 2767159799, 2993761039,
    3238918481, 3504151727, 3791104843, 4101556399, 4294967291,
];

/// No element (the end of a chain).
const NIL: u32 = u32::MAX;

/// OctoMap's `OcTreeKey::KeyHash`.
#[inline]
fn key_hash(k: Key) -> u64 {
    u64::from(k[0]) + 1447 * u64::from(k[1]) + 345_637 * u64::from(k[2])
}

/// `ceil(p * max_load_factor)` with the factor 1.0f: `p` rounded to `float` first.
fn resize_threshold(p: u64) -> u64 {
    (p as f32).ceil() as u64
}

#[derive(Debug, Clone, Copy)]
struct Entry<V> {
    key: Key,
    value: V,
    next: u32,
}

/// A map from keys to `V` (a set with `V = ()`) that iterates in the order of OctoMap's
/// `KeySet` / `KeyBoolMap` under GCC's libstdc++ (see the module docs).
#[derive(Debug, Clone)]
pub struct KeyTable<V: Copy> {
    /// Elements by slot; freed slots are reused.
    entries: Vec<Entry<V>>,
    free: Vec<u32>,
    /// Slot of each key present.
    slots: HashMap<Key, u32, KeyHashing>,
    /// Head of each bucket's chain (`NIL` when empty); the length is the bucket count.
    heads: Vec<u32>,
    /// When the table grows.
    growth: Growth,
}

/// libstdc++'s `_Prime_rehash_policy` as a `KeySet` uses it: the bucket count, and
/// `_M_next_resize`, the count past which the policy is asked for growth.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Growth {
    buckets: u64,
    next_resize: u64,
}

impl Default for Growth {
    /// A default-constructed container's: `_M_next_bkt(10)` = 11 buckets.
    fn default() -> Self {
        let buckets = next_bucket_count(10);
        Growth {
            buckets,
            next_resize: resize_threshold(buckets),
        }
    }
}

impl Growth {
    /// The buckets in use.
    pub(crate) fn buckets(&self) -> u64 {
        self.buckets
    }

    /// `_M_need_rehash(bucket_count, size, ins)` in its `float` arithmetic, before `ins` more
    /// keys join `n_elt`: the new bucket count (taken as the table's), or `None` (possibly
    /// moving the threshold).
    #[inline]
    pub(crate) fn need_rehash(&mut self, n_elt: u64, ins: u64) -> Option<u64> {
        if n_elt + ins <= self.next_resize {
            return None;
        }
        let n_bkt = self.buckets;
        let min_bkts = ins as f32 + n_elt as f32;
        if min_bkts > n_bkt as f32 {
            let want = min_bkts.max(2.0f32 * n_bkt as f32);
            let n = next_bucket_count(f64::from(want).ceil() as u64);
            self.next_resize = resize_threshold(n);
            self.buckets = n;
            Some(n)
        } else {
            self.next_resize = resize_threshold(n_bkt);
            None
        }
    }
}

impl<V: Copy> Default for KeyTable<V> {
    fn default() -> Self {
        let growth = Growth::default();
        KeyTable {
            entries: Vec::new(),
            free: Vec::new(),
            slots: HashMap::default(),
            heads: vec![NIL; growth.buckets() as usize],
            growth,
        }
    }
}

/// `_Prime_rehash_policy::_M_next_bkt(n)`: the first prime of [`PRIMES`] not below `n` (the
/// last one beyond it).
fn next_bucket_count(n: u64) -> u64 {
    PRIMES[PRIMES[..PRIMES.len() - 1].partition_point(|&p| p < n)]
}

impl<V: Copy> KeyTable<V> {
    /// An empty table, as a default-constructed container (11 buckets).
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of keys.
    pub fn len(&self) -> usize {
        self.slots.len()
    }

    /// Whether there is no key.
    pub fn is_empty(&self) -> bool {
        self.slots.is_empty()
    }

    /// Whether `key` is present.
    pub fn contains(&self, key: &Key) -> bool {
        self.slots.contains_key(key)
    }

    /// The value of `key`, if present.
    pub fn get(&self, key: &Key) -> Option<V> {
        self.slots.get(key).map(|&s| self.entries[s as usize].value)
    }

    /// The buckets in use.
    pub fn bucket_count(&self) -> usize {
        self.heads.len()
    }

    fn bucket(&self, key: Key) -> usize {
        (key_hash(key) % self.heads.len() as u64) as usize
    }

    /// `insert({key, value})`: adds the key at the head of its bucket unless present (a
    /// present key keeps its value and place); `false` when it was present.
    pub fn insert(&mut self, key: Key, value: V) -> bool {
        if self.slots.contains_key(&key) {
            return false;
        }
        if let Some(n) = self.need_rehash(1) {
            self.rehash(n);
        }
        let slot = self.push_head(key, value);
        self.slots.insert(key, slot);
        true
    }

    /// Put `key`, known to be absent, at the head of its bucket's chain; returns its slot.
    /// Neither the growth policy nor the slot map is consulted (the caller's business).
    pub(crate) fn push_head(&mut self, key: Key, value: V) -> u32 {
        let b = self.bucket(key);
        let e = Entry {
            key,
            value,
            next: self.heads[b],
        };
        let slot = place(&mut self.entries, &mut self.free, e);
        self.heads[b] = slot;
        slot
    }

    /// `insert(first, last)`: room for the whole range first (duplicates included), then
    /// key by key.
    pub fn insert_range(&mut self, items: impl ExactSizeIterator<Item = (Key, V)>) {
        if let Some(n) = self.need_rehash(items.len() as u64) {
            self.rehash(n);
        }
        for (k, v) in items {
            self.insert(k, v);
        }
    }

    /// [`Growth::need_rehash`] before `ins` more keys join the table.
    fn need_rehash(&mut self, ins: u64) -> Option<u64> {
        self.growth.need_rehash(self.len() as u64, ins)
    }

    /// `_M_rehash`: bucket by bucket, each chain from its head, every element pushed onto the
    /// head of its new bucket's chain.
    pub(crate) fn rehash(&mut self, buckets: u64) {
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
    pub fn remove(&mut self, key: &Key) {
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
    pub fn clear(&mut self) {
        self.entries.clear();
        self.free.clear();
        self.slots.clear();
        self.heads.fill(NIL);
    }

    /// The keys and values in OctoMap's iteration order.
    pub fn iter(&self) -> impl Iterator<Item = (Key, V)> + '_ {
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
                let new = next_bucket_count(2 * n as u64) as usize;
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
        let mut m = KeyTable::<bool>::default();
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
        let mut m = KeyTable::<bool>::default();
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

    type KeySetOrder = KeyTable<()>;

    fn pairs(s: &KeySetOrder) -> Vec<(u16, u16)> {
        s.iter().map(|(k, ())| (k[0], k[1])).collect()
    }

    /// The orders printed by a C++ program iterating OctoMap's `KeySet` (GCC 12, liboctomap
    /// 1.9.7) after the same insertions: single keys, a range that grows the table before
    /// inserting, a second range with duplicates that grows it again.
    #[test]
    fn order_is_the_keyset_order_of_libstdcxx() {
        let mut s = KeySetOrder::new();
        for h in [1, 12, 2] {
            assert!(s.insert(Key::new(h, 0, 0), ()));
        }
        assert!(!s.insert(Key::new(12, 0, 0), ()));
        assert_eq!(pairs(&s), [(12, 0), (1, 0), (2, 0)]);
        assert_eq!(s.bucket_count(), 11);

        let r: Vec<Key> = (0..30u16).map(|h| Key::new(h * 5 % 31, h % 3, 0)).collect();
        let mut t = KeySetOrder::new();
        t.insert_range(r[..12].iter().map(|&k| (k, ())));
        assert_eq!(t.bucket_count(), 23);
        assert_eq!(
            pairs(&t),
            [
                (0, 0),
                (4, 1),
                (5, 1),
                (9, 2),
                (10, 2),
                (30, 0),
                (14, 0),
                (15, 0),
                (19, 1),
                (20, 1),
                (24, 2),
                (25, 2)
            ]
        );
        t.insert_range(r[5..].iter().map(|&k| (k, ())));
        assert_eq!(t.bucket_count(), 47);
        assert_eq!(t.len(), 30);
        assert_eq!(
            pairs(&t),
            [
                (0, 0),
                (21, 2),
                (22, 2),
                (23, 2),
                (24, 2),
                (25, 2),
                (16, 1),
                (17, 1),
                (18, 1),
                (19, 1),
                (20, 1),
                (11, 0),
                (12, 0),
                (13, 0),
                (14, 0),
                (15, 0),
                (27, 0),
                (28, 0),
                (29, 0),
                (30, 0),
                (6, 2),
                (7, 2),
                (8, 2),
                (9, 2),
                (10, 2),
                (1, 1),
                (2, 1),
                (3, 1),
                (4, 1),
                (5, 1)
            ]
        );
    }
}
