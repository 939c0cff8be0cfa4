//! OctoMap's `ColorOcTree`: an occupancy octree whose nodes also carry an RGB colour.
//!
//! # Representation
//!
//! A [`ColorOcTree`] is an [`OcTree`] for the occupancy plus a side table of colours keyed by
//! node (depth and smallest voxel key). Only nodes whose colour is *set* (not white, see
//! [`Color::is_set`]) have an entry; every other node is white, which is exactly OctoMap's
//! default. Why beside the tree and not inside the store: the store packs depth-16 voxels as
//! 2-byte palette indices in 16-byte blocks, which is what makes plain maps 4-8 bytes per node;
//! a colour per node there would triple the voxel blocks of every map, coloured or not, and
//! touch the hot update paths the ray insertion relies on. Beside it, plain `OcTree`s pay
//! nothing, and a coloured map pays only for its coloured nodes.
//!
//! The price is bookkeeping: every structural change OctoMap makes (creating, expanding,
//! pruning, deleting nodes) must be mirrored in the table. Each operation here first notes
//! where the occupancy tree will expand (a pruned leaf on the path), lets [`OcTree`] do the
//! occupancy work, then reads which nodes on the path were pruned and applies OctoMap's colour
//! rules to them, bottom-up as `updateNodeRecurs` does. The table holds entries only for
//! existing nodes, so a node created later starts white.
//!
//! # OctoMap's colour semantics (1.9.7), reproduced
//!
//! - New nodes are white; occupancy updates never change colours except through the structure:
//!   expanding a pruned node gives its eight children its colour (`copyData`); pruning a node
//!   whose eight children are equal-valued leaves (colours are *not* compared) gives it child
//!   0's colour, replaced by the average colour of the children when child 0 has one.
//! - [`ColorOcTree::set_node_color`], [`ColorOcTree::average_node_color`] and
//!   [`ColorOcTree::integrate_node_color`] act on the node `search` finds (the voxel, or the
//!   pruned leaf covering it) and do nothing in unknown space.
//! - Eager updates refresh inner occupancy only; inner colours change only through
//!   [`ColorOcTree::update_inner_occupancy`] (the average of the children that have a colour,
//!   white when none has). [`ColorOcTree::to_max_likelihood`] changes no colour.

use crate::color::Color;
use crate::error::OctreeError;
use crate::key::{Key, KeyConverter, TREE_DEPTH};
pub(crate) use crate::node_id::{child_id, node_id, NodeId};
use crate::params::OccupancyParams;
use crate::store::NodeRef;
use crate::tree::{InnerNodes, NodeInfo, OcTree, Update};
use nalgebra::Point3;
use std::collections::HashMap;

/// A node of a [`ColorOcTree`] found by [`ColorOcTree::search`]: occupancy and colour.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ColorNodeInfo {
    /// The node's occupancy (log-odds, depth, whether it has children).
    pub node: NodeInfo,
    /// Its colour (white when none was set).
    pub color: Color,
}

/// OctoMap's `ColorOcTree`: occupancy log-odds and an RGB colour per node, with OctoMap
/// 1.9.7's colour rules and `.ot` bytes (see the module docs for the rules and the layout).
#[derive(Clone)]
pub struct ColorOcTree {
    pub(crate) tree: OcTree,
    /// Colours of the nodes whose colour is set (not white).
    pub(crate) colors: HashMap<NodeId, Color>,
}

impl std::fmt::Debug for ColorOcTree {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ColorOcTree")
            .field("resolution", &self.resolution())
            .field("size", &self.size())
            .field("colored_nodes", &self.colors.len())
            .finish()
    }
}

impl ColorOcTree {
    /// An empty tree with leaf size `resolution` and OctoMap's default sensor model.
    pub fn new(resolution: f64) -> Result<Self, OctreeError> {
        Ok(Self::from_occupancy(OcTree::new(resolution)?))
    }

    /// An empty tree with the given sensor model.
    pub fn with_params(resolution: f64, params: OccupancyParams) -> Result<Self, OctreeError> {
        Ok(Self::from_occupancy(OcTree::with_params(
            resolution, params,
        )?))
    }

    /// A colour tree over an existing occupancy tree, every node white (how OctoMap reads an
    /// `OcTree` into a `ColorOcTree`).
    pub fn from_occupancy(tree: OcTree) -> Self {
        ColorOcTree {
            tree,
            colors: HashMap::new(),
        }
    }

