//! Property tests of the octree against naive definitions.

use octoquant_octree::io::{read_bt, read_ot, write_bt, write_ot};
use octoquant_octree::validate::assert_well_formed;
use octoquant_octree::{Brick, InnerNodes, Key, KeyConverter, OcTree, Update, TREE_DEPTH};
use proptest::prelude::*;
use std::collections::HashMap;

fn keys() -> impl Strategy<Value = Key> {
    prop_oneof![
        (0u16..6, 0u16..6, 0u16..6).prop_map(|(x, y, z)| Key::new(32766 + x, 32766 + y, 32766 + z)),
        any::<[u16; 3]>().prop_map(Key),
    ]
}

/// The value a single voxel has after a sequence of updates, by OctoMap's definition:
/// unknown voxels start at 0, an update at the clamp it pushes towards is ignored,
/// otherwise add then clamp.
fn naive_apply(model: &mut HashMap<Key, f32>, tree: &OcTree, key: Key, hit: bool) {
    let p = tree.params();
    let d = if hit { p.hit } else { p.miss };
    let v = model.entry(key).or_insert(0.0);
    if (d >= 0.0 && *v >= p.clamp_max) || (d <= 0.0 && *v <= p.clamp_min) {
        return;
    }
    *v = (*v + d).clamp(p.clamp_min, p.clamp_max);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

    /// Every voxel reads back the value a per-voxel map computes, whatever pruning did; the
    /// tree stays well formed; inner nodes hold the max of their children.
    #[test]
    fn voxel_values_match_a_flat_map(ups in prop::collection::vec((keys(), any::<bool>(), 1usize..10), 1..200)) {
        let mut tree = OcTree::new(0.1).unwrap();
        let mut model = HashMap::new();
        for (k, hit, n) in ups {
            for _ in 0..n {
                naive_apply(&mut model, &tree, k, hit);
                tree.update_node(k, if hit { Update::Hit } else { Update::Miss }, InnerNodes::Refresh);
            }
        }
        assert_well_formed(&tree, InnerNodes::Refresh);
        for (k, v) in &model {
            let n = tree.search(*k, TREE_DEPTH).expect("updated voxel is known");
            prop_assert_eq!(n.value.to_bits(), v.to_bits());
        }
        // leaves cover exactly the updated voxels
        let covered: u64 = tree.leaves().map(|l| (l.width() as u64).pow(3)).sum();
        prop_assert_eq!(covered, model.len() as u64);
    }

    /// Lazy updates followed by `update_inner_occupancy` give the same voxel values.
    #[test]
    fn lazy_then_inner_gives_same_voxels(ups in prop::collection::vec((keys(), any::<bool>()), 1..150)) {
        let mut eager = OcTree::new(0.05).unwrap();
        let mut lazy = OcTree::new(0.05).unwrap();
        for (k, hit) in &ups {
            let u = if *hit { Update::Hit } else { Update::Miss };
            eager.update_node(*k, u, InnerNodes::Refresh);
            lazy.update_node(*k, u, InnerNodes::Defer);
        }
        lazy.update_inner_occupancy();
        assert_well_formed(&lazy, InnerNodes::Defer);
        for (k, _) in &ups {
            prop_assert_eq!(eager.search(*k, 16).unwrap().value, lazy.search(*k, 16).unwrap().value);
        }
        prop_assert_eq!(eager.root_value(), lazy.root_value());
    }

    /// `.ot` round-trips the whole tree; `.bt` round-trips the max-likelihood pruned tree.
    #[test]
    fn files_round_trip(ups in prop::collection::vec((keys(), any::<bool>()), 0..120)) {
        let mut tree = OcTree::new(0.2).unwrap();
        for (k, hit) in &ups {
            tree.update_node(*k, if *hit { Update::Hit } else { Update::Miss }, InnerNodes::Refresh);
        }
        let mut ot = Vec::new();
        write_ot(&tree, &mut ot).unwrap();
        let back = read_ot(&ot[..]).unwrap();
        let mut ot2 = Vec::new();
        write_ot(&back, &mut ot2).unwrap();
        prop_assert_eq!(&ot, &ot2);
        let mut bt = Vec::new();
        write_bt(&mut tree, &mut bt).unwrap();
        let mut back = read_bt(&bt[..]).unwrap();
        assert_well_formed(&back, InnerNodes::Defer);
        let mut bt2 = Vec::new();
        write_bt(&mut back, &mut bt2).unwrap();
        prop_assert_eq!(bt, bt2);
    }

    /// Leaves inside a key box are exactly the leaves whose cube overlaps it.
    #[test]
    fn bbx_iteration_matches_filter(ups in prop::collection::vec(keys(), 1..80),
                                    lo in (32760u16..32772, 32760u16..32772, 32760u16..32772),
                                    ext in (0u16..8, 0u16..8, 0u16..8)) {
        let mut tree = OcTree::new(0.1).unwrap();
        for k in &ups {
            for _ in 0..6 { tree.update_node(*k, Update::Hit, InnerNodes::Refresh); }
        }
        let min = Key::new(lo.0, lo.1, lo.2);
        let max = Key::new(lo.0 + ext.0, lo.1 + ext.1, lo.2 + ext.2);
        let got: Vec<_> = tree.leaves_in_bbx(min, max).map(|l| (l.key, l.depth)).collect();
        let want: Vec<_> = tree.leaves().filter(|l| {
            let m = l.min_key();
            (0..3).all(|a| (m[a] as u32) <= max[a] as u32 && (m[a] as u32 + l.width() - 1) >= min[a] as u32)
        }).map(|l| (l.key, l.depth)).collect();
        prop_assert_eq!(got, want);
    }

    /// Coarse keys from coordinates agree with adjusting the fine key, and centres lie inside
    /// the voxel they name.
    #[test]
    fn key_maths_is_consistent(c in -3000.0f64..3000.0, res in prop_oneof![Just(0.1), Just(0.05), Just(0.37)], d in 1u8..=16) {
        let conv = KeyConverter::new(res).unwrap();
        if let Some(k) = conv.coord_to_key_checked(c) {
            prop_assert_eq!(Key::new(k, k, k).at_depth(d).x(), conv.coord_to_key_at_depth(c, d));
            let centre = conv.key_to_coord(k);
            prop_assert_eq!(conv.coord_to_key_checked(centre), Some(k));
        }
    }
}

