//! OctoMap's `OcTreeStamped`: an occupancy octree whose nodes also carry the time (whole
//! seconds, `unsigned int`) of their last update, so a long-running robot can forget what it
//! has not seen for a while ([`StampedOcTree::degrade_outdated_nodes`]).
//!
//! # Representation
//!
//! As [`ColorOcTree`](crate::ColorOcTree) keeps colours, a [`StampedOcTree`] is an [`OcTree`]
//! for the occupancy plus a side table of time stamps keyed by node (depth and smallest voxel
//! key), with an entry for every existing node whose stamp is not 0 (OctoMap's stamp of a new
//! node). The plain tree's packed voxel blocks stay as they are, and every structural change
//! OctoMap makes is mirrored in the table (the bookkeeping `payload_tree` shares with the
//! colour tree; this module gives it the stamp rules through `NodePayload` for `u32`).
//!
//! # OctoMap's stamp semantics (1.9.7), reproduced
//!
//! - A voxel an update reaches gets the current time (`updateNodeLogOdds` calls
//!   `updateTimestamp`); so does every inner node an eager update refreshes
//!   (`updateOccupancyChildren`). An update that cannot change the voxel (already at the clamp
//!   it pushes towards) returns early and refreshes nothing. Lazy updates stamp only the voxel.
//! - Nodes compare equal only with equal log-odds *and* stamps (`OcTreeNodeStamped::
//!   operator==`), so eight equal-valued leaves with different stamps are *not* pruned, unlike
//!   in a plain `OcTree`. A pruned node takes child 0's stamp; expanding a node gives its
//!   children its stamp (`copyData`).
//! - `setNodeValue` leaves the voxel's stamp alone but refreshes the inner nodes it passes;
//!   `updateInnerOccupancy` stamps every inner node; `deleteNode` stamps the parent that keeps
//!   children; `toMaxLikelihood` changes no stamp.
//! - [`StampedOcTree::degrade_outdated_nodes`] applies one miss, without a new stamp and
//!   without refreshing inner nodes (`integrateMissNoTime`), to every occupied leaf whose stamp
//!   is more than `time_thres` seconds older than now, in `unsigned int` arithmetic.
//! - `.ot` files of type `OcTreeStamped` hold only the log-odds, exactly as a plain `.ot`:
//!   OctoMap does not save stamps, and a tree read back has every stamp 0.
//!
//! OctoMap reads the clock (`time(NULL)`) inside each operation; here every operation that
//! stamps has an `_at` form taking `now` explicitly (what tests and replays of recorded data
//! need) and a plain form reading the system clock ([`now_seconds`]). A scan goes in with
//! [`StampedOcTree::insert_update_at`] from the free and occupied voxel sets that
//! `octoquant_raycast::compute_update` computes, as OctoMap's `insertPointCloud` does.
//!
//! ```
//! use octoquant_octree::{InnerNodes, Key, StampedOcTree, Update};
//!
//! let mut tree = StampedOcTree::new(0.1).unwrap();
//! let wall = Key::new(32800, 32768, 32768);
//! for t in 100..103 {
//!     tree.update_node_at(wall, Update::Hit, InnerNodes::Refresh, t);
//! }
//! assert_eq!(tree.timestamp(wall), Some(102));
//! assert_eq!(tree.last_update_time(), 102);
//! // not seen for 60 s: one miss each time the map is degraded
//! let before = tree.search(wall, 16).unwrap().node.value;
//! tree.degrade_outdated_nodes_at(30, 162);
//! assert!(tree.search(wall, 16).unwrap().node.value < before);
//! ```

use crate::error::OctreeError;
use crate::key::{Key, KeyConverter, TREE_DEPTH};
use crate::node_id::{child_id, node_id, NodeId, NodeMap};
use crate::params::OccupancyParams;
use crate::payload_tree::{
    collapse_into, copy_to_children, payloads_may_collapse, NodePayload, PayloadTree,
};
use crate::store::{clamp_sum, present, NodeRef, NO_BLOCK};
use crate::tree::{InnerNodes, NodeInfo, OcTree, Update};
use crate::tree_batch::{key_bricks, WalkHooks};

