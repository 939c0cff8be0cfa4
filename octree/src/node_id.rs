//! Names for nodes that survive the tree's restructuring: a node is its depth and its smallest
//! voxel key. The side tables of the tree types that carry more than occupancy per node
//! (`ColorOcTree`'s colours, `OcTreeStamped`'s time stamps) are keyed by it.

use crate::key::{Key, TREE_DEPTH};
use crate::key_hasher::KeyHashing;
use crate::packed_slabs::PackedSlabs;
use crate::slab_index::SlabIndex;
use std::collections::HashMap;

/// The side table's key for a node: its depth and smallest voxel key.
pub(crate) type NodeId = (u8, Key);

/// The id of the node at `depth` containing `key`.
#[inline]
pub(crate) fn node_id(key: Key, depth: u8) -> NodeId {
    (depth, key.min_at_depth(depth))
}

/// The id of child `i` of the node `id`.
#[inline]
pub(crate) fn child_id(id: NodeId, i: usize) -> NodeId {
    let (depth, mut k) = id;
    let half = 1u16 << (15 - depth);
    for a in 0..3 {
        if i >> a & 1 == 1 {
            k.0[a] |= half;
        }
    }
    (depth + 1, k)
}

/// The shallowest depth whose nodes are kept in slabs (12 to 16: nearly all of a tree's nodes).
/// Depths 12 and 13 joined in session 38: a walk refreshes (and stamps) each ancestor it
/// leaves, and hash entries there cost a miss each (`map --stamped` on norlab at 0.1 m about
/// 8 % faster).
const SLAB_MIN_DEPTH: u8 = TREE_DEPTH - 4;
/// The slabbed depths.
const SLABBED: usize = (TREE_DEPTH - SLAB_MIN_DEPTH + 1) as usize;

/// The side tables' map from node ids to payloads, holding no entry for `unset` (white, stamp
/// 0): the payloads of the nodes at depths 12 to 16, most of the entries, in slabs of a 4x4x4
/// block of same-depth nodes each (found through a [`SlabIndex`]), the others in a hash map
/// (hashed by [`crate::key_hasher::KeyHasher`]).
///
/// Why slabs: a voxel update reads its seven siblings' payloads (may the eight be collapsed?)
/// and writes its own, and the same one level up; with a hash entry per node each of those was
/// a cache miss of its own (the entries of neighbours land anywhere), with a slab per block
/// they share one or two cache lines (packed: only the entries a block has,
/// [`crate::packed_slabs`]). The misses left per brick (the index, the slab's header, its
/// entries) a batched walk hides by looking its bricks' slabs up ahead
/// ([`NodeMap::look_ahead`]).
#[derive(Debug, Clone)]
pub(crate) struct NodeMap<P> {
    unset: P,
    /// Nodes above depth 12.
    inner: HashMap<NodeId, P, KeyHashing>,
    /// Block code (see [`slab_of`]) to slab index.
    bricks: SlabIndex,
    /// The blocks' payloads, only those set, packed ([`crate::packed_slabs`]).
    slabs: PackedSlabs<P>,
    /// Entries in all.
    len: usize,
    /// The slab looked up last at each slabbed depth (12 to 16), as block code and slab
    /// index ([`NO_SLAB`] for none): a batched walk goes through the tree in Morton order, so
    /// most look-ups repeat the one before at their depth.
    recent: [(u64, u32); SLABBED],
    /// Slabs of depths 15 and 16 looked up ahead of use ([`NodeMap::look_ahead`]),
    /// direct-mapped by block code: `(code, slab)`, [`NO_SLAB_IDX`] when the block had none.
    /// Kept true: a slab made or freed updates its entry.
    hints: [(u64, u32); HINTS],
    /// Block codes (depths 15 and 16) whose index slot is being loaded ([`NodeMap::look_ahead`]'s
    /// first stage), oldest at `staged_at`; [`NO_SLAB`] for none.
    staged: [u64; STAGE],
    /// The oldest entry of `staged`.
    staged_at: usize,
    /// The last depth-15 block code staged.
    staged_15: u64,
    /// Slabs whose header is being loaded (the look-ahead's second stage), oldest at
    /// `loaded_at`: [`LOADED`] stages later their entries are asked for (the third).
    loaded: [u32; LOADED],
    /// The oldest entry of `loaded`.
    loaded_at: usize,
}

