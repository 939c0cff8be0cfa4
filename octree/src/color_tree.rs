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
//! existing nodes, so a node created later starts white. That bookkeeping is the same for
//! every per-node payload and lives in `payload_tree`; this module gives it the colour rules
//! (`NodePayload` for `Color`) and the colour operations.
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
use crate::node_id::{child_id, node_id, NodeId};
use crate::params::OccupancyParams;
use crate::payload_tree::{NodePayload, PayloadTree};
use crate::tree::{InnerNodes, NodeInfo, OcTree, Update};
use nalgebra::Point3;

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
    /// The occupancy and the colours of the nodes whose colour is set (not white).
    pub(crate) base: PayloadTree<Color>,
}

/// `ColorOcTree::pruneNode`'s colour rule: colours never stop a collapse (only the occupancy
/// is compared), and the collapsed node takes child 0's colour, or the children's average
/// colour when child 0 has one.
impl NodePayload for Color {
    const UNSET: Color = Color::WHITE;

    fn may_collapse(_child: impl Fn(usize) -> Color) -> bool {
        true
    }

    fn collapsed(children: [Color; 8]) -> Color {
        if children[0].is_set() {
            Color::average_of(children)
        } else {
            children[0]
        }
    }
}

impl std::fmt::Debug for ColorOcTree {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ColorOcTree")
            .field("resolution", &self.resolution())
            .field("size", &self.size())
            .field("colored_nodes", &self.num_colored_nodes())
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
            base: PayloadTree::new(tree),
        }
    }

    /// The occupancy tree, for every read-only query `OcTree` offers (search, iteration,
    /// bounds, `.bt` export of a copy, ...).
    pub fn occupancy(&self) -> &OcTree {
        &self.base.tree
    }

    /// Drop the colours and keep the occupancy tree.
    pub fn into_occupancy(self) -> OcTree {
        self.base.tree
    }

    /// Leaf edge length in metres.
    pub fn resolution(&self) -> f64 {
        self.base.tree.resolution()
    }

    /// The coordinate <-> key converter.
    pub fn converter(&self) -> &KeyConverter {
        self.base.tree.converter()
    }

    /// The sensor model.
    pub fn params(&self) -> &OccupancyParams {
        self.base.tree.params()
    }

    /// Change the leaf size (OctoMap's `setResolution`, see [`OcTree::set_resolution`]).
    pub fn set_resolution(&mut self, resolution: f64) -> Result<(), OctreeError> {
        self.base.tree.set_resolution(resolution)
    }

    /// Replace the sensor model; node values and colours are kept.
    pub fn set_params(&mut self, params: OccupancyParams) {
        self.base.tree.set_params(params);
    }

    /// Number of nodes (OctoMap's `size()`).
    pub fn size(&self) -> usize {
        self.base.tree.size()
    }

    /// `true` when the tree has no root.
    pub fn is_empty(&self) -> bool {
        self.base.tree.is_empty()
    }

    /// Bytes held by the node storage ([`OcTree::memory_usage`]) and the colours' side table:
    /// what the tree costs in memory, where `occupancy().memory_usage()` leaves the colours
    /// out.
    pub fn memory_usage(&self) -> usize {
        self.base.memory_usage()
    }

    /// Number of nodes whose colour is set (not white).
    pub fn num_colored_nodes(&self) -> usize {
        self.base.payloads.len()
    }

    /// Remove every node and colour.
    pub fn clear(&mut self) {
        self.base.clear();
    }

    /// The colour of node `id` (white when none is set).
    pub(crate) fn color_of(&self, id: NodeId) -> Color {
        self.base.get(id)
    }

    /// Give node `id` the colour `c` (white removes its entry).
    pub(crate) fn put_color(&mut self, id: NodeId, c: Color) {
        self.base.set(id, c);
    }

    /// The node `search` finds for `key` at `depth` (16 = voxel), with its colour; `None` in
    /// unknown space.
    pub fn search(&self, key: Key, depth: u8) -> Option<ColorNodeInfo> {
        let (node, color) = self.base.search(key, depth)?;
        Some(ColorNodeInfo { node, color })
    }

    /// The colour of the node holding voxel `key` (the voxel or the pruned leaf covering it);
    /// `None` in unknown space.
    pub fn node_color(&self, key: Key) -> Option<Color> {
        self.search(key, TREE_DEPTH).map(|n| n.color)
    }

    /// The colour of the node at exactly `depth` holding `key` (inner, leaf or pruned leaf);
    /// `None` when no node exists there. What iterators and `ColorOcTreeNode::getColor` read.
    pub fn color_at(&self, key: Key, depth: u8) -> Option<Color> {
        self.base.tree.node_at_depth(key, depth)?;
        Some(self.color_of(node_id(key, depth)))
    }

    /// Set the colour of the node at exactly `depth` holding `key` (OctoMap's
    /// `ColorOcTreeNode::setColor` on a node in hand, inner nodes included); `false` and no
    /// change when no node exists there.
    pub fn set_color_at(&mut self, key: Key, depth: u8, color: Color) -> bool {
        if self.base.tree.node_at_depth(key, depth).is_none() {
            return false;
        }
        self.put_color(node_id(key, depth), color);
        true
    }

    /// OctoMap's `getAverageChildColor` of the node at exactly `depth` holding `key`: the mean
    /// colour of its existing children that have one, white when none has (or it has no
    /// children); `None` when no node exists there.
    pub fn average_child_color(&self, key: Key, depth: u8) -> Option<Color> {
        self.base.tree.node_at_depth(key, depth)?;
        if depth >= TREE_DEPTH {
            return Some(Color::WHITE);
        }
        let id = node_id(key, depth);
        let kids = (0..8).filter_map(|i| {
            let (d, k) = child_id(id, i);
            self.base
                .tree
                .node_at_depth(k, d)
                .map(|_| self.color_of((d, k)))
        });
        Some(Color::average_of(kids))
    }

    /// Integrate one occupancy observation of voxel `key` (OctoMap's `updateNode`), with the
    /// colour bookkeeping of the expansions and prunings it causes. Returns the voxel's new
    /// log-odds.
    pub fn update_node(&mut self, key: Key, update: Update, inner: InnerNodes) -> f32 {
        // colours never stop a prune: each collapse averages them on the way up
        self.base.update_node(key, update, inner, |_| {}, |_, _| {})
    }

    /// Set voxel `key` to `value` clamped to the sensor model's bounds (OctoMap's
    /// `setNodeValue`), with the colour bookkeeping. Errors on NaN.
    pub fn set_node_value(
        &mut self,
        key: Key,
        value: f32,
        inner: InnerNodes,
    ) -> Result<f32, OctreeError> {
        self.base.set_node_value(key, value, inner, |_, _| {})
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

    /// The node holding voxel `key` (the voxel, or a pruned leaf covering it), or `None`.
    fn found(&self, key: Key) -> Option<(NodeId, f32)> {
        let n = self.base.tree.search(key, TREE_DEPTH)?;
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
        self.average_node_colors(key, [color])
    }

    /// [`ColorOcTree::average_node_color`] of each of `colors` in turn into the node holding
    /// `key`, with one search: averaging changes no occupancy, so every call of the run finds
    /// the same node (a scan's neighbouring points often end in one voxel). Returns the node's
    /// last colour, `None` (and no change) in unknown space.
    pub fn average_node_colors(
        &mut self,
        key: Key,
        colors: impl IntoIterator<Item = Color>,
    ) -> Option<Color> {
        self.merge_colors(key, colors, |old, c, _| old.averaged_with(c))
    }

    /// Integrate `color` into the node holding `key`, weighted by its occupancy (OctoMap's
    /// `integrateNodeColor`: `old·p + color·(0.99 − p)` with `p` the node's probability, or
    /// `color` when it had none). Returns the new colour, `None` in unknown space.
    pub fn integrate_node_color(&mut self, key: Key, color: Color) -> Option<Color> {
        self.integrate_node_colors(key, [color])
    }

    /// [`ColorOcTree::integrate_node_color`] of each of `colors` in turn into the node holding
    /// `key`, with one search (the node and its occupancy stay the same through the run).
    /// Returns the node's last colour, `None` (and no change) in unknown space.
    pub fn integrate_node_colors(
        &mut self,
        key: Key,
        colors: impl IntoIterator<Item = Color>,
    ) -> Option<Color> {
        self.merge_colors(key, colors, |old, c, p| old.integrated_with(c, p))
    }

    /// Merge `colors` in turn into the node holding `key` by `rule(old, new, p)` (`p` the
    /// node's occupancy probability, the same through the run), with one search; the node's
    /// last colour, `None` (and no change) in unknown space.
    fn merge_colors(
        &mut self,
        key: Key,
        colors: impl IntoIterator<Item = Color>,
        rule: impl Fn(Color, Color, f64) -> Color,
    ) -> Option<Color> {
        let (id, v) = self.found(key)?;
        let p = crate::params::probability(f64::from(v));
        let c = colors
            .into_iter()
            .fold(self.color_of(id), |old, c| rule(old, c, p));
        self.put_color(id, c);
        Some(c)
    }

    /// Collapse every node whose eight children are leaves of equal occupancy, level by level
    /// as OctoMap's `prune()`, with `ColorOcTree::pruneNode`'s colour rule (colours do not
    /// stop a collapse).
    pub fn prune(&mut self) {
        self.base.prune();
    }

    /// Give every leaf above depth 16 eight children, recursively (OctoMap's `expand()`);
    /// each child takes its parent's occupancy and colour.
    pub fn expand(&mut self) {
        self.base.expand();
    }

    /// [`Self::expand`], unless it would add more than `max_nodes` nodes
    /// ([`OcTree::expansion_nodes`](crate::OcTree::expansion_nodes) of the occupancy tree):
    /// then [`OctreeError::ExpansionTooLarge`] and the tree is unchanged. Returns the nodes
    /// added.
    pub fn try_expand(&mut self, max_nodes: u64) -> Result<u64, OctreeError> {
        self.base.try_expand(max_nodes)
    }

    /// Set every node to the clamp its occupancy points to (OctoMap's `toMaxLikelihood()`);
    /// colours are untouched.
    pub fn to_max_likelihood(&mut self) {
        self.base.tree.to_max_likelihood();
    }

    /// Bring every inner node up to date, bottom-up: occupancy to the max of its children and
    /// colour to the average of the children that have one (`ColorOcTree::updateInnerOccupancy`).
    pub fn update_inner_occupancy(&mut self) {
        self.base.update_inner_occupancy(Color::average_of);
    }

    /// Enable or disable change detection (OctoMap's `enableChangeDetection`), as
    /// [`OcTree::enable_change_detection`]: read the record through the occupancy tree.
    pub fn enable_change_detection(&mut self, enable: bool) {
        self.base.tree.enable_change_detection(enable);
    }

    /// Forget the changes recorded so far (OctoMap's `resetChangeDetection`).
    pub fn reset_change_detection(&mut self) {
        self.base.tree.reset_change_detection();
    }

    /// The node at exactly `depth` holding `key`, with its colour (`None` when no node exists
    /// there): a node handed out by `search`, `getNodeChild` or an iterator, looked up again.
    pub fn node_at_depth(&self, key: Key, depth: u8) -> Option<ColorNodeInfo> {
        let (node, color) = self.base.node_at_depth(key, depth)?;
        Some(ColorNodeInfo { node, color })
    }

    /// Child `i` (0..8: bit 0 x, bit 1 y, bit 2 z) of the node at exactly `depth` holding
    /// `key`, with its colour (OctoMap's `getNodeChild`); `None` when either does not exist.
    pub fn node_child(&self, key: Key, depth: u8, i: usize) -> Option<ColorNodeInfo> {
        let (node, color) = self.base.node_child(key, depth, i)?;
        Some(ColorNodeInfo { node, color })
    }

    /// OctoMap's `setValue` on a node in hand (see [`OcTree::set_node_raw_value`]); its
    /// payload is kept.
    pub fn set_node_raw_value(
        &mut self,
        key: Key,
        depth: u8,
        value: f32,
    ) -> Result<bool, OctreeError> {
        self.base.tree.set_node_raw_value(key, depth, value)
    }

    /// OctoMap's `updateNodeLogOdds` (`integrateHit`, `integrateMiss`) on a node in hand (see
    /// [`OcTree::update_node_log_odds`]); its colour is kept.
    pub fn update_node_log_odds(
        &mut self,
        key: Key,
        depth: u8,
        update: Update,
    ) -> Result<Option<f32>, OctreeError> {
        self.base.tree.update_node_log_odds(key, depth, update)
    }

    /// OctoMap's `nodeToMaxLikelihood` on a node in hand (see
    /// [`OcTree::node_to_max_likelihood`]); its colour is kept.
    pub fn node_to_max_likelihood(&mut self, key: Key, depth: u8) -> Option<f32> {
        self.base.tree.node_to_max_likelihood(key, depth)
    }

    /// OctoMap's `expandNode`: the childless node at exactly `depth` holding `key` gets eight
    /// children with its occupancy and colour (`copyData`); inner nodes above are not
    /// refreshed. `false`, changing nothing, when there is no such node, it has children or
    /// it is a voxel.
    pub fn expand_node(&mut self, key: Key, depth: u8) -> bool {
        self.base.expand_node(key, depth)
    }

    /// OctoMap's `ColorOcTree::isNodeCollapsible`: the node at exactly `depth` holding `key`
    /// has eight childless children of equal occupancy (colours are not compared).
    pub fn is_node_collapsible(&self, key: Key, depth: u8) -> bool {
        self.base.is_node_collapsible(key, depth)
    }

    /// OctoMap's `ColorOcTree::pruneNode`: a collapsible node loses its children and takes
    /// child 0's occupancy and colour, or their average colour when child 0 has one. Returns
    /// whether it pruned.
    pub fn prune_node(&mut self, key: Key, depth: u8) -> bool {
        self.base.prune_node(key, depth)
    }

    /// OctoMap's `createNodeChild`: child `i` of the node at exactly `depth` holding `key`,
    /// new with log-odds 0 and no colour (white); `None` when it exists already, the node does
    /// not, or it is a voxel.
    pub fn create_node_child(&mut self, key: Key, depth: u8, i: usize) -> Option<ColorNodeInfo> {
        let node = self.base.create_node_child(key, depth, i)?;
        Some(ColorNodeInfo {
            node,
            color: Color::WHITE,
        })
    }

    /// OctoMap's `deleteNodeChild`: child `i` of the node at exactly `depth` holding `key` and
    /// its subtree go, with their colours; inner nodes above are not refreshed. Returns the
    /// nodes removed (0 when the child does not exist).
    pub fn delete_node_child(&mut self, key: Key, depth: u8, i: usize) -> usize {
        self.base.delete_node_child(key, depth, i)
    }

    /// Delete the node at `depth` holding `key` with its subtree (OctoMap's `deleteNode`, see
    /// [`OcTree::delete_node`]); the colours of the deleted nodes go with them, and pruned
    /// nodes expanded on the way hand theirs to their children. Returns whether anything was
    /// deleted.
    pub fn delete_node(&mut self, key: Key, depth: u8) -> bool {
        self.base.delete_node(key, depth).is_some()
    }
}

#[cfg(test)]
#[path = "color_tree_tests.rs"]
mod tests;
