//! Map merge: every leaf of another tree applied to this one as a log-odds update, with
//! OctoMap's `updateNode` semantics, pruned leaves of the other tree applied whole.
//!
//! # Semantics
//!
//! `a.merge(&b)` gives the tree that these OctoMap calls give, starting from `a`: for each
//! leaf of `b` in pre-order (children 0..7), for each voxel (depth-16 key) the leaf covers, in
//! Morton order, `a.updateNode(voxel, leaf_log_odds, lazy = false)`. So each voxel of `a`
//! receives `b`'s log-odds as a delta, clamped to `a`'s sensor model (with `updateNode`'s early
//! exit for a voxel already at the clamp the delta pushes towards); voxels unknown to `a`
//! start from 0 (`clamp(0 + b)`); every touched path is pruned or refreshed as an eager
//! update does. Only `b`'s leaves count (its inner nodes are summaries); `b`'s sensor model is
//! not used (its leaves' log-odds are what they are).
//!
//! # Pruned leaves without enumerating voxels
//!
//! A leaf of `b` at depth `d` stands for `8^(16-d)` voxels (2.8e14 for the root). It is
//! applied to `a`'s subtree in that region in one walk over `a`'s nodes there, not over
//! the voxels:
//!
//! - unknown in `a` (a missing child): every voxel would be created from 0 and get
//!   `f = clamp(0 + b)`, and then pruned bottom-up into one leaf of value `f` (child 0's value,
//!   all equal bits): the missing node is created as that leaf;
//! - a leaf of `a` with value `v` covering the region (a voxel, or a pruned node at any depth):
//!   at the clamp, every voxel takes the early exit and nothing changes (not even the
//!   ancestors, as in OctoMap). Otherwise every voxel becomes `g = clamp(v + b)`: the leaf
//!   is expanded down to the region (siblings keep `v`), the region's node becomes a leaf of
//!   `g`. When `g == v` under float `==` each voxel's update prunes straight back; the leaf then
//!   keeps its depth and takes `g`'s bits only if the region's first voxel is the leaf's first
//!   voxel (child 0 of every pruning holds it), which matters only for `-0.0` against `+0.0`;
//! - an inner node of `a`: the same, child by child, then the node is pruned or refreshed;
//!
//! and after the region, each ancestor of a touched node is pruned (eight equal leaf
//! children, child 0's value kept) or set to the max of its children, bottom-up. The voxel-
//! by-voxel sequence reaches the same state because each voxel's update changes only its own
//! path, and every node's last refresh comes after the last change below it. The work is
//! `O(depth)` per leaf of `b` plus the nodes of `a` inside `b`'s pruned leaves, whatever their
//! size. The tests check it against the voxel-by-voxel sequence of
//! [`OcTree::update_node`] calls (random trees, lazy-built and unpruned ones included) and, in
//! the workspace tests, against OctoMap's own `updateNode` byte for byte.
//!
//! Resolutions must be equal (no resampling); sensor models may differ (`a`'s is kept, its
//! clamping applies). A leaf of `b` holding NaN or an infinite log-odds is an error, found
//! before `a` is touched. Change detection is not kept up to date by a merge, so a tree with
//! it enabled is refused.

use crate::error::OctreeError;
use crate::key::{Key, TREE_DEPTH};
use crate::store::{clamp_sum, NodeRef, NO_BLOCK};
use crate::tree::OcTree;

/// What [`OcTree::merge`] applied.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MergeStats {
    /// Leaves of the other tree applied.
    pub leaves: usize,
    /// Of those, pruned leaves (depth below 16) applied as a whole.
    pub pruned_leaves: usize,
    /// Voxels the applied leaves stand for (`8^(16-d)` per leaf of depth `d`).
    pub voxels: u64,
}

/// The sensor model's clamps and the delta of one leaf of the other tree.
#[derive(Clone, Copy)]
struct Delta {
    delta: f32,
    cmin: f32,
    cmax: f32,
}

impl Delta {
    /// `updateNode`'s early exit at the clamp the delta pushes towards.
    fn exits_at(&self, v: f32) -> bool {
        (self.delta >= 0.0 && v >= self.cmax) || (self.delta <= 0.0 && v <= self.cmin)
    }

    /// The voxel value after the update from `v`.
    fn apply(&self, v: f32) -> f32 {
        clamp_sum(v, self.delta, self.cmin, self.cmax)
    }
}

