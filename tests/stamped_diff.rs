//! `OcTreeStamped` against the real OctoMap: the reference program's clock is set by the
//! script (it interposes `time()`, which OctoMap reads inside every stamping operation), and
//! random operation sequences at changing times, and real scans inserted a second apart, must
//! give the same nodes with the same log-odds and stamps, the same last update time and
//! byte-identical `.ot` files.

use crate::common::{self, first_diff};
use octoquant::formats::{read_frames, Frame, ReadOptions};
use octoquant::octree::io::{read_stamped_ot, write_stamped_ot};
use octoquant::octree::{InnerNodes, Key, OccupancyParams, StampedOcTree, Update};
use octoquant::raycast::{compute_update_f32, ScanUpdate};
use proptest::prelude::*;
use std::fmt::Write as _;
use std::path::Path;
use std::process::Command;

/// One operation applied to both trees.
#[derive(Debug, Clone)]
enum Op {
    /// Move the clock forward by this many seconds (0: same second).
    Tick(u32),
    Update {
        key: Key,
        hit: bool,
        repeat: u8,
        lazy: bool,
    },
    Set {
        key: Key,
        bits: u32,
        lazy: bool,
    },
    Delete {
        key: Key,
    },
    Degrade(u32),
    Prune,
    Expand,
    MaxLikelihood,
    Inner,
    /// Node surgery on one node (`expandNode`, `pruneNode`, `createNodeChild`,
    /// `deleteNodeChild`, which read no clock; `integrateHit`, `integrateMiss`,
    /// `updateNodeLogOdds`, which stamp the node; `nodeToMaxLikelihood`).
    Surgery(common::Surgery),
    /// A node's stamp by hand (`setTimestamp(t)`, or `updateTimestamp()` with `None`), or
    /// `integrateMissNoTime` on it (`miss`).
    Stamp {
        key: Key,
        depth: u8,
        t: Option<u32>,
        miss: bool,
    },
    Many(Vec<Op>),
    /// One scan's sets at one time (`insert_update_at`): a miss on each free key, then a
    /// hit on each occupied one, eager.
    Batch {
        free: Vec<Key>,
        occupied: Vec<Key>,
    },
}

#[derive(Debug, Clone)]
struct Case {
    res: f64,
    params: Option<[f64; 5]>,
    start: u32,
    ops: Vec<Op>,
}

fn key_strategy(base: Key) -> impl Strategy<Value = Key> {
    let near = move |w: u16| {
        (0..w, 0..w, 0..w).prop_map(move |(x, y, z)| {
            Key::new(
                base.x().wrapping_add(x),
                base.y().wrapping_add(y),
                base.z().wrapping_add(z),
            )
        })
    };
    prop_oneof![
        6 => near(4),
        3 => near(16),
        1 => any::<[u16; 3]>().prop_map(Key),
    ]
}

