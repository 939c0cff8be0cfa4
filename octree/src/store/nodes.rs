//! The tree's nodes over the two kinds of block: [`NodeStore`] and its node handles.
//!
//! Children of one node live together in a block. Nodes at depths 1..=15 sit in 64-byte
//! [`InnerBlock`]s (eight `f32` log-odds plus eight child-block indices, one cache line); nodes
//! at depth 16 can have no children and sit in 16-byte blocks of palette indices (see
//! [`super::voxel_blocks`]). A missing child is marked by a reserved NaN bit pattern in its
//! value slot (see [`super::slot`]), a node without children by [`NO_BLOCK`]. On real maps this
//! costs 4-8 bytes per node, against OctoMap's ~27.

use super::arena::{Arena, NO_BLOCK};
use super::inner_block::{InnerBlock, EMPTY_INNER};
use super::memory::MemoryUsage;
use super::palette::{Adder, PALETTE_LIMIT};
use super::slot::{max_present, present, ABSENT};
use super::voxel_blocks::{Outcome, VoxelBlocks};

/// Both arenas and the root.
#[derive(Clone)]
pub(crate) struct NodeStore {
    /// The blocks of the nodes at depths 1..=15.
    pub inner: Arena<InnerBlock>,
    /// The blocks of the depth-16 nodes (voxels).
    pub voxels: VoxelBlocks,
    /// The most distinct voxel values narrow storage holds ([`PALETTE_LIMIT`] but in tests).
    palette_limit: usize,
    /// Root log-odds, or `None` for an empty tree.
    pub root_val: Option<f32>,
    /// The root's child block (in `inner`), or `NO_BLOCK`.
    pub root_kids: u32,
}

/// A node: the root (`depth == 0`), or slot `slot` of block `block` at `depth` 1..=16.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct NodeRef {
    pub depth: u8,
    pub slot: u8,
    pub block: u32,
}

impl NodeRef {
    pub const ROOT: NodeRef = NodeRef {
        depth: 0,
        slot: 0,
        block: NO_BLOCK,
    };
}

impl NodeStore {
    pub fn new() -> Self {
        NodeStore {
            inner: Arena::new(EMPTY_INNER),
            voxels: VoxelBlocks::new(PALETTE_LIMIT),
            palette_limit: PALETTE_LIMIT,
            root_val: None,
            root_kids: NO_BLOCK,
        }
    }

    /// A small palette limit, so that tests reach the wide fallback with few values.
    #[cfg(test)]
    pub fn set_palette_limit(&mut self, limit: usize) {
        self.palette_limit = limit;
        self.compact();
    }

    pub fn clear(&mut self) {
        self.inner.clear();
        self.voxels = VoxelBlocks::new(self.palette_limit);
        self.root_val = None;
        self.root_kids = NO_BLOCK;
    }

    /// Value of an existing node.
    #[inline(always)]
    pub fn value(&self, n: NodeRef) -> f32 {
        match n.depth {
            0 => self.root_val.unwrap_or(ABSENT),
            16 => self.voxels.get(n.block, n.slot as usize),
            _ => self.inner.blocks[n.block as usize].vals[n.slot as usize],
        }
    }

    #[inline]
    pub fn set_value(&mut self, n: NodeRef, v: f32) {
        match n.depth {
            0 => self.root_val = Some(v),
            16 => self.voxels.set(n.block, n.slot as usize, v),
            _ => self.inner.blocks[n.block as usize].vals[n.slot as usize] = v,
        }
    }

    /// The node's child block, or `NO_BLOCK` (always for depth 16).
    #[inline]
    pub fn kids(&self, n: NodeRef) -> u32 {
        match n.depth {
            0 => self.root_kids,
            16 => NO_BLOCK,
            _ => self.inner.blocks[n.block as usize].kids[n.slot as usize],
        }
    }

    #[inline]
    fn set_kids(&mut self, n: NodeRef, b: u32) {
        match n.depth {
            0 => self.root_kids = b,
            16 => unreachable!("depth-16 nodes have no children"),
            _ => self.inner.blocks[n.block as usize].kids[n.slot as usize] = b,
        }
    }

