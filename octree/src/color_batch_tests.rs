use super::*;
use crate::io::write_color_ot;
use proptest::prelude::*;

/// The tree's `.ot` bytes: values, structure and colours.
fn ot(t: &ColorOcTree) -> Vec<u8> {
    let mut out = Vec::new();
    write_color_ot(t, &mut out).unwrap();
    out
}

/// The reference: OctoMap's `updateNode` per key, in turn.
fn one_by_one(t: &mut ColorOcTree, keys: &[Key], update: Update, inner: InnerNodes) {
    for &k in keys {
        t.update_node(k, update, inner);
    }
}

/// A depth-15 node's eight voxels, seven at one miss and one at 0, each with its own
/// colour. Updating the one at 0 first makes all eight equal (OctoMap prunes them, averaging
/// their colours); a miss on another voxel then expands the node again, handing every voxel
/// the average. In the other order nothing is pruned and every voxel keeps its colour.
#[test]
fn a_prune_undone_in_the_same_pass_follows_the_order() {
    let base = Key::new(32768, 32768, 32768);
    let vox: [Key; 8] = std::array::from_fn(|i| {
        Key::new(
            base.x() + (i & 1) as u16,
            base.y() + (i >> 1 & 1) as u16,
            base.z() + (i >> 2 & 1) as u16,
        )
    });
    let mut t = ColorOcTree::new(0.1).unwrap();
    let miss = t.params().miss;
    for (i, &v) in vox.iter().enumerate() {
        let value = if i == 3 { 0.0 } else { miss };
        t.set_node_value(v, value, InnerNodes::Refresh).unwrap();
        t.set_node_color(v, Color::new(10 * i as u8, 0, 200));
    }
    // a far voxel too, so that the pass is not all one hazard
    let far = Key::new(1000, 2000, 3000);
    t.update_node(far, Update::Hit, InnerNodes::Refresh);
    t.set_node_color(far, Color::new(1, 2, 3));
    for order in [
        [vox[3], vox[5], far],
        [vox[5], vox[3], far],
        [far, vox[5], vox[3]],
    ] {
        let (mut a, mut b) = (t.clone(), t.clone());
        one_by_one(&mut a, &order, Update::Miss, InnerNodes::Refresh);
        b.update_keys(&order, Update::Miss, InnerNodes::Refresh);
        assert_eq!(ot(&a), ot(&b), "order {order:?}");
    }
    // the orders give different colours, and the prune was found as a hazard
    let mut first = t.clone();
    first.update_keys(&[vox[3], vox[5]], Update::Miss, InnerNodes::Refresh);
    let mut second = t.clone();
    second.update_keys(&[vox[5], vox[3]], Update::Miss, InnerNodes::Refresh);
    assert_eq!(first.node_color(vox[0]), Some(Color::new(35, 0, 200)));
    assert_eq!(second.node_color(vox[0]), Some(Color::new(0, 0, 200)));
    let rule = Rule {
        delta: miss,
        cmin: t.params().clamp_min,
        cmax: t.params().clamp_max,
    };
    let mut codes = vec![vox[3].morton(), vox[5].morton(), far.morton()];
    codes.sort_unstable();
    let lo = base.morton();
    let suspects = HazardSearch::new(t.occupancy(), rule).run(&codes);
    assert_eq!(suspects, vec![(lo, lo + 8)]);
    // with the order: a hazard only when the voxel that completes the node comes first
    let narrow = |order: &[Key]| HazardSearch::new(t.occupancy(), rule).narrow(&suspects, order);
    assert_eq!(narrow(&[vox[3], far, vox[5]]), vec![(lo, lo + 8)]);
    assert_eq!(narrow(&[vox[5], far, vox[3]]), vec![]);
}

/// One step of building a random coloured tree in a small region.
#[derive(Debug, Clone)]
enum Build {
    Update(usize, bool),
    Set(usize, u8),
    Fill(usize, u8),
    Trap(usize, u8, u8),
    Paint(usize, u8),
    Prune,
}

/// Voxel `i` of a small region in Morton order: runs of 8 and 64 are a depth-15 node and
/// a brick; the four bricks lie in four of the root's octants.
fn brick_voxel(i: usize) -> Key {
    let base = Key::new(32764, 32764, 32764).morton();
    Key::from_morton(base + (i % 256) as u64)
}

fn build_step() -> impl Strategy<Value = Build> {
    prop_oneof![
        6 => (0..256usize, any::<bool>()).prop_map(|(i, h)| Build::Update(i, h)),
        3 => (0..256usize, 0..5u8).prop_map(|(i, v)| Build::Set(i, v)),
        2 => (0..256usize, 0..5u8).prop_map(|(i, v)| Build::Fill(i, v)),
        3 => (0..128usize, 0..4u8, any::<u8>()).prop_map(|(i, w, c)| Build::Trap(i, w, c)),
        3 => (0..256usize, any::<u8>()).prop_map(|(i, c)| Build::Paint(i, c)),
        1 => Just(Build::Prune),
    ]
}