    /// The occupancy tree, for every read-only query `OcTree` offers (search, iteration,
    /// bounds, `.bt` export of a copy, ...).
    pub fn occupancy(&self) -> &OcTree {
        &self.tree
    }

    /// Drop the colours and keep the occupancy tree.
    pub fn into_occupancy(self) -> OcTree {
        self.tree
    }

    /// Leaf edge length in metres.
    pub fn resolution(&self) -> f64 {
        self.tree.resolution()
    }

    /// The coordinate <-> key converter.
    pub fn converter(&self) -> &KeyConverter {
        self.tree.converter()
    }

    /// The sensor model.
    pub fn params(&self) -> &OccupancyParams {
        self.tree.params()
    }

    /// Replace the sensor model; node values and colours are kept.
    pub fn set_params(&mut self, params: OccupancyParams) {
        self.tree.set_params(params);
    }

    /// Number of nodes (OctoMap's `size()`).
    pub fn size(&self) -> usize {
        self.tree.size()
    }

    /// `true` when the tree has no root.
    pub fn is_empty(&self) -> bool {
        self.tree.is_empty()
    }

    /// Number of nodes whose colour is set (not white).
    pub fn num_colored_nodes(&self) -> usize {
        self.colors.len()
    }

    /// Remove every node and colour.
    pub fn clear(&mut self) {
        self.tree.clear();
        self.colors.clear();
    }

    pub(crate) fn color_of(&self, id: NodeId) -> Color {
        self.colors.get(&id).copied().unwrap_or(Color::WHITE)
    }

    pub(crate) fn put_color(&mut self, id: NodeId, c: Color) {
        if c.is_set() {
            self.colors.insert(id, c);
        } else {
            self.colors.remove(&id);
        }
    }

    /// The node `search` finds for `key` at `depth` (16 = voxel), with its colour; `None` in
    /// unknown space.
    pub fn search(&self, key: Key, depth: u8) -> Option<ColorNodeInfo> {
        let node = self.tree.search(key, depth)?;
        Some(ColorNodeInfo {
            node,
            color: self.color_of(node_id(key, node.depth)),
        })
    }

    /// The colour of the node holding voxel `key` (the voxel or the pruned leaf covering it);
    /// `None` in unknown space.
    pub fn node_color(&self, key: Key) -> Option<Color> {
        self.search(key, TREE_DEPTH).map(|n| n.color)
    }

    /// The colour of the node at exactly `depth` holding `key` (inner, leaf or pruned leaf);
    /// `None` when no node exists there. What iterators and `ColorOcTreeNode::getColor` read.
    pub fn color_at(&self, key: Key, depth: u8) -> Option<Color> {
        self.tree.node_at_depth(key, depth)?;
        Some(self.color_of(node_id(key, depth)))
    }

    /// Set the colour of the node at exactly `depth` holding `key` (OctoMap's
    /// `ColorOcTreeNode::setColor` on a node in hand, inner nodes included); `false` and no
    /// change when no node exists there.
    pub fn set_color_at(&mut self, key: Key, depth: u8, color: Color) -> bool {
        if self.tree.node_at_depth(key, depth).is_none() {
            return false;
        }
        self.put_color(node_id(key, depth), color);
        true
    }

    /// OctoMap's `getAverageChildColor` of the node at exactly `depth` holding `key`: the mean
    /// colour of its existing children that have one, white when none has (or it has no
    /// children); `None` when no node exists there.
    pub fn average_child_color(&self, key: Key, depth: u8) -> Option<Color> {
        self.tree.node_at_depth(key, depth)?;
        if depth >= TREE_DEPTH {
            return Some(Color::WHITE);
        }
        let id = node_id(key, depth);
        let kids = (0..8).filter_map(|i| {
            let (d, k) = child_id(id, i);
            self.tree.node_at_depth(k, d).map(|_| self.color_of((d, k)))
        });
        Some(Color::average_of(kids))
    }

    /// Integrate one occupancy observation of voxel `key` (OctoMap's `updateNode`), with the
    /// colour bookkeeping of the expansions and prunings it causes. Returns the voxel's new
    /// log-odds.
    pub fn update_node(&mut self, key: Key, update: Update, inner: InnerNodes) -> f32 {
        let delta = self.tree.delta(update);
        if let Some(n) = self.tree.search(key, TREE_DEPTH) {
            let p = self.tree.params();
            if (delta >= 0.0 && n.value >= p.clamp_max) || (delta <= 0.0 && n.value <= p.clamp_min)
            {
                return n.value; // OctoMap's early exit: nothing changes
            }
        }
        if delta.is_nan() {
            return self.tree.update_node(key, update, inner);
        }
        self.before_descent(key);
        let v = self.tree.update_node(key, update, inner);
        self.after_descent(key, inner);
        v
    }

