//! A pass of updates on a [`ColorOcTree`] in a given order (a scan's `KeySet` order), at the
//! speed of the plain tree's batched walk where the order cannot show.
//!
//! # Why the order matters, and where
//!
//! Occupancy updates change colours only through the structure: a prune gives a node its
//! children's average colour (or child 0's), an expansion copies the node's colour down. So
//! a node pruned by one update and expanded again by a later one of the same pass hands all
//! its children the average colour, and which voxels it averaged depends on the order. Nothing
//! else does: values do not depend on the order (each voxel of a pass is updated once), the
//! expansions of nodes pruned before the pass copy down what they held before it, and a node
//! that is pruned during the pass and not expanded again ends pruned with the colours its
//! children end with. The batched walk (`tree_batch.rs`) prunes a node once, when it leaves
//! it, which is OctoMap's result exactly when no node is pruned and then expanded within the
//! pass.
//!
//! # Which nodes might be ("hazards")
//!
//! OctoMap checks a node for pruning right after an update below it, of a voxel `x` that
//! then holds its new value `f(x)`; the node is collapsible only if every voxel below it holds
//! one value `c` then, so `c = f(x)` ("`x` reaches `c`"). A later expansion needs a later
//! update, not an early exit, of a voxel `x'` below it while it is pruned at `c`, so whose
//! value before the pass is `c` ("`x'` leaves `c`"). At that moment each voxel below the node
//! holds either its value before the pass or, if already updated, its value after it. So a
//! node is a hazard only if some `c` is allowed by every voxel below it (a voxel the pass does
//! not update allows its value; one it updates allows its value before and after; a voxel
//! that does not exist allows nothing) and some voxel below reaches `c` and another (or the
//! same) leaves `c`. That is decided bottom-up without the order, with at most two
//! candidate values per subtree; a child that the pass does not touch and that has children
//! keeps them through the pass, so its parent can never be collapsed and allows nothing.
//! The test ignores the rest of the structure (a child must be a leaf too), so it may name a
//! node that is never pruned: that costs time, never exactness.
//!
//! With the order, the same search is sharper: every voxel that leaves `c` must come after
//! the check and every voxel that reaches `c` from another value no later than it, so a node
//! is a hazard only if the last such voxel to reach `c` comes before the first to leave it.
//! The order is asked for only when the search without it finds a node (a scan's `KeySet`
//! order costs more than its updates; an empty tree never needs it).
//!
//! # The pass
//!
//! The voxels below the topmost nodes found without the order that hold a hazard in the
//! given order are updated one at a time in that order, with OctoMap's per-voxel ascent;
//! every other stretch of voxels (sorted by Morton code) goes through the batched walk, whose
//! hooks copy colours down on expansion and average them on collapse. Such a node is kept
//! whole, not cut down to the hazard inside it: the walks on either side of it leave its
//! ancestors refreshed, and may prune them, before the updates below it are done, which only
//! the search without the order (any order) shows to be harmless. Each walk leaves every node
//! it touched refreshed, and an early prune of a node that is no hazard in any order is its
//! final prune (a later update below it would make it one). A node inside one walk is pruned
//! only when the walk leaves it for good, after all its updates, so for it no hazard in the
//! given order suffices. With deferred inner nodes nothing is pruned, so the walk takes the
//! whole pass.

use crate::color::Color;
use crate::color_tree::ColorOcTree;
use crate::key::{Key, TREE_DEPTH};
use crate::node_id::{NodeId, NodeMap};
use crate::payload_tree::{collapse_into, copy_to_children};
use crate::store::{clamp_sum, NodeRef};
use crate::tree::{InnerNodes, OcTree, Update};
use crate::tree_batch::{morton_bricks, WalkHooks};

impl ColorOcTree {
    /// Apply `update` to every key in `keys`, in order: the tree and its colours end exactly
    /// as after [`ColorOcTree::update_node`] for each key in turn (OctoMap's `updateNode` in a
    /// loop, as `insertPointCloud` runs over its `KeySet`s).
    ///
    /// Much faster than single updates when the keys are distinct: the voxels whose order can
    /// change a colour (see the module docs of `color_batch`) are updated one by one, the
    /// others in the plain tree's batched walk. Keys given twice make it one update per key.
    /// A NaN delta changes nothing.
    pub fn update_keys(&mut self, keys: &[Key], update: Update, inner: InnerNodes) {
        self.update_key_set(keys, || keys.to_vec(), update, inner)
    }