impl OcTree {
    /// Fuse `other` into this tree: each leaf of `other` applied as a log-odds update of the
    /// voxels it covers, with this tree's clamping, exactly as a voxel-by-voxel sequence of
    /// OctoMap `updateNode(voxel, leaf_log_odds)` calls: for each leaf of `other` in pre-order,
    /// each voxel it covers in Morton order. Unknown voxels start from 0; a pruned leaf
    /// of depth `d` is applied to its `8^(16-d)` voxels at once, in time bounded by this tree's
    /// nodes in its region, with the same result (the `merge` module of the source explains
    /// the cases; `docs/distributed.md` the semantics).
    ///
    /// Errors, before anything changes, when the resolutions differ, a leaf of `other` has a
    /// NaN or infinite value, or change detection is enabled on this tree.
    pub fn merge(&mut self, other: &OcTree) -> Result<MergeStats, OctreeError> {
        if other.resolution() != self.resolution() {
            return Err(OctreeError::ResolutionMismatch {
                first: self.resolution(),
                second: other.resolution(),
            });
        }
        if self.is_change_detection_enabled() {
            return Err(OctreeError::Unsupported {
                what: "merging into a tree with change detection enabled",
            });
        }
        if let Some(l) = other.leaves().find(|l| !l.value.is_finite()) {
            return Err(OctreeError::NonFiniteValue {
                key: l.key.0,
                depth: l.depth,
                value: l.value,
            });
        }
        let mut stats = MergeStats::default();
        let (cmin, cmax) = (self.params.clamp_min, self.params.clamp_max);
        for leaf in other.leaves() {
            stats.leaves += 1;
            stats.voxels += 1u64 << (3 * u32::from(TREE_DEPTH - leaf.depth));
            let d = Delta {
                delta: leaf.value,
                cmin,
                cmax,
            };
            if leaf.depth == TREE_DEPTH {
                self.update_node(
                    leaf.key,
                    crate::Update::LogOdds(leaf.value),
                    crate::InnerNodes::Refresh,
                );
            } else {
                stats.pruned_leaves += 1;
                self.update_region(leaf.min_key(), leaf.depth, d);
            }
        }
        Ok(stats)
    }

    /// Apply `d` to every voxel of the node at `depth` (< 16) holding `key` (see the module
    /// docs for the cases).
    fn update_region(&mut self, key: Key, depth: u8, d: Delta) {
        let mut just_created = false;
        if self.store.root_val.is_none() {
            self.store.root_val = Some(0.0);
            self.add_size(1);
            just_created = true;
        }
        let mut path = [NodeRef::ROOT; TREE_DEPTH as usize];
        let mut cur = NodeRef::ROOT;
        for level in 0..depth {
            path[level as usize] = cur;
            let pos = key.child_index(level);
            let b = self.store.kids(cur);
            if b != NO_BLOCK && self.store.child_present(level + 1, b, pos) {
                cur = NodeRef {
                    depth: level + 1,
                    slot: pos as u8,
                    block: b,
                };
                continue;
            }
            if b == NO_BLOCK && !just_created {
                // a leaf of this tree covering the region
                let v = self.store.value(cur);
                if d.exits_at(v) {
                    return;
                }
                let g = d.apply(v);
                if g == v {
                    // every voxel's update prunes straight back into this leaf; the bits of
                    // the region's first voxel survive only when it is the leaf's first voxel
                    if key.min_at_depth(depth) == key.min_at_depth(level) {
                        self.store.set_value(cur, g);
                    }
                    self.refresh_path(&path[..level as usize]);
                    return;
                }
                for l in level..depth {
                    path[l as usize] = cur;
                    self.store.expand_node(cur);
                    self.add_size(8);
                    cur = NodeRef {
                        depth: l + 1,
                        slot: key.child_index(l) as u8,
                        block: self.store.kids(cur),
                    };
                }
                self.store.set_value(cur, g);
                self.refresh_path(&path[..depth as usize]);
                return;
            }
            cur = self.store.create_child_zero(cur, pos);
            self.add_size(1);
            just_created = true;
        }
        if just_created {
            // unknown space: every voxel created from 0, pruned into one leaf
            self.store.set_value(cur, d.apply(0.0));
        } else if self.store.has_children(cur) {
            if !self.update_subtree(cur, d) {
                return;
            }
        } else {
            let v = self.store.value(cur);
            if d.exits_at(v) {
                return;
            }
            self.store.set_value(cur, d.apply(v));
        }
        self.refresh_path(&path[..depth as usize]);
    }

    /// Apply `d` to every voxel below the inner node `n`; returns whether anything changed
    /// (when not, `n` is left as it is, stale or not, as OctoMap leaves it).
    fn update_subtree(&mut self, n: NodeRef, d: Delta) -> bool {
        let mut touched = false;
        for i in 0..8 {
            match self.store.child(n, i) {
                None => {
                    self.store.create_child(n, i, d.apply(0.0));
                    self.add_size(1);
                    touched = true;
                }
                Some(c) if self.store.has_children(c) => {
                    touched |= self.update_subtree(c, d);
                }
                Some(c) => {
                    let v = self.store.value(c);
                    if !d.exits_at(v) {
                        self.store.set_value(c, d.apply(v));
                        touched = true;
                    }
                }
            }
        }
        if touched && self.store.prune_or_refresh(n) == Some(true) {
            self.sub_size(8);
        }
        touched
    }

    /// Prune or refresh the nodes of `path` (root first) bottom-up, as an eager update does
    /// after changing the node below them.
    fn refresh_path(&mut self, path: &[NodeRef]) {
        for n in path.iter().rev() {
            if self.store.prune_or_refresh(*n) == Some(true) {
                self.sub_size(8);
            }
        }
    }
}
