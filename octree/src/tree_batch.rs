//! Batched updates: many keys in one walk, same result as one `update_node` call per key.
//!
//! Consecutive keys share their path from the root down to their deepest common ancestor, so
//! the walk only re-descends below it. Ancestors are pruned or refreshed (max of children)
//! once, when the walk leaves them, instead of after every key. That is equivalent to
//! OctoMap's per-key ascent: pruning never changes a voxel's value, a pruned node that is
//! expanded again gets back the same eight equal leaves, and every ancestor is still
//! processed after the last update below it. Keys sorted by [`Key::morton`] give the shortest
//! walks; any order gives the same tree.

use crate::key::{Key, TREE_DEPTH};
use crate::leaves::{Adder, Outcome};
use crate::node::{NodeRef, NO_BLOCK};
use crate::tree::{OcTree, Update};

impl OcTree {
    /// Apply `update` to every key in `keys`, in order; the tree ends exactly as after calling
    /// [`OcTree::update_node`] for each key in turn (same values, same structure, same size).
    ///
    /// Much faster than single updates when keys are sorted by [`Key::morton`]. A NaN delta
    /// changes nothing.
    pub fn update_keys(&mut self, keys: &[Key], update: Update, lazy: bool) {
        // change detection costs a value read before and after each update: compiled in
        // only when it is on
        if self.is_change_detection_enabled() {
            self.update_keys_with::<true>(keys, update, lazy)
        } else {
            self.update_keys_with::<false>(keys, update, lazy)
        }
    }

    /// [`OcTree::update_keys`], recording changes when `TRACK`.
    fn update_keys_with<const TRACK: bool>(&mut self, keys: &[Key], update: Update, lazy: bool) {
        let delta = self.delta(update);
        if delta.is_nan() || keys.is_empty() {
            return;
        }
        let (cmin, cmax) = (self.params().clamp_min, self.params().clamp_max);
        let add = self.store.adder(delta, cmin, cmax);
        let mut memo = self.store.take_memo(&add);
        let mut path = [NodeRef::ROOT; TREE_DEPTH as usize + 1];
        // `valid` = number of leading path entries (depth 0..valid) known to match the previous
        // key's path and still exist; ancestors below that have been processed.
        let mut valid = 0usize;
        // `dirty` = number of leading path entries with an applied update below them since
        // they were last refreshed; a key that takes OctoMap's early exit dirties nothing, as
        // `updateNode` then refreshes no ancestor
        let mut dirty = 0usize;
        let mut prev: Option<Key> = None;
        for &key in keys {
            let common = match prev {
                Some(p) => common_depth(p, key).min(valid.saturating_sub(1)),
                None => 0,
            };
            if common == TREE_DEPTH as usize - 1 && valid == TREE_DEPTH as usize + 1 {
                // a sibling of the previous voxel, whose whole path exists: only the leaf
                // block is touched (the previous leaf needs no refresh)
                let block = path[TREE_DEPTH as usize].block;
                let pos = key.child_index(TREE_DEPTH - 1);
                let leaf = NodeRef {
                    depth: TREE_DEPTH,
                    slot: pos as u8,
                    block,
                };
                let old = if TRACK { self.store.value(leaf) } else { 0.0 };
                path[TREE_DEPTH as usize] = leaf;
                prev = Some(key);
                let Outcome::Applied(created) =
                    self.store.update_leaf(leaf, &add, false, &mut memo)
                else {
                    // OctoMap's early exit at a voxel already at the clamp
                    continue;
                };
                self.add_size(usize::from(created));
                if TRACK {
                    let v = self.store.value(leaf);
                    self.record_change(key, old, v, created);
                }
                dirty = TREE_DEPTH as usize + 1;
                continue;
            }
            // leave the previous key's nodes below the common ancestor
            if !lazy {
                for d in (common + 1..valid.min(dirty)).rev() {
                    self.refresh(path[d]);
                }
            }
            dirty = dirty.min(common + 1);
            let just_rooted = self.store.root_val.is_none();
            if just_rooted {
                self.store.root_val = Some(0.0);
                self.add_size(1);
            }
            let (v, applied) = self.apply_from::<TRACK>(
                key,
                &mut path,
                if just_rooted { 0 } else { common },
                just_rooted,
                &add,
                &mut memo,
            );
            valid = v;
            if applied {
                dirty = valid;
            }
            prev = Some(key);
        }
        if !lazy {
            for d in (0..valid).rev() {
                self.refresh(path[d]);
            }
        }
        self.store.put_memo(&add, memo);
    }

