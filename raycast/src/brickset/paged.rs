//! The large form of a [`super::BrickSet`]: bricks in pages of 4x4x4 bricks, found through a
//! small hash table keyed by the page's Morton code.
//!
//! A brick's code splits into its page (`brick >> 6`) and its place in the page
//! (`brick & 63`, the Morton order of the page's 64 bricks), so listing the pages sorted and
//! each page's bricks in place order lists the bricks in code order: only the pages are
//! sorted. A LiDAR frame at 0.1 m touches about 700 000 bricks in 40 000 pages (18 each): in
//! a table hashed by brick every brick's first touch was a cache miss in 32 MB and the listing
//! a radix sort of all of them; here the page table stays in the second-level cache and a
//! ray's next brick is mostly in a page line it touched already.

use octoquant_octree::Brick;

/// The table entry of an empty slot. An entry is `(page code + 1) << INDEX_BITS | index`: a
/// page code has 36 bits (the last page, of the map's far corner, is `2^36 - 1`), so its tag
/// `code + 1` fits the 37 bits above the index and is never 0.
const EMPTY: u64 = 0;
/// Bits of a table entry below the page's tag: the page's index in the pool (2^27 pages of
/// 512 bytes would be 64 GiB).
const INDEX_BITS: u32 = 27;
const INDEX_MASK: u64 = (1 << INDEX_BITS) - 1;

/// The table entry of page `page` at index `p`.
#[inline(always)]
fn entry(page: u64, p: usize) -> u64 {
    (page + 1) << INDEX_BITS | p as u64
}

/// Whether table entry `e` is page `page`'s (never an empty slot's).
#[inline(always)]
fn holds(e: u64, page: u64) -> bool {
    e >> INDEX_BITS == page + 1
}

/// The masks of the 64 bricks of one page (4x4x4 bricks), by their Morton order in the page;
/// 0 for a brick not in the set. Eight bricks (a 2x2x2 group) share a cache line.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct Page([u64; 64]);

const CLEAN: Page = Page([0; 64]);

/// The paged set. `clear` keeps the allocations for the next frame.
#[derive(Debug, Clone)]
pub(super) struct BrickPages {
    /// Open addressing, at most half full: [`entry`]s, or [`EMPTY`].
    table: Vec<u64>,
    /// The pages in use are `pages[..codes.len()]`; the others are clean (all zero), as are
    /// the ones in use once listed.
    pages: Vec<Page>,
    /// The code of each page in use, by index.
    codes: Vec<u64>,
    /// The bricks in code order, once listed by [`BrickPages::sort_in_place`].
    sorted: Vec<Brick>,
    /// The pages in code order (code, index) and the sort's other buffer, kept for reuse.
    order: Vec<Brick>,
    scratch: Vec<Brick>,
    /// `true` once listed: the pages in use are clean again.
    listed: bool,
}

impl Default for BrickPages {
    fn default() -> Self {
        BrickPages {
            table: vec![EMPTY; 64],
            pages: Vec::new(),
            codes: Vec::new(),
            sorted: Vec::new(),
            order: Vec::new(),
            scratch: Vec::new(),
            listed: false,
        }
    }
}

/// The index of `page` when it sits in one of its first two table slots (its hash's or the
/// next), found without a branch: which of the two is data, not a guess. Dense depth images
/// hand on millions of bricks of a few hundred pages, and a mispredicted probe loop costs more
/// than the look-up.
#[inline(always)]
fn near_page(table: &[u64], page: u64) -> Option<usize> {
    let mask = table.len() - 1;
    let h = hash(page, mask);
    let j = (h + !holds(table[h], page) as usize) & mask;
    let e = table[j];
    holds(e, page).then_some((e & INDEX_MASK) as usize)
}

/// Ask for the cache line of `slot` ahead of its use.
#[inline(always)]
fn prefetch(slot: &u64) {
    #[cfg(target_arch = "x86_64")]
    safe_arch::prefetch_t0(slot);
    #[cfg(not(target_arch = "x86_64"))]
    let _ = slot;
}

