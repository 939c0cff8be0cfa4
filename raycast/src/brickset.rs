//! A set of voxel keys stored as 4x4x4 bricks: one `u64` bit mask per brick, in an
//! open-addressing table keyed by the brick's Morton code.
//!
//! A key's Morton code splits into the brick (`code >> 6`) and the bit inside it
//! (`code & 63`, itself the Morton order of the 64 voxels), so a ray, which walks through
//! neighbouring voxels, mostly sets bits of the brick it touched last. Listing the bricks
//! sorted and then their bits in order yields the keys in Morton order, the tree's own
//! depth-first order, without sorting every key.

use octoquant_octree::{Brick, Key};

/// The code of an empty slot (no brick has it: codes have 42 bits).
const EMPTY: u64 = u64::MAX;
/// An empty slot.
const VACANT: Brick = Brick {
    code: EMPTY,
    voxels: 0,
};

/// The key set. `clear` keeps the allocation for the next frame.
///
/// Each slot holds a [`Brick`] (code and voxels side by side), so a probe touches one cache
/// line. A small
/// table is kept at most a quarter full (see [`fill_limit`]), so that a brick already in it
/// almost always sits in one of its first two slots, which are looked at without a branch
/// ([`near_slot`]): on dense depth images the lookups repeat the same few thousand bricks
/// millions of times, and a mispredicted probe loop cost more there than the larger table.
#[derive(Debug, Clone)]
pub(crate) struct BrickSet {
    slots: Vec<Brick>,
    len: usize,
    /// Slot of the brick touched last (a cache for ray walks).
    last: usize,
}

impl Default for BrickSet {
    fn default() -> Self {
        BrickSet {
            slots: vec![VACANT; 1024],
            len: 0,
            last: 0,
        }
    }
}

/// The inverse of the largest share of a table of `slots` that may be filled before it
/// grows: a quarter while the table fits in L2 (the dense depth images, whose lookups repeat
/// the same bricks), half beyond (LiDAR frames, where a sparser table costs more in cache
/// misses than it saves in probes).
#[inline(always)]
fn fill_limit(slots: usize) -> usize {
    if slots < SPARSE_UP_TO {
        4
    } else {
        2
    }
}

/// Tables with fewer slots than this (1 MiB) are kept at most a quarter full.
const SPARSE_UP_TO: usize = 1 << 16;

/// How many bricks ahead of its insert a brick's home slot is prefetched in a large table:
/// enough for the miss to be served meanwhile (8: no gain, 32: best, 64: a little less on
/// norlab at 0.2 m).
const PREFETCH_AHEAD: usize = 32;

/// The slot of `brick` when it sits in one of its first two slots (`h`, the brick's hash, or
/// the next), found without a branch: which of the two is data, not a guess.
#[inline(always)]
fn near_slot(slots: &[Brick], brick: u64, h: usize) -> Option<usize> {
    let mask = slots.len() - 1;
    let j = (h + (slots[h].code != brick) as usize) & mask;
    (slots[j].code == brick).then_some(j)
}

/// Ask for the cache line of `slot` ahead of its use.
#[inline(always)]
fn prefetch(slot: &Brick) {
    #[cfg(target_arch = "x86_64")]
    safe_arch::prefetch_t0(slot);
    #[cfg(not(target_arch = "x86_64"))]
    let _ = slot;
}

#[inline(always)]
fn hash(brick: u64, mask: usize) -> usize {
    (brick.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 20) as usize & mask
}

impl BrickSet {
    /// Remove every key, keeping the table's size.
    pub fn clear(&mut self) {
        if self.len > 0 {
            self.slots.fill(VACANT);
        }
        self.len = 0;
        self.last = 0;
    }

    /// Add the key with Morton code `code`.
    #[inline(always)]
    pub fn insert(&mut self, code: u64) {
        self.insert_brick(Brick::of_voxel(code));
    }

    /// Add the voxels of `brick`.
    #[inline(always)]
    pub fn insert_brick(&mut self, brick: Brick) {
        if self.slots[self.last].code == brick.code {
            self.slots[self.last].voxels |= brick.voxels;
            return;
        }
        self.insert_brick_hashed(brick);
    }

    /// [`BrickSet::insert_brick`] without the check of the brick touched last, for callers
    /// whose bricks rarely repeat one after another.
    #[inline(always)]
    pub fn insert_brick_hashed(&mut self, brick: Brick) {
        let mask = self.slots.len() - 1;
        let mut i = hash(brick.code, mask);
        if let Some(j) = near_slot(&self.slots, brick.code, i) {
            self.slots[j].voxels |= brick.voxels;
            self.last = j;
            return;
        }
        loop {
            let slot = &mut self.slots[i];
            if slot.code == brick.code {
                slot.voxels |= brick.voxels;
                self.last = i;
                return;
            }
            if slot.code == EMPTY {
                *slot = brick;
                self.len += 1;
                self.last = i;
                if self.len * fill_limit(self.slots.len()) > self.slots.len() {
                    self.grow();
                }
                return;
            }
            i = (i + 1) & mask;
        }
    }

