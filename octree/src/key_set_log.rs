//! An insert-only `KeySet` whose iteration order is OctoMap's, for a scan's millions of
//! insertions: [`KeySetLog`].
//!
//! [`KeyTable`] models libstdc++'s hash table as it goes, a chain link per new key and a hash
//! lookup per insertion. An octomap_server colour scan inserts every step of every ray, about
//! ten million keys a depth image of which one in a hundred or two is new, so that lookup is
//! the scan's cost. But of an insert-only table's history the order depends only on
//!
//! - the distinct keys, in the order they were first inserted, and
//! - where the table grew: each growth takes the elements present then and re-chains them;
//!   whether it grows before an insertion depends on the count of elements and the size of
//!   the insertion (a range reserves room for all its keys, duplicates included).
//!
//! A [`KeySetLog`] keeps just that: membership in a plain set (a bit per voxel of a window
//! the caller expects the keys in, a hash set beyond it), the new keys in a list, and the
//! growth points, with libstdc++'s policy ([`Growth`]) applied as insertions come. The order
//! is rebuilt once, when asked for, by replaying that history into a [`KeyTable`]: the same
//! chains, built from the new keys alone.
//!
//! A ray's keys may also come as the bricks of 4x4x4 voxels its walk entered
//! ([`RangeInsert::bricks`]): the window keeps a brick's voxels in one word, so a brick is
//! tested and added at once, and only its new voxels are put in the walk's order (a walk moves
//! one axis by one at each step, so that order is the order of `Σ step[a]·key[a]`).
//!
//! The insertions of a scan can also be made in parts, on several threads: a [`KeySetPart`]
//! takes a stretch of them (its rays, in their order) with a membership of its own, and
//! [`KeySetLog::append`] adds the parts in their order. A key's first insertion in the whole
//! sequence is its first one in the earliest part that holds it, so the set's new keys, in
//! order, are each part's new keys in order that the set does not hold yet; and a range's
//! room depends only on its length and the keys held before it. So the appended set is the
//! one the insertions would have made one after another, whatever the split, and the serial
//! append only looks at each part's new keys, not at every key inserted.

use crate::brick::Brick;
use crate::key::Key;
use crate::key_hasher::KeyHashing;
use crate::key_table::{Growth, KeyTable};
use std::collections::HashSet;

/// At most this many voxels (bits) in a membership window: 8 MiB of bits.
pub const MAX_WINDOW_VOXELS: u64 = 1 << 26;

/// An insert-only `KeySet` (OctoMap's `KeySet` under GCC's libstdc++, as [`KeyTable`] models
/// it) that records its history instead of chaining keys as they come; [`KeySetLog::order`]
/// gives the keys in the order the `KeySet` would iterate them.
#[derive(Debug, Clone, Default)]
pub struct KeySetLog {
    seen: SeenKeys,
    /// Distinct keys in the order they were first inserted.
    keys: Vec<Key>,
    growth: Growth,
    /// Growths: the count of keys present and the new bucket count, in order.
    rehashes: Vec<(usize, u64)>,
}

impl KeySetLog {
    /// An empty set, as a default-constructed `KeySet` (11 buckets).
    pub fn new() -> Self {
        Self::default()
    }

    /// An empty set that expects its keys in the box from `lo` to `hi` (corners included): a
    /// bit per voxel there answers membership, when the box has at most
    /// [`MAX_WINDOW_VOXELS`] voxels. Keys outside it are kept too (in a hash set), so the box
    /// only decides the speed.
    pub fn with_window(lo: Key, hi: Key) -> Self {
        KeySetLog {
            seen: SeenKeys {
                window: Window::new(lo, hi),
                rest: HashSet::default(),
            },
            ..Self::default()
        }
    }

    /// Keys held.
    pub fn len(&self) -> usize {
        self.keys.len()
    }

    /// Whether the set is empty.
    pub fn is_empty(&self) -> bool {
        self.keys.is_empty()
    }

    /// The keys in the order they were first inserted (cheap, unlike [`KeySetLog::order`]).
    pub fn keys(&self) -> &[Key] {
        &self.keys
    }

    /// Whether `key` is in the set.
    pub fn contains(&self, key: &Key) -> bool {
        self.seen.contains(*key)
    }

