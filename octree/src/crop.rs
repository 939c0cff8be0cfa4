//! Cropping a map to a box of voxels: everything outside is deleted, everything inside kept
//! with its value, pruned cubes cut where the box boundary crosses them.
//!
//! The box is inclusive in keys, as OctoMap's bounding-box iterators take it
//! (`begin_leafs_bbx(min, max)` with `coordToKey` of the corners). The walk only descends
//! into nodes the boundary crosses, so its cost is that of the boundary, not of the volume.

use crate::key::{Key, TREE_DEPTH};
use crate::tree::OcTree;

impl OcTree {
    /// Delete every voxel outside the inclusive key box `[min, max]` (corners in any order),
    /// keeping the values inside; pruned nodes the boundary crosses are expanded first (as
    /// OctoMap's `deleteNode` does), inner nodes get the max of their remaining children, and
    /// the tree is pruned again at the end. A box holding no known voxel leaves an empty tree.
    pub fn crop(&mut self, min: Key, max: Key) {
        let lo = [0, 1, 2].map(|a| min[a].min(max[a]));
        let hi = [0, 1, 2].map(|a| min[a].max(max[a]));
        if self.leaves_in_bbx(Key(lo), Key(hi)).next().is_none() {
            self.clear();
            return;
        }
        // a root that is one pruned cube gets children to delete from (a no-op otherwise)
        let root_key = Key([0; 3]);
        self.expand_node(root_key, 0);
        self.crop_node(root_key, 0, lo, hi);
        self.update_inner_occupancy();
        self.prune();
    }

    /// Crop below the node at `depth` holding `key`, which the box boundary crosses.
    fn crop_node(&mut self, key: Key, depth: u8, lo: [u16; 3], hi: [u16; 3]) {
        let child_size = 1u32 << (TREE_DEPTH - depth - 1);
        for i in 0..8 {
            let Some(ck) = OcTree::child_key(key, depth, i) else {
                return;
            };
            let cd = depth + 1;
            // the child's cube of keys
            let first = [0, 1, 2].map(|a| u32::from(ck[a]) & !(child_size - 1));
            let last = first.map(|f| f + child_size - 1);
            let outside = (0..3).any(|a| last[a] < u32::from(lo[a]) || first[a] > u32::from(hi[a]));
            let inside =
                (0..3).all(|a| first[a] >= u32::from(lo[a]) && last[a] <= u32::from(hi[a]));
            if inside || self.search(ck, cd).is_none() {
                continue;
            }
            if outside {
                self.delete_node(ck, cd);
            } else {
                self.crop_node(ck, cd, lo, hi);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::io::write_ot;
    use crate::validate::check_well_formed;
    use crate::{InnerNodes, Key, OcTree, Update};
    use proptest::prelude::*;

    const LO: u16 = 32760;
    const N: u16 = 16;

    fn ot(t: &OcTree) -> Vec<u8> {
        let mut out = Vec::new();
        write_ot(t, &mut out).unwrap();
        out
    }

    /// The definition: a new tree holding exactly the voxels of `t` inside the box, each with
    /// its value, set one voxel at a time and pruned.
    fn naive(t: &OcTree, lo: [u16; 3], hi: [u16; 3]) -> OcTree {
        let mut out = OcTree::new(t.resolution()).unwrap();
        for x in LO..LO + N {
            for y in LO..LO + N {
                for z in LO..LO + N {
                    let inside = [x, y, z]
                        .iter()
                        .zip(lo.iter().zip(&hi))
                        .all(|(&k, (&l, &h))| l <= k && k <= h);
                    if !inside {
                        continue;
                    }
                    if let Some(n) = t.search(Key::new(x, y, z), 16) {
                        let _ = out.set_node_value(Key::new(x, y, z), n.value, InnerNodes::Refresh);
                    }
                }
            }
        }
        out.prune();
        out
    }

    proptest! {
        /// Cropping gives, node for node (`.ot` bytes, exact values), the tree of the voxels
        /// inside the box built from scratch, with pruned cubes on the boundary and inside.
        #[test]
        fn crop_is_the_tree_of_the_voxels_inside(
            ops in prop::collection::vec((0u16..16, 0u16..16, 0u16..16, any::<bool>()), 0..300),
            cube in any::<bool>(),
            a in (0u16..16, 0u16..16, 0u16..16),
            b in (0u16..16, 0u16..16, 0u16..16),
        ) {
            let mut t = OcTree::new(0.1).unwrap();
            for &(x, y, z, hit) in &ops {
                let u = if hit { Update::Hit } else { Update::Miss };
                t.update_node(Key::new(LO + x, LO + y, LO + z), u, InnerNodes::Refresh);
            }
            if cube {
                for x in 0..8 {
                    for y in 0..8 {
                        for z in 0..8 {
                            t.update_node(Key::new(LO + 8 + x, LO + y, LO + 8 + z), Update::Miss, InnerNodes::Refresh);
                        }
                    }
                }
            }
            t.prune();
            let (ka, kb) = (Key::new(LO + a.0, LO + a.1, LO + a.2), Key::new(LO + b.0, LO + b.1, LO + b.2));
            let lo = [0, 1, 2].map(|i| ka[i].min(kb[i]));
            let hi = [0, 1, 2].map(|i| ka[i].max(kb[i]));
            let want = naive(&t, lo, hi);
            let mut got = t.clone();
            got.crop(ka, kb);
            prop_assert_eq!(check_well_formed(&got, InnerNodes::Refresh), Ok(()));
            prop_assert_eq!(got.size(), want.size());
            prop_assert!(ot(&got) == ot(&want));
            // the whole region: nothing changes
            let mut all = t.clone();
            all.crop(Key::new(LO, LO, LO), Key::new(LO + N - 1, LO + N - 1, LO + N - 1));
            prop_assert!(ot(&all) == ot(&t));
        }
    }

    #[test]
    fn a_box_without_known_voxels_leaves_an_empty_tree() {
        let mut t = OcTree::new(0.1).unwrap();
        t.update_node(Key::new(LO, LO, LO), Update::Hit, InnerNodes::Refresh);
        t.crop(Key::new(LO + 1, LO, LO), Key::new(LO + 5, LO + 5, LO + 5));
        assert!(t.is_empty());
        assert_eq!(t.size(), 0);
    }

    #[test]
    fn a_root_that_is_one_cube_is_cut() {
        // deleting a tree's only voxel leaves the root childless: one cube over the key space
        let mut t = OcTree::new(0.1).unwrap();
        let k = Key::new(LO, LO, LO);
        t.update_node(k, Update::Hit, InnerNodes::Refresh);
        assert!(t.delete_node(k, 16));
        assert_eq!((t.size(), t.leaves().count()), (1, 1));
        let v = t.root_value().unwrap();
        t.crop(k, Key::new(LO + 1, LO, LO));
        assert_eq!(check_well_formed(&t, InnerNodes::Refresh), Ok(()));
        let leaves: Vec<_> = t.leaves().map(|l| (l.key, l.depth, l.value)).collect();
        assert_eq!(leaves, [(k, 16, v), (Key::new(LO + 1, LO, LO), 16, v)]);
    }
}
