//! Depth-16 node storage: blocks of eight voxels, as `u16` indices into the tree's palette of
//! values (see [`super::palette`]) or, past the palette's limit, as values.
//!
//! A depth-16 block stores eight 2-byte palette indices (16 bytes) instead of eight `f32`s
//! (32 bytes). A tree that needs more than
//! [`PALETTE_LIMIT`](super::palette::PALETTE_LIMIT) distinct voxel values (arbitrary
//! `set_node_value`s, an `.ot` file from elsewhere) switches to wide storage: blocks of eight
//! `f32` at the same block indices, so nothing that refers to a block changes. Compaction
//! (`shrink_to_fit`) rebuilds the palette from the values in use and goes back to narrow
//! storage when they fit again.

use super::arena::{Arena, NO_BLOCK};
use super::inner_block::InnerBlock;
use super::palette::{
    index_words, words_index, Adder, Palette, ABSENT_IDX, EXIT, UNKNOWN, ZERO_IDX,
};
use super::slot::{max_present, present, ABSENT};

/// Eight depth-16 children as palette indices ([`ABSENT_IDX`] for a missing child).
#[derive(Clone, Copy)]
#[repr(C, align(16))]
pub(crate) struct NarrowBlock {
    pub idx: [u16; 8],
}

/// Eight depth-16 children as values (the wide fallback; absent children hold [`ABSENT`]).
#[derive(Clone, Copy)]
#[repr(C, align(32))]
pub(crate) struct WideBlock {
    pub vals: [f32; 8],
}

const EMPTY_NARROW: NarrowBlock = NarrowBlock {
    idx: [ABSENT_IDX; 8],
};
const EMPTY_WIDE: WideBlock = WideBlock { vals: [ABSENT; 8] };

/// What [`VoxelBlocks::update`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Outcome {
    /// Nothing: OctoMap's early exit.
    Exit,
    /// The update was applied; `true` when the voxel is new.
    Applied(bool),
}

/// What [`VoxelBlocks::update_group`] did to a block of eight voxels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct GroupUpdate {
    /// Voxels that were absent and now exist.
    pub created: usize,
    /// Some voxel took its update (not OctoMap's early exit).
    pub applied: bool,
    /// After the update (when applied): all eight voxels exist and are equal, to `max`.
    pub uniform: bool,
    /// After the update (when applied): the largest present value (as
    /// [`VoxelBlocks::collapse_or_max`]).
    pub max: f32,
}

/// What [`VoxelBlocks::update_groups`] did below one depth-14 node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct GroupsUpdate {
    /// Some voxel took its update (not OctoMap's early exit).
    pub applied: bool,
    /// Nodes created (depth-15 nodes and voxels).
    pub added: usize,
    /// Nodes removed by pruning depth-15 nodes.
    pub removed: usize,
    /// The groups not done (a mask as the one passed in): the first of them needs the
    /// voxel-by-voxel path; 0 when all were done.
    pub rest: u64,
}

/// The depth-16 blocks of a tree: narrow (palette indices) or, past the palette limit, wide.
#[derive(Clone)]
pub(crate) struct VoxelBlocks {
    /// Blocks of palette indices (empty when wide, so that an index into it fails there).
    narrow: Arena<NarrowBlock>,
    /// The values `narrow` indexes.
    palette: Palette,
    /// Blocks of values, once the palette overflowed.
    wide: Option<Arena<WideBlock>>,
}

/// The storage in use: narrow blocks and their palette, or wide blocks.
pub(crate) enum View<A, P, W> {
    /// Blocks of palette indices.
    Narrow(A, P),
    /// Blocks of values.
    Wide(W),
}

impl VoxelBlocks {
    /// Empty narrow storage whose palette holds at most `limit` values.
    pub fn new(limit: usize) -> Self {
        VoxelBlocks {
            narrow: Arena::new(EMPTY_NARROW),
            palette: Palette::new(limit),
            wide: None,
        }
    }