    /// Set voxel `key` to `value` clamped to the sensor model's bounds (OctoMap's
    /// `setNodeValue`), with the colour bookkeeping. Errors on NaN.
    pub fn set_node_value(
        &mut self,
        key: Key,
        value: f32,
        inner: InnerNodes,
    ) -> Result<f32, OctreeError> {
        if value.is_nan() {
            return Err(OctreeError::NanValue);
        }
        self.before_descent(key);
        let v = self.tree.set_node_value(key, value, inner)?;
        self.after_descent(key, inner);
        Ok(v)
    }

    /// Integrate an observation of the voxel containing `point`; errors outside the map.
    pub fn update_point(
        &mut self,
        point: &Point3<f64>,
        update: Update,
        inner: InnerNodes,
    ) -> Result<f32, OctreeError> {
        let key = self.converter().point_to_key_checked(point)?;
        Ok(self.update_node(key, update, inner))
    }

    /// A descent to `key` expands a pruned leaf on the path, and every level below it: each
    /// expansion gives the eight children the colour of the expanded node (`copyData`).
    fn before_descent(&mut self, key: Key) {
        let Some(n) = self.tree.search(key, TREE_DEPTH) else {
            return; // unknown space: nodes are created white
        };
        if n.depth >= TREE_DEPTH {
            return;
        }
        let c = self.color_of(node_id(key, n.depth));
        if !c.is_set() {
            return;
        }
        for d in n.depth..TREE_DEPTH {
            let id = node_id(key, d);
            for i in 0..8 {
                self.colors.insert(child_id(id, i), c);
            }
        }
    }

    /// After an eager descent, the ancestors of `key` that are now leaves were pruned, deepest
    /// first: apply the pruning colour rule to each in that order.
    fn after_descent(&mut self, key: Key, inner: InnerNodes) {
        if inner.is_deferred() {
            return;
        }
        let Some(n) = self.tree.search(key, TREE_DEPTH) else {
            return;
        };
        for d in (n.depth..TREE_DEPTH).rev() {
            self.prune_colors(node_id(key, d));
        }
    }

    /// `ColorOcTree::pruneNode`'s colour rule for the node `id` whose eight children were just
    /// collapsed into it: child 0's colour, or the children's average colour when child 0 has
    /// one. The children's entries go.
    pub(crate) fn prune_colors(&mut self, id: NodeId) {
        let kids: [Color; 8] =
            std::array::from_fn(|i| self.colors.remove(&child_id(id, i)).unwrap_or(Color::WHITE));
        let c = if kids[0].is_set() {
            Color::average_of(kids)
        } else {
            kids[0]
        };
        self.put_color(id, c);
    }

    /// The node holding voxel `key` (the voxel, or a pruned leaf covering it), or `None`.
    fn found(&self, key: Key) -> Option<(NodeId, f32)> {
        let n = self.tree.search(key, TREE_DEPTH)?;
        Some((node_id(key, n.depth), n.value))
    }

    /// Set the colour of the node holding `key`, replacing the old one (OctoMap's
    /// `setNodeColor`). Returns the node's new colour, `None` (and no change) in unknown space.
    pub fn set_node_color(&mut self, key: Key, color: Color) -> Option<Color> {
        let (id, _) = self.found(key)?;
        self.put_color(id, color);
        Some(color)
    }

    /// Average `color` into the node holding `key` (OctoMap's `averageNodeColor`: the integer
    /// mean with the old colour, or `color` when it had none). Returns the new colour, `None`
    /// in unknown space.
    pub fn average_node_color(&mut self, key: Key, color: Color) -> Option<Color> {
        let (id, _) = self.found(key)?;
        let c = self.color_of(id).averaged_with(color);
        self.put_color(id, c);
        Some(c)
    }

    /// Integrate `color` into the node holding `key`, weighted by its occupancy (OctoMap's
    /// `integrateNodeColor`: `old·p + color·(0.99 − p)` with `p` the node's probability, or
    /// `color` when it had none). Returns the new colour, `None` in unknown space.
    pub fn integrate_node_color(&mut self, key: Key, color: Color) -> Option<Color> {
        let (id, v) = self.found(key)?;
        let p = crate::params::probability(f64::from(v));
        let c = self.color_of(id).integrated_with(color, p);
        self.put_color(id, c);
        Some(c)
    }

