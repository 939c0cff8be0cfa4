//! The side tables' slabs, packed: each slab (the payloads of a 4x4x4 block of same-depth
//! nodes) keeps only the entries it has, in slot order, in a segment of one shared pool.
//!
//! Why packed: a slab used to hold all 64 payloads whether set or not (260 bytes for time
//! stamps), and on LiDAR maps a block has about fifteen nodes (norlab at 0.1 m: 15.6 M stamps
//! in 1.07 M slabs), so a stamped map's side table took 2.6 times the bytes of the occupancy
//! tree it sits beside. Here a slab is a 64-bit mask of the slots it holds, the place of its
//! segment and, per group of eight slots (a node's children), where the group's entries start
//! in it; an entry is found there plus its rank among its group's bits (a table look-up).
//!
//! Segments come in size classes of 8, 16, 32 and 64 entries; a slab moves to the next class
//! when it fills its segment and back to a smaller one when it drops to a quarter of it, and
//! freed segments of each class are handed out again before the pool grows.
//!
//! What it costs: on norlab at 0.1 m (`map --stamped`, one thread) about 8 % more insertion
//! time than the dense slabs, for a third less peak memory (14 frames: 639 -> 442 MB).

/// Entries per slab (a 4x4x4 block).
const SLAB_SLOTS: usize = 64;

/// Size classes: class `c` holds `8 << c` entries, up to [`SLAB_SLOTS`]. Eight at least: a
/// slab's first entries are often a node's eight children (an expansion), and on norlab at
/// 0.1 m starting slabs at two entries moved each about three times as it grew, which made
/// `map --stamped` a tenth slower for 3 % less memory.
const CLASSES: usize = 4;

/// Entries of a segment of class `class`.
#[inline(always)]
fn capacity(class: usize) -> usize {
    8 << class
}

/// The smallest class holding `n` entries (`n` at most [`SLAB_SLOTS`]).
#[inline(always)]
fn class_for(n: usize) -> usize {
    (n.max(8).next_power_of_two().trailing_zeros() - 3) as usize
}

/// Bits set in each byte value: the library is built for any x86-64, where `count_ones`
/// has no `popcnt` instruction to use and costs a dozen operations.
const POP8: [u8; 256] = {
    let mut t = [0u8; 256];
    let mut i = 0;
    while i < 256 {
        t[i] = (i as u8).count_ones() as u8;
        i += 1;
    }
    t
};

/// Bits of `b` set.
#[inline(always)]
fn pop8(b: u8) -> usize {
    POP8[usize::from(b)] as usize
}

/// One in every byte.
const ONES: u64 = 0x0101_0101_0101_0101;

/// What adds `k` to the bytes of [`Slab::below`] of the groups above group `g`.
#[inline(always)]
fn above_group(g: usize, k: usize) -> u64 {
    if g >= 7 {
        0
    } else {
        (k as u64 * ONES) << (8 * (g + 1))
    }
}

/// One slab: the slots it has entries for and where they are.
#[derive(Debug, Clone, Copy)]
struct Slab {
    /// Bit `i`: slot `i` has an entry.
    mask: u64,
    /// Byte `g`: the entries of the groups below group `g`, where group `g`'s first entry
    /// sits in the segment (kept, so that no access counts bits across the whole mask).
    below: u64,
    /// The segment: its first entry's place in the pool, shifted left by 3, or'd with its
    /// class.
    seg: usize,
}

impl Slab {
    /// The first entry's place in the pool.
    #[inline(always)]
    fn at(self) -> usize {
        self.seg >> 3
    }

    /// The segment's class.
    #[inline(always)]
    fn class(self) -> usize {
        self.seg & 7
    }

    /// The mask of group `g` (slots `8g..8g + 8`).
    #[inline(always)]
    fn group(self, g: usize) -> u8 {
        (self.mask >> (8 * g)) as u8
    }

    /// Where group `g`'s first entry sits in the segment.
    #[inline(always)]
    fn base(self, g: usize) -> usize {
        usize::from((self.below >> (8 * g)) as u8)
    }

