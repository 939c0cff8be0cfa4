//! Structure-aware: random operation sequences on an `OcTree` (update, batched updates of
//! bricks with change detection on or off, set, delete, prune, expand, max-likelihood, inner
//! occupancy, `.bt`/`.ot` write and read back, OctoMap's `updateNodeLogOdds` and
//! `nodeToMaxLikelihood` on a node in hand), checked after every step against the tree's
//! invariants (`check_well_formed`, strict while no operation has left it lazy) and at the
//! end against a naive oracle: a map from voxel key to log-odds that every operation updates
//! the obvious way. (Deleting the root's last child leaves the root as a leaf covering the
//! whole map, as in OctoMap, whose next update expands it into the whole space: the oracle is
//! off from there until the next `Clear`.)
#![no_main]
use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use octoquant_fuzz::ops::{FuzzKey, FuzzUpdate};
use octoquant_octree::io::{read_bt, read_ot, write_bt, write_ot};
use octoquant_octree::validate::check_well_formed;
use octoquant_octree::{Brick, InnerNodes, Key, OcTree, Update, TREE_DEPTH};
use std::collections::BTreeMap;

/// The side of the block of near keys: siblings meet and prune.
const SIDE: u16 = 16;

#[derive(Arbitrary, Debug, Clone, Copy)]
enum Op {
    Update {
        key: FuzzKey,
        update: FuzzUpdate,
        lazy: bool,
    },
    /// The same update on the 8 voxels of one depth-15 node, so it can prune.
    UpdateOctant {
        key: FuzzKey,
        update: FuzzUpdate,
    },
    /// `update_bricks` (the batched walk every scan insertion takes) on up to four bricks of
    /// 4x4x4 voxels, each the brick of a key with any mask, in the order given (repeats
    /// included); with change detection on or off, which the walk compiles as two paths.
    UpdateBricks {
        bricks: [(FuzzKey, u64); 4],
        count: u8,
        update: FuzzUpdate,
        lazy: bool,
        track: bool,
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
    Prune,
    Expand,
    UpdateInnerOccupancy,
    ToMaxLikelihood,
    WriteReadBt,
    WriteReadOt,
    Clear,
    /// `update_node_log_odds` (or, with `ml`, `node_to_max_likelihood`) on the node at exactly
    /// `depth` (0 or past 16: 16) holding the key.
    NodeInHand {
        key: FuzzKey,
        depth: u8,
        update: FuzzUpdate,
        ml: bool,
    },
}

#[derive(Arbitrary, Debug)]
struct Input {
    ops: Vec<Op>,
}

type Model = BTreeMap<[u16; 3], f32>;

/// OctoMap's voxel update: from 0 for a new voxel, `old + delta` clamped, NaN ignored.
fn model_update(tree: &OcTree, model: &mut Model, key: Key, update: Update) {
    let delta = tree.delta(update);
    if delta.is_nan() {
        return;
    }
    let p = tree.params();
    let old = model.get(&key.0).copied().unwrap_or(0.0);
    let v = old + delta;
    let v = if v < p.clamp_min {
        p.clamp_min
    } else if v > p.clamp_max {
        p.clamp_max
    } else {
        v
    };
    model.insert(key.0, v);
}

fn same_prefix(a: [u16; 3], b: [u16; 3], depth: u8) -> bool {
    let shift = u32::from(TREE_DEPTH - depth);
    (0..3).all(|i| (u32::from(a[i]) >> shift) == (u32::from(b[i]) >> shift))
}

fn write_bt_bytes(tree: &mut OcTree) -> Vec<u8> {
    let mut out = Vec::new();
    write_bt(tree, &mut out).unwrap();
    out
}

fn write_ot_bytes(tree: &OcTree) -> Vec<u8> {
    let mut out = Vec::new();
    write_ot(tree, &mut out).unwrap();
    out
}

fn check_against_model(tree: &OcTree, model: &Model) {
    for (k, v) in model {
        let found = tree
            .search(Key(*k), TREE_DEPTH)
            .unwrap_or_else(|| panic!("voxel {k:?} (model {v}) is missing"));
        assert!(
            found.value.to_bits() == v.to_bits(),
            "voxel {k:?}: tree {} model {v}",
            found.value
        );
    }
    let covered: u64 = tree.leaves().map(|l| u64::from(l.width()).pow(3)).sum();
    assert_eq!(
        covered,
        model.len() as u64,
        "leaves cover other voxels than the model"
    );
}

fuzz_target!(|input: Input| {
    let mut tree = OcTree::new(0.1).unwrap();
    let mut model = Model::new();
    // Strict: every inner node is the max of its children and nothing is collapsible.
    let mut strict = true;
    // The oracle holds: no delete has left the root as a leaf.
    let mut model_ok = true;
    for op in input.ops.iter().take(256) {
        match *op {
            Op::Update { key, update, lazy } => {
                let (k, u) = (key.key_in(SIDE), update.update());
                model_update(&tree, &mut model, k, u);
                tree.update_node(k, u, InnerNodes::from_lazy(lazy));
                strict &= !lazy;
            }
            Op::UpdateOctant { key, update } => {
                let base = key.key_in(SIDE).0.map(|c| c & !1);
                let u = update.update();
                for i in 0..8u16 {
                    let k = Key::new(
                        base[0] | (i & 1),
                        base[1] | ((i >> 1) & 1),
                        base[2] | (i >> 2),
                    );
                    model_update(&tree, &mut model, k, u);
                    tree.update_node(k, u, InnerNodes::Refresh);
                }
            }
            Op::UpdateBricks {
                bricks,
                count,
                update,
                lazy,
                track,
            } => {
                let u = update.update();
                let list: Vec<Brick> = bricks[..usize::from(count % 5)]
                    .iter()
                    .map(|&(key, voxels)| Brick {
                        code: Brick::of_voxel(key.key_in(SIDE).morton()).code,
                        voxels,
                    })
                    .collect();
                // the documented meaning: `update_node` on every selected voxel, brick by
                // brick, in mask-bit order
                for b in &list {
                    for bit in 0..64 {
                        if b.voxels >> bit & 1 == 1 {
                            let k = Key::from_morton((b.code << 6) | bit);
                            model_update(&tree, &mut model, k, u);
                        }
                    }
                }
                tree.enable_change_detection(track);
                tree.update_bricks(&list, u, InnerNodes::from_lazy(lazy));
                tree.enable_change_detection(false);
                strict &= !lazy;
            }
            Op::Set { key, value, lazy } => {
                let k = key.key_in(SIDE);
                let r = tree.set_node_value(k, value, InnerNodes::from_lazy(lazy));
                if value.is_nan() {
                    assert!(r.is_err(), "set_node_value accepted NaN");
                } else {
                    let p = tree.params();
                    model.insert(k.0, value.max(p.clamp_min).min(p.clamp_max));
                    strict &= !lazy;
                }
            }
            Op::Delete { key, depth } => {
                let k = key.key_in(SIDE);
                let d = if depth == 0 || depth > TREE_DEPTH {
                    TREE_DEPTH
                } else {
                    depth
                };
                let before = model.len();
                model.retain(|m, _| !same_prefix(*m, k.0, d));
                let deleted = tree.delete_node(k, depth);
                if model_ok {
                    assert_eq!(deleted, model.len() != before, "delete_node's answer");
                }
                // OctoMap's deleteNodeRecurs refreshes only the parent that keeps children;
                // the ancestors above keep their values (proven against liboctomap and
                // octomap-python), so inner values may be stale from here
                if deleted {
                    strict = false;
                }
                if tree.size() == 1 {
                    model_ok = false;
                }
            }
            Op::Prune => {
                tree.prune();
                strict = false;
            }
            Op::Expand => {
                // expand() gives every leaf all its voxels and the inner nodes above them:
                // (8^(17-d) - 8) / 7 nodes below a leaf at depth d; a root left as a leaf
                // would mean 2^48 voxels. try_expand refuses past its limit and leaves the
                // tree as it was; 8192 nodes cover every expansion of the 16^3 block the
                // near keys live in, and keep each later step's whole-tree check cheap.
                const LIMIT: u64 = 1 << 13;
                let naive: u64 = tree
                    .leaves()
                    .map(|l| (8u64.pow(17 - u32::from(l.depth)) - 8) / 7)
                    .sum();
                let before = tree.size() as u64;
                assert_eq!(tree.expansion_nodes(), naive);
                match tree.try_expand(LIMIT) {
                    Ok(n) => {
                        assert!(naive <= LIMIT && n == naive);
                        assert_eq!(tree.size() as u64, before + n);
                        strict = false;
                    }
                    Err(_) => {
                        assert!(naive > LIMIT);
                        assert_eq!(tree.size() as u64, before);
                    }
                }
            }
            Op::UpdateInnerOccupancy => {
                tree.update_inner_occupancy();
                strict = false;
            }
            Op::ToMaxLikelihood => {
                tree.to_max_likelihood();
                let p = *tree.params();
                for v in model.values_mut() {
                    *v = if p.is_occupied(*v) {
                        p.clamp_max
                    } else {
                        p.clamp_min
                    };
                }
                strict = false;
            }
            Op::WriteReadBt => {
                let first = write_bt_bytes(&mut tree);
                let p = *tree.params();
                for v in model.values_mut() {
                    *v = if p.is_occupied(*v) {
                        p.clamp_max
                    } else {
                        p.clamp_min
                    };
                }
                let mut back = read_bt(first.as_slice()).expect(".bt output does not read back");
                let second = write_bt_bytes(&mut back);
                assert!(
                    first == second,
                    ".bt write/read/write is not a byte round trip"
                );
                tree = back;
                strict = false;
            }
            Op::WriteReadOt => {
                let first = write_ot_bytes(&tree);
                let back = read_ot(first.as_slice()).expect(".ot output does not read back");
                assert!(
                    first == write_ot_bytes(&back),
                    ".ot write/read/write is not a byte round trip"
                );
                assert_eq!(back.size(), tree.size());
                tree = back;
            }
            Op::Clear => {
                tree.clear();
                model.clear();
                strict = true;
                model_ok = true;
            }
            Op::NodeInHand {
                key,
                depth,
                update,
                ml,
            } => {
                let k = key.key_in(SIDE);
                let d = if depth == 0 || depth > TREE_DEPTH {
                    TREE_DEPTH
                } else {
                    depth
                };
                let before = tree.node_at_depth(k, d);
                let p = *tree.params();
                let delta = tree.delta(update.update());
                let got = if ml {
                    Ok(tree.node_to_max_likelihood(k, d))
                } else {
                    tree.update_node_log_odds(k, d, update.update())
                };
                match (before, got) {
                    (None, got) => assert!(matches!(got, Ok(None)), "a call on no node: {got:?}"),
                    (Some(n), Err(_)) => {
                        // refused only for a NaN sum, and then nothing changed
                        assert!(!ml && (n.value + delta).is_nan());
                        let now = tree.node_at_depth(k, d).map(|m| m.value.to_bits());
                        assert_eq!(now, Some(n.value.to_bits()));
                    }
                    (Some(n), Ok(v)) => {
                        // OctoMap's definitions: add then clamp, no early exit; or the clamp
                        // on the node's side of the threshold
                        let expected = if ml {
                            if p.is_occupied(n.value) {
                                p.clamp_max
                            } else {
                                p.clamp_min
                            }
                        } else {
                            let s = n.value + delta;
                            if s < p.clamp_min {
                                p.clamp_min
                            } else if s > p.clamp_max {
                                p.clamp_max
                            } else {
                                s
                            }
                        };
                        let v = v.expect("the node exists");
                        assert_eq!(v.to_bits(), expected.to_bits());
                        // a leaf's voxels all take the value; an inner node's keep theirs
                        if !n.has_children {
                            for (m, val) in model.iter_mut() {
                                if same_prefix(*m, k.0, d) {
                                    *val = v;
                                }
                            }
                        }
                        // no ancestor is refreshed, as in OctoMap
                        strict = false;
                    }
                }
            }
        }
        if let Err(e) = check_well_formed(&tree, InnerNodes::from_lazy(!strict)) {
            panic!("after {op:?} (strict {strict}): {e}");
        }
    }
    if model_ok {
        check_against_model(&tree, &model);
    }
});
