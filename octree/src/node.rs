//! Node storage: arenas of 8-child blocks addressed by `u32` indices.
//!
//! Children of one node live together in a block. Nodes at depths 1..=15 sit in 64-byte
//! [`InnerBlock`]s (eight `f32` log-odds plus eight child-block indices, one cache line); nodes
//! at depth 16 can have no children and sit in 32-byte [`LeafBlock`]s. A missing child is
//! marked by a reserved NaN bit pattern in its value slot, a node without children by
//! [`NO_BLOCK`]. On real maps this costs about 8 bytes per node, against OctoMap's ~27.

use crate::key::Key;

/// Bit pattern of the value slot of a child that does not exist (a quiet NaN that the tree
/// never stores, since NaN log-odds are rejected at the API).
pub(crate) const ABSENT_BITS: u32 = 0x7fc0_0a5e;
/// The value of an absent slot.
pub(crate) const ABSENT: f32 = f32::from_bits(ABSENT_BITS);
/// Child-block index meaning "this node has no children".
pub(crate) const NO_BLOCK: u32 = u32::MAX;

/// `true` when a value slot holds a node.
#[inline]
pub(crate) fn present(v: f32) -> bool {
    v.to_bits() != ABSENT_BITS
}

/// The largest present value of a child block (`-f32::MAX` when none): absent children hold
/// a NaN, which `>` never picks, and strict `>` in child order keeps OctoMap's choice between
/// equal values (+0.0 and -0.0).
#[inline]
fn max_present(vals: &[f32; 8]) -> f32 {
    let mut m = -f32::MAX;
    for &v in vals {
        if v > m {
            m = v;
        }
    }
    m
}

/// Eight children at depths 1..=15: their log-odds and their own child blocks.
#[derive(Clone, Copy)]
#[repr(C, align(64))]
pub(crate) struct InnerBlock {
    pub vals: [f32; 8],
    pub kids: [u32; 8],
}

/// Eight depth-16 children: log-odds only.
#[derive(Clone, Copy)]
#[repr(C, align(32))]
pub(crate) struct LeafBlock {
    pub vals: [f32; 8],
}

const EMPTY_INNER: InnerBlock = InnerBlock {
    vals: [ABSENT; 8],
    kids: [NO_BLOCK; 8],
};
const EMPTY_LEAF: LeafBlock = LeafBlock { vals: [ABSENT; 8] };

/// A growable pool of blocks with a free list; freed blocks are reset to empty.
#[derive(Clone)]
pub(crate) struct Arena<B: Copy> {
    pub blocks: Vec<B>,
    free: Vec<u32>,
    empty: B,
}

impl<B: Copy> Arena<B> {
    fn new(empty: B) -> Self {
        Arena {
            blocks: Vec::new(),
            free: Vec::new(),
            empty,
        }
    }

    #[inline]
    pub fn alloc(&mut self) -> u32 {
        if let Some(i) = self.free.pop() {
            i
        } else {
            let i = self.blocks.len();
            assert!(
                i < NO_BLOCK as usize,
                "octree node arena exhausted (2^32 blocks)"
            );
            self.blocks.push(self.empty);
            i as u32
        }
    }

    #[inline]
    pub fn release(&mut self, i: u32) {
        self.blocks[i as usize] = self.empty;
        self.free.push(i);
    }

    pub fn clear(&mut self) {
        self.blocks.clear();
        self.free.clear();
    }

    /// Blocks in use (allocated and not on the free list).
    pub fn live(&self) -> usize {
        self.blocks.len() - self.free.len()
    }

    /// Bytes held by the blocks (including freed ones awaiting reuse) and the free list.
    pub fn bytes(&self) -> usize {
        self.blocks.len() * std::mem::size_of::<B>() + self.free.len() * 4
    }
}

