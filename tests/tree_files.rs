//! Hostile and broken tree files, and the `info` / `convert` commands on real maps.

use crate::common;
use octoquant::octree::io::{read_bt, read_ot, read_tree, write_bt, write_ot};
use octoquant::octree::{InnerNodes, OcTree, OctreeError, Update};
use octoquant::treefile::{read_tree_file, write_tree_file, TreeFileError};
use std::process::Command;

fn geb079() -> Option<Vec<u8>> {
    common::data_file("octomap_reference/geb079.bt").map(|p| std::fs::read(p).unwrap())
}

fn small_tree() -> OcTree {
    let mut t = OcTree::new(0.1).unwrap();
    for i in 0..300u16 {
        let k = octoquant::Key::new(32760 + i % 13, 32768 + i % 7, 32768 + i % 5);
        t.update_node(
            k,
            if i % 3 == 0 {
                Update::Miss
            } else {
                Update::Hit
            },
            InnerNodes::Refresh,
        );
    }
    t
}

#[test]
fn every_truncation_of_a_bt_is_an_error_with_an_offset() {
    let Some(bytes) = geb079() else { return };
    let header_len = bytes.windows(5).position(|w| w == b"data\n").unwrap() + 5;
    let mut cuts: Vec<usize> = (0..header_len + 64).collect();
    cuts.extend((header_len..bytes.len()).step_by(997));
    cuts.push(bytes.len() - 1);
    for cut in cuts {
        match read_bt(&bytes[..cut]) {
            Err(OctreeError::Format { offset, .. }) | Err(OctreeError::Io { offset, .. }) => {
                assert!(offset <= cut as u64, "offset {offset} beyond cut {cut}")
            }
            Err(e) => panic!("cut at {cut}: unexpected error kind {e}"),
            Ok(t) => panic!(
                "cut at {cut}: accepted a truncated file ({} nodes)",
                t.size()
            ),
        }
    }
}

#[test]
fn every_truncation_of_an_ot_is_an_error() {
    let mut t = small_tree();
    let mut ot = Vec::new();
    write_ot(&t, &mut ot).unwrap();
    for cut in 0..ot.len() {
        assert!(read_ot(&ot[..cut]).is_err(), "cut at {cut} accepted");
    }
    let mut bt = Vec::new();
    write_bt(&mut t, &mut bt).unwrap();
    for cut in 0..bt.len() {
        assert!(read_bt(&bt[..cut]).is_err(), "cut at {cut} accepted");
    }
}

#[test]
fn corrupted_bytes_never_panic_and_valid_results_are_consistent() {
    let Some(bytes) = geb079() else { return };
    let mut rng = 0x1234_5678_9abc_def0u64;
    let mut next = || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        rng
    };
    let mut errors = 0;
    for _ in 0..300 {
        let mut b = bytes.clone();
        for _ in 0..1 + next() % 4 {
            let i = (next() % b.len() as u64) as usize;
            b[i] = next() as u8;
        }
        match read_bt(&b[..]) {
            Ok(t) => {
                // a flip that keeps the structure valid must give a tree whose count matches
                octoquant::octree::validate::assert_well_formed(&t, InnerNodes::Defer);
            }
            Err(_) => errors += 1,
        }
    }
    assert!(errors > 0, "no corruption was ever detected");
}