/// The current time as OctoMap stamps it: `(unsigned int) time(NULL)`, whole seconds since
/// the Unix epoch, truncated to 32 bits (0 if the clock is before the epoch).
pub fn now_seconds() -> u32 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs() as u32)
        .unwrap_or(0)
}

/// A node of a [`StampedOcTree`] found by [`StampedOcTree::search`]: occupancy and stamp.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StampedNodeInfo {
    /// The node's occupancy (log-odds, depth, whether it has children).
    pub node: NodeInfo,
    /// The time of its last update (seconds; 0 for a node never stamped).
    pub timestamp: u32,
}

/// OctoMap's `OcTreeStamped`: occupancy log-odds and a time stamp per node, with OctoMap
/// 1.9.7's stamp rules and `.ot` bytes (see the module docs).
#[derive(Clone)]
pub struct StampedOcTree {
    /// The occupancy and the stamps of the nodes whose stamp is not 0.
    pub(crate) base: PayloadTree<u32>,
}

/// A time stamp's pruning rule (`OcTreeNodeStamped::operator==` in `pruneNode`): children
/// collapse only when their stamps are equal too, and the collapsed node takes child 0's.
impl NodePayload for u32 {
    const UNSET: u32 = 0;

    fn may_collapse(child: impl Fn(usize) -> u32) -> bool {
        let t0 = child(0);
        (1..8).all(|i| child(i) == t0)
    }

    fn collapsed(children: [u32; 8]) -> u32 {
        children[0]
    }
}

impl std::fmt::Debug for StampedOcTree {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StampedOcTree")
            .field("resolution", &self.resolution())
            .field("size", &self.size())
            .field("last_update_time", &self.last_update_time())
            .finish()
    }
}

impl StampedOcTree {
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

    /// A stamped tree over an existing occupancy tree, every stamp 0 (what OctoMap's reader
    /// gives, since `.ot` files hold no stamps).
    pub fn from_occupancy(tree: OcTree) -> Self {
        StampedOcTree {
            base: PayloadTree::new(tree),
        }
    }

    /// The occupancy tree, for every read-only query `OcTree` offers.
    pub fn occupancy(&self) -> &OcTree {
        &self.base.tree
    }

    /// The occupancy tree without the stamps.
    pub fn into_occupancy(self) -> OcTree {
        self.base.tree
    }

    /// Leaf size in metres.
    pub fn resolution(&self) -> f64 {
        self.base.tree.resolution()
    }

    /// Key <-> coordinate conversion of this tree.
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

    /// Replace the sensor model; node values and stamps are kept.
    pub fn set_params(&mut self, params: OccupancyParams) {
        self.base.tree.set_params(params);
    }

    /// Number of nodes.
    pub fn size(&self) -> usize {
        self.base.tree.size()
    }

    /// Whether the tree has no node.
    pub fn is_empty(&self) -> bool {
        self.base.tree.is_empty()
    }

    /// Bytes held by the node storage ([`OcTree::memory_usage`]) and the stamps' side table:
    /// what the tree costs in memory, where `occupancy().memory_usage()` leaves the stamps
    /// out.
    pub fn memory_usage(&self) -> usize {
        self.base.memory_usage()
    }

    /// Remove every node.
    pub fn clear(&mut self) {
        self.base.clear();
    }

    /// The stamp of node `id` (0 when it has none).
    pub(crate) fn stamp_of(&self, id: NodeId) -> u32 {
        self.base.get(id)
    }

    /// The node `search` finds for `key` at `depth` (16 = voxel), with its stamp; `None` in
    /// unknown space.
    pub fn search(&self, key: Key, depth: u8) -> Option<StampedNodeInfo> {
        let (node, timestamp) = self.base.search(key, depth)?;
        Some(StampedNodeInfo { node, timestamp })
    }

    /// The stamp of the node holding voxel `key` (the voxel or the pruned leaf covering it);
    /// `None` in unknown space.
    pub fn timestamp(&self, key: Key) -> Option<u32> {
        self.search(key, TREE_DEPTH).map(|n| n.timestamp)
    }

