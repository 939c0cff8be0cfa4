//! The small form of a [`super::BrickSet`]: bricks in an open-addressing table keyed by the
//! brick's Morton code, small enough for the second-level cache.
//!
//! Dense depth images hand on millions of bricks of a few thousand distinct ones; here a
//! brick already in the set almost always sits in one of its first two slots, which are looked
//! at without a branch ([`near_slot`]), and its mask is in the same cache line as its code.

use octoquant_octree::Brick;

/// The code of an empty slot (no brick has it: codes have 42 bits).
const EMPTY: u64 = u64::MAX;
/// An empty slot.
const VACANT: Brick = Brick {
    code: EMPTY,
    voxels: 0,
};

/// The most slots the table grows to (1 MiB); past a quarter of them the set is full and
/// moves to pages (see [`super::BrickSet`]).
#[cfg(not(fuzzing))]
pub(super) const MAX_SLOTS: usize = 1 << 16;
/// In the fuzzing build, the table's first size: the fuzz targets' few dozen rays reach the
/// pages.
#[cfg(fuzzing)]
pub(super) const MAX_SLOTS: usize = 1 << 10;

/// The table: at most a quarter full, so that a brick already in it almost always sits in one
/// of its first two slots.
#[derive(Debug, Clone)]
pub(super) struct BrickHash {
    slots: Vec<Brick>,
    len: usize,
    /// Slot of the brick touched last (a cache for ray walks).
    last: usize,
}

impl Default for BrickHash {
    fn default() -> Self {
        BrickHash {
            slots: vec![VACANT; 1024],
            len: 0,
            last: 0,
        }
    }
}

/// The slot of `brick` when it sits in one of its first two slots (`h`, the brick's hash, or
/// the next), found without a branch: which of the two is data, not a guess.
#[inline(always)]
fn near_slot(slots: &[Brick], brick: u64, h: usize) -> Option<usize> {
    let mask = slots.len() - 1;
    let j = (h + (slots[h].code != brick) as usize) & mask;
    (slots[j].code == brick).then_some(j)
}

#[inline(always)]
fn hash(brick: u64, mask: usize) -> usize {
    (brick.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 20) as usize & mask
}

impl BrickHash {
    /// Remove every brick, keeping the table's size.
    pub fn clear(&mut self) {
        if self.len > 0 {
            self.slots.fill(VACANT);
        }
        self.len = 0;
        self.last = 0;
    }

    /// The table holds as many bricks as it may: the next insert may find no room soon.
    #[inline(always)]
    pub fn full(&self) -> bool {
        self.len * 4 > MAX_SLOTS
    }

    /// Add the voxels of `brick`, looking at the brick touched last first.
    #[inline(always)]
    pub fn insert_brick(&mut self, brick: Brick) {
        if self.slots[self.last].code == brick.code {
            self.slots[self.last].voxels |= brick.voxels;
            return;
        }
        self.insert_brick_hashed(brick);
    }

    /// Add the voxels of `brick`. Once [`BrickHash::full`], the table no longer grows: the
    /// caller moves the set to pages before it fills.
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
                if self.len * 4 > self.slots.len() && self.slots.len() < MAX_SLOTS {
                    self.grow();
                }
                return;
            }
            i = (i + 1) & mask;
        }
    }

    /// Add the bricks of codes `bricks` and voxels `bits` until the set is full; how many
    /// were added. Bricks already in the set, found in one of their first two slots, are
    /// added in a tight loop; anything else (a new brick, a longer probe, growth) goes through
    /// [`BrickHash::insert_brick_hashed`] and the loop resumes.
    #[inline]
    pub fn put_until_full(&mut self, bricks: &[u64], bits: &[u64]) -> usize {
        let n = bricks.len().min(bits.len());
        let mut i = 0;
        while i < n && !self.full() {
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
        i
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

    /// The bricks in the table, in no order.
    pub fn bricks(&self) -> impl Iterator<Item = Brick> + '_ {
        self.slots.iter().copied().filter(|b| b.code != EMPTY)
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

    /// Bytes of the table's allocation.
    pub fn heap_bytes(&self) -> usize {
        self.slots.capacity() * std::mem::size_of::<Brick>()
    }

    /// Sort the bricks by code into the front of the table itself and return how many there
    /// are ([`BrickHash::sorted_front`] lists them): no copy of the set is made. The table is
    /// then a sorted list: nothing may be inserted before [`BrickHash::clear`].
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
        octoquant_radix::sort_by_key(front, back, |b| b.code);
        // `len` stays as it was, so that `clear` resets the whole table
        self.last = 0;
        n
    }

    /// The first `n` slots: after [`BrickHash::sort_in_place`] returned `n`, the bricks in
    /// code order.
    pub fn sorted_front(&self, n: usize) -> &[Brick] {
        &self.slots[..n]
    }
}
