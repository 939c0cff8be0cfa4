//! Structure-aware: random operation sequences at a moving clock on two `StampedOcTree`s, one
//! taking each scan's sets through the batched `insert_update_at` (the plain tree's brick walk,
//! the stamps following through its hooks), the other the same updates one `update_node_at` at
//! a time, as the batch is documented to be. Every other operation (update, set, delete,
//! degrade, prune, expand, max-likelihood, inner occupancy, `.ot` write and read back) goes
//! to both. After every step the two must hold the same nodes with the same log-odds bits and
//! stamps, the occupancy tree must be well formed (never strictly: nodes with different
//! stamps are not pruned), and a Hit or Miss that reached a voxel not already at the clamp it
//! pushes towards must have stamped it with the clock's time. Both trees' side tables must
//! keep their bookkeeping (`check_stamp_table`).
#![no_main]
use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use octoquant_fuzz::ops::{FuzzKey, FuzzUpdate};
use octoquant_octree::io::{read_stamped_ot, write_stamped_ot};
use octoquant_octree::validate::{check_stamp_table, check_well_formed};
use octoquant_octree::{InnerNodes, Key, StampedOcTree, Update, TREE_DEPTH};

/// The side of the block of near keys: siblings meet, collapse and share ancestors.
const SIDE: u16 = 8;

#[derive(Arbitrary, Debug, Clone)]
enum Op {
    /// Move the clock on by this many seconds (wrapping, as OctoMap's `unsigned int`).
    Tick(u16),
    Update {
        key: FuzzKey,
        update: FuzzUpdate,
        lazy: bool,
    },
    /// One scan's sets at the clock's time: a miss on each free key, then a hit on each
    /// occupied one, in the order given (repeats and unsorted keys included).
    Batch {
        free: Vec<FuzzKey>,
        occupied: Vec<FuzzKey>,
        lazy: bool,
    },
    Set {
        key: FuzzKey,
        value: f32,
        lazy: bool,
    },
    Delete {
        key: FuzzKey,
        depth: u8,
    },
    Degrade(u16),
    Prune,
    Expand,
    UpdateInnerOccupancy,
    ToMaxLikelihood,
    WriteReadOt,
    Clear,
}

#[derive(Arbitrary, Debug)]
struct Input {
    start: u32,
    ops: Vec<Op>,
}

/// Nodes as comparable values: log-odds by their bits, so NaN-free trees compare exactly.
fn nodes(tree: &StampedOcTree) -> Vec<(u8, [u16; 3], u32, u32)> {
    tree.nodes_with_stamps()
        .into_iter()
        .map(|(d, k, v, t)| (d, k.0, v.to_bits(), t))
        .collect()
}

fn ot_bytes(tree: &StampedOcTree) -> Vec<u8> {
    let mut out = Vec::new();
    write_stamped_ot(tree, &mut out).unwrap();
    out
}

/// Whether OctoMap's `updateNode` returns early for this voxel: it exists and already sits at
/// the clamp the update pushes towards (a delta of 0 counts as both ways).
fn at_its_clamp(tree: &StampedOcTree, key: Key, delta: f32) -> bool {
    let p = tree.params();
    match tree.search(key, TREE_DEPTH) {
        Some(n) => {
            (delta >= 0.0 && n.node.value >= p.clamp_max)
                || (delta <= 0.0 && n.node.value <= p.clamp_min)
        }
        None => false,
    }
}