    /// The root's stamp (OctoMap's `getLastUpdateTime`): the time of the last eager update
    /// anywhere in the tree; 0 for an empty tree.
    pub fn last_update_time(&self) -> u32 {
        if self.base.tree.is_empty() {
            0
        } else {
            self.stamp_of(node_id(Key::default(), 0))
        }
    }

    /// [`StampedOcTree::update_node_at`] at the system clock's time.
    pub fn update_node(&mut self, key: Key, update: Update, inner: InnerNodes) -> f32 {
        self.update_node_at(key, update, inner, now_seconds())
    }

    /// Integrate one observation of voxel `key` at time `now` (OctoMap's `updateNode` on an
    /// `OcTreeStamped` whose clock reads `now`). Returns the voxel's new log-odds.
    pub fn update_node_at(&mut self, key: Key, update: Update, inner: InnerNodes, now: u32) -> f32 {
        // as `updateNodeRecurs`: the voxel gets `now` before its parents compare it, a parent
        // is pruned only where its eight children also have equal stamps (taking child 0's),
        // and every ancestor left with children gets `now`
        self.base.update_node(
            key,
            update,
            inner,
            |b| b.set(node_id(key, TREE_DEPTH), now),
            |b, held| stamp_ancestors(b, key, held, now),
        )
    }

    /// [`StampedOcTree::set_node_value_at`] at the system clock's time.
    pub fn set_node_value(
        &mut self,
        key: Key,
        value: f32,
        inner: InnerNodes,
    ) -> Result<f32, OctreeError> {
        self.set_node_value_at(key, value, inner, now_seconds())
    }

    /// Set voxel `key` to `value` clamped to the sensor model's bounds (OctoMap's
    /// `setNodeValue`): the voxel keeps its stamp, the inner nodes refreshed on the way get
    /// `now`. Errors on NaN.
    pub fn set_node_value_at(
        &mut self,
        key: Key,
        value: f32,
        inner: InnerNodes,
        now: u32,
    ) -> Result<f32, OctreeError> {
        self.base.set_node_value(key, value, inner, |b, held| {
            stamp_ancestors(b, key, held, now);
        })
    }

    /// Apply one scan's update as OctoMap's `insertPointCloud` does after `computeUpdate`:
    /// every free voxel gets a miss, then every occupied voxel a hit, all at time `now`.
    pub fn insert_update_at(
        &mut self,
        free: impl IntoIterator<Item = Key>,
        occupied: impl IntoIterator<Item = Key>,
        inner: InnerNodes,
        now: u32,
    ) {
        self.insert_brick_iters(key_bricks(free), key_bricks(occupied), inner, now);
    }

    /// [`StampedOcTree::insert_update_at`] for sets given as bricks of 4x4x4 voxels (as
    /// [`OcTree::update_bricks`] takes them; `octoquant_raycast`'s `ScanUpdate` keeps its sets
    /// so): the same tree and stamps as the keys of `free`'s bricks, then `occupied`'s, each
    /// brick's voxels in mask-bit order. Saves listing the keys.
    pub fn insert_bricks_at(
        &mut self,
        free: &[crate::Brick],
        occupied: &[crate::Brick],
        inner: InnerNodes,
        now: u32,
    ) {
        let free = free.iter().map(|b| (b.code, b.voxels));
        let occupied = occupied.iter().map(|b| (b.code, b.voxels));
        self.insert_brick_iters(free, occupied, inner, now);
    }

    /// A scan's free and occupied bricks (code and mask) through the plain tree's batched
    /// walk, the stamps following its changes: each node is descended to once per brick and
    /// refreshed once, not once per voxel.
    fn insert_brick_iters(
        &mut self,
        free: impl Iterator<Item = (u64, u64)>,
        occupied: impl Iterator<Item = (u64, u64)>,
        inner: InnerNodes,
        now: u32,
    ) {
        let PayloadTree { tree, payloads } = &mut self.base;
        let stamps = &mut *payloads;
        tree.update_brick_iter(free, Update::Miss, inner, StampHooks { stamps, now });
        let stamps = payloads;
        tree.update_brick_iter(occupied, Update::Hit, inner, StampHooks { stamps, now });
    }

