//! The side tables' index from a slab's block code to its slab: an open-addressing hash map
//! whose slot for a code can be prefetched before the look-up.
//!
//! Why not a `HashMap`: a batched walk knows the bricks it will reach next, and with its
//! slabs' look-ups about half of a stamped scan's time was cache misses on the hash table and
//! then on the slab. A look-up started some bricks ahead overlaps the slab's miss with the
//! walk, but a `HashMap` look-up itself (control bytes, then the bucket) still stalled the
//! walk; here a code's first probe slot is known from the code alone, so it can be asked for
//! one stage earlier ([`SlabIndex::prefetch`]).

/// A code no block has (block codes have 45 bits): marks an empty slot.
const EMPTY: u64 = u64::MAX;

/// Block code to slab index; linear probing, at most three quarters full (half full cost
/// 8 % more peak memory on a stamped run and was no faster), deletion by backward shift
/// (no tombstones, so probes stay short however many slabs come and go).
#[derive(Debug, Clone)]
pub(crate) struct SlabIndex {
    /// `(code, slab)`, `code == EMPTY` for a free slot; the length is a power of two (or 0).
    slots: Vec<(u64, u32)>,
    /// Occupied slots.
    len: usize,
}

impl SlabIndex {
    /// An empty index.
    pub(crate) fn new() -> Self {
        SlabIndex {
            slots: Vec::new(),
            len: 0,
        }
    }

    /// Codes held.
    #[cfg(test)]
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// Bytes of the slots.
    pub(crate) fn heap_bytes(&self) -> usize {
        self.slots.capacity() * std::mem::size_of::<(u64, u32)>()
    }

    /// Nothing held (keeps the slots' memory).
    pub(crate) fn clear(&mut self) {
        self.slots.fill((EMPTY, 0));
        self.len = 0;
    }

    /// The first probe slot of `code`: Fibonacci hashing of the code, which spreads
    /// neighbouring blocks (codes differing in low bits of any axis) over the table.
    #[inline(always)]
    fn home(&self, code: u64) -> usize {
        let bits = self.slots.len().trailing_zeros();
        (code.wrapping_mul(0x9e37_79b9_7f4a_7c15) >> (64 - bits)) as usize
    }

    /// Start loading `code`'s first probe slot (a hint; no effect on results).
    #[inline(always)]
    pub(crate) fn prefetch(&self, code: u64) {
        if self.slots.is_empty() {
            return;
        }
        #[cfg(target_arch = "x86_64")]
        safe_arch::prefetch_t0(&self.slots[self.home(code)]);
    }

    /// The slot holding `code` (`Ok`), or the empty slot that ends its probe run (`Err`).
    /// The table must have slots; it always has an empty one (it grows at three quarters).
    #[inline]
    fn probe(&self, code: u64) -> Result<usize, usize> {
        let mask = self.slots.len() - 1;
        let mut i = self.home(code);
        loop {
            match self.slots[i].0 {
                c if c == code => return Ok(i),
                EMPTY => return Err(i),
                _ => i = (i + 1) & mask,
            }
        }
    }

    /// The slab of `code`, if it has one.
    #[inline]
    pub(crate) fn get(&self, code: u64) -> Option<u32> {
        if self.slots.is_empty() {
            return None;
        }
        self.probe(code).ok().map(|i| self.slots[i].1)
    }

    /// Give `code` the slab `slab` (replacing any it had).
    pub(crate) fn insert(&mut self, code: u64, slab: u32) {
        debug_assert_ne!(code, EMPTY);
        if 4 * (self.len + 1) > 3 * self.slots.len() {
            self.grow();
        }
        match self.probe(code) {
            Ok(i) => self.slots[i].1 = slab,
            Err(i) => {
                self.slots[i] = (code, slab);
                self.len += 1;
            }
        }
    }

    /// Remove `code`, returning its slab.
    pub(crate) fn remove(&mut self, code: u64) -> Option<u32> {
        if self.slots.is_empty() {
            return None;
        }
        let i = self.probe(code).ok()?;
        let s = self.slots[i].1;
        self.len -= 1;
        self.close_gap(i);
        Some(s)
    }

    /// Slot `gap` was just vacated: move later entries of its probe run back into it, as long
    /// as that keeps each between its home and where it was (so every entry stays reachable
    /// from its home without crossing an empty slot).
    fn close_gap(&mut self, mut gap: usize) {
        let mask = self.slots.len() - 1;
        let mut j = gap;
        loop {
            j = (j + 1) & mask;
            let (c, _) = self.slots[j];
            if c == EMPTY {
                break;
            }
            // distance from home: the entry may move to `gap` only if `gap` lies on its way
            // from its home to `j`
            let home = self.home(c);
            if (j.wrapping_sub(home) & mask) >= (j.wrapping_sub(gap) & mask) {
                self.slots[gap] = self.slots[j];
                gap = j;
            }
        }
        self.slots[gap] = (EMPTY, 0);
    }

    /// Double the slots (at least 64) and put every entry back.
    fn grow(&mut self) {
        let n = (2 * self.slots.len()).max(64);
        let old = std::mem::replace(&mut self.slots, vec![(EMPTY, 0); n]);
        self.len = 0;
        for (c, s) in old {
            if c != EMPTY {
                self.insert(c, s);
            }
        }
    }

    /// The `(code, slab)` entries, in no particular order.
    pub(crate) fn iter(&self) -> impl Iterator<Item = (u64, u32)> + '_ {
        self.slots.iter().copied().filter(|&(c, _)| c != EMPTY)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::collections::HashMap;

    proptest! {
        /// The index holds what a `HashMap` holds through inserts, replacements and removals
        /// (codes from a small range, so that probe runs collide and wrap, and removals shift
        /// entries back).
        #[test]
        fn holds_what_a_hash_map_holds(
            ops in prop::collection::vec((0u8..3, 0u64..200, 0u32..1000), 0..600)
        ) {
            let mut index = SlabIndex::new();
            let mut naive = HashMap::new();
            for (op, code, slab) in ops {
                // codes spread over 45 bits as block codes are
                let code = code.wrapping_mul(0x1_0000_0001) & ((1 << 45) - 1);
                match op {
                    0 | 1 => {
                        index.insert(code, slab);
                        naive.insert(code, slab);
                    }
                    _ => prop_assert_eq!(index.remove(code), naive.remove(&code)),
                }
                prop_assert_eq!(index.len(), naive.len());
                for (&c, &s) in &naive {
                    prop_assert_eq!(index.get(c), Some(s));
                }
                prop_assert_eq!(index.get(code), naive.get(&code).copied());
            }
            let mut all: Vec<(u64, u32)> = index.iter().collect();
            let mut want: Vec<(u64, u32)> = naive.into_iter().collect();
            all.sort();
            want.sort();
            prop_assert_eq!(all, want);
        }
    }
}