#[test]
fn pruning_sizes_like_octomaps_test_pruning() {
    // octomap/src/testing/test_pruning.cpp, res 0.01f: single node 17, diagonal sibling 18,
    // full octant collapses back to 16, and expand/prune restore sizes.
    let mut tree = OcTree::new(0.01f32 as f64).unwrap();
    let conv = tree.converter().clone();
    let k = |x: f64, y: f64, z: f64| conv.point_to_key(&nalgebra::Point3::new(x, y, z)).unwrap();
    tree.update_node(k(0.0, 0.0, 0.0), Update::Hit, InnerNodes::Refresh);
    assert_eq!(tree.size(), 17);
    tree.update_node(k(0.01, 0.01, 0.01), Update::Hit, InnerNodes::Refresh);
    assert_eq!(tree.size(), 18);
    for (x, y, z) in [
        (0.01, 0.0, 0.0),
        (0.0, 0.01, 0.0),
        (0.0, 0.0, 0.01),
        (0.01, 0.01, 0.0),
        (0.0, 0.01, 0.01),
    ] {
        tree.update_node(k(x, y, z), Update::Hit, InnerNodes::Refresh);
    }
    assert_eq!(tree.size(), 23);
    tree.update_node(k(0.01, 0.0, 0.01), Update::Hit, InnerNodes::Refresh);
    assert_eq!(
        tree.size(),
        16,
        "the eighth equal sibling prunes the octant"
    );
    tree.expand();
    assert_eq!(tree.size(), 24);
    tree.prune();
    assert_eq!(tree.size(), 16);
    tree.clear();
    assert_eq!(tree.size(), 0);
    assert!(tree.is_empty());
}