    /// The storage in use.
    #[inline(always)]
    pub fn view(&self) -> View<&Arena<NarrowBlock>, &Palette, &Arena<WideBlock>> {
        match &self.wide {
            None => View::Narrow(&self.narrow, &self.palette),
            Some(w) => View::Wide(w),
        }
    }

    /// The storage in use, mutably.
    #[inline(always)]
    fn view_mut(&mut self) -> View<&mut Arena<NarrowBlock>, &mut Palette, &mut Arena<WideBlock>> {
        match &mut self.wide {
            None => View::Narrow(&mut self.narrow, &mut self.palette),
            Some(w) => View::Wide(w),
        }
    }

    /// `true` for the wide fallback.
    #[cfg(test)]
    pub fn is_wide(&self) -> bool {
        self.wide.is_some()
    }

    /// Distinct values in the palette (0 when wide).
    #[cfg(test)]
    pub fn palette_len(&self) -> usize {
        match self.view() {
            View::Narrow(_, palette) => palette.len(),
            View::Wide(_) => 0,
        }
    }

    /// A new empty block.
    #[inline]
    pub fn alloc(&mut self) -> u32 {
        match self.view_mut() {
            View::Narrow(arena, _) => arena.alloc(),
            View::Wide(arena) => arena.alloc(),
        }
    }

    /// Free block `b` (reset to empty, kept for reuse).
    #[inline]
    pub fn release(&mut self, b: u32) {
        match self.view_mut() {
            View::Narrow(arena, _) => arena.release(b),
            View::Wide(arena) => arena.release(b),
        }
    }

    /// Blocks in use.
    pub fn live(&self) -> usize {
        match self.view() {
            View::Narrow(arena, _) => arena.live(),
            View::Wide(arena) => arena.live(),
        }
    }

    /// Bytes held: (live blocks, freed blocks and free list, one block, palette, number of
    /// palette values or `None` when wide).
    pub fn bytes(&self) -> (usize, usize, usize, usize, Option<usize>) {
        match self.view() {
            View::Narrow(arena, palette) => {
                let (live, free) = arena.split_bytes();
                (live, free, 16, palette.bytes(), Some(palette.len()))
            }
            View::Wide(arena) => {
                let (live, free) = arena.split_bytes();
                (live, free, 32, 0, None)
            }
        }
    }

    /// Value of slot `s` of block `b` ([`ABSENT`] when the child does not exist).
    #[inline(always)]
    pub fn get(&self, b: u32, s: usize) -> f32 {
        match self.view() {
            View::Narrow(arena, palette) => {
                palette.vals[arena.blocks[b as usize].idx[s & 7] as usize]
            }
            View::Wide(arena) => arena.blocks[b as usize].vals[s & 7],
        }
    }

    /// Whether slot `s` of block `b` holds a child.
    #[inline(always)]
    pub fn is_present(&self, b: u32, s: usize) -> bool {
        match self.view() {
            View::Narrow(arena, _) => arena.blocks[b as usize].idx[s & 7] != ABSENT_IDX,
            View::Wide(arena) => present(arena.blocks[b as usize].vals[s & 7]),
        }
    }

    /// The eight values of block `b`.
    #[inline]
    pub fn vals(&self, b: u32) -> [f32; 8] {
        match self.view() {
            View::Narrow(arena, palette) => arena.blocks[b as usize]
                .idx
                .map(|i| palette.vals[i as usize]),
            View::Wide(arena) => arena.blocks[b as usize].vals,
        }
    }