/// Both arenas and the root.
#[derive(Clone)]
pub(crate) struct NodeStore {
    pub inner: Arena<InnerBlock>,
    pub leaf: Arena<LeafBlock>,
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
            leaf: Arena::new(EMPTY_LEAF),
            root_val: None,
            root_kids: NO_BLOCK,
        }
    }

    pub fn clear(&mut self) {
        self.inner.clear();
        self.leaf.clear();
        self.root_val = None;
        self.root_kids = NO_BLOCK;
    }

    /// Value of an existing node.
    #[inline]
    pub fn value(&self, n: NodeRef) -> f32 {
        match n.depth {
            0 => self.root_val.unwrap_or(ABSENT),
            16 => self.leaf.blocks[n.block as usize].vals[n.slot as usize],
            _ => self.inner.blocks[n.block as usize].vals[n.slot as usize],
        }
    }

    #[inline]
    pub fn set_value(&mut self, n: NodeRef, v: f32) {
        match n.depth {
            0 => self.root_val = Some(v),
            16 => self.leaf.blocks[n.block as usize].vals[n.slot as usize] = v,
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
    pub fn child_vals(&self, cd: u8, b: u32) -> &[f32; 8] {
        if cd == 16 {
            &self.leaf.blocks[b as usize].vals
        } else {
            &self.inner.blocks[b as usize].vals
        }
    }

    /// Child `i` of `n`, if it exists.
    #[inline]
    pub fn child(&self, n: NodeRef, i: usize) -> Option<NodeRef> {
        let b = self.kids(n);
        if b == NO_BLOCK {
            return None;
        }
        let cd = n.depth + 1;
        if present(self.child_vals(cd, b)[i]) {
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
            self.leaf.alloc()
        } else {
            self.inner.alloc()
        };
        self.set_kids(n, b);
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

    /// Below `n` (childless, at depth < 16), create one child per level along `key` down to
    /// depth 16, each with value 0 (what OctoMap's `createNodeChild` does under a node it has
    /// just created); records the new nodes in `path[depth]` and returns the voxel's node.
    #[inline]
    pub fn create_chain(&mut self, mut n: NodeRef, key: Key, path: &mut [NodeRef]) -> NodeRef {
        debug_assert_eq!(self.kids(n), NO_BLOCK);
        let mut d = n.depth;
        while d < 15 {
            let b = self.inner.alloc();
            self.set_kids(n, b);
            let pos = key.child_index(d);
            self.inner.blocks[b as usize].vals[pos] = 0.0;
            d += 1;
            n = NodeRef {
                depth: d,
                slot: pos as u8,
                block: b,
            };
            path[d as usize] = n;
        }
        let b = self.leaf.alloc();
        self.set_kids(n, b);
        let pos = key.child_index(15);
        self.leaf.blocks[b as usize].vals[pos] = 0.0;
        n = NodeRef {
            depth: 16,
            slot: pos as u8,
            block: b,
        };
        path[16] = n;
        n
    }

    /// Give a childless node all eight children, each a copy of its value (`expandNode`).
    #[inline]
    pub fn expand_node(&mut self, n: NodeRef) -> u32 {
        let v = self.value(n);
        let b = self.alloc_kids(n);
        if n.depth == 15 {
            self.leaf.blocks[b as usize].vals = [v; 8];
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
        let (vals, leaves) = if n.depth == 15 {
            (&self.leaf.blocks[b as usize].vals, true)
        } else {
            let blk = &self.inner.blocks[b as usize];
            (
                &blk.vals,
                blk.kids.iter().fold(NO_BLOCK, |a, &k| a & k) == NO_BLOCK,
            )
        };
        let v0 = vals[0];
        if !(leaves && present(v0) && vals.iter().fold(true, |a, &v| a & (v == v0))) {
            return false;
        }
        if n.depth == 15 {
            self.leaf.release(b);
        } else {
            self.inner.release(b);
        }
        self.set_kids(n, NO_BLOCK);
        self.set_value(n, v0);
        true
    }

    /// The per-ancestor step of `updateNodeRecurs` with one look-up of the child block:
    /// nothing for a childless node (`None`); otherwise prune it when its eight children are
    /// equal leaves (`Some(true)`), else set it to the max of its children (`Some(false)`).
    #[inline]
    pub fn prune_or_refresh(&mut self, n: NodeRef) -> Option<bool> {
        let b = self.kids(n);
        if b == NO_BLOCK {
            return None;
        }
        if self.try_collapse(n, b) {
            return Some(true);
        }
        let m = max_present(self.child_vals(n.depth + 1, b));
        self.set_value(n, m);
        Some(false)
    }

    /// Maximum log-odds over the existing children of a node that has children
    /// (`getMaxChildLogOdds`).
    #[inline]
    pub fn max_child(&self, n: NodeRef) -> f32 {
        let b = self.kids(n);
        debug_assert_ne!(b, NO_BLOCK);
        max_present(self.child_vals(n.depth + 1, b))
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
            self.leaf.release(b);
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
        if !self.child_vals(n.depth + 1, b).iter().any(|&v| present(v)) {
            if n.depth == 15 {
                self.leaf.release(b);
            } else {
                self.inner.release(b);
            }
            self.set_kids(n, NO_BLOCK);
        }
        removed
    }

    /// Copy the tree into fresh arenas in depth-first order, dropping the blocks that pruning
    /// freed and any spare capacity; indices change, the tree does not.
    pub fn compact(&mut self) {
        let mut inner = Arena::new(EMPTY_INNER);
        let mut leaf = Arena::new(EMPTY_LEAF);
        inner.blocks.reserve_exact(self.inner.live());
        leaf.blocks.reserve_exact(self.leaf.live());
        if self.root_kids != NO_BLOCK {
            self.root_kids = self.copy_block(1, self.root_kids, &mut inner, &mut leaf);
        }
        self.inner = inner;
        self.leaf = leaf;
    }

    /// Copy block `b` (holding nodes at depth `cd`) and everything below it; returns its new
    /// index.
    fn copy_block(
        &self,
        cd: u8,
        b: u32,
        inner: &mut Arena<InnerBlock>,
        leaf: &mut Arena<LeafBlock>,
    ) -> u32 {
        if cd == 16 {
            let i = leaf.blocks.len() as u32;
            leaf.blocks.push(self.leaf.blocks[b as usize]);
            return i;
        }
        let blk = self.inner.blocks[b as usize];
        let i = inner.blocks.len();
        inner.blocks.push(blk);
        for (slot, &kid) in blk.kids.iter().enumerate() {
            if kid != NO_BLOCK {
                let nb = self.copy_block(cd + 1, kid, inner, leaf);
                inner.blocks[i].kids[slot] = nb;
            }
        }
        i as u32
    }

    /// Bytes held by the node arenas (blocks in use and freed, plus free lists).
    pub fn bytes(&self) -> usize {
        self.inner.bytes() + self.leaf.bytes() + std::mem::size_of::<Self>()
    }
}