    /// The bit mask of a brick (0 when absent).
    #[cfg(test)]
    pub fn get(&self, brick: u64) -> u64 {
        let mask = self.slots.len() - 1;
        let mut i = hash(brick, mask);
        loop {
            let Brick { code, voxels } = self.slots[i];
            if code == brick {
                return voxels;
            }
            if code == EMPTY {
                return 0;
            }
            i = (i + 1) & mask;
        }
    }

    fn grow(&mut self) {
        let n = self.slots.len() * 2;
        let old = std::mem::replace(&mut self.slots, vec![VACANT; n]);
        let mask = n - 1;
        for b in old {
            if b.code != EMPTY {
                let mut i = hash(b.code, mask);
                while self.slots[i].code != EMPTY {
                    i = (i + 1) & mask;
                }
                self.slots[i] = b;
            }
        }
        self.last = 0;
    }

    /// Bytes of the table's allocation.
    pub fn heap_bytes(&self) -> usize {
        self.slots.capacity() * std::mem::size_of::<Brick>()
    }

    /// Sort the non-empty bricks by code into the front of the table itself and return how
    /// many there are ([`BrickSet::sorted_front`] lists them): no copy of the set
    /// is made. The set is then a sorted list, not a hash table: nothing may be
    /// inserted or looked up before [`BrickSet::clear`], which empties the whole table.
    pub fn sort_in_place(&mut self) -> usize {
        let mut n = 0;
        for i in 0..self.slots.len() {
            let b = self.slots[i];
            if b.code != EMPTY {
                self.slots[i] = VACANT;
                self.slots[n] = b;
                n += 1;
            }
        }
        // the table is at most half full, so its back half is free for the sort's passes
        let (front, back) = self.slots.split_at_mut(n);
        crate::brick_sort::sort_by_code(front, back);
        // `len` stays as it was, so that `clear` resets the whole table
        self.last = 0;
        n
    }

    /// The first `n` slots: after [`BrickSet::sort_in_place`] returned `n`, the bricks in code
    /// order.
    pub fn sorted_front(&self, n: usize) -> &[Brick] {
        &self.slots[..n]
    }

    /// The non-empty bricks, sorted by code (that is, in Morton order), leaving the set as it
    /// is.
    #[cfg(test)]
    pub fn sorted(&self, out: &mut Vec<Brick>) {
        out.clear();
        out.reserve(self.len);
        out.extend(self.slots.iter().filter(|b| b.code != EMPTY).copied());
        out.sort_unstable_by_key(|b| b.code);
    }
}

/// Where walks hand the bricks they entered: one [`Brick`] at a time, or a batch at once. Any
/// `FnMut(Brick)` is a sink (tests collect into their own sets); the brick set is one with a
/// batch insert that keeps the table's address and size in registers.
pub(crate) trait BrickSink {
    /// Add the voxels of `brick`.
    fn put(&mut self, brick: Brick);

    /// Add the brick of code `bricks[i]` and voxels `bits[i]` for every `i`: the SIMD lanes
    /// collect the bricks they leave as two arrays, one register store each.
    #[inline]
    fn put_all(&mut self, bricks: &[u64], bits: &[u64]) {
        for (&code, &voxels) in bricks.iter().zip(bits) {
            self.put(Brick { code, voxels });
        }
    }
}

impl<F: FnMut(Brick)> BrickSink for F {
    #[inline(always)]
    fn put(&mut self, brick: Brick) {
        self(brick)
    }
}

impl BrickSink for BrickSet {
    #[inline(always)]
    fn put(&mut self, brick: Brick) {
        self.insert_brick_hashed(brick)
    }

    /// In a table beyond the second-level cache (LiDAR frames) each insert would wait for its
    /// cache miss: there the home slot of the brick [`PREFETCH_AHEAD`] places on is asked for
    /// while a brick goes in, so that the misses overlap (about a fifth off the casting time of
    /// norlab at 0.2 m). In a smaller table, bricks already in the set, found in one of their
    /// first two slots, are added in a tight loop; anything else (a new brick, a longer
    /// probe, growth) goes through [`BrickSet::insert_brick_hashed`] and the loop resumes.
    #[inline]
    fn put_all(&mut self, bricks: &[u64], bits: &[u64]) {
        let n = bricks.len().min(bits.len());
        if self.slots.len() >= SPARSE_UP_TO {
            // the home slot of the brick PREFETCH_AHEAD places on is asked for while this
            // one goes in
            for &b in bricks[..n].iter().take(PREFETCH_AHEAD) {
                prefetch(&self.slots[hash(b, self.slots.len() - 1)]);
            }
            for (i, (&code, &voxels)) in bricks[..n].iter().zip(&bits[..n]).enumerate() {
                if let Some(&b) = bricks[..n].get(i + PREFETCH_AHEAD) {
                    prefetch(&self.slots[hash(b, self.slots.len() - 1)]);
                }
                self.insert_brick_hashed(Brick { code, voxels });
            }
            return;
        }
        let mut i = 0;
        while i < n {
            let slots = self.slots.as_mut_slice();
            let mask = slots.len() - 1;
            while let (Some(&b), Some(&m)) = (bricks.get(i), bits.get(i)) {
                let Some(j) = near_slot(slots, b, hash(b, mask)) else {
                    break;
                };
                slots[j].voxels |= m;
                i += 1;
            }
            if let (Some(&code), Some(&voxels)) = (bricks.get(i), bits.get(i)) {
                self.insert_brick_hashed(Brick { code, voxels });
                i += 1;
            }
        }
    }
}

