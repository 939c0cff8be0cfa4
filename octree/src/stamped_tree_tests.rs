//! Unit tests of the stamp rules. The byte-level proof against OctoMap's `OcTreeStamped` is
//! the differential test `stamped_diff` of the root crate.

use super::*;
use crate::io::{read_stamped_ot, write_ot, write_stamped_ot};
use proptest::prelude::*;

fn octant(base: Key, i: u16) -> Key {
    Key::new(
        base.x() & !1 | (i & 1),
        base.y() & !1 | (i >> 1 & 1),
        base.z() & !1 | (i >> 2 & 1),
    )
}

#[test]
fn a_voxel_and_its_ancestors_take_the_update_time() {
    let mut t = StampedOcTree::new(0.1).unwrap();
    let k = Key::new(32768, 32768, 32768);
    t.update_node_at(k, Update::Hit, InnerNodes::Refresh, 100);
    let other = Key::new(40000, 32768, 32768);
    t.update_node_at(other, Update::Hit, InnerNodes::Refresh, 250);
    assert_eq!(t.timestamp(k), Some(100));
    assert_eq!(t.timestamp(other), Some(250));
    assert_eq!(t.last_update_time(), 250);
    // the common ancestors (depth 1: the half with x >= 0) were refreshed last at 250, the
    // branch to k only at 100
    assert_eq!(t.search(k, 1).unwrap().timestamp, 250);
    assert_eq!(t.search(k, 15).unwrap().timestamp, 100);
}

#[test]
fn memory_usage_counts_the_stamps() {
    let mut t = StampedOcTree::new(0.1).unwrap();
    // voxels spread over many 4x4x4 blocks and a few dense ones: every node of the tree is
    // stamped (time 7), and each stamp takes at least its four bytes
    for i in 0..2000u16 {
        let k = Key::new(30000 + i * 3, 32768 + (i % 7), 32768 + i % 5);
        t.update_node_at(k, Update::Hit, InnerNodes::Refresh, 7);
    }
    let stamped = t.base.payloads.len();
    assert_eq!(stamped, t.size());
    let occupancy = t.occupancy().memory_usage();
    assert!(t.memory_usage() >= occupancy + 4 * stamped);
}

#[test]
fn a_lazy_update_stamps_only_the_voxel() {
    let mut t = StampedOcTree::new(0.1).unwrap();
    let k = Key::new(32768, 32768, 32768);
    t.update_node_at(k, Update::Hit, InnerNodes::Refresh, 10);
    t.update_node_at(k, Update::Hit, InnerNodes::Defer, 20);
    assert_eq!(t.timestamp(k), Some(20));
    assert_eq!(t.last_update_time(), 10);
}

#[test]
fn a_saturated_voxel_keeps_its_stamp() {
    let mut t = StampedOcTree::new(0.1).unwrap();
    let k = Key::new(32768, 32768, 32768);
    let mut now = 1;
    while t.update_node_at(k, Update::Hit, InnerNodes::Refresh, now) < t.params().clamp_max {
        now += 1;
    }
    let saturated_at = now;
    t.update_node_at(k, Update::Hit, InnerNodes::Refresh, now + 50);
    assert_eq!(t.timestamp(k), Some(saturated_at));
}

#[test]
fn equal_values_with_different_stamps_do_not_prune() {
    let base = Key::new(32768, 32768, 32768);
    let mut t = StampedOcTree::new(0.1).unwrap();
    let mut plain = OcTree::new(0.1).unwrap();
    for i in 0..8 {
        // five hits each; octant 7 a second later
        let now = if i == 7 { 2 } else { 1 };
        for _ in 0..5 {
            t.update_node_at(octant(base, i), Update::Hit, InnerNodes::Refresh, now);
            plain.update_node(octant(base, i), Update::Hit, InnerNodes::Refresh);
        }
    }
    // the plain tree collapsed the octant, the stamped one keeps it
    assert!(plain.search(base, 16).unwrap().depth < 16);
    assert_eq!(t.search(base, 16).unwrap().node.depth, 16);
    assert_eq!(t.size(), plain.size() + 8);
    // prune() does not merge them either; after a common update time it does
    t.prune();
    assert_eq!(t.search(base, 16).unwrap().node.depth, 16);
    for i in 0..7 {
        t.set_node_value_at(octant(base, i), 0.5, InnerNodes::Refresh, 3)
            .unwrap();
    }
    t.set_node_value_at(octant(base, 7), 0.5, InnerNodes::Refresh, 3)
        .unwrap();
    // set keeps voxel stamps (1 and 2): still apart
    assert_eq!(t.search(base, 16).unwrap().node.depth, 16);
    for i in 0..8 {
        t.update_node_at(
            octant(base, i),
            Update::LogOdds(0.25),
            InnerNodes::Refresh,
            9,
        );
    }
    let n = t.search(base, 16).unwrap();
    assert!(n.node.depth < 16, "same values and stamps: pruned");
    assert_eq!(n.timestamp, 9);
}

