//! A command line that never surprises: the demo and `map` without inputs write into a new
//! directory, every `--json` is valid JSON whatever the file names, output names are checked
//! before any work, the readers' options are reachable.

use crate::common::scratch;
use std::path::Path;
use std::process::{Command, Output};

fn octoquant(cwd: &Path) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_octoquant"));
    c.current_dir(cwd);
    c
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The names in `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// A small demo: one LiDAR ring set, no terrestrial scanner or depth camera.
const SMALL_DEMO: [&str; 10] = [
    "--no-terrestrial",
    "--no-depth",
    "--rings",
    "4",
    "--columns",
    "64",
    "--spacing",
    "4",
    "--res",
    "0.5",
];

#[test]
fn demo_without_out_writes_into_a_new_directory() {
    let dir = scratch("cli-demo-fresh");
    // what a user may have here already: a map.bt of their own and an earlier demo
    std::fs::write(dir.join("map.bt"), b"mine").unwrap();
    std::fs::create_dir(dir.join("octoquant-demo")).unwrap();
    std::fs::write(dir.join("octoquant-demo/map.bt"), b"earlier").unwrap();
    let o = octoquant(&dir)
        .arg("demo")
        .args(SMALL_DEMO)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("octoquant-demo-2"), "{}", stderr(&o));
    assert_eq!(std::fs::read(dir.join("map.bt")).unwrap(), b"mine");
    assert_eq!(
        std::fs::read(dir.join("octoquant-demo/map.bt")).unwrap(),
        b"earlier"
    );
    assert_eq!(names(&dir.join("octoquant-demo-2")), ["map.bt", "map.png"]);
    let bt = std::fs::read(dir.join("octoquant-demo-2/map.bt")).unwrap();
    assert!(bt.starts_with(b"# Octomap OcTree binary file"));
    // a second run takes the next name
    let o = octoquant(&dir)
        .arg("demo")
        .args(SMALL_DEMO)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(dir.join("octoquant-demo-3/map.bt").is_file());
    assert_eq!(
        names(&dir),
        [
            "map.bt",
            "octoquant-demo",
            "octoquant-demo-2",
            "octoquant-demo-3"
        ]
    );
    // --out is obeyed as told
    let o = octoquant(&dir)
        .arg("demo")
        .args(SMALL_DEMO)
        .args(["--out", "mine"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(names(&dir.join("mine")), ["map.bt", "map.png"]);
}

#[test]
fn demo_checks_its_options_before_making_a_directory() {
    let dir = scratch("cli-demo-bad-res");
    let o = octoquant(&dir)
        .args(["demo", "--res", "-1"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(stderr(&o).contains("--res"), "{}", stderr(&o));
    assert!(names(&dir).is_empty(), "{:?}", names(&dir));
}

#[test]
fn map_without_inputs_writes_into_a_new_directory() {
    let dir = scratch("cli-map-fresh");
    std::fs::write(dir.join("map.bt"), b"mine").unwrap();
    let o = octoquant(&dir)
        .args(["map", "--res", "0.5"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("octoquant-demo"), "{}", stderr(&o));
    assert_eq!(std::fs::read(dir.join("map.bt")).unwrap(), b"mine");
    assert_eq!(names(&dir.join("octoquant-demo")), ["map.bt"]);
    let o = String::from_utf8(o.stdout).unwrap();
    assert!(o.contains("octoquant-demo/map.bt"), "{o}");
}