/// How many look-aheads pass between loading a slab's header and asking for its entries.
const LOADED: usize = 4;

/// How many look-aheads pass between loading a block's index slot and reading it.
const STAGE: usize = 8;

/// Entries of [`NodeMap::hints`] (a power of two).
const HINTS: usize = 32;
/// A hint's slab index for a block known to have no slab.
const NO_SLAB_IDX: u32 = u32::MAX;

/// The hint entry of block `code`.
#[inline(always)]
fn hint_of(code: u64) -> usize {
    (code ^ (code >> 14) ^ (code >> 28)) as usize & (HINTS - 1)
}

/// A block code no slab has (codes have 45 bits).
const NO_SLAB: u64 = u64::MAX;

/// The code of the slab of node `id` (depth 12 to 16) and its place there: the node's
/// coordinates at its depth (`key >> (16 - depth)`) without their two low bits, packed with the
/// depth, and those low bits interleaved (x, y, z, then the second bits), so that the eight
/// children of a node, `child_id`'s order, fill one group of eight slots
/// ([`crate::packed_slabs`]).
#[inline]
fn slab_of(id: NodeId) -> (u64, usize) {
    let (depth, k) = id;
    let up = TREE_DEPTH - depth;
    let c = k.0.map(|v| v >> up);
    let code = u64::from(c[0] >> 2)
        | u64::from(c[1] >> 2) << 14
        | u64::from(c[2] >> 2) << 28
        | u64::from(up) << 42;
    let bit = |a: usize, b: u32| usize::from(c[a] >> b & 1);
    let slot = bit(0, 0)
        | bit(1, 0) << 1
        | bit(2, 0) << 2
        | bit(0, 1) << 3
        | bit(1, 1) << 4
        | bit(2, 1) << 5;
    (code, slot)
}

impl<P: Copy + PartialEq> NodeMap<P> {
    /// An empty map whose absent entries read as `unset`.
    pub(crate) fn new(unset: P) -> Self {
        NodeMap {
            unset,
            inner: HashMap::default(),
            bricks: SlabIndex::new(),
            slabs: PackedSlabs::new(unset),
            len: 0,
            recent: [(NO_SLAB, 0); SLABBED],
            hints: [(NO_SLAB, 0); HINTS],
            staged: [NO_SLAB; STAGE],
            staged_at: 0,
            staged_15: NO_SLAB,
            loaded: [NO_SLAB_IDX; LOADED],
            loaded_at: 0,
        }
    }

    /// Entries held.
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// Whether no entry is held.
    pub(crate) fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Check the map's bookkeeping, returning a description of the first violation: every
    /// slab of the index passes [`PackedSlabs::check`] and holds an entry, no two blocks share
    /// a slab, and the entry count is the hash map's plus the slabs'.
    pub(crate) fn check(&self) -> Result<(), String> {
        let mut total = self.inner.len();
        let mut seen = std::collections::HashSet::new();
        for (code, s) in self.bricks.iter() {
            let n = self.slabs.check(s)?;
            if n == 0 {
                return Err(format!("block {code:#x}: its slab {s} holds no entry"));
            }
            if !seen.insert(s) {
                return Err(format!("block {code:#x}: slab {s} is another block's too"));
            }
            total += n;
        }
        if total != self.len {
            return Err(format!("{total} entries held, {} counted", self.len));
        }
        Ok(())
    }

    /// Bytes held: the hash map of the shallow nodes' entries (its slots and control bytes),
    /// the slab index and the packed slabs.
    pub(crate) fn heap_bytes(&self) -> usize {
        self.inner.capacity() * (std::mem::size_of::<(NodeId, P)>() + 1)
            + self.bricks.heap_bytes()
            + self.slabs.heap_bytes()
    }

    /// No entries.
    pub(crate) fn clear(&mut self) {
        self.inner.clear();
        self.bricks.clear();
        self.slabs.clear();
        self.len = 0;
        self.recent = [(NO_SLAB, 0); SLABBED];
        self.hints = [(NO_SLAB, 0); HINTS];
        self.staged = [NO_SLAB; STAGE];
        self.staged_15 = NO_SLAB;
        self.loaded = [NO_SLAB_IDX; LOADED];
    }