    /// `true` when the node has at least one child (a block is freed with its last child).
    #[inline]
    pub fn has_children(&self, n: NodeRef) -> bool {
        self.kids(n) != NO_BLOCK
    }

    /// The eight child values of a node with child block `b` at child depth `cd`.
    #[inline]
    pub fn child_vals(&self, cd: u8, b: u32) -> [f32; 8] {
        if cd == 16 {
            self.voxels.vals(b)
        } else {
            self.inner.blocks[b as usize].vals
        }
    }

    /// Whether slot `pos` of child block `b` at child depth `cd` holds a node.
    #[inline(always)]
    pub fn child_present(&self, cd: u8, b: u32, pos: usize) -> bool {
        if cd == 16 {
            self.voxels.is_present(b, pos)
        } else {
            present(self.inner.blocks[b as usize].vals[pos])
        }
    }

    /// Prepare voxel updates adding `delta` and clamping to `[cmin, cmax]`.
    #[inline]
    pub fn adder(&mut self, delta: f32, cmin: f32, cmax: f32) -> Adder {
        self.voxels.adder(delta, cmin, cmax)
    }

    /// OctoMap's `updateNodeLogOdds` with its early exit on the depth-16 node `n`; an absent
    /// slot becomes a new node, and a `fresh` node (just created) is updated from 0 without
    /// the early exit.
    /// `memo` is `add`'s transition memo, from [`NodeStore::take_memo`].
    #[inline(always)]
    pub fn update_voxel(
        &mut self,
        n: NodeRef,
        add: &Adder,
        fresh: bool,
        memo: &mut Vec<u16>,
    ) -> Outcome {
        debug_assert_eq!(n.depth, 16);
        self.voxels
            .update(n.block, n.slot as usize, add, fresh, memo)
    }

    /// Take `add`'s transition memo for a batch of [`NodeStore::update_voxel`] calls (held
    /// by the caller so that the hot loop keeps it in registers); give it back with
    /// [`NodeStore::put_memo`].
    #[inline]
    pub fn take_memo(&mut self, add: &Adder) -> Vec<u16> {
        self.voxels.take_memo(add)
    }

    /// Give back the memo from [`NodeStore::take_memo`].
    #[inline]
    pub fn put_memo(&mut self, add: &Adder, memo: Vec<u16>) {
        self.voxels.put_memo(add, memo)
    }

    /// Child `i` of `n`, if it exists.
    #[inline]
    pub fn child(&self, n: NodeRef, i: usize) -> Option<NodeRef> {
        let b = self.kids(n);
        if b == NO_BLOCK {
            return None;
        }
        let cd = n.depth + 1;
        if self.child_present(cd, b, i) {
            Some(NodeRef {
                depth: cd,
                slot: i as u8,
                block: b,
            })
        } else {
            None
        }
    }

    /// Allocate an empty child block for `n` (which must have none) and return it.
    #[inline]
    pub fn alloc_kids(&mut self, n: NodeRef) -> u32 {
        debug_assert_eq!(self.kids(n), NO_BLOCK);
        let b = if n.depth == 15 {
            self.voxels.alloc()
        } else {
            self.inner.alloc()
        };
        self.set_kids(n, b);
        b
    }

    /// [`NodeStore::alloc_kids`] for a node `n` at depth 0..=14 (children in an inner block),
    /// without a dispatch on the child depth.
    #[inline(always)]
    pub fn alloc_inner_kids(&mut self, n: NodeRef) -> u32 {
        debug_assert!(n.depth < 15);
        debug_assert_eq!(self.kids(n), NO_BLOCK);
        let b = self.inner.alloc();
        if n.depth == 0 {
            self.root_kids = b;
        } else {
            self.inner.blocks[n.block as usize].kids[n.slot as usize & 7] = b;
        }
        b
    }

    /// [`NodeStore::alloc_kids`] for the depth-15 node in slot `j` of inner block `kb`: a new
    /// empty voxel block, without a dispatch on the node's depth.
    #[inline(always)]
    pub fn alloc_voxel_kids(&mut self, kb: u32, j: usize) -> u32 {
        let b = self.voxels.alloc();
        let kid = &mut self.inner.blocks[kb as usize].kids[j & 7];
        debug_assert_eq!(*kid, NO_BLOCK);
        *kid = b;
        b
    }