    /// [`ColorOcTree::update_keys`] over the keys `order()` lists, for a caller that holds
    /// them (`keys`, the same keys in any order) more cheaply than in their order: `order` is
    /// called only when the order can change a colour. A scan's `KeySet` order costs more
    /// than its updates, and a pass into a tree without a node that a prune could undo (an
    /// empty tree, or deferred inner nodes) needs none.
    pub fn update_key_set(
        &mut self,
        keys: &[Key],
        order: impl FnOnce() -> Vec<Key>,
        update: Update,
        inner: InnerNodes,
    ) {
        let tree = &self.base.tree;
        let delta = tree.delta(update);
        if delta.is_nan() || keys.is_empty() {
            return;
        }
        let mut codes: Vec<u64> = keys.iter().map(Key::morton).collect();
        codes.sort_unstable();
        if codes.windows(2).any(|w| w[0] == w[1]) {
            // a voxel updated twice in one pass is outside the hazard test's argument
            for k in order() {
                self.update_node(k, update, inner);
            }
            return;
        }
        if inner.is_deferred() {
            // nothing is pruned, so nothing is undone
            self.walk(&codes, update, inner);
            return;
        }
        let rule = Rule {
            delta,
            cmin: tree.params().clamp_min,
            cmax: tree.params().clamp_max,
        };
        // without the order: the nodes that might be hazards in some order
        let suspects = HazardSearch::new(tree, rule).run(&codes);
        if suspects.is_empty() {
            self.walk(&codes, update, inner);
            return;
        }
        let order = order();
        let hazards = HazardSearch::new(tree, rule).narrow(&suspects, &order);
        // each hazard's keys, in order
        let mut ordered: Vec<Vec<Key>> = vec![Vec::new(); hazards.len()];
        for &k in &order {
            if let Some(h) = span_of(&hazards, k.morton()) {
                ordered[h].push(k);
            }
        }
        let mut rest = &codes[..];
        for (&(lo, hi), own) in hazards.iter().zip(&ordered) {
            let before = rest.partition_point(|&c| c < lo);
            self.walk(&rest[..before], update, inner);
            for &k in own {
                self.update_node(k, update, inner);
            }
            rest = &rest[rest.partition_point(|&c| c < hi)..];
        }
        self.walk(rest, update, inner);
    }

    /// The voxels of `codes` (sorted Morton codes) through the batched walk, the colours
    /// following its expansions and collapses.
    fn walk(&mut self, codes: &[u64], update: Update, inner: InnerNodes) {
        if codes.is_empty() {
            return;
        }
        let base = &mut self.base;
        let hooks = ColorHooks {
            colors: &mut base.payloads,
        };
        base.tree
            .update_brick_iter(morton_bricks(codes.iter().copied()), update, inner, hooks);
    }
}

/// The index of the span of `spans` (sorted, disjoint `[lo, hi)`) holding `code`.
fn span_of(spans: &[(u64, u64)], code: u64) -> Option<usize> {
    let h = spans.partition_point(|&(_, hi)| hi <= code);
    (h < spans.len() && spans[h].0 <= code).then_some(h)
}

/// The batched walk's hooks for colours: an expansion copies the node's colour to its
/// children, a collapse gives the node the colour rule's result; colours never stop one.
struct ColorHooks<'a> {
    colors: &'a mut NodeMap<Color>,
}

impl WalkHooks for ColorHooks<'_> {
    const PLAIN: bool = false;

    fn expanded(&mut self, id: NodeId) {
        copy_to_children(self.colors, id);
    }

    fn applied(&mut self, _: NodeId) {}

    fn may_prune(&mut self, _: NodeId) -> bool {
        true
    }

    fn collapsed(&mut self, id: NodeId) {
        collapse_into(self.colors, id);
    }

    fn refreshed(&mut self, _: NodeId) {}
}

/// One pass's update rule: the delta and the clamps.
#[derive(Debug, Clone, Copy)]
struct Rule {
    delta: f32,
    cmin: f32,
    cmax: f32,
}

impl Rule {
    /// OctoMap's early exit: a voxel (or the pruned node holding it) already at the clamp the
    /// update pushes towards is left alone, and no ascent follows.
    fn exits_at(self, v: f32) -> bool {
        (self.delta >= 0.0 && v >= self.cmax) || (self.delta <= 0.0 && v <= self.cmin)
    }

    /// The value after the update.
    fn apply(self, v: f32) -> f32 {
        clamp_sum(v, self.delta, self.cmin, self.cmax)
    }
}

