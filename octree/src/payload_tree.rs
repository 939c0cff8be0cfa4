//! The machinery shared by the tree types that carry a payload per node beside the occupancy
//! (`ColorOcTree`'s colours, `OcTreeStamped`'s time stamps): an [`OcTree`] plus a side table
//! of payloads keyed by node ([`NodeId`]), kept in step with every structural change OctoMap
//! makes.
//!
//! Why a side table and not the store: the store packs depth-16 voxels as 2-byte palette
//! indices, which is what makes plain maps 4-8 bytes per node; a payload there would grow the
//! voxel blocks of every map and touch the hot update paths. Beside it, plain `OcTree`s pay
//! nothing and a payload tree pays only for its nodes whose payload is set.
//!
//! What is the same for every payload lives here, written once: the table's convention (only
//! set payloads are stored, and only for existing nodes), OctoMap's `copyData` on expansion
//! (children take their parent's payload), the level-by-level `prune()`, `expand()`, the
//! inner-node refresh traversal, `deleteNode` and the bookkeeping around an update's descent.
//! What differs, OctoMap's rule for collapsing eight children into their parent, comes from
//! the payload type through [`NodePayload`]; the rest of each type's semantics stays in its
//! own module.

use crate::error::OctreeError;
use crate::key::{Key, TREE_DEPTH};
use crate::node_id::{child_id, node_id, NodeId, NodeMap};
use crate::store::NodeRef;
use crate::tree::{InnerNodes, NodeInfo, OcTree, Update};

/// A per-node payload of a [`PayloadTree`] and OctoMap's rule for it when eight children are
/// collapsed into their parent (`pruneNode`), the one structural rule that differs between
/// the payload types.
pub(crate) trait NodePayload: Copy + PartialEq {
    /// The payload of a node that was never given one (white, stamp 0); never stored.
    const UNSET: Self;

    /// Whether children with these payloads (`child(i)` reads child `i`'s) may be collapsed
    /// into their parent, their occupancy permitting: OctoMap's node comparison.
    fn may_collapse(child: impl Fn(usize) -> Self) -> bool;

    /// The payload the parent takes when its eight children are collapsed into it.
    fn collapsed(children: [Self; 8]) -> Self;
}

/// An occupancy tree plus a payload per node in a side table, with the table mirrored through
/// every structural change (see the module docs).
#[derive(Clone)]
pub(crate) struct PayloadTree<P> {
    /// The occupancy, exactly as a plain `OcTree` holds it.
    pub(crate) tree: OcTree,
    /// The payloads of the existing nodes whose payload is not [`NodePayload::UNSET`].
    pub(crate) payloads: NodeMap<P>,
}

impl<P: NodePayload> PayloadTree<P> {
    /// A payload tree over `tree`, every payload unset.
    pub(crate) fn new(tree: OcTree) -> Self {
        PayloadTree {
            tree,
            payloads: NodeMap::new(P::UNSET),
        }
    }

    /// Check the payload side table's bookkeeping ([`NodeMap::check`]).
    pub(crate) fn check_payloads(&self) -> Result<(), String> {
        self.payloads.check()
    }

    /// Bytes held by the node storage and the payload side table.
    pub(crate) fn memory_usage(&self) -> usize {
        self.tree.memory_usage() + self.payloads.heap_bytes()
    }

    /// Remove every node and payload.
    pub(crate) fn clear(&mut self) {
        self.tree.clear();
        self.payloads.clear();
    }

    /// The payload of node `id` ([`NodePayload::UNSET`] when it has none).
    pub(crate) fn get(&self, id: NodeId) -> P {
        self.payloads.get(id)
    }

    /// Give node `id` the payload `p`; an unset payload removes its entry.
    pub(crate) fn set(&mut self, id: NodeId, p: P) {
        self.payloads.insert(id, p);
    }

    /// The node `search` finds for `key` at `depth`, with its payload; `None` in unknown space.
    pub(crate) fn search(&self, key: Key, depth: u8) -> Option<(NodeInfo, P)> {
        let node = self.tree.search(key, depth)?;
        Some((node, self.get(node_id(key, node.depth))))
    }

