//! `OcTree::merge` against its definition: every voxel of every leaf of the other tree
//! applied by `update_node` (Morton order within a leaf), compared byte for byte (`.ot`,
//! `.bt`) and by size, on random trees with pruned leaves, lazy and unpruned trees included.

use octoquant_octree::io::{write_bt, write_ot};
use octoquant_octree::validate::assert_well_formed;
use octoquant_octree::{InnerNodes, Key, OcTree, OccupancyParams, OctreeError, Update, TREE_DEPTH};
use proptest::prelude::*;

/// The definition: per leaf of `b` in pre-order, per voxel it covers in Morton order,
/// `update_node(voxel, leaf value)` with eager inner nodes.
fn brute_force(a: &OcTree, b: &OcTree) -> OcTree {
    let mut t = a.clone();
    for leaf in b.leaves() {
        let first = leaf.min_key().morton();
        let n = 1u64 << (3 * u32::from(TREE_DEPTH - leaf.depth));
        for c in first..first + n {
            t.update_node(
                Key::from_morton(c),
                Update::LogOdds(leaf.value),
                InnerNodes::Refresh,
            );
        }
    }
    t
}

fn files(t: &OcTree) -> (Vec<u8>, Vec<u8>) {
    let (mut ot, mut bt) = (Vec::new(), Vec::new());
    write_ot(t, &mut ot).unwrap();
    write_bt(&mut t.clone(), &mut bt).unwrap();
    (ot, bt)
}

fn assert_same(got: &OcTree, want: &OcTree, what: &str) {
    assert_eq!(got.size(), want.size(), "{what}: size");
    let (go, gb) = files(got);
    let (wo, wb) = files(want);
    assert!(go == wo, "{what}: .ot differs");
    assert!(gb == wb, "{what}: .bt differs");
    // and node for node, values by bits
    let g: Vec<_> = got
        .nodes()
        .map(|n| (n.key, n.depth, n.value.to_bits(), n.has_children))
        .collect();
    let w: Vec<_> = want
        .nodes()
        .map(|n| (n.key, n.depth, n.value.to_bits(), n.has_children))
        .collect();
    assert!(g == w, "{what}: nodes differ");
}

/// One step building a random tree near the map centre.
#[derive(Debug, Clone)]
enum Op {
    /// Update every voxel of the aligned cube of side `2^k` at `corner` (k <= 3).
    Cube {
        corner: [u16; 3],
        k: u8,
        update: Upd,
        lazy: bool,
    },
    /// Set every voxel of the cube to a value.
    SetCube { corner: [u16; 3], k: u8, value: f32 },
}

#[derive(Debug, Clone, Copy)]
enum Upd {
    Hit,
    Miss,
    LogOdds(f32),
}

fn values() -> impl Strategy<Value = f32> {
    prop_oneof![
        Just(0.0f32),
        Just(-0.0f32),
        Just(0.85f32),
        Just(-0.4f32),
        Just(3.5f32),
        Just(-2.0f32),
        Just(5.0f32),
        Just(-7.0f32),
        -4.0f32..4.0,
    ]
}

fn ops() -> impl Strategy<Value = Vec<Op>> {
    let corner = (0u16..24, 0u16..24, 0u16..24, 0u8..4);
    let op = prop_oneof![
        (
            corner.clone(),
            prop_oneof![
                Just(Upd::Hit),
                Just(Upd::Miss),
                values().prop_map(Upd::LogOdds)
            ],
            any::<bool>()
        )
            .prop_map(|((x, y, z, k), update, lazy)| Op::Cube {
                corner: [x, y, z],
                k,
                update,
                lazy
            }),
        (corner, values()).prop_map(|((x, y, z, k), value)| Op::SetCube {
            corner: [x, y, z],
            k,
            value
        }),
    ];
    prop::collection::vec(op, 0..24)
}

fn cube_keys(corner: [u16; 3], k: u8) -> impl Iterator<Item = Key> {
    let side = 1u16 << k;
    // aligned cubes near the centre (keys 32752..32800), so that they prune
    let base = corner.map(|c| 32752 + (c & !(side - 1)));
    (0..side).flat_map(move |x| {
        (0..side).flat_map(move |y| {
            (0..side).map(move |z| Key::new(base[0] + x, base[1] + y, base[2] + z))
        })
    })
}