    /// The buckets the `KeySet` would have now.
    pub fn bucket_count(&self) -> usize {
        self.growth.buckets() as usize
    }

    /// `KeySet::insert(key)`; false when it was there.
    #[inline]
    pub fn insert(&mut self, key: Key) -> bool {
        if !self.seen.insert(key) {
            return false;
        }
        // a new key alone asks the policy (a present one returns before it)
        self.reserve(1);
        self.keys.push(key);
        true
    }

    /// `KeySet::insert(first, last)`: room for the whole range first (duplicates included),
    /// then key by key.
    pub fn insert_range(&mut self, keys: &[Key]) {
        let mut range = self.range();
        for &k in keys {
            range.key(k);
        }
        range.finish();
    }

    /// `KeySet::insert(first, last)` of a range whose keys come one at a time (a ray being
    /// walked), without holding them: [`RangeInsert::key`] for each, then
    /// [`RangeInsert::finish`] (the same as [`KeySetLog::insert_range`] over them) or
    /// [`RangeInsert::cancel`] (as if the range had never been started).
    pub fn range(&mut self) -> RangeInsert<'_> {
        RangeInsert {
            start: self.keys.len(),
            len: 0,
            log: self,
        }
    }

    /// The policy's answer before `n` more keys: a growth is recorded with the count it
    /// happens at.
    #[inline]
    fn reserve(&mut self, n: usize) {
        self.reserve_at(self.keys.len(), n);
    }

    /// The policy's answer before `n` more keys join `count`.
    #[inline]
    fn reserve_at(&mut self, count: usize, n: usize) {
        if let Some(b) = self.growth.need_rehash(count as u64, n as u64) {
            self.rehashes.push((count, b));
        }
    }

    /// The keys in the order OctoMap's `KeySet` iterates them after the same insertions.
    pub fn order(&self) -> Vec<Key> {
        let mut table = KeyTable::<()>::new();
        let mut growths = self.rehashes.iter().peekable();
        for (i, &k) in self.keys.iter().enumerate() {
            while let Some(&(_, b)) = growths.next_if(|g| g.0 == i) {
                table.rehash(b);
            }
            table.push_head(k, ());
        }
        for &(_, b) in growths {
            table.rehash(b);
        }
        table.iter().map(|(k, ())| k).collect()
    }
}

impl KeySetLog {
    /// Make the insertions `part` holds, in its order: the set ends as if they had been made
    /// on it one after another (see the module docs). Parts appended in the order of the
    /// stretches they hold give the set of the whole sequence.
    pub fn append(&mut self, part: &KeySetPart) {
        let mut keys = part.log.keys.iter().copied();
        for step in &part.steps {
            match *step {
                PartStep::One => {
                    if let Some(k) = keys.next() {
                        self.insert(k);
                    }
                }
                PartStep::Range { len, new } => {
                    let mut range = self.range();
                    keys.by_ref().take(new).for_each(|k| range.key(k));
                    // the part's other keys were in it before, so they are here now
                    range.len = len;
                    range.finish();
                }
            }
        }
    }
}

/// A stretch of insertions into a [`KeySetLog`] made apart from it (on another thread), to be
/// added to it by [`KeySetLog::append`] (see the module docs). It keeps the keys new to the
/// stretch in order and, for each insertion that matters to the set, its kind and length.
#[derive(Debug, Clone, Default)]
pub struct KeySetPart {
    /// The stretch's own membership and new keys (its growth history is not used).
    log: KeySetLog,
    /// The insertions, in order, each taking its new keys from the front of `log.keys`.
    steps: Vec<PartStep>,
}

/// One insertion of a [`KeySetPart`].
#[derive(Debug, Clone, Copy)]
enum PartStep {
    /// `insert(key)` of a key new to the part (a single key the part held already is held by
    /// the set too, by then, and changes nothing).
    One,
    /// `insert(first, last)` of `len` keys, duplicates included, `new` of them new to the part.
    Range { len: usize, new: usize },
}

impl KeySetPart {
    /// An empty part, membership by hashing alone.
    pub fn new() -> Self {
        Self::default()
    }

