//! Batched updates: many voxels in one walk, same result as one `update_node` call per voxel.
//!
//! The walk takes voxels a brick at a time: the (up to) 64 voxels of one depth-14 node, given
//! as a 64-bit mask in Morton order. Consecutive bricks share their path from the root down to
//! their deepest common ancestor, so the walk only re-descends below it; inside a brick each
//! depth-15 node with voxels to update is reached once, its voxels updated together, and then
//! it is pruned or refreshed once. Ancestors are pruned or refreshed (max of children) once,
//! when the walk leaves them, instead of after every voxel.
//!
//! That is equivalent to OctoMap's per-voxel ascent: pruning never changes a voxel's value, a
//! pruned node that is expanded again gets back the same eight equal leaves, every ancestor is
//! still processed after the last update below it, and a voxel's early exit (it already sits
//! at the clamp the update pushes towards) reads the same value whether or not an ancestor
//! has been pruned meanwhile. Bricks sorted by Morton code give the shortest walks; any order
//! gives the same tree.

use crate::key::{Key, TREE_DEPTH};
use crate::node_id::{node_id, NodeId};
use crate::store::{present, Adder, NodeRef, Outcome, NO_BLOCK};
use crate::tree::{InnerNodes, OcTree, Update};

/// What a tree with a payload per node (the stamped tree's time stamps) is told during a
/// batched walk, so that its side table follows every structural change OctoMap's per-voxel
/// `updateNodeRecurs` would make: the same events, once per node instead of once per voxel.
///
/// The plain tree walks with [`NoHooks`], for which the walk keeps its memoized group updates
/// (they hide which voxel took its update and which depth-15 node they pruned).
pub(crate) trait WalkHooks {
    /// `true` only for [`NoHooks`]: the walk may update whole voxel groups at once and prune
    /// without asking.
    const PLAIN: bool;

    /// The childless node `id` was just given eight children, copies of itself (`expandNode`
    /// and `copyData`).
    fn expanded(&mut self, id: NodeId);

    /// Voxel `id` took its update (not OctoMap's early exit).
    fn applied(&mut self, id: NodeId);

    /// The voxels below the depth-15 node `parent` selected by `which` (bit `i`: child `i`)
    /// took their update: [`WalkHooks::applied`] on each, in child order, unless a side table
    /// can do them at once.
    #[inline(always)]
    fn applied_group(&mut self, parent: NodeId, which: u8) {
        for i in (0..8).filter(|i| which >> i & 1 == 1) {
            self.applied(crate::node_id::child_id(parent, i));
        }
    }

    /// Whether node `id`, whose eight children are leaves of equal occupancy, may be collapsed
    /// (OctoMap's node comparison also looks at the payload).
    fn may_prune(&mut self, id: NodeId) -> bool;

    /// The eight children of node `id` were just collapsed into it.
    fn collapsed(&mut self, id: NodeId);

    /// Node `id` kept its children and was set to their max (`updateOccupancyChildren`).
    fn refreshed(&mut self, id: NodeId);

    /// The walk will reach brick `code` (its depth-14 node's Morton code) a few bricks from
    /// now: a side table may start loading what it will need there.
    #[inline(always)]
    fn ahead(&mut self, _code: u64) {}
}

/// The plain tree's hooks: nothing to tell.
pub(crate) struct NoHooks;

impl WalkHooks for NoHooks {
    const PLAIN: bool = true;

    #[inline(always)]
    fn expanded(&mut self, _: NodeId) {}

    #[inline(always)]
    fn applied(&mut self, _: NodeId) {}

    #[inline(always)]
    fn may_prune(&mut self, _: NodeId) -> bool {
        true
    }

    #[inline(always)]
    fn collapsed(&mut self, _: NodeId) {}

    #[inline(always)]
    fn refreshed(&mut self, _: NodeId) {}
}

/// The id of the node at `depth` on the way to the voxel of Morton code `voxel`.
#[inline(always)]
fn id_at(voxel: u64, depth: usize) -> NodeId {
    node_id(Key::from_morton(voxel), depth as u8)
}

/// Depth of the nodes a brick covers: 4x4x4 voxels below each.
const BRICK_DEPTH: usize = TREE_DEPTH as usize - 2;
/// How many bricks ahead of the walk a side table hears of them ([`WalkHooks::ahead`]).
const LOOK_AHEAD: usize = 16;
/// The bits of a brick code: three per level from the root to [`BRICK_DEPTH`].
const BRICK_CODE_MASK: u64 = (1 << (3 * BRICK_DEPTH)) - 1;

