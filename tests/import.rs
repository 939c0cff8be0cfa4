//! `octoquant import` against OctoMap's own `binvox2bt` (Debian octomap-tools): binvox grids
//! made from a real map's occupied voxels (written here with the project's binvox writer),
//! converted by both, must give byte-identical .bt files for every option binvox2bt has.

use crate::common::{self, first_diff, scratch};
use octoquant::formats::binvox::write_binvox;
use octoquant::treefile::read_tree_file;
use std::path::{Path, PathBuf};
use std::process::Command;

/// A binvox grid of a real map's occupied voxels inside `[lo, hi)` (keys), one cell per
/// voxel, placed at the map's voxel corners. Returns the file and the number of voxel cells.
fn grid_from_map(map: &Path, lo: [u16; 3], hi: [u16; 3], out: &Path) -> (PathBuf, usize) {
    let tree = read_tree_file(map).unwrap();
    let res = tree.resolution();
    // binvox order: dim D H W with x slowest (D), then z (H), then y (W, fastest)
    let size = [0, 1, 2].map(|a| usize::from(hi[a] - lo[a]));
    let (d, w, h) = (size[0], size[1], size[2]);
    let mut cells = vec![0u8; d * h * w];
    let mut voxels = 0;
    for leaf in tree.leaves() {
        if !tree.params().is_occupied(leaf.value) {
            continue;
        }
        let min = leaf.min_key();
        let n = leaf.width() as usize;
        for i in 0..n * n * n {
            let k = [i % n, (i / n) % n, i / (n * n)];
            let key = [0, 1, 2].map(|a| usize::from(min[a]) + k[a]);
            if (0..3).any(|a| key[a] < usize::from(lo[a]) || key[a] >= usize::from(hi[a])) {
                continue;
            }
            let [x, y, z] = [0, 1, 2].map(|a| key[a] - usize::from(lo[a]));
            cells[x * w * h + z * w + y] = 1;
            voxels += 1;
        }
    }
    let corner = tree
        .converter()
        .key_to_point(&octoquant::Key(lo))
        .map(|c| (c - res / 2.0) as f32);
    let side = d.max(h).max(w);
    let bytes = write_binvox(
        [d, h, w],
        [corner.x, corner.y, corner.z],
        (res * side as f64) as f32,
        &cells,
    );
    std::fs::write(out, bytes).unwrap();
    (out.to_path_buf(), voxels)
}

fn binvox2bt(args: &[&str], inputs: &[&Path], out: &Path) -> Vec<u8> {
    let st = Command::new("binvox2bt")
        .args(args)
        .arg("-o")
        .arg(out)
        .args(inputs)
        .output()
        .expect("binvox2bt (apt-get install octomap-tools)");
    assert!(st.status.success(), "{st:?}");
    std::fs::read(out)
        .unwrap_or_else(|e| panic!("binvox2bt wrote no {}: {e}: {st:?}", out.display()))
}

fn octoquant_import(args: &[&str], inputs: &[&Path], out: &Path) -> (Vec<u8>, serde_json::Value) {
    let st = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .arg("import")
        .args(inputs)
        .args(args)
        .arg("-o")
        .arg(out)
        .arg("--json")
        .output()
        .unwrap();
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    (
        std::fs::read(out).unwrap(),
        serde_json::from_slice(&st.stdout).unwrap(),
    )
}