#[test]
fn hostile_headers_are_rejected_without_allocation() {
    let cases: Vec<(&str, Vec<u8>)> = vec![
        (
            "absurd size",
            b"# Octomap OcTree binary file\nid OcTree\nsize 4000000000000\nres 0.1\ndata\n\x00\x00"
                .to_vec(),
        ),
        (
            "no data line",
            b"# Octomap OcTree binary file\nid OcTree\nsize 1\nres 0.1\n".to_vec(),
        ),
        (
            "no res",
            b"# Octomap OcTree binary file\nid OcTree\nsize 0\ndata\n".to_vec(),
        ),
        (
            "negative res",
            b"# Octomap OcTree binary file\nid OcTree\nsize 0\nres -1\ndata\n".to_vec(),
        ),
        (
            "nan res",
            b"# Octomap OcTree binary file\nid OcTree\nsize 0\nres nan\ndata\n".to_vec(),
        ),
        (
            "bad size",
            b"# Octomap OcTree binary file\nid OcTree\nsize -5\nres 0.1\ndata\n".to_vec(),
        ),
        (
            "no id",
            b"# Octomap OcTree binary file\nsize 0\nres 0.1\ndata\n".to_vec(),
        ),
        ("huge token", {
            let mut v = b"# Octomap OcTree binary file\n".to_vec();
            v.extend(std::iter::repeat_n(b'x', 100_000));
            v
        }),
        ("not a tree", b"hello world\n".to_vec()),
        ("empty", Vec::new()),
    ];
    for (what, bytes) in cases {
        assert!(read_bt(&bytes[..]).is_err(), "{what} accepted by read_bt");
        assert!(
            read_tree(&bytes[..]).is_err(),
            "{what} accepted by read_tree"
        );
    }
    // endless inner nodes: every record says "all eight children are inner"
    let mut deep = b"# Octomap OcTree binary file\nid OcTree\nsize 99\nres 0.1\ndata\n".to_vec();
    deep.extend(std::iter::repeat_n(0xffu8, 4096));
    match read_bt(&deep[..]) {
        Err(OctreeError::Format { message, .. }) => {
            assert!(message.contains("deeper"), "{message}")
        }
        other => panic!("deep garbage: {other:?}"),
    }
    let mut deep_ot = b"# Octomap OcTree file\nid OcTree\nsize 99\nres 0.1\ndata\n".to_vec();
    for _ in 0..40 {
        deep_ot.extend_from_slice(&[0, 0, 0, 0, 1]);
    }
    assert!(matches!(
        read_ot(&deep_ot[..]),
        Err(OctreeError::Format { .. })
    ));
    let mut nan_ot = b"# Octomap OcTree file\nid OcTree\nsize 1\nres 0.1\ndata\n".to_vec();
    nan_ot.extend_from_slice(&f32::NAN.to_le_bytes());
    nan_ot.push(0);
    assert!(read_ot(&nan_ot[..]).is_err());
}

#[test]
fn other_tree_types_get_a_clear_error() {
    for (hdr, id) in [
        ("# Octomap OcTree file", "ColorOcTree"),
        ("# Octomap OcTree file", "OcTreeStamped"),
        // a .bt holds occupancy only: ColorOcTree and OcTreeStamped .bt files read (as
        // OctoMap's readBinary reads any), other types are refused
        ("# Octomap OcTree binary file", "CountingOcTree"),
    ] {
        let bytes = format!("{hdr}\nid {id}\nsize 1\nres 0.1\ndata\n");
        match read_tree(bytes.as_bytes()) {
            Err(OctreeError::UnsupportedTreeType { id: got }) => assert_eq!(got, id),
            other => panic!("{id}: {other:?}"),
        }
    }
}

#[test]
fn empty_tree_round_trips_like_octomaps_test_io() {
    let mut t = OcTree::new(0.999).unwrap();
    let mut bt = Vec::new();
    write_bt(&mut t, &mut bt).unwrap();
    assert!(bt.ends_with(b"size 0\nres 0.999\ndata\n"));
    assert_eq!(read_bt(&bt[..]).unwrap().size(), 0);
    let mut ot = Vec::new();
    write_ot(&t, &mut ot).unwrap();
    assert_eq!(read_ot(&ot[..]).unwrap().size(), 0);
}

#[test]
fn file_errors_name_the_file_and_writes_are_atomic() {
    let dir = common::scratch("tree_files_atomic");
    let bad = dir.join("broken.bt");
    std::fs::write(
        &bad,
        b"# Octomap OcTree binary file\nid OcTree\nsize 3\nres 0.1\ndata\n\x00",
    )
    .unwrap();
    let e = read_tree_file(&bad).unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains("broken.bt") && msg.contains("byte"), "{msg}");
    assert!(matches!(
        read_tree_file(&dir.join("missing.bt")),
        Err(TreeFileError::Open { .. })
    ));
    let mut t = small_tree();
    let target = dir.join("no_such_dir/out.bt");
    assert!(write_tree_file(&mut t, &target).is_err());
    assert!(!target.exists());
    assert!(write_tree_file(&mut t, &dir.join("x.png")).is_err());
    let good = dir.join("good.ot");
    write_tree_file(&mut t, &good).unwrap();
    assert_eq!(
        std::fs::read_dir(&dir).unwrap().count(),
        2,
        "temp files left behind"
    );
    assert_eq!(read_tree_file(&good).unwrap().size(), t.size());
}