/// The brick of `key` (the Morton code of its depth-14 node, `key.morton() >> 6`) and the
/// voxel's bit in the brick's mask.
#[inline]
pub(crate) fn brick_of(key: Key) -> (u64, u64) {
    let code = Key::new(key.x() >> 2, key.y() >> 2, key.z() >> 2).morton();
    (code, 1 << brick_bit(key))
}

/// Index of `key`'s bit in its brick's mask: its Morton offset inside the 4x4x4 brick.
#[inline]
fn brick_bit(key: Key) -> u32 {
    let spread = |v: u16| u32::from(v & 1) | (u32::from(v & 2) << 2);
    spread(key.x()) | (spread(key.y()) << 1) | (spread(key.z()) << 2)
}

impl OcTree {
    /// Apply `update` to every key in `keys`, in order; the tree ends exactly as after calling
    /// [`OcTree::update_node`] for each key in turn (same values, same structure, same size).
    ///
    /// Much faster than single updates when keys are sorted by [`Key::morton`]. A NaN delta
    /// changes nothing.
    pub fn update_keys(&mut self, keys: &[Key], update: Update, inner: InnerNodes) {
        self.update_brick_iter(key_bricks(keys.iter().copied()), update, inner, NoHooks)
    }

    /// Apply `update` to the voxels of bricks of 4x4x4 voxels: each [`Brick`](crate::Brick)
    /// is a brick's code (the Morton code of its depth-14 node, i.e. `key.morton() >> 6` of any
    /// voxel in it; bits above the 42nd are ignored) and a mask whose bit `i` selects the voxel
    /// at Morton offset `i` inside the brick (`key.morton() & 63`). The tree ends exactly as
    /// after [`OcTree::update_node`] on every selected voxel, brick by brick, in mask-bit order.
    ///
    /// This is the fastest way to apply a scan's key sets: bricks sorted by code visit the
    /// tree in one depth-first sweep, and each depth-15 node is reached once per brick. A NaN
    /// delta changes nothing.
    pub fn update_bricks(&mut self, bricks: &[crate::Brick], update: Update, inner: InnerNodes) {
        self.update_brick_iter(
            bricks.iter().map(|b| (b.code, b.voxels)),
            update,
            inner,
            NoHooks,
        )
    }

    /// [`OcTree::update_bricks`] over any sequence of bricks (code and mask), telling `hooks`
    /// what changes (the batch insertion of the trees with a payload per node).
    pub(crate) fn update_brick_iter<H: WalkHooks>(
        &mut self,
        bricks: impl Iterator<Item = (u64, u64)>,
        update: Update,
        inner: InnerNodes,
        hooks: H,
    ) {
        let delta = self.delta(update);
        if delta.is_nan() {
            return;
        }
        let (cmin, cmax) = (self.params().clamp_min, self.params().clamp_max);
        let add = self.store.adder(delta, cmin, cmax);
        let memo = self.store.take_memo(&add);
        let mut walk = Walk {
            add,
            memo,
            path: [NodeRef::ROOT; BRICK_DEPTH + 1],
            valid: 0,
            dirty: 0,
            prev: 0,
            lazy: inner.is_deferred(),
            hooks,
        };
        // change detection costs a value read before and after each update: compiled in
        // only when it is on
        let track = self.is_change_detection_enabled();
        if !H::PLAIN {
            // the hooks hear of each brick LOOK_AHEAD bricks before the walk reaches it: a
            // ring of the bricks heard of and not yet walked, oldest at `at`
            let mut bricks = bricks;
            let mut ring = [(0u64, 0u64); LOOK_AHEAD];
            let mut held = 0;
            for b in bricks.by_ref().take(LOOK_AHEAD) {
                walk.hooks.ahead(b.0 & BRICK_CODE_MASK);
                ring[held] = b;
                held += 1;
            }
            let mut at = 0;
            while held > 0 {
                let (code, mask) = ring[at];
                match bricks.next() {
                    Some(b) => {
                        walk.hooks.ahead(b.0 & BRICK_CODE_MASK);
                        ring[at] = b;
                    }
                    None => held -= 1,
                }
                at = (at + 1) % LOOK_AHEAD;
                if track {
                    walk.brick::<true>(self, code & BRICK_CODE_MASK, mask);
                } else {
                    walk.brick::<false>(self, code & BRICK_CODE_MASK, mask);
                }
            }
        } else if track {
            for (code, mask) in bricks {
                walk.brick::<true>(self, code & BRICK_CODE_MASK, mask);
            }
        } else {
            for (code, mask) in bricks {
                walk.brick::<false>(self, code & BRICK_CODE_MASK, mask);
            }
        }
        walk.leave(self, 0);
        let Walk { add, memo, .. } = walk;
        self.store.put_memo(&add, memo);
    }

