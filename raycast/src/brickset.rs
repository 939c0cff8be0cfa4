//! A set of voxel keys stored as 4x4x4 bricks: one `u64` bit mask per brick, in an
//! open-addressing table keyed by the brick's Morton code.
//!
//! A key's Morton code splits into the brick (`code >> 6`) and the bit inside it
//! (`code & 63`, itself the Morton order of the 64 voxels), so a ray, which walks through
//! neighbouring voxels, mostly sets bits of the brick it touched last. Listing the bricks
//! sorted and then their bits in order yields the keys in Morton order, the tree's own
//! depth-first order, without sorting every key.

use octoquant_octree::Key;

const EMPTY: u64 = u64::MAX;

/// The key set. `clear` keeps the allocation for the next frame.
#[derive(Debug, Clone)]
pub(crate) struct BrickSet {
    bricks: Vec<u64>,
    bits: Vec<u64>,
    len: usize,
    /// Slot of the brick touched last (a cache for ray walks).
    last: usize,
}

impl Default for BrickSet {
    fn default() -> Self {
        BrickSet {
            bricks: vec![EMPTY; 1024],
            bits: vec![0; 1024],
            len: 0,
            last: 0,
        }
    }
}

#[inline(always)]
fn hash(brick: u64, mask: usize) -> usize {
    (brick.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 20) as usize & mask
}

impl BrickSet {
    /// Remove every key, keeping the table's size.
    pub fn clear(&mut self) {
        if self.len > 0 {
            self.bricks.fill(EMPTY);
            self.bits.fill(0);
        }
        self.len = 0;
        self.last = 0;
    }

    /// Add the key with Morton code `code`.
    #[inline(always)]
    pub fn insert(&mut self, code: u64) {
        self.insert_bits(code >> 6, 1u64 << (code & 63));
    }

    /// Add the keys of `bit` (a mask) in brick `brick`.
    #[inline(always)]
    pub fn insert_bits(&mut self, brick: u64, bit: u64) {
        if self.bricks[self.last] == brick {
            self.bits[self.last] |= bit;
            return;
        }
        let mask = self.bricks.len() - 1;
        let mut i = hash(brick, mask);
        loop {
            let b = self.bricks[i];
            if b == brick {
                self.bits[i] |= bit;
                self.last = i;
                return;
            }
            if b == EMPTY {
                self.bricks[i] = brick;
                self.bits[i] = bit;
                self.len += 1;
                self.last = i;
                if self.len * 2 > self.bricks.len() {
                    self.grow();
                }
                return;
            }
            i = (i + 1) & mask;
        }
    }

    /// The bit mask of a brick (0 when absent).
    #[inline]
    pub fn get(&self, brick: u64) -> u64 {
        let mask = self.bricks.len() - 1;
        let mut i = hash(brick, mask);
        loop {
            let b = self.bricks[i];
            if b == brick {
                return self.bits[i];
            }
            if b == EMPTY {
                return 0;
            }
            i = (i + 1) & mask;
        }
    }

    fn grow(&mut self) {
        let n = self.bricks.len() * 2;
        let old_b = std::mem::replace(&mut self.bricks, vec![EMPTY; n]);
        let old_m = std::mem::replace(&mut self.bits, vec![0; n]);
        let mask = self.bricks.len() - 1;
        for (b, m) in old_b.into_iter().zip(old_m) {
            if b != EMPTY {
                let mut i = hash(b, mask);
                while self.bricks[i] != EMPTY {
                    i = (i + 1) & mask;
                }
                self.bricks[i] = b;
                self.bits[i] = m;
            }
        }
        self.last = 0;
    }

    /// Add every key of `other`.
    pub fn union_with(&mut self, other: &BrickSet) {
        for (b, m) in other.bricks.iter().zip(&other.bits) {
            if *b != EMPTY {
                self.insert_bits(*b, *m);
            }
        }
    }

    /// The non-empty bricks as `(brick, bits)`, sorted by brick (that is, in Morton order).
    pub fn sorted(&self, out: &mut Vec<(u64, u64)>) {
        out.clear();
        out.reserve(self.len);
        out.extend(
            self.bricks
                .iter()
                .zip(&self.bits)
                .filter(|(b, _)| **b != EMPTY)
                .map(|(b, m)| (*b, *m)),
        );
        out.sort_unstable_by_key(|e| e.0);
    }
}

/// Append the keys of a brick's set bits, in Morton order.
#[inline]
pub(crate) fn push_brick_keys(brick: u64, mut bits: u64, out: &mut Vec<Key>) {
    while bits != 0 {
        let b = bits.trailing_zeros() as u64;
        bits &= bits - 1;
        out.push(Key::from_morton((brick << 6) | b));
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
            for (b, m) in bricks {
                assert_eq!(set.get(b), m);
                push_brick_keys(b, m, &mut keys);
            }
            let want: Vec<Key> = naive.iter().map(|c| Key::from_morton(*c)).collect();
            assert_eq!(keys, want);
        }
        assert_eq!(set.get(u64::MAX >> 6), 0);
    }
}
