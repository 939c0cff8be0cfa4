//! A set of voxel keys stored as 4x4x4 bricks: one `u64` bit mask per brick.
//!
//! A key's Morton code splits into the brick (`code >> 6`) and the bit inside it
//! (`code & 63`, itself the Morton order of the 64 voxels), so a ray, which walks through
//! neighbouring voxels, mostly sets bits of the brick it touched last. Listing the bricks
//! sorted and then their bits in order yields the keys in Morton order, the tree's own
//! depth-first order, without sorting every key.
//!
//! A set starts as a hash table of bricks small enough for the second-level cache
//! ([`hashed`]: depth images, whose frames touch a few thousand bricks millions of times)
//! and moves to pages of 4x4x4 bricks once it holds more than 16 384 bricks ([`paged`]:
//! LiDAR frames, hundreds of thousands of bricks, where a table of bricks costs a cache miss
//! per brick and a sort of all of them). Measured on one thread (history, session 41): pages
//! take two fifths off the casting of norlab's LiDAR frames at 0.1 m, and were a tenth slower
//! than the small table on TUM's depth images. A set that used many pages ([`STAY_PAGED`])
//! starts its next frame in pages: the frames of one sensor are alike, and moving every
//! LiDAR frame's first 16 384 bricks from the table to pages cost 6 % of the casting at
//! 0.2 m (history, session 42).

mod hashed;
mod paged;

use hashed::BrickHash;
use octoquant_octree::{Brick, Key};
use paged::BrickPages;

/// The key set. `clear` keeps the allocations for the next frame.
#[derive(Debug, Clone, Default)]
pub(crate) struct BrickSet {
    /// The bricks while few (empty once `paged`).
    hash: BrickHash,
    /// The bricks once many.
    pages: BrickPages,
    /// Which of the two holds the set.
    paged: bool,
}

/// A set that ends a frame in at least this many pages starts the next one in pages; below
/// it, small again. A frame of that many pages holds at least as many bricks, a quarter of
/// the most the small table holds; a depth image's few thousand bricks stay below it.
#[cfg(not(fuzzing))]
const STAY_PAGED: usize = 4096;
/// In the fuzzing build, few pages: the fuzz targets' second scans start in pages.
#[cfg(fuzzing)]
const STAY_PAGED: usize = 16;

impl BrickSet {
    /// Remove every key, keeping the tables' sizes. The set starts the next frame small,
    /// unless it is in pages and used at least [`STAY_PAGED`] of them.
    pub fn clear(&mut self) {
        self.hash.clear();
        if self.paged {
            self.paged = self.pages.pages_in_use() >= STAY_PAGED;
            self.pages.clear();
        }
    }

    /// Add the key with Morton code `code`.
    #[inline(always)]
    pub fn insert(&mut self, code: u64) {
        self.insert_brick(Brick::of_voxel(code));
    }

    /// Add the voxels of `brick`.
    #[inline(always)]
    pub fn insert_brick(&mut self, brick: Brick) {
        self.add::<true>(brick);
    }

    /// [`BrickSet::insert_brick`] without the check of the brick touched last, for callers
    /// whose bricks rarely repeat one after another.
    #[inline(always)]
    pub fn insert_brick_hashed(&mut self, brick: Brick) {
        self.add::<false>(brick);
    }

    /// Add `brick` to the pages, or to the small hash (looking at the brick touched last
    /// first when `LAST`), moving the set to pages once the hash is full.
    #[inline(always)]
    fn add<const LAST: bool>(&mut self, brick: Brick) {
        if self.paged {
            self.pages.insert_brick(brick);
            return;
        }
        if LAST {
            self.hash.insert_brick(brick);
        } else {
            self.hash.insert_brick_hashed(brick);
        }
        if self.hash.full() {
            self.move_to_pages();
        }
    }

    /// Move the bricks of the full hash table into pages.
    #[cold]
    #[inline(never)]
    fn move_to_pages(&mut self) {
        for b in self.hash.bricks() {
            self.pages.insert_brick(b);
        }
        self.hash.clear();
        self.paged = true;
    }

    /// `true` once the set moved to pages.
    #[cfg(test)]
    fn is_paged(&self) -> bool {
        self.paged
    }