#[inline(always)]
fn hash(page: u64, mask: usize) -> usize {
    (page.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 24) as usize & mask
}

impl BrickPages {
    /// Pages in use (each holds at least one brick).
    pub fn pages_in_use(&self) -> usize {
        self.codes.len()
    }

    /// Remove every key, keeping the tables' sizes.
    pub fn clear(&mut self) {
        let used = self.codes.len();
        if used > 0 {
            self.table.fill(EMPTY);
            if !self.listed {
                self.pages[..used].fill(CLEAN);
            }
        }
        self.codes.clear();
        self.sorted.clear();
        self.listed = false;
    }

    /// Add the voxels of `brick`.
    #[inline(always)]
    pub fn insert_brick(&mut self, brick: Brick) {
        let page = brick.code >> 6;
        let p = match near_page(&self.table, page) {
            Some(p) => p,
            None => self.page_of(page),
        };
        self.pages[p].0[(brick.code & 63) as usize] |= brick.voxels;
    }

    /// Add the bricks of codes `bricks` and voxels `bits`, in chunks: each chunk's pages are
    /// looked up (the page table is in the second-level cache) and the brick's line asked for
    /// first, then the masks are set, so that the chunk's misses on the pages overlap.
    #[inline]
    pub fn put_all(&mut self, bricks: &[u64], bits: &[u64]) {
        const CHUNK: usize = 64;
        let n = bricks.len().min(bits.len());
        let mut at = [0usize; CHUNK];
        for (codes, masks) in bricks[..n].chunks(CHUNK).zip(bits[..n].chunks(CHUNK)) {
            for (a, &code) in at.iter_mut().zip(codes) {
                let page = code >> 6;
                let p = match near_page(&self.table, page) {
                    Some(p) => p,
                    None => self.page_of(page),
                };
                let j = (code & 63) as usize;
                prefetch(&self.pages[p].0[j]);
                *a = p << 6 | j;
            }
            for (&a, &m) in at.iter().zip(masks) {
                self.pages[a >> 6].0[a & 63] |= m;
            }
        }
    }

    /// The index of page `page`, added (clean) if absent.
    #[inline(never)]
    fn page_of(&mut self, page: u64) -> usize {
        let mask = self.table.len() - 1;
        let mut i = hash(page, mask);
        loop {
            let e = self.table[i];
            if e == EMPTY {
                return self.add_page(page, i);
            }
            if holds(e, page) {
                return (e & INDEX_MASK) as usize;
            }
            i = (i + 1) & mask;
        }
    }

    /// Add page `page` at the empty table slot `i`.
    #[inline(never)]
    fn add_page(&mut self, page: u64, i: usize) -> usize {
        let p = self.codes.len();
        self.codes.push(page);
        if self.pages.len() < self.codes.len() {
            self.pages.push(CLEAN);
        }
        self.table[i] = entry(page, p);
        if self.codes.len() * 2 > self.table.len() {
            self.grow();
        }
        p
    }

    fn grow(&mut self) {
        let n = self.table.len() * 2;
        self.table = vec![EMPTY; n];
        let mask = n - 1;
        for (p, &page) in self.codes.iter().enumerate() {
            let mut i = hash(page, mask);
            while self.table[i] != EMPTY {
                i = (i + 1) & mask;
            }
            self.table[i] = entry(page, p);
        }
    }

    /// The bit mask of a brick (0 when absent or once listed).
    #[cfg(test)]
    pub fn get(&self, brick: u64) -> u64 {
        let page = brick >> 6;
        let mask = self.table.len() - 1;
        let mut i = hash(page, mask);
        loop {
            let e = self.table[i];
            if e == EMPTY || self.listed {
                return 0;
            }
            if holds(e, page) {
                return self.pages[(e & INDEX_MASK) as usize].0[(brick & 63) as usize];
            }
            i = (i + 1) & mask;
        }
    }