    /// Entries held.
    #[inline(always)]
    fn count(self) -> usize {
        self.base(7) + pop8(self.group(7))
    }
}

/// Slabs of payloads `P`, addressed by `u32` ids, their entries packed into one pool. A
/// slab's 64 slots are eight groups of eight (slot `8g + i`: entry `i` of group `g`), the
/// unit the side tables read and write: the eight children of one node.
#[derive(Debug, Clone)]
pub(crate) struct PackedSlabs<P> {
    /// What an absent entry reads as.
    unset: P,
    /// The slabs by id (freed ids included).
    slabs: Vec<Slab>,
    /// Ids no slab uses.
    free_ids: Vec<u32>,
    /// The segments' entries.
    pool: Vec<P>,
    /// Freed segments by class (their places in the pool).
    free_segs: [Vec<usize>; CLASSES],
}

impl<P: Copy + PartialEq> PackedSlabs<P> {
    /// No slabs; absent entries read as `unset`.
    pub(crate) fn new(unset: P) -> Self {
        PackedSlabs {
            unset,
            slabs: Vec::new(),
            free_ids: Vec::new(),
            pool: Vec::new(),
            free_segs: Default::default(),
        }
    }

    /// Remove every slab (keeps the memory).
    pub(crate) fn clear(&mut self) {
        self.slabs.clear();
        self.free_ids.clear();
        self.pool.clear();
        for f in &mut self.free_segs {
            f.clear();
        }
    }

    /// Slab ids handed out and not released.
    #[cfg(test)]
    pub(crate) fn live(&self) -> usize {
        self.slabs.len() - self.free_ids.len()
    }

    /// A segment of class `class`: a freed one, or new at the pool's end.
    #[inline]
    fn alloc_seg(&mut self, class: usize) -> usize {
        match self.free_segs[class].pop() {
            Some(at) => at,
            None => {
                let at = self.pool.len();
                self.pool.resize(at + capacity(class), self.unset);
                at
            }
        }
    }

    /// Move slab `s`'s `n` entries to a segment of class `class`; returns its place.
    #[inline]
    fn move_to(&mut self, s: u32, n: usize, class: usize) -> usize {
        let slab = self.slabs[s as usize];
        let to = self.alloc_seg(class);
        for j in 0..n {
            self.pool[to + j] = self.pool[slab.at() + j];
        }
        self.free_segs[slab.class()].push(slab.at());
        self.slabs[s as usize].seg = to << 3 | class;
        to
    }

    /// A new slab without entries, with room for `first` (at most 64); returns its id.
    #[inline]
    pub(crate) fn make(&mut self, first: usize) -> u32 {
        let class = class_for(first);
        let seg = self.alloc_seg(class) << 3 | class;
        let slab = Slab {
            mask: 0,
            below: 0,
            seg,
        };
        match self.free_ids.pop() {
            Some(s) => {
                self.slabs[s as usize] = slab;
                s
            }
            None => {
                self.slabs.push(slab);
                (self.slabs.len() - 1) as u32
            }
        }
    }

    /// Release slab `s` (it has no entries left): its id and segment are reused.
    #[inline]
    pub(crate) fn release(&mut self, s: u32) {
        let slab = self.slabs[s as usize];
        debug_assert_eq!(slab.mask, 0);
        self.free_segs[slab.class()].push(slab.at());
        self.free_ids.push(s);
    }

    /// Entries slab `s` holds.
    #[inline]
    pub(crate) fn count(&self, s: u32) -> u32 {
        self.slabs[s as usize].count() as u32
    }

    /// The entry of slot `slot` (below [`SLAB_SLOTS`]) of slab `s`, `unset` when absent.
    #[inline]
    pub(crate) fn get(&self, s: u32, slot: usize) -> P {
        debug_assert!(slot < SLAB_SLOTS);
        let slab = self.slabs[s as usize];
        let (g, i) = (slot >> 3, slot & 7);
        let m = slab.group(g);
        if m >> i & 1 == 0 {
            return self.unset;
        }
        self.pool[slab.at() + slab.base(g) + pop8(m & ((1u8 << i) - 1))]
    }