#[test]
fn degrading_applies_one_miss_to_stale_occupied_leaves_only() {
    let mut t = StampedOcTree::new(0.1).unwrap();
    let old = Key::new(32768, 32768, 32768);
    let fresh = Key::new(32800, 32768, 32768);
    let free = Key::new(32900, 32768, 32768);
    t.update_node_at(old, Update::Hit, InnerNodes::Refresh, 100);
    t.update_node_at(free, Update::Miss, InnerNodes::Refresh, 100);
    t.update_node_at(fresh, Update::Hit, InnerNodes::Refresh, 195);
    let before = |k| t.search(k, 16).unwrap().node.value;
    let (vo, vf, vfr) = (before(old), before(free), before(fresh));
    let root_before = t.search(old, 1).unwrap().node.value;
    t.degrade_outdated_nodes_at(50, 200);
    let after = |t: &StampedOcTree, k| t.search(k, 16).unwrap();
    assert_eq!(
        after(&t, old).node.value,
        vo + t.occupancy().delta(Update::Miss)
    );
    assert_eq!(after(&t, old).timestamp, 100, "no new stamp");
    assert_eq!(after(&t, free).node.value, vf, "free leaves stay");
    assert_eq!(after(&t, fresh).node.value, vfr, "recent leaves stay");
    assert_eq!(
        t.search(old, 1).unwrap().node.value,
        root_before,
        "inner untouched"
    );
    // unsigned arithmetic: a stamp in the future is very old
    t.update_node_at(fresh, Update::Hit, InnerNodes::Refresh, 300);
    let v = after(&t, fresh).node.value;
    t.degrade_outdated_nodes_at(50, 200);
    assert!(after(&t, fresh).node.value < v);
}

#[test]
fn ot_files_hold_the_plain_payload_and_read_back_unstamped() {
    let mut t = StampedOcTree::new(0.05).unwrap();
    for i in 0..40u16 {
        let k = Key::new(32768 + i * 3, 32768 - i, 32768 + (i % 5));
        t.update_node_at(k, Update::Hit, InnerNodes::Refresh, u32::from(i));
    }
    let mut stamped = Vec::new();
    write_stamped_ot(&t, &mut stamped).unwrap();
    let mut plain = Vec::new();
    write_ot(t.occupancy(), &mut plain).unwrap();
    let text = String::from_utf8_lossy(&stamped[..120]).to_string();
    assert!(text.contains("\nid OcTreeStamped\n"), "{text}");
    let cut = |b: &[u8]| b[b.windows(5).position(|w| w == b"data\n").unwrap()..].to_vec();
    assert_eq!(cut(&stamped), cut(&plain));
    let back = read_stamped_ot(&stamped[..]).unwrap();
    assert_eq!(back.size(), t.size());
    assert!(back.nodes_with_stamps().iter().all(|n| n.3 == 0));
    let mut again = Vec::new();
    write_stamped_ot(&back, &mut again).unwrap();
    assert_eq!(again, stamped);
    // a plain OcTree file is not a stamped one, and the other way round
    assert!(matches!(
        read_stamped_ot(&plain[..]),
        Err(OctreeError::WrongTreeType { .. })
    ));
    assert!(crate::io::read_ot(&stamped[..]).is_err());
}

/// Keys of two neighbouring bricks, dense enough for scans to fill whole groups of siblings.
fn key_in_two_bricks() -> impl Strategy<Value = Key> {
    (0u16..4, 0u16..4, 0u16..8).prop_map(|(x, y, z)| Key::new(32764 + x, 32764 + y, 32764 + z))
}

fn key_in_block() -> impl Strategy<Value = Key> {
    (0u16..8, 0u16..8, 0u16..8).prop_map(|(x, y, z)| Key::new(32764 + x, 32764 + y, 32764 + z))
}

proptest! {
    /// With one clock reading for everything, stamps never differ, so the occupancy tree is
    /// exactly the plain tree's (same updates, same prunings) and every node carries that time.
    #[test]
    fn at_one_time_the_tree_is_the_plain_tree(
        ops in prop::collection::vec((key_in_block(), any::<bool>(), prop::bool::weighted(0.1)), 1..300),
        now in 1u32..u32::MAX,
    ) {
        let mut t = StampedOcTree::new(0.1).unwrap();
        let mut plain = OcTree::new(0.1).unwrap();
        for (k, hit, lazy) in ops {
            let u = if hit { Update::Hit } else { Update::Miss };
            t.update_node_at(k, u, InnerNodes::from_lazy(lazy), now);
            plain.update_node(k, u, InnerNodes::from_lazy(lazy));
        }
        let (mut a, mut b) = (Vec::new(), Vec::new());
        write_ot(t.occupancy(), &mut a).unwrap();
        write_ot(&plain, &mut b).unwrap();
        prop_assert_eq!(a, b);
        // every node on an updated path got `now`; nodes created only by lazy descents are 0
        prop_assert!(t.nodes_with_stamps().iter().all(|n| n.3 == now || n.3 == 0));
        prop_assert_eq!(t.base.payloads.len() <= t.size(), true);
    }

    /// The side table only names existing nodes, whatever the operations.
    #[test]
    fn stamps_only_for_existing_nodes(
        ops in prop::collection::vec((key_in_block(), 0u8..6, 1u32..6), 1..200),
    ) {
        let mut t = StampedOcTree::new(0.1).unwrap();
        for (k, op, now) in ops {
            match op {
                0 | 1 => { t.update_node_at(k, Update::Hit, InnerNodes::Refresh, now); }
                2 => { t.update_node_at(k, Update::Miss, InnerNodes::Refresh, now); }
                3 => { t.delete_node_at(k, 16, now); }
                4 => t.prune(),
                _ => t.degrade_outdated_nodes_at(1, now + 3),
            }
        }
        let existing: std::collections::HashSet<NodeId> =
            t.nodes_with_stamps().iter().map(|n| (n.0, n.1)).collect();
        for id in t.base.payloads.ids() {
            prop_assert!(existing.contains(&id), "stamp for a missing node {:?}", id);
        }
    }
}