fn op_strategy(base: Key) -> impl Strategy<Value = Op> {
    let k = move || key_strategy(base);
    prop_oneof![
        8 => prop_oneof![3 => Just(0u32), 3 => 1u32..3, 1 => 3u32..100].prop_map(Op::Tick),
        30 => (k(), any::<bool>(), 1u8..10, prop::bool::weighted(0.2))
            .prop_map(|(key, hit, repeat, lazy)| Op::Update { key, hit, repeat, lazy }),
        // the eight voxels of one depth-15 node, five times each: they reach a clamp
        // together and prune only if their stamps agree
        // and then, now and then, node surgery on their parent or grandparent (pruned or
        // not: a stamp goes down with an expansion and up with a prune)
        8 => (
            k(),
            any::<bool>(),
            prop::bool::weighted(0.1),
            prop::collection::vec(0u32..2, 8),
            prop::collection::vec((0u8..8, 14u8..=15, 0u8..8), 0..4),
        )
            .prop_map(|(key, hit, lazy, ticks, calls)| {
                let mut ops = Vec::new();
                for (i, t) in (0..8u16).zip(ticks) {
                    ops.push(Op::Tick(t));
                    ops.push(Op::Update {
                        key: Key::new(
                            key.x() & !1 | (i & 1),
                            key.y() & !1 | (i >> 1 & 1),
                            key.z() & !1 | (i >> 2 & 1),
                        ),
                        hit,
                        repeat: 5,
                        lazy,
                    });
                }
                for (kind, depth, child) in calls {
                    ops.push(Op::Tick(1));
                    let bits = 0.5f32.to_bits();
                    ops.push(Op::Surgery(common::Surgery { kind, key, depth, child, bits }));
                }
                Op::Many(ops)
            }),
        4 => (k(), -4.0f32..4.0, prop::bool::weighted(0.2))
            .prop_map(|(key, v, lazy)| Op::Set { key, bits: v.to_bits(), lazy }),
        2 => k().prop_map(|key| Op::Delete { key }),
        4 => prop_oneof![Just(0u32), 1u32..5, 5u32..200].prop_map(Op::Degrade),
        3 => Just(Op::Prune),
        1 => Just(Op::Expand),
        1 => Just(Op::MaxLikelihood),
        2 => Just(Op::Inner),
        8 => common::surgery_strategy(k()).prop_map(Op::Surgery),
        4 => (k(), 12u8..=16, prop::option::of(0u32..5), prop::bool::weighted(0.3))
            .prop_map(|(key, depth, t, miss)| Op::Stamp { key, depth, t, miss }),
        // a scan's sets, in Morton order as computed (or not), repeated keys and all
        6 => (prop::collection::vec(k(), 1..60), prop::collection::vec(k(), 0..8), any::<bool>())
            .prop_map(|(mut free, mut occupied, sorted)| {
                if sorted {
                    free.sort_by_key(|k| k.morton());
                    occupied.sort_by_key(|k| k.morton());
                }
                Op::Batch { free, occupied }
            }),
    ]
}

fn case_strategy() -> impl Strategy<Value = Case> {
    let res = prop_oneof![Just(0.1), Just(0.05), Just(0.123456789)];
    let params = prop::option::weighted(
        0.3,
        (
            0.51f64..0.95,
            0.05f64..0.49,
            0.01f64..0.4,
            0.6f64..0.99,
            0.3f64..0.7,
        ),
    )
    .prop_map(|p| p.map(|(h, m, lo, hi, t)| [h, m, lo, hi, t]));
    let base = prop_oneof![
        Just(Key::new(32768, 32768, 32768)),
        Just(Key::new(32766, 32765, 32767)),
        any::<[u16; 3]>().prop_map(Key),
    ];
    // the clock starts anywhere up to the end of u32 (stamps wrap in OctoMap's arithmetic)
    let start = prop_oneof![
        1u32..1000,
        (u32::MAX - 300)..u32::MAX,
        1_700_000_000u32..1_800_000_000
    ];
    (res, params, base, start).prop_flat_map(|(res, params, base, start)| {
        prop::collection::vec(op_strategy(base), 1..160).prop_map(move |mut ops| {
            // a delete can leave a childless root that the next update expands into coarse
            // leaves; a later expand() would then create billions of nodes
            if ops.iter().any(|o| matches!(o, Op::Delete { .. })) {
                ops.retain(|o| !matches!(o, Op::Expand));
            }
            Case {
                res,
                params,
                start,
                ops,
            }
        })
    })
}

/// Apply the operations to our tree and write the same script for OctoMap.
fn run_ours(case: &Case) -> (StampedOcTree, String) {
    let mut tree = StampedOcTree::new(case.res).unwrap();
    let mut s = String::new();
    writeln!(s, "tree {:.17e}", case.res).unwrap();
    if let Some([h, m, lo, hi, t]) = case.params {
        tree = StampedOcTree::with_params(
            case.res,
            OccupancyParams::from_probabilities(h, m, lo, hi, t).unwrap(),
        )
        .unwrap();
        writeln!(s, "params {h:.17e} {m:.17e} {lo:.17e} {hi:.17e} {t:.17e}").unwrap();
    }
    let mut now = case.start;
    writeln!(s, "clock {now}").unwrap();
    apply(&mut tree, &case.ops, &mut now, &mut s);
    (tree, s)
}