    /// OctoMap's `updateNode` on the occupancy with the payload bookkeeping: nothing happens
    /// when the update cannot change the voxel (OctoMap's early exit) or its delta is NaN;
    /// otherwise the expansions on the way copy payloads down, and the payloads take part in
    /// the ascent as in `updateNodeRecurs`: `before` runs once the update is known to apply
    /// (so the voxel's new payload is what its parent compares), a prune the occupancy allows
    /// is made only if the children's payloads allow it too (their payloads then collapse into
    /// the parent's), and `after` gets the depth of the node holding `key` afterwards (`None`
    /// for a deferred update, which has no ascent). Nothing is pruned that would have to be
    /// expanded again. Returns the voxel's new log-odds.
    pub(crate) fn update_node(
        &mut self,
        key: Key,
        update: Update,
        inner: InnerNodes,
        before: impl FnOnce(&mut Self),
        after: impl FnOnce(&mut Self, Option<u8>),
    ) -> f32 {
        if let Err(v) = self.start_update(key, update) {
            return v;
        }
        before(self);
        self.ascend_collapsing(
            key,
            inner,
            |tree, guard| tree.update_node_guarded(key, update, inner, guard),
            after,
        )
    }

    /// The occupancy operation `op` on `key` (handed the guard its ascent asks before each
    /// prune), with the payloads taking part in that ascent: a prune is made only if the
    /// children's payloads allow it too, their payloads then collapsing into the parent's;
    /// `after` gets the depth of the node holding `key` afterwards (`None` when deferred).
    fn ascend_collapsing<T>(
        &mut self,
        key: Key,
        inner: InnerNodes,
        op: impl FnOnce(&mut OcTree, &mut dyn FnMut(u8) -> bool) -> T,
        after: impl FnOnce(&mut Self, Option<u8>),
    ) -> T {
        let mut held = TREE_DEPTH;
        let PayloadTree { tree, payloads } = self;
        let out = op(tree, &mut |depth| {
            let id = node_id(key, depth);
            if !payloads_may_collapse(payloads, id) {
                return false;
            }
            collapse_into(payloads, id);
            held = depth;
            true
        });
        after(self, (!inner.is_deferred()).then_some(held));
        out
    }

    /// The start of an update of `key`: `Err` with the voxel's log-odds when nothing is to
    /// change (OctoMap's early exit at the clamp, or a NaN delta, which the plain tree
    /// ignores); otherwise the payloads of the pruned leaf holding `key`, which the descent
    /// will expand, are copied down.
    fn start_update(&mut self, key: Key, update: Update) -> Result<(), f32> {
        let delta = self.tree.delta(update);
        let found = self.tree.search(key, TREE_DEPTH);
        if let Some(n) = found {
            let p = self.tree.params();
            if (delta >= 0.0 && n.value >= p.clamp_max) || (delta <= 0.0 && n.value <= p.clamp_min)
            {
                return Err(n.value); // OctoMap's early exit: nothing changes
            }
        }
        if delta.is_nan() {
            return Err(found.map_or(0.0, |n| n.value));
        }
        // the descent expands the pruned leaf holding `key` (the node just found)
        if let Some(n) = found {
            self.copy_down(key, n.depth, TREE_DEPTH);
        }
        Ok(())
    }

    /// OctoMap's `setNodeValue` on the occupancy with the payload bookkeeping, as
    /// [`PayloadTree::update_node`] (no early exit, and nothing before the ascent: the voxel
    /// keeps its payload). Errors on NaN, changing nothing.
    pub(crate) fn set_node_value(
        &mut self,
        key: Key,
        value: f32,
        inner: InnerNodes,
        after: impl FnOnce(&mut Self, Option<u8>),
    ) -> Result<f32, OctreeError> {
        if value.is_nan() {
            return Err(OctreeError::NanValue);
        }
        self.before_descent(key);
        self.ascend_collapsing(
            key,
            inner,
            |tree, guard| tree.set_node_value_guarded(key, value, inner, guard),
            after,
        )
    }

