//! Map merge against the real OctoMap: `octoquant merge A B -o M.ot -o M.bt` (and
//! `OcTree::merge` on random trees) give the bytes of liboctomap's `updateNode` applied to A,
//! voxel by voxel, with each leaf of B's log-odds (the reference program's `update` command).

use crate::common::{self, first_diff};
use octoquant::formats::{read_frames, ReadOptions};
use octoquant::octree::io::{write_bt, write_ot};
use octoquant::pipeline::{Mapper, MapperOptions};
use octoquant::{InnerNodes, Key, OcTree, Update};
use proptest::prelude::*;
use std::fmt::Write as _;
use std::path::Path;
use std::process::Command;

/// The reference: `base` (a command that loads A, `read_ot PATH` or `read_bt PATH`), then per
/// leaf of `b` in pre-order and per voxel in Morton order, OctoMap's
/// `updateNode(voxel, value, lazy = false)`; returns OctoMap's (.ot, .bt) bytes.
fn reference(dir: &Path, base: &str, b: &OcTree) -> Option<(Vec<u8>, Vec<u8>)> {
    let refprog = common::reference_program()?;
    let mut s = String::with_capacity(1 << 20);
    writeln!(s, "{base}").unwrap();
    for leaf in b.leaves() {
        let first = leaf.min_key().morton();
        let n = 1u64 << (3 * u32::from(16 - leaf.depth));
        let bits = leaf.value.to_bits();
        for c in first..first + n {
            let k = Key::from_morton(c);
            writeln!(s, "update {} {} {} {bits:08x} 0", k[0], k[1], k[2]).unwrap();
        }
    }
    writeln!(s, "write_ot {}", dir.join("ref.ot").display()).unwrap();
    writeln!(s, "write_bt {}", dir.join("ref.bt").display()).unwrap();
    let sp = dir.join("merge.script");
    std::fs::write(&sp, s).unwrap();
    let out = Command::new(refprog)
        .arg("script")
        .arg(&sp)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "reference program failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rd = |n: &str| std::fs::read(dir.join(n)).unwrap();
    Some((rd("ref.ot"), rd("ref.bt")))
}

fn write_files(t: &OcTree, dir: &Path, stem: &str) {
    let (mut ot, mut bt) = (Vec::new(), Vec::new());
    write_ot(t, &mut ot).unwrap();
    write_bt(&mut t.clone(), &mut bt).unwrap();
    std::fs::write(dir.join(format!("{stem}.ot")), ot).unwrap();
    std::fs::write(dir.join(format!("{stem}.bt")), bt).unwrap();
}

/// Merge `ext` files of A and B with the CLI and compare its outputs with OctoMap's.
fn check_cli(dir: &Path, ext: &str) {
    let (a, b) = (dir.join(format!("a.{ext}")), dir.join(format!("b.{ext}")));
    let out = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .arg("merge")
        .args([&a, &b])
        .arg("-o")
        .arg(dir.join("m.ot"))
        .arg("-o")
        .arg(dir.join("m.bt"))
        .arg("--json")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "octoquant merge: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let summary: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    // the B the reference applies: the file as read (a .bt holds the clamping bounds only)
    let b_tree = octoquant::treefile::read_tree_file(&b).unwrap();
    let pruned = b_tree.leaves().filter(|l| l.depth < 16).count();
    assert!(pruned > 0, "B has pruned leaves");
    assert_eq!(summary["pruned_leaves_merged"], pruned);
    assert_eq!(summary["leaves_merged"], b_tree.leaves().count());
    let base = format!("read_{ext} {}", a.display());
    let Some((rot, rbt)) = reference(dir, &base, &b_tree) else {
        return;
    };
    let ot = std::fs::read(dir.join("m.ot")).unwrap();
    let bt = std::fs::read(dir.join("m.bt")).unwrap();
    assert!(ot == rot, "{ext} inputs: .ot {}", first_diff(&ot, &rot));
    assert!(bt == rbt, "{ext} inputs: .bt {}", first_diff(&bt, &rbt));
}

#[test]
fn norlab_halves_merged_match_octomap() {
    let Some(src) = common::data_file("lidar3d/norlab_icp_mapper_example") else {
        return;
    };
    let frames = read_frames(&src, &ReadOptions::default()).unwrap();
    let options = MapperOptions {
        resolution: 0.2,
        max_range: Some(12.0),
        ..MapperOptions::default()
    };
    // the 14 frames, every other point; frames 0-6 and 7-13 mapped separately
    let frames: Vec<_> = frames
        .into_iter()
        .map(|f| octoquant::Frame {
            points: f.points.into_iter().step_by(2).collect(),
            ..f
        })
        .collect();
    let dir = common::scratch("merge_norlab");
    let half = frames.len() / 2;
    for (stem, part) in [("a", &frames[..half]), ("b", &frames[half..])] {
        let mut m = Mapper::new(options.clone()).unwrap();
        m.insert_frames(part);
        write_files(m.tree(), &dir, stem);
    }
    check_cli(&dir, "ot");
    check_cli(&dir, "bt");
}