    /// Create child `i` of `n` with value `v`; returns the new child.
    #[inline]
    pub fn create_child(&mut self, n: NodeRef, i: usize, v: f32) -> NodeRef {
        let mut b = self.kids(n);
        if b == NO_BLOCK {
            b = self.alloc_kids(n);
        }
        let c = NodeRef {
            depth: n.depth + 1,
            slot: i as u8,
            block: b,
        };
        self.set_value(c, v);
        c
    }

    /// [`NodeStore::create_child`] with value 0, the value of every node an update creates.
    #[inline(always)]
    pub fn create_child_zero(&mut self, n: NodeRef, i: usize) -> NodeRef {
        let mut b = self.kids(n);
        if b == NO_BLOCK {
            b = self.alloc_kids(n);
        }
        if n.depth == 15 {
            self.voxels.set_zero(b, i);
        } else {
            self.inner.blocks[b as usize].vals[i & 7] = 0.0;
        }
        NodeRef {
            depth: n.depth + 1,
            slot: i as u8,
            block: b,
        }
    }

    /// Give a childless node all eight children, each a copy of its value (`expandNode`).
    #[inline]
    pub fn expand_node(&mut self, n: NodeRef) -> u32 {
        let v = self.value(n);
        let b = self.alloc_kids(n);
        if n.depth == 15 {
            self.voxels.fill(b, v);
        } else {
            self.inner.blocks[b as usize].vals = [v; 8];
        }
        b
    }

    /// Collapse `n` if all eight children exist, have no children and equal values under
    /// float `==` (`pruneNode`); `n` takes child 0's value. Returns whether it pruned.
    #[inline]
    pub fn prune_node(&mut self, n: NodeRef) -> bool {
        let b = self.kids(n);
        b != NO_BLOCK && self.try_collapse(n, b)
    }

    /// Collapse `n` (whose child block is `b`) when its eight children are equal leaves:
    /// free the block and give `n` child 0's value. The comparisons fold without
    /// short-circuit so they compile to a few vector compares; an absent child (NaN) never
    /// equals a present value.
    #[inline]
    fn try_collapse(&mut self, n: NodeRef, b: u32) -> bool {
        let Some(v0) = self.uniform_in(n.depth + 1, b) else {
            return false;
        };
        self.collapse(n, b, v0);
        true
    }

    /// Free `n`'s child block `b` and give `n` the value `v0`.
    #[inline(always)]
    fn collapse(&mut self, n: NodeRef, b: u32, v0: f32) {
        if n.depth == 15 {
            self.voxels.release(b);
        } else {
            self.inner.release(b);
        }
        self.set_kids(n, NO_BLOCK);
        self.set_branch_value(n, v0);
    }

    /// The value of child block `b` at child depth `cd` when its eight children are leaves
    /// with values equal under float `==` (child 0's value); `None` otherwise. The
    /// comparisons fold without short-circuit so they compile to a few vector compares; an
    /// absent child (NaN) never equals a present value.
    #[inline(always)]
    fn uniform_in(&self, cd: u8, b: u32) -> Option<f32> {
        if cd == 16 {
            return self.voxels.uniform(b);
        }
        inner_uniform(&self.inner.blocks[b as usize])
    }

    /// Set the value of a node at depth 0..=15 (cheaper than [`NodeStore::set_value`]).
    #[inline(always)]
    fn set_branch_value(&mut self, n: NodeRef, v: f32) {
        debug_assert!(n.depth < 16);
        if n.depth == 0 {
            self.root_val = Some(v);
        } else {
            self.inner.blocks[n.block as usize].vals[n.slot as usize & 7] = v;
        }
    }

    /// The per-ancestor step of `updateNodeRecurs` with one look-up of the child block:
    /// nothing for a childless node (`None`); otherwise prune it when its eight children are
    /// equal leaves (`Some(true)`), else set it to the max of its children (`Some(false)`).
    #[inline]
    pub fn prune_or_refresh(&mut self, n: NodeRef) -> Option<bool> {
        self.prune_or_refresh_if(n, || true)
    }

