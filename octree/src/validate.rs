//! Structural checks for tests: the invariants every tree must keep.

use crate::store::{present, NodeRef, NO_BLOCK};
use crate::tree::{InnerNodes, OcTree};
use crate::{ColorOcTree, StampedOcTree};

/// Check the bookkeeping of a stamped tree's side table, returning a description of the first
/// violation: each block's slab records where each group of eight entries starts consistently
/// with the entries it holds, fits its segment and holds an entry, and the entry count adds
/// up. Structural only: which stamps are right is for the differential tests.
pub fn check_stamp_table(tree: &StampedOcTree) -> Result<(), String> {
    tree.base.check_payloads()
}

/// [`check_stamp_table`] for a colour tree's side table.
pub fn check_color_table(tree: &ColorOcTree) -> Result<(), String> {
    tree.base.check_payloads()
}

/// Check the tree's invariants, returning a description of the first violation:
/// the node count matches `size()`, every child block holds at least one child, no value is
/// NaN, and (with [`InnerNodes::Refresh`]) every inner node equals the max of its children and
/// no node is collapsible. Pass [`InnerNodes::Defer`] for trees whose inner nodes may be stale:
/// after deferred updates, `prune()` (which may stop early) or reading a `.bt` (whose root keeps
/// the upper clamp).
pub fn check_well_formed(tree: &OcTree, inner: InnerNodes) -> Result<(), String> {
    if tree.is_empty() {
        return if tree.size() == 0 {
            Ok(())
        } else {
            Err(format!("empty tree with size {}", tree.size()))
        };
    }
    let store = &tree.store;
    let mut count = 0usize;
    let mut stack = vec![NodeRef::ROOT];
    while let Some(n) = stack.pop() {
        count += 1;
        let v = store.value(n);
        if !present(v) || v.is_nan() {
            return Err(format!("node {n:?} has a NaN value"));
        }
        let b = store.kids(n);
        if b == NO_BLOCK {
            continue;
        }
        if n.depth >= 16 {
            return Err(format!("depth-16 node {n:?} has children"));
        }
        let mut any = false;
        let mut all_equal_leaves = true;
        let first = store.child(n, 0).map(|c| store.value(c));
        for i in 0..8 {
            match store.child(n, i) {
                Some(c) => {
                    any = true;
                    stack.push(c);
                    if store.has_children(c) || Some(store.value(c)) != first {
                        all_equal_leaves = false;
                    }
                }
                None => all_equal_leaves = false,
            }
        }
        if !any {
            return Err(format!("node {n:?} has an empty child block"));
        }
        if !inner.is_deferred() {
            let m = store.max_child(n);
            if m.to_bits() != v.to_bits() && m != v {
                return Err(format!("inner node {n:?} value {v} != max child {m}"));
            }
            if all_equal_leaves && n.depth > 0 {
                return Err(format!("node {n:?} is collapsible but not pruned"));
            }
        }
    }
    if count != tree.size() {
        return Err(format!(
            "walked {count} nodes but size() is {}",
            tree.size()
        ));
    }
    Ok(())
}

/// Panic with the violation if [`check_well_formed`] fails.
pub fn assert_well_formed(tree: &OcTree, inner: InnerNodes) {
    if let Err(e) = check_well_formed(tree, inner) {
        panic!("octree not well formed: {e}");
    }
}