    /// The bit mask of a brick (0 when absent).
    #[cfg(test)]
    pub fn get(&self, brick: u64) -> u64 {
        if self.paged {
            self.pages.get(brick)
        } else {
            self.hash.get(brick)
        }
    }

    /// Bytes of the set's allocations.
    pub fn heap_bytes(&self) -> usize {
        self.hash.heap_bytes() + self.pages.heap_bytes()
    }

    /// Sort the bricks by code and return how many there are ([`BrickSet::sorted_front`]
    /// lists them). The set is then a sorted list, not a hash table: nothing may be inserted
    /// or looked up before [`BrickSet::clear`], which empties it.
    pub fn sort_in_place(&mut self) -> usize {
        if self.paged {
            self.pages.sort_in_place()
        } else {
            self.hash.sort_in_place()
        }
    }

    /// Replace `out` with the bricks in code order ([`BrickSet::sort_in_place`] and a copy of
    /// [`BrickSet::sorted_front`], without the copy for a paged set). Instead of
    /// [`BrickSet::sort_in_place`], not after it; nothing may be inserted or listed again
    /// before [`BrickSet::clear`].
    pub fn sorted_into(&mut self, out: &mut Vec<Brick>) {
        self.sorted_into_kept(out, |_| true);
    }

    /// [`BrickSet::sorted_into`] keeping only the bricks `keep` keeps (it may change them):
    /// the free set, listed with the occupied voxels taken out ([`Subtract`]) in the same
    /// pass.
    pub fn sorted_into_kept(
        &mut self,
        out: &mut Vec<Brick>,
        mut keep: impl FnMut(&mut Brick) -> bool,
    ) {
        if self.paged {
            self.pages.list_into_kept(out, keep);
        } else {
            let n = self.hash.sort_in_place();
            out.clear();
            out.extend(
                self.hash
                    .sorted_front(n)
                    .iter()
                    .filter_map(|&(mut b)| keep(&mut b).then_some(b)),
            );
        }
    }

    /// After [`BrickSet::sort_in_place`] returned `n`: the `n` bricks in code order.
    pub fn sorted_front(&self, n: usize) -> &[Brick] {
        if self.paged {
            self.pages.sorted_front(n)
        } else {
            self.hash.sorted_front(n)
        }
    }

    /// The bricks, sorted by code (that is, in Morton order), leaving the set as it is.
    #[cfg(test)]
    pub fn sorted(&self, out: &mut Vec<Brick>) {
        if self.paged {
            self.pages.sorted(out);
        } else {
            out.clear();
            out.extend(self.hash.bricks());
            out.sort_unstable_by_key(|b| b.code);
        }
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

    /// While small, the hash table's tight loop for bricks already in it; once full, the rest
    /// of the batch and every later one go into pages.
    #[inline]
    fn put_all(&mut self, bricks: &[u64], bits: &[u64]) {
        let n = bricks.len().min(bits.len());
        let mut i = 0;
        if !self.paged {
            i = self.hash.put_until_full(&bricks[..n], &bits[..n]);
            if i == n {
                return;
            }
            self.move_to_pages();
        }
        self.pages.put_all(&bricks[i..n], &bits[i..n]);
    }
}

/// Takes the voxels of a sorted brick list out of bricks met in ascending code order, and
/// counts the voxels left: occupied voxels win over free ones in a frame's update, so the
/// free bricks are listed through [`Subtract::keep`] with the occupied bricks as `minus`.
pub(crate) struct Subtract<'a> {
    /// The bricks to take out whose codes are not below the last brick met.
    minus: &'a [Brick],
    /// Voxels in the bricks kept so far.
    pub voxels: usize,
}

impl<'a> Subtract<'a> {
    /// Take out the voxels of `minus`, sorted by code, each brick once.
    pub fn new(minus: &'a [Brick]) -> Self {
        Subtract { minus, voxels: 0 }
    }