    /// Prune `n` or set it to the max of its children (the per-ancestor step of
    /// `updateNodeRecurs`). Leaves are left alone.
    #[inline]
    fn refresh(&mut self, n: NodeRef) {
        if self.store.prune_or_refresh(n) == Some(true) {
            self.sub_size(8);
        }
    }
}

/// `keys` as the bricks [`OcTree::update_keys`] walks: consecutive keys of one brick go down
/// together; a key already in the pending brick (a duplicate) starts a new one, so that it is
/// updated twice.
pub(crate) fn key_bricks(keys: impl IntoIterator<Item = Key>) -> impl Iterator<Item = (u64, u64)> {
    Coalesce::new(keys.into_iter().map(brick_of))
}

/// Sorted, distinct voxel Morton codes as the bricks [`OcTree::update_bricks`] walks.
pub(crate) fn morton_bricks(
    codes: impl IntoIterator<Item = u64>,
) -> impl Iterator<Item = (u64, u64)> {
    Coalesce::new(codes.into_iter().map(|c| (c >> 6, 1 << (c & 63))))
}

/// Groups a sequence of single-voxel bricks into runs: consecutive voxels of one brick become
/// one mask, and a voxel already in the pending mask closes it (so duplicates stay separate
/// updates, in order).
struct Coalesce<I> {
    inner: I,
    pending: Option<(u64, u64)>,
}

impl<I> Coalesce<I> {
    fn new(inner: I) -> Self {
        Coalesce {
            inner,
            pending: None,
        }
    }
}

impl<I: Iterator<Item = (u64, u64)>> Iterator for Coalesce<I> {
    type Item = (u64, u64);

    fn next(&mut self) -> Option<(u64, u64)> {
        for (code, bit) in self.inner.by_ref() {
            match &mut self.pending {
                Some((c, m)) if *c == code && *m & bit == 0 => *m |= bit,
                p => {
                    if let Some(done) = p.replace((code, bit)) {
                        return Some(done);
                    }
                }
            }
        }
        self.pending.take()
    }
}

/// The state of one batched walk: the path of the previous brick and what is known about it.
struct Walk<H> {
    add: Adder,
    /// `add`'s transition memo, held here so that the hot loop keeps it at hand.
    memo: Vec<u16>,
    /// The previous brick's path, depths 0 to [`BRICK_DEPTH`].
    path: [NodeRef; BRICK_DEPTH + 1],
    /// Leading path entries (depths `0..valid`) that exist and lie on the previous brick's
    /// path; the nodes below them have been processed.
    valid: usize,
    /// Leading path entries with an applied update below them since they were last
    /// refreshed; a voxel that takes OctoMap's early exit dirties nothing, as `updateNode`
    /// then refreshes no ancestor.
    dirty: usize,
    /// The previous brick's code.
    prev: u64,
    /// Ancestors are left stale ([`InnerNodes::Defer`]).
    lazy: bool,
    /// Told of every change a side table of payloads must follow.
    hooks: H,
}

impl<H: WalkHooks> Walk<H> {
    /// Prune node `n` (`id`) or set it to the max of its children, telling the hooks which;
    /// returns whether it pruned.
    #[inline(always)]
    fn refresh_hooked(&mut self, t: &mut OcTree, n: NodeRef, id: NodeId) -> bool {
        let hooks = &mut self.hooks;
        match t.store.prune_or_refresh_if(n, || hooks.may_prune(id)) {
            Some(true) => {
                t.sub_size(8);
                hooks.collapsed(id);
                true
            }
            Some(false) => {
                hooks.refreshed(id);
                false
            }
            None => false,
        }
    }

    /// Refresh the dirty path entries deeper than `keep` (bottom-up), as OctoMap does when
    /// its recursion returns through them; afterwards at most `keep` entries are dirty.
    #[inline]
    fn leave(&mut self, t: &mut OcTree, keep: usize) {
        if !self.lazy {
            for d in (keep..self.valid.min(self.dirty)).rev() {
                if H::PLAIN {
                    t.refresh(self.path[d]);
                } else {
                    self.refresh_hooked(t, self.path[d], id_at(self.prev << 6, d));
                }
            }
        }
        self.dirty = self.dirty.min(keep);
    }

