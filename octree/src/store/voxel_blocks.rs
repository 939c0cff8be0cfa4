//! Depth-16 node storage: blocks of eight `u16` indices into a per-tree palette of values.
//!
//! Real maps hold few distinct voxel log-odds (sums of the hit and miss deltas, clamped), so a
//! depth-16 block stores eight 2-byte palette indices (16 bytes) instead of eight `f32`s
//! (32 bytes). The palette interns each distinct bit pattern once: equal indices mean equal
//! bits, so `+0.0` and `-0.0` get different indices, as they must to keep `.ot` bytes. Index 0
//! is an absent child (its palette entry is the absent NaN), index 1 is `0.0`.
//!
//! Voxel updates go through a memo of transitions, index -> index, for the (delta, clamps) of
//! the batch, so the common update is two table look-ups: no arithmetic, no hashing.
//!
//! A tree that needs more than [`PALETTE_LIMIT`] distinct leaf values (arbitrary
//! `set_node_value`s, an `.ot` file from elsewhere) switches to wide storage: blocks of eight
//! `f32` at the same block indices, so nothing that refers to a block changes. Compaction
//! (`shrink_to_fit`) rebuilds the palette from the values in use and goes back to narrow
//! storage when they fit again.

use super::nodes::{max_present, present, Arena, ABSENT};

/// Index of an absent slot in a narrow block (palette entry: [`ABSENT`]).
const ABSENT_IDX: u16 = 0;
/// Index of `+0.0`, the value of a new voxel.
const ZERO_IDX: u16 = 1;
/// A memo entry: not computed yet.
const UNKNOWN: u16 = 0;
/// A memo entry: OctoMap's early exit (the voxel is at the clamp the update pushes towards).
const EXIT: u16 = u16::MAX;
/// The most distinct values a palette holds (so indices stay below [`EXIT`]).
pub(crate) const PALETTE_LIMIT: usize = 0xfff0;
/// An empty slot of the palette's hash table.
const EMPTY_SLOT: u16 = 0;

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

/// `old + delta` clamped to `[cmin, cmax]`, as `updateNodeLogOdds` computes it.
#[inline(always)]
pub(crate) fn clamp_sum(old: f32, delta: f32, cmin: f32, cmax: f32) -> f32 {
    let v = old + delta;
    if v < cmin {
        cmin
    } else if v > cmax {
        cmax
    } else {
        v
    }
}

/// A voxel update: add `delta`, clamp to `[cmin, cmax]`; `memo` names the palette's
/// transition table for these three numbers (from [`Leaves::adder`]). Valid within the call
/// that made it: no other adder is made and the palette is not rebuilt meanwhile.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Adder {
    pub delta: f32,
    pub cmin: f32,
    pub cmax: f32,
    memo: usize,
}

impl Adder {
    fn bits(&self) -> [u32; 3] {
        [
            self.delta.to_bits(),
            self.cmin.to_bits(),
            self.cmax.to_bits(),
        ]
    }

    /// OctoMap's early exit: the voxel already sits at the clamp the update pushes towards.
    #[inline(always)]
    pub fn exits_at(&self, v: f32) -> bool {
        (self.delta >= 0.0 && v >= self.cmax) || (self.delta <= 0.0 && v <= self.cmin)
    }

    #[inline(always)]
    fn apply(&self, v: f32) -> f32 {
        clamp_sum(v, self.delta, self.cmin, self.cmax)
    }
}

/// What [`Leaves::update`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Outcome {
    /// Nothing: OctoMap's early exit.
    Exit,
    /// The update was applied; `true` when the voxel is new.
    Applied(bool),
}

/// Transitions index -> index of one (delta, cmin, cmax): `next[0]` for a new voxel (value
/// 0, no early exit), `next[i]` for an existing voxel of value `vals[i]` ([`EXIT`] for the
/// early exit); [`UNKNOWN`] where not computed yet.
#[derive(Clone, Default)]
struct Memo {
    key: Option<[u32; 3]>,
    next: Vec<u16>,
}