fn batch_ops() -> impl Strategy<Value = Vec<(Vec<Key>, bool, bool)>> {
    prop::collection::vec(
        (
            prop::collection::vec(keys(), 0..120),
            any::<bool>(),
            prop::bool::weighted(0.2),
        ),
        1..8,
    )
}

/// Batches that drive whole regions to the clamps: each is the keys of an aligned cube (4, 8
/// or 16 voxels wide), all of them or a seeded subset, updated `1..7` times in a row with one
/// kind of update; so nodes are pruned at the clamp and later updates take OctoMap's early
/// exit at pruned nodes of every depth.
fn saturating_ops() -> impl Strategy<Value = Vec<(u8, u64, bool, bool, u8)>> {
    prop::collection::vec(
        (
            0u8..3,
            any::<u64>(),
            any::<bool>(),
            prop::bool::weighted(0.3),
            1u8..7,
        ),
        1..12,
    )
}

/// The keys of a saturating batch: cube `size` (4 << region) at a base aligned to it, all
/// keys when `seed` is even, else about half of them, in Morton order or reversed.
fn cube_keys(region: u8, seed: u64) -> Vec<Key> {
    let size = 4u16 << region;
    let base = 32768 - size;
    let mut ks = Vec::new();
    for x in 0..size {
        for y in 0..size {
            for z in 0..size {
                let k = Key::new(base + x, base + y, base + z);
                let h = (k.morton() ^ seed).wrapping_mul(0x9e37_79b9_7f4a_7c15);
                if seed.is_multiple_of(2) || h >> 63 == 1 {
                    ks.push(k);
                }
            }
        }
    }
    ks.sort_by_key(|k| k.morton());
    if seed % 4 == 3 {
        ks.reverse();
    }
    ks
}

/// `keys` as bricks for [`OcTree::update_bricks`]: consecutive keys of one brick in one mask.
fn bricks_of(keys: &[Key]) -> Vec<Brick> {
    let mut out: Vec<Brick> = Vec::new();
    for k in keys {
        let b = Brick::of_voxel(k.morton());
        match out.last_mut() {
            Some(last) if last.code == b.code && last.voxels & b.voxels == 0 => {
                last.voxels |= b.voxels
            }
            _ => out.push(b),
        }
    }
    out
}

