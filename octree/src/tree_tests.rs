//! Whole trees whose voxel palette holds only a few values (so they switch to wide voxel
//! storage and, on `shrink_to_fit`, back) against trees with the real limit and a flat voxel
//! map; and a tree past the real limit.

use super::*;
use crate::io::{read_ot, write_bt, write_ot};
use crate::store::PALETTE_LIMIT;
use crate::validate::check_well_formed;
use proptest::prelude::*;
use std::collections::HashMap;

/// A small set of values with repeats, both zeros and values that clamp.
const VALS: [f32; 9] = [0.0, -0.0, 0.85, -0.4, 1.7, -2.0, 3.5, 0.45, 1e-30];

/// Tree operations for the whole-tree test.
#[derive(Debug, Clone)]
enum TreeOp {
    Update(Key, bool),
    Batch(Vec<Key>, bool),
    Set(Key, usize),
    Delete(Key, u8),
    Prune,
    Expand,
    MaxLikelihood,
    Shrink,
}

fn key() -> impl Strategy<Value = Key> {
    (0u16..6, 0u16..6, 0u16..6).prop_map(|(x, y, z)| Key::new(32764 + x, 32764 + y, 32764 + z))
}

fn tree_op() -> impl Strategy<Value = TreeOp> {
    prop_oneof![
        8 => (key(), any::<bool>()).prop_map(|(k, h)| TreeOp::Update(k, h)),
        4 => (prop::collection::vec(key(), 0..30), any::<bool>()).prop_map(|(k, h)| TreeOp::Batch(k, h)),
        4 => (key(), 0usize..VALS.len()).prop_map(|(k, v)| TreeOp::Set(k, v)),
        1 => (key(), 13u8..=16).prop_map(|(k, d)| TreeOp::Delete(k, d)),
        1 => Just(TreeOp::Prune),
        1 => Just(TreeOp::Expand),
        1 => Just(TreeOp::MaxLikelihood),
        1 => Just(TreeOp::Shrink),
    ]
}