    /// Bytes of the set's allocations.
    pub fn heap_bytes(&self) -> usize {
        self.table.capacity() * std::mem::size_of::<u64>()
            + self.pages.capacity() * std::mem::size_of::<Page>()
            + self.codes.capacity() * std::mem::size_of::<u64>()
            + (self.sorted.capacity() + self.order.capacity() + self.scratch.capacity())
                * std::mem::size_of::<Brick>()
    }

    /// List the bricks sorted by code and return how many there are
    /// ([`BrickPages::sorted_front`] lists them). The set is then a sorted list: nothing may be
    /// inserted before [`BrickPages::clear`], which empties it.
    pub fn sort_in_place(&mut self) -> usize {
        if !self.listed {
            let mut sorted = std::mem::take(&mut self.sorted);
            self.list_into(&mut sorted);
            self.sorted = sorted;
        }
        self.sorted.len()
    }

    /// Replace `out` with the bricks sorted by code, cleaning the pages as they are read: once
    /// between two [`BrickPages::clear`]s, and nothing may be inserted after it.
    pub fn list_into(&mut self, out: &mut Vec<Brick>) {
        self.list_into_kept(out, |_| true);
    }

    /// [`BrickPages::list_into`] keeping only the bricks `keep` keeps (it may change them).
    #[inline]
    pub fn list_into_kept(
        &mut self,
        out: &mut Vec<Brick>,
        mut keep: impl FnMut(&mut Brick) -> bool,
    ) {
        debug_assert!(!self.listed, "a paged brick set is listed once");
        out.clear();
        // the pages in code order: their codes, with their indices as the payload
        self.order.clear();
        self.order
            .extend(self.codes.iter().enumerate().map(|(p, &code)| Brick {
                code,
                voxels: p as u64,
            }));
        self.scratch
            .resize(self.order.len(), Brick { code: 0, voxels: 0 });
        octoquant_radix::sort_by_key(&mut self.order, &mut self.scratch, |b| b.code);
        // pages are read in code order, not where they lie: each page's eight lines are asked
        // for four pages ahead (norlab at 0.1 m, 39 000 pages, 20 MB: casting 7 % faster; two
        // or eight pages ahead gave about the same)
        const AHEAD: usize = 4;
        for (i, o) in self.order.iter().enumerate() {
            if let Some(next) = self.order.get(i + AHEAD) {
                if let Some(p) = self.pages.get(next.voxels as usize) {
                    for line in p.0.chunks(8) {
                        prefetch(&line[0]);
                    }
                }
            }
            let page = &mut self.pages[o.voxels as usize];
            let mut present = 0u64;
            for (j, &m) in page.0.iter().enumerate() {
                present |= ((m != 0) as u64) << j;
            }
            while present != 0 {
                let j = present.trailing_zeros() as usize;
                present &= present - 1;
                let mut b = Brick {
                    code: o.code << 6 | j as u64,
                    voxels: page.0[j],
                };
                if keep(&mut b) {
                    out.push(b);
                }
            }
            *page = CLEAN;
        }
        self.listed = true;
    }

    /// The first `n` bricks in code order: after [`BrickPages::sort_in_place`] returned `n`,
    /// all of them.
    pub fn sorted_front(&self, n: usize) -> &[Brick] {
        &self.sorted[..n]
    }