/// After lazy updates leave inner values stale, a batch in which every voxel takes OctoMap's
/// early exit refreshes nothing (OctoMap's `updateNode` returns before its ascent), so the
/// stale inner values stay, in the batched walks too.
#[test]
fn all_exit_batch_after_lazy_refreshes_nothing() {
    let ks = cube_keys(1, 0);
    let bricks = bricks_of(&ks);
    let mut trees = [
        OcTree::new(0.1).unwrap(),
        OcTree::new(0.1).unwrap(),
        OcTree::new(0.1).unwrap(),
    ];
    for t in &mut trees {
        for _ in 0..6 {
            t.update_keys(&ks, Update::Hit, InnerNodes::Defer);
        }
    }
    let stale = trees[0].search(ks[0], 10).map(|n| n.value);
    assert_eq!(
        stale,
        Some(0.0),
        "lazy updates leave inner nodes at their first value"
    );
    for k in &ks[..100] {
        trees[0].update_node(*k, Update::Hit, InnerNodes::Refresh);
    }
    trees[1].update_keys(&ks[..100], Update::Hit, InnerNodes::Refresh);
    let first = bricks_of(&ks[..100]);
    trees[2].update_bricks(&first, Update::Hit, InnerNodes::Refresh);
    assert!(first.len() < bricks.len());
    let ot: Vec<Vec<u8>> = trees
        .iter()
        .map(|t| {
            let mut b = Vec::new();
            write_ot(t, &mut b).unwrap();
            b
        })
        .collect();
    assert_eq!(trees[0].search(ks[0], 10).map(|n| n.value), stale);
    assert!(ot[0] == ot[1], "update_keys refreshed a node");
    assert!(ot[0] == ot[2], "update_bricks refreshed a node");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 120, ..ProptestConfig::default() })]

    /// `update_keys` and `update_bricks` equal one `update_node` per key (full `.ot` bytes,
    /// size, changed keys) on batches that saturate and prune whole regions, so that early
    /// exits at pruned nodes, refreshes after lazy batches and re-expansion all happen. With
    /// change detection off, the batched walk updates a block's voxels together (its own
    /// path), so both settings are checked.
    #[test]
    fn batch_updates_at_the_clamps(ops in saturating_ops(), track in any::<bool>()) {
        let mut single = OcTree::new(0.1).unwrap();
        let mut by_keys = OcTree::new(0.1).unwrap();
        let mut by_bricks = OcTree::new(0.1).unwrap();
        for t in [&mut single, &mut by_keys, &mut by_bricks] {
            t.enable_change_detection(track);
        }
        for (region, seed, hit, lazy, reps) in ops {
            let ks = cube_keys(region, seed);
            let bricks = bricks_of(&ks);
            let u = if hit { Update::Hit } else { Update::Miss };
            for _ in 0..reps {
                for k in &ks {
                    single.update_node(*k, u, InnerNodes::from_lazy(lazy));
                }
                by_keys.update_keys(&ks, u, InnerNodes::from_lazy(lazy));
                by_bricks.update_bricks(&bricks, u, InnerNodes::from_lazy(lazy));
            }
            prop_assert_eq!(single.size(), by_keys.size());
            prop_assert_eq!(single.size(), by_bricks.size());
        }
        let ot = |t: &OcTree| {
            let mut b = Vec::new();
            write_ot(t, &mut b).unwrap();
            b
        };
        // no block leaks: the blocks in use are those of the nodes with children
        for t in [&single, &by_keys, &by_bricks] {
            let parents = |inner: bool| {
                t.nodes().filter(|n| n.has_children && (n.depth < TREE_DEPTH - 1) == inner).count()
            };
            prop_assert_eq!(t.live_blocks(), (parents(true), parents(false)));
        }
        let a = ot(&single);
        prop_assert!(a == ot(&by_keys), "update_keys differs");
        prop_assert!(a == ot(&by_bricks), "update_bricks differs");
        let ca: Vec<_> = single.changed_keys().collect();
        prop_assert_eq!(&ca, &by_keys.changed_keys().collect::<Vec<_>>());
        prop_assert_eq!(&ca, &by_bricks.changed_keys().collect::<Vec<_>>());
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    /// `update_keys` leaves the tree byte-identical (full `.ot`) to one `update_node` per key,
    /// in any key order, sorted or not, lazy or not, with duplicates.
    #[test]
    fn batch_update_equals_single_updates(batches in batch_ops(), sort in any::<bool>()) {
        let mut single = OcTree::new(0.1).unwrap();
        let mut batch = OcTree::new(0.1).unwrap();
        single.enable_change_detection(true);
        batch.enable_change_detection(true);
        for (mut ks, hit, lazy) in batches {
            if sort {
                ks.sort_by_key(|k| k.morton());
            }
            let u = if hit { Update::Hit } else { Update::Miss };
            for k in &ks {
                single.update_node(*k, u, InnerNodes::from_lazy(lazy));
            }
            batch.update_keys(&ks, u, InnerNodes::from_lazy(lazy));
            prop_assert_eq!(single.size(), batch.size());
        }
        let (mut a, mut b) = (Vec::new(), Vec::new());
        write_ot(&single, &mut a).unwrap();
        write_ot(&batch, &mut b).unwrap();
        prop_assert!(a == b, "trees differ");
        // compaction keeps the tree and leaves no freed block behind
        let before = batch.memory_usage();
        batch.shrink_to_fit();
        // lazy batches leave inner values stale, so only the structure is checked
        assert_well_formed(&batch, InnerNodes::Defer);
        let mut c = Vec::new();
        write_ot(&batch, &mut c).unwrap();
        prop_assert!(a == c, "compaction changed the tree");
        prop_assert!(batch.memory_usage() <= before);
        let (inner, leaf) = batch.live_blocks();
        let m = batch.memory_breakdown();
        prop_assert_eq!(m.total(), batch.memory_usage());
        prop_assert_eq!((m.inner_blocks, m.leaf_blocks), (inner, leaf));
        prop_assert_eq!(m.free_bytes, 0);
        // few distinct values: 16-byte depth-16 blocks, and the palette holds each value
        // still in use (and 0) once
        prop_assert_eq!(m.leaf_block_bytes, 16);
        prop_assert_eq!(m.block_bytes, inner * 64 + leaf * 16);
        let distinct: std::collections::BTreeSet<u32> = batch
            .nodes()
            .filter(|n| n.depth == TREE_DEPTH)
            .map(|n| n.value.to_bits())
            .chain([0])
            .collect();
        prop_assert_eq!(m.palette_values, Some(distinct.len()));
        prop_assert_eq!(m.fixed_bytes, OcTree::new(0.1).unwrap().memory_breakdown().fixed_bytes);
        let ca: Vec<_> = single.changed_keys().collect();
        let cb: Vec<_> = batch.changed_keys().collect();
        prop_assert_eq!(ca, cb);
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

    /// OctoMap's `updateNodeLogOdds` and `nodeToMaxLikelihood` on a node in hand: the node
    /// at exactly that depth becomes add-then-clamp (no early exit at a clamp) or its clamp,
    /// every other node keeps its value; a missing node or a NaN sum changes nothing.
    #[test]
    fn node_in_hand_updates_change_that_node_alone(
        ups in prop::collection::vec((keys(), any::<bool>()), 1..60),
        calls in prop::collection::vec(
            (keys(), 12u8..=16, prop_oneof![
                Just(f32::NAN), Just(f32::INFINITY), Just(f32::NEG_INFINITY), -5.0f32..5.0
            ], any::<bool>()),
            1..30,
        ),
    ) {
        let mut tree = OcTree::new(0.1).unwrap();
        for &(k, hit) in &ups {
            tree.update_node(k, if hit { Update::Hit } else { Update::Miss }, InnerNodes::Refresh);
        }
        let p = *tree.params();
        for &(k, depth, d, ml) in &calls {
            let before: Vec<_> = tree.nodes().map(|n| (n.depth, n.value.to_bits())).collect();
            let old = tree.node_at_depth(k, depth).map(|n| n.value);
            let expected = old.map(|v| {
                if ml {
                    if v >= p.occupancy_threshold { p.clamp_max } else { p.clamp_min }
                } else {
                    let s = v + d;
                    if s < p.clamp_min { p.clamp_min } else if s > p.clamp_max { p.clamp_max } else { s }
                }
            });
            let got = if ml {
                Ok(tree.node_to_max_likelihood(k, depth))
            } else {
                tree.update_node_log_odds(k, depth, Update::LogOdds(d))
            };
            match expected {
                Some(e) if e.is_nan() => prop_assert!(got.is_err()),
                e => prop_assert_eq!(got.unwrap().map(f32::to_bits), e.map(f32::to_bits)),
            }
            let now = tree.node_at_depth(k, depth).map(|n| n.value);
            let changed = expected.filter(|e| !e.is_nan());
            prop_assert_eq!(now.map(f32::to_bits), changed.or(old).map(f32::to_bits));
            // no other node changes, and none comes or goes
            let after: Vec<_> = tree.nodes().map(|n| (n.depth, n.value.to_bits())).collect();
            prop_assert_eq!(before.len(), after.len());
            let differ: Vec<_> = before.iter().zip(&after).filter(|(b, a)| b != a).collect();
            prop_assert!(differ.len() <= 1);
            prop_assert!(differ.iter().all(|(b, _)| b.0 == depth));
        }
        // the ancestors are the caller's business, as in OctoMap
        assert_well_formed(&tree, InnerNodes::from_lazy(true));
    }
}