    /// An empty part whose keys are expected in the box from `lo` to `hi` (as
    /// [`KeySetLog::with_window`]: the box only decides the speed).
    pub fn with_window(lo: Key, hi: Key) -> Self {
        KeySetPart {
            log: KeySetLog::with_window(lo, hi),
            steps: Vec::new(),
        }
    }

    /// `KeySet::insert(key)` in the stretch; false when the stretch held it.
    pub fn insert(&mut self, key: Key) -> bool {
        let new = self.log.seen.insert(key);
        if new {
            self.log.keys.push(key);
            self.steps.push(PartStep::One);
        }
        new
    }

    /// `KeySet::insert(first, last)` of a range whose keys come one at a time, as
    /// [`KeySetLog::range`].
    pub fn range(&mut self) -> PartRange<'_> {
        PartRange {
            range: self.log.range(),
            steps: &mut self.steps,
        }
    }

    /// Keys new to the stretch.
    pub fn len(&self) -> usize {
        self.log.len()
    }

    /// Whether the stretch inserted no key that it keeps.
    pub fn is_empty(&self) -> bool {
        self.log.is_empty()
    }
}

/// A range being inserted into a [`KeySetPart`] ([`KeySetPart::range`]).
#[derive(Debug)]
pub struct PartRange<'a> {
    range: RangeInsert<'a>,
    steps: &'a mut Vec<PartStep>,
}

impl PartRange<'_> {
    /// The range's next key.
    #[inline]
    pub fn key(&mut self, key: Key) {
        self.range.key(key);
    }

    /// The range's next keys as a walk's bricks ([`RangeInsert::bricks`]).
    pub fn bricks(&mut self, bricks: &[Brick], step: [i32; 3]) {
        self.range.bricks(bricks, step);
    }

    /// End the range ([`RangeInsert::finish`]).
    pub fn finish(self) {
        let r = self.range;
        self.steps.push(PartStep::Range {
            len: r.len,
            new: r.log.keys.len() - r.start,
        });
    }

    /// Drop the range ([`RangeInsert::cancel`]): the part is as before it.
    pub fn cancel(self) {
        self.range.cancel();
    }
}

/// A range being inserted ([`KeySetLog::range`]). The policy's room for the range depends on
/// its length, known only at its end; it comes before the range's first key, and which keys
/// are new does not depend on it, so [`RangeInsert::finish`] asks the policy afterwards, in
/// the order `insert(first, last)` asks it: for the range, then for each new key.
#[derive(Debug)]
pub struct RangeInsert<'a> {
    log: &'a mut KeySetLog,
    /// Keys held before the range.
    start: usize,
    /// Keys given so far, duplicates included.
    len: usize,
}

impl RangeInsert<'_> {
    /// The range's next key.
    #[inline]
    pub fn key(&mut self, key: Key) {
        self.len += 1;
        if self.log.seen.insert(key) {
            self.log.keys.push(key);
        }
    }

    /// The range's next keys, given as the bricks a ray walk entered, in walk order: each
    /// [`Brick`]'s voxels (its code's bits above the 42nd ignored) are keys of the range, in
    /// the order of `Σ step[a]·key[a]` (the order of a walk that moves one axis at a time by
    /// `step[a]`, one of -1, 0 and 1), as [`RangeInsert::key`] for each would take them. Each
    /// key must be in one brick only (a walk enters a brick once).
    pub fn bricks(&mut self, bricks: &[Brick], step: [i32; 3]) {
        for b in bricks {
            self.len += b.voxels.count_ones() as usize;
            let code = b.code & BRICK_CODES;
            let new = self.log.seen.insert_brick(code, b.voxels);
            if new != 0 {
                push_in_walk_order(&mut self.log.keys, Key::from_morton(code << 6), new, step);
            }
        }
    }

    /// End the range: the set is as after `insert(first, last)` of its keys.
    pub fn finish(self) {
        let log = self.log;
        log.reserve_at(self.start, self.len);
        for count in self.start..log.keys.len() {
            log.reserve_at(count, 1);
        }
    }

    /// Drop the range: the set is as before it (a ray whose keys could not all be computed
    /// is not inserted at all).
    pub fn cancel(self) {
        let log = self.log;
        for k in log.keys.drain(self.start..) {
            log.seen.remove(k);
        }
    }
}

/// The bits of a brick's code (`Key::morton() >> 6` has 42).
const BRICK_CODES: u64 = (1 << 42) - 1;