    /// Set slot `s` of block `b` to `v` (not NaN, or [`ABSENT`] to remove the child); switches
    /// to wide storage when the palette is full.
    #[inline]
    pub fn set(&mut self, b: u32, s: usize, v: f32) {
        if let View::Narrow(arena, palette) = self.view_mut() {
            let i = if v.to_bits() == 0 {
                Some(ZERO_IDX)
            } else if present(v) {
                palette.intern(v)
            } else {
                Some(ABSENT_IDX)
            };
            match i {
                Some(i) => {
                    arena.blocks[b as usize].idx[s & 7] = i;
                    return;
                }
                None => self.widen(),
            }
        }
        if let View::Wide(arena) = self.view_mut() {
            arena.blocks[b as usize].vals[s & 7] = v;
        }
    }

    /// Set all eight slots of block `b` to `v` (present, not NaN).
    pub fn fill(&mut self, b: u32, v: f32) {
        self.set(b, 0, v);
        match self.view_mut() {
            View::Narrow(arena, _) => {
                let blk = &mut arena.blocks[b as usize];
                blk.idx = [blk.idx[0]; 8];
            }
            View::Wide(arena) => arena.blocks[b as usize].vals = [v; 8],
        }
    }

    /// Slot `s` of block `b` becomes a new child with value 0.
    #[inline]
    pub fn set_zero(&mut self, b: u32, s: usize) {
        match self.view_mut() {
            View::Narrow(arena, _) => arena.blocks[b as usize].idx[s & 7] = ZERO_IDX,
            View::Wide(arena) => arena.blocks[b as usize].vals[s & 7] = 0.0,
        }
    }

    /// Prepare voxel updates by `delta` clamped to `[cmin, cmax]`.
    pub fn adder(&mut self, delta: f32, cmin: f32, cmax: f32) -> Adder {
        match self.view_mut() {
            View::Narrow(_, palette) => palette.adder(delta, cmin, cmax),
            View::Wide(_) => Adder::new(delta, cmin, cmax),
        }
    }

    /// Take the transition memo of `add` out of the palette, to pass to
    /// [`VoxelBlocks::update`] for a batch of updates (empty when wide); give it back with
    /// [`VoxelBlocks::put_memo`].
    pub fn take_memo(&mut self, add: &Adder) -> Vec<u16> {
        match self.view_mut() {
            View::Narrow(_, palette) => palette.take_memo(add),
            View::Wide(_) => Vec::new(),
        }
    }

    /// Give back the memo taken by [`VoxelBlocks::take_memo`] (dropped when the storage became
    /// wide meanwhile).
    pub fn put_memo(&mut self, add: &Adder, next: Vec<u16>) {
        if let View::Narrow(_, palette) = self.view_mut() {
            palette.put_memo(add, next);
        }
    }

    /// OctoMap's `updateNodeLogOdds` on slot `s` of block `b`: a voxel that is absent, or
    /// `fresh` (just created with value 0), gets `0 + delta` clamped; an existing one takes the
    /// early exit at the clamp the update pushes towards, else gets `v + delta` clamped.
    /// `memo` is `add`'s transition memo (from [`VoxelBlocks::take_memo`]).
    #[inline(always)]
    pub fn update(
        &mut self,
        b: u32,
        s: usize,
        add: &Adder,
        fresh: bool,
        memo: &mut Vec<u16>,
    ) -> Outcome {
        // wide storage keeps no narrow blocks, so this look-up is also the mode test
        if let Some(blk) = self.narrow.blocks.get_mut(b as usize) {
            let slot = &mut blk.idx[s & 7];
            let i = if fresh { ABSENT_IDX } else { *slot };
            let n = memo.get(i as usize).copied().unwrap_or(UNKNOWN);
            if n.wrapping_sub(1) < EXIT - 1 {
                // neither UNKNOWN nor EXIT: a known transition
                *slot = n;
                return Outcome::Applied(i == ABSENT_IDX);
            }
            if n == EXIT {
                return Outcome::Exit;
            }
        }
        self.update_slow(b, s, add, fresh, memo)
    }