/// The distinct leaf values of a tree, each once, with a hash index and the update memos.
#[derive(Clone)]
pub(crate) struct Palette {
    /// Index -> value; index 0 is the absent NaN, index 1 is `0.0`.
    vals: Vec<f32>,
    /// Open addressing over `vals[1..]` by bit pattern: slots hold an index or
    /// [`EMPTY_SLOT`]; the length is a power of two at least twice `vals.len()`.
    table: Vec<u16>,
    /// Whether some value is `-0.0` (which equals `+0.0` under `==` with another index).
    neg_zero: bool,
    /// Two transition memos (a scan updates with a miss delta and a hit delta).
    memos: [Memo; 2],
    /// The memo replaced last.
    last_memo: usize,
    /// The most values allowed ([`PALETTE_LIMIT`], less only in tests).
    limit: usize,
}

impl Palette {
    fn new(limit: usize) -> Self {
        let mut p = Palette {
            vals: vec![ABSENT],
            table: vec![EMPTY_SLOT; 16],
            neg_zero: false,
            memos: Default::default(),
            last_memo: 1,
            limit: limit.clamp(1, PALETTE_LIMIT),
        };
        let zero = p.intern(0.0);
        debug_assert_eq!(zero, Some(ZERO_IDX));
        p
    }

    /// Number of distinct values.
    #[cfg(test)]
    pub fn len(&self) -> usize {
        self.vals.len() - 1
    }

    #[inline]
    fn slot_of(&self, bits: u32) -> usize {
        let shift = 32 - self.table.len().trailing_zeros();
        (bits.wrapping_mul(0x9e37_79b9) >> shift) as usize
    }

    /// The index of `v` (present, not NaN), added if new; `None` when the palette is full.
    fn intern(&mut self, v: f32) -> Option<u16> {
        let bits = v.to_bits();
        let mask = self.table.len() - 1;
        let mut s = self.slot_of(bits);
        loop {
            let i = self.table[s];
            if i == EMPTY_SLOT {
                break;
            }
            if self.vals[i as usize].to_bits() == bits {
                return Some(i);
            }
            s = (s + 1) & mask;
        }
        if self.vals.len() > self.limit {
            return None;
        }
        let i = self.vals.len() as u16;
        self.vals.push(v);
        self.neg_zero |= bits == (-0.0f32).to_bits();
        if 2 * self.vals.len() > self.table.len() {
            self.rehash(2 * self.table.len());
        } else {
            self.table[s] = i;
        }
        Some(i)
    }

    fn rehash(&mut self, len: usize) {
        self.table = vec![EMPTY_SLOT; len];
        let mask = len - 1;
        for (i, v) in self.vals.iter().enumerate().skip(1) {
            let mut s = self.slot_of(v.to_bits());
            while self.table[s] != EMPTY_SLOT {
                s = (s + 1) & mask;
            }
            self.table[s] = i as u16;
        }
    }

    /// The memo for `(delta, cmin, cmax)`, reusing or replacing one of the two.
    fn memo_for(&mut self, key: [u32; 3]) -> usize {
        if let Some(m) = self.memos.iter().position(|m| m.key == Some(key)) {
            return m;
        }
        let m = 1 - self.last_memo;
        self.last_memo = m;
        self.memos[m].key = Some(key);
        self.memos[m].next.clear();
        m
    }

    /// Compute the memo entry for index `i` (see [`Memo`]) and store it in `next`, the
    /// memo of `add`; `None` when the result does not fit in the palette.
    #[cold]
    #[inline(never)]
    fn step_slow(&mut self, i: u16, add: &Adder, next: &mut Vec<u16>) -> Option<u16> {
        let n = if i == ABSENT_IDX {
            self.intern(add.apply(0.0))?
        } else {
            let v = self.vals[i as usize];
            if add.exits_at(v) {
                EXIT
            } else {
                self.intern(add.apply(v))?
            }
        };
        if next.len() <= i as usize {
            next.resize(i as usize + 1, UNKNOWN);
        }
        next[i as usize] = n;
        Some(n)
    }

