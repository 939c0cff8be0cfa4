//! OctoMap's `KeySet` with the iteration order it has under GCC's libstdc++, for code that
//! must visit keys exactly as a C++ program walking a `KeySet` does (octomap_server's
//! `insertScan`).
//!
//! Why it matters: OctoMap's occupancy updates give the same tree in any order, but a
//! `ColorOcTree`'s colours do not. An eager update can prune a node (its colour becomes the
//! children's average) that a later update of the same scan expands again (all children take
//! that average), while the other order never prunes it; so to give octomap_server's colours,
//! the updates must come in its order.
//!
//! With GCC (and not libc++), OctoMap's `OcTreeKey.h` makes `KeySet` a
//! `std::tr1::unordered_set<OcTreeKey, OcTreeKey::KeyHash>`, whose order is that of libstdc++'s
//! TR1 hash table (header-only, unchanged for many GCC releases; checked against GCC 12):
//!
//! - the hash is OctoMap's `KeyHash`, `k0 + 1447·k1 + 345637·k2`, and a key's bucket is the
//!   hash modulo the bucket count; each bucket is a singly linked list, a new key goes to its
//!   front, and iteration runs through the buckets in index order;
//! - a new set has `_M_next_bkt(10)` = 11 buckets; before an insertion that would make the
//!   element count exceed the bucket count (load factor 1), the table grows to the first prime
//!   of [`PRIMES`] not below `max(count, 2·buckets)` (in `float`, as the policy computes),
//!   moving every bucket's nodes, front first, to the front of their new buckets;
//! - inserting a range (`insert(first, last)`, how octomap_server adds a ray's keys) first
//!   makes room for the whole range, duplicates included, then inserts key by key.

use octoquant_octree::Key;
use std::collections::HashSet;

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

/// No node.
const NIL: u32 = u32::MAX;

/// OctoMap's `KeyHash`.
fn key_hash(k: &Key) -> u64 {
    u64::from(k[0]) + 1447 * u64::from(k[1]) + 345_637 * u64::from(k[2])
}

/// A set of keys that iterates in the order of OctoMap's `KeySet` under libstdc++ (see the
/// module docs).
#[derive(Debug, Clone)]
pub struct KeySetOrder {
    keys: Vec<Key>,
    next: Vec<u32>,
    /// Per bucket: its first node, or [`NIL`].
    buckets: Vec<u32>,
    /// The element count above which the table grows (`_M_next_resize`).
    next_resize: u64,
    members: HashSet<Key>,
}

impl Default for KeySetOrder {
    fn default() -> Self {
        let mut s = KeySetOrder {
            keys: Vec::new(),
            next: Vec::new(),
            buckets: Vec::new(),
            next_resize: 0,
            members: HashSet::new(),
        };
        let n = s.next_bkt(10);
        s.buckets = vec![NIL; n as usize];
        s
    }
}

impl KeySetOrder {
    /// An empty set, as a default-constructed `KeySet` (11 buckets).
    pub fn new() -> Self {
        Self::default()
    }

    /// Keys held.
    pub fn len(&self) -> usize {
        self.keys.len()
    }

    /// Whether the set is empty.
    pub fn is_empty(&self) -> bool {
        self.keys.is_empty()
    }

    /// Whether `k` is in the set.
    pub fn contains(&self, k: &Key) -> bool {
        self.members.contains(k)
    }

    /// The buckets in use.
    pub fn bucket_count(&self) -> usize {
        self.buckets.len()
    }

    /// `_Prime_rehash_policy::_M_next_bkt`: the first prime not below `n` (the last one of the
    /// table beyond it), and the element count that will trigger the next growth.
    fn next_bkt(&mut self, n: u64) -> u64 {
        let i = PRIMES[..PRIMES.len() - 1].partition_point(|&p| p < n);
        let p = PRIMES[i];
        self.next_resize = f64::from(p as f32).ceil() as u64;
        p
    }

    /// `_Prime_rehash_policy::_M_need_rehash` for `ins` more keys: the new bucket count, if
    /// the table grows.
    fn need_rehash(&mut self, ins: u64) -> Option<u64> {
        let (bkt, elt) = (self.buckets.len() as u64, self.keys.len() as u64);
        if elt + ins <= self.next_resize {
            return None;
        }
        let min_bkts = ins as f32 + elt as f32;
        if min_bkts > bkt as f32 {
            let min_bkts = min_bkts.max(2.0f32 * bkt as f32);
            Some(self.next_bkt(f64::from(min_bkts).ceil() as u64))
        } else {
            self.next_resize = f64::from(bkt as f32).ceil() as u64;
            None
        }
    }

    /// `_M_rehash`: every old bucket in order, its nodes front first, each to the front of its
    /// new bucket.
    fn rehash(&mut self, count: u64) {
        let mut new = vec![NIL; count as usize];
        for b in 0..self.buckets.len() {
            let mut p = self.buckets[b];
            while p != NIL {
                let nxt = self.next[p as usize];
                let i = (key_hash(&self.keys[p as usize]) % count) as usize;
                self.next[p as usize] = new[i];
                new[i] = p;
                p = nxt;
            }
        }
        self.buckets = new;
    }

    /// Insert `k` (`KeySet::insert(key)`); false when it was there.
    pub fn insert(&mut self, k: Key) -> bool {
        if self.members.contains(&k) {
            return false;
        }
        if let Some(n) = self.need_rehash(1) {
            self.rehash(n);
        }
        self.members.insert(k);
        let b = (key_hash(&k) % self.buckets.len() as u64) as usize;
        let n = self.keys.len() as u32;
        self.keys.push(k);
        self.next.push(self.buckets[b]);
        self.buckets[b] = n;
        true
    }

    /// Insert a range of keys (`KeySet::insert(first, last)`): room for all of them first,
    /// then one by one.
    pub fn insert_range(&mut self, keys: &[Key]) {
        if let Some(n) = self.need_rehash(keys.len() as u64) {
            self.rehash(n);
        }
        for &k in keys {
            self.insert(k);
        }
    }

    /// The keys in the set's iteration order.
    pub fn iter(&self) -> impl Iterator<Item = Key> + '_ {
        let mut b = 0usize;
        let mut p = NIL;
        std::iter::from_fn(move || {
            while p == NIL {
                if b >= self.buckets.len() {
                    return None;
                }
                p = self.buckets[b];
                b += 1;
            }
            let k = self.keys[p as usize];
            p = self.next[p as usize];
            Some(k)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pairs(s: &KeySetOrder) -> Vec<(u16, u16)> {
        s.iter().map(|k| (k[0], k[1])).collect()
    }

    /// The orders printed by a C++ program iterating OctoMap's `KeySet` (GCC 12, liboctomap
    /// 1.9.7) after the same insertions: single keys, a range that grows the table before
    /// inserting, a second range with duplicates that grows it again.
    #[test]
    fn order_is_the_keyset_order_of_libstdcxx() {
        let mut s = KeySetOrder::new();
        for h in [1, 12, 2] {
            assert!(s.insert(Key::new(h, 0, 0)));
        }
        assert!(!s.insert(Key::new(12, 0, 0)));
        assert_eq!(pairs(&s), [(12, 0), (1, 0), (2, 0)]);
        assert_eq!(s.bucket_count(), 11);

        let r: Vec<Key> = (0..30u16).map(|h| Key::new(h * 5 % 31, h % 3, 0)).collect();
        let mut t = KeySetOrder::new();
        t.insert_range(&r[..12]);
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
        t.insert_range(&r[5..]);
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