    /// [`VoxelBlocks::update`] on the voxels `bits` (bit = slot) of narrow block `b` at once,
    /// followed by [`VoxelBlocks::collapse_or_max`] of the block, when every one of them has a
    /// memoized transition: the block is read once into a local copy, updated there, written
    /// back once, and the parent's test reads the copy instead of the block again (about a
    /// twentieth less tree time on LiDAR frames than slot-by-slot updates and a re-read).
    ///
    /// `None` (and nothing changed) on wide storage, when a transition is not memoized yet, or
    /// when the palette holds `-0.0` (equal to `+0.0` under another index): then the caller
    /// takes the voxel-by-voxel path.
    #[inline(always)]
    pub fn update_group(&mut self, b: u32, bits: u8, memo: &[u16]) -> Option<GroupUpdate> {
        if self.palette.neg_zero {
            return None;
        }
        let blk = self.narrow.blocks.get_mut(b as usize)?;
        group_step(blk, &self.palette, bits, memo)
    }

    /// The batched walk's updates below a depth-14 node whose child block is `parent`: for
    /// each group of eight bits of `mask` (byte `j` = the voxels below the depth-15 node in
    /// slot `j`), in order, create the depth-15 node when absent, then
    /// [`VoxelBlocks::update_group`] and, unless `lazy`, set the node to the max of its
    /// voxels or prune it. A pruned depth-15 node whose value is at the clamp the update
    /// pushes towards takes OctoMap's early exit (nothing changes); another one is expanded
    /// first. A new or just expanded node's block holds one value (absent, or the node's), so
    /// its update and max need one memo look-up and no per-voxel loop.
    ///
    /// Stops before a group that needs more: a transition not memoized yet, a full palette,
    /// wide storage or `-0.0` in the palette; [`GroupsUpdate::rest`] holds the groups left
    /// (the first one's node may have been created or expanded meanwhile, as that path
    /// would). The parent block is borrowed once for the whole brick, and nodes added and
    /// removed are counted here instead of in the tree.
    #[inline(always)]
    pub fn update_groups(
        &mut self,
        parent: &mut InnerBlock,
        mask: u64,
        memo: &[u16],
        add: &Adder,
        lazy: bool,
    ) -> GroupsUpdate {
        let mut out = GroupsUpdate {
            applied: false,
            added: 0,
            removed: 0,
            rest: mask,
        };
        if self.palette.neg_zero || self.wide.is_some() {
            return out;
        }
        while out.rest != 0 {
            let j = out.rest.trailing_zeros() as usize / 8;
            let bits = (out.rest >> (8 * j)) as u8;
            let v = parent.vals[j & 7];
            let mut lb = parent.kids[j & 7];
            if !present(v) {
                // a new node: every voxel below it is new
                parent.vals[j & 7] = 0.0;
                out.added += 1;
                lb = self.narrow.alloc();
                parent.kids[j & 7] = lb;
                let n0 = memo.first().copied().unwrap_or(UNKNOWN);
                if n0 != UNKNOWN {
                    // every selected voxel takes the transition of a new voxel (never OctoMap's
                    // early exit), the others stay absent: the block's max is that voxel's
                    // value, and the block is uniform when all eight are selected
                    self.narrow.blocks[lb as usize].idx = selected_to(ABSENT_IDX, bits, n0);
                    out.added += bits.count_ones() as usize;
                    out.applied = true;
                    out.rest &= !(0xff << (8 * j));
                    if !lazy {
                        let v0 = self.palette.vals[usize::from(n0)];
                        if bits == 0xff {
                            parent.vals[j & 7] = v0;
                            parent.kids[j & 7] = NO_BLOCK;
                            self.narrow.release(lb);
                            out.removed += 8;
                        } else {
                            parent.vals[j & 7] = if v0 > -f32::MAX { v0 } else { -f32::MAX };
                        }
                    }
                    continue;
                }
            } else if lb == NO_BLOCK {
                if add.exits_at(v) {
                    // a pruned node at the clamp: its voxels' searches end here
                    out.rest &= !(0xff << (8 * j));
                    continue;
                }
                // a pruned node: expand it (`expandNode`), unless the palette is full (the
                // caller's path widens the storage)
                let Some(i) = self.palette.intern(v) else {
                    return out;
                };
                lb = self.narrow.alloc();
                self.narrow.blocks[lb as usize].idx = [i; 8];
                parent.kids[j & 7] = lb;
                out.added += 8;
                if self.palette.neg_zero {
                    // `v` was -0.0
                    return out;
                }
                let n = memo.get(usize::from(i)).copied().unwrap_or(UNKNOWN);
                if n.wrapping_sub(1) < EXIT - 1 {
                    // every selected voxel takes the transition of `v` (not the early exit:
                    // `v` is not at that clamp), the others keep `v`: two values, so the max
                    // is the larger, and the block is uniform when all eight are selected or
                    // the transition keeps the index
                    self.narrow.blocks[lb as usize].idx = selected_to(i, bits, n);
                    out.applied = true;
                    out.rest &= !(0xff << (8 * j));
                    if !lazy {
                        let vn = self.palette.vals[usize::from(n)];
                        if bits == 0xff || n == i {
                            parent.vals[j & 7] = vn;
                            parent.kids[j & 7] = NO_BLOCK;
                            self.narrow.release(lb);
                            out.removed += 8;
                        } else {
                            let mut m = -f32::MAX;
                            for x in [v, vn] {
                                if x > m {
                                    m = x;
                                }
                            }
                            parent.vals[j & 7] = m;
                        }
                    }
                    continue;
                }
            }
            let Some(blk) = self.narrow.blocks.get_mut(lb as usize) else {
                return out;
            };
            let Some(g) = group_step(blk, &self.palette, bits, memo) else {
                return out;
            };
            out.rest &= !(0xff << (8 * j));
            out.added += g.created;
            if g.applied {
                out.applied = true;
                if !lazy {
                    parent.vals[j & 7] = g.max;
                    if g.uniform {
                        parent.kids[j & 7] = NO_BLOCK;
                        self.narrow.release(lb);
                        out.removed += 8;
                    }
                }
            }
        }
        out
    }