    /// Bytes held: values, hash table and memos.
    fn bytes(&self) -> usize {
        self.vals.capacity() * 4
            + self.table.capacity() * 2
            + self
                .memos
                .iter()
                .map(|m| m.next.capacity() * 2)
                .sum::<usize>()
    }
}

/// The depth-16 blocks of a tree: narrow (palette indices) or, past the palette limit, wide.
#[derive(Clone)]
pub(crate) struct Leaves {
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

impl Leaves {
    /// Empty narrow storage whose palette holds at most `limit` values.
    pub fn new(limit: usize) -> Self {
        Leaves {
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
                (
                    live,
                    free,
                    16,
                    palette.bytes(),
                    Some(palette.vals.len() - 1),
                )
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
        let mut a = Adder {
            delta,
            cmin,
            cmax,
            memo: 0,
        };
        if let View::Narrow(_, palette) = self.view_mut() {
            a.memo = palette.memo_for(a.bits());
        }
        a
    }

    /// Take the transition memo of `add` out of the palette, to pass to
    /// [`Leaves::update`] for a batch of updates (empty when wide); give it back with
    /// [`Leaves::put_memo`].
    pub fn take_memo(&mut self, add: &Adder) -> Vec<u16> {
        match self.view_mut() {
            View::Narrow(_, palette) => std::mem::take(&mut palette.memos[add.memo & 1].next),
            View::Wide(_) => Vec::new(),
        }
    }

    /// Give back the memo taken by [`Leaves::take_memo`] (dropped when the storage became
    /// wide meanwhile).
    pub fn put_memo(&mut self, add: &Adder, next: Vec<u16>) {
        if let View::Narrow(_, palette) = self.view_mut() {
            let memo = &mut palette.memos[add.memo & 1];
            if memo.key == Some(add.bits()) {
                memo.next = next;
            }
        }
    }

    /// OctoMap's `updateNodeLogOdds` on slot `s` of block `b`: a voxel that is absent, or
    /// `fresh` (just created with value 0), gets `0 + delta` clamped; an existing one takes the
    /// early exit at the clamp the update pushes towards, else gets `v + delta` clamped.
    /// `memo` is `add`'s transition memo (from [`Leaves::take_memo`]).
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

    /// [`Leaves::update`] without a memo entry, or on wide storage.
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
    /// ([`Leaves::uniform`]), else `(false, their max)` ([`Leaves::max`]).
    #[inline(always)]
    pub fn collapse_or_max(&self, b: u32) -> (bool, f32) {
        if let View::Narrow(arena, palette) = self.view() {
            let idx = arena.blocks[b as usize].idx;
            let i0 = idx[0];
            if idx == [i0; 8] && i0 != ABSENT_IDX {
                return (true, palette.vals[i0 as usize]);
            }
            if !palette.neg_zero {
                let mut m = -f32::MAX;
                for i in idx {
                    let v = palette.vals[i as usize];
                    if v > m {
                        m = v;
                    }
                }
                return (false, m);
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
                for &v in &palette.vals[1..] {
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
    pub fn compacted(&self, order: &[u32], limit: usize) -> Leaves {
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
            return Leaves {
                narrow: arena,
                palette,
                wide: None,
            };
        }
        let mut wide = Arena::new(EMPTY_WIDE);
        wide.blocks.reserve_exact(order.len());
        wide.blocks
            .extend(order.iter().map(|&b| WideBlock { vals: self.vals(b) }));
        Leaves {
            narrow: Arena::new(EMPTY_NARROW),
            palette: Palette::new(limit),
            wide: Some(wide),
        }
    }
}

/// `Some(v0)` when all eight values are present and equal to the first under `==`.
#[inline]
fn uniform_vals(vals: &[f32; 8]) -> Option<f32> {
    let v0 = vals[0];
    (present(v0) && vals.iter().fold(true, |a, &v| a & (v == v0))).then_some(v0)
}

#[cfg(test)]
mod tests {
    //! The leaf storage against a naive model (plain `f32` blocks), with palette limits small
    //! enough that the wide fallback and the way back to narrow storage are exercised; and
    //! whole trees with a tiny limit against trees with the real one and a flat voxel map.

    use super::*;
    use crate::io::{read_ot, write_bt, write_ot};
    use crate::store::nodes::{max_present, present};
    use crate::validate::check_well_formed;
    use crate::{Key, OcTree, Update};
    use proptest::prelude::*;
    use std::collections::HashMap;

    /// A small set of values with repeats, both zeros and values that clamp.
    const VALS: [f32; 9] = [0.0, -0.0, 0.85, -0.4, 1.7, -2.0, 3.5, 0.45, 1e-30];

    #[derive(Debug, Clone)]
    enum Op {
        Alloc,
        Release(usize),
        Set(usize, usize, usize),
        Remove(usize, usize),
        Zero(usize, usize),
        Fill(usize, usize),
        Update(usize, usize, usize, bool, bool),
        Map(bool),
        Compact(Vec<usize>),
    }

    fn op() -> impl Strategy<Value = Op> {
        prop_oneof![
            3 => Just(Op::Alloc),
            1 => any::<usize>().prop_map(Op::Release),
            4 => (any::<usize>(), 0usize..8, 0usize..VALS.len()).prop_map(|(b, s, v)| Op::Set(b, s, v)),
            1 => (any::<usize>(), 0usize..8).prop_map(|(b, s)| Op::Remove(b, s)),
            1 => (any::<usize>(), 0usize..8).prop_map(|(b, s)| Op::Zero(b, s)),
            1 => (any::<usize>(), 0usize..VALS.len()).prop_map(|(b, v)| Op::Fill(b, v)),
            6 => (any::<usize>(), 0usize..8, 0usize..3, any::<bool>(), any::<bool>())
                .prop_map(|(b, s, d, twice, fresh)| Op::Update(b, s, d, twice, fresh)),
            1 => any::<bool>().prop_map(Op::Map),
            1 => prop::collection::vec(any::<usize>(), 0..6).prop_map(Op::Compact),
        ]
    }

    /// The naive storage: blocks of values, and which of them are in use.
    struct Model {
        blocks: Vec<[f32; 8]>,
        live: Vec<bool>,
    }

    fn check(l: &Leaves, m: &Model) -> Result<(), TestCaseError> {
        prop_assert_eq!(l.live(), m.live.iter().filter(|&&x| x).count());
        for (b, want) in m.blocks.iter().enumerate() {
            let b32 = b as u32;
            let got = l.vals(b32);
            prop_assert_eq!(got.map(f32::to_bits), want.map(f32::to_bits), "block {}", b);
            for (s, w) in want.iter().enumerate() {
                prop_assert_eq!(l.get(b32, s).to_bits(), w.to_bits());
                prop_assert_eq!(l.is_present(b32, s), present(*w));
            }
            prop_assert_eq!(l.max(b32).to_bits(), max_present(want).to_bits());
            let v0 = want[0];
            let uniform = (present(v0) && want.iter().all(|&v| v == v0)).then_some(v0);
            prop_assert_eq!(l.uniform(b32).map(f32::to_bits), uniform.map(f32::to_bits));
        }
        if let View::Narrow(_, palette) = l.view() {
            prop_assert!(palette.len() <= palette.limit);
            prop_assert_eq!(palette.vals[0].to_bits(), ABSENT.to_bits());
            prop_assert_eq!(palette.vals[1].to_bits(), 0);
            // the hash index finds every value at its own index
            let mut p = palette.clone();
            for (i, v) in palette.vals.iter().enumerate().skip(1) {
                prop_assert_eq!(p.intern(*v), Some(i as u16));
            }
        }
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

        /// Every operation leaves the storage reading back what plain `f32` blocks hold,
        /// whether it is narrow, became wide on the way, or was compacted back to narrow.
        #[test]
        fn storage_matches_plain_blocks(limit in 1usize..8, ops in prop::collection::vec(op(), 1..120)) {
            let mut l = Leaves::new(limit);
            let mut m = Model { blocks: Vec::new(), live: Vec::new() };
            let deltas = [0.85f32, -0.4, 0.7];
            let (cmin, cmax) = (-2.0f32, 3.5f32);
            for op in ops {
                let live: Vec<usize> = (0..m.live.len()).filter(|&b| m.live[b]).collect();
                let pick = |i: usize| live.get(i % live.len().max(1)).copied();
                match op {
                    Op::Alloc => {
                        let b = l.alloc() as usize;
                        if b == m.blocks.len() {
                            m.blocks.push([ABSENT; 8]);
                            m.live.push(false);
                        }
                        prop_assert!(!m.live[b], "allocated a live block");
                        prop_assert!(m.blocks[b].iter().all(|v| !present(*v)));
                        m.live[b] = true;
                    }
                    Op::Release(i) => if let Some(b) = pick(i) {
                        l.release(b as u32);
                        m.blocks[b] = [ABSENT; 8];
                        m.live[b] = false;
                    },
                    Op::Set(i, s, v) => if let Some(b) = pick(i) {
                        l.set(b as u32, s, VALS[v]);
                        m.blocks[b][s] = VALS[v];
                    },
                    Op::Remove(i, s) => if let Some(b) = pick(i) {
                        l.set(b as u32, s, ABSENT);
                        m.blocks[b][s] = ABSENT;
                    },
                    Op::Zero(i, s) => if let Some(b) = pick(i) {
                        l.set_zero(b as u32, s);
                        m.blocks[b][s] = 0.0;
                    },
                    Op::Fill(i, v) => if let Some(b) = pick(i) {
                        l.fill(b as u32, VALS[v]);
                        m.blocks[b] = [VALS[v]; 8];
                    },
                    Op::Update(i, s, d, twice, fresh) => if let Some(b) = pick(i) {
                        let add = l.adder(deltas[d], cmin, cmax);
                        let mut memo = l.take_memo(&add);
                        for round in 0..1 + usize::from(twice) {
                            // a fresh voxel is one just created: it holds 0
                            let fresh = fresh && round == 0;
                            if fresh {
                                l.set_zero(b as u32, s);
                                m.blocks[b][s] = 0.0;
                            }
                            let old = m.blocks[b][s];
                            let created = fresh || !present(old);
                            let want = if !created && add.exits_at(old) {
                                Outcome::Exit
                            } else {
                                let base = if created { 0.0 } else { old };
                                m.blocks[b][s] = clamp_sum(base, deltas[d], cmin, cmax);
                                Outcome::Applied(created)
                            };
                            prop_assert_eq!(l.update(b as u32, s, &add, fresh, &mut memo), want);
                        }
                        l.put_memo(&add, memo);
                    },
                    Op::Map(ml) => {
                        let f = |v: f32| if ml { if v >= 0.0 { cmax } else { cmin } } else { v * 0.5 };
                        l.map_values(f);
                        for blk in &mut m.blocks {
                            for v in blk.iter_mut().filter(|v| present(**v)) {
                                *v = f(*v);
                            }
                        }
                    }
                    Op::Compact(keep) => {
                        // keep some live blocks, in a shuffled order
                        let mut order: Vec<u32> = Vec::new();
                        for i in keep {
                            if let Some(b) = pick(i) {
                                if !order.contains(&(b as u32)) {
                                    order.push(b as u32);
                                }
                            }
                        }
                        l = l.compacted(&order, limit);
                        m.blocks = order.iter().map(|&b| m.blocks[b as usize]).collect();
                        m.live = vec![true; order.len()];
                        let distinct: std::collections::BTreeSet<u32> = m.blocks.iter().flatten()
                            .filter(|v| present(**v)).map(|v| v.to_bits()).chain([0]).collect();
                        // narrow again exactly when the values in use fit
                        prop_assert_eq!(l.is_wide(), distinct.len() > limit);
                    }
                }
                check(&l, &m)?;
            }
        }
    }

    /// Tree operations for the whole-tree test.
    #[derive(Debug, Clone)]
    enum TreeOp {
        Update(Key, bool),
        Batch(Vec<Key>, bool),
        Set(Key, usize),
        Delete(Key, u8),
        Prune,
        Expand,
        MaxLikelihood,
        Shrink,
    }

    fn key() -> impl Strategy<Value = Key> {
        (0u16..6, 0u16..6, 0u16..6).prop_map(|(x, y, z)| Key::new(32764 + x, 32764 + y, 32764 + z))
    }

    fn tree_op() -> impl Strategy<Value = TreeOp> {
        prop_oneof![
            8 => (key(), any::<bool>()).prop_map(|(k, h)| TreeOp::Update(k, h)),
            4 => (prop::collection::vec(key(), 0..30), any::<bool>()).prop_map(|(k, h)| TreeOp::Batch(k, h)),
            4 => (key(), 0usize..VALS.len()).prop_map(|(k, v)| TreeOp::Set(k, v)),
            1 => (key(), 13u8..=16).prop_map(|(k, d)| TreeOp::Delete(k, d)),
            1 => Just(TreeOp::Prune),
            1 => Just(TreeOp::Expand),
            1 => Just(TreeOp::MaxLikelihood),
            1 => Just(TreeOp::Shrink),
        ]
    }

    /// What a voxel reads in the flat model: unknown voxels start at 0, updates at the clamp
    /// they push towards are ignored, otherwise add then clamp; set clamps.
    fn model_update(model: &mut HashMap<Key, f32>, t: &OcTree, k: Key, hit: bool) {
        let p = t.params();
        let d = if hit { p.hit } else { p.miss };
        let v = model.entry(k).or_insert(0.0);
        if !((d >= 0.0 && *v >= p.clamp_max) || (d <= 0.0 && *v <= p.clamp_min)) {
            *v = clamp_sum(*v, d, p.clamp_min, p.clamp_max);
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

        /// A tree whose palette holds only `limit` values (so it switches to wide storage
        /// and, on `shrink_to_fit`, back) writes the same `.ot` and `.bt` bytes after every
        /// operation as a tree with the real limit, both stay well formed, and every voxel
        /// reads what a flat per-voxel map says.
        #[test]
        fn small_palette_tree_equals_normal_tree(limit in 1usize..6, ops in prop::collection::vec(tree_op(), 1..40)) {
            let mut small = OcTree::new(0.1).unwrap();
            small.store.set_leaf_limit(limit);
            let mut normal = OcTree::new(0.1).unwrap();
            let mut model: HashMap<Key, f32> = HashMap::new();
            let mut model_valid = true;
            let mut lazy_ok = false;
            for op in ops {
                // expanding a shallow leaf (a root left childless by deletes) would build
                // 8^16 voxels
                if matches!(op, TreeOp::Expand) && normal.leaves().any(|l| l.depth < 13) {
                    continue;
                }
                for t in [&mut small, &mut normal] {
                    match &op {
                        TreeOp::Update(k, h) => {
                            t.update_node(*k, if *h { Update::Hit } else { Update::Miss }, false);
                        }
                        TreeOp::Batch(ks, h) => t.update_keys(ks, if *h { Update::Hit } else { Update::Miss }, false),
                        TreeOp::Set(k, v) => {
                            t.set_node_value(*k, VALS[*v], false).unwrap();
                        }
                        TreeOp::Delete(k, d) => {
                            t.delete_node(*k, *d);
                        }
                        TreeOp::Prune => t.prune(),
                        TreeOp::Expand => t.expand(),
                        TreeOp::MaxLikelihood => t.to_max_likelihood(),
                        TreeOp::Shrink => t.shrink_to_fit(),
                    }
                }
                match &op {
                    TreeOp::Update(k, h) => model_update(&mut model, &normal, *k, *h),
                    TreeOp::Batch(ks, h) => ks.iter().for_each(|k| model_update(&mut model, &normal, *k, *h)),
                    TreeOp::Set(k, v) => {
                        let p = normal.params();
                        model.insert(*k, VALS[*v].max(p.clamp_min).min(p.clamp_max));
                    }
                    TreeOp::Delete(..) | TreeOp::MaxLikelihood => model_valid = false,
                    _ => {}
                }
                // prune may stop early, expand leaves equal siblings, delete refreshes only the
                // parent (as OctoMap's deleteNodeRecurs): shapes only the lazy check accepts
                lazy_ok |= matches!(
                    op,
                    TreeOp::Prune | TreeOp::Expand | TreeOp::MaxLikelihood | TreeOp::Delete(..)
                );
                if let Err(e) = check_well_formed(&small, lazy_ok) {
                    return Err(TestCaseError::fail(e));
                }
                let (mut a, mut b) = (Vec::new(), Vec::new());
                write_ot(&small, &mut a).unwrap();
                write_ot(&normal, &mut b).unwrap();
                prop_assert!(a == b, ".ot bytes differ after {:?}", op);
                prop_assert_eq!(small.size(), normal.size());
                prop_assert_eq!(read_ot(&a[..]).map(|t| t.size()).ok(), Some(small.size()));
            }
            if model_valid {
                for (k, v) in &model {
                    let n = small.search(*k, 16).expect("updated voxel is known");
                    prop_assert_eq!(n.value.to_bits(), v.to_bits(), "voxel {:?}", k);
                }
            }
            let (mut a, mut b) = (Vec::new(), Vec::new());
            write_bt(&mut small, &mut a).unwrap();
            write_bt(&mut normal, &mut b).unwrap();
            prop_assert!(a == b);
        }
    }

    /// Past the real palette limit: 70 000 distinct voxel values force the wide fallback;
    /// every value reads back, updates keep working, `.ot` round-trips, and after
    /// `to_max_likelihood` compaction returns to narrow storage and less memory.
    #[test]
    fn more_values_than_the_palette_holds() {
        let mut t = OcTree::new(0.1).unwrap();
        let n = 70_000u32;
        let key = |i: u32| {
            Key::new(
                30000 + (i % 64) as u16,
                30000 + (i / 64 % 64) as u16,
                30000 + (i / 4096) as u16,
            )
        };
        let val = |i: u32| -1.5 + i as f32 * 4e-5;
        for i in 0..n {
            t.set_node_value(key(i), val(i), false).unwrap();
            if i as usize == PALETTE_LIMIT - 2 {
                assert!(!t.store.leaf.is_wide());
            }
        }
        assert!(t.store.leaf.is_wide());
        for i in (0..n).step_by(97) {
            assert_eq!(
                t.search(key(i), 16).unwrap().value.to_bits(),
                val(i).to_bits()
            );
        }
        let keys: Vec<Key> = (0..n).step_by(3).map(key).collect();
        t.update_keys(&keys, Update::Hit, false);
        for i in (0..n).step_by(3) {
            let want = clamp_sum(
                val(i),
                t.params().hit,
                t.params().clamp_min,
                t.params().clamp_max,
            );
            assert_eq!(
                t.search(key(i), 16).unwrap().value.to_bits(),
                want.to_bits()
            );
        }
        crate::validate::assert_well_formed(&t, false);
        let mut ot = Vec::new();
        write_ot(&t, &mut ot).unwrap();
        let mut back = read_ot(&ot[..]).unwrap();
        assert!(back.store.leaf.is_wide());
        let mut ot2 = Vec::new();
        write_ot(&back, &mut ot2).unwrap();
        assert_eq!(ot, ot2);
        // still too many values: compaction keeps it wide
        back.shrink_to_fit();
        assert!(back.store.leaf.is_wide());
        t.shrink_to_fit();
        let wide_bytes = t.memory_usage();
        t.to_max_likelihood();
        t.shrink_to_fit();
        assert!(!t.store.leaf.is_wide());
        assert!(t.store.leaf.palette_len() <= 3);
        assert!(t.memory_usage() < wide_bytes);
        crate::validate::assert_well_formed(&t, true);
    }
}