fn build(params: OccupancyParams, ops: &[Op], finish: u8) -> OcTree {
    let mut t = OcTree::with_params(0.1, params).unwrap();
    for op in ops {
        match *op {
            Op::Cube {
                corner,
                k,
                update,
                lazy,
            } => {
                let u = match update {
                    Upd::Hit => Update::Hit,
                    Upd::Miss => Update::Miss,
                    Upd::LogOdds(v) => Update::LogOdds(v),
                };
                for key in cube_keys(corner, k) {
                    t.update_node(key, u, InnerNodes::from_lazy(lazy));
                }
            }
            Op::SetCube { corner, k, value } => {
                for key in cube_keys(corner, k) {
                    t.set_node_value(key, value, InnerNodes::Refresh).unwrap();
                }
            }
        }
    }
    match finish {
        // stale inner nodes left as they are (lazy updates) or refreshed
        1 => t.update_inner_occupancy(),
        // fully expanded: unpruned equal leaves
        2 => t.expand(),
        3 => t.prune(),
        _ => {}
    }
    t
}

fn params() -> impl Strategy<Value = OccupancyParams> {
    prop_oneof![
        Just(OccupancyParams::default()),
        Just(OccupancyParams::from_probabilities(0.7, 0.4, 0.2, 0.8, 0.5).unwrap()),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    /// Merging equals the voxel-by-voxel definition, byte for byte.
    #[test]
    fn merge_is_the_voxel_by_voxel_update(
        pa in params(), a_ops in ops(), a_finish in 0u8..4,
        pb in params(), b_ops in ops(), b_finish in prop_oneof![Just(0u8), Just(3u8)],
    ) {
        let a = build(pa, &a_ops, a_finish);
        let b = build(pb, &b_ops, b_finish);
        let want = brute_force(&a, &b);
        let mut got = a.clone();
        let stats = got.merge(&b).unwrap();
        prop_assert_eq!(stats.leaves, b.leaves().count());
        let voxels: u64 = b.leaves().map(|l| u64::from(l.width()).pow(3)).sum();
        prop_assert_eq!(stats.voxels, voxels);
        assert_same(&got, &want, "merge");
        let lazy = a_ops.iter().any(|o| matches!(o, Op::Cube { lazy: true, .. }));
        if a_finish != 2 && !lazy {
            assert_well_formed(&got, InnerNodes::Refresh);
        }
    }
}

/// A cube of `2^k` voxels a side filled with `value` (one pruned leaf at depth `16 - k`).
fn cube_tree(corner: Key, k: u8, value: f32) -> OcTree {
    let mut t = OcTree::new(0.1).unwrap();
    let side = 1u16 << k;
    for x in 0..side {
        for y in 0..side {
            for z in 0..side {
                let key = Key::new(corner[0] + x, corner[1] + y, corner[2] + z);
                t.set_node_value(key, value, InnerNodes::Refresh).unwrap();
            }
        }
    }
    assert_eq!(t.leaves().count(), 1);
    t
}

#[test]
fn a_large_pruned_leaf_is_applied_whole() {
    // a leaf of depth 10 (262144 voxels) over a tree with structure inside and around it
    let corner = Key::new(32768, 32768, 32768);
    let b = cube_tree(corner, 6, -1.25);
    assert_eq!(b.leaves().next().unwrap().depth, 10);
    let mut a = OcTree::new(0.1).unwrap();
    for (i, k) in [
        Key::new(32768, 32768, 32768),
        Key::new(32800, 32790, 32770),
        Key::new(32831, 32831, 32831),
        Key::new(32832, 32768, 32768), // outside
        Key::new(32767, 32768, 32768), // outside
    ]
    .into_iter()
    .enumerate()
    {
        for _ in 0..=i {
            a.update_node(k, Update::Hit, InnerNodes::Refresh);
        }
    }
    // a pruned free block inside the region, and one at the clamp
    for key in cube_keys([0, 0, 0], 3).map(|k| Key::new(k[0] + 32, k[1] + 16, k[2] + 16)) {
        a.update_node(key, Update::Miss, InnerNodes::Refresh);
    }
    let want = brute_force(&a, &b);
    let mut got = a.clone();
    let stats = got.merge(&b).unwrap();
    assert_eq!(
        (stats.leaves, stats.pruned_leaves, stats.voxels),
        (1, 1, 262144)
    );
    assert_same(&got, &want, "depth-10 leaf");
    // into an empty tree: one leaf, clamped
    let mut empty = OcTree::new(0.1).unwrap();
    empty.merge(&b).unwrap();
    assert_same(
        &empty,
        &brute_force(&OcTree::new(0.1).unwrap(), &b),
        "into empty",
    );
}

#[test]
fn a_pruned_leaf_inside_a_larger_leaf_of_the_map() {
    // A holds a depth-10 leaf; B a depth-13 leaf inside it, not at its first voxel, and one at
    // it; with a delta that changes the value and one that cannot (at the clamp)
    let corner = Key::new(32768, 32768, 32768);
    for (value, bcorner) in [
        (0.5f32, Key::new(32776, 32768, 32768)),
        (0.5, corner),
        (-3.0, Key::new(32776, 32776, 32768)),
    ] {
        for a_value in [-2.0f32, 0.7, 3.5] {
            let a = cube_tree(corner, 6, a_value);
            let b = cube_tree(bcorner, 3, value);
            let want = brute_force(&a, &b);
            let mut got = a.clone();
            got.merge(&b).unwrap();
            assert_same(
                &got,
                &want,
                &format!("A {a_value}, B {value} at {bcorner:?}"),
            );
        }
    }
}

#[test]
fn signed_zeros_follow_the_voxel_order() {
    // -0.0 + 0.0 is +0.0, equal under == but not in bits: the leaf keeps its depth and takes
    // the new bits only when B's region starts at its first voxel
    let corner = Key::new(32768, 32768, 32768);
    for bcorner in [corner, Key::new(32772, 32768, 32768)] {
        let a = cube_tree(corner, 3, -0.0);
        let b = cube_tree(bcorner, 2, 0.0);
        let want = brute_force(&a, &b);
        let mut got = a.clone();
        got.merge(&b).unwrap();
        assert_same(&got, &want, &format!("B at {bcorner:?}"));
    }
}

#[test]
fn mismatches_and_bad_values_are_refused_untouched() {
    let mut a = OcTree::new(0.1).unwrap();
    a.update_node(Key::new(1, 2, 3), Update::Hit, InnerNodes::Refresh);
    let before = files(&a);
    let b = OcTree::new(0.2).unwrap();
    assert!(matches!(
        a.merge(&b),
        Err(OctreeError::ResolutionMismatch { .. })
    ));
    let mut b = OcTree::new(0.1).unwrap();
    b.update_node(Key::new(5, 5, 5), Update::Hit, InnerNodes::Refresh);
    b.set_node_value(Key::new(9, 9, 9), 1.0, InnerNodes::Refresh)
        .unwrap();
    // an infinite leaf can only come from a file (the reader refuses NaN): write one by hand
    let mut ot = Vec::new();
    write_ot(&b, &mut ot).unwrap();
    let one = 1.0f32.to_le_bytes();
    let at = ot
        .windows(5)
        .rposition(|w| w[..4] == one && w[4] == 0)
        .unwrap();
    ot[at..at + 4].copy_from_slice(&f32::INFINITY.to_le_bytes());
    let b = octoquant_octree::io::read_ot(&ot[..]).unwrap();
    let e = a.merge(&b).unwrap_err();
    assert!(
        matches!(e, OctreeError::NonFiniteValue { depth: 16, .. }),
        "{e}"
    );
    assert!(files(&a) == before);
    a.enable_change_detection(true);
    assert!(matches!(
        a.merge(&OcTree::new(0.1).unwrap()),
        Err(OctreeError::Unsupported { .. })
    ));
    assert!(files(&a) == before);
}

#[test]
fn sensor_models_may_differ_and_the_map_keeps_its_own() {
    let tight = OccupancyParams::from_probabilities(0.7, 0.4, 0.2, 0.8, 0.5).unwrap();
    let mut a = OcTree::with_params(0.1, tight).unwrap();
    let k = Key::new(32768, 32768, 32768);
    a.update_node(k, Update::Hit, InnerNodes::Refresh);
    let mut b = OcTree::new(0.1).unwrap();
    for _ in 0..10 {
        b.update_node(k, Update::Hit, InnerNodes::Refresh);
    }
    a.merge(&b).unwrap();
    assert_eq!(a.params(), &tight);
    assert_eq!(a.search(k, 16).unwrap().value, tight.clamp_max);
}
