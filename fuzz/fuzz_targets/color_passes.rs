//! Structure-aware: `ColorOcTree::update_keys` (a pass through the plain tree's batched walk,
//! one update at a time only below the nodes that a prune could undo within the pass, in the
//! pass's order) against `update_node` on each key in turn, which is OctoMap's `updateNode`
//! loop. Both trees take the same random operations in a small block of voxels: single
//! updates, values (on the lattice the updates walk, or any `f32`), whole nodes set to one
//! value with one voxel an update short of it and every voxel its own colour (so that one
//! update makes the node prunable and the next expands it again), colours, prunes and
//! passes of keys in any order, repeats included, with hits, misses or any log-odds, eager or
//! lazy. No call may panic, after every pass the coloured `.ot` bytes must be equal, and after
//! every operation both trees' side tables must keep their bookkeeping (`check_color_table`).
#![no_main]
use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use octoquant_fuzz::ops::{FuzzKey, FuzzUpdate};
use octoquant_octree::io::write_color_ot;
use octoquant_octree::validate::check_color_table;
use octoquant_octree::{Color, ColorOcTree, InnerNodes, Key};

/// The side of the block of near keys: it straddles the root's octants.
const SIDE: u16 = 8;

/// A value to set: one of the lattice the default updates walk from 0, or any `f32`.
#[derive(Arbitrary, Debug, Clone, Copy)]
enum Value {
    Lattice(u8),
    Any(f32),
}

#[derive(Arbitrary, Debug, Clone)]
enum Op {
    Update {
        key: FuzzKey,
        update: FuzzUpdate,
        lazy: bool,
    },
    Set {
        key: FuzzKey,
        value: Value,
    },
    /// The depth-15 node (or, with `brick`, the depth-14 node) holding `key` at `value`, the
    /// voxel `key` itself at `short`, every voxel painted a colour of its own from `shade`.
    Trap {
        key: FuzzKey,
        brick: bool,
        value: Value,
        short: Value,
        shade: u8,
    },
    Paint {
        key: FuzzKey,
        color: [u8; 3],
    },
    Prune,
    Pass {
        keys: Vec<FuzzKey>,
        update: FuzzUpdate,
        lazy: bool,
    },
}

fn value(tree: &ColorOcTree, v: Value) -> f32 {
    let p = tree.params();
    let lattice = [
        0.0,
        p.miss,
        p.miss + p.miss,
        p.hit,
        p.hit + p.miss,
        p.hit + p.hit,
        p.clamp_min,
        p.clamp_max,
    ];
    match v {
        Value::Lattice(i) => lattice[usize::from(i) % lattice.len()],
        Value::Any(x) => x,
    }
}

/// Apply a non-pass operation to `t`.
fn apply(t: &mut ColorOcTree, op: &Op) {
    match op {
        Op::Update { key, update, lazy } => {
            t.update_node(
                key.key_in(SIDE),
                update.update(),
                InnerNodes::from_lazy(*lazy),
            );
        }
        Op::Set { key, value: v } => {
            let v = value(t, *v);
            let _ = t.set_node_value(key.key_in(SIDE), v, InnerNodes::Refresh);
        }
        Op::Trap {
            key,
            brick,
            value: v,
            short,
            shade,
        } => {
            let key = key.key_in(SIDE);
            let span = if *brick { 64 } else { 8 };
            let first = key.morton() / span * span;
            let (v, s) = (value(t, *v), value(t, *short));
            for c in first..first + span {
                let k = Key::from_morton(c);
                let x = if k == key { s } else { v };
                let _ = t.set_node_value(k, x, InnerNodes::Refresh);
            }
            for c in first..first + span {
                let g = shade.wrapping_add((c as u8).wrapping_mul(37));
                t.set_node_color(Key::from_morton(c), Color::new(g, 255 - g, c as u8));
            }
        }
        Op::Paint { key, color } => {
            let [r, g, b] = *color;
            t.set_node_color(key.key_in(SIDE), Color::new(r, g, b));
        }
        Op::Prune => t.prune(),
        Op::Pass { .. } => unreachable!("passes differ between the trees"),
    }
}

fn ot(t: &ColorOcTree) -> Vec<u8> {
    let mut out = Vec::new();
    write_color_ot(t, &mut out).expect("writing to memory");
    out
}

fuzz_target!(|ops: Vec<Op>| {
    let mut batched = ColorOcTree::new(0.1).expect("resolution");
    let mut single = batched.clone();
    for op in ops.iter().take(64) {
        if let Op::Pass { keys, update, lazy } = op {
            let keys: Vec<Key> = keys.iter().map(|k| k.key_in(SIDE)).collect();
            let (u, inner) = (update.update(), InnerNodes::from_lazy(*lazy));
            batched.update_keys(&keys, u, inner);
            for &k in &keys {
                single.update_node(k, u, inner);
            }
            assert_eq!(batched.size(), single.size(), "size after {op:?}");
            assert!(ot(&batched) == ot(&single), "other bytes after {op:?}");
        } else {
            apply(&mut batched, op);
            apply(&mut single, op);
        }
        for t in [&batched, &single] {
            if let Err(e) = check_color_table(t) {
                panic!("after {op:?}: colour table: {e}");
            }
        }
    }
});
