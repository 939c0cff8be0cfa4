//! Per-node surgery, OctoMap's `expandNode`, `pruneNode`, `isNodeCollapsible`,
//! `createNodeChild`, `getNodeChild`, `deleteNodeChild`, `nodeChildExists` and
//! `nodeHasChildren`, and the occupancy calls on a node in hand (`updateNodeLogOdds`,
//! `integrateHit`, `integrateMiss`, `nodeToMaxLikelihood`, `setValue`), with the node named by
//! its key and depth instead of a pointer.
//!
//! OctoMap hands out raw node pointers and asserts its preconditions; here a node is addressed
//! by `(key, depth)` (the key of any voxel inside it, depth 0 = root .. 16 = voxel), and a call
//! whose node does not exist at exactly that depth, or whose precondition OctoMap only asserts,
//! does nothing and says so (`false` / `None`). None of these calls refreshes the inner nodes
//! above, as in OctoMap.

use crate::key::{Key, TREE_DEPTH};
use crate::store::{clamp_sum, NodeRef};
use crate::tree::{NodeInfo, OcTree, Update};

impl OcTree {
    /// The node at exactly `depth` on the way to `key`; `None` when the tree has no node there
    /// (unknown space, or a pruned leaf above it).
    fn node_ref_at(&self, key: Key, depth: u8) -> Option<NodeRef> {
        if depth > TREE_DEPTH {
            return None;
        }
        let n = self.search_ref(key, depth)?;
        (n.depth == depth).then_some(n)
    }

    fn info(&self, n: NodeRef) -> NodeInfo {
        NodeInfo {
            value: self.store.value(n),
            depth: n.depth,
            has_children: self.store.has_children(n),
        }
    }

    /// The key (in [`Key::at_depth`]'s convention) of child `i` (bit 0 x, bit 1 y, bit 2 z:
    /// OctoMap's `computeChildKey`) of the node at `depth` holding `key`; `None` for a voxel
    /// (`depth >= 16`) or `i >= 8`, which name no child.
    pub fn child_key(key: Key, depth: u8, i: usize) -> Option<Key> {
        if depth >= TREE_DEPTH || i >= 8 {
            return None;
        }
        let mut k = key.min_at_depth(depth);
        let half = 1u16 << (15 - depth);
        for a in 0..3 {
            if i >> a & 1 == 1 {
                k[a] |= half;
            }
        }
        Some(k.at_depth(depth + 1))
    }

    /// The node at exactly `depth` (0 = root .. 16) holding `key`, or `None` when there is
    /// none at that depth (unknown space, or covered by a pruned leaf above).
    pub fn node_at_depth(&self, key: Key, depth: u8) -> Option<NodeInfo> {
        self.node_ref_at(key, depth).map(|n| self.info(n))
    }

    /// Whether child `i` (0..8) of the node at `depth` holding `key` exists (OctoMap's
    /// `nodeChildExists`); `None` when there is no such node or `i >= 8`.
    pub fn node_child_exists(&self, key: Key, depth: u8, i: usize) -> Option<bool> {
        let n = self.node_ref_at(key, depth)?;
        (i < 8).then(|| self.store.child(n, i).is_some())
    }

    /// Child `i` of the node at `depth` holding `key` (OctoMap's `getNodeChild`); `None`
    /// when the node or the child does not exist.
    pub fn node_child(&self, key: Key, depth: u8, i: usize) -> Option<NodeInfo> {
        let n = self.node_ref_at(key, depth)?;
        if i >= 8 {
            return None;
        }
        self.store.child(n, i).map(|c| self.info(c))
    }

    /// Whether the node at `depth` holding `key` has all eight children, none of them with
    /// children of its own, all with equal log-odds (OctoMap's `isNodeCollapsible`);
    /// `false` also when there is no such node.
    pub fn is_node_collapsible(&self, key: Key, depth: u8) -> bool {
        let Some(n) = self.node_ref_at(key, depth) else {
            return false;
        };
        let Some(c0) = self.store.child(n, 0) else {
            return false;
        };
        if self.store.has_children(c0) {
            return false;
        }
        let v0 = self.store.value(c0);
        (1..8).all(|i| {
            self.store
                .child(n, i)
                .is_some_and(|c| !self.store.has_children(c) && self.store.value(c) == v0)
        })
    }