    /// Prepare, ahead of their use, the slabs of the voxels and depth-15 nodes around `key`:
    /// a batched walk calls this for each brick some bricks before it reaches it, in order,
    /// so that the cache misses of the slabs' look-ups overlap the walk instead of stalling
    /// it. In three stages: now the index slot of each block is asked for; about [`STAGE`]
    /// blocks later it is read (a hint for [`NodeMap::find_slab`]) and the slab's header is
    /// asked for; [`LOADED`] blocks later still, the header is read and the slab's entries
    /// are asked for. A depth-15 block serves eight bricks in a row, so it is staged once.
    #[inline]
    pub(crate) fn look_ahead(&mut self, key: Key) {
        let (code16, _) = slab_of(node_id(key, TREE_DEPTH));
        let (code15, _) = slab_of(node_id(key, TREE_DEPTH - 1));
        if self.staged_15 != code15 {
            self.staged_15 = code15;
            self.stage(code15);
        }
        self.stage(code16);
    }

    /// [`NodeMap::look_ahead`]'s stages for one block code.
    #[inline(always)]
    fn stage(&mut self, code: u64) {
        self.bricks.prefetch(code);
        let older = std::mem::replace(&mut self.staged[self.staged_at], code);
        self.staged_at = (self.staged_at + 1) % STAGE;
        if older == NO_SLAB {
            return;
        }
        let s = self.bricks.get(older).unwrap_or(NO_SLAB_IDX);
        self.hints[hint_of(older)] = (older, s);
        self.slabs.prefetch_slab(s);
        let loaded = std::mem::replace(&mut self.loaded[self.loaded_at], s);
        self.loaded_at = (self.loaded_at + 1) % LOADED;
        self.slabs.prefetch_entries(loaded);
    }

    /// The slab of block `code` at depth `depth` (12 to 16), if it has one; remembered for
    /// the next look-up.
    #[inline]
    fn find_slab(&mut self, code: u64, depth: u8) -> Option<u32> {
        let r = &mut self.recent[usize::from(depth - SLAB_MIN_DEPTH)];
        if r.0 == code {
            return Some(r.1);
        }
        let h = self.hints[hint_of(code)];
        let s = if h.0 == code {
            Some(h.1).filter(|&s| s != NO_SLAB_IDX)?
        } else {
            self.bricks.get(code)?
        };
        *r = (code, s);
        Some(s)
    }

    /// [`NodeMap::find_slab`] without remembering (for readers).
    #[inline]
    fn peek_slab(&self, code: u64, depth: u8) -> Option<u32> {
        let r = self.recent[usize::from(depth - SLAB_MIN_DEPTH)];
        if r.0 == code {
            return Some(r.1);
        }
        self.bricks.get(code)
    }

    /// The slab of block `code` at depth `depth`, made (with room for `first` entries) when it
    /// has none.
    #[inline]
    fn slab_for(&mut self, code: u64, depth: u8, first: usize) -> u32 {
        if let Some(s) = self.find_slab(code, depth) {
            return s;
        }
        let s = self.slabs.make(first);
        self.bricks.insert(code, s);
        self.recent[usize::from(depth - SLAB_MIN_DEPTH)] = (code, s);
        self.correct_hint(code, s);
        s
    }

    /// Block `code` now has slab `s` ([`NO_SLAB_IDX`]: none): a hint held for it says so.
    #[inline]
    fn correct_hint(&mut self, code: u64, s: u32) {
        let h = &mut self.hints[hint_of(code)];
        if h.0 == code {
            h.1 = s;
        }
    }

    /// Slab `s` of block `code` lost an entry: freed when it was the last.
    #[inline]
    fn release_if_empty(&mut self, code: u64, s: u32) {
        if self.slabs.count(s) == 0 {
            self.bricks.remove(code);
            self.slabs.release(s);
            for r in &mut self.recent {
                if r.0 == code {
                    *r = (NO_SLAB, 0);
                }
            }
            self.correct_hint(code, NO_SLAB_IDX);
        }
    }