    /// A descent to `key` expands a pruned leaf on the path and every level below it.
    fn before_descent(&mut self, key: Key) {
        if let Some(n) = self.tree.search(key, TREE_DEPTH) {
            self.copy_down(key, n.depth, TREE_DEPTH);
        }
    }

    /// The leaf at depth `from` holding `key` is about to be expanded level by level down to
    /// depth `to`: each expansion gives the eight children the leaf's payload (`copyData`).
    fn copy_down(&mut self, key: Key, from: u8, to: u8) {
        if from >= to {
            return; // nothing is expanded
        }
        for d in from..to {
            if !copy_to_children(&mut self.payloads, node_id(key, d)) {
                return; // the new children are unset too, and theirs below
            }
        }
    }

    /// The eight children of `id` were just collapsed into it: their entries go and it takes
    /// [`NodePayload::collapsed`] of their payloads.
    fn collapse(&mut self, id: NodeId) {
        collapse_into(&mut self.payloads, id);
    }

    /// Collapse every node whose eight children are leaves of equal occupancy and whose
    /// payloads allow it, level by level as OctoMap's `prune()`.
    pub(crate) fn prune(&mut self) {
        if self.tree.is_empty() {
            return;
        }
        for depth in (1..TREE_DEPTH).rev() {
            let pruned = self.prune_level(NodeRef::ROOT, node_id(Key::default(), 0), depth);
            if pruned == 0 {
                break;
            }
            self.tree.sub_size(8 * pruned);
        }
    }

    /// One level of [`PayloadTree::prune`]: collapse what can be at depth `target` below `n`
    /// (node `id`); returns how many nodes were collapsed.
    fn prune_level(&mut self, n: NodeRef, id: NodeId, target: u8) -> usize {
        if n.depth == target {
            if payloads_may_collapse(&self.payloads, id) && self.tree.store.prune_node(n) {
                self.collapse(id);
                return 1;
            }
            return 0;
        }
        let mut count = 0;
        for i in 0..8 {
            if let Some(c) = self.tree.store.child(n, i) {
                count += self.prune_level(c, child_id(id, i), target);
            }
        }
        count
    }

    /// [`PayloadTree::expand`] unless it would add more than `max_nodes` nodes (as
    /// [`OcTree::try_expand`]); the nodes added.
    pub(crate) fn try_expand(&mut self, max_nodes: u64) -> Result<u64, OctreeError> {
        let nodes = crate::tree_prune::check_expansion(self.tree.expansion_nodes(), max_nodes)?;
        self.expand();
        Ok(nodes)
    }

    /// Give every leaf above depth 16 eight children, recursively (OctoMap's `expand()`);
    /// each child takes its parent's occupancy and payload.
    pub(crate) fn expand(&mut self) {
        if !self.tree.is_empty() {
            self.expand_recurs(NodeRef::ROOT, node_id(Key::default(), 0));
        }
    }

    /// [`PayloadTree::expand`] below `n` (node `id`).
    fn expand_recurs(&mut self, n: NodeRef, id: NodeId) {
        if n.depth >= TREE_DEPTH {
            return;
        }
        if !self.tree.store.has_children(n) {
            self.tree.store.expand_node(n);
            self.tree.add_size(8);
            let (depth, key) = id;
            self.copy_down(key, depth, depth + 1);
        }
        for i in 0..8 {
            if let Some(c) = self.tree.store.child(n, i) {
                self.expand_recurs(c, child_id(id, i));
            }
        }
    }

    /// Bring every inner node up to date, bottom-up (OctoMap's `updateInnerOccupancy`):
    /// occupancy to the max of its children, payload to `rule` of its children's payloads
    /// (unset for a missing child).
    pub(crate) fn update_inner_occupancy(&mut self, rule: impl Fn([P; 8]) -> P + Copy) {
        if self.tree.is_empty() {
            return;
        }
        self.tree.update_inner_occupancy();
        self.inner_payloads(NodeRef::ROOT, node_id(Key::default(), 0), rule);
    }