    /// [`VoxelBlocks::update`] without a memo entry, or on wide storage.
    #[inline(never)]
    fn update_slow(
        &mut self,
        b: u32,
        s: usize,
        add: &Adder,
        fresh: bool,
        memo: &mut Vec<u16>,
    ) -> Outcome {
        if let View::Narrow(arena, palette) = self.view_mut() {
            let slot = &mut arena.blocks[b as usize].idx[s & 7];
            let i = if fresh { ABSENT_IDX } else { *slot };
            if let Some(n) = palette.step_slow(i, add, memo) {
                if n == EXIT {
                    return Outcome::Exit;
                }
                *slot = n;
                return Outcome::Applied(i == ABSENT_IDX);
            }
            self.widen();
        }
        match self.view_mut() {
            View::Wide(arena) => {
                let slot = &mut arena.blocks[b as usize].vals[s & 7];
                let created = fresh || !present(*slot);
                let old = if created { 0.0 } else { *slot };
                if !created && add.exits_at(old) {
                    return Outcome::Exit;
                }
                *slot = add.apply(old);
                Outcome::Applied(created)
            }
            View::Narrow(..) => unreachable!("widened above"),
        }
    }

    /// The value all eight children of block `b` share when they exist and are equal under
    /// float `==` (OctoMap's prune test); `None` otherwise.
    #[inline]
    pub fn uniform(&self, b: u32) -> Option<f32> {
        match self.view() {
            View::Narrow(arena, palette) => {
                let idx = arena.blocks[b as usize].idx;
                let i0 = idx[0];
                if idx == [i0; 8] {
                    return (i0 != ABSENT_IDX).then(|| palette.vals[i0 as usize]);
                }
                if !palette.neg_zero {
                    return None;
                }
                // +0.0 and -0.0 have different indices but are equal
                uniform_vals(&idx.map(|i| palette.vals[i as usize]))
            }
            View::Wide(arena) => uniform_vals(&arena.blocks[b as usize].vals),
        }
    }