    /// The eight entries of group `g` (below 8) of slab `s`, `unset` where absent.
    #[inline]
    pub(crate) fn group(&self, s: u32, g: usize) -> [P; 8] {
        let slab = self.slabs[s as usize];
        let m = slab.group(g);
        let mut out = [self.unset; 8];
        if m == 0 {
            return out;
        }
        let mut r = slab.at() + slab.base(g);
        for (i, o) in out.iter_mut().enumerate() {
            if m >> i & 1 == 1 {
                *o = self.pool[r];
                r += 1;
            }
        }
        out
    }

    /// Give the entries of group `g` of slab `s` selected by `which` (bit `i`: entry `i`)
    /// the payload `p` (not `unset`); returns how many of them had none.
    #[inline(always)]
    pub(crate) fn set(&mut self, s: u32, g: usize, which: u8, p: P) -> usize {
        debug_assert!(p != self.unset);
        let slab = self.slabs[s as usize];
        let old = slab.group(g);
        if old | which != old {
            return self.add(s, g, which, p);
        }
        // entries all there: written in place
        let (at, base) = (slab.at(), slab.base(g));
        if which == old {
            self.pool[at + base..at + base + pop8(old)].fill(p);
        } else {
            let mut w = which;
            while w != 0 {
                let i = w.trailing_zeros();
                self.pool[at + base + pop8(old & ((1u8 << i) - 1))] = p;
                w &= w - 1;
            }
        }
        0
    }

    /// [`PackedSlabs::set`] where some selected entry is absent: the segment makes room.
    #[inline(never)]
    fn add(&mut self, s: u32, g: usize, which: u8, p: P) -> usize {
        let slab = self.slabs[s as usize];
        let (old, new) = (slab.group(g), slab.group(g) | which);
        let base = slab.base(g);
        let mut at = slab.at();
        let n = slab.count();
        let added = pop8(new) - pop8(old);
        if n + added > capacity(slab.class()) {
            at = self.move_to(s, n, class_for(n + added));
        }
        if added == 1 {
            // one new entry: the entries from its place up move up by one
            let i = (which & !old).trailing_zeros();
            let pos = base + pop8(old & ((1u8 << i) - 1));
            for j in (pos..n).rev() {
                self.pool[at + j + 1] = self.pool[at + j];
            }
            let mut w = which;
            while w != 0 {
                let k = w.trailing_zeros();
                self.pool[at + base + pop8(new & ((1u8 << k) - 1))] = p;
                w &= w - 1;
            }
            let slab = &mut self.slabs[s as usize];
            slab.mask |= u64::from(which) << (8 * g);
            slab.below += above_group(g, 1);
            return 1;
        }
        // the groups above move up; this group's entries are rebuilt from the top down
        let above = base + pop8(old);
        for j in (above..n).rev() {
            self.pool[at + j + added] = self.pool[at + j];
        }
        if old & !which == 0 {
            // every entry of the group is `p`
            self.pool[at + base..at + above + added].fill(p);
        } else {
            let (mut src, mut dst) = (above, above + added);
            for i in (0..8).rev() {
                if new >> i & 1 == 1 {
                    dst -= 1;
                    src -= usize::from(old >> i & 1);
                    self.pool[at + dst] = if which >> i & 1 == 1 {
                        p
                    } else {
                        self.pool[at + src]
                    };
                }
            }
        }
        let slab = &mut self.slabs[s as usize];
        slab.mask |= u64::from(which) << (8 * g);
        slab.below += above_group(g, added);
        added
    }

