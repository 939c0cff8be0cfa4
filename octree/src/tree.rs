//! The occupancy octree: node updates with OctoMap's exact semantics, search and summaries.

use crate::error::OctreeError;
use crate::key::{Key, KeyConverter, TREE_DEPTH};
use crate::key_table::KeyTable;
use crate::params::OccupancyParams;
use crate::store::{Adder, MemoryUsage, NodeRef, NodeStore, Outcome, NO_BLOCK};
use nalgebra::Point3;

/// One occupancy observation of a voxel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Update {
    /// Add the sensor model's hit log-odds.
    Hit,
    /// Add the sensor model's miss log-odds.
    Miss,
    /// Add an arbitrary log-odds delta.
    LogOdds(f32),
}

/// Whether a write brings the inner nodes above the voxels it changed up to date at once
/// (OctoMap's `lazy_eval` flag, inverted).
///
/// Eager refreshing keeps every inner node equal to the max of its children and prunes
/// collapsible nodes after each write, as OctoMap does with `lazy_eval = false`. Deferring
/// skips that ascent, which is faster for many writes in a row; the inner nodes are then stale
/// until [`OcTree::update_inner_occupancy`] is called, as with OctoMap's `lazy_eval = true`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum InnerNodes {
    /// Prune or refresh every ancestor of a changed voxel right away (`lazy_eval = false`).
    #[default]
    Refresh,
    /// Leave ancestors stale until [`OcTree::update_inner_occupancy`] (`lazy_eval = true`).
    Defer,
}

impl InnerNodes {
    /// The policy OctoMap's `lazy_eval` flag stands for: `true` defers, `false` refreshes.
    pub fn from_lazy(lazy: bool) -> Self {
        if lazy {
            InnerNodes::Defer
        } else {
            InnerNodes::Refresh
        }
    }

    /// True when inner nodes are left stale (OctoMap's `lazy_eval = true`).
    pub fn is_deferred(self) -> bool {
        self == InnerNodes::Defer
    }
}

/// A node found by [`OcTree::search`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodeInfo {
    /// The node's log-odds.
    pub value: f32,
    /// Its depth (16 = voxel, less for a pruned node covering many voxels).
    pub depth: u8,
    /// Whether it has children (an inner node) or not (a leaf).
    pub has_children: bool,
}

/// Node and leaf counts of a tree (see [`OcTree::counts`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Counts {
    /// All nodes, inner and leaves (OctoMap's `size()`).
    pub nodes: usize,
    /// Nodes with children.
    pub inner: usize,
    /// Nodes without children.
    pub leaves: usize,
    /// Leaves whose log-odds is at or above the occupancy threshold.
    pub occupied_leaves: usize,
    /// Leaves below the threshold.
    pub free_leaves: usize,
    /// Nodes (inner too) sitting at either clamp (OctoMap's "thresholded" count).
    pub at_threshold: usize,
}

/// What `descend_and_apply` does to the voxel.
#[derive(Clone, Copy)]
enum VoxelOp {
    /// Add a delta and clamp (`updateNode`).
    Add(Adder),
    /// Set a value (`setNodeValue`).
    Set(f32),
}

/// OctoMap's `OcTree`: a probabilistic occupancy octree of depth 16 with log-odds nodes.
///
/// Storage is an arena of 8-child blocks (see the crate docs). All update, prune and
/// max-likelihood operations reproduce OctoMap 1.9.7 bit for bit, so the `.bt`/`.ot` files
/// written from the same updates are byte-identical.
#[derive(Clone)]
pub struct OcTree {
    conv: KeyConverter,
    pub(crate) params: OccupancyParams,
    pub(crate) store: NodeStore,
    size: usize,
    /// Change detection (OctoMap's `changed_keys`): key -> "the voxel is new", in OctoMap's
    /// iteration order; made on the first enabling and kept (OctoMap never drops it).
    changes: Option<Box<KeyTable<bool>>>,
    /// Whether updates are recorded (OctoMap's `use_change_detection`).
    detect_changes: bool,
}