#[test]
fn import_is_byte_identical_to_binvox2bt() {
    let Some(map) = common::data_file("octomap_reference/expected/scan_r02_clamp.bt") else {
        return;
    };
    let dir = scratch("binvox2bt");
    let tree = read_tree_file(&map).unwrap();
    let conv = tree.converter().clone();
    let key = |p: [f64; 3]| {
        conv.point_to_key(&nalgebra::Point3::new(p[0], p[1], p[2]))
            .unwrap()
            .0
    };
    // two boxes of the real scan: a wide one and a small one beside it
    let (a, voxels_a) = grid_from_map(
        &map,
        key([-10.0, -10.0, -2.0]),
        key([10.0, 6.0, 3.0]),
        &dir.join("a.binvox"),
    );
    let (b, _) = grid_from_map(
        &map,
        key([10.0, -4.0, -2.0]),
        key([14.0, 0.0, 2.0]),
        &dir.join("b.binvox"),
    );
    assert!(voxels_a > 1000, "{voxels_a} voxels");
    let cases: Vec<(&str, Vec<&str>, Vec<&Path>)> = vec![
        ("plain", vec![], vec![&a]),
        ("mark-free", vec!["--mark-free"], vec![&a]),
        ("rotate", vec!["--rotate"], vec![&a]),
        (
            "bb",
            vec!["--bb", "-5", "-3.5", "-1", "4.2", "2", "1.5"],
            vec![&a],
        ),
        (
            "offset + mark-free + bb",
            vec![
                "--mark-free",
                "--offset",
                "0.37",
                "-1.2",
                "0.05",
                "--bb",
                "-6",
                "-6",
                "-2",
                "6",
                "6",
                "2",
            ],
            vec![&a],
        ),
        ("two files", vec!["--mark-free"], vec![&a, &b]),
    ];
    for (what, args, inputs) in cases {
        let theirs = binvox2bt(&args, &inputs, &dir.join("theirs.bt"));
        let (ours, summary) = octoquant_import(&args, &inputs, &dir.join("ours.bt"));
        assert!(
            ours == theirs,
            "{what}: {} ({summary})",
            first_diff(&ours, &theirs)
        );
        let leaves = summary["leaves"].as_u64().unwrap();
        assert!(leaves > 100, "{what}: {summary}");
        if what == "plain" {
            // every voxel cell came back as an occupied voxel, nothing else is known
            let back = read_tree_file(&dir.join("ours.bt")).unwrap();
            let occupied: usize = back
                .leaves()
                .filter(|l| back.params().is_occupied(l.value))
                .map(|l| (l.width() as usize).pow(3))
                .sum();
            assert_eq!(occupied, voxels_a, "{summary}");
            assert_eq!(summary["inputs"][0]["hits"].as_u64(), Some(voxels_a as u64));
        }
    }
}

#[test]
fn hostile_binvox_files_are_refused_without_output() {
    let dir = scratch("binvox_hostile");
    let out = dir.join("out.bt");
    for (name, data) in [
        (
            "short.binvox",
            b"#binvox 1\ndim 4 4 4\ntranslate 0 0 0\nscale 1\ndata\n\x01\x10".to_vec(),
        ),
        (
            "long.binvox",
            b"#binvox 1\ndim 2 2 2\ntranslate 0 0 0\nscale 1\ndata\n\x01\xff".to_vec(),
        ),
        (
            "zero-scale.binvox",
            b"#binvox 1\ndim 2 2 2\ntranslate 0 0 0\nscale 0\ndata\n\x01\x08".to_vec(),
        ),
        (
            "huge.binvox",
            b"#binvox 1\ndim 99999999999 99999999999 9 translate 0 0 0 scale 1 data\n\x01\xff"
                .to_vec(),
        ),
    ] {
        let input = dir.join(name);
        std::fs::write(&input, data).unwrap();
        let st = Command::new(env!("CARGO_BIN_EXE_octoquant"))
            .arg("import")
            .arg(&input)
            .arg("-o")
            .arg(&out)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&st.stderr);
        assert!(!st.status.success(), "{name}: {err}");
        assert!(err.contains(name), "{name}: {err}");
        assert!(!err.contains("panicked"), "{name}: {err}");
        assert!(!out.exists(), "{name}");
    }
}

/// An offset that moves every voxel out of the map's addressable cube is refused, naming
/// `--offset`, with no output (binvox2bt writes an empty map there).
#[test]
fn an_offset_that_leaves_no_voxel_in_the_map_is_refused() {
    let Some(map) = common::data_file("octomap_reference/expected/scan_r02_clamp.bt") else {
        return;
    };
    let dir = scratch("binvox_far_offset");
    let tree = read_tree_file(&map).unwrap();
    let key = |p: [f64; 3]| {
        tree.converter()
            .point_to_key(&nalgebra::Point3::new(p[0], p[1], p[2]))
            .unwrap()
            .0
    };
    let (grid, voxels) = grid_from_map(
        &map,
        key([-4.0, -4.0, -1.0]),
        key([4.0, 4.0, 1.0]),
        &dir.join("g.binvox"),
    );
    assert!(voxels > 100, "{voxels} voxels");
    let out = dir.join("out.bt");
    let run = |offset: &str| {
        Command::new(env!("CARGO_BIN_EXE_octoquant"))
            .arg("import")
            .arg(&grid)
            .args(["--offset", offset, "0", "0", "-o"])
            .arg(&out)
            .output()
            .unwrap()
    };
    let st = run("1e7");
    let err = String::from_utf8_lossy(&st.stderr);
    assert_eq!(st.status.code(), Some(1), "{err}");
    assert!(
        err.contains("--offset") && err.contains(&format!("({voxels})")),
        "{err}"
    );
    assert!(!out.exists());
    // an offset that keeps the voxels inside is imported
    let st = run("3");
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    assert!(out.exists());
}