    /// Prune `n` or set it to the max of its children (the per-ancestor step of
    /// `updateNodeRecurs`). Leaves are left alone.
    #[inline]
    fn refresh(&mut self, n: NodeRef) {
        if self.store.prune_or_refresh(n) == Some(true) {
            self.sub_size(8);
        }
    }

    /// Walk from `path[start]` to `key`'s voxel, creating or expanding nodes, and apply the
    /// delta; returns how many path entries (from the root) are valid afterwards and whether
    /// the delta was applied (not OctoMap's early exit). Returns
    /// early, creating nothing, when OctoMap's clamp early-exit applies.
    #[inline]
    fn apply_from<const TRACK: bool>(
        &mut self,
        key: Key,
        path: &mut [NodeRef; TREE_DEPTH as usize + 1],
        start: usize,
        root_just_created: bool,
        add: &Adder,
        memo: &mut Vec<u16>,
    ) -> (usize, bool) {
        // read-only descent to the deepest existing node (OctoMap's `search`)
        let mut d = start;
        let mut cur = path[d];
        let mut missing_child = false;
        while d < TREE_DEPTH as usize {
            let b = self.store.kids(cur);
            if b == NO_BLOCK {
                break;
            }
            let pos = key.child_index(d as u8);
            if !self.store.child_present(d as u8 + 1, b, pos) {
                missing_child = true;
                break;
            }
            cur = NodeRef {
                depth: d as u8 + 1,
                slot: pos as u8,
                block: b,
            };
            d += 1;
            path[d] = cur;
        }
        if !missing_child && !root_just_created && add.exits_at(self.store.value(cur)) {
            return (d + 1, false);
        }
        // create or expand the rest of the path
        let mut just_created = root_just_created;
        while d < TREE_DEPTH as usize {
            let pos = key.child_index(d as u8);
            let created = if self.store.kids(cur) == NO_BLOCK && !just_created {
                self.store.expand_node(cur);
                self.add_size(8);
                false
            } else {
                self.store.create_child_zero(cur, pos);
                self.add_size(1);
                true
            };
            cur = NodeRef {
                depth: d as u8 + 1,
                slot: pos as u8,
                block: self.store.kids(cur),
            };
            d += 1;
            path[d] = cur;
            just_created = created;
            if created && d < TREE_DEPTH as usize {
                // everything below a new node is new: one block per level, no checks
                cur = self.store.create_chain(cur, key, path);
                self.add_size(TREE_DEPTH as usize - d);
                d = TREE_DEPTH as usize;
            }
        }
        let old = if TRACK { self.store.value(cur) } else { 0.0 };
        // an existing voxel (or a pruned node expanded to it) passed the early-exit test above
        if self.store.update_leaf(cur, add, just_created, memo) == Outcome::Exit {
            return (TREE_DEPTH as usize + 1, false);
        }
        if TRACK {
            let v = self.store.value(cur);
            self.record_change(key, old, v, just_created);
        }
        (TREE_DEPTH as usize + 1, true)
    }
}

/// Depth of the deepest node containing both keys (16 when equal, 0 when only the root does).
#[inline]
fn common_depth(a: Key, b: Key) -> usize {
    let diff = (a.x() ^ b.x()) | (a.y() ^ b.y()) | (a.z() ^ b.z());
    diff.leading_zeros() as usize
}