    /// Update the voxels of `mask` in brick `code` (42 bits).
    #[inline(always)]
    fn brick<const TRACK: bool>(&mut self, t: &mut OcTree, code: u64, mask: u64) {
        if mask == 0 {
            return;
        }
        let common = if self.valid == 0 {
            0
        } else {
            common_depth(self.prev, code).min(self.valid - 1)
        };
        self.leave(t, common + 1);
        self.prev = code;
        let just_rooted = t.store.root_val.is_none();
        if just_rooted {
            t.store.root_val = Some(0.0);
            t.add_size(1);
        }
        // read-only descent to the deepest existing node (OctoMap's `search`); `kids` is
        // `cur`'s child block, read from the block that holds `cur`
        let path = &mut self.path;
        let mut d = if just_rooted { 0 } else { common };
        let mut cur = path[d];
        let mut kids = t.store.kids(cur);
        let mut missing_child = false;
        while d < BRICK_DEPTH && kids != NO_BLOCK {
            let pos = child_at(code, d);
            let blk = &t.store.inner.blocks[kids as usize];
            if !present(blk.vals[pos]) {
                missing_child = true;
                break;
            }
            cur = NodeRef {
                depth: d as u8 + 1,
                slot: pos as u8,
                block: kids,
            };
            kids = blk.kids[pos];
            d += 1;
            path[d] = cur;
        }
        // a childless node above the voxels: every voxel's search ends there, so all take
        // the same early exit or none does
        if !missing_child
            && !just_rooted
            && kids == NO_BLOCK
            && self.add.exits_at(t.store.value(cur))
        {
            self.valid = d + 1;
            return;
        }
        // create or expand the rest of the path; `fresh`: `cur` was just created (value 0,
        // no children), so everything below it is created rather than expanded
        let mut fresh = just_rooted;
        while d < BRICK_DEPTH {
            let pos = child_at(code, d);
            let created = if kids == NO_BLOCK && !fresh {
                kids = t.store.expand_node(cur);
                t.add_size(8);
                self.hooks.expanded(id_at(code << 6, d));
                false
            } else {
                if kids == NO_BLOCK {
                    kids = t.store.alloc_inner_kids(cur);
                }
                let blk = &mut t.store.inner.blocks[kids as usize];
                debug_assert!(!present(blk.vals[pos]) && blk.kids[pos] == NO_BLOCK);
                blk.vals[pos] = 0.0;
                t.add_size(1);
                true
            };
            cur = NodeRef {
                depth: d as u8 + 1,
                slot: pos as u8,
                block: kids,
            };
            // a created or expanded child has no children
            kids = NO_BLOCK;
            d += 1;
            path[d] = cur;
            fresh = created;
        }
        self.valid = BRICK_DEPTH + 1;
        // the brick's node: its child block holds the depth-15 nodes
        let mut kb = kids;
        if kb == NO_BLOCK {
            kb = if fresh {
                t.store.alloc_inner_kids(cur)
            } else {
                // a childless existing node that passed the early-exit test above
                t.add_size(8);
                let kb = t.store.expand_node(cur);
                self.hooks.expanded(id_at(code << 6, BRICK_DEPTH));
                kb
            };
        }
        let mut applied = false;
        let mut rest = mask;
        while rest != 0 {
            if !TRACK && H::PLAIN {
                // the groups that need no more than memoized transitions, at once
                let store = &mut t.store;
                let g = store.voxels.update_groups(
                    &mut store.inner.blocks[kb as usize],
                    rest,
                    &self.memo,
                    &self.add,
                    self.lazy,
                );
                t.add_size(g.added);
                t.sub_size(g.removed);
                applied |= g.applied;
                rest = g.rest;
                if rest == 0 {
                    break;
                }
            }
            // the next group voxel by voxel
            let j = rest.trailing_zeros() as usize / 8;
            let byte = (rest >> (8 * j)) as u8;
            rest &= !(0xff << (8 * j));
            applied |= self.voxel_group::<TRACK>(t, code, kb, j, byte);
        }
        if applied {
            if !self.lazy {
                if !H::PLAIN {
                    self.refresh_hooked(t, cur, id_at(code << 6, BRICK_DEPTH));
                } else if t.store.refresh_branch(cur, kb) {
                    t.sub_size(8);
                }
            }
            // the brick's node is refreshed; its ancestors wait until the walk leaves them
            self.dirty = BRICK_DEPTH;
        }
    }