impl std::fmt::Debug for OcTree {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("OcTree")
            .field("resolution", &self.conv.resolution())
            .field("size", &self.size)
            .field("params", &self.params)
            .finish()
    }
}

impl OcTree {
    /// An empty tree with leaf size `resolution` and OctoMap's default sensor model.
    pub fn new(resolution: f64) -> Result<Self, OctreeError> {
        Self::with_params(resolution, OccupancyParams::default())
    }

    /// An empty tree with the given sensor model.
    pub fn with_params(resolution: f64, params: OccupancyParams) -> Result<Self, OctreeError> {
        Ok(OcTree {
            conv: KeyConverter::new(resolution)?,
            params,
            store: NodeStore::new(),
            size: 0,
            changes: None,
            detect_changes: false,
        })
    }

    /// Leaf edge length in metres.
    pub fn resolution(&self) -> f64 {
        self.conv.resolution()
    }

    /// Change the leaf size to `resolution` (OctoMap's `setResolution`): every node keeps its
    /// key and value, so the map is scaled about the centre of the key range (coordinates of
    /// the keys, metric bounds and files change; the structure does not). Errors, changing
    /// nothing, as [`KeyConverter::new`] does for a resolution that is not finite and positive.
    pub fn set_resolution(&mut self, resolution: f64) -> Result<(), OctreeError> {
        self.conv = KeyConverter::new(resolution)?;
        Ok(())
    }

    /// The coordinate <-> key converter for this tree's resolution.
    pub fn converter(&self) -> &KeyConverter {
        &self.conv
    }

    /// The sensor model.
    pub fn params(&self) -> &OccupancyParams {
        &self.params
    }

    /// Replace the sensor model; existing node values are kept as they are.
    pub fn set_params(&mut self, params: OccupancyParams) {
        self.params = params;
    }

    /// Number of nodes, inner and leaves (OctoMap's `size()`); 0 for an empty tree.
    pub fn size(&self) -> usize {
        self.size
    }

    /// `true` when the tree has no root.
    pub fn is_empty(&self) -> bool {
        self.store.root_val.is_none()
    }

    /// Remove every node (the resolution and sensor model stay).
    pub fn clear(&mut self) {
        self.store.clear();
        self.size = 0;
    }

    pub(crate) fn add_size(&mut self, n: usize) {
        self.size += n;
    }

    pub(crate) fn sub_size(&mut self, n: usize) {
        self.size -= n;
    }

    /// The log-odds delta an [`Update`] stands for under this tree's sensor model.
    #[inline]
    pub fn delta(&self, update: Update) -> f32 {
        match update {
            Update::Hit => self.params.hit,
            Update::Miss => self.params.miss,
            Update::LogOdds(d) => d,
        }
    }

    /// Integrate one observation of voxel `key` (OctoMap's `updateNode(key, delta, lazy)`).
    ///
    /// Adds the delta then clamps; returns at once when the voxel (or the pruned node holding
    /// it) already sits at the clamp the update pushes towards. Pruned nodes on the path are
    /// expanded. With [`InnerNodes::Refresh`], every ancestor is then pruned or set to the max
    /// of its children; with [`InnerNodes::Defer`], call [`OcTree::update_inner_occupancy`]
    /// afterwards.
    /// Returns the voxel's new log-odds. A NaN delta is ignored (the tree is unchanged).
    pub fn update_node(&mut self, key: Key, update: Update, inner: InnerNodes) -> f32 {
        let delta = self.delta(update);
        if let Some(n) = self.search_ref(key, TREE_DEPTH) {
            let v = self.store.value(n);
            if (delta >= 0.0 && v >= self.params.clamp_max)
                || (delta <= 0.0 && v <= self.params.clamp_min)
            {
                return v;
            }
        }
        if delta.is_nan() {
            return self.search(key, TREE_DEPTH).map_or(0.0, |n| n.value);
        }
        let (cmin, cmax) = (self.params.clamp_min, self.params.clamp_max);
        let add = self.store.adder(delta, cmin, cmax);
        self.descend_and_apply(key, inner, VoxelOp::Add(add), |_| true)
    }