    /// [`PayloadTree::update_inner_occupancy`] for a rule that gives every inner node the same
    /// payload `p` whatever its children hold (the stamped tree's `now`): the leaves' payloads
    /// are not looked up.
    pub(crate) fn update_inner_occupancy_to(&mut self, p: P) {
        if self.tree.is_empty() {
            return;
        }
        self.tree.update_inner_occupancy();
        let mut stack = vec![(NodeRef::ROOT, node_id(Key::default(), 0))];
        while let Some((n, id)) = stack.pop() {
            if !self.tree.store.has_children(n) {
                continue;
            }
            self.set(id, p);
            for i in 0..8 {
                if let Some(c) = self.tree.store.child(n, i) {
                    stack.push((c, child_id(id, i)));
                }
            }
        }
    }

    /// The payload half of `updateInnerOccupancyRecurs` below `n` (node `id`); returns the
    /// node's payload.
    fn inner_payloads(&mut self, n: NodeRef, id: NodeId, rule: impl Fn([P; 8]) -> P + Copy) -> P {
        if !self.tree.store.has_children(n) {
            return self.get(id);
        }
        let mut kids = [P::UNSET; 8];
        for (i, k) in kids.iter_mut().enumerate() {
            if let Some(c) = self.tree.store.child(n, i) {
                *k = self.inner_payloads(c, child_id(id, i), rule);
            }
        }
        let p = rule(kids);
        self.set(id, p);
        p
    }

    /// Delete the node at `depth` holding `key` with its subtree (OctoMap's `deleteNode`, see
    /// [`OcTree::delete_node`]): the payloads of the deleted nodes go with them, and pruned
    /// nodes expanded on the way hand theirs to their children. Returns the deepest node left
    /// on the path (it has children unless it is the root), `None` when nothing was deleted.
    pub(crate) fn delete_node(&mut self, key: Key, depth: u8) -> Option<NodeInfo> {
        let depth = if depth == 0 || depth > TREE_DEPTH {
            TREE_DEPTH
        } else {
            depth
        };
        let found = self.tree.search(key, depth)?;
        // OctoMap expands a pruned leaf on the way (never the root) down to the target depth
        if found.depth < depth && !found.has_children && found.depth > 0 {
            self.copy_down(key, found.depth, depth);
        }
        if found.depth == depth {
            self.forget_subtree(key, depth);
        }
        if !self.tree.delete_node(key, depth) {
            return None;
        }
        // the target and the ancestors left without children are gone (never the root)
        for d in (1..=depth).rev() {
            if let Some(n) = self.tree.node_at_depth(key, d) {
                return Some(n);
            }
            self.payloads.remove(node_id(key, d));
        }
        Some(
            self.tree
                .node_at_depth(key, 0)
                .expect("the root is never deleted"),
        )
    }

    /// The node at exactly `depth` holding `key`, with its payload (`None` when no node exists
    /// there).
    pub(crate) fn node_at_depth(&self, key: Key, depth: u8) -> Option<(NodeInfo, P)> {
        let node = self.tree.node_at_depth(key, depth)?;
        Some((node, self.get(node_id(key, depth))))
    }

    /// Child `i` of the node at exactly `depth` holding `key`, with its payload; `None` when
    /// either does not exist.
    pub(crate) fn node_child(&self, key: Key, depth: u8, i: usize) -> Option<(NodeInfo, P)> {
        self.tree.node_child(key, depth, i)?;
        self.node_at_depth(OcTree::child_key(key, depth, i)?, depth + 1)
    }

    /// OctoMap's `expandNode` on the childless node at exactly `depth` holding `key`: eight
    /// children with its occupancy and its payload (`copyData`). `false`, changing nothing,
    /// when there is no such node, it has children or it is a voxel.
    pub(crate) fn expand_node(&mut self, key: Key, depth: u8) -> bool {
        if !self.tree.expand_node(key, depth) {
            return false;
        }
        copy_to_children(&mut self.payloads, node_id(key, depth));
        true
    }