/// Append the keys of `voxels` in the brick whose first voxel is `base` to `keys`, in the
/// order of `Σ step[a]·offset[a]` (distinct for the voxels one walk enters: each of its steps
/// adds one).
#[inline]
fn push_in_walk_order(keys: &mut Vec<Key>, base: Key, voxels: u64, step: [i32; 3]) {
    let from = keys.len();
    let mut rest = voxels;
    while rest != 0 {
        keys.push(brick_voxel(base, rest.trailing_zeros()));
        rest &= rest - 1;
    }
    let rank = |k: &Key| -> i32 { (0..3).map(|a| step[a] * i32::from(k[a] & 3)).sum() };
    keys[from..].sort_unstable_by_key(rank);
}

/// Membership: a bit per voxel of the window, a hash set for keys outside it.
#[derive(Debug, Clone, Default)]
struct SeenKeys {
    window: Option<Window>,
    rest: HashSet<Key, KeyHashing>,
}

impl SeenKeys {
    /// Add `key`; false when it was there.
    #[inline]
    fn insert(&mut self, key: Key) -> bool {
        if let Some(w) = &mut self.window {
            if let Some((word, mask)) = w.bit(key) {
                // stores only for new keys (rare): a store on every step would make the next
                // step's load of the same word wait for it
                let b = &mut w.bits[word];
                let new = *b & mask == 0;
                if new {
                    *b |= mask;
                }
                return new;
            }
        }
        self.rest.insert(key)
    }

    /// Add the voxels `voxels` of brick `code` (42 bits); returns those that were not there.
    #[inline]
    fn insert_brick(&mut self, code: u64, voxels: u64) -> u64 {
        if let Some(w) = &mut self.window {
            if let Some(word) = w.word_mut(code) {
                let b = &mut w.bits[word];
                let new = voxels & !*b;
                // stores only when something is new (rare), as `insert`
                if new != 0 {
                    *b |= new;
                }
                return new;
            }
        }
        let base = Key::from_morton(code << 6);
        let mut new = 0;
        let mut rest = voxels;
        while rest != 0 {
            let bit = rest.trailing_zeros();
            rest &= rest - 1;
            if self.rest.insert(brick_voxel(base, bit)) {
                new |= 1 << bit;
            }
        }
        new
    }

    fn remove(&mut self, key: Key) {
        if let Some(w) = &mut self.window {
            if let Some((word, mask)) = w.bit(key) {
                w.bits[word] &= !mask;
                return;
            }
        }
        self.rest.remove(&key);
    }

    fn contains(&self, key: Key) -> bool {
        match self
            .window
            .as_ref()
            .and_then(|w| w.bit(key).map(|b| (w, b)))
        {
            Some((w, (word, mask))) => w.bits[word] & mask != 0,
            None => self.rest.contains(&key),
        }
    }
}

/// A box of voxels with a bit each, in chunks of 8x8x8 of the tree's bricks of 4x4x4 voxels:
/// the box is widened to whole chunks (32 voxels a side, aligned to 32), a chunk is 512 words in
/// the Morton order of its bricks, a brick is one word whose bits are its voxels in Morton order
/// (as a [`Brick`]'s mask). So a brick's word is found from its code, the chunk's part of it
/// (above the low 9 bits) looked up once for the bricks of a ray that stay in one chunk, and a
/// ray's voxels in one brick are tested and added at once ([`SeenKeys::insert_brick`]).
/// Chunks are x fastest.
#[derive(Debug, Clone)]
struct Window {
    /// The box's first chunk, in chunks.
    lo: [u16; 3],
    /// Chunks along each axis.
    chunks: [u32; 3],
    bits: Vec<u64>,
    /// The chunk code looked up last and its first word (`u64::MAX` for none).
    last: (u64, usize),
}

/// Brick codes in a chunk: 8x8x8.
const CHUNK_BITS: u32 = 9;