/// What a voxel reads in the flat model: unknown voxels start at 0, updates at the clamp
/// they push towards are ignored, otherwise add then clamp; set clamps.
fn model_update(model: &mut HashMap<Key, f32>, t: &OcTree, k: Key, hit: bool) {
    let p = t.params();
    let d = if hit { p.hit } else { p.miss };
    let v = model.entry(k).or_insert(0.0);
    if !((d >= 0.0 && *v >= p.clamp_max) || (d <= 0.0 && *v <= p.clamp_min)) {
        *v = (*v + d).clamp(p.clamp_min, p.clamp_max);
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

    /// A tree whose palette holds only `limit` values (so it switches to wide storage
    /// and, on `shrink_to_fit`, back) writes the same `.ot` and `.bt` bytes after every
    /// operation as a tree with the real limit, both stay well formed, and every voxel
    /// reads what a flat per-voxel map says.
    #[test]
    fn small_palette_tree_equals_normal_tree(limit in 1usize..6, ops in prop::collection::vec(tree_op(), 1..40)) {
        let mut small = OcTree::new(0.1).unwrap();
        small.store.set_palette_limit(limit);
        let mut normal = OcTree::new(0.1).unwrap();
        let mut model: HashMap<Key, f32> = HashMap::new();
        let mut model_valid = true;
        let mut lazy_ok = false;
        for op in ops {
            // what expanding adds, from OctoMap's rule (a leaf at depth d becomes a full
            // subtree down to 16: (8^(17-d) - 8) / 7 nodes); a shallow leaf (a root left
            // childless by deletes) would build 8^16 voxels, which `try_expand` refuses
            let naive_expansion: u64 = normal
                .leaves()
                .map(|l| (8u64.pow(17 - u32::from(l.depth)) - 8) / 7)
                .sum();
            for t in [&mut small, &mut normal] {
                match &op {
                    TreeOp::Update(k, h) => {
                        t.update_node(*k, if *h { Update::Hit } else { Update::Miss }, InnerNodes::Refresh);
                    }
                    TreeOp::Batch(ks, h) => t.update_keys(ks, if *h { Update::Hit } else { Update::Miss }, InnerNodes::Refresh),
                    TreeOp::Set(k, v) => {
                        t.set_node_value(*k, VALS[*v], InnerNodes::Refresh).unwrap();
                    }
                    TreeOp::Delete(k, d) => {
                        t.delete_node(*k, *d);
                    }
                    TreeOp::Prune => t.prune(),
                    TreeOp::Expand => {
                        const LIMIT: u64 = 1 << 16;
                        let before = t.size();
                        prop_assert_eq!(t.expansion_nodes(), naive_expansion);
                        match t.try_expand(LIMIT) {
                            Ok(n) => {
                                prop_assert!(naive_expansion <= LIMIT);
                                prop_assert_eq!(n, naive_expansion);
                                prop_assert_eq!(t.size() as u64, before as u64 + n);
                            }
                            Err(OctreeError::ExpansionTooLarge { nodes, limit }) => {
                                prop_assert!(naive_expansion > LIMIT);
                                prop_assert_eq!((nodes, limit), (naive_expansion, LIMIT));
                                prop_assert_eq!(t.size(), before);
                            }
                            Err(e) => return Err(TestCaseError::fail(e.to_string())),
                        }
                    }
                    TreeOp::MaxLikelihood => t.to_max_likelihood(),
                    TreeOp::Shrink => t.shrink_to_fit(),
                }
            }
            match &op {
                TreeOp::Update(k, h) => model_update(&mut model, &normal, *k, *h),
                TreeOp::Batch(ks, h) => ks.iter().for_each(|k| model_update(&mut model, &normal, *k, *h)),
                TreeOp::Set(k, v) => {
                    let p = normal.params();
                    model.insert(*k, VALS[*v].max(p.clamp_min).min(p.clamp_max));
                }
                TreeOp::Delete(..) | TreeOp::MaxLikelihood => model_valid = false,
                _ => {}
            }
            // prune may stop early, expand leaves equal siblings, delete refreshes only the
            // parent (as OctoMap's deleteNodeRecurs): shapes only the lazy check accepts
            lazy_ok |= matches!(
                op,
                TreeOp::Prune | TreeOp::Expand | TreeOp::MaxLikelihood | TreeOp::Delete(..)
            );
            if let Err(e) = check_well_formed(&small, InnerNodes::from_lazy(lazy_ok)) {
                return Err(TestCaseError::fail(e));
            }
            let (mut a, mut b) = (Vec::new(), Vec::new());
            write_ot(&small, &mut a).unwrap();
            write_ot(&normal, &mut b).unwrap();
            prop_assert!(a == b, ".ot bytes differ after {:?}", op);
            prop_assert_eq!(small.size(), normal.size());
            prop_assert_eq!(read_ot(&a[..]).map(|t| t.size()).ok(), Some(small.size()));
        }
        if model_valid {
            for (k, v) in &model {
                let n = small.search(*k, 16).expect("updated voxel is known");
                prop_assert_eq!(n.value.to_bits(), v.to_bits(), "voxel {:?}", k);
            }
        }
        let (mut a, mut b) = (Vec::new(), Vec::new());
        write_bt(&mut small, &mut a).unwrap();
        write_bt(&mut normal, &mut b).unwrap();
        prop_assert!(a == b);
    }
}

/// Operations for the batched-walk test: a batch over a box of keys, or over its keys in a
/// scattered order (hit or miss, lazy or not), repeated to drive voxels to the clamps and
/// prune them; one voxel set to a value (`-0.0` among them); a compaction, which rebuilds the
/// palette (and may make wide storage narrow again).
#[derive(Debug, Clone)]
enum WalkOp {
    Batch([u16; 6], bool, bool, bool, u8),
    Set(Key, usize),
    Shrink,
}

fn walk_op() -> impl Strategy<Value = WalkOp> {
    prop_oneof![
        8 => (
            prop::array::uniform6(0u16..6),
            any::<bool>(),
            any::<bool>(),
            any::<bool>(),
            1u8..8,
        )
            .prop_map(|(b, h, l, s, r)| WalkOp::Batch(b, h, l, s, r)),
        2 => (key(), 0usize..VALS.len()).prop_map(|(k, v)| WalkOp::Set(k, v)),
        3 => Just(WalkOp::Shrink),
    ]
}

/// The keys of the box `b` (a corner and an extent per axis, in [`key`]'s region), in Morton
/// order or scattered.
fn box_keys(b: [u16; 6], sorted: bool) -> Vec<Key> {
    let mut ks = Vec::new();
    for x in b[0]..6.min(b[0] + b[3] + 1) {
        for y in b[1]..6.min(b[1] + b[4] + 1) {
            for z in b[2]..6.min(b[2] + b[5] + 1) {
                ks.push(Key::new(32764 + x, 32764 + y, 32764 + z));
            }
        }
    }
    if sorted {
        ks.sort_by_key(|k| k.morton());
    } else {
        ks.sort_by_key(|k| k.morton().wrapping_mul(0x9e37_79b9_7f4a_7c15));
    }
    ks
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    /// The batched walk (`update_keys`) against one `update_node` per key, both with a palette
    /// of only `limit` values: the walk's group loop stops for a full palette, wide storage
    /// and `-0.0` and hands the group to its voxel-by-voxel path, before or after creating
    /// or expanding the group's node. Same `.ot` bytes and size after every operation.
    #[test]
    fn batched_walk_with_a_small_palette_equals_single_updates(
        limit in 1usize..16,
        ops in prop::collection::vec(walk_op(), 1..40),
    ) {
        let mut walk = OcTree::new(0.1).unwrap();
        let mut single = OcTree::new(0.1).unwrap();
        walk.store.set_palette_limit(limit);
        single.store.set_palette_limit(limit);
        for op in &ops {
            match op {
                WalkOp::Batch(b, hit, lazy, sorted, reps) => {
                    let ks = box_keys(*b, *sorted);
                    let u = if *hit { Update::Hit } else { Update::Miss };
                    let inner = InnerNodes::from_lazy(*lazy);
                    for _ in 0..*reps {
                        walk.update_keys(&ks, u, inner);
                        for k in &ks {
                            single.update_node(*k, u, inner);
                        }
                    }
                }
                WalkOp::Set(k, v) => {
                    for t in [&mut walk, &mut single] {
                        t.set_node_value(*k, VALS[*v], InnerNodes::Refresh).unwrap();
                    }
                }
                WalkOp::Shrink => {
                    walk.shrink_to_fit();
                    single.shrink_to_fit();
                }
            }
            let (mut a, mut b) = (Vec::new(), Vec::new());
            write_ot(&walk, &mut a).unwrap();
            write_ot(&single, &mut b).unwrap();
            prop_assert!(a == b, ".ot bytes differ after {:?}", op);
            prop_assert_eq!(walk.size(), single.size());
        }
    }
}

/// The batched walk expands a pruned depth-15 node whose value the palette no longer holds
/// (compaction keeps only voxel values) while the palette is full: the expansion switches to
/// wide storage, as one `update_node` does, and the voxel takes its update.
#[test]
fn batched_walk_expands_a_node_whose_value_a_full_palette_lacks() {
    let group: Vec<Key> = (0..8u16)
        .map(|i| Key::new(32768 + (i & 1), 32768 + (i >> 1 & 1), 32768 + (i >> 2)))
        .collect();
    let build = || {
        let mut t = OcTree::new(0.1).unwrap();
        for _ in 0..10 {
            t.update_keys(&group, Update::Hit, InnerNodes::Refresh);
        }
        for (i, v) in [0.5, -0.3, 1.1].into_iter().enumerate() {
            let k = Key::new(32780 + 4 * i as u16, 32768, 32768);
            t.set_node_value(k, v, InnerNodes::Refresh).unwrap();
        }
        // absent, 0.0 and the three values: full, without the pruned node's clamp value
        t.store.set_palette_limit(4);
        assert!(!t.store.voxels.is_wide());
        assert_eq!(t.search(group[0], 16).map(|n| n.depth), Some(15));
        t
    };
    let mut walk = build();
    let mut single = build();
    walk.update_keys(&group[..3], Update::Miss, InnerNodes::Refresh);
    for k in &group[..3] {
        single.update_node(*k, Update::Miss, InnerNodes::Refresh);
    }
    assert!(walk.store.voxels.is_wide());
    let (mut a, mut b) = (Vec::new(), Vec::new());
    write_ot(&walk, &mut a).unwrap();
    write_ot(&single, &mut b).unwrap();
    assert!(a == b);
    assert_eq!(walk.size(), single.size());
}

/// Past the real palette limit: 70 000 distinct voxel values force the wide fallback;
/// every value reads back, updates keep working, `.ot` round-trips, and after
/// `to_max_likelihood` compaction returns to narrow storage and less memory.
#[test]
fn more_values_than_the_palette_holds() {
    let mut t = OcTree::new(0.1).unwrap();
    let n = 70_000u32;
    let key = |i: u32| {
        Key::new(
            30000 + (i % 64) as u16,
            30000 + (i / 64 % 64) as u16,
            30000 + (i / 4096) as u16,
        )
    };
    let val = |i: u32| -1.5 + i as f32 * 4e-5;
    for i in 0..n {
        t.set_node_value(key(i), val(i), InnerNodes::Refresh)
            .unwrap();
        if i as usize == PALETTE_LIMIT - 2 {
            assert!(!t.store.voxels.is_wide());
        }
    }
    assert!(t.store.voxels.is_wide());
    for i in (0..n).step_by(97) {
        assert_eq!(
            t.search(key(i), 16).unwrap().value.to_bits(),
            val(i).to_bits()
        );
    }
    let keys: Vec<Key> = (0..n).step_by(3).map(key).collect();
    t.update_keys(&keys, Update::Hit, InnerNodes::Refresh);
    for i in (0..n).step_by(3) {
        let p = t.params();
        let want = (val(i) + p.hit).clamp(p.clamp_min, p.clamp_max);
        assert_eq!(
            t.search(key(i), 16).unwrap().value.to_bits(),
            want.to_bits()
        );
    }
    crate::validate::assert_well_formed(&t, InnerNodes::Refresh);
    let mut ot = Vec::new();
    write_ot(&t, &mut ot).unwrap();
    let mut back = read_ot(&ot[..]).unwrap();
    assert!(back.store.voxels.is_wide());
    let mut ot2 = Vec::new();
    write_ot(&back, &mut ot2).unwrap();
    assert_eq!(ot, ot2);
    // still too many values: compaction keeps it wide
    back.shrink_to_fit();
    assert!(back.store.voxels.is_wide());
    t.shrink_to_fit();
    let wide_bytes = t.memory_usage();
    t.to_max_likelihood();
    t.shrink_to_fit();
    assert!(!t.store.voxels.is_wide());
    assert!(t.store.voxels.palette_len() <= 3);
    assert!(t.memory_usage() < wide_bytes);
    crate::validate::assert_well_formed(&t, InnerNodes::Defer);
}

/// `probability_at` is `1 - 1/(1 + e^l)` of the log-odds the voxel holds (written out here,
/// not through `probability`), for pruned nodes too; `None` in unknown space and outside.
#[test]
fn probability_at_a_point() {
    let mut t = OcTree::new(0.1).unwrap();
    let oracle = |l: f32| 1.0 - 1.0 / (1.0 + f64::from(l).exp());
    let p = Point3::new(1.03, -0.42, 0.27);
    assert_eq!(t.probability_at(&p), None);
    let l = t
        .update_point(&p, Update::Hit, InnerNodes::Refresh)
        .unwrap();
    assert_eq!(t.probability_at(&p), Some(oracle(l)));
    assert!((t.probability_at(&p).unwrap() - 0.7).abs() < 1e-6);
    let l = t
        .update_point(&p, Update::Miss, InnerNodes::Refresh)
        .unwrap();
    assert_eq!(t.probability_at(&p), Some(oracle(l)));
    // a neighbour in the same voxel, one in the next
    assert_eq!(
        t.probability_at(&Point3::new(1.01, -0.41, 0.21)),
        Some(oracle(l))
    );
    assert_eq!(t.probability_at(&Point3::new(1.13, -0.42, 0.27)), None);
    assert_eq!(t.probability_at(&Point3::new(1e9, 0.0, 0.0)), None);
    assert_eq!(t.probability_at(&Point3::new(f64::NAN, 0.0, 0.0)), None);
    // eight sibling voxels driven to the clamp prune into one leaf, which answers for all
    let mut t = OcTree::new(0.1).unwrap();
    let base = Key::new(32770, 32770, 32770);
    for _ in 0..20 {
        for i in 0..8u16 {
            let k = Key::new(
                base[0] + (i & 1),
                base[1] + (i >> 1 & 1),
                base[2] + (i >> 2),
            );
            t.update_node(k, Update::Hit, InnerNodes::Refresh);
        }
    }
    let centre = t.converter().key_to_point(&base);
    let n = t.search_point(&centre).unwrap();
    assert!(n.depth < TREE_DEPTH, "not pruned");
    assert_eq!(t.probability_at(&centre), Some(oracle(n.value)));
}

/// `set_resolution` keeps every node's key and value (OctoMap's `setResolution` only changes
/// the leaf size), so a voxel's centre moves with the scale; a bad size changes nothing.
#[test]
fn set_resolution_keeps_keys_and_values() {
    let mut t = OcTree::new(0.1).unwrap();
    let k = Key::new(32800, 32700, 32768);
    t.update_node(k, Update::Hit, InnerNodes::Refresh);
    let (size, v) = (t.size(), t.search(k, 16).unwrap().value);
    t.set_resolution(0.25).unwrap();
    assert_eq!(t.resolution(), 0.25);
    assert_eq!((t.size(), t.search(k, 16).unwrap().value), (size, v));
    // the voxel 32 keys above the centre on x now lies 32.5 leaves of 0.25 m out
    assert_eq!(t.converter().key_to_coord(k.x()), 32.5 * 0.25);
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(t.set_resolution(bad).is_err());
        assert_eq!(t.resolution(), 0.25);
    }
}