/// Per bit of a brick (its voxels' Morton order), the voxel's offset from the brick's first
/// voxel on each axis.
const BRICK_OFFSET: [[u16; 3]; 64] = {
    let mut t = [[0u16; 3]; 64];
    let mut b = 0;
    while b < 64 {
        let mut a = 0;
        while a < 3 {
            t[b][a] = (((b >> a) & 1) | (((b >> (a + 3)) & 1) << 1)) as u16;
            a += 1;
        }
        b += 1;
    }
    t
};

/// Append the keys of a brick's voxels, in Morton order: the brick's first key decoded once,
/// each voxel's offset inside the brick (0 to 3 per axis) looked up.
#[inline]
pub(crate) fn push_brick_keys(brick: Brick, out: &mut Vec<Key>) {
    let base = Key::from_morton(brick.code << 6);
    let mut bits = brick.voxels;
    out.reserve(bits.count_ones() as usize);
    while bits != 0 {
        let o = BRICK_OFFSET[bits.trailing_zeros() as usize];
        bits &= bits - 1;
        // the brick's first key is a multiple of 4 on every axis, so the offsets add no carry
        out.push(Key::new(base[0] | o[0], base[1] | o[1], base[2] | o[2]));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeSet;

    #[test]
    fn matches_a_btreeset() {
        let mut set = BrickSet::default();
        let mut naive = BTreeSet::new();
        let mut s = 0x1234_5678u64;
        for round in 0..3 {
            set.clear();
            naive.clear();
            for _ in 0..20_000 {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                let k = Key::new(
                    32768 + (s % 97) as u16,
                    (s >> 20) as u16 % (50 + round * 1000),
                    (s >> 40) as u16,
                );
                set.insert(k.morton());
                naive.insert(k.morton());
            }
            let mut bricks = Vec::new();
            set.sorted(&mut bricks);
            let mut keys = Vec::new();
            for b in bricks {
                assert_eq!(set.get(b.code), b.voxels);
                push_brick_keys(b, &mut keys);
            }
            let want: Vec<Key> = naive.iter().map(|c| Key::from_morton(*c)).collect();
            assert_eq!(keys, want);
            // sorted in the table itself: the same bricks; and a cleared set is empty again
            let copy = {
                let mut v = Vec::new();
                set.sorted(&mut v);
                v
            };
            let n = set.sort_in_place();
            assert!(set.sorted_front(n) == &copy[..]);
            set.clear();
            let mut after = Vec::new();
            set.sorted(&mut after);
            assert!(after.is_empty());
            for b in &copy {
                set.insert_brick(*b);
            }
        }
        assert_eq!(set.get(u64::MAX >> 6), 0);
    }

    /// The batch insert gives the set of one insert at a time, through growth (in small
    /// tables and in large ones, where batches prefetch ahead), repeats, and
    /// bricks that collide in their first slots.
    #[test]
    fn batches_match_single_inserts() {
        let mut batched = BrickSet::default();
        let mut single = BrickSet::default();
        let mut naive = std::collections::BTreeMap::new();
        let mut s = 0x9E37_79B9u64;
        for round in 0..60 {
            let n = 1 + (round * 97) % 2000;
            let (mut bricks, mut bits) = (Vec::new(), Vec::new());
            for _ in 0..n {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                // few distinct bricks early (repeats), many later (growth)
                let b = s % (16 + round as u64 * 3000);
                let m = 1u64 << (s >> 58);
                bricks.push(b);
                bits.push(m);
                single.insert_brick_hashed(Brick { code: b, voxels: m });
                *naive.entry(b).or_insert(0u64) |= m;
            }
            batched.put_all(&bricks, &bits);
        }
        let (mut a, mut b) = (Vec::new(), Vec::new());
        batched.sorted(&mut a);
        single.sorted(&mut b);
        assert_eq!(a, b);
        let naive: Vec<Brick> = naive
            .into_iter()
            .map(|(code, voxels)| Brick { code, voxels })
            .collect();
        assert_eq!(a, naive);
        // grown past the size from which batches prefetch ahead
        assert!(batched.slots.len() > SPARSE_UP_TO, "the set grew");
    }
}