    /// OctoMap's `isNodeCollapsible` for the payload type: the node at exactly `depth` holding
    /// `key` has eight childless children of equal occupancy, and their payloads allow the
    /// collapse ([`NodePayload::may_collapse`], OctoMap's node comparison).
    pub(crate) fn is_node_collapsible(&self, key: Key, depth: u8) -> bool {
        self.tree.is_node_collapsible(key, depth)
            && payloads_may_collapse(&self.payloads, node_id(key, depth))
    }

    /// OctoMap's `pruneNode` for the payload type: when the node is collapsible
    /// ([`PayloadTree::is_node_collapsible`]), its children go and it takes their occupancy
    /// and [`NodePayload::collapsed`] of their payloads. Returns whether it pruned.
    pub(crate) fn prune_node(&mut self, key: Key, depth: u8) -> bool {
        if !self.is_node_collapsible(key, depth) || !self.tree.prune_node(key, depth) {
            return false;
        }
        collapse_into(&mut self.payloads, node_id(key, depth));
        true
    }

    /// OctoMap's `createNodeChild`: child `i` of the node at exactly `depth` holding `key`,
    /// new with log-odds 0 and an unset payload; `None` when it exists already, the node does
    /// not, or it is a voxel.
    pub(crate) fn create_node_child(&mut self, key: Key, depth: u8, i: usize) -> Option<NodeInfo> {
        // no entry to clear: the table holds payloads of existing nodes only
        self.tree.create_node_child(key, depth, i)
    }

    /// OctoMap's `deleteNodeChild`: child `i` of the node at exactly `depth` holding `key` and
    /// its subtree go, with their payloads. Returns the nodes removed (0 when the child does
    /// not exist).
    pub(crate) fn delete_node_child(&mut self, key: Key, depth: u8, i: usize) -> usize {
        if self.tree.node_child_exists(key, depth, i) != Some(true) {
            return 0;
        }
        let Some(child) = OcTree::child_key(key, depth, i) else {
            return 0;
        };
        self.forget_subtree(child, depth + 1);
        self.payloads.remove(node_id(child, depth + 1));
        self.tree.delete_node_child(key, depth, i)
    }

    /// Remove the payloads of the strict descendants of the node at `depth` holding `key`.
    fn forget_subtree(&mut self, key: Key, depth: u8) {
        if self.payloads.is_empty() {
            return;
        }
        let Some(start) = self.tree.search_ref(key, depth) else {
            return;
        };
        let mut stack = vec![(start, node_id(key, depth))];
        while let Some((n, id)) = stack.pop() {
            for i in 0..8 {
                if let Some(c) = self.tree.store.child(n, i) {
                    let cid = child_id(id, i);
                    self.payloads.remove(cid);
                    stack.push((c, cid));
                }
            }
        }
    }
}

/// Node `id` was just expanded: its eight children take its payload (OctoMap's `copyData`).
/// Returns whether that payload is set (an unset one adds no entry).
pub(crate) fn copy_to_children<P: NodePayload>(payloads: &mut NodeMap<P>, id: NodeId) -> bool {
    let p = payloads.get(id);
    if p == P::UNSET {
        return false;
    }
    payloads.set_children(id, p);
    true
}

/// Whether the eight children of `id` may be collapsed by their payloads
/// ([`NodePayload::may_collapse`]).
pub(crate) fn payloads_may_collapse<P: NodePayload>(payloads: &NodeMap<P>, id: NodeId) -> bool {
    let kids = payloads.children(id);
    P::may_collapse(|i| kids[i])
}

/// The eight children of `id` were just collapsed into it: their entries go and it takes
/// [`NodePayload::collapsed`] of their payloads.
pub(crate) fn collapse_into<P: NodePayload>(payloads: &mut NodeMap<P>, id: NodeId) {
    let kids = payloads.remove_children(id);
    payloads.insert(id, P::collapsed(kids));
}