    /// The payloads of the eight children of `id` (child `i` as [`child_id`]): one slab
    /// look-up for children at depths 12 to 16.
    #[inline]
    pub(crate) fn children(&self, id: NodeId) -> [P; 8] {
        let first = child_id(id, 0);
        if first.0 < SLAB_MIN_DEPTH {
            return std::array::from_fn(|i| self.get(child_id(id, i)));
        }
        let (code, slot) = slab_of(first);
        match self.peek_slab(code, first.0) {
            Some(s) => self.slabs.group(s, slot >> 3),
            None => [self.unset; 8],
        }
    }

    /// Give the eight children of `id` the payload `p`, which is set (`copyData` on an
    /// expansion).
    #[inline]
    pub(crate) fn set_children(&mut self, id: NodeId, p: P) {
        debug_assert!(p != self.unset);
        self.set_children_where(id, 0xff, p);
    }

    /// Give the children of `id` selected by `which` (bit `i`: child `i`, as [`child_id`])
    /// the payload `p` (`unset` removes their entries, as [`NodeMap::insert`]): one slab
    /// look-up for children at depths 12 to 16 when `p` is set.
    #[inline]
    pub(crate) fn set_children_where(&mut self, id: NodeId, which: u8, p: P) {
        let first = child_id(id, 0);
        if which == 0 {
            // nothing to set (and no slab to make)
            return;
        }
        if first.0 < SLAB_MIN_DEPTH || p == self.unset {
            for i in (0..8).filter(|i| which >> i & 1 == 1) {
                self.insert(child_id(id, i), p);
            }
            return;
        }
        let (code, slot) = slab_of(first);
        let s = self.slab_for(code, first.0, which.count_ones() as usize);
        self.len += self.slabs.set(s, slot >> 3, which, p);
    }

    /// Remove the entries of the eight children of `id`, returning their payloads.
    #[inline]
    pub(crate) fn remove_children(&mut self, id: NodeId) -> [P; 8] {
        let first = child_id(id, 0);
        if first.0 < SLAB_MIN_DEPTH {
            return std::array::from_fn(|i| self.remove(child_id(id, i)).unwrap_or(self.unset));
        }
        let (code, slot) = slab_of(first);
        let Some(s) = self.find_slab(code, first.0) else {
            return [self.unset; 8];
        };
        let out = self.slabs.group(s, slot >> 3);
        self.len -= self.slabs.remove(s, slot >> 3, 0xff);
        self.release_if_empty(code, s);
        out
    }

    /// The payload of `id`, `unset` when it has none.
    #[inline]
    pub(crate) fn get(&self, id: NodeId) -> P {
        if id.0 < SLAB_MIN_DEPTH {
            return self.inner.get(&id).copied().unwrap_or(self.unset);
        }
        let (code, slot) = slab_of(id);
        match self.peek_slab(code, id.0) {
            Some(s) => self.slabs.get(s, slot),
            None => self.unset,
        }
    }

    /// Give `id` the payload `p` (`unset` removes its entry).
    #[inline]
    pub(crate) fn insert(&mut self, id: NodeId, p: P) {
        if p == self.unset {
            self.remove(id);
            return;
        }
        if id.0 < SLAB_MIN_DEPTH {
            if self.inner.insert(id, p).is_none() {
                self.len += 1;
            }
            return;
        }
        let (code, slot) = slab_of(id);
        let s = self.slab_for(code, id.0, 1);
        self.len += self.slabs.set(s, slot >> 3, 1 << (slot & 7), p);
    }

    /// Remove the entry of `id`, returning its payload (`None`: it had none).
    #[inline]
    pub(crate) fn remove(&mut self, id: NodeId) -> Option<P> {
        if id.0 < SLAB_MIN_DEPTH {
            let p = self.inner.remove(&id);
            self.len -= usize::from(p.is_some());
            return p;
        }
        let (code, slot) = slab_of(id);
        let s = self.find_slab(code, id.0)?;
        let p = self.slabs.get(s, slot);
        if p == self.unset {
            return None;
        }
        self.len -= self.slabs.remove(s, slot >> 3, 1 << (slot & 7));
        self.release_if_empty(code, s);
        Some(p)
    }