/// A value every voxel of a subtree allows, with the last place in the pass's order of a
/// voxel that reaches it from another value (after which a prune check may find the subtree
/// uniform at it) and the first of a voxel that leaves it (which would expand a node pruned
/// at it). Without the order every voxel reaches at place 0 and leaves at place 1, so that
/// any pair counts.
#[derive(Debug, Clone, Copy, Default)]
struct Candidate {
    value: f32,
    reach: Option<u32>,
    leave: Option<u32>,
}

/// The values every voxel of a subtree allows (at most two: a voxel allows its value before
/// and after the pass); none when the subtree can never be collapsed during the pass.
#[derive(Debug, Clone, Copy, Default)]
struct Allowed {
    values: [Candidate; 2],
    len: usize,
}

impl Allowed {
    /// No value: the subtree is never uniform during the pass.
    const NONE: Allowed = Allowed {
        values: [Candidate {
            value: 0.0,
            reach: None,
            leave: None,
        }; 2],
        len: 0,
    };

    fn one(c: Candidate) -> Allowed {
        Allowed {
            values: [c, c],
            len: 1,
        }
    }

    fn candidates(&self) -> &[Candidate] {
        &self.values[..self.len]
    }

    /// The values both allow (compared as OctoMap compares node values), with the later
    /// reach and the earlier leave of the two.
    fn meet(&self, other: &Allowed) -> Allowed {
        let mut out = Allowed::NONE;
        for a in self.candidates() {
            for b in other.candidates() {
                if a.value == b.value {
                    out.values[out.len] = Candidate {
                        value: a.value,
                        reach: a.reach.max(b.reach),
                        leave: match (a.leave, b.leave) {
                            (Some(x), Some(y)) => Some(x.min(y)),
                            (x, y) => x.or(y),
                        },
                    };
                    out.len += 1;
                }
            }
        }
        out
    }

    /// Whether a node with these voxels might be pruned during the pass and expanded again:
    /// every voxel that must come before the check (it reaches the value) does so before the
    /// first that leaves it.
    fn is_hazard(&self) -> bool {
        self.candidates().iter().any(|c| match (c.reach, c.leave) {
            (Some(r), Some(l)) => r < l,
            _ => false,
        })
    }
}

/// The search for a pass's hazards on the tree as it is before the pass.
struct HazardSearch<'a> {
    tree: &'a OcTree,
    rule: Rule,
    /// The topmost hazards found so far, as spans `[lo, hi)` of voxel codes, in order.
    found: Vec<(u64, u64)>,
    /// An update that changes nothing was met: it both checks and expands, which the places
    /// in the order do not model, so the search without the order stands.
    degenerate: bool,
}

impl<'a> HazardSearch<'a> {
    fn new(tree: &'a OcTree, rule: Rule) -> Self {
        HazardSearch {
            tree,
            rule,
            found: Vec::new(),
            degenerate: false,
        }
    }

    /// The topmost nodes that might be hazards in some order of the voxels `codes` (sorted,
    /// distinct Morton codes).
    fn run(mut self, codes: &[u64]) -> Vec<(u64, u64)> {
        let root = self.tree.store.root_val.map(|_| NodeRef::ROOT);
        self.subtree(root, 0, codes, None);
        self.found
    }

    /// The spans of `suspects` (what [`HazardSearch::run`] found for the same pass) that hold
    /// a hazard when the voxels come in `order`. A suspect is kept whole: the walks on either
    /// side of it leave its ancestors refreshed and may prune them early, which only the
    /// search without the order shows to be harmless, so a node between a hazard and its
    /// suspect must not be split by a walk.
    fn narrow(mut self, suspects: &[(u64, u64)], order: &[Key]) -> Vec<(u64, u64)> {
        let mut placed: Vec<(u64, u32)> = order
            .iter()
            .enumerate()
            .filter_map(|(i, k)| {
                let c = k.morton();
                span_of(suspects, c).map(|_| (c, i as u32))
            })
            .collect();
        placed.sort_unstable();
        let (codes, places): (Vec<u64>, Vec<u32>) = placed.into_iter().unzip();
        let mut kept = Vec::new();
        for &(lo, hi) in suspects {
            let a = codes.partition_point(|&c| c < lo);
            let b = codes.partition_point(|&c| c < hi);
            let depth = TREE_DEPTH - ((hi - lo).trailing_zeros() / 3) as u8;
            let node = self.node_at(lo, depth);
            self.found.clear();
            self.subtree(node, depth, &codes[a..b], Some(&places[a..b]));
            if !self.found.is_empty() {
                kept.push((lo, hi));
            }
        }
        if self.degenerate || order.len() > u32::MAX as usize {
            return suspects.to_vec();
        }
        kept
    }

