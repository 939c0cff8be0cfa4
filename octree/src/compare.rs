//! Voxel-by-voxel comparison of two maps by occupancy class (unknown, free, occupied).
//!
//! Two maps of the same scene built differently (OctoMap's DDA rays against Bresenham rays,
//! say) are compared by the class each gives every finest-level voxel, so that "how much of
//! the map agrees" is one number. Both trees are walked together; where one is a pruned leaf,
//! its class stands for every voxel below it, so the walk costs the size of the two trees, not
//! the volume.

use crate::error::OctreeError;
use crate::key::{Key, TREE_DEPTH};
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
    /// A node without children (a voxel or a pruned cube): its class and log-odds cover
    /// everything below.
    Leaf(VoxelClass, f32),
    /// A node with children.
    Inner(NodeRef),
}

impl OcTree {
    fn side(&self, n: NodeRef) -> Side {
        if self.store.has_children(n) {
            Side::Inner(n)
        } else {
            self.leaf(self.store.value(n))
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
            } else {
                self.leaf(v)
            }
        })
    }

    fn leaf(&self, v: f32) -> Side {
        let class = if self.params.is_occupied(v) {
            VoxelClass::Occupied
        } else {
            VoxelClass::Free
        };
        Side::Leaf(class, v)
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
/// Errors when the resolutions differ by more than 1e-6 m (`compare_octrees`' test), since
/// voxels would not line up.
pub fn compare_classes(a: &OcTree, b: &OcTree) -> Result<ClassComparison, OctreeError> {
    if (a.resolution() - b.resolution()).abs() > 1e-6 {
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
        Side::Leaf(c, _) => Some(c),
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

/// A cube of space over which two maps are each uniform (a leaf, a pruned cube or unknown
/// space in each), as [`for_each_class_cube`] visits them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ClassCube {
    /// The smallest depth-16 key inside the cube.
    pub min_key: Key,
    /// The cube's depth (16 = one voxel): it spans `2^(16 - depth)` keys per axis.
    pub depth: u8,
    /// Its class in the first map.
    pub first: VoxelClass,
    /// Its class in the second map.
    pub second: VoxelClass,
}

impl ClassCube {
    /// Keys per axis the cube spans.
    pub fn width(&self) -> u32 {
        1u32 << (TREE_DEPTH - self.depth)
    }
}

/// Visit every cube of space known to at least one of two maps of the same resolution, each
/// cube as large as both maps allow (where one map has a pruned leaf and the other detail, the
/// detail's cubes), in depth-first child order: the walk of [`compare_classes`], with places.
/// Errors when the resolutions differ by more than 1e-6 m.
pub fn for_each_class_cube(
    a: &OcTree,
    b: &OcTree,
    mut visit: impl FnMut(ClassCube),
) -> Result<(), OctreeError> {
    if (a.resolution() - b.resolution()).abs() > 1e-6 {
        return Err(OctreeError::ResolutionMismatch {
            first: a.resolution(),
            second: b.resolution(),
        });
    }
    cube_walk(a, b, a.root_side(), b.root_side(), 0, [0; 3], &mut visit);
    Ok(())
}

fn cube_walk(
    a: &OcTree,
    b: &OcTree,
    sa: Side,
    sb: Side,
    depth: u8,
    min: [u16; 3],
    visit: &mut impl FnMut(ClassCube),
) {
    let class = |s: Side| match s {
        Side::Absent => Some(VoxelClass::Unknown),
        Side::Leaf(c, _) => Some(c),
        Side::Inner(_) => None,
    };
    match (class(sa), class(sb)) {
        (Some(VoxelClass::Unknown), Some(VoxelClass::Unknown)) => {}
        (Some(first), Some(second)) => visit(ClassCube {
            min_key: Key(min),
            depth,
            first,
            second,
        }),
        _ => {
            let (ka, kb) = (a.child_sides(sa), b.child_sides(sb));
            let half = 1u16 << (TREE_DEPTH - depth - 1);
            for i in 0..8 {
                let m = [0, 1, 2].map(|ax| min[ax] + if i >> ax & 1 == 1 { half } else { 0 });
                cube_walk(a, b, ka[i], kb[i], depth + 1, m, visit);
            }
        }
    }
}

/// The Kullback-Leibler divergence OctoMap's `compare_octrees` tool reports between two maps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Divergence {
    /// The sum over every finest-level voxel of the first map of `KLD(p1, p2)` (see
    /// [`voxel_kld`]), added in the order `compare_octrees` adds it (its leaf iterator over the
    /// expanded first tree) when `octomap_order`, so that the value is the tool's to the last
    /// bit; maps of more than [`KLD_ORDERED_VOXELS`] voxels are summed cube by cube instead
    /// (`octomap_order` false: the same value up to rounding).
    Sum {
        /// The divergence in nats.
        kld: f64,
        /// Whether the terms were added one voxel at a time in `compare_octrees`' order.
        octomap_order: bool,
    },
    /// The maps do not know the same voxels (`compare_octrees` then stops with "Octrees have
    /// different size" or reports missing coordinates): the divergence is not defined.
    DifferentVoxels,
    /// A voxel's term is NaN (a NaN log-odds in a map; `compare_octrees` stops with "KLD is
    /// nan").
    NotANumber,
}

/// Above this many voxels in the first map, [`kl_divergence`] multiplies a pruned cube's term
/// by its voxel count instead of adding it once per voxel (about 4 s of additions).
pub const KLD_ORDERED_VOXELS: u64 = 1 << 32;

/// One voxel's term of `compare_octrees`' divergence, for occupancy probabilities `p1` (first
/// map) and `p2` (second), with the tool's cases: only the second half of the binary KLD when
/// `p1 < 0.0001`, only the first when `p1 > 0.9999`.
pub fn voxel_kld(p1: f64, p2: f64) -> f64 {
    if p1 < 0.0001 {
        ((1.0 - p1) / (1.0 - p2)).ln() * (1.0 - p1)
    } else if p1 > 0.9999 {
        (p1 / p2).ln() * p1
    } else {
        (p1 / p2).ln() * p1 + ((1.0 - p1) / (1.0 - p2)).ln() * (1.0 - p1)
    }
}

/// OctoMap's `compare_octrees A B` divergence without expanding either tree: pruned cubes
/// stand for the voxels below them, visited in the order of the leaf iterator over the
/// expanded first map (children 0 to 7, depth first), each voxel's [`voxel_kld`] added to a
/// running `f64` sum. Errors when the resolutions differ by more than 1e-6 m (the tool's
/// test).
pub fn kl_divergence(a: &OcTree, b: &OcTree) -> Result<Divergence, OctreeError> {
    if (a.resolution() - b.resolution()).abs() > 1e-6 {
        return Err(OctreeError::ResolutionMismatch {
            first: a.resolution(),
            second: b.resolution(),
        });
    }
    let mut classes = ClassComparison::default();
    walk(a, b, a.root_side(), b.root_side(), 0, &mut classes);
    let c = &classes.counts;
    if c[0][1] + c[0][2] + c[1][0] + c[2][0] > 0 {
        return Ok(Divergence::DifferentVoxels);
    }
    let voxels = c[1][1] + c[1][2] + c[2][1] + c[2][2];
    let ordered = voxels <= KLD_ORDERED_VOXELS;
    let mut sum = 0.0;
    kld_walk(a.root_side(), b.root_side(), 0, ordered, a, b, &mut sum);
    Ok(if sum.is_nan() {
        Divergence::NotANumber
    } else {
        Divergence::Sum {
            kld: sum,
            octomap_order: ordered,
        }
    })
}

fn kld_walk(sa: Side, sb: Side, depth: u8, ordered: bool, a: &OcTree, b: &OcTree, sum: &mut f64) {
    match (sa, sb) {
        // no voxel of the first map here, or none of the second (excluded before)
        (Side::Absent, _) | (_, Side::Absent) => {}
        (Side::Leaf(_, v1), Side::Leaf(_, v2)) => {
            let p1 = crate::params::probability(f64::from(v1));
            let p2 = crate::params::probability(f64::from(v2));
            let k = voxel_kld(p1, p2);
            let voxels = 1u64 << (3 * (TREE_DEPTH - depth) as u32);
            if k == 0.0 {
                // adding zero changes no sum (equal maps cost their size, not their volume)
            } else if ordered {
                for _ in 0..voxels {
                    *sum += k;
                }
            } else {
                *sum += k * voxels as f64;
            }
        }
        _ => {
            let (ka, kb) = (a.child_sides(sa), b.child_sides(sb));
            for i in 0..8 {
                kld_walk(ka[i], kb[i], depth + 1, ordered, a, b, sum);
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
            // the cubes cover exactly the known voxels, each with both maps' classes there
            let class = |t: &OcTree, k: Key| match t.is_occupied(k) {
                None => VoxelClass::Unknown,
                Some(false) => VoxelClass::Free,
                Some(true) => VoxelClass::Occupied,
            };
            let mut from_cubes = ClassComparison::default();
            for_each_class_cube(&ta, &tb, |c| {
                let w = c.width() as u16;
                for i in 0..u32::from(w).pow(3) {
                    let o = [i % u32::from(w), i / u32::from(w) % u32::from(w), i / u32::from(w).pow(2)];
                    let k = Key::new(c.min_key[0] + o[0] as u16, c.min_key[1] + o[1] as u16, c.min_key[2] + o[2] as u16);
                    assert_eq!((class(&ta, k), class(&tb, k)), (c.first, c.second), "{c:?}");
                }
                from_cubes.counts[c.first as usize][c.second as usize] += u64::from(w).pow(3);
            }).unwrap();
            prop_assert_eq!(from_cubes, got);
            let same = compare_classes(&ta, &ta).unwrap();
            prop_assert_eq!(same.agreement(), 1.0);
            prop_assert_eq!(same.known_in_either(), naive(&ta, &ta, LO, N).known_in_either());
        }
    }

    /// `compare_octrees` by its definition: every voxel the first map knows, in the order of
    /// OctoMap's leaf iterator over the expanded tree (child index `x | y << 1 | z << 2` at
    /// every level from the root, depth first: ascending interleaved codes), the second map's
    /// probability looked up per voxel.
    fn naive_kld(a: &OcTree, b: &OcTree) -> Option<f64> {
        let prob = |t: &OcTree, k: Key| {
            t.search(k, TREE_DEPTH)
                .map(|n| crate::params::probability(f64::from(n.value)))
        };
        let mut voxels = Vec::new();
        for x in LO..LO + N {
            for y in LO..LO + N {
                for z in LO..LO + N {
                    let k = Key::new(x, y, z);
                    match (prob(a, k), prob(b, k)) {
                        (None, None) => {}
                        (Some(p1), Some(p2)) => {
                            let mut code = 0u64;
                            for bit in (0..16).rev() {
                                let b3 = ((x >> bit) & 1)
                                    | ((y >> bit) & 1) << 1
                                    | ((z >> bit) & 1) << 2;
                                code = code << 3 | u64::from(b3);
                            }
                            voxels.push((code, p1, p2));
                        }
                        _ => return None,
                    }
                }
            }
        }
        voxels.sort_by_key(|v| v.0);
        let mut sum = 0.0;
        for (_, p1, p2) in voxels {
            let kld = if p1 < 0.0001 {
                ((1.0 - p1) / (1.0 - p2)).ln() * (1.0 - p1)
            } else if p1 > 0.9999 {
                (p1 / p2).ln() * p1
            } else {
                (p1 / p2).ln() * p1 + ((1.0 - p1) / (1.0 - p2)).ln() * (1.0 - p1)
            };
            sum += kld;
        }
        Some(sum)
    }

    proptest! {
        /// The divergence without expansion is the voxel-by-voxel sum in OctoMap's order, bit
        /// for bit, with pruned cubes on either side; maps that know different voxels have none.
        #[test]
        fn kld_matches_the_expanded_sum(
            keys in prop::collection::vec((0u8..16, 0u8..16, 0u8..16), 1..300),
            hits_a in prop::collection::vec(any::<bool>(), 300),
            hits_b in prop::collection::vec(any::<bool>(), 300),
            cube in any::<bool>(),
            extra in any::<bool>(),
        ) {
            let ops = |hits: &[bool]| -> Vec<(u8, u8, u8, bool)> {
                keys.iter().zip(hits).map(|(&(x, y, z), &h)| (x, y, z, h)).collect()
            };
            let mut ta = tree(&ops(&hits_a), true);
            let mut tb = tree(&ops(&hits_b), false);
            if cube {
                // the same solid free cube in both, pruned only in the first
                for x in 0..8 {
                    for y in 0..8 {
                        for z in 0..8 {
                            let k = Key::new(LO + 8 + x, LO + y, LO + z);
                            ta.update_node(k, Update::Miss, InnerNodes::Refresh);
                            tb.update_node(k, Update::Miss, InnerNodes::Refresh);
                        }
                    }
                }
                ta.prune();
            }
            if extra {
                tb.update_node(Key::new(LO + 15, LO + 15, LO + 15), Update::Hit, InnerNodes::Refresh);
            }
            let got = kl_divergence(&ta, &tb).unwrap();
            match naive_kld(&ta, &tb) {
                Some(want) => prop_assert_eq!(
                    got,
                    Divergence::Sum { kld: want, octomap_order: true }
                ),
                None => prop_assert_eq!(got, Divergence::DifferentVoxels),
            }
            prop_assert_eq!(
                kl_divergence(&ta, &ta).unwrap(),
                Divergence::Sum { kld: 0.0, octomap_order: true }
            );
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