fn build(steps: &[Build]) -> ColorOcTree {
    let mut t = ColorOcTree::new(0.1).unwrap();
    let (hit, miss) = (t.params().hit, t.params().miss);
    // values on the lattice the updates walk, so that nodes fall uniform often
    let values = [0.0, miss, miss + miss, hit, hit + miss];
    for s in steps {
        match *s {
            Build::Update(i, h) => {
                let u = if h { Update::Hit } else { Update::Miss };
                t.update_node(brick_voxel(i), u, InnerNodes::Refresh);
            }
            Build::Set(i, v) => {
                t.set_node_value(brick_voxel(i), values[v as usize], InnerNodes::Refresh)
                    .unwrap();
            }
            Build::Fill(i, v) => {
                // a whole depth-15 node, or (every other time) a whole brick, at one value
                let span = if i % 2 == 0 { 8 } else { 64 };
                let first = i / span * span;
                for j in first..first + span {
                    t.set_node_value(brick_voxel(j), values[v as usize], InnerNodes::Refresh)
                        .unwrap();
                }
            }
            Build::Trap(i, which, c) => {
                // a node (8 or 64 voxels) at `c`, one voxel an update short of it, every
                // voxel its own colour: updating that voxel makes the node prunable
                let (span, first) = if c % 2 == 0 {
                    (8, i / 8 * 8)
                } else {
                    (64, i / 64 * 64)
                };
                let [value, short] = [
                    [miss, 0.0],
                    [miss + miss, miss],
                    [hit, 0.0],
                    [hit + miss, miss],
                ][which as usize];
                for j in first..first + span {
                    let v = if j == i { short } else { value };
                    t.set_node_value(brick_voxel(j), v, InnerNodes::Refresh)
                        .unwrap();
                }
                for j in first..first + span {
                    let shade = c.wrapping_add((j as u8).wrapping_mul(37));
                    t.set_node_color(brick_voxel(j), Color::new(shade, 255 - shade, j as u8));
                }
            }
            Build::Paint(i, c) => {
                t.set_node_color(brick_voxel(i), Color::new(c, c / 2, 255 - c));
            }
            Build::Prune => t.prune(),
        }
    }
    t
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1000))]

    /// Any pass, on any coloured tree, in any order: the same bytes as OctoMap's one update
    /// per key in turn.
    #[test]
    fn update_keys_is_update_node_in_turn(
        steps in prop::collection::vec(build_step(), 0..80),
        pass in prop::collection::vec(0..128usize, 0..100),
        update in prop_oneof![Just(Update::Hit), Just(Update::Miss), Just(Update::LogOdds(0.0))],
        lazy: bool,
        twice: bool,
        track: bool,
    ) {
        let mut t = build(&steps);
        t.enable_change_detection(track);
        let mut keys: Vec<Key> = Vec::new();
        for i in pass {
            let k = brick_voxel(i);
            if twice || !keys.contains(&k) {
                keys.push(k);
            }
        }
        let inner = InnerNodes::from_lazy(lazy);
        let (mut a, mut b) = (t.clone(), t);
        one_by_one(&mut a, &keys, update, inner);
        b.update_keys(&keys, update, inner);
        prop_assert_eq!(a.size(), b.size());
        prop_assert_eq!(a.num_colored_nodes(), b.num_colored_nodes());
        prop_assert!(ot(&a) == ot(&b));
        // change detection records the same voxels (their set does not depend on the order)
        let changes = |t: &ColorOcTree| t.occupancy().changed_keys().collect::<Vec<_>>();
        prop_assert_eq!(changes(&a), changes(&b));
    }
}

/// The random trees of the property test do hit the case the order decides: in a seeded
/// sample, tens of passes in Morton order (the walk alone) give other bytes than OctoMap's
/// order, and `update_keys` gives OctoMap's every time.
#[test]
fn random_passes_meet_prunes_undone_in_the_pass() {
    use proptest::strategy::ValueTree;
    use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
    let mut runner = TestRunner::new_with_rng(
        Config::default(),
        TestRng::from_seed(RngAlgorithm::ChaCha, &[7; 32]),
    );
    let case = (
        prop::collection::vec(build_step(), 0..80),
        prop::collection::vec(0..128usize, 0..100),
        any::<bool>(),
    );
    let (mut differ, mut hazards) = (0, 0);
    for _ in 0..1000 {
        let (steps, pass, hit) = case.new_tree(&mut runner).unwrap().current();
        let t = build(&steps);
        let mut keys: Vec<Key> = Vec::new();
        for i in pass {
            let k = brick_voxel(i);
            if !keys.contains(&k) {
                keys.push(k);
            }
        }
        let update = if hit { Update::Hit } else { Update::Miss };
        let mut a = t.clone();
        one_by_one(&mut a, &keys, update, InnerNodes::Refresh);
        let mut b = t.clone();
        b.update_keys(&keys, update, InnerNodes::Refresh);
        if ot(&a) != ot(&b) {
            eprintln!(
                "steps {steps:?}\nkeys {:?}\nhit {hit}",
                keys.iter()
                    .map(|k| k.morton() - brick_voxel(0).morton())
                    .collect::<Vec<_>>()
            );
            panic!();
        }
        let mut codes: Vec<u64> = keys.iter().map(Key::morton).collect();
        codes.sort_unstable();
        let rule = Rule {
            delta: t.occupancy().delta(update),
            cmin: t.params().clamp_min,
            cmax: t.params().clamp_max,
        };
        hazards += usize::from(
            !HazardSearch::new(t.occupancy(), rule)
                .run(&codes)
                .is_empty(),
        );
        let mut walked = t;
        walked.walk(&codes, update, InnerNodes::Refresh);
        differ += usize::from(ot(&walked) != ot(&a));
    }
    eprintln!("{differ} of 1000 passes differ in Morton order; {hazards} have hazards");
    assert!(
        differ >= 15,
        "only {differ} of 1000 passes depend on the order"
    );
}
