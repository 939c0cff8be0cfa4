//! Leaf and node iteration in OctoMap's order: depth-first pre-order, children 0..7.

use crate::key::{Key, KEY_CENTER, TREE_DEPTH};
use crate::store::NodeRef;
use crate::tree::OcTree;

/// A node visited by an iterator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodeItem {
    /// The node's key in OctoMap's iterator convention: its smallest depth-16 key plus half
    /// its width in keys (equal to the voxel key at depth 16).
    pub key: Key,
    /// Depth of the node (0 = root, 16 = voxel).
    pub depth: u8,
    /// Its log-odds.
    pub value: f32,
    /// Whether it has children.
    pub has_children: bool,
}

impl NodeItem {
    /// Smallest depth-16 key inside the node.
    pub fn min_key(&self) -> Key {
        self.key.min_at_depth(self.depth)
    }

    /// Number of depth-16 keys per axis the node spans: `2^(16 - depth)`.
    pub fn width(&self) -> u32 {
        1u32 << (TREE_DEPTH - self.depth)
    }
}

/// What an iterator yields.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Mode {
    Leaves,
    All,
}

/// Pre-order iterator over nodes or leaves, optionally limited to a depth and a key box.
pub struct TreeIter<'a> {
    tree: &'a OcTree,
    stack: Vec<(NodeRef, [u16; 3])>,
    max_depth: u8,
    mode: Mode,
    bbx: Option<(Key, Key)>,
}

impl<'a> TreeIter<'a> {
    fn new(tree: &'a OcTree, mode: Mode, max_depth: u8, bbx: Option<(Key, Key)>) -> Self {
        let mut stack = Vec::with_capacity(8 * TREE_DEPTH as usize);
        if !tree.is_empty() {
            stack.push((NodeRef::ROOT, [0u16; 3]));
        }
        TreeIter {
            tree,
            stack,
            max_depth: max_depth.min(TREE_DEPTH),
            mode,
            bbx,
        }
    }

    fn overlaps(&self, min: [u16; 3], depth: u8) -> bool {
        let Some((lo, hi)) = self.bbx else {
            return true;
        };
        let w = (1u32 << (TREE_DEPTH - depth)) - 1;
        (0..3).all(|a| (min[a] as u32) <= hi[a] as u32 && (min[a] as u32 + w) >= lo[a] as u32)
    }
}

impl Iterator for TreeIter<'_> {
    type Item = NodeItem;

    fn next(&mut self) -> Option<NodeItem> {
        while let Some((n, min)) = self.stack.pop() {
            let store = &self.tree.store;
            let descend = n.depth < self.max_depth && store.has_children(n);
            if descend {
                let cw = 1u32 << (TREE_DEPTH - n.depth - 1);
                for i in (0..8).rev() {
                    if let Some(c) = store.child(n, i) {
                        let mut cm = min;
                        for (a, v) in cm.iter_mut().enumerate() {
                            if i & (1 << a) != 0 {
                                *v = (*v as u32 + cw) as u16;
                            }
                        }
                        if self.overlaps(cm, c.depth) {
                            self.stack.push((c, cm));
                        }
                    }
                }
            }
            if self.mode == Mode::All || !descend {
                let half = if n.depth == TREE_DEPTH {
                    0
                } else {
                    (KEY_CENTER >> n.depth) as u32
                };
                let key = Key(min.map(|m| (m as u32 + half) as u16));
                return Some(NodeItem {
                    key,
                    depth: n.depth,
                    value: store.value(n),
                    has_children: store.has_children(n),
                });
            }
        }
        None
    }
}

impl OcTree {
    /// All leaves in pre-order (OctoMap's `leaf_iterator`).
    pub fn leaves(&self) -> TreeIter<'_> {
        TreeIter::new(self, Mode::Leaves, TREE_DEPTH, None)
    }

    /// Leaves, treating nodes at `max_depth` as leaves (OctoMap's `begin_leafs(maxDepth)`).
    pub fn leaves_to_depth(&self, max_depth: u8) -> TreeIter<'_> {
        TreeIter::new(self, Mode::Leaves, max_depth, None)
    }

    /// Leaves whose cube overlaps the inclusive key box `[min, max]`
    /// (OctoMap's `begin_leafs_bbx`).
    pub fn leaves_in_bbx(&self, min: Key, max: Key) -> TreeIter<'_> {
        let lo = Key([0, 1, 2].map(|a| min[a].min(max[a])));
        let hi = Key([0, 1, 2].map(|a| min[a].max(max[a])));
        TreeIter::new(self, Mode::Leaves, TREE_DEPTH, Some((lo, hi)))
    }

    /// Every node, inner ones too, in pre-order (OctoMap's `tree_iterator`).
    pub fn nodes(&self) -> TreeIter<'_> {
        TreeIter::new(self, Mode::All, TREE_DEPTH, None)
    }
}