    /// Set the log-odds of the node at exactly `depth` holding `key` to `value`, as OctoMap's
    /// `OcTreeNode::setValue` / `setLogOdds` on a node in hand: no clamping, no early exit, no
    /// change detection, and no ancestor refreshed or pruned (the caller's business, as in
    /// OctoMap). `Ok(false)`, changing nothing, when no node exists there; NaN is an error
    /// (the store marks absent slots with it).
    pub fn set_node_raw_value(
        &mut self,
        key: Key,
        depth: u8,
        value: f32,
    ) -> Result<bool, crate::OctreeError> {
        if value.is_nan() {
            return Err(crate::OctreeError::NanValue);
        }
        let Some(n) = self.node_ref_at(key, depth) else {
            return Ok(false);
        };
        self.store.set_value(n, value);
        Ok(true)
    }

    /// Add `update`'s log-odds to the node at exactly `depth` holding `key` and clamp the sum
    /// to the sensor model's bounds, as OctoMap's `updateNodeLogOdds` on a node in hand
    /// (`integrateHit` with [`Update::Hit`], `integrateMiss` with [`Update::Miss`]): no early
    /// exit at a clamp, no change detection, no ancestor refreshed or pruned. Returns the
    /// node's new log-odds, `Ok(None)` (nothing changed) when no node exists there, and
    /// [`crate::OctreeError::NanValue`] (nothing changed) when the sum is NaN (a NaN update, or
    /// infinities of both signs), which OctoMap would store and this tree cannot.
    pub fn update_node_log_odds(
        &mut self,
        key: Key,
        depth: u8,
        update: Update,
    ) -> Result<Option<f32>, crate::OctreeError> {
        let Some(n) = self.node_ref_at(key, depth) else {
            return Ok(None);
        };
        let p = self.params;
        let v = clamp_sum(
            self.store.value(n),
            self.delta(update),
            p.clamp_min,
            p.clamp_max,
        );
        if v.is_nan() {
            return Err(crate::OctreeError::NanValue);
        }
        self.store.set_value(n, v);
        Ok(Some(v))
    }

    /// Set the node at exactly `depth` holding `key` to the clamp its occupancy points to
    /// (OctoMap's `nodeToMaxLikelihood` on a node in hand: occupied nodes to the upper clamp,
    /// the others to the lower), without touching its children or ancestors. Returns the new
    /// log-odds, `None` when no node exists there.
    pub fn node_to_max_likelihood(&mut self, key: Key, depth: u8) -> Option<f32> {
        let n = self.node_ref_at(key, depth)?;
        let v = self.params.max_likelihood(self.store.value(n));
        self.store.set_value(n, v);
        Some(v)
    }

    /// Collapse the node at `depth` holding `key` when it is collapsible (OctoMap's
    /// `pruneNode`): it takes its children's value and loses them. Returns whether it did.
    pub fn prune_node(&mut self, key: Key, depth: u8) -> bool {
        let Some(n) = self.node_ref_at(key, depth) else {
            return false;
        };
        let pruned = self.store.prune_node(n);
        if pruned {
            self.sub_size(8);
        }
        pruned
    }

    /// Give the childless node at `depth` < 16 holding `key` eight children with its value
    /// (OctoMap's `expandNode`). Returns `false` (and changes nothing) when there is no such
    /// node, it has children (OctoMap asserts), or it is a voxel (depth 16, which OctoMap would
    /// give children below the finest level).
    pub fn expand_node(&mut self, key: Key, depth: u8) -> bool {
        let Some(n) = self.node_ref_at(key, depth) else {
            return false;
        };
        if depth >= TREE_DEPTH || self.store.has_children(n) {
            return false;
        }
        self.store.expand_node(n);
        self.add_size(8);
        true
    }