    /// `(true, v)` when the eight children of block `b` exist and equal `v` under float `==`
    /// ([`VoxelBlocks::uniform`]), else `(false, their max)` ([`VoxelBlocks::max`]).
    #[inline(always)]
    pub fn collapse_or_max(&self, b: u32) -> (bool, f32) {
        if let View::Narrow(arena, palette) = self.view() {
            if !palette.neg_zero {
                return palette.uniform_or_max(&arena.blocks[b as usize].idx);
            }
        }
        match self.uniform(b) {
            Some(v0) => (true, v0),
            None => (false, self.max(b)),
        }
    }

    /// The largest present value of block `b` (`-f32::MAX` when none), first in child order
    /// among equal values.
    #[inline]
    pub fn max(&self, b: u32) -> f32 {
        match self.view() {
            View::Narrow(arena, palette) => {
                let mut m = -f32::MAX;
                for &i in &arena.blocks[b as usize].idx {
                    let v = palette.vals[i as usize];
                    if v > m {
                        m = v;
                    }
                }
                m
            }
            View::Wide(arena) => max_present(&arena.blocks[b as usize].vals),
        }
    }

    /// Replace every present value `v` by `f(v)` (`f` must not return NaN).
    pub fn map_values(&mut self, f: impl Fn(f32) -> f32) {
        match self.view_mut() {
            View::Narrow(arena, palette) => {
                let mut fresh = Palette::new(palette.limit);
                let mut remap = vec![ABSENT_IDX];
                for &v in &palette.values()[1..] {
                    match fresh.intern(f(v)) {
                        Some(i) => remap.push(i),
                        None => {
                            // more distinct results than fit: convert value by value
                            self.widen();
                            return self.map_values(f);
                        }
                    }
                }
                for blk in &mut arena.blocks {
                    for i in &mut blk.idx {
                        *i = remap[*i as usize];
                    }
                }
                *palette = fresh;
            }
            View::Wide(arena) => {
                for blk in &mut arena.blocks {
                    for v in &mut blk.vals {
                        if present(*v) {
                            *v = f(*v);
                        }
                    }
                }
            }
        }
    }

    /// Switch to wide storage: every block keeps its index, every slot its value.
    #[cold]
    #[inline(never)]
    fn widen(&mut self) {
        if self.wide.is_some() {
            return;
        }
        let palette = &self.palette;
        let wide = self.narrow.map_blocks(EMPTY_WIDE, |blk| WideBlock {
            vals: blk.idx.map(|i| palette.vals[i as usize]),
        });
        self.wide = Some(wide);
        self.narrow = Arena::new(EMPTY_NARROW);
        self.palette = Palette::new(self.palette.limit);
    }

    /// New compact storage holding the blocks `order` (old indices) at indices 0, 1, ...:
    /// narrow with a palette of just the values still in use when at most `limit` distinct
    /// values are, else wide.
    pub fn compacted(&self, order: &[u32], limit: usize) -> VoxelBlocks {
        let mut palette = Palette::new(limit);
        let mut arena = Arena::new(EMPTY_NARROW);
        arena.blocks.reserve_exact(order.len());
        let mut fits = true;
        'blocks: for &b in order {
            let mut blk = EMPTY_NARROW;
            for (s, v) in self.vals(b).into_iter().enumerate() {
                if present(v) {
                    match palette.intern(v) {
                        Some(i) => blk.idx[s] = i,
                        None => {
                            fits = false;
                            break 'blocks;
                        }
                    }
                }
            }
            arena.blocks.push(blk);
        }
        if fits {
            palette.vals.shrink_to_fit();
            return VoxelBlocks {
                narrow: arena,
                palette,
                wide: None,
            };
        }
        let mut wide = Arena::new(EMPTY_WIDE);
        wide.blocks.reserve_exact(order.len());
        wide.blocks
            .extend(order.iter().map(|&b| WideBlock { vals: self.vals(b) }));
        VoxelBlocks {
            narrow: Arena::new(EMPTY_NARROW),
            palette: Palette::new(limit),
            wide: Some(wide),
        }
    }
}

