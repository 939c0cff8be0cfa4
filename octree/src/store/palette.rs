//! The per-tree palette of depth-16 values, and the voxel updates that go through it.
//!
//! Real maps hold few distinct voxel log-odds (sums of the hit and miss deltas, clamped), so
//! the narrow voxel blocks (see [`super::voxel_blocks`]) store `u16` indices into a palette
//! that interns each distinct bit pattern once: equal indices mean equal bits, so `+0.0` and
//! `-0.0` get different indices, as they must to keep `.ot` bytes. Index 0 is an absent child
//! (its palette entry is the absent NaN), index 1 is `0.0`.
//!
//! Voxel updates go through a memo of transitions, index -> index, for the (delta, clamps) of
//! the batch ([`Adder`]), so the common update is two table look-ups: no arithmetic, no
//! hashing.

use super::slot::ABSENT;

/// Index of an absent slot in a narrow block (palette entry: [`ABSENT`]).
pub(super) const ABSENT_IDX: u16 = 0;
/// Index of `+0.0`, the value of a new voxel.
pub(super) const ZERO_IDX: u16 = 1;
/// A memo entry: not computed yet.
pub(super) const UNKNOWN: u16 = 0;
/// A memo entry: OctoMap's early exit (the voxel is at the clamp the update pushes towards).
pub(super) const EXIT: u16 = u16::MAX;
/// The most distinct values a palette holds (so indices stay below [`EXIT`]).
pub(crate) const PALETTE_LIMIT: usize = 0xfff0;
/// An empty slot of the palette's hash table.
const EMPTY_SLOT: u16 = 0;

/// A block's eight indices as two words of four 16-bit lanes, slot `k` in lane `k % 4` of
/// word `k / 4`.
#[inline(always)]
pub(super) fn index_words(idx: &[u16; 8]) -> [u64; 2] {
    let word = |k: usize| {
        u64::from(idx[4 * k])
            | (u64::from(idx[4 * k + 1]) << 16)
            | (u64::from(idx[4 * k + 2]) << 32)
            | (u64::from(idx[4 * k + 3]) << 48)
    };
    [word(0), word(1)]
}

/// The indices of [`index_words`]'s words.
#[inline(always)]
pub(super) fn words_index(w: [u64; 2]) -> [u16; 8] {
    std::array::from_fn(|k| (w[k / 4] >> (16 * (k % 4))) as u16)
}

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
/// transition table for these three numbers (from [`Palette::adder`]). Valid within the call
/// that made it: no other adder is made and the palette is not rebuilt meanwhile.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Adder {
    pub delta: f32,
    pub cmin: f32,
    pub cmax: f32,
    memo: usize,
}

impl Adder {
    /// An update that names no memo (for wide storage, which keeps none).
    pub(super) fn new(delta: f32, cmin: f32, cmax: f32) -> Adder {
        Adder {
            delta,
            cmin,
            cmax,
            memo: 0,
        }
    }

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

    /// The value after the update: `v + delta` clamped.
    #[inline(always)]
    pub(super) fn apply(&self, v: f32) -> f32 {
        clamp_sum(v, self.delta, self.cmin, self.cmax)
    }
}

/// Transitions index -> index of one (delta, cmin, cmax): `next[0]` for a new voxel (value
/// 0, no early exit), `next[i]` for an existing voxel of value `vals[i]` ([`EXIT`] for the
/// early exit); [`UNKNOWN`] where not computed yet.
#[derive(Clone, Default)]
struct Memo {
    key: Option<[u32; 3]>,
    next: Vec<u16>,
}

/// The distinct voxel values of a tree, each once, with a hash index and the update memos.
#[derive(Clone)]
pub(crate) struct Palette {
    /// Index -> value; index 0 is the absent NaN, index 1 is `0.0`. Padded with the absent NaN
    /// past the `count` values to a power-of-two length, so that the bitwise OR of indices in
    /// use is an index too ([`Palette::max_of`]).
    pub(super) vals: Vec<f32>,
    /// The values in `vals`, the absent NaN included.
    count: usize,
    /// Open addressing over `vals[1..count]` by bit pattern: slots hold an index or
    /// [`EMPTY_SLOT`]; the length is a power of two at least twice `count`.
    table: Vec<u16>,
    /// Whether some value is `-0.0` (which equals `+0.0` under `==` with another index).
    pub(super) neg_zero: bool,
    /// Two transition memos (a scan updates with a miss delta and a hit delta).
    memos: [Memo; 2],
    /// The memo replaced last.
    last_memo: usize,
    /// The most values allowed ([`PALETTE_LIMIT`], less only in tests).
    pub(super) limit: usize,
}

