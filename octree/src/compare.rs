//! Voxel-by-voxel comparison of two maps by occupancy class (unknown, free, occupied).
//!
//! Two maps of the same scene built differently (OctoMap's DDA rays against Bresenham rays,
//! say) are compared by the class each gives every finest-level voxel, so that "how much of
//! the map agrees" is one number. Both trees are walked together; where one is a pruned leaf,
//! its class stands for every voxel below it, so the walk costs the size of the two trees, not
//! the volume.

use crate::error::OctreeError;
use crate::key::TREE_DEPTH;
use crate::store::{present, NodeRef, NO_BLOCK};
use crate::tree::OcTree;

/// What a map says about a voxel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum VoxelClass {
    /// No node covers the voxel.
    Unknown = 0,
    /// A node covers it with log-odds below the occupancy threshold.
    Free = 1,
    /// A node covers it with log-odds at or above the occupancy threshold.
    Occupied = 2,
}

impl VoxelClass {
    /// The three classes, in index order.
    pub const ALL: [VoxelClass; 3] = [VoxelClass::Unknown, VoxelClass::Free, VoxelClass::Occupied];
}

/// Finest-level voxel counts per pair of classes: `counts[a][b]` voxels are of class `a` in
/// the first map and `b` in the second (indexes are [`VoxelClass`] as `usize`). Voxels unknown
/// to both maps are not counted (`counts[0][0] == 0`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ClassComparison {
    /// The confusion matrix, in voxels.
    pub counts: [[u64; 3]; 3],
}

impl ClassComparison {
    /// Voxels known (free or occupied) to at least one of the maps.
    pub fn known_in_either(&self) -> u64 {
        self.counts.iter().flatten().sum()
    }

    /// Voxels both maps put in the same class (both free or both occupied).
    pub fn agreeing(&self) -> u64 {
        self.counts[1][1] + self.counts[2][2]
    }

    /// Share of [`known_in_either`](Self::known_in_either) voxels with the same class in both
    /// maps; 1 for two empty maps.
    pub fn agreement(&self) -> f64 {
        let known = self.known_in_either();
        if known == 0 {
            1.0
        } else {
            self.agreeing() as f64 / known as f64
        }
    }

    /// Voxels of class `a` in the first map and `b` in the second.
    pub fn count(&self, a: VoxelClass, b: VoxelClass) -> u64 {
        self.counts[a as usize][b as usize]
    }
}

/// One side of the joint walk.
#[derive(Clone, Copy)]
enum Side {
    /// Unknown space.
    Absent,
    /// A node without children (a voxel or a pruned cube): its class covers everything below.
    Leaf(VoxelClass),
    /// A node with children.
    Inner(NodeRef),
}

impl OcTree {
    fn side(&self, n: NodeRef) -> Side {
        if self.store.has_children(n) {
            Side::Inner(n)
        } else if self.params.is_occupied(self.store.value(n)) {
            Side::Leaf(VoxelClass::Occupied)
        } else {
            Side::Leaf(VoxelClass::Free)
        }
    }

    /// The eight children of a side: an inner node's children read from its block once; a
    /// leaf or unknown space stands for all eight.
    fn child_sides(&self, s: Side) -> [Side; 8] {
        let Side::Inner(n) = s else {
            return [s; 8];
        };
        let b = self.store.kids(n);
        let cd = n.depth + 1;
        let vals = self.store.child_vals(cd, b);
        let kids = if cd < TREE_DEPTH {
            self.store.inner.blocks[b as usize].kids
        } else {
            [NO_BLOCK; 8]
        };
        std::array::from_fn(|i| {
            let v = vals[i];
            if !present(v) {
                Side::Absent
            } else if kids[i] != NO_BLOCK {
                Side::Inner(NodeRef {
                    depth: cd,
                    slot: i as u8,
                    block: b,
                })
            } else if self.params.is_occupied(v) {
                Side::Leaf(VoxelClass::Occupied)
            } else {
                Side::Leaf(VoxelClass::Free)
            }
        })
    }

    fn root_side(&self) -> Side {
        if self.store.root_val.is_none() {
            Side::Absent
        } else {
            self.side(NodeRef::ROOT)
        }
    }
}