    /// Take `minus`'s voxels out of `b` (whose code is not below any met before); whether
    /// any are left.
    #[inline(always)]
    pub fn keep(&mut self, b: &mut Brick) -> bool {
        while let Some((first, rest)) = self.minus.split_first() {
            if first.code >= b.code {
                if first.code == b.code {
                    b.voxels &= !first.voxels;
                }
                break;
            }
            self.minus = rest;
        }
        self.voxels += b.voxels.count_ones() as usize;
        b.voxels != 0
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
        // small, then paged, then in pages from the start after rounds of many pages, and small
        // again after a round of few (clean pages, small table)
        let mut started_paged = Vec::new();
        for (round, count) in [3_000, 20_000, 60_000, 3_000, 3_000]
            .into_iter()
            .enumerate()
        {
            set.clear();
            started_paged.push(set.is_paged());
            naive.clear();
            for _ in 0..count {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                let k = Key::new(
                    32768 + (s % 97) as u16,
                    (s >> 20) as u16 % (50 + round as u16 * 1000),
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
            let distinct: BTreeSet<u64> = naive.iter().map(|c| c >> 6).collect();
            assert_eq!(
                set.is_paged(),
                distinct.len() > hashed::MAX_SLOTS / 4 || started_paged[round],
                "round {round}"
            );
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
            let mut again = Vec::new();
            set.sorted(&mut again);
            assert!(again == copy);
        }
        // rounds 2 and 3 hold 20 000 and 60 000 bricks, each in its own page (random z),
        // round 4 3 000
        assert_eq!(started_paged, [false, false, true, true, false]);
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
        assert!(batched.is_paged(), "the set moved to pages");
    }

    /// Bricks of `n` random voxels in a box `spread` bricks wide on each axis around the
    /// map's centre (a narrow box repeats bricks; a wide one makes more than a small set
    /// holds).
    fn voxels(seed: u64, n: usize, spread: u16) -> Vec<u64> {
        let mut s = seed | 1;
        (0..n)
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                let axis = |v: u64| 32768 - 2 * spread + (v % (4 * u64::from(spread))) as u16;
                Key::new(axis(s), axis(s >> 21), axis(s >> 42)).morton()
            })
            .collect()
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(24))]
        /// The free set listed with the occupied voxels taken out ([`Subtract`], as a frame's
        /// update lists it), from a small set or from pages, and the same subtraction over a
        /// listed vector (the split frames' merged sets): the naive difference of two maps,
        /// in code order, without bricks left empty, and its voxel count.
        #[test]
        fn lists_the_free_bricks_without_the_occupied_voxels(
            seed in proptest::prelude::any::<u64>(),
            free_n in 0usize..60_000,
            occ_n in 0usize..3_000,
            spread in 1u16..400,
        ) {
            let free = voxels(seed, free_n, spread);
            let occ = voxels(seed ^ 0x5555, occ_n, spread);
            let mut naive_free = std::collections::BTreeMap::new();
            for c in &free {
                *naive_free.entry(c >> 6).or_insert(0u64) |= 1 << (c & 63);
            }
            let mut naive_occ = std::collections::BTreeMap::new();
            for c in &occ {
                *naive_occ.entry(c >> 6).or_insert(0u64) |= 1 << (c & 63);
            }
            let want: Vec<Brick> = naive_free
                .iter()
                .map(|(&code, &m)| Brick {
                    code,
                    voxels: m & !naive_occ.get(&code).copied().unwrap_or(0),
                })
                .filter(|b| b.voxels != 0)
                .collect();
            let want_voxels: usize = want.iter().map(|b| b.voxels.count_ones() as usize).sum();
            let occ_bricks: Vec<Brick> = naive_occ
                .iter()
                .map(|(&code, &voxels)| Brick { code, voxels })
                .collect();

            let mut set = BrickSet::default();
            for &c in &free {
                set.insert(c);
            }
            proptest::prop_assert_eq!(set.is_paged(), naive_free.len() > hashed::MAX_SLOTS / 4);
            let mut listed = vec![Brick { code: 7, voxels: 7 }];
            let mut sub = Subtract::new(&occ_bricks);
            set.sorted_into_kept(&mut listed, |b| sub.keep(b));
            proptest::prop_assert!(listed == want);
            proptest::prop_assert_eq!(sub.voxels, want_voxels);

            let mut all: Vec<Brick> = naive_free
                .iter()
                .map(|(&code, &voxels)| Brick { code, voxels })
                .collect();
            let mut sub = Subtract::new(&occ_bricks);
            all.retain_mut(|b| sub.keep(b));
            proptest::prop_assert!(all == want);
            proptest::prop_assert_eq!(sub.voxels, want_voxels);
        }
    }
}
