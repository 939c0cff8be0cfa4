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
//! TR1 hash table, modelled by [`octoquant_octree::KeyTable`] (its docs give the rules; the
//! same model gives OctoMap's changed-keys order for the distance maps).

use octoquant_octree::{Key, KeyTable};

/// A set of keys that iterates in the order of OctoMap's `KeySet` under libstdc++.
#[derive(Debug, Clone, Default)]
pub struct KeySetOrder(KeyTable<()>);

impl KeySetOrder {
    /// An empty set, as a default-constructed `KeySet` (11 buckets).
    pub fn new() -> Self {
        Self::default()
    }

    /// Keys held.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// Whether the set is empty.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// Whether `k` is in the set.
    pub fn contains(&self, k: &Key) -> bool {
        self.0.contains(k)
    }

    /// The buckets in use.
    pub fn bucket_count(&self) -> usize {
        self.0.bucket_count()
    }

    /// Insert `k` (`KeySet::insert(key)`); false when it was there.
    pub fn insert(&mut self, k: Key) -> bool {
        self.0.insert(k, ())
    }

    /// Insert a range of keys (`KeySet::insert(first, last)`): room for all of them first,
    /// then one by one.
    pub fn insert_range(&mut self, keys: &[Key]) {
        self.0.insert_range(keys.iter().map(|&k| (k, ())));
    }

    /// The keys in the set's iteration order.
    pub fn iter(&self) -> impl Iterator<Item = Key> + '_ {
        self.0.iter().map(|(k, ())| k)
    }
}