    /// [`OcTree::update_node`] for a caller that has already taken OctoMap's early exit and
    /// the NaN case (the trees with a payload per node, which search first), with
    /// `may_prune(depth)` asked before each ancestor the ascent would prune (see
    /// [`NodeStore::prune_or_refresh_if`](crate::store::NodeStore::prune_or_refresh_if)):
    /// refused, it is refreshed instead, as OctoMap's `pruneNode` fails when the children's
    /// payloads differ.
    pub(crate) fn update_node_guarded(
        &mut self,
        key: Key,
        update: Update,
        inner: InnerNodes,
        may_prune: impl FnMut(u8) -> bool,
    ) -> f32 {
        let delta = self.delta(update);
        let (cmin, cmax) = (self.params.clamp_min, self.params.clamp_max);
        let add = self.store.adder(delta, cmin, cmax);
        self.descend_and_apply(key, inner, VoxelOp::Add(add), may_prune)
    }

    /// Set voxel `key` to `value` clamped to the sensor model's bounds (OctoMap's
    /// `setNodeValue`; no early exit). Errors on NaN.
    pub fn set_node_value(
        &mut self,
        key: Key,
        value: f32,
        inner: InnerNodes,
    ) -> Result<f32, OctreeError> {
        self.set_node_value_guarded(key, value, inner, |_| true)
    }

    /// [`OcTree::set_node_value`] with `may_prune(depth)` asked before each ancestor the
    /// ascent would prune, as [`OcTree::update_node_guarded`].
    pub(crate) fn set_node_value_guarded(
        &mut self,
        key: Key,
        value: f32,
        inner: InnerNodes,
        may_prune: impl FnMut(u8) -> bool,
    ) -> Result<f32, OctreeError> {
        if value.is_nan() {
            return Err(OctreeError::NanValue);
        }
        let v = value.max(self.params.clamp_min).min(self.params.clamp_max);
        Ok(self.descend_and_apply(key, inner, VoxelOp::Set(v), may_prune))
    }

    /// Integrate an observation of the voxel containing `point`; errors outside the map.
    pub fn update_point(
        &mut self,
        point: &Point3<f64>,
        update: Update,
        inner: InnerNodes,
    ) -> Result<f32, OctreeError> {
        let key = self.conv.point_to_key_checked(point)?;
        Ok(self.update_node(key, update, inner))
    }

    /// The shared descent of `updateNodeRecurs` / `setNodeValueRecurs`: create or expand the
    /// path to `key`, apply `op` to the voxel, then (unless deferred) prune or refresh every
    /// ancestor bottom-up, root included, a prune only where `may_prune(depth)` allows it.
    #[inline]
    fn descend_and_apply(
        &mut self,
        key: Key,
        inner: InnerNodes,
        op: VoxelOp,
        mut may_prune: impl FnMut(u8) -> bool,
    ) -> f32 {
        let mut just_created = false;
        if self.store.root_val.is_none() {
            self.store.root_val = Some(0.0);
            self.size += 1;
            just_created = true;
        }
        let mut path = [NodeRef::ROOT; TREE_DEPTH as usize];
        let mut cur = NodeRef::ROOT;
        for depth in 0..TREE_DEPTH {
            path[depth as usize] = cur;
            let pos = key.child_index(depth);
            let b = self.store.kids(cur);
            let exists = b != NO_BLOCK && self.store.child_present(depth + 1, b, pos);
            let created = if exists {
                false
            } else if b == NO_BLOCK && !just_created {
                // a pruned leaf: give it all eight children before descending
                self.store.expand_node(cur);
                self.size += 8;
                false
            } else {
                self.store.create_child_zero(cur, pos);
                self.size += 1;
                true
            };
            cur = NodeRef {
                depth: depth + 1,
                slot: pos as u8,
                block: self.store.kids(cur),
            };
            just_created = created;
        }
        let old = self.store.value(cur);
        match op {
            VoxelOp::Add(add) => {
                // the early exit was taken above, before anything was created
                let mut memo = self.store.take_memo(&add);
                let out = self.store.update_voxel(cur, &add, just_created, &mut memo);
                self.store.put_memo(&add, memo);
                if out == Outcome::Exit {
                    return old;
                }
            }
            VoxelOp::Set(v) => self.store.set_value(cur, v),
        }
        let v = self.store.value(cur);
        self.record_change(key, old, v, just_created);
        if !inner.is_deferred() {
            for n in path.iter().rev() {
                if self.store.prune_or_refresh_if(*n, || may_prune(n.depth)) == Some(true) {
                    self.size -= 8;
                }
            }
        }
        v
    }