    /// Collapse every node whose eight children are leaves of equal occupancy, level by level
    /// as OctoMap's `prune()`, with `ColorOcTree::pruneNode`'s colour rule (colours do not
    /// stop a collapse).
    pub fn prune(&mut self) {
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

    fn prune_level(&mut self, n: NodeRef, id: NodeId, target: u8) -> usize {
        if n.depth == target {
            if self.tree.store.prune_node(n) {
                self.prune_colors(id);
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

    /// Give every leaf above depth 16 eight children, recursively (OctoMap's `expand()`);
    /// each child takes its parent's occupancy and colour.
    pub fn expand(&mut self) {
        if !self.tree.is_empty() {
            self.expand_recurs(NodeRef::ROOT, node_id(Key::default(), 0));
        }
    }

    fn expand_recurs(&mut self, n: NodeRef, id: NodeId) {
        if n.depth >= TREE_DEPTH {
            return;
        }
        if !self.tree.store.has_children(n) {
            self.tree.store.expand_node(n);
            self.tree.add_size(8);
            let c = self.color_of(id);
            if c.is_set() {
                for i in 0..8 {
                    self.colors.insert(child_id(id, i), c);
                }
            }
        }
        for i in 0..8 {
            if let Some(c) = self.tree.store.child(n, i) {
                self.expand_recurs(c, child_id(id, i));
            }
        }
    }

    /// Set every node to the clamp its occupancy points to (OctoMap's `toMaxLikelihood()`);
    /// colours are untouched.
    pub fn to_max_likelihood(&mut self) {
        self.tree.to_max_likelihood();
    }

    /// Bring every inner node up to date, bottom-up: occupancy to the max of its children and
    /// colour to the average of the children that have one (`ColorOcTree::updateInnerOccupancy`).
    pub fn update_inner_occupancy(&mut self) {
        if self.tree.is_empty() {
            return;
        }
        self.tree.update_inner_occupancy();
        self.inner_colors(NodeRef::ROOT, node_id(Key::default(), 0));
    }

    /// The colour half of `updateInnerOccupancyRecurs`; returns the node's colour.
    fn inner_colors(&mut self, n: NodeRef, id: NodeId) -> Color {
        if !self.tree.store.has_children(n) {
            return self.color_of(id);
        }
        let mut kids = [Color::WHITE; 8];
        for (i, k) in kids.iter_mut().enumerate() {
            if let Some(c) = self.tree.store.child(n, i) {
                *k = self.inner_colors(c, child_id(id, i));
            }
        }
        let c = Color::average_of(kids);
        self.put_color(id, c);
        c
    }

    /// Delete the node at `depth` holding `key` with its subtree (OctoMap's `deleteNode`, see
    /// [`OcTree::delete_node`]); the colours of the deleted nodes go with them, and pruned
    /// nodes expanded on the way hand theirs to their children. Returns whether anything was
    /// deleted.
    pub fn delete_node(&mut self, key: Key, depth: u8) -> bool {
        let depth = if depth == 0 || depth > TREE_DEPTH {
            TREE_DEPTH
        } else {
            depth
        };
        let Some(found) = self.tree.search(key, depth) else {
            return false;
        };
        // OctoMap expands a pruned leaf on the way (never the root) down to the target depth
        if found.depth < depth && !found.has_children && found.depth > 0 {
            let c = self.color_of(node_id(key, found.depth));
            if c.is_set() {
                for d in found.depth..depth {
                    let id = node_id(key, d);
                    for i in 0..8 {
                        self.colors.insert(child_id(id, i), c);
                    }
                }
            }
        }
        if found.depth == depth {
            self.forget_subtree(key, depth);
        }
        if !self.tree.delete_node(key, depth) {
            return false;
        }
        // the target and the ancestors left without children are gone (never the root)
        for d in (1..=depth).rev() {
            if self.tree.node_at_depth(key, d).is_some() {
                break;
            }
            self.colors.remove(&node_id(key, d));
        }
        true
    }

    /// Remove the colours of the strict descendants of the node at `depth` holding `key`.
    fn forget_subtree(&mut self, key: Key, depth: u8) {
        if self.colors.is_empty() {
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
                    self.colors.remove(&cid);
                    stack.push((c, cid));
                }
            }
        }
    }
}

#[cfg(test)]
#[path = "color_tree_tests.rs"]
mod tests;