impl Window {
    /// The chunks holding the box from `lo` to `hi` (corners included), or `None` when it is
    /// empty (a corner past the other) or they hold more than [`MAX_WINDOW_VOXELS`].
    fn new(lo: Key, hi: Key) -> Option<Window> {
        if (0..3).any(|i| hi[i] < lo[i]) {
            return None;
        }
        let lo: [u16; 3] = std::array::from_fn(|i| lo[i] >> 5);
        let chunks: [u32; 3] = std::array::from_fn(|i| u32::from((hi[i] >> 5) - lo[i]) + 1);
        let words = chunks.iter().map(|&d| u64::from(d)).product::<u64>() << CHUNK_BITS;
        (words * 64 <= MAX_WINDOW_VOXELS).then(|| Window {
            lo,
            chunks,
            bits: vec![0; words as usize],
            last: (u64::MAX, 0),
        })
    }

    /// The first word of the chunk of brick `code` (42 bits), or `None` outside the box.
    #[inline]
    fn chunk(&self, code: u64) -> Option<usize> {
        // the chunk's first voxel: its coordinates are multiples of 32
        let first = Key::from_morton((code >> CHUNK_BITS) << (CHUNK_BITS + 6));
        self.chunk_at(first.0.map(|c| c >> 5))
    }

    /// The first word of the chunk at `chunk` (in chunks), or `None` outside the box.
    #[inline]
    fn chunk_at(&self, chunk: [u16; 3]) -> Option<usize> {
        let c: [u32; 3] = std::array::from_fn(|i| u32::from(chunk[i].wrapping_sub(self.lo[i])));
        if c[0] >= self.chunks[0] || c[1] >= self.chunks[1] || c[2] >= self.chunks[2] {
            return None;
        }
        let i = (u64::from(c[2]) * u64::from(self.chunks[1]) + u64::from(c[1]))
            * u64::from(self.chunks[0])
            + u64::from(c[0]);
        Some((i as usize) << CHUNK_BITS)
    }

    /// The word of brick `code` (42 bits), or `None` outside the box; remembers its chunk.
    #[inline]
    fn word_mut(&mut self, code: u64) -> Option<usize> {
        let inside = (code & ((1 << CHUNK_BITS) - 1)) as usize;
        if code >> CHUNK_BITS == self.last.0 {
            return Some(self.last.1 | inside);
        }
        let first = self.chunk(code)?;
        self.last = (code >> CHUNK_BITS, first);
        Some(first | inside)
    }

    /// The word and bit of `key`, or `None` outside the box.
    #[inline]
    fn bit(&self, key: Key) -> Option<(usize, u64)> {
        // the chunk from the key itself, the brick and voxel from its Morton code
        let first = self.chunk_at(key.0.map(|c| c >> 5))?;
        let code = key.morton();
        Some((
            first | ((code >> 6) as usize & ((1 << CHUNK_BITS) - 1)),
            1 << (code & 63),
        ))
    }
}