fn octoquant_cmd() -> Command {
    Command::new(env!("CARGO_BIN_EXE_octoquant"))
}

/// `info --json` writes numbers in their shortest form: a map at 1e-300 m says
/// `"resolution":1e-300`, not three hundred digits.
#[test]
fn cli_info_json_numbers_are_short() {
    let map = common::scratch("cli_info_tiny").join("tiny.bt");
    let run = |args: &[&std::ffi::OsStr]| {
        let out = octoquant_cmd().args(args).output().unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8(out.stdout).unwrap()
    };
    // (`map` refuses this resolution: every point would lie outside the map)
    let mut tiny = OcTree::new(1e-300).unwrap();
    write_tree_file(&mut tiny, &map).unwrap();
    let json = run(&["info".as_ref(), map.as_ref(), "--json".as_ref()]);
    assert!(json.contains("\"resolution\":1e-300,"), "{json}");
    assert!(json.len() < 400, "{json}");
}

#[test]
fn cli_info_and_convert_on_geb079() {
    let Some(geb) = common::data_file("octomap_reference/geb079.bt") else {
        return;
    };
    let out = octoquant_cmd()
        .arg("info")
        .arg(&geb)
        .arg("--json")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json = String::from_utf8(out.stdout).unwrap();
    for want in [
        "\"nodes\":532566",
        "\"leaves\":428144",
        "\"occupied_leaves\":143729",
        "\"free_leaves\":284415",
        "\"resolution\":0.08",
    ] {
        assert!(json.contains(want), "{want} missing in {json}");
    }
    let bpn: f64 = json
        .split("\"bytes_per_node\":")
        .nth(1)
        .and_then(|s| s.split([',', '}']).next())
        .and_then(|s| s.parse().ok())
        .unwrap();
    assert!(bpn <= 10.0, "{bpn} bytes per node");

    let dir = common::scratch("cli_convert");
    let ot = dir.join("geb.ot");
    let bt = dir.join("geb.bt");
    assert!(octoquant_cmd()
        .arg("convert")
        .arg(&geb)
        .arg(&ot)
        .status()
        .unwrap()
        .success());
    assert!(octoquant_cmd()
        .arg("convert")
        .arg(&ot)
        .arg(&bt)
        .status()
        .unwrap()
        .success());
    assert_eq!(std::fs::read(&bt).unwrap(), std::fs::read(&geb).unwrap());

    let bad = octoquant_cmd()
        .arg("info")
        .arg(dir.join("nope.bt"))
        .output()
        .unwrap();
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("nope.bt"));
}

/// `save_tree_file` writes the bytes `write_tree_file` writes (for `.bt`, OctoMap's
/// max-likelihood pruned tree) and leaves the tree as it was, which `write_tree_file` does not.
#[test]
fn save_tree_file_writes_the_same_bytes_without_changing_the_tree() {
    let dir = common::scratch("tree_files_save_const");
    let tree = small_tree();
    let mut before = Vec::new();
    write_ot(&tree, &mut before).unwrap();
    for name in ["a.bt", "a.ot"] {
        octoquant::treefile::save_tree_file(&tree, &dir.join(name)).unwrap();
        let mut after = Vec::new();
        write_ot(&tree, &mut after).unwrap();
        assert_eq!(before, after, "{name}: the tree changed");
        let mut copy = tree.clone();
        write_tree_file(&mut copy, &dir.join(format!("m{name}"))).unwrap();
        assert_eq!(
            std::fs::read(dir.join(name)).unwrap(),
            std::fs::read(dir.join(format!("m{name}"))).unwrap(),
            "{name}"
        );
    }
    // and the in-place writer does change a tree with values between the clamps
    let mut copy = tree.clone();
    write_tree_file(&mut copy, &dir.join("b.bt")).unwrap();
    let mut changed = Vec::new();
    write_ot(&copy, &mut changed).unwrap();
    assert_ne!(before, changed, "the test tree is already max-likelihood");
    assert!(octoquant::treefile::save_tree_file(&tree, &dir.join("a.png")).is_err());
}