    /// Remove the entries of group `g` of slab `s` selected by `which`; returns how many it
    /// had. A slab left with a quarter of its segment or less moves to a smaller one (an
    /// emptied one to the smallest, kept until [`PackedSlabs::release`]).
    #[inline]
    pub(crate) fn remove(&mut self, s: u32, g: usize, which: u8) -> usize {
        let slab = self.slabs[s as usize];
        let old = slab.group(g);
        let gone = old & which;
        if gone == 0 {
            return 0;
        }
        let at = slab.at();
        let n = slab.count();
        let base = slab.base(g);
        // this group's remaining entries close up, then the groups above move down
        let mut dst = base;
        for (r, i) in (0..8).filter(|i| old >> i & 1 == 1).enumerate() {
            if gone >> i & 1 == 0 {
                self.pool[at + dst] = self.pool[at + base + r];
                dst += 1;
            }
        }
        for j in base + pop8(old)..n {
            self.pool[at + dst] = self.pool[at + j];
            dst += 1;
        }
        let left = n - pop8(gone);
        let slab = &mut self.slabs[s as usize];
        slab.mask &= !(u64::from(gone) << (8 * g));
        slab.below -= above_group(g, pop8(gone));
        let class = slab.class();
        if class > 0 && 4 * left <= capacity(class) {
            self.move_to(s, left, class_for(2 * left));
        }
        pop8(gone)
    }