    /// [`StampedOcTree::degrade_outdated_nodes_at`] at the system clock's time.
    pub fn degrade_outdated_nodes(&mut self, time_thres: u32) {
        self.degrade_outdated_nodes_at(time_thres, now_seconds());
    }

    /// Forget stale obstacles (OctoMap's `degradeOutdatedNodes`): every occupied leaf whose
    /// stamp is more than `time_thres` seconds before `now` (`now - stamp` in wrapping 32-bit
    /// arithmetic, as OctoMap's `unsigned int`) gets one miss, clamped, keeping its stamp.
    /// Inner nodes are not refreshed (call [`StampedOcTree::update_inner_occupancy_at`] for
    /// that), exactly as OctoMap leaves them.
    pub fn degrade_outdated_nodes_at(&mut self, time_thres: u32, now: u32) {
        let PayloadTree { tree, payloads } = &mut self.base;
        if tree.is_empty() {
            return;
        }
        let p = *tree.params();
        let miss = tree.delta(Update::Miss);
        let stale = |v: f32, id: NodeId| {
            p.is_occupied(v) && now.wrapping_sub(payloads.get(id)) > time_thres
        };
        // the stale occupied leaves, by a walk that looks a leaf's stamp up only when it is
        // occupied, and takes the eight voxels below a depth-15 node at once
        let store = &tree.store;
        let mut found = Vec::new();
        let mut stack = vec![(NodeRef::ROOT, node_id(Key::default(), 0))];
        while let Some((n, id)) = stack.pop() {
            let b = store.kids(n);
            if b == NO_BLOCK {
                if stale(store.value(n), id) {
                    found.push(n);
                }
                continue;
            }
            let cd = n.depth + 1;
            if cd == TREE_DEPTH {
                for (i, v) in store.child_vals(cd, b).into_iter().enumerate() {
                    if present(v) && stale(v, child_id(id, i)) {
                        found.push(NodeRef {
                            depth: cd,
                            slot: i as u8,
                            block: b,
                        });
                    }
                }
                continue;
            }
            for i in 0..8 {
                if let Some(c) = store.child(n, i) {
                    stack.push((c, child_id(id, i)));
                }
            }
        }
        // one miss each, clamped, as OctoMap's `integrateMissNoTime`
        for n in found {
            let v = clamp_sum(tree.store.value(n), miss, p.clamp_min, p.clamp_max);
            tree.store.set_value(n, v);
        }
    }

    /// Collapse every node whose eight children are leaves with equal log-odds and equal
    /// stamps, level by level as OctoMap's `prune()`; the node takes child 0's stamp.
    pub fn prune(&mut self) {
        self.base.prune();
    }

    /// Give every leaf above depth 16 eight children, recursively (OctoMap's `expand()`);
    /// each child takes its parent's log-odds and stamp.
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
    /// stamps are untouched.
    pub fn to_max_likelihood(&mut self) {
        self.base.tree.to_max_likelihood();
    }

    /// [`StampedOcTree::update_inner_occupancy_at`] at the system clock's time.
    pub fn update_inner_occupancy(&mut self) {
        self.update_inner_occupancy_at(now_seconds());
    }

    /// Bring every inner node up to date (OctoMap's `updateInnerOccupancy`): log-odds to the
    /// max of its children, stamp to `now`.
    pub fn update_inner_occupancy_at(&mut self, now: u32) {
        self.base.update_inner_occupancy_to(now);
    }

    /// [`StampedOcTree::delete_node_at`] at the system clock's time.
    pub fn delete_node(&mut self, key: Key, depth: u8) -> bool {
        self.delete_node_at(key, depth, now_seconds())
    }