    /// Delete the node at `depth` (16 = voxel) holding `key`, with its subtree (OctoMap's
    /// `deleteNode`): pruned nodes on the way are expanded first, parents left without
    /// children are deleted too (never the root), and the others get the max of their
    /// remaining children. Returns whether anything was deleted.
    ///
    /// Unlike OctoMap 1.9.7, `size()` also drops by the deleted subtree's nodes (OctoMap only
    /// counts one node per deleted child, so its size goes stale).
    pub fn delete_node(&mut self, key: Key, depth: u8) -> bool {
        let depth = if depth == 0 || depth > TREE_DEPTH {
            TREE_DEPTH
        } else {
            depth
        };
        if self.is_empty() {
            return false;
        }
        let key = if depth < TREE_DEPTH {
            key.at_depth(depth)
        } else {
            key
        };
        let mut path = [NodeRef::ROOT; TREE_DEPTH as usize];
        let mut cur = NodeRef::ROOT;
        for d in 0..depth {
            path[d as usize] = cur;
            let pos = key.child_index(d);
            if self.store.child(cur, pos).is_none() {
                if !self.store.has_children(cur) && d > 0 {
                    self.store.expand_node(cur);
                    self.size += 8;
                } else {
                    return false;
                }
            }
            cur = self
                .store
                .child(cur, pos)
                .expect("child exists after expansion");
        }
        // delete upwards while parents become childless
        let mut d = depth as usize;
        loop {
            let parent = path[d - 1];
            let pos = key.child_index(d as u8 - 1);
            self.size -= self.store.delete_child(parent, pos);
            if self.store.has_children(parent) {
                let m = self.store.max_child(parent);
                self.store.set_value(parent, m);
                break;
            }
            if d == 1 {
                break; // the root stays, childless
            }
            d -= 1;
        }
        true
    }

    /// Enable or disable change detection (OctoMap's `enableChangeDetection`). While enabled,
    /// every voxel that is created or whose occupancy flips is recorded; disabling keeps the
    /// record until [`OcTree::reset_change_detection`].
    pub fn enable_change_detection(&mut self, enable: bool) {
        if enable && self.changes.is_none() {
            self.changes = Some(Box::default());
        }
        self.detect_changes = enable;
    }

    /// Whether change detection is on.
    pub fn is_change_detection_enabled(&self) -> bool {
        self.detect_changes
    }

    /// Forget the changes recorded so far (OctoMap's `resetChangeDetection`).
    pub fn reset_change_detection(&mut self) {
        if let Some(c) = self.changes.as_mut() {
            c.clear();
        }
    }

