//! Whole-tree passes: prune, expand, max-likelihood conversion and inner-node refresh.

use crate::error::OctreeError;
use crate::key::TREE_DEPTH;
use crate::store::NodeRef;
use crate::tree::OcTree;

/// The nodes below a leaf at `depth` once it is expanded down to depth 16:
/// `8 + 8^2 + ... + 8^(16 - depth)`.
fn subtree_below(depth: u8) -> u64 {
    (1..=u32::from(TREE_DEPTH.saturating_sub(depth)))
        .map(|k| 8u64.pow(k))
        .sum()
}

/// `nodes` when an expansion of that many nodes is within `max_nodes`, else the error.
pub(crate) fn check_expansion(nodes: u64, max_nodes: u64) -> Result<u64, OctreeError> {
    if nodes > max_nodes {
        return Err(OctreeError::ExpansionTooLarge {
            nodes,
            limit: max_nodes,
        });
    }
    Ok(nodes)
}

impl OcTree {
    /// Collapse every node whose eight children are equal leaves, level by level from depth 15
    /// up to depth 1 (OctoMap's `prune()`).
    ///
    /// Like OctoMap it stops at the first level that prunes nothing and never prunes the root;
    /// both quirks change `.bt` bytes, so they are kept.
    pub fn prune(&mut self) {
        if self.is_empty() {
            return;
        }
        for depth in (1..TREE_DEPTH).rev() {
            if self.prune_depth(depth) == 0 {
                break;
            }
        }
    }

    /// One level of [`OcTree::prune`]'s loop: collapse every node at exactly `depth` whose
    /// eight children are equal leaves; returns how many. For callers that run the loop
    /// over pieces of a tree (a tile at a time) and must stop where the whole tree's loop
    /// would. Depth 0 (the root, which `prune` never collapses) and depths from 16 on prune
    /// nothing.
    pub fn prune_depth(&mut self, depth: u8) -> usize {
        if self.is_empty() || depth == 0 || depth >= TREE_DEPTH {
            return 0;
        }
        let pruned = self.prune_level(NodeRef::ROOT, depth);
        self.sub_size(8 * pruned);
        pruned
    }

    fn prune_level(&mut self, n: NodeRef, target: u8) -> usize {
        if n.depth == target {
            return usize::from(self.store.prune_node(n));
        }
        let mut count = 0;
        for i in 0..8 {
            if let Some(c) = self.store.child(n, i) {
                count += self.prune_level(c, target);
            }
        }
        count
    }

    /// How many nodes [`OcTree::expand`] would add: each leaf at depth `d < 16` becomes a
    /// full subtree of `8 + 8^2 + ... + 8^(16-d)` nodes (a childless root alone: about
    /// 3.2e14). The expansion allocates them all, so a tree from elsewhere (a file, a merge, a
    /// deletion that left a coarse leaf) is worth this check first; see
    /// [`OcTree::try_expand`]. Saturates at `u64::MAX`.
    pub fn expansion_nodes(&self) -> u64 {
        self.leaves()
            .fold(0u64, |n, leaf| n.saturating_add(subtree_below(leaf.depth)))
    }

    /// [`OcTree::expand`], unless it would add more than `max_nodes` nodes: then
    /// [`OctreeError::ExpansionTooLarge`] and the tree is unchanged. Returns the nodes added.
    pub fn try_expand(&mut self, max_nodes: u64) -> Result<u64, OctreeError> {
        let nodes = check_expansion(self.expansion_nodes(), max_nodes)?;
        self.expand();
        Ok(nodes)
    }

    /// Give every leaf above depth 16 its eight children, recursively, so every known voxel
    /// is a depth-16 node (OctoMap's `expand()`). Memory grows by up to 8^(16-depth) per leaf
    /// ([`OcTree::expansion_nodes`] says how many nodes; [`OcTree::try_expand`] refuses past
    /// a limit).
    pub fn expand(&mut self) {
        if !self.is_empty() {
            self.expand_recurs(NodeRef::ROOT);
        }
    }

    fn expand_recurs(&mut self, n: NodeRef) {
        if n.depth >= TREE_DEPTH {
            return;
        }
        if !self.store.has_children(n) {
            self.store.expand_node(n);
            self.add_size(8);
        }
        for i in 0..8 {
            if let Some(c) = self.store.child(n, i) {
                self.expand_recurs(c);
            }
        }
    }

    /// Set every node, inner ones included, to the upper clamp if occupied and to the lower
    /// clamp otherwise (OctoMap's `toMaxLikelihood()`). Does not prune.
    pub fn to_max_likelihood(&mut self) {
        let p = *self.params();
        self.store.map_values(|v| p.max_likelihood(v));
    }

    /// Set every inner node to the maximum of its children, bottom-up; needed after lazy
    /// updates (OctoMap's `updateInnerOccupancy()`). Does not prune.
    pub fn update_inner_occupancy(&mut self) {
        if !self.is_empty() {
            self.update_inner_recurs(NodeRef::ROOT);
        }
    }

    fn update_inner_recurs(&mut self, n: NodeRef) {
        if !self.store.has_children(n) {
            return;
        }
        for i in 0..8 {
            if let Some(c) = self.store.child(n, i) {
                self.update_inner_recurs(c);
            }
        }
        let m = self.store.max_child(n);
        self.store.set_value(n, m);
    }
}
