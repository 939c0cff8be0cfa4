//! The octree against the real OctoMap: random update sequences applied to both must give
//! byte-identical `.ot` and `.bt` files, and OctoMap's own files must read and rewrite
//! identically.

use crate::common::{self, first_diff};
use octoquant::octree::io::{read_bt, read_ot, read_tree, write_bt, write_bt_const, write_ot};
use octoquant::octree::{InnerNodes, Key, OcTree, OccupancyParams, Update};
use proptest::prelude::*;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

/// One operation applied to both trees.
#[derive(Debug, Clone)]
enum Op {
    Update {
        key: Key,
        hit: bool,
        repeat: u8,
        lazy: bool,
    },
    Delta {
        key: Key,
        bits: u32,
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
    Prune,
    Expand,
    MaxLikelihood,
    Inner,
    /// One call on one node in hand (expand, prune, create or delete a child, integrate a
    /// hit or a miss, update its log-odds, set it to its max likelihood).
    Surgery(common::Surgery),
}

#[derive(Debug, Clone)]
struct Case {
    res: f64,
    params: Option<[f64; 5]>,
    ops: Vec<Op>,
}

fn key_strategy(base: Key) -> impl Strategy<Value = Key> {
    prop_oneof![
        // clustered: a 4x4x4 neighbourhood, so octants fill up and prune
        (0u16..4, 0u16..4, 0u16..4).prop_map(move |(x, y, z)| Key::new(
            base.x().wrapping_add(x),
            base.y().wrapping_add(y),
            base.z().wrapping_add(z)
        )),
        // a little wider: 16^3 around the base
        (0u16..16, 0u16..16, 0u16..16).prop_map(move |(x, y, z)| Key::new(
            base.x().wrapping_add(x),
            base.y().wrapping_add(y),
            base.z().wrapping_add(z)
        )),
        // spread over the whole key space, including the extremes
        any::<[u16; 3]>().prop_map(Key),
    ]
}

fn op_strategy(base: Key) -> impl Strategy<Value = Op> {
    let k = || key_strategy(base);
    prop_oneof![
        30 => (k(), any::<bool>(), 1u8..14, prop::bool::weighted(0.2))
            .prop_map(|(key, hit, repeat, lazy)| Op::Update { key, hit, repeat, lazy }),
        4 => (k(), -3.0f32..3.0, prop::bool::weighted(0.2))
            .prop_map(|(key, d, lazy)| Op::Delta { key, bits: d.to_bits(), lazy }),
        3 => (k(), -4.0f32..4.0, prop::bool::weighted(0.2))
            .prop_map(|(key, v, lazy)| Op::Set { key, bits: v.to_bits(), lazy }),
        2 => k().prop_map(|key| Op::Delete { key }),
        1 => Just(Op::Prune),
        1 => Just(Op::Expand),
        1 => Just(Op::MaxLikelihood),
        1 => Just(Op::Inner),
        6 => common::surgery_strategy(k()).prop_map(Op::Surgery),
    ]
}

fn case_strategy() -> impl Strategy<Value = Case> {
    let res = prop_oneof![
        Just(0.1),
        Just(0.05),
        Just(0.2),
        Just(0.01f32 as f64),
        Just(0.123456789),
        Just(1e-5),
        Just(2.5),
    ];
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
    (res, params, base).prop_flat_map(|(res, params, base)| {
        prop::collection::vec(op_strategy(base), 1..160).prop_map(move |mut ops| {
            // Deleting a tree's last voxel leaves a childless root; the next update then
            // expands it into coarse leaves (OctoMap does the same), which a later `expand()`
            // would blow up into billions of nodes. Keep the two apart.
            if ops.iter().any(|o| matches!(o, Op::Delete { .. })) {
                ops.retain(|o| !matches!(o, Op::Expand));
            }
            Case { res, params, ops }
        })
    })
}

/// A Rust tree with the case's resolution and sensor model, after all its operations.
fn apply_case(case: &Case) -> OcTree {
    let mut tree = OcTree::new(case.res).unwrap();
    if let Some([h, m, lo, hi, t]) = case.params {
        tree.set_params(OccupancyParams::from_probabilities(h, m, lo, hi, t).unwrap());
    }
    apply_ops(&mut tree, &case.ops);
    tree
}

fn apply_ops(tree: &mut OcTree, ops: &[Op]) {
    for op in ops {
        match *op {
            Op::Update {
                key,
                hit,
                repeat,
                lazy,
            } => {
                let u = if hit { Update::Hit } else { Update::Miss };
                for _ in 0..repeat {
                    tree.update_node(key, u, InnerNodes::from_lazy(lazy));
                }
            }
            Op::Delta { key, bits, lazy } => {
                tree.update_node(
                    key,
                    Update::LogOdds(f32::from_bits(bits)),
                    InnerNodes::from_lazy(lazy),
                );
            }
            Op::Set { key, bits, lazy } => {
                tree.set_node_value(key, f32::from_bits(bits), InnerNodes::from_lazy(lazy))
                    .unwrap();
            }
            Op::Delete { key } => {
                tree.delete_node(key, 16);
            }
            Op::Prune => tree.prune(),
            Op::Expand => tree.expand(),
            Op::MaxLikelihood => tree.to_max_likelihood(),
            Op::Inner => tree.update_inner_occupancy(),
            Op::Surgery(ref c) => c.apply(tree, 0),
        }
    }
}

/// Apply `case` to a Rust tree and write the three files; returns their bytes.
fn run_rust(case: &Case) -> (Vec<u8>, Vec<u8>, Vec<u8>) {
    let mut tree = apply_case(case);
    let mut ot = Vec::new();
    write_ot(&tree, &mut ot).unwrap();
    let mut btc = Vec::new();
    write_bt_const(&tree, &mut btc).unwrap();
    let mut bt = Vec::new();
    write_bt(&mut tree, &mut bt).unwrap();
    (ot, btc, bt)
}

fn script_for(case: &Case, dir: &Path) -> String {
    let mut s = String::new();
    writeln!(s, "tree {:.17e}", case.res).unwrap();
    if let Some([h, m, lo, hi, t]) = case.params {
        writeln!(s, "params {h:.17e} {m:.17e} {lo:.17e} {hi:.17e} {t:.17e}").unwrap();
    }
    for op in &case.ops {
        match *op {
            Op::Update {
                key,
                hit,
                repeat,
                lazy,
            } => {
                for _ in 0..repeat {
                    let c = if hit { "hit" } else { "miss" };
                    writeln!(s, "{c} {} {} {} {}", key.x(), key.y(), key.z(), lazy as u8).unwrap();
                }
            }
            Op::Delta { key, bits, lazy } => writeln!(
                s,
                "update {} {} {} {bits:08x} {}",
                key.x(),
                key.y(),
                key.z(),
                lazy as u8
            )
            .unwrap(),
            Op::Set { key, bits, lazy } => writeln!(
                s,
                "set {} {} {} {bits:08x} {}",
                key.x(),
                key.y(),
                key.z(),
                lazy as u8
            )
            .unwrap(),
            Op::Delete { key } => {
                writeln!(s, "delete {} {} {} 16", key.x(), key.y(), key.z()).unwrap()
            }
            Op::Prune => s.push_str("prune\n"),
            Op::Expand => s.push_str("expand\n"),
            Op::MaxLikelihood => s.push_str("ml\n"),
            Op::Inner => s.push_str("inner\n"),
            Op::Surgery(ref c) => s.push_str(&c.line()),
        }
    }
    let p = |n: &str| dir.join(n).display().to_string();
    writeln!(s, "write_ot {}", p("ref.ot")).unwrap();
    writeln!(s, "write_bt_const {}", p("ref_const.bt")).unwrap();
    writeln!(s, "write_bt {}", p("ref.bt")).unwrap();
    s
}

/// OctoMap 1.9.7 aborts on this assertion when a node emptied by `deleteNode` is later
/// destroyed (its empty child array is never freed); such cases have no reference answer.
const OCTOMAP_DELETE_ABORT: &str = "Assertion `children == NULL' failed";

/// Run a script with the reference program; `None` when OctoMap hit its known delete abort.
fn try_reference(refprog: &Path, script: &str, dir: &Path) -> Option<(Vec<u8>, Vec<u8>, Vec<u8>)> {
    let sp = dir.join("ops.txt");
    std::fs::write(&sp, script).unwrap();
    let out = Command::new(refprog)
        .arg("script")
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
    let rd = |n: &str| std::fs::read(dir.join(n)).unwrap();
    Some((rd("ref.ot"), rd("ref_const.bt"), rd("ref.bt")))
}

fn run_reference(refprog: &Path, script: &str, dir: &Path) -> (Vec<u8>, Vec<u8>, Vec<u8>) {
    try_reference(refprog, script, dir).expect("the reference program aborted")
}

#[test]
fn random_update_sequences_match_octomap() {
    let Some(refprog) = common::reference_program() else {
        return;
    };
    let dir = common::scratch("octree_diff_random");
    let compared = std::cell::Cell::new(0usize);
    let aborted = std::cell::Cell::new(0usize);
    let mut runner = proptest::test_runner::TestRunner::new(ProptestConfig {
        cases: 160,
        failure_persistence: None,
        ..ProptestConfig::default()
    });
    runner
        .run(&case_strategy(), |case| {
            let (ot, btc, bt) = run_rust(&case);
            let reference = try_reference(&refprog, &script_for(&case, &dir), &dir);
            let Some((rot, rbtc, rbt)) = reference else {
                aborted.set(aborted.get() + 1);
                return Ok(());
            };
            compared.set(compared.get() + 1);
            prop_assert!(ot == rot, ".ot differs: {}", first_diff(&ot, &rot));
            prop_assert!(
                btc == rbtc,
                "const .bt differs: {}",
                first_diff(&btc, &rbtc)
            );
            prop_assert!(bt == rbt, ".bt differs: {}", first_diff(&bt, &rbt));
            Ok(())
        })
        .unwrap();
    // OctoMap's delete abort must stay rare, or this test would compare too little
    assert!(
        compared.get() >= 4 * aborted.get() && compared.get() >= 100,
        "compared {} cases, reference aborted on {}",
        compared.get(),
        aborted.get()
    );
}

/// A long deterministic sequence that saturates both clamps over a dense block, so pruning
/// happens at several depths, with lazy phases and the standalone passes in between.
#[test]
fn dense_saturating_block_matches_octomap() {
    let Some(refprog) = common::reference_program() else {
        return;
    };
    let dir = common::scratch("octree_diff_dense");
    let mut ops = Vec::new();
    let base = 32760u16;
    for round in 0..8u16 {
        for x in 0..16u16 {
            for y in 0..16u16 {
                for z in 0..4u16 {
                    let key = Key::new(base + x, base + y, base + z + 4 * (round % 2));
                    let hit = (x / 4 + y / 4 + round) % 3 != 0;
                    ops.push(Op::Update {
                        key,
                        hit,
                        repeat: 1,
                        lazy: round == 3,
                    });
                }
            }
        }
        match round {
            3 => ops.push(Op::Inner),
            5 => ops.push(Op::Prune),
            6 => ops.push(Op::Expand),
            _ => {}
        }
    }
    let case = Case {
        res: 0.1,
        params: None,
        ops,
    };
    let (ot, btc, bt) = run_rust(&case);
    let (rot, rbtc, rbt) = run_reference(&refprog, &script_for(&case, &dir), &dir);
    assert!(ot == rot, ".ot differs: {}", first_diff(&ot, &rot));
    assert!(
        btc == rbtc,
        "const .bt differs: {}",
        first_diff(&btc, &rbtc)
    );
    assert!(bt == rbt, ".bt differs: {}", first_diff(&bt, &rbt));
    assert!(
        ot.len() > 2_000,
        "the case should build a sizeable tree, got {} bytes",
        ot.len()
    );
}

fn geb079_paths() -> Vec<PathBuf> {
    let mut v = Vec::new();
    if let Some(p) = common::data_file("octomap_reference/geb079.bt") {
        v.push(p);
    }
    let debian = PathBuf::from("/usr/share/doc/liboctomap-dev/examples/data/geb079.bt");
    if debian.is_file() {
        v.push(debian);
    }
    v
}

#[test]
fn geb079_reads_and_rewrites_identically() {
    let paths = geb079_paths();
    if paths.is_empty() {
        return;
    }
    for p in paths {
        let bytes = std::fs::read(&p).unwrap();
        let mut tree = read_bt(&bytes[..]).unwrap();
        let c = tree.counts();
        // figures from OctoMap's own reading of the file (shared/data PROVENANCE)
        assert_eq!(c.nodes, 532_566);
        assert_eq!(c.inner, 104_422);
        assert_eq!(c.occupied_leaves, 143_729);
        assert_eq!(c.free_leaves, 284_415);
        assert_eq!(tree.resolution(), 0.08);
        assert_eq!(tree.root_value(), Some(tree.params().clamp_max));
        octoquant::octree::validate::assert_well_formed(&tree, InnerNodes::Defer);
        let mut out = Vec::new();
        write_bt(&mut tree, &mut out).unwrap();
        assert!(
            out == bytes,
            "{}: {}",
            p.display(),
            first_diff(&out, &bytes)
        );
        let per_node = tree.memory_usage() as f64 / tree.size() as f64;
        assert!(per_node <= 10.0, "{per_node} bytes per node on geb079");
    }
}

#[test]
fn geb079_ot_matches_octomap_conversion() {
    let Some(refprog) = common::reference_program() else {
        return;
    };
    let Some(p) = geb079_paths().into_iter().next() else {
        return;
    };
    let dir = common::scratch("octree_diff_geb_ot");
    let script = format!(
        "read_bt {}\nwrite_ot {}\n",
        p.display(),
        dir.join("ref.ot").display()
    );
    let sp = dir.join("s.txt");
    std::fs::write(&sp, script).unwrap();
    let st = Command::new(&refprog)
        .arg("script")
        .arg(&sp)
        .output()
        .unwrap();
    assert!(st.status.success());
    let reference = std::fs::read(dir.join("ref.ot")).unwrap();
    let tree = read_bt(&std::fs::read(&p).unwrap()[..]).unwrap();
    let mut ot = Vec::new();
    write_ot(&tree, &mut ot).unwrap();
    assert!(ot == reference, "{}", first_diff(&ot, &reference));
    // and the .ot reads back to the same tree
    let back = read_ot(&ot[..]).unwrap();
    let mut again = Vec::new();
    write_ot(&back, &mut again).unwrap();
    assert!(again == ot);
}

#[test]
fn expected_reference_files_rewrite_identically() {
    let Some(dir) = common::data_file("octomap_reference/expected") else {
        return;
    };
    let mut seen = 0;
    for e in std::fs::read_dir(&dir).unwrap() {
        let p = e.unwrap().path();
        let ext = p.extension().and_then(|e| e.to_str()).unwrap_or("");
        if ext != "bt" && ext != "ot" {
            continue;
        }
        let bytes = std::fs::read(&p).unwrap();
        let mut tree = read_tree(&bytes[..]).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
        let mut out = Vec::new();
        if ext == "bt" {
            write_bt(&mut tree, &mut out).unwrap();
        } else {
            write_ot(&tree, &mut out).unwrap();
        }
        assert!(
            out == bytes,
            "{}: {}",
            p.display(),
            first_diff(&out, &bytes)
        );
        seen += 1;
    }
    assert!(
        seen >= 18,
        "expected at least 18 .bt/.ot files, found {seen}"
    );
}

#[test]
fn keys_match_octomap_on_boundaries_and_random_coordinates() {
    let Some(refprog) = common::reference_program() else {
        return;
    };
    let dir = common::scratch("octree_diff_keys");
    let mut rng = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        rng
    };
    for res in [0.1, 0.05, 0.2, 0.01f32 as f64, 0.08, 0.3333] {
        let mut coords = Vec::new();
        for k in -40000i64..40000 {
            let c = k as f64 * res;
            coords.push(c);
            coords.push((k as f32 * res as f32) as f64);
            coords.push(c + 1e-12);
            coords.push(c - 1e-12);
        }
        for _ in 0..200_000 {
            let r = next();
            let mag = [1.0, 10.0, 1000.0, 5000.0][(r % 4) as usize];
            let c = ((r >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0) * mag;
            coords.push(c);
            coords.push(c as f32 as f64);
        }
        coords.extend([f64::NAN, f64::INFINITY, -f64::INFINITY, 1e300, -1e300, -0.0]);
        let mut input = (coords.len() as u32).to_le_bytes().to_vec();
        for c in &coords {
            input.extend_from_slice(&c.to_le_bytes());
        }
        let inp = dir.join("in.bin");
        let outp = dir.join("out.bin");
        std::fs::write(&inp, &input).unwrap();
        let st = Command::new(&refprog)
            .args(["keys", &format!("{res:.17e}")])
            .arg(&inp)
            .arg(&outp)
            .output()
            .unwrap();
        assert!(st.status.success());
        let out = std::fs::read(&outp).unwrap();
        assert_eq!(out.len(), coords.len() * 13);
        let conv = octoquant::KeyConverter::new(res).unwrap();
        for (i, c) in coords.iter().enumerate() {
            let r = &out[i * 13..(i + 1) * 13];
            let ok = r[0] == 1;
            let checked = u16::from_le_bytes([r[1], r[2]]);
            let unchecked = u16::from_le_bytes([r[3], r[4]]);
            let centre = f64::from_le_bytes(r[5..13].try_into().unwrap());
            assert_eq!(
                conv.coord_to_key_checked(*c),
                ok.then_some(checked),
                "checked key of {c:e} at res {res}"
            );
            assert_eq!(
                conv.coord_to_key_unchecked(*c),
                unchecked,
                "unchecked key of {c:e}"
            );
            assert_eq!(conv.key_to_coord(unchecked).to_bits(), centre.to_bits());
        }
    }
}

/// Change detection records the same keys as OctoMap's `changed_keys` after random updates.
#[test]
fn change_detection_matches_octomap() {
    let Some(refprog) = common::reference_program() else {
        return;
    };
    let dir = common::scratch("octree_diff_changes");
    let mut runner = proptest::test_runner::TestRunner::new(ProptestConfig {
        cases: 60,
        failure_persistence: None,
        ..ProptestConfig::default()
    });
    runner
        .run(&case_strategy(), |case| {
            let mut tree = OcTree::new(case.res).unwrap();
            if let Some([h, m, lo, hi, t]) = case.params {
                tree.set_params(OccupancyParams::from_probabilities(h, m, lo, hi, t).unwrap());
            }
            tree.enable_change_detection(true);
            let mut script = String::from("changes_on\n");
            // the same operations as `script_for`, without the trailing writes
            let full = script_for(&case, &dir);
            let ops_part: Vec<&str> = full.lines().filter(|l| !l.starts_with("write_")).collect();
            // `tree`/`params` must come first: insert changes_on after them
            let (head, tail): (Vec<&str>, Vec<&str>) = ops_part
                .iter()
                .partition(|l| l.starts_with("tree ") || l.starts_with("params "));
            let mut s = head.join("\n");
            s.push('\n');
            s.push_str(&script);
            s.push_str(&tail.join("\n"));
            s.push_str("\nprint_changes\n");
            script = s;
            apply_ops(&mut tree, &case.ops);
            let mine: String = tree
                .changed_keys()
                .map(|(k, new)| format!("change {} {} {} {}\n", k.x(), k.y(), k.z(), new as u8))
                .collect();
            let sp = dir.join("changes.txt");
            std::fs::write(&sp, &script).unwrap();
            let out = Command::new(&refprog)
                .arg("script")
                .arg(&sp)
                .output()
                .unwrap();
            if !out.status.success()
                && String::from_utf8_lossy(&out.stderr).contains(OCTOMAP_DELETE_ABORT)
            {
                return Ok(()); // no reference answer (see OCTOMAP_DELETE_ABORT)
            }
            prop_assert!(out.status.success());
            let theirs = String::from_utf8(out.stdout).unwrap();
            prop_assert_eq!(tree.num_changes_detected(), theirs.lines().count());
            prop_assert_eq!(mine, theirs);
            Ok(())
        })
        .unwrap();
}

/// The script lines of a case's operations (no writes), with change detection switched on
/// after `tree`/`params`.
fn change_script(case: &Case, dir: &Path) -> String {
    let full = script_for(case, dir);
    let ops: Vec<&str> = full.lines().filter(|l| !l.starts_with("write_")).collect();
    let (head, tail): (Vec<&str>, Vec<&str>) = ops
        .iter()
        .partition(|l| l.starts_with("tree ") || l.starts_with("params "));
    format!("{}\nchanges_on\n{}\n", head.join("\n"), tail.join("\n"))
}

/// `print_changes_ordered` lines of a tree's changes in OctoMap's iteration order.
fn ordered_changes(tree: &OcTree) -> String {
    tree.changed_keys_octomap_order()
        .map(|(k, new)| format!("change {} {} {} {}\n", k.x(), k.y(), k.z(), new as u8))
        .collect()
}

/// Run a script; `None` when OctoMap hit its known delete abort.
fn reference_stdout(refprog: &Path, script: &str, path: &Path) -> Option<String> {
    std::fs::write(path, script).unwrap();
    let out = Command::new(refprog)
        .arg("script")
        .arg(path)
        .output()
        .unwrap();
    if !out.status.success() && String::from_utf8_lossy(&out.stderr).contains(OCTOMAP_DELETE_ABORT)
    {
        return None;
    }
    assert!(
        out.status.success(),
        "reference program failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    Some(String::from_utf8(out.stdout).unwrap())
}

/// The changed keys come out in OctoMap's own iteration order (its hash map's), through
/// growth of the map, erasures of keys that flipped back, and a reset between two rounds of
/// updates (which keeps the map's buckets).
#[test]
fn change_detection_order_matches_octomap() {
    let Some(refprog) = common::reference_program() else {
        return;
    };
    let dir = common::scratch("octree_diff_change_order");
    let mut runner = proptest::test_runner::TestRunner::new(ProptestConfig {
        cases: 60,
        failure_persistence: None,
        ..ProptestConfig::default()
    });
    let nonempty = std::cell::Cell::new(0usize);
    runner
        .run(&case_strategy(), |case| {
            let mut tree = apply_case(&Case {
                ops: Vec::new(),
                ..case.clone()
            });
            tree.enable_change_detection(true);
            apply_ops(&mut tree, &case.ops);
            let first = ordered_changes(&tree);
            tree.reset_change_detection();
            apply_ops(&mut tree, &case.ops);
            apply_ops(&mut tree, &case.ops[..case.ops.len() / 2]);
            let second = ordered_changes(&tree);
            let ops_only = change_script(&case, &dir);
            let again: String = ops_only
                .lines()
                .filter(|l| !l.starts_with("tree ") && !l.starts_with("params "))
                .filter(|l| *l != "changes_on")
                .map(|l| format!("{l}\n"))
                .collect();
            let half: Case = Case {
                ops: case.ops[..case.ops.len() / 2].to_vec(),
                ..case.clone()
            };
            let half_ops: String = change_script(&half, &dir)
                .lines()
                .filter(|l| !l.starts_with("tree ") && !l.starts_with("params "))
                .filter(|l| *l != "changes_on")
                .map(|l| format!("{l}\n"))
                .collect();
            let script = format!(
                "{ops_only}print_changes_ordered\nprint_size\nchanges_reset\n{again}{half_ops}print_changes_ordered\n"
            );
            let Some(theirs) = reference_stdout(&refprog, &script, &dir.join("order.txt")) else {
                return Ok(());
            };
            let mine = format!("{first}size {}\n{second}", tree_size_after_first(&case));
            nonempty.set(nonempty.get() + usize::from(!first.is_empty()));
            prop_assert_eq!(mine, theirs);
            Ok(())
        })
        .unwrap();
    assert!(nonempty.get() > 30);
}

/// The tree's size after one pass of the case's operations.
fn tree_size_after_first(case: &Case) -> usize {
    apply_case(case).size()
}

/// Thousands of changed voxels (the map grows past 7517 buckets), flips back and forth that
/// erase and re-add keys, and resets: the same iteration order as OctoMap's.
#[test]
fn change_detection_order_matches_octomap_at_scale() {
    let Some(refprog) = common::reference_program() else {
        return;
    };
    let dir = common::scratch("octree_diff_change_order_scale");
    let mut tree = OcTree::new(0.1).unwrap();
    tree.enable_change_detection(true);
    let mut script = String::from("tree 0.1\nchanges_on\n");
    let mut mine = String::new();
    let mut x: u64 = 0x2545_f491_4f6c_dd1d;
    for round in 0..3 {
        for i in 0..6000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let key = Key::new(
                32768 + (x % 64) as u16,
                32700 + (x >> 8) as u16 % 90,
                32760 + (x >> 20) as u16 % 12,
            );
            let hit = !(x >> 40).is_multiple_of(3) || i % 5 == round;
            tree.update_node(
                key,
                if hit { Update::Hit } else { Update::Miss },
                InnerNodes::Refresh,
            );
            let c = if hit { "hit" } else { "miss" };
            writeln!(script, "{c} {} {} {} 0", key.x(), key.y(), key.z()).unwrap();
        }
        mine.push_str(&ordered_changes(&tree));
        script.push_str("print_changes_ordered\n");
        if round == 1 {
            tree.reset_change_detection();
            script.push_str("changes_reset\n");
        }
    }
    assert!(tree.num_changes_detected() > 3000);
    let theirs = reference_stdout(&refprog, &script, &dir.join("scale.txt")).unwrap();
    assert_eq!(mine.lines().count(), theirs.lines().count());
    assert!(
        mine == theirs,
        "first difference at line {:?}",
        mine.lines().zip(theirs.lines()).position(|(a, b)| a != b)
    );
}