    /// Voxels changed since the last reset, in key order: `(key, true)` for a voxel that did
    /// not exist before, `(key, false)` for one whose occupancy flipped. A voxel that flipped
    /// back is dropped again, as in OctoMap.
    pub fn changed_keys(&self) -> impl Iterator<Item = (Key, bool)> + '_ {
        let mut all: Vec<(Key, bool)> = self.changed_keys_octomap_order().collect();
        all.sort_unstable_by_key(|e| e.0);
        all.into_iter()
    }

    /// The changed voxels as [`OcTree::changed_keys`] gives them, but in the order OctoMap's
    /// `changedKeysBegin()..changedKeysEnd()` walks them (its `unordered_map` as GCC's
    /// libstdc++ lays it out) when the same single-voxel updates (`update_node`,
    /// `set_node_value`) were made in the same order. What dynamicEDT3D's incremental update
    /// walks.
    pub fn changed_keys_octomap_order(&self) -> impl Iterator<Item = (Key, bool)> + '_ {
        self.changes.iter().flat_map(|c| c.iter())
    }

    /// Number of recorded changes (OctoMap's `numChangesDetected`).
    pub fn num_changes_detected(&self) -> usize {
        self.changes.as_ref().map_or(0, |c| c.len())
    }

    /// Record a voxel update for change detection, as `updateNodeRecurs` does at the leaf.
    #[inline]
    pub(crate) fn record_change(&mut self, key: Key, old: f32, new: f32, created: bool) {
        if !self.detect_changes {
            return;
        }
        let Some(changes) = self.changes.as_mut() else {
            return;
        };
        let p = &self.params;
        if created {
            changes.insert(key, true);
        } else if p.is_occupied(old) != p.is_occupied(new) {
            match changes.get(&key) {
                None => {
                    changes.insert(key, false);
                }
                Some(false) => changes.remove(&key),
                Some(true) => {}
            }
        }
    }

    /// The deepest existing node on the way to `key` at `depth` (OctoMap's `search`): the node
    /// itself, or a pruned leaf covering it; `None` in unknown space.
    pub(crate) fn search_ref(&self, key: Key, depth: u8) -> Option<NodeRef> {
        self.store.root_val?;
        let key = if depth < TREE_DEPTH {
            key.at_depth(depth)
        } else {
            key
        };
        let mut cur = NodeRef::ROOT;
        for d in 0..depth {
            let b = self.store.kids(cur);
            if b == NO_BLOCK {
                return Some(cur);
            }
            let pos = key.child_index(d);
            if !self.store.child_present(d + 1, b, pos) {
                return None;
            }
            cur = NodeRef {
                depth: d + 1,
                slot: pos as u8,
                block: b,
            };
        }
        Some(cur)
    }

    /// Look up the node holding `key`, descending at most to `depth` (16 = voxel level).
    ///
    /// Returns the node at that depth, or the pruned leaf above it that covers it, or `None`
    /// when the space is unknown. Depths above 16 are treated as 16.
    pub fn search(&self, key: Key, depth: u8) -> Option<NodeInfo> {
        let depth = depth.min(TREE_DEPTH);
        let depth = if depth == 0 { TREE_DEPTH } else { depth };
        self.search_ref(key, depth).map(|n| NodeInfo {
            value: self.store.value(n),
            depth: n.depth,
            has_children: self.store.has_children(n),
        })
    }

    /// Look up the node holding `point` at voxel level; `None` in unknown space or outside.
    pub fn search_point(&self, point: &Point3<f64>) -> Option<NodeInfo> {
        self.search(self.conv.point_to_key(point)?, TREE_DEPTH)
    }

    /// The occupancy probability at `point` (metres): that of the node holding it (the voxel,
    /// or the pruned leaf above it that covers it), `None` in unknown space or outside the
    /// map. The probability form of [`OcTree::search_point`]'s log-odds, as OctoMap's
    /// `getOccupancy`.
    pub fn probability_at(&self, point: &Point3<f64>) -> Option<f64> {
        self.search_point(point)
            .map(|n| crate::params::probability(f64::from(n.value)))
    }

    /// `Some(true)` if the voxel is known occupied, `Some(false)` if known free, `None` if
    /// unknown.
    pub fn is_occupied(&self, key: Key) -> Option<bool> {
        self.search(key, TREE_DEPTH)
            .map(|n| self.params.is_occupied(n.value))
    }

    /// Log-odds of the root, `None` for an empty tree.
    pub fn root_value(&self) -> Option<f32> {
        self.store.root_val
    }

    /// Node, leaf, occupied/free and at-clamp counts, in one walk.
    pub fn counts(&self) -> Counts {
        let mut c = Counts::default();
        if self.is_empty() {
            return c;
        }
        let mut stack = vec![NodeRef::ROOT];
        while let Some(n) = stack.pop() {
            c.nodes += 1;
            let v = self.store.value(n);
            if self.params.is_at_threshold(v) {
                c.at_threshold += 1;
            }
            if self.store.has_children(n) {
                c.inner += 1;
                for i in 0..8 {
                    if let Some(ch) = self.store.child(n, i) {
                        stack.push(ch);
                    }
                }
            } else {
                c.leaves += 1;
                if self.params.is_occupied(v) {
                    c.occupied_leaves += 1;
                } else {
                    c.free_leaves += 1;
                }
            }
        }
        c
    }

    /// Number of leaves (OctoMap's `getNumLeafNodes`).
    pub fn num_leaves(&self) -> usize {
        self.counts().leaves
    }

    /// Bytes held by the node storage (blocks in use and awaiting reuse).
    ///
    /// The figure to compare with OctoMap's `memoryUsage()`, which counts 16 bytes per node
    /// plus 64 per inner node plus the tree object.
    pub fn memory_usage(&self) -> usize {
        self.memory_breakdown().total()
    }

    /// [`OcTree::memory_usage`] item by item: blocks in use, freed blocks, the depth-16 value
    /// palette.
    pub fn memory_breakdown(&self) -> MemoryUsage {
        let mut m = self.store.memory();
        m.fixed_bytes += std::mem::size_of::<Self>() - std::mem::size_of::<NodeStore>();
        m
    }

    /// OctoMap's `memoryUsage()` formula for the same tree on amd64:
    /// `320 + 16·nodes + 64·inner`.
    pub fn octomap_memory_usage(&self) -> usize {
        let c = self.counts();
        320 + 16 * c.nodes + 64 * c.inner
    }

    /// Give back memory: the tree is copied into fresh arenas in depth-first order, which drops
    /// the blocks pruning freed (kept for reuse while mapping) and any spare capacity. O(size);
    /// the tree, its files and its iteration order do not change.
    pub fn shrink_to_fit(&mut self) {
        self.store.compact();
    }

    /// Blocks in use: (inner blocks of 64 bytes, depth-16 blocks of 16 bytes, or 32 bytes
    /// once the tree holds too many distinct voxel values for the palette).
    pub fn live_blocks(&self) -> (usize, usize) {
        (self.store.inner.live(), self.store.voxels.live())
    }

    /// Axis-aligned bounds of all leaves, free and occupied (OctoMap's `getMetricMin/Max`);
    /// `None` for an empty tree.
    pub fn metric_bounds(&self) -> Option<(Point3<f64>, Point3<f64>)> {
        if self.is_empty() {
            return None;
        }
        let mut lo = [f64::MAX; 3];
        let mut hi = [-f64::MAX; 3];
        for leaf in self.leaves() {
            let size = self.conv.node_size(leaf.depth);
            let half = size / 2.0;
            for a in 0..3 {
                let c = self.conv.key_to_coord_at_depth(leaf.key[a], leaf.depth) - half;
                if c < lo[a] {
                    lo[a] = c;
                }
                let c2 = c + size;
                if c2 > hi[a] {
                    hi[a] = c2;
                }
            }
        }
        Some((Point3::from(lo), Point3::from(hi)))
    }

    /// Edge lengths of [`OcTree::metric_bounds`] (zeros for an empty tree).
    pub fn metric_size(&self) -> [f64; 3] {
        match self.metric_bounds() {
            Some((lo, hi)) => [hi.x - lo.x, hi.y - lo.y, hi.z - lo.z],
            None => [0.0; 3],
        }
    }

    /// Volume of the bounding box of all leaves (OctoMap's `volume()`).
    pub fn volume(&self) -> f64 {
        let s = self.metric_size();
        s[0] * s[1] * s[2]
    }
}

#[cfg(test)]
#[path = "tree_tests.rs"]
mod tests;