    /// The ids with an entry, in no particular order.
    #[cfg(test)]
    pub(crate) fn ids(&self) -> impl Iterator<Item = NodeId> + '_ {
        let slabbed = self.bricks.iter().flat_map(move |(code, s)| {
            let up = (code >> 42) as u8;
            let lo = |shift: u32| ((code >> shift) as u16 & 0x3fff) << 2;
            let base = [lo(0), lo(14), lo(28)];
            self.slabs.entries(s).map(move |(i, _)| {
                // slot bits: x, y, z low bits, then x, y, z second bits
                let c: [usize; 3] = std::array::from_fn(|a| (i >> a & 1) | (i >> (a + 3) & 1) << 1);
                let k = Key(std::array::from_fn(|a| (base[a] | c[a] as u16) << up));
                (TREE_DEPTH - up, k)
            })
        });
        self.inner.keys().copied().chain(slabbed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::collections::HashMap;

    proptest! {
        /// The map holds what a plain hash map of the set entries holds (setting the unset
        /// payload removes), through slabs emptied and reused, with look-aheads (whose hints
        /// must stay true as slabs come and go) between any two operations.
        #[test]
        fn holds_what_a_hash_map_holds(
            ops in prop::collection::vec(
                (0u8..9, 9u8..=16, 0u16..24, 0u16..24, 0u16..8, 0u32..4),
                0..300,
            )
        ) {
            let mut m = NodeMap::new(0u32);
            let mut naive: HashMap<NodeId, u32> = HashMap::new();
            for (op, depth, x, y, z, p) in ops {
                let id = node_id(Key::new(32760 + x, 32760 + y, 32760 + z), depth);
                // the eight children, named as `child_id`'s definition: bit a of i adds half
                // the node's side on axis a
                let kids: Vec<NodeId> = (0..8)
                    .map(|i| {
                        let half = 1u16 << (15 - id.0.min(15));
                        let k = Key(std::array::from_fn(|a| id.1[a] + ((i >> a) & 1) * half));
                        (id.0 + 1, k)
                    })
                    .collect();
                match op {
                    0 | 1 => {
                        m.insert(id, p);
                        if p == 0 {
                            naive.remove(&id);
                        } else {
                            naive.insert(id, p);
                        }
                    }
                    2 => prop_assert_eq!(m.remove(id), naive.remove(&id)),
                    6 | 7 => {
                        // enough times that the block's hint is read in (its second stage)
                        for _ in 0..=STAGE {
                            m.look_ahead(id.1);
                        }
                    }
                    _ if depth == 16 => {}
                    3 => {
                        let want: Vec<u32> =
                            kids.iter().map(|k| naive.get(k).copied().unwrap_or(0)).collect();
                        prop_assert_eq!(m.children(id).to_vec(), want);
                    }
                    4 => {
                        let p = p + 1;
                        m.set_children(id, p);
                        for &k in &kids {
                            naive.insert(k, p);
                        }
                    }
                    8 => {
                        // some children, chosen by the coordinates; `p` may be the unset
                        // payload (a stamp of time 0), which removes
                        let which = (x * 37 + y * 11 + z) as u8;
                        m.set_children_where(id, which, p);
                        for (i, &k) in kids.iter().enumerate() {
                            if which >> i & 1 == 1 {
                                if p == 0 {
                                    naive.remove(&k);
                                } else {
                                    naive.insert(k, p);
                                }
                            }
                        }
                    }
                    _ => {
                        let want: Vec<u32> =
                            kids.iter().map(|k| naive.remove(k).unwrap_or(0)).collect();
                        prop_assert_eq!(m.remove_children(id).to_vec(), want);
                    }
                }
                for k in &kids {
                    if k.0 <= 16 {
                        prop_assert_eq!(m.get(*k), naive.get(k).copied().unwrap_or(0));
                    }
                }
                prop_assert_eq!(m.get(id), naive.get(&id).copied().unwrap_or(0));
                prop_assert_eq!(m.len(), naive.len());
            }
            let mut ids: Vec<NodeId> = m.ids().collect();
            let mut want: Vec<NodeId> = naive.keys().copied().collect();
            ids.sort();
            want.sort();
            prop_assert_eq!(ids, want);
            prop_assert_eq!(m.slabs.live(), m.bricks.len());
            prop_assert_eq!(m.check(), Ok(()));
            // no slab is kept without entries
            for (_, s) in m.bricks.iter() {
                prop_assert!(m.slabs.count(s) > 0);
            }
        }
    }
}