fuzz_target!(|input: Input| {
    let mut batched = StampedOcTree::new(0.1).unwrap();
    let mut single = StampedOcTree::new(0.1).unwrap();
    let mut now = input.start;
    for op in input.ops.iter().take(128) {
        match op {
            Op::Tick(s) => now = now.wrapping_add(u32::from(*s)),
            Op::Update { key, update, lazy } => {
                let (k, u) = (key.key_in(SIDE), update.update());
                let inner = InnerNodes::from_lazy(*lazy);
                let delta = single.occupancy().delta(u);
                let stamps =
                    matches!(u, Update::Hit | Update::Miss) && !at_its_clamp(&single, k, delta);
                let a = batched.update_node_at(k, u, inner, now);
                let b = single.update_node_at(k, u, inner, now);
                assert_eq!(a.to_bits(), b.to_bits());
                if stamps {
                    assert_eq!(single.timestamp(k), Some(now), "{op:?} did not stamp {k:?}");
                }
            }
            Op::Batch {
                free,
                occupied,
                lazy,
            } => {
                let free: Vec<Key> = free.iter().take(64).map(|k| k.key_in(SIDE)).collect();
                let occupied: Vec<Key> = occupied.iter().take(64).map(|k| k.key_in(SIDE)).collect();
                let inner = InnerNodes::from_lazy(*lazy);
                batched.insert_update_at(
                    free.iter().copied(),
                    occupied.iter().copied(),
                    inner,
                    now,
                );
                for &k in &free {
                    single.update_node_at(k, Update::Miss, inner, now);
                }
                for &k in &occupied {
                    single.update_node_at(k, Update::Hit, inner, now);
                }
            }
            Op::Set { key, value, lazy } => {
                let k = key.key_in(SIDE);
                let inner = InnerNodes::from_lazy(*lazy);
                let a = batched.set_node_value_at(k, *value, inner, now);
                let b = single.set_node_value_at(k, *value, inner, now);
                assert_eq!(a.is_err(), value.is_nan(), "set_node_value_at({value})");
                assert_eq!(a.ok().map(f32::to_bits), b.ok().map(f32::to_bits));
            }
            Op::Delete { key, depth } => {
                let k = key.key_in(SIDE);
                let a = batched.delete_node_at(k, *depth, now);
                let b = single.delete_node_at(k, *depth, now);
                assert_eq!(a, b);
            }
            Op::Degrade(thres) => {
                batched.degrade_outdated_nodes_at(u32::from(*thres), now);
                single.degrade_outdated_nodes_at(u32::from(*thres), now);
            }
            Op::Prune => {
                batched.prune();
                single.prune();
            }
            Op::Expand => {
                // as in `octree_ops`: past 8192 new nodes try_expand refuses and changes nothing
                const LIMIT: u64 = 1 << 13;
                let before = nodes(&single);
                let a = batched.try_expand(LIMIT);
                let b = single.try_expand(LIMIT);
                assert_eq!(a.is_ok(), b.is_ok());
                if b.is_err() {
                    assert!(
                        nodes(&single) == before,
                        "a refused expansion changed the tree"
                    );
                }
            }
            Op::UpdateInnerOccupancy => {
                batched.update_inner_occupancy_at(now);
                single.update_inner_occupancy_at(now);
            }
            Op::ToMaxLikelihood => {
                batched.to_max_likelihood();
                single.to_max_likelihood();
            }
            Op::WriteReadOt => {
                let first = ot_bytes(&single);
                assert!(first == ot_bytes(&batched), "the twins write different .ot");
                let back =
                    read_stamped_ot(first.as_slice()).expect(".ot output does not read back");
                assert!(
                    first == ot_bytes(&back),
                    ".ot write/read/write is not a byte round trip"
                );
                assert_eq!(back.size(), single.size());
                assert!(
                    back.nodes_with_stamps().iter().all(|n| n.3 == 0),
                    "a tree read back has a stamp (OctoMap saves none)"
                );
                batched = back.clone();
                single = back;
            }
            Op::Clear => {
                batched.clear();
                single.clear();
            }
        }
        let (a, b) = (nodes(&batched), nodes(&single));
        if a != b {
            let at = a.iter().zip(&b).position(|(x, y)| x != y);
            panic!(
                "after {op:?}: batched and one-by-one trees differ ({} and {} nodes, first \
                 difference at {at:?})",
                a.len(),
                b.len()
            );
        }
        assert_eq!(batched.last_update_time(), single.last_update_time());
        if let Err(e) = check_well_formed(single.occupancy(), InnerNodes::Defer) {
            panic!("after {op:?}: {e}");
        }
        // the side table's bookkeeping, which both trees share the code of (a slip there that
        // both make alike would pass the comparison above)
        for t in [&batched, &single] {
            if let Err(e) = check_stamp_table(t) {
                panic!("after {op:?}: stamp table: {e}");
            }
        }
    }
});