fn apply(tree: &mut StampedOcTree, ops: &[Op], now: &mut u32, s: &mut String) {
    for op in ops {
        match *op {
            Op::Many(ref ops) => apply(tree, ops, now, s),
            Op::Tick(dt) => {
                // OctoMap's clock is a time_t; keep both inside u32 as its stamps are
                *now = now.saturating_add(dt);
                writeln!(s, "clock {now}").unwrap();
            }
            Op::Update {
                key,
                hit,
                repeat,
                lazy,
            } => {
                let u = if hit { Update::Hit } else { Update::Miss };
                for _ in 0..repeat {
                    tree.update_node_at(key, u, InnerNodes::from_lazy(lazy), *now);
                    let c = if hit { "hit" } else { "miss" };
                    writeln!(s, "{c} {} {} {} {}", key.x(), key.y(), key.z(), lazy as u8).unwrap();
                }
            }
            Op::Set { key, bits, lazy } => {
                tree.set_node_value_at(
                    key,
                    f32::from_bits(bits),
                    InnerNodes::from_lazy(lazy),
                    *now,
                )
                .unwrap();
                writeln!(
                    s,
                    "set {} {} {} {bits:08x} {}",
                    key.x(),
                    key.y(),
                    key.z(),
                    lazy as u8
                )
                .unwrap();
            }
            Op::Delete { key } => {
                tree.delete_node_at(key, 16, *now);
                writeln!(s, "delete {} {} {} 16", key.x(), key.y(), key.z()).unwrap();
            }
            Op::Degrade(thres) => {
                tree.degrade_outdated_nodes_at(thres, *now);
                writeln!(s, "degrade {thres}").unwrap();
            }
            Op::Prune => {
                tree.prune();
                s.push_str("prune\n");
            }
            Op::Expand => {
                tree.expand();
                s.push_str("expand\n");
            }
            Op::MaxLikelihood => {
                tree.to_max_likelihood();
                s.push_str("ml\n");
            }
            Op::Inner => {
                tree.update_inner_occupancy_at(*now);
                s.push_str("inner\n");
            }
            Op::Surgery(ref c) => {
                c.apply(tree, *now);
                s.push_str(&c.line());
            }
            Op::Stamp {
                key,
                depth,
                t,
                miss,
            } => {
                let (x, y, z) = (key.x(), key.y(), key.z());
                let found = if miss {
                    writeln!(s, "miss_no_time {x} {y} {z} {depth}").unwrap();
                    tree.integrate_miss_no_time(key, depth).is_some()
                } else if let Some(t) = t {
                    // a small stamp: a prune then compares it with the clock's
                    writeln!(s, "stamp {x} {y} {z} {depth} {t}").unwrap();
                    tree.set_timestamp(key, depth, t)
                } else {
                    writeln!(s, "touch {x} {y} {z} {depth}").unwrap();
                    tree.set_timestamp(key, depth, *now)
                };
                assert_eq!(found, tree.node_at_depth(key, depth).is_some());
            }
            Op::Batch {
                ref free,
                ref occupied,
            } => {
                tree.insert_update_at(
                    free.iter().copied(),
                    occupied.iter().copied(),
                    InnerNodes::Refresh,
                    *now,
                );
                for (keys, c) in [(free, "miss"), (occupied, "hit")] {
                    for k in keys {
                        writeln!(s, "{c} {} {} {} 0", k.x(), k.y(), k.z()).unwrap();
                    }
                }
            }
        }
    }
}

/// OctoMap 1.9.7 aborts on this assertion when a node emptied by `deleteNode` is later
/// destroyed; such cases have no reference answer.
const OCTOMAP_DELETE_ABORT: &str = "Assertion `children == NULL' failed";