/// Compare the occupancy class of every voxel in two maps of the same resolution (each map
/// classifies with its own occupancy threshold).
///
/// Errors when the resolutions differ, since voxels would not line up.
pub fn compare_classes(a: &OcTree, b: &OcTree) -> Result<ClassComparison, OctreeError> {
    if a.resolution() != b.resolution() {
        return Err(OctreeError::ResolutionMismatch {
            first: a.resolution(),
            second: b.resolution(),
        });
    }
    let mut out = ClassComparison::default();
    walk(a, b, a.root_side(), b.root_side(), 0, &mut out);
    Ok(out)
}

fn walk(a: &OcTree, b: &OcTree, sa: Side, sb: Side, depth: u8, out: &mut ClassComparison) {
    let class = |s: Side| match s {
        Side::Absent => Some(VoxelClass::Unknown),
        Side::Leaf(c) => Some(c),
        Side::Inner(_) => None,
    };
    match (class(sa), class(sb)) {
        (Some(VoxelClass::Unknown), Some(VoxelClass::Unknown)) => {}
        (Some(ca), Some(cb)) => {
            let voxels = 1u64 << (3 * (TREE_DEPTH - depth) as u32);
            out.counts[ca as usize][cb as usize] += voxels;
        }
        _ => {
            let (ka, kb) = (a.child_sides(sa), b.child_sides(sb));
            for i in 0..8 {
                walk(a, b, ka[i], kb[i], depth + 1, out);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{InnerNodes, Key, Update};
    use proptest::prelude::*;

    /// The definition: look every voxel of the box up in both maps.
    fn naive(a: &OcTree, b: &OcTree, lo: u16, n: u16) -> ClassComparison {
        let class = |t: &OcTree, k: Key| match t.is_occupied(k) {
            None => VoxelClass::Unknown,
            Some(false) => VoxelClass::Free,
            Some(true) => VoxelClass::Occupied,
        };
        let mut out = ClassComparison::default();
        for x in lo..lo + n {
            for y in lo..lo + n {
                for z in lo..lo + n {
                    let k = Key::new(x, y, z);
                    let (ca, cb) = (class(a, k), class(b, k));
                    if (ca, cb) != (VoxelClass::Unknown, VoxelClass::Unknown) {
                        out.counts[ca as usize][cb as usize] += 1;
                    }
                }
            }
        }
        out
    }

    const LO: u16 = 32760;
    const N: u16 = 16;

    fn tree(ops: &[(u8, u8, u8, bool)], prune: bool) -> OcTree {
        let mut t = OcTree::new(0.1).unwrap();
        for &(x, y, z, hit) in ops {
            let k = Key::new(
                LO + (x % N as u8) as u16,
                LO + (y % N as u8) as u16,
                LO + (z % N as u8) as u16,
            );
            let u = if hit { Update::Hit } else { Update::Miss };
            t.update_node(k, u, InnerNodes::Refresh);
        }
        if prune {
            t.prune();
        }
        t
    }

    proptest! {
        /// The joint walk counts exactly what a voxel-by-voxel look-up counts, with pruned
        /// cubes (whole 2x2x2 and 4x4x4 blocks updated alike) on either side.
        #[test]
        fn matches_voxel_lookups(
            a in prop::collection::vec((0u8..16, 0u8..16, 0u8..16, any::<bool>()), 0..400),
            b in prop::collection::vec((0u8..16, 0u8..16, 0u8..16, any::<bool>()), 0..400),
            fill in any::<bool>(),
        ) {
            let mut ta = tree(&a, true);
            let tb = tree(&b, false);
            if fill {
                // a solid free cube, pruned to one node in `ta`
                for x in 0..8 {
                    for y in 0..8 {
                        for z in 0..8 {
                            ta.update_node(Key::new(LO + 8 + x, LO + y, LO + z), Update::Miss, InnerNodes::Refresh);
                        }
                    }
                }
            }
            let got = compare_classes(&ta, &tb).unwrap();
            prop_assert_eq!(got, naive(&ta, &tb, LO, N));
            let same = compare_classes(&ta, &ta).unwrap();
            prop_assert_eq!(same.agreement(), 1.0);
            prop_assert_eq!(same.known_in_either(), naive(&ta, &ta, LO, N).known_in_either());
        }
    }

    #[test]
    fn resolutions_must_match() {
        let a = OcTree::new(0.1).unwrap();
        let b = OcTree::new(0.2).unwrap();
        assert!(compare_classes(&a, &b).is_err());
        assert_eq!(compare_classes(&a, &a).unwrap().agreement(), 1.0);
    }
}