    /// [`NodeStore::prune_or_refresh`] where a prune the occupancy allows also needs `allow()`
    /// (asked only then): refused, the node is refreshed instead (to its children's common
    /// value). The trees with a payload per node use it, whose children must also have equal
    /// payloads to be pruned.
    #[inline]
    pub fn prune_or_refresh_if(
        &mut self,
        n: NodeRef,
        allow: impl FnOnce() -> bool,
    ) -> Option<bool> {
        let b = self.kids(n);
        if b == NO_BLOCK {
            return None;
        }
        let cd = n.depth + 1;
        let (uniform, v) = if cd == 16 {
            // one look at the depth-16 block: equal children, else their max
            self.voxels.collapse_or_max(b)
        } else {
            match self.uniform_in(cd, b) {
                Some(v0) => (true, v0),
                None => (false, max_present(&self.inner.blocks[b as usize].vals)),
            }
        };
        if uniform && allow() {
            self.collapse(n, b, v);
            return Some(true);
        }
        self.set_branch_value(n, v);
        Some(false)
    }

    /// [`NodeStore::prune_or_refresh`] for a node `n` at depth 1..=14 whose child block `b`
    /// (of inner nodes) is known: no look-up of the block, no dispatch on the depth. Returns
    /// whether it pruned.
    #[inline(always)]
    pub fn refresh_branch(&mut self, n: NodeRef, b: u32) -> bool {
        debug_assert!((1..15).contains(&n.depth));
        debug_assert_eq!(self.kids(n), b);
        let kids = &self.inner.blocks[b as usize];
        let (pruned, v) = match inner_uniform(kids) {
            Some(v0) => (true, v0),
            None => (false, max_present(&kids.vals)),
        };
        let blk = &mut self.inner.blocks[n.block as usize];
        blk.vals[n.slot as usize & 7] = v;
        if pruned {
            blk.kids[n.slot as usize & 7] = NO_BLOCK;
            self.inner.release(b);
        }
        pruned
    }

    /// [`NodeStore::prune_or_refresh`] for the depth-15 node in slot `j` of inner block `kb`,
    /// whose child block `lb` (depth 16) is known: the batched walk's step after updating
    /// voxels below it, without a look-up of the node or a dispatch on its depth. Returns
    /// whether it pruned.
    #[inline(always)]
    pub fn refresh_voxel_parent(&mut self, kb: u32, j: usize, lb: u32) -> bool {
        let (pruned, v) = self.voxels.collapse_or_max(lb);
        self.set_voxel_parent(kb, j, lb, pruned, v)
    }

    /// [`NodeStore::refresh_voxel_parent`] with the voxel block's outcome already known (from
    /// [`VoxelBlocks::update_group`]): `pruned` when its eight voxels are equal leaves, `v`
    /// their common value or their max. Returns `pruned`.
    #[inline(always)]
    pub fn set_voxel_parent(&mut self, kb: u32, j: usize, lb: u32, pruned: bool, v: f32) -> bool {
        let blk = &mut self.inner.blocks[kb as usize];
        blk.vals[j & 7] = v;
        if pruned {
            blk.kids[j & 7] = NO_BLOCK;
            self.voxels.release(lb);
        }
        pruned
    }

    /// Maximum log-odds over the existing children of a node that has children
    /// (`getMaxChildLogOdds`).
    #[inline]
    pub fn max_child(&self, n: NodeRef) -> f32 {
        let b = self.kids(n);
        debug_assert_ne!(b, NO_BLOCK);
        self.max_in(n.depth + 1, b)
    }

    /// The largest present value of child block `b` at child depth `cd`.
    #[inline]
    fn max_in(&self, cd: u8, b: u32) -> f32 {
        if cd == 16 {
            self.voxels.max(b)
        } else {
            max_present(&self.inner.blocks[b as usize].vals)
        }
    }

    /// Delete the subtree below `n` (not `n` itself); returns the number of nodes removed.
    pub fn delete_children(&mut self, n: NodeRef) -> usize {
        let b = self.kids(n);
        if b == NO_BLOCK {
            return 0;
        }
        let mut removed = 0;
        for i in 0..8 {
            if let Some(c) = self.child(n, i) {
                removed += 1 + self.delete_children(c);
            }
        }
        if n.depth == 15 {
            self.voxels.release(b);
        } else {
            self.inner.release(b);
        }
        self.set_kids(n, NO_BLOCK);
        removed
    }