    /// Update the voxels `byte` (bit = slot) below the depth-15 node in slot `j` of block
    /// `kb`, creating or expanding that node as needed, then prune or refresh it; returns
    /// whether any update was applied.
    #[inline(always)]
    fn voxel_group<const TRACK: bool>(
        &mut self,
        t: &mut OcTree,
        code: u64,
        kb: u32,
        j: usize,
        byte: u8,
    ) -> bool {
        let node = NodeRef {
            depth: TREE_DEPTH - 1,
            slot: j as u8,
            block: kb,
        };
        let blk = &mut t.store.inner.blocks[kb as usize];
        let v = blk.vals[j];
        let mut lb = blk.kids[j];
        if !present(v) {
            // a new node: every voxel below it is new (an empty block holds absent slots,
            // which an update treats as new voxels)
            blk.vals[j] = 0.0;
            t.add_size(1);
            lb = t.store.alloc_voxel_kids(kb, j);
        } else if lb == NO_BLOCK {
            // a pruned node: its voxels' searches end here
            if self.add.exits_at(v) {
                return false;
            }
            t.add_size(8);
            lb = t.store.expand_node(node);
            self.hooks.expanded(id_at(
                (code << 6) | ((j as u64) << 3),
                TREE_DEPTH as usize - 1,
            ));
        }
        if !TRACK && H::PLAIN {
            // the whole group at once when its transitions are memoized
            if let Some(g) = t.store.voxels.update_group(lb, byte, &self.memo) {
                t.add_size(g.created);
                if g.applied && !self.lazy && t.store.set_voxel_parent(kb, j, lb, g.uniform, g.max)
                {
                    t.sub_size(8);
                }
                return g.applied;
            }
        }
        let mut took = 0u8;
        let mut bits = byte;
        while bits != 0 {
            let s = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            let old = if TRACK {
                t.store.voxels.get(lb, s)
            } else {
                0.0
            };
            let Outcome::Applied(created) =
                t.store
                    .voxels
                    .update(lb, s, &self.add, false, &mut self.memo)
            else {
                // OctoMap's early exit at a voxel already at the clamp
                continue;
            };
            t.add_size(usize::from(created));
            took |= 1 << s;
            if TRACK {
                let key = Key::from_morton((code << 6) | ((j as u64) << 3) | s as u64);
                let v = t.store.voxels.get(lb, s);
                t.record_change(key, old, v, created);
            }
        }
        if took == 0 {
            return false;
        }
        if !H::PLAIN {
            // the voxels that took their update, told together (one slab look-up)
            let id = id_at((code << 6) | ((j as u64) << 3), TREE_DEPTH as usize - 1);
            self.hooks.applied_group(id, took);
            if !self.lazy {
                self.refresh_hooked(t, node, id);
            }
        } else if !self.lazy && t.store.refresh_voxel_parent(kb, j, lb) {
            t.sub_size(8);
        }
        true
    }
}

/// The child slot, at depth `d + 1`, on the way from depth `d` to brick `code`.
#[inline(always)]
fn child_at(code: u64, d: usize) -> usize {
    ((code >> (3 * (BRICK_DEPTH - 1 - d))) & 7) as usize
}

/// Depth of the deepest node containing both bricks (14 when equal, 0 when only the root
/// does).
#[inline]
fn common_depth(a: u64, b: u64) -> usize {
    let diff = a ^ b;
    if diff == 0 {
        return BRICK_DEPTH;
    }
    // the highest differing bit's level, counted from the brick's parent upwards
    let level = (63 - diff.leading_zeros() as usize) / 3;
    BRICK_DEPTH - 1 - level
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn brick_of_matches_the_morton_code() {
        for k in [
            Key::new(0, 0, 0),
            Key::new(1, 2, 3),
            Key::new(32767, 32768, 65535),
            Key::new(65535, 65535, 65535),
            Key::new(4, 9, 14),
        ] {
            let (code, bit) = brick_of(k);
            assert_eq!(code, k.morton() >> 6);
            assert_eq!(bit, 1 << (k.morton() & 63));
        }
    }

    #[test]
    fn common_depth_of_bricks() {
        let code = |x, y, z| Key::new(x, y, z).morton();
        assert_eq!(common_depth(code(5, 5, 5), code(5, 5, 5)), 14);
        assert_eq!(common_depth(code(4, 5, 5), code(5, 5, 5)), 13);
        assert_eq!(common_depth(code(3, 5, 5), code(4, 5, 5)), 11);
        assert_eq!(common_depth(code(0, 0, 0), code(0, 0, 1 << 13)), 0);
        // the child slots on the way to a brick spell its code
        let c = code(0x1234, 0x0fed, 0x2bcd);
        let rebuilt = (0..14).fold(0, |acc, d| (acc << 3) | child_at(c, d) as u64);
        assert_eq!(rebuilt, c);
    }
}