    /// The node at `depth` on the way to voxel `code`, if it exists.
    fn node_at(&self, code: u64, depth: u8) -> Option<NodeRef> {
        let store = &self.tree.store;
        self.tree.store.root_val?;
        let mut n = NodeRef::ROOT;
        for d in 0..depth {
            let shift = 3 * u32::from(TREE_DEPTH - 1 - d);
            n = store.child(n, ((code >> shift) & 7) as usize)?;
        }
        Some(n)
    }

    /// What the voxels below node `n` at `depth` (`None`: not in the tree) allow, where
    /// `codes` (not empty) are the pass's voxels below it and `places` their places in the
    /// order (`None`: unknown); records the hazards at and below it, only the topmost.
    fn subtree(
        &mut self,
        n: Option<NodeRef>,
        depth: u8,
        codes: &[u64],
        places: Option<&[u32]>,
    ) -> Allowed {
        let bits = 3 * u32::from(TREE_DEPTH - depth);
        let all = codes.len() as u64 == 1u64 << bits;
        // the last and the first place of the voxels; without the order, any pair counts
        let (last, first) = match places {
            Some(p) => (
                p.iter().copied().max().unwrap_or(0),
                p.iter().copied().min().unwrap_or(0),
            ),
            None => (0, 1),
        };
        let store = &self.tree.store;
        let Some(n) = n else {
            // unknown space: the updates create voxels at `apply(0)`; a voxel left out never
            // exists, so the node never has all its children
            return if all {
                Allowed::one(Candidate {
                    value: self.rule.apply(0.0),
                    reach: Some(last),
                    leave: None,
                })
            } else {
                Allowed::NONE
            };
        };
        if depth == TREE_DEPTH || !store.has_children(n) {
            return self.leaf(store.value(n), all, last, first);
        }
        let mark = self.found.len();
        let shift = bits - 3;
        let mut allowed: Option<Allowed> = None;
        let mut rest = codes;
        let mut rest_places = places;
        for i in 0..8 {
            let end = rest.partition_point(|&c| ((c >> shift) & 7) as usize <= i);
            let (mine, after) = rest.split_at(end);
            rest = after;
            let my_places = rest_places.map(|p| {
                let (m, a) = p.split_at(end);
                rest_places = Some(a);
                m
            });
            let child = store.child(n, i);
            let a = if mine.is_empty() {
                match child {
                    // untouched: a leaf keeps its value; a node with children keeps them
                    Some(c) if !store.has_children(c) => Allowed::one(Candidate {
                        value: store.value(c),
                        reach: None,
                        leave: None,
                    }),
                    _ => Allowed::NONE,
                }
            } else {
                self.subtree(child, depth + 1, mine, my_places)
            };
            allowed = Some(match allowed {
                None => a,
                Some(b) => b.meet(&a),
            });
        }
        let allowed = allowed.unwrap_or(Allowed::NONE);
        if allowed.is_hazard() {
            // this node's span covers the hazards found below it
            self.found.truncate(mark);
            let lo = codes[0] >> bits << bits;
            self.found.push((lo, lo + (1u64 << bits)));
        }
        allowed
    }

    /// What the voxels below a leaf of value `v` allow (a voxel, or a pruned node whose voxels
    /// all hold `v`); `all`: the pass updates every one of them; `last`, `first`: the last and
    /// first place of those it updates.
    fn leaf(&mut self, v: f32, all: bool, last: u32, first: u32) -> Allowed {
        let stays = Candidate {
            value: v,
            reach: None,
            leave: None,
        };
        if self.rule.exits_at(v) {
            return Allowed::one(stays);
        }
        let f = self.rule.apply(v);
        if f == v {
            // an update that changes nothing still checks the ancestors for pruning
            self.degenerate = true;
            return Allowed::one(Candidate {
                reach: Some(0),
                leave: Some(1),
                ..stays
            });
        }
        let left = Candidate {
            leave: Some(first),
            ..stays
        };
        if all {
            Allowed {
                values: [
                    left,
                    Candidate {
                        value: f,
                        reach: Some(last),
                        leave: None,
                    },
                ],
                len: 2,
            }
        } else {
            Allowed::one(left)
        }
    }
}

#[cfg(test)]
#[path = "color_batch_tests.rs"]
mod tests;