/// What OctoMap says after a script: its node dump and last update line (stdout), and the
/// `.ot` it wrote; `None` when it hit its known delete abort.
fn reference(refprog: &Path, script: &str, dir: &Path) -> Option<(String, Vec<u8>)> {
    let ot = dir.join("ref.ot");
    let _ = std::fs::remove_file(&ot);
    let sp = dir.join("ops.txt");
    std::fs::write(
        &sp,
        format!(
            "{script}print_last_update\nprint_nodes\nwrite_ot {}\n",
            ot.display()
        ),
    )
    .unwrap();
    let out = Command::new(refprog)
        .arg("stamped-script")
        .arg(&sp)
        .output()
        .expect("run reference program");
    if !out.status.success() && String::from_utf8_lossy(&out.stderr).contains(OCTOMAP_DELETE_ABORT)
    {
        return None;
    }
    assert!(
        out.status.success(),
        "reference program failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8(out.stdout).unwrap();
    // only our lines: "frame ..." timing lines of insert are not compared
    let dump = stdout
        .lines()
        .filter(|l| l.starts_with("node ") || l.starts_with("last_update "))
        .map(|l| format!("{l}\n"))
        .collect();
    Some((dump, std::fs::read(ot).unwrap()))
}

/// Our tree in the reference program's dump format.
fn dump(tree: &StampedOcTree) -> String {
    let mut s = format!("last_update {}\n", tree.last_update_time());
    for (depth, key, value, stamp) in tree.nodes_with_stamps() {
        writeln!(
            s,
            "node {depth} {} {} {} {:08x} {stamp}",
            key.x(),
            key.y(),
            key.z(),
            value.to_bits()
        )
        .unwrap();
    }
    s
}

fn stamped_ot(tree: &StampedOcTree) -> Vec<u8> {
    let mut v = Vec::new();
    write_stamped_ot(tree, &mut v).unwrap();
    v
}

/// The first line where two dumps differ.
fn first_line_diff(a: &str, b: &str) -> String {
    for (i, (x, y)) in a.lines().zip(b.lines()).enumerate() {
        if x != y {
            return format!("line {i}: ours {x:?}, OctoMap {y:?}");
        }
    }
    format!("{} lines against {}", a.lines().count(), b.lines().count())
}

#[test]
fn random_stamped_sequences_match_octomap() {
    let Some(refprog) = common::reference_program() else {
        return;
    };
    let dir = common::scratch("stamped_diff_random");
    let compared = std::cell::Cell::new(0usize);
    let aborted = std::cell::Cell::new(0usize);
    // cases where some equal-valued octant stayed apart for its stamps, or a leaf degraded
    let stamps_mattered = std::cell::Cell::new(0usize);
    let mut runner = proptest::test_runner::TestRunner::new(ProptestConfig {
        cases: 200,
        failure_persistence: None,
        ..ProptestConfig::default()
    });
    runner
        .run(&case_strategy(), |case| {
            let (tree, script) = run_ours(&case);
            let Some((rdump, rot)) = reference(&refprog, &script, &dir) else {
                aborted.set(aborted.get() + 1);
                return Ok(());
            };
            compared.set(compared.get() + 1);
            let ours = dump(&tree);
            prop_assert!(
                ours == rdump,
                "nodes differ: {}",
                first_line_diff(&ours, &rdump)
            );
            let ot = stamped_ot(&tree);
            prop_assert!(ot == rot, ".ot differs: {}", first_diff(&ot, &rot));
            let back = read_stamped_ot(&rot[..]).unwrap();
            prop_assert!(stamped_ot(&back) == rot);
            // would a plain tree have pruned more? then stamps decided the structure
            let mut plain = tree.occupancy().clone();
            plain.prune();
            let distinct: std::collections::HashSet<u32> =
                tree.nodes_with_stamps().iter().map(|n| n.3).collect();
            if plain.size() < tree.size() && distinct.len() > 1 {
                stamps_mattered.set(stamps_mattered.get() + 1);
            }
            Ok(())
        })
        .unwrap();
    assert!(
        compared.get() >= 4 * aborted.get() && compared.get() >= 120,
        "compared {} cases, reference aborted on {}",
        compared.get(),
        aborted.get()
    );
    assert!(
        stamps_mattered.get() * 5 >= compared.get(),
        "stamps kept equal-valued leaves apart in only {} of {} cases",
        stamps_mattered.get(),
        compared.get()
    );
}

/// Real scans inserted one per second (OctoMap's `insertPointCloud` at a clock it reads; as
/// keys and as bricks in turn), then the stale obstacles degraded: same nodes, stamps and `.ot` bytes as OctoMap.
fn check_real_frames(name: &str, frames: &[Frame], res: f64, max_range: Option<f64>) {
    let Some(refprog) = common::reference_program() else {
        return;
    };
    let dir = common::scratch(&format!("stamped_diff_{name}"));
    let ff = dir.join("frames.frames");
    octoquant::formats::frames::write_frames_file(&ff, frames).unwrap();
    let start = 1_790_000_000u32;
    let mut tree = StampedOcTree::new(res).unwrap();
    let mut update = ScanUpdate::new();
    for (i, f) in frames.iter().enumerate() {
        compute_update_f32(
            tree.converter(),
            &f.points,
            &f.origin,
            max_range,
            &mut update,
        );
        let now = start + i as u32;
        // both batch forms, keys and bricks, in turn
        if i % 2 == 0 {
            tree.insert_update_at(
                update.free().iter().copied(),
                update.occupied().iter().copied(),
                InnerNodes::Refresh,
                now,
            );
        } else {
            tree.insert_bricks_at(
                update.free_bricks(),
                update.occupied_bricks(),
                InnerNodes::Refresh,
                now,
            );
        }
    }
    let last = start + frames.len() as u32 - 1;
    let before = dump(&tree);
    tree.degrade_outdated_nodes_at(1, last);
    let after = dump(&tree);
    assert_ne!(before, after, "{name}: degrading changed nothing");
    let mr = max_range.map_or(-1.0, |m| m);
    let script = format!(
        "tree {res:.17e}\ninsert {} maxrange {mr:.17e} stamps {start} 1\nclock {last}\ndegrade 1\n",
        ff.display()
    );
    let (rdump, rot) = reference(&refprog, &script, &dir).expect("no delete here");
    assert!(
        after == rdump,
        "{name}: nodes differ: {}",
        first_line_diff(&after, &rdump)
    );
    let ot = stamped_ot(&tree);
    assert!(ot == rot, "{name}: .ot differs: {}", first_diff(&ot, &rot));
    // several stamps in the tree, and equal-valued leaves kept apart by them
    let distinct: std::collections::HashSet<u32> =
        tree.nodes_with_stamps().iter().map(|n| n.3).collect();
    assert!(
        distinct.len() >= frames.len().min(3),
        "{name}: stamps {distinct:?}"
    );
    let mut plain = tree.occupancy().clone();
    plain.prune();
    assert!(
        plain.size() < tree.size(),
        "{name}: no octant was kept apart by its stamps"
    );
}

#[test]
fn real_lidar_scans_match_octomap() {
    let Some(dir_in) = common::data_file("lidar3d/norlab_icp_mapper_example") else {
        return;
    };
    let frames = read_frames(&dir_in, &ReadOptions::default()).unwrap();
    // 4 frames, every 16th point, 30 m rays: OctoMap's time stays reasonable
    let frames: Vec<Frame> = frames
        .into_iter()
        .take(4)
        .map(|f| Frame {
            points: f.points.into_iter().step_by(16).collect(),
            ..f
        })
        .collect();
    check_real_frames("norlab", &frames, 0.2, Some(30.0));
}

#[test]
fn real_depth_images_match_octomap() {
    let Some(assoc) = common::data_file("rgbd/tum_fr2_pioneer_slam2_subset/my_association.txt")
    else {
        return;
    };
    let opts = ReadOptions {
        tum: octoquant::formats::TumOptions {
            pixel_step: 8,
            ..Default::default()
        },
        ..ReadOptions::default()
    };
    let frames = read_frames(&assoc, &opts).unwrap();
    let frames: Vec<Frame> = frames.into_iter().take(4).collect();
    check_real_frames("tum", &frames, 0.05, None);
}

/// `map --stamped --degrade-older-than 1` on the TUM RGB-D frames (stamped with their own
/// times, 1-2 s apart, degraded after each): `StampedMapper` and the CLI give the nodes,
/// stamps and `.ot` bytes of liboctomap's `OcTreeStamped` with its clock set to each frame's
/// second, inserting and degrading frame by frame.
#[test]
fn stamped_cli_map_with_frame_times_matches_octomap() {
    use octoquant::stamped_map::StampedMapper;
    let Some(assoc) = common::data_file("rgbd/tum_fr2_pioneer_slam2_subset/my_association.txt")
    else {
        return;
    };
    let Some(refprog) = common::reference_program() else {
        return;
    };
    let dir = common::scratch("stamped_cli_tum");
    let mut options = ReadOptions::default();
    options.tum.pixel_step = 4;
    let frames = read_frames(&assoc, &options).unwrap();
    let mut mapper = StampedMapper::new(
        octoquant::MapperOptions {
            resolution: 0.1,
            ..octoquant::MapperOptions::default()
        },
        Some(1),
    )
    .unwrap();
    let mut script = format!("tree {:.17e}\n", 0.1);
    for (i, f) in frames.iter().enumerate() {
        mapper.insert(f).unwrap();
        let ff = dir.join(format!("f{i}.frames"));
        octoquant::formats::frames::write_frames_file(&ff, std::slice::from_ref(f)).unwrap();
        let t = f.stamp.unwrap().floor() as u32;
        writeln!(script, "clock {t}\ninsert {}\ndegrade 1", ff.display()).unwrap();
    }
    let tree = mapper.into_tree();
    let ours = stamped_ot(&tree);
    let (rdump, rot) = reference(&refprog, &script, &dir).expect("no delete here");
    assert!(
        dump(&tree) == rdump,
        "nodes differ: {}",
        first_line_diff(&dump(&tree), &rdump)
    );
    assert!(ours == rot, ".ot differs: {}", first_diff(&ours, &rot));
    assert_eq!(tree.last_update_time(), 1_311_877_824);

    // `octoquant map ARGS`, which must succeed, then the map it wrote to OUT
    let map = |args: &[&str], out: &str| {
        let o = Command::new(env!("CARGO_BIN_EXE_octoquant"))
            .current_dir(&dir)
            .arg("map")
            .args(args)
            .args(["-q", "-o", out])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        std::fs::read(dir.join(out)).unwrap()
    };
    let tum = [assoc.to_str().unwrap(), "--pixel-step", "4", "--res", "0.1"];
    let degrade = ["--stamped", "--degrade-older-than", "1"];
    let cli = map(&[&tum[..], &degrade].concat(), "cli.ot");
    assert!(cli == ours, "{}", first_diff(&cli, &ours));
    // the frames saved as one .frames file keep their stamps: the same map from it
    octoquant::formats::frames::write_frames_file(&dir.join("all.frames"), &frames).unwrap();
    let saved = map(
        &[&["all.frames", "--res", "0.1"][..], &degrade].concat(),
        "frames.ot",
    );
    assert!(saved == ours, "{}", first_diff(&saved, &ours));
    // the stamps matter: without degrading the map differs
    assert!(map(&[&tum[..], &["--stamped"]].concat(), "plain.ot") != cli);
    // the summary's bytes per node count the stamps: four bytes at least for each node (every
    // node of the tree is stamped) beyond the nodes' own storage
    let o = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .current_dir(&dir)
        .arg("map")
        .args([&tum[..], &degrade].concat())
        .args(["--json", "-o", "json.ot"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let summary: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(summary["nodes"].as_u64(), Some(tree.size() as u64));
    let held = summary["bytes_per_node"].as_f64().unwrap() * tree.size() as f64;
    let least = tree.occupancy().memory_usage() + 4 * tree.size();
    assert!(held >= least as f64, "{held} bytes, at least {least}");
    let out = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .current_dir(&dir)
        .args(["map", assoc.to_str().unwrap(), "--stamped", "-o", "s.bt"])
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && e.contains("OcTreeStamped"), "{e}");
}