#[test]
fn tum_halves_merged_match_octomap() {
    let Some(assoc) = common::data_file("rgbd/tum_fr2_pioneer_slam2_subset/my_association.txt")
    else {
        return;
    };
    let frames = read_frames(&assoc, &ReadOptions::default()).unwrap();
    let options = MapperOptions {
        resolution: 0.05,
        max_range: Some(3.0),
        ..MapperOptions::default()
    };
    let frames: Vec<_> = frames
        .into_iter()
        .take(4)
        .map(|f| octoquant::Frame {
            points: f.points.into_iter().step_by(7).collect(),
            ..f
        })
        .collect();
    let dir = common::scratch("merge_tum");
    for (stem, part) in [("a", &frames[..2]), ("b", &frames[2..])] {
        let mut m = Mapper::new(options.clone()).unwrap();
        m.insert_frames(part);
        write_files(m.tree(), &dir, stem);
    }
    check_cli(&dir, "ot");
}

/// A random tree near the map centre: aligned cubes of side 1..8 hit, missed or set, so that
/// some prune; lazy updates (stale inner nodes) included.
fn random_tree(cubes: &[(u16, u16, u16, u8, u8, bool)]) -> OcTree {
    let mut t = OcTree::new(0.1).unwrap();
    for &(x, y, z, k, what, lazy) in cubes {
        let side = 1u16 << k;
        let base = [x, y, z].map(|c| 32752 + (c & !(side - 1)));
        for dx in 0..side {
            for dy in 0..side {
                for dz in 0..side {
                    let key = Key::new(base[0] + dx, base[1] + dy, base[2] + dz);
                    let inner = InnerNodes::from_lazy(lazy);
                    match what {
                        0 => t.update_node(key, Update::Hit, inner),
                        1 => t.update_node(key, Update::Miss, inner),
                        2 => t.set_node_value(key, -1.5, inner).unwrap(),
                        _ => t.set_node_value(key, 2.25, inner).unwrap(),
                    };
                }
            }
        }
    }
    t
}

fn cubes() -> impl Strategy<Value = Vec<(u16, u16, u16, u8, u8, bool)>> {
    prop::collection::vec(
        (
            0u16..24,
            0u16..24,
            0u16..24,
            0u8..4,
            0u8..4,
            prop::bool::weighted(0.2),
        ),
        0..16,
    )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    /// `OcTree::merge` on random trees gives OctoMap's bytes.
    #[test]
    fn random_merges_match_octomap(a_cubes in cubes(), b_cubes in cubes()) {
        let a = random_tree(&a_cubes);
        let b = random_tree(&b_cubes);
        let dir = common::scratch("merge_random");
        write_files(&a, &dir, "a");
        let Some((rot, rbt)) = reference(&dir, &format!("read_ot {}", dir.join("a.ot").display()), &b) else {
            return Ok(());
        };
        let mut m = a.clone();
        m.merge(&b).unwrap();
        let (mut ot, mut bt) = (Vec::new(), Vec::new());
        write_ot(&m, &mut ot).unwrap();
        write_bt(&mut m, &mut bt).unwrap();
        prop_assert!(ot == rot, ".ot {}", first_diff(&ot, &rot));
        prop_assert!(bt == rbt, ".bt {}", first_diff(&bt, &rbt));
    }
}

#[test]
fn a_resolution_mismatch_names_the_file_and_writes_nothing() {
    let dir = common::scratch("merge_mismatch");
    let mut a = OcTree::new(0.1).unwrap();
    a.update_node(Key::new(1, 2, 3), Update::Hit, InnerNodes::Refresh);
    let mut c = OcTree::new(0.2).unwrap();
    c.update_node(Key::new(1, 2, 3), Update::Hit, InnerNodes::Refresh);
    write_files(&a, &dir, "a");
    write_files(&c, &dir, "c");
    let out = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .arg("merge")
        .arg(dir.join("a.ot"))
        .arg(dir.join("c.ot"))
        .arg("-o")
        .arg(dir.join("m.bt"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("c.ot") && err.contains("resolutions differ"),
        "{err}"
    );
    assert!(!dir.join("m.bt").exists());
    // one input is not a merge
    let out = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .arg("merge")
        .arg(dir.join("a.ot"))
        .arg("-o")
        .arg(dir.join("m.bt"))
        .output()
        .unwrap();
    assert!(!out.status.success());
}

/// The same map given twice (by two spellings of its path) is merged, as asked, with a
/// warning on stderr naming both; distinct maps give no warning.
#[test]
fn a_map_given_twice_is_merged_with_a_warning() {
    let dir = common::scratch("merge_twice");
    let mut a = OcTree::new(0.1).unwrap();
    a.update_node(Key::new(1, 2, 3), Update::Hit, InnerNodes::Refresh);
    let mut b = OcTree::new(0.1).unwrap();
    b.update_node(Key::new(4, 5, 6), Update::Miss, InnerNodes::Refresh);
    write_files(&a, &dir, "a");
    write_files(&b, &dir, "b");
    let merge = |inputs: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_octoquant"))
            .current_dir(&dir)
            .arg("merge")
            .args(inputs)
            .args(["-o", "m.ot"])
            .output()
            .unwrap();
        assert!(out.status.success(), "{out:?}");
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let err = merge(&["a.ot", "b.ot", "./a.ot"]);
    assert!(
        err.contains("warning: ./a.ot is the same file as a.ot"),
        "{err}"
    );
    // the evidence was added twice, as asked
    let m = octoquant::treefile::read_tree_file(&dir.join("m.ot")).unwrap();
    let hit = a.params().hit;
    assert_eq!(
        m.search(Key::new(1, 2, 3), 16).map(|n| n.value),
        Some(2.0 * hit)
    );
    assert!(!merge(&["a.ot", "b.ot"]).contains("warning"));
}