    /// Create child `i` (0..8) of the node at `depth` < 16 holding `key`, with log-odds 0
    /// (OctoMap's `createNodeChild`, whose new node has value 0). Returns the child; `None`
    /// (nothing changed) when there is no such node, it is a voxel, `i >= 8`, or the child
    /// exists already (OctoMap asserts).
    pub fn create_node_child(&mut self, key: Key, depth: u8, i: usize) -> Option<NodeInfo> {
        let n = self.node_ref_at(key, depth)?;
        if depth >= TREE_DEPTH || i >= 8 || self.store.child(n, i).is_some() {
            return None;
        }
        let c = self.store.create_child_zero(n, i);
        self.add_size(1);
        Some(self.info(c))
    }

    /// Delete child `i` of the node at `depth` holding `key`, with its subtree (OctoMap's
    /// `deleteNodeChild`). Returns the number of nodes removed (0: no such node or child).
    ///
    /// `size()` drops by the whole subtree; OctoMap's drops by one node only, so its size goes
    /// stale when the child had children (as with [`OcTree::delete_node`]).
    pub fn delete_node_child(&mut self, key: Key, depth: u8, i: usize) -> usize {
        let Some(n) = self.node_ref_at(key, depth) else {
            return 0;
        };
        if i >= 8 {
            return 0;
        }
        let removed = self.store.delete_child(n, i);
        self.sub_size(removed);
        removed
    }
}

#[cfg(test)]
mod tests {
    use crate::{InnerNodes, Key, OcTree, Update, TREE_DEPTH};

    fn tree_with_voxel() -> (OcTree, Key) {
        let mut t = OcTree::new(0.1).unwrap();
        let k = Key::new(32768, 32768, 32768);
        t.update_node(k, Update::Hit, InnerNodes::Refresh);
        (t, k)
    }

    #[test]
    fn child_keys_are_inside_their_parent() {
        let k = Key::new(40000, 1234, 65535);
        for d in 0..TREE_DEPTH {
            for i in 0..8 {
                let c = OcTree::child_key(k, d, i).unwrap();
                assert_eq!(c.at_depth(d), k.at_depth(d), "depth {d} child {i}");
                assert_eq!(c.child_index(d), i, "depth {d} child {i}");
            }
            assert_eq!(OcTree::child_key(k, d, 8), None);
        }
        assert_eq!(OcTree::child_key(k, TREE_DEPTH, 0), None);
    }

    #[test]
    fn expand_then_prune_restores_the_tree() {
        let (mut t, k) = tree_with_voxel();
        let size = t.size();
        // the depth-15 parent has one child: not collapsible
        assert!(!t.is_node_collapsible(k, 15));
        assert!(!t.expand_node(k, 15), "has children");
        assert!(!t.expand_node(k, 16), "a voxel");
        t.prune_node(k, 15);
        assert_eq!(t.size(), size);
        // make the voxel's siblings equal to it, then prune the parent
        let v = t.node_at_depth(k, 16).unwrap().value;
        for i in 0..8 {
            if t.node_child_exists(k, 15, i) == Some(false) {
                let c = t.create_node_child(k, 15, i).unwrap();
                assert_eq!(c.value, 0.0);
            }
        }
        assert_eq!(t.size(), size + 7);
        for i in 0..8 {
            let ck = OcTree::child_key(k, 15, i).unwrap();
            t.update_node(
                ck,
                Update::LogOdds(v - t.node_at_depth(ck, 16).unwrap().value),
                InnerNodes::Defer,
            );
        }
        assert!(t.is_node_collapsible(k, 15));
        assert!(t.prune_node(k, 15));
        assert_eq!(t.size(), size - 1);
        assert_eq!(t.node_at_depth(k, 15).unwrap().value, v);
        assert!(t.node_at_depth(k, 16).is_none());
        assert!(t.expand_node(k, 15));
        assert_eq!(t.size(), size + 7);
        assert_eq!(t.node_child(k, 15, 3).unwrap().value, v);
        assert_eq!(t.delete_node_child(k, 15, 3), 1);
        assert_eq!(t.node_child_exists(k, 15, 3), Some(false));
        assert_eq!(t.size(), size + 6);
        crate::validate::assert_well_formed(&t, InnerNodes::Defer);
    }
}