/// The key of the voxel at Morton position `bit` (0 to 63) in the brick whose first voxel is
/// `base` (whose coordinates are multiples of 4).
#[inline]
fn brick_voxel(base: Key, bit: u32) -> Key {
    let o = |a: u32| (((bit >> a) & 1) | (((bit >> (a + 3)) & 1) << 1)) as u16;
    Key::new(base[0] | o(0), base[1] | o(1), base[2] | o(2))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// One insertion: a single key or a range (a ray's keys).
    #[derive(Debug, Clone)]
    enum Insert {
        One(Key),
        Range(Vec<Key>),
        /// A range given key by key, then cancelled.
        Cancelled(Vec<Key>),
    }

    fn key_in(span: u16) -> impl Strategy<Value = Key> {
        (0..span, 0..span, 0..span).prop_map(|(x, y, z)| Key::new(100 + x, 200 + y, 300 + z))
    }

    fn inserts(span: u16) -> impl Strategy<Value = Vec<Insert>> {
        prop::collection::vec(
            prop_oneof![
                key_in(span).prop_map(Insert::One),
                prop::collection::vec(key_in(span), 0..40).prop_map(Insert::Range),
                prop::collection::vec(key_in(span), 0..40).prop_map(Insert::Cancelled),
            ],
            0..120,
        )
    }

    proptest! {
        /// The log gives the keys, and the bucket count, of the table that models libstdc++
        /// insertion by insertion, with and without a window (one that holds some of the
        /// keys, all of them, or none); a cancelled range leaves no trace.
        #[test]
        fn order_is_the_modelled_tables(
            ins in inserts(12),
            window in prop_oneof![
                Just(None),
                (0u16..12, 0u16..12).prop_map(Some),
            ],
        ) {
            let mut model = KeyTable::<()>::new();
            let mut log = match window {
                None => KeySetLog::new(),
                Some((a, b)) => KeySetLog::with_window(
                    Key::new(100 + a, 200, 300 + a.min(b)),
                    Key::new(100 + b, 211, 300 + a.max(b)),
                ),
            };
            for i in &ins {
                match i {
                    Insert::One(k) => {
                        prop_assert_eq!(log.insert(*k), model.insert(*k, ()));
                    }
                    Insert::Range(ks) => {
                        model.insert_range(ks.iter().map(|&k| (k, ())));
                        log.insert_range(ks);
                    }
                    Insert::Cancelled(ks) => {
                        let mut r = log.range();
                        ks.iter().for_each(|&k| r.key(k));
                        r.cancel();
                    }
                }
                prop_assert_eq!(log.len(), model.len());
                prop_assert_eq!(log.bucket_count(), model.bucket_count());
            }
            let want: Vec<Key> = model.iter().map(|(k, ())| k).collect();
            prop_assert_eq!(log.order(), want);
            for x in 95..115 {
                let k = Key::new(x, 205, 305);
                prop_assert_eq!(log.contains(&k), model.contains(&k));
            }
        }
    }

    /// `ins`'s insertions made on `set` as they come.
    fn insert_all(set: &mut KeySetLog, ins: &[Insert]) {
        for i in ins {
            match i {
                Insert::One(k) => {
                    set.insert(*k);
                }
                Insert::Range(ks) => set.insert_range(ks),
                Insert::Cancelled(ks) => {
                    let mut r = set.range();
                    ks.iter().for_each(|&k| r.key(k));
                    r.cancel();
                }
            }
        }
    }

    proptest! {
        /// Insertions split into parts at any points, each part made apart (with or without a
        /// window) and the parts appended in order, give the set of the insertions made one
        /// after another: the same order, bucket count and membership.
        #[test]
        fn appended_parts_are_the_whole_sequence(
            ins in inserts(10),
            cuts in prop::collection::vec(0usize..=120, 0..6),
            windowed in prop::collection::vec(any::<bool>(), 7),
        ) {
            let mut whole = KeySetLog::new();
            insert_all(&mut whole, &ins);
            let mut cuts: Vec<usize> = cuts.into_iter().map(|c| c.min(ins.len())).collect();
            cuts.push(0);
            cuts.push(ins.len());
            cuts.sort_unstable();
            let mut appended = KeySetLog::with_window(Key::new(100, 200, 300), Key::new(104, 209, 309));
            for (p, w) in cuts.windows(2).zip(&windowed) {
                let mut part = if *w {
                    KeySetPart::with_window(Key::new(102, 200, 300), Key::new(109, 209, 309))
                } else {
                    KeySetPart::new()
                };
                for i in &ins[p[0]..p[1]] {
                    match i {
                        Insert::One(k) => {
                            part.insert(*k);
                        }
                        Insert::Range(ks) => {
                            let mut r = part.range();
                            ks.iter().for_each(|&k| r.key(k));
                            r.finish();
                        }
                        Insert::Cancelled(ks) => {
                            let mut r = part.range();
                            ks.iter().for_each(|&k| r.key(k));
                            r.cancel();
                        }
                    }
                }
                appended.append(&part);
            }
            prop_assert_eq!(appended.len(), whole.len());
            prop_assert_eq!(appended.bucket_count(), whole.bucket_count());
            prop_assert_eq!(appended.order(), whole.order());
            for x in 95..115 {
                let k = Key::new(x, 205, 305);
                prop_assert_eq!(appended.contains(&k), whole.contains(&k));
            }
        }
    }

    /// A walk's keys: from `start`, each step moves one axis (with a non-zero sign in `step`)
    /// by its sign, as a ray walk does.
    fn walk_keys(start: Key, step: [i32; 3], axes: &[usize]) -> Vec<Key> {
        let mut k = start;
        let mut keys = vec![k];
        for &a in axes {
            if step[a] == 0 {
                continue;
            }
            k.0[a] = k.0[a].wrapping_add_signed(step[a] as i16);
            keys.push(k);
        }
        keys
    }

    /// `keys` (a walk's, which enters each brick once) as its bricks in walk order.
    fn walk_bricks(keys: &[Key]) -> Vec<Brick> {
        let mut out: Vec<Brick> = Vec::new();
        for k in keys {
            let b = Brick::of_voxel(k.morton());
            match out.last_mut() {
                Some(last) if last.code == b.code => last.voxels |= b.voxels,
                _ => out.push(b),
            }
        }
        out
    }

    /// One walk: start (in a 40-voxel cube around the windows' boxes), signs, axes.
    fn walk_strategy() -> impl Strategy<Value = (Key, [i32; 3], Vec<usize>)> {
        (
            (0u16..40, 0u16..40, 0u16..40).prop_map(|(x, y, z)| Key::new(90 + x, 190 + y, 290 + z)),
            prop::array::uniform3(-1i32..=1),
            prop::collection::vec(0usize..3, 0..50),
        )
    }

    proptest! {
        /// Walks inserted as their bricks ([`RangeInsert::bricks`], [`PartRange::bricks`])
        /// give the set of the same walks inserted key by key: order, bucket count and
        /// membership, with keys inside and outside a window, between single keys, in a
        /// set and in parts appended to it.
        #[test]
        fn walks_as_bricks_are_walks_key_by_key(
            walks in prop::collection::vec((walk_strategy(), any::<bool>()), 0..30),
            window in prop_oneof![Just(None), (0u16..40, 0u16..40).prop_map(Some)],
        ) {
            let make = || match window {
                None => KeySetLog::new(),
                Some((a, b)) => KeySetLog::with_window(
                    Key::new(90 + a.min(b), 190, 290 + a),
                    Key::new(90 + a.max(b), 229, 290 + b.max(a)),
                ),
            };
            let (mut by_keys, mut by_bricks) = (make(), make());
            let mut part = match window {
                None => KeySetPart::new(),
                Some(_) => KeySetPart::with_window(Key::new(100, 200, 300), Key::new(120, 210, 330)),
            };
            for ((start, step, axes), single) in &walks {
                let keys = walk_keys(*start, *step, axes);
                let bricks = walk_bricks(&keys);
                by_keys.insert_range(&keys);
                let mut r = by_bricks.range();
                r.bricks(&bricks, *step);
                r.finish();
                let mut r = part.range();
                r.bricks(&bricks, *step);
                r.finish();
                if *single {
                    by_keys.insert(*start);
                    by_bricks.insert(*start);
                    part.insert(*start);
                }
            }
            let mut appended = make();
            appended.append(&part);
            for log in [&by_bricks, &appended] {
                prop_assert_eq!(log.len(), by_keys.len());
                prop_assert_eq!(log.bucket_count(), by_keys.bucket_count());
                prop_assert_eq!(log.order(), by_keys.order());
                for x in (85..135).step_by(3) {
                    for y in (185..235).step_by(7) {
                        let k = Key::new(x, y, 300 + x % 17);
                        prop_assert_eq!(log.contains(&k), by_keys.contains(&k));
                    }
                }
            }
        }
    }

    #[test]
    fn windows_past_the_limit_or_inside_out_are_not_made() {
        let lo = Key::new(0, 0, 0);
        assert!(Window::new(lo, Key::new(1023, 1023, 63)).is_some());
        assert!(Window::new(lo, Key::new(1023, 1023, 64)).is_none());
        assert!(Window::new(Key::new(5, 0, 0), Key::new(4, 9, 9)).is_none());
        // a whole-axis box (65,536 voxels) along one axis fits
        assert!(Window::new(lo, Key::new(65535, 0, 0)).is_some());
        // and a key outside any window is still a member once inserted
        let mut s = KeySetLog::with_window(Key::new(10, 10, 10), Key::new(11, 11, 11));
        assert!(s.insert(Key::new(65535, 0, 7)));
        assert!(!s.insert(Key::new(65535, 0, 7)));
        assert!(s.insert(Key::new(10, 11, 10)));
        assert!(s.contains(&Key::new(65535, 0, 7)) && s.contains(&Key::new(10, 11, 10)));
        assert!(!s.contains(&Key::new(11, 11, 10)));
        assert_eq!(s.len(), 2);
    }
}