    /// Delete the node at `depth` holding `key` with its subtree (OctoMap's `deleteNode`, see
    /// [`OcTree::delete_node`]): stamps go with the deleted nodes, pruned nodes expanded on
    /// the way hand theirs to their children, and the parent that keeps children is refreshed
    /// at `now`. Returns whether anything was deleted.
    pub fn delete_node_at(&mut self, key: Key, depth: u8, now: u32) -> bool {
        let Some(left) = self.base.delete_node(key, depth) else {
            return false;
        };
        // the deepest node left, if it still has children, ran updateOccupancyChildren
        if left.has_children {
            self.base.set(node_id(key, left.depth), now);
        }
        true
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

    /// The node at exactly `depth` holding `key`, with its stamp (`None` when no node exists
    /// there).
    pub fn node_at_depth(&self, key: Key, depth: u8) -> Option<StampedNodeInfo> {
        let (node, timestamp) = self.base.node_at_depth(key, depth)?;
        Some(StampedNodeInfo { node, timestamp })
    }

    /// Child `i` (0..8: bit 0 x, bit 1 y, bit 2 z) of the node at exactly `depth` holding
    /// `key`, with its stamp (OctoMap's `getNodeChild`); `None` when either does not exist.
    pub fn node_child(&self, key: Key, depth: u8, i: usize) -> Option<StampedNodeInfo> {
        let (node, timestamp) = self.base.node_child(key, depth, i)?;
        Some(StampedNodeInfo { node, timestamp })
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

    /// Set the stamp of the node at exactly `depth` holding `key` to `t` (OctoMap's
    /// `OcTreeNodeStamped::setTimestamp` on a node in hand; 0 is a node never stamped).
    /// Nothing else changes: no ancestor is stamped, and a later prune compares the new stamp.
    /// Returns `false`, changing nothing, when no node exists there.
    pub fn set_timestamp(&mut self, key: Key, depth: u8, t: u32) -> bool {
        if self.base.tree.node_at_depth(key, depth).is_none() {
            return false;
        }
        self.base.set(node_id(key, depth), t);
        true
    }

    /// [`StampedOcTree::set_timestamp`] at the system clock's time (OctoMap's
    /// `updateTimestamp`).
    pub fn update_timestamp(&mut self, key: Key, depth: u8) -> bool {
        self.set_timestamp(key, depth, now_seconds())
    }

    /// [`StampedOcTree::update_node_log_odds_at`] at the system clock's time.
    pub fn update_node_log_odds(
        &mut self,
        key: Key,
        depth: u8,
        update: Update,
    ) -> Result<Option<f32>, OctreeError> {
        self.update_node_log_odds_at(key, depth, update, now_seconds())
    }

    /// OctoMap's `updateNodeLogOdds` on a node of an `OcTreeStamped` in hand (and so its
    /// `integrateHit` and `integrateMiss`): the node's log-odds as
    /// [`OcTree::update_node_log_odds`], then its stamp set to `now`; no ancestor is refreshed
    /// or stamped. Returns the new log-odds, `Ok(None)` when no node exists there, an error
    /// (nothing changed) when the sum is NaN.
    pub fn update_node_log_odds_at(
        &mut self,
        key: Key,
        depth: u8,
        update: Update,
        now: u32,
    ) -> Result<Option<f32>, OctreeError> {
        let v = self.base.tree.update_node_log_odds(key, depth, update)?;
        if v.is_some() {
            self.base.set(node_id(key, depth), now);
        }
        Ok(v)
    }

    /// OctoMap's `integrateMissNoTime`: one miss on the node at exactly `depth` holding `key`,
    /// clamped, its stamp kept (what [`StampedOcTree::degrade_outdated_nodes_at`] gives each
    /// stale leaf). Returns the new log-odds, `None` when no node exists there.
    pub fn integrate_miss_no_time(&mut self, key: Key, depth: u8) -> Option<f32> {
        // a miss is finite, and stored log-odds are never NaN: the sum is never NaN
        self.base
            .tree
            .update_node_log_odds(key, depth, Update::Miss)
            .ok()
            .flatten()
    }

    /// OctoMap's `nodeToMaxLikelihood` on a node in hand (see
    /// [`OcTree::node_to_max_likelihood`]); the stamp is kept.
    pub fn node_to_max_likelihood(&mut self, key: Key, depth: u8) -> Option<f32> {
        self.base.tree.node_to_max_likelihood(key, depth)
    }

    /// OctoMap's `expandNode`: the childless node at exactly `depth` holding `key` gets eight
    /// children with its occupancy and stamp (`copyData`; no clock is read). `false`, changing
    /// nothing, when there is no such node, it has children or it is a voxel.
    pub fn expand_node(&mut self, key: Key, depth: u8) -> bool {
        self.base.expand_node(key, depth)
    }

    /// OctoMap's `isNodeCollapsible` on an `OcTreeStamped`: eight childless children of equal
    /// occupancy and equal stamps (its node comparison).
    pub fn is_node_collapsible(&self, key: Key, depth: u8) -> bool {
        self.base.is_node_collapsible(key, depth)
    }

    /// OctoMap's `pruneNode`: a collapsible node loses its children and takes child 0's
    /// occupancy and stamp. Returns whether it pruned.
    pub fn prune_node(&mut self, key: Key, depth: u8) -> bool {
        self.base.prune_node(key, depth)
    }

    /// OctoMap's `createNodeChild`: child `i` of the node at exactly `depth` holding `key`,
    /// new with log-odds 0 and stamp 0; `None` when it exists already, the node does not, or
    /// it is a voxel.
    pub fn create_node_child(&mut self, key: Key, depth: u8, i: usize) -> Option<StampedNodeInfo> {
        let node = self.base.create_node_child(key, depth, i)?;
        Some(StampedNodeInfo { node, timestamp: 0 })
    }

    /// OctoMap's `deleteNodeChild`: child `i` of the node at exactly `depth` holding `key` and
    /// its subtree go, with their stamps. Returns the nodes removed (0 when the child does not
    /// exist).
    pub fn delete_node_child(&mut self, key: Key, depth: u8, i: usize) -> usize {
        self.base.delete_node_child(key, depth, i)
    }

    /// Every node with its stamp, pre-order (children in OctoMap's order 0..8): depth,
    /// smallest voxel key, log-odds, stamp. For comparing with OctoMap node by node.
    pub fn nodes_with_stamps(&self) -> Vec<(u8, Key, f32, u32)> {
        let mut out = Vec::with_capacity(self.size());
        if self.base.tree.is_empty() {
            return out;
        }
        let mut stack = vec![(NodeRef::ROOT, node_id(Key::default(), 0))];
        while let Some((n, id)) = stack.pop() {
            out.push((id.0, id.1, self.base.tree.store.value(n), self.stamp_of(id)));
            for i in (0..8).rev() {
                if let Some(c) = self.base.tree.store.child(n, i) {
                    stack.push((c, child_id(id, i)));
                }
            }
        }
        out
    }
}

/// The stamp rules for the batched walk ([`StampedOcTree::insert_update_at`]): a voxel that
/// takes its update and an inner node refreshed with children left get `now`; expansions copy
/// stamps down; children collapse only with equal stamps, the parent taking child 0's.
struct StampHooks<'a> {
    stamps: &'a mut NodeMap<u32>,
    now: u32,
}

impl WalkHooks for StampHooks<'_> {
    const PLAIN: bool = false;