proptest! {
    /// A scan's sets through the batched walk leave the same nodes, log-odds and stamps as the
    /// same updates one `update_node_at` at a time (a miss on each free key, then a hit on each
    /// occupied one), whatever came before: other times, lazy scans, unsorted keys, repeats.
    #[test]
    fn a_batch_is_its_updates_one_at_a_time(
        scans in prop::collection::vec(
            (
                prop::collection::vec(prop_oneof![key_in_two_bricks(), key_in_block()], 0..160),
                prop::collection::vec(prop_oneof![key_in_two_bricks(), key_in_block()], 0..40),
                0u32..3,
                prop::bool::weighted(0.15),
                any::<bool>(),
            ),
            1..12,
        ),
    ) {
        let mut batched = StampedOcTree::new(0.1).unwrap();
        let mut single = StampedOcTree::new(0.1).unwrap();
        let mut now = 100;
        for (mut free, occupied, tick, lazy, sorted) in scans {
            now += tick;
            if sorted {
                free.sort_by_key(|k| k.morton());
            }
            let inner = InnerNodes::from_lazy(lazy);
            batched.insert_update_at(free.iter().copied(), occupied.iter().copied(), inner, now);
            for &k in &free {
                single.update_node_at(k, Update::Miss, inner, now);
            }
            for &k in &occupied {
                single.update_node_at(k, Update::Hit, inner, now);
            }
            let (a, b) = (batched.nodes_with_stamps(), single.nodes_with_stamps());
            prop_assert_eq!(a.len(), b.len());
            for (x, y) in a.iter().zip(&b) {
                prop_assert_eq!((x.0, x.1, x.2.to_bits(), x.3), (y.0, y.1, y.2.to_bits(), y.3));
            }
            prop_assert_eq!(batched.size(), single.size());
            prop_assert_eq!(batched.base.payloads.len(), single.base.payloads.len());
        }
    }
}

proptest! {
    /// `degrade_outdated_nodes_at` as OctoMap's `degradeOutdatedNodes` reads: for every leaf
    /// of the leaf iterator that is occupied and whose stamp is more than `thres` before `now`
    /// (wrapping), one miss clamped to the sensor model's bounds; nothing else changes, stamps
    /// included.
    #[test]
    fn degrading_is_one_miss_on_each_stale_occupied_leaf(
        ops in prop::collection::vec((key_in_block(), any::<bool>(), 0u32..6, prop::bool::weighted(0.1)), 1..300),
        fills in prop::collection::vec((0u16..4, 0u16..4, 0u16..4, 0u32..6), 0..6),
        thres in 0u32..6,
        now in 0u32..12,
    ) {
        let mut t = StampedOcTree::new(0.1).unwrap();
        for (k, hit, time, lazy) in ops {
            let u = if hit { Update::Hit } else { Update::Miss };
            t.update_node_at(k, u, InnerNodes::from_lazy(lazy), 3 + time);
        }
        // the eight voxels of a depth-15 node hit to the clamp at one time: pruned into an
        // occupied leaf above the voxels
        for (x, y, z, time) in fills {
            let base = Key::new(32764 + 2 * x, 32764 + 2 * y, 32764 + 2 * z);
            for _ in 0..6 {
                for i in 0..8 {
                    t.update_node_at(octant(base, i), Update::Hit, InnerNodes::Refresh, 3 + time);
                }
            }
        }
        let p = *t.params();
        let miss = t.occupancy().delta(Update::Miss);
        let mut want = t.nodes_with_stamps();
        let leaves: std::collections::HashSet<(u8, Key)> = t
            .occupancy()
            .leaves()
            .map(|l| node_id(l.key, l.depth))
            .collect();
        for n in &mut want {
            if leaves.contains(&(n.0, n.1))
                && n.2 >= p.occupancy_threshold
                && now.wrapping_sub(n.3) > thres
            {
                n.2 = (n.2 + miss).clamp(p.clamp_min, p.clamp_max);
            }
        }
        t.degrade_outdated_nodes_at(thres, now);
        let got = t.nodes_with_stamps();
        prop_assert_eq!(got.len(), want.len());
        for (g, w) in got.iter().zip(&want) {
            prop_assert_eq!((g.0, g.1, g.2.to_bits(), g.3), (w.0, w.1, w.2.to_bits(), w.3));
        }
    }
}