impl Palette {
    /// A palette holding only the absent NaN and `0.0`, taking at most `limit` values.
    pub(super) fn new(limit: usize) -> Self {
        let mut p = Palette {
            vals: vec![ABSENT; 2],
            count: 1,
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
    pub(super) fn len(&self) -> usize {
        self.count - 1
    }

    /// Index -> value for the indices in use (index 0, the absent NaN, included).
    pub(super) fn values(&self) -> &[f32] {
        &self.vals[..self.count]
    }

    /// For a block of eight indices: `(true, v)` when all eight are the same present index,
    /// of value `v`; else `(false, m)` with `m` the largest present value (`-f32::MAX` when
    /// none), first in child order among equal values, as
    /// [`max_present`](super::slot::max_present) of their values. Equal indices are equal
    /// values only without `-0.0` in the palette ([`Palette::neg_zero`]), which the caller
    /// checks.
    ///
    /// The block is read as two `u64`s. Every index in use lies below `vals.len()`, a power of
    /// two, and so does their bitwise OR `o`; every index is `i & o`, so one bounds check (of
    /// `..=o`) serves all eight look-ups.
    #[inline(always)]
    pub(super) fn uniform_or_max(&self, idx: &[u16; 8]) -> (bool, f32) {
        let [lo, hi] = index_words(idx);
        self.uniform_or_max_words(lo, hi)
    }

    /// [`Palette::uniform_or_max`] of the block whose indices are the 16-bit lanes of `lo`
    /// (slots 0 to 3) and `hi` (slots 4 to 7), as [`index_words`] gives them.
    #[inline(always)]
    pub(super) fn uniform_or_max_words(&self, lo: u64, hi: u64) -> (bool, f32) {
        let o = lo | hi;
        let o = o | (o >> 32);
        let o = ((o | (o >> 16)) & 0xffff) as usize;
        let vals = &self.vals[..=o];
        if lo == hi && lo == lo.rotate_left(16) && lo & 0xffff != u64::from(ABSENT_IDX) {
            return (true, vals[lo as usize & o]);
        }
        let mut m = -f32::MAX;
        for w in [lo, hi] {
            for k in 0..4 {
                let v = vals[(w >> (16 * k)) as usize & o];
                if v > m {
                    m = v;
                }
            }
        }
        (false, m)
    }

    #[inline]
    fn slot_of(&self, bits: u32) -> usize {
        let shift = 32 - self.table.len().trailing_zeros();
        (bits.wrapping_mul(0x9e37_79b9) >> shift) as usize
    }

    /// The index of `v` (present, not NaN), added if new; `None` when the palette is full.
    pub(super) fn intern(&mut self, v: f32) -> Option<u16> {
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
        if self.count > self.limit {
            return None;
        }
        let i = self.count as u16;
        if self.count == self.vals.len() {
            self.vals.resize(2 * self.count, ABSENT);
        }
        self.vals[self.count] = v;
        self.count += 1;
        self.neg_zero |= bits == (-0.0f32).to_bits();
        if 2 * self.count > self.table.len() {
            self.rehash(2 * self.table.len());
        } else {
            self.table[s] = i;
        }
        Some(i)
    }

    fn rehash(&mut self, len: usize) {
        self.table = vec![EMPTY_SLOT; len];
        let mask = len - 1;
        for (i, v) in self.vals[..self.count].iter().enumerate().skip(1) {
            let mut s = self.slot_of(v.to_bits());
            while self.table[s] != EMPTY_SLOT {
                s = (s + 1) & mask;
            }
            self.table[s] = i as u16;
        }
    }

    /// An update by `delta` clamped to `[cmin, cmax]`, naming its transition memo (reused or
    /// replacing one of the two).
    pub(super) fn adder(&mut self, delta: f32, cmin: f32, cmax: f32) -> Adder {
        let mut a = Adder::new(delta, cmin, cmax);
        a.memo = self.memo_for(a.bits());
        a
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

    /// Take the transition memo of `add` out, for a batch of updates.
    pub(super) fn take_memo(&mut self, add: &Adder) -> Vec<u16> {
        std::mem::take(&mut self.memos[add.memo & 1].next)
    }

    /// Give back the memo taken by [`Palette::take_memo`] (dropped when the memo slot was
    /// given to another update meanwhile).
    pub(super) fn put_memo(&mut self, add: &Adder, next: Vec<u16>) {
        let memo = &mut self.memos[add.memo & 1];
        if memo.key == Some(add.bits()) {
            memo.next = next;
        }
    }

    /// Compute the memo entry for index `i` (see [`Memo`]) and store it in `next`, the
    /// memo of `add`; `None` when the result does not fit in the palette.
    #[cold]
    #[inline(never)]
    pub(super) fn step_slow(&mut self, i: u16, add: &Adder, next: &mut Vec<u16>) -> Option<u16> {
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
    pub(super) fn bytes(&self) -> usize {
        self.vals.capacity() * 4
            + self.table.capacity() * 2
            + self
                .memos
                .iter()
                .map(|m| m.next.capacity() * 2)
                .sum::<usize>()
    }
}