    fn expanded(&mut self, id: NodeId) {
        copy_to_children(self.stamps, id);
    }

    fn applied(&mut self, id: NodeId) {
        self.stamps.insert(id, self.now);
    }

    fn applied_group(&mut self, parent: NodeId, which: u8) {
        self.stamps.set_children_where(parent, which, self.now);
    }

    fn may_prune(&mut self, id: NodeId) -> bool {
        payloads_may_collapse(self.stamps, id)
    }

    fn collapsed(&mut self, id: NodeId) {
        collapse_into(self.stamps, id);
    }

    fn refreshed(&mut self, id: NodeId) {
        self.stamps.insert(id, self.now);
    }

    fn ahead(&mut self, code: u64) {
        self.stamps.look_ahead(Key::from_morton(code << 6));
    }
}

/// After an eager ascent from `key` that left it held at depth `held` (`None`: deferred, no
/// ascent): every ancestor above, left with children and refreshed, gets `now`
/// (`updateOccupancyChildren`).
fn stamp_ancestors(base: &mut PayloadTree<u32>, key: Key, held: Option<u8>, now: u32) {
    if let Some(h) = held {
        for d in 0..h {
            base.set(node_id(key, d), now);
        }
    }
}

#[cfg(test)]
#[path = "stamped_tree_tests.rs"]
mod tests;