/// [`VoxelBlocks::update_group`] on the narrow block `blk` (the palette holds no `-0.0`).
///
/// The indices are changed as two words in registers ([`index_words`]) and written back with
/// one store each: changed one 16-bit slot at a time in memory, the block's write-back and
/// the max that reads it waited for those narrow stores (a store-forwarding stall).
#[inline(always)]
fn group_step(
    blk: &mut NarrowBlock,
    palette: &Palette,
    bits: u8,
    memo: &[u16],
) -> Option<GroupUpdate> {
    let mut w = index_words(&blk.idx);
    let mut created = 0;
    let mut applied = false;
    let mut rest = u32::from(bits);
    while rest != 0 {
        let s = rest.trailing_zeros() as usize;
        rest &= rest - 1;
        let (k, shift) = ((s >> 2) & 1, 16 * (s & 3));
        let i = (w[k] >> shift) as u16;
        let n = memo.get(i as usize).copied().unwrap_or(UNKNOWN);
        // one test for both special entries, UNKNOWN (0) and EXIT (0xffff)
        if n.wrapping_sub(1) < EXIT - 1 {
            w[k] = (w[k] & !(0xffff << shift)) | (u64::from(n) << shift);
            created += usize::from(i == ABSENT_IDX);
            applied = true;
        } else if n == UNKNOWN {
            return None;
        }
    }
    if !applied {
        return Some(GroupUpdate {
            created: 0,
            applied: false,
            uniform: false,
            max: 0.0,
        });
    }
    blk.idx = words_index(w);
    let (uniform, max) = palette.uniform_or_max_words(w[0], w[1]);
    Some(GroupUpdate {
        created,
        applied,
        uniform,
        max,
    })
}

/// `Some(v0)` when all eight values are present and equal to the first under `==`.
#[inline]
fn uniform_vals(vals: &[f32; 8]) -> Option<f32> {
    let v0 = vals[0];
    (present(v0) && vals.iter().fold(true, |a, &v| a & (v == v0))).then_some(v0)
}

#[cfg(test)]
#[path = "voxel_blocks_tests.rs"]
mod tests;

/// Eight slots all holding `from`, except those selected by `bits` (bit `k`: slot `k`), which
/// hold `to`.
///
/// Built as two words in registers ([`words_index`]): written slot by slot into a copy on the
/// stack, the block's store waited for the narrow stores to reach the copy (a
/// store-forwarding stall, 7 % of the tree walk's samples on norlab's LiDAR frames at 0.2 m).
#[inline(always)]
fn selected_to(from: u16, bits: u8, to: u16) -> [u16; 8] {
    let (from, to) = (u64::from(from) * LANES_OF_16, u64::from(to) * LANES_OF_16);
    let word = |sel: u8| {
        let m = SLOT_MASKS[usize::from(sel & 15)];
        (from & !m) | (to & m)
    };
    words_index([word(bits), word(bits >> 4)])
}

/// One in each 16-bit slot of a word.
const LANES_OF_16: u64 = 0x0001_0001_0001_0001;

/// Per four-bit selection (bit `k`: slot `k` of a word), the mask of the selected 16-bit
/// slots.
const SLOT_MASKS: [u64; 16] = {
    let mut t = [0u64; 16];
    let mut sel = 0;
    while sel < 16 {
        let mut k = 0;
        while k < 4 {
            if sel >> k & 1 == 1 {
                t[sel] |= 0xffff << (16 * k);
            }
            k += 1;
        }
        sel += 1;
    }
    t
};