    /// Ask for the cache line of slab `s`'s header (a hint; no effect on results; ids of no
    /// slab are ignored).
    #[inline(always)]
    pub(crate) fn prefetch_slab(&self, s: u32) {
        #[cfg(target_arch = "x86_64")]
        if let Some(slab) = self.slabs.get(s as usize) {
            safe_arch::prefetch_t0(slab);
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = s;
    }

    /// Ask for the cache lines of slab `s`'s entries, reading its header (best some time
    /// after [`PackedSlabs::prefetch_slab`]; a hint, no effect on results; ids of no slab are
    /// ignored).
    #[inline(always)]
    pub(crate) fn prefetch_entries(&self, s: u32) {
        #[cfg(target_arch = "x86_64")]
        if let Some(slab) = self.slabs.get(s as usize) {
            let n = slab.count();
            let step = (64 / std::mem::size_of::<P>().max(1)).max(1);
            let mut i = 0;
            while i < n {
                if let Some(e) = self.pool.get(slab.at() + i) {
                    safe_arch::prefetch_t0(e);
                }
                i += step;
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = s;
    }

    /// Check slab `s`'s bookkeeping, returning a description of the first violation: every
    /// group starts after the entries of the groups below it, the entries fit the segment,
    /// and the segment lies in the pool. Returns the slab's entry count.
    pub(crate) fn check(&self, s: u32) -> Result<usize, String> {
        let slab = *self
            .slabs
            .get(s as usize)
            .ok_or_else(|| format!("slab {s} does not exist"))?;
        let mut below = 0;
        for g in 0..8 {
            if slab.base(g) != below {
                return Err(format!(
                    "slab {s}: group {g} starts at {} after {below} entries below it",
                    slab.base(g)
                ));
            }
            below += pop8(slab.group(g));
        }
        if slab.class() >= CLASSES || below > capacity(slab.class()) {
            return Err(format!(
                "slab {s}: {below} entries in a segment of class {}",
                slab.class()
            ));
        }
        if slab.at() + capacity(slab.class()) > self.pool.len() {
            return Err(format!("slab {s}: its segment ends beyond the pool"));
        }
        Ok(below)
    }

    /// Bytes held: slabs, entries (free segments included) and free lists. The slabs and
    /// entries count by length: a large vector's room beyond it is address space never
    /// written (it grows by remapping its pages), not memory in use; the small free lists
    /// count by capacity.
    pub(crate) fn heap_bytes(&self) -> usize {
        self.slabs.len() * std::mem::size_of::<Slab>()
            + self.free_ids.capacity() * 4
            + self.pool.len() * std::mem::size_of::<P>()
            + self
                .free_segs
                .iter()
                .map(|f| f.capacity() * std::mem::size_of::<usize>())
                .sum::<usize>()
    }

    /// The slots of slab `s` with an entry, and their entries, in slot order.
    #[cfg(test)]
    pub(crate) fn entries(&self, s: u32) -> impl Iterator<Item = (usize, P)> + '_ {
        let slab = self.slabs[s as usize];
        (0..SLAB_SLOTS)
            .filter(move |&i| slab.mask >> i & 1 == 1)
            .enumerate()
            .map(move |(r, i)| (i, self.pool[slab.at() + r]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// Slabs hold what plain 64-entry arrays hold, through sets and removals of any
        /// entries of any group (growing and shrinking segments) and slabs released and made
        /// again.
        #[test]
        fn hold_what_arrays_hold(
            ops in prop::collection::vec((0u8..5, 0usize..4, 0usize..8, any::<u8>(), 1u32..5), 0..300)
        ) {
            let mut p = PackedSlabs::new(0u32);
            // per slab id in use: the naive array
            let mut naive: Vec<(u32, [u32; SLAB_SLOTS])> = Vec::new();
            for (op, which_slab, g, which, v) in ops {
                let n = naive.len().max(1);
                match op {
                    0 if naive.len() < 4 => {
                        // made with room for its first group, as the side tables make them
                        let s = p.make(which.count_ones() as usize);
                        let mut a = [0; SLAB_SLOTS];
                        if which != 0 {
                            prop_assert_eq!(p.set(s, g, which, v), which.count_ones() as usize);
                            for (i, e) in a[8 * g..8 * g + 8].iter_mut().enumerate() {
                                if which >> i & 1 == 1 {
                                    *e = v;
                                }
                            }
                        }
                        naive.push((s, a));
                    }
                    0..=2 => {
                        if let Some((s, a)) = naive.get_mut(which_slab % n) {
                            let group = &mut a[8 * g..8 * g + 8];
                            let had = (0..8).filter(|&i| which >> i & 1 == 1 && group[i] != 0).count();
                            prop_assert_eq!(p.set(*s, g, which, v), which.count_ones() as usize - had);
                            for (i, e) in group.iter_mut().enumerate() {
                                if which >> i & 1 == 1 {
                                    *e = v;
                                }
                            }
                        }
                    }
                    3 => {
                        if let Some((s, a)) = naive.get_mut(which_slab % n) {
                            let group = &mut a[8 * g..8 * g + 8];
                            let had = (0..8).filter(|&i| which >> i & 1 == 1 && group[i] != 0).count();
                            prop_assert_eq!(p.remove(*s, g, which), had);
                            for (i, e) in group.iter_mut().enumerate() {
                                if which >> i & 1 == 1 {
                                    *e = 0;
                                }
                            }
                        }
                    }
                    _ => {
                        if !naive.is_empty() {
                            let (s, a) = naive.swap_remove(which_slab % naive.len());
                            for g in 0..8 {
                                let all = (0..8).fold(0u8, |m, i| m | u8::from(a[8 * g + i] != 0) << i);
                                prop_assert_eq!(p.remove(s, g, 0xff), all.count_ones() as usize);
                            }
                            p.release(s);
                        }
                    }
                }
                for (s, a) in &naive {
                    for (i, &e) in a.iter().enumerate() {
                        prop_assert_eq!(p.get(*s, i), e);
                    }
                    for g in 0..8 {
                        prop_assert_eq!(&p.group(*s, g)[..], &a[8 * g..8 * g + 8]);
                    }
                    prop_assert_eq!(p.count(*s) as usize, a.iter().filter(|&&e| e != 0).count());
                    let listed: Vec<(usize, u32)> = p.entries(*s).collect();
                    let want: Vec<(usize, u32)> =
                        a.iter().enumerate().filter(|(_, &e)| e != 0).map(|(i, &e)| (i, e)).collect();
                    prop_assert_eq!(listed, want);
                    // the segment is at least as large as the entries, and less than four
                    // times larger (beyond the smallest class)
                    let slab = p.slabs[*s as usize];
                    let k = slab.mask.count_ones() as usize;
                    prop_assert!(capacity(slab.class()) >= k);
                    prop_assert!(slab.class() == 0 || capacity(slab.class()) < 4 * k);
                }
                prop_assert_eq!(p.live(), naive.len());
            }
        }
    }

    #[test]
    fn classes_fit_their_counts() {
        for n in 0..=SLAB_SLOTS {
            let c = class_for(n);
            assert!(c < CLASSES);
            assert!(capacity(c) >= n);
            assert!(c == 0 || capacity(c - 1) < n);
        }
    }
}