    /// The bricks, sorted by code (that is, in Morton order), leaving the set as it is.
    #[cfg(test)]
    pub fn sorted(&self, out: &mut Vec<Brick>) {
        out.clear();
        if self.listed {
            out.extend_from_slice(&self.sorted);
            return;
        }
        for (p, &page) in self.codes.iter().enumerate() {
            for (j, &m) in self.pages[p].0.iter().enumerate() {
                if m != 0 {
                    out.push(Brick {
                        code: page << 6 | j as u64,
                        voxels: m,
                    });
                }
            }
        }
        out.sort_unstable_by_key(|b| b.code);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::collections::BTreeMap;

    /// The definition: a brick set is the union of the masks given per code, listed by code,
    /// bricks without voxels left out.
    fn naive(entries: &[(u64, u64)]) -> Vec<Brick> {
        let mut m = BTreeMap::new();
        for &(code, voxels) in entries {
            *m.entry(code).or_insert(0u64) |= voxels;
        }
        m.into_iter()
            .filter(|&(_, v)| v != 0)
            .map(|(code, voxels)| Brick { code, voxels })
            .collect()
    }

    /// Codes clustered around a base (many bricks per page) or spread over all 42 bits (one
    /// per page), with any masks, zero among them.
    fn entries() -> impl Strategy<Value = Vec<(u64, u64)>> {
        (0u64..(1 << 42), 0u32..=42).prop_flat_map(|(base, spread)| {
            let m = if spread == 42 {
                u64::MAX
            } else {
                (1u64 << spread) - 1
            };
            proptest::collection::vec(
                (
                    any::<u64>(),
                    prop_oneof![Just(0u64), any::<u64>(), (0u32..64).prop_map(|b| 1u64 << b)],
                ),
                0..3000,
            )
            .prop_map(move |v| {
                v.into_iter()
                    .map(|(o, bits)| ((base ^ (o & m)) & ((1 << 42) - 1), bits))
                    .collect()
            })
        })
    }

    /// The map's far corner (keys 65535 on every axis: brick code `2^42 - 1`, the last page)
    /// and its origin corner, inserted alone and in a batch, in a table with empty slots.
    #[test]
    fn the_last_page_and_the_first() {
        let last = (1u64 << 42) - 1;
        let entries = [
            (last, 1u64 << 63),
            (last - 1, 3),
            (0, 1),
            (64, 1 << 5),
            (last, 1),
        ];
        for batched in [false, true] {
            let mut set = BrickPages::default();
            if batched {
                let (codes, bits): (Vec<u64>, Vec<u64>) = entries.iter().copied().unzip();
                set.put_all(&codes, &bits);
            } else {
                for &(code, voxels) in &entries {
                    set.insert_brick(Brick { code, voxels });
                }
            }
            let mut out = Vec::new();
            set.list_into(&mut out);
            assert!(out == naive(&entries));
            // a page looked up before any is added finds none (the empty slots name no page)
            set.clear();
            assert_eq!(set.get(last), 0);
            set.insert_brick(Brick { code: 5, voxels: 2 });
            assert_eq!((set.get(last), set.get(5)), (0, 2));
        }
    }

    proptest! {
        /// Inserted one by one or in batches of any length, two frames in a row on one set
        /// (the second on the pages the first cleaned): the naive set's bricks, in code order.
        #[test]
        fn lists_the_union_in_code_order(
            frames in proptest::collection::vec((entries(), 1usize..200, any::<bool>()), 1..3),
        ) {
            let mut set = BrickPages::default();
            for (entries, chunk, batched) in frames {
                set.clear();
                if batched {
                    let (codes, bits): (Vec<u64>, Vec<u64>) = entries.iter().copied().unzip();
                    for (c, b) in codes.chunks(chunk).zip(bits.chunks(chunk)) {
                        set.put_all(c, b);
                    }
                } else {
                    for &(code, voxels) in &entries {
                        set.insert_brick(Brick { code, voxels });
                    }
                }
                let want = naive(&entries);
                for b in &want {
                    prop_assert_eq!(set.get(b.code), b.voxels);
                }
                let mut out = vec![Brick { code: 1, voxels: 1 }];
                if batched {
                    set.list_into(&mut out);
                } else {
                    let n = set.sort_in_place();
                    out = set.sorted_front(n).to_vec();
                }
                prop_assert!(out == want);
                // listing cleaned every page in use
                prop_assert!(set.pages.iter().all(|p| p.0.iter().all(|&m| m == 0)));
            }
        }
    }
}