    /// Remove child `i` of `n` and its subtree; frees the block when it was the last child.
    /// Returns the number of nodes removed.
    pub fn delete_child(&mut self, n: NodeRef, i: usize) -> usize {
        let Some(c) = self.child(n, i) else { return 0 };
        let removed = 1 + self.delete_children(c);
        self.set_value(c, ABSENT);
        let b = self.kids(n);
        if !(0..8).any(|i| self.child_present(n.depth + 1, b, i)) {
            if n.depth == 15 {
                self.voxels.release(b);
            } else {
                self.inner.release(b);
            }
            self.set_kids(n, NO_BLOCK);
        }
        removed
    }

    /// Copy the tree into fresh arenas in depth-first order, dropping the blocks that pruning
    /// freed and any spare capacity; indices change, the tree does not.
    /// The voxel palette is rebuilt from the values in use (so values no voxel holds any more
    /// are dropped), and wide voxel storage becomes narrow again when they fit.
    pub fn compact(&mut self) {
        let mut inner = Arena::new(EMPTY_INNER);
        let mut order = Vec::with_capacity(self.voxels.live());
        inner.blocks.reserve_exact(self.inner.live());
        if self.root_kids != NO_BLOCK {
            self.root_kids = self.copy_block(1, self.root_kids, &mut inner, &mut order);
        }
        self.inner = inner;
        self.voxels = self.voxels.compacted(&order, self.palette_limit);
    }

    /// Copy block `b` (holding nodes at depth `cd`) and everything below it; returns its new
    /// index. Voxel blocks are only listed in `order` (old indices; new index = position).
    fn copy_block(
        &self,
        cd: u8,
        b: u32,
        inner: &mut Arena<InnerBlock>,
        order: &mut Vec<u32>,
    ) -> u32 {
        if cd == 16 {
            order.push(b);
            return order.len() as u32 - 1;
        }
        let blk = self.inner.blocks[b as usize];
        let i = inner.blocks.len();
        inner.blocks.push(blk);
        for (slot, &kid) in blk.kids.iter().enumerate() {
            if kid != NO_BLOCK {
                let nb = self.copy_block(cd + 1, kid, inner, order);
                inner.blocks[i].kids[slot] = nb;
            }
        }
        i as u32
    }

    /// Replace every node's value `v` by `f(v)` (`f` must not return NaN).
    pub fn map_values(&mut self, f: impl Fn(f32) -> f32) {
        // freed blocks hold only absent slots, so every arena slot can be converted directly
        for b in &mut self.inner.blocks {
            for v in &mut b.vals {
                if present(*v) {
                    *v = f(*v);
                }
            }
        }
        if let Some(v) = self.root_val.as_mut() {
            *v = f(*v);
        }
        self.voxels.map_values(f);
    }

    /// Where the bytes of the node storage go (blocks in use and freed, free lists, the voxel
    /// palette, this struct).
    pub fn memory(&self) -> MemoryUsage {
        let (inner_live, inner_free) = self.inner.split_bytes();
        let (voxel_live, voxel_free, leaf_block_bytes, palette_bytes, palette_values) =
            self.voxels.bytes();
        MemoryUsage {
            inner_blocks: self.inner.live(),
            leaf_blocks: self.voxels.live(),
            leaf_block_bytes,
            block_bytes: inner_live + voxel_live,
            free_bytes: inner_free + voxel_free,
            palette_bytes,
            palette_values,
            fixed_bytes: std::mem::size_of::<Self>(),
        }
    }
}

/// The value of the eight children in `blk` when they exist, have no children and are equal
/// under float `==` (child 0's value); `None` otherwise. The comparisons fold without
/// short-circuit so they compile to a few vector compares; an absent child (NaN) never equals
/// a present value.
#[inline(always)]
fn inner_uniform(blk: &InnerBlock) -> Option<f32> {
    let leaves = blk.kids.iter().fold(NO_BLOCK, |a, &k| a & k) == NO_BLOCK;
    let v0 = blk.vals[0];
    (leaves && present(v0) && blk.vals.iter().fold(true, |a, &v| a & (v == v0))).then_some(v0)
}
