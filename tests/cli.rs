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

/// `simulate --scene builtin --carve-misses` saves the frames `map` maps without inputs, scan
/// times included: the stamped map of the saved file is the built-in one, byte for byte
/// (with the times lost, the saved file's map would be stamped with the clock).
#[test]
fn simulated_frames_keep_their_scan_times() {
    let dir = scratch("cli-simulate-stamps");
    let run = |args: &[&str]| {
        let o = octoquant(&dir).args(args).output().unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
    };
    run(&[
        "simulate",
        "--scene",
        "builtin",
        "--carve-misses",
        "-o",
        "s.frames",
    ]);
    let stamped = ["--stamped", "--res", "0.5", "-q", "-o"];
    run(&[&["map", "s.frames"][..], &stamped, &["saved.ot"]].concat());
    run(&[&["map"][..], &stamped, &["builtin.ot"]].concat());
    let saved = std::fs::read(dir.join("saved.ot")).unwrap();
    assert!(saved == std::fs::read(dir.join("builtin.ot")).unwrap());
}

/// A file name JSON printed with `format!` would break: quotes, a backslash, a tab, a newline,
/// a bell (which Rust's `{:?}` writes as `\u{7}`, not JSON) and a byte that is not UTF-8
/// (printed lossily, as U+FFFD, as the text output does).
#[cfg(unix)]
fn awkward(stem: &str, ext: &str) -> std::path::PathBuf {
    use std::os::unix::ffi::OsStrExt;
    let mut name = format!("{stem} \"q\" \\ \t\n\u{7}").into_bytes();
    name.push(0xff);
    name.extend_from_slice(format!(".{ext}").as_bytes());
    std::path::PathBuf::from(std::ffi::OsStr::from_bytes(&name))
}

/// The one JSON object `o` printed on stdout.
fn json_of(o: &Output) -> serde_json::Value {
    assert!(o.status.success(), "{}", stderr(o));
    let text = String::from_utf8(o.stdout.clone()).expect("JSON output is UTF-8");
    assert_eq!(text.lines().count(), 1, "{text}");
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{e}: {text}"))
}

#[cfg(unix)]
#[test]
fn every_json_is_valid_for_any_file_name() {
    use nalgebra::Point3;
    let dir = scratch("cli-json-names");
    let lossy = |p: &Path| p.to_string_lossy().into_owned();
    let frames = dir.join(awkward("scan", "frames"));
    let wall: Vec<octoquant::Frame> = (0..3)
        .map(|i| {
            octoquant::Frame::new_f32(
                Point3::new(0.0, 0.0, 0.2 * i as f32),
                (0..400)
                    .map(|j| Point3::new(3.0, (j % 20) as f32 * 0.1, (j / 20) as f32 * 0.1))
                    .collect(),
            )
        })
        .collect();
    octoquant::formats::frames::write_frames_file(&frames, &wall).unwrap();
    let map = dir.join(awkward("map", "bt"));
    let o = octoquant(&dir)
        .arg("map")
        .arg(&frames)
        .arg("-o")
        .arg(&map)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));

    let v = json_of(
        &octoquant(&dir)
            .arg("info")
            .arg(&map)
            .arg("--json")
            .output()
            .unwrap(),
    );
    assert_eq!(v["file"], lossy(&map));
    assert!(v["occupied_leaves"].as_u64().unwrap() > 0);
    assert_eq!(v["resolution"], 0.1);

    let ot = dir.join(awkward("full", "ot"));
    let v = json_of(
        &octoquant(&dir)
            .arg("convert")
            .arg(&map)
            .arg(&ot)
            .arg("--json")
            .output()
            .unwrap(),
    );
    assert_eq!(
        (v["input"].clone(), v["output"].clone()),
        (lossy(&map).into(), lossy(&ot).into())
    );
    assert!(ot.is_file());

    let ply = dir.join(awkward("cloud", "ply"));
    let v = json_of(
        &octoquant(&dir)
            .arg("export")
            .arg(&map)
            .arg("-o")
            .arg(&ply)
            .arg("--json")
            .output()
            .unwrap(),
    );
    assert_eq!(v["output"], lossy(&ply));
    assert!(v["occupied"].as_u64().unwrap() > 0);

    let png = dir.join(awkward("top", "png"));
    let v = json_of(
        &octoquant(&dir)
            .arg("render")
            .arg(&map)
            .arg("-o")
            .arg(&png)
            .arg("--json")
            .output()
            .unwrap(),
    );
    assert_eq!(v["output"], lossy(&png));
    assert!(v["width"].as_u64().unwrap() > 0);

    let yaml = dir.join(awkward("floor", "yaml"));
    let v = json_of(
        &octoquant(&dir)
            .arg("grid")
            .arg(&map)
            .arg("-o")
            .arg(&yaml)
            .arg("--json")
            .output()
            .unwrap(),
    );
    assert_eq!(v["yaml"], lossy(&yaml));

    let reduced = dir.join(awkward("thin", "ply"));
    let v = json_of(
        &octoquant(&dir)
            .arg("reduce")
            .arg(&frames)
            .args(["--format", "frames", "--cell", "0.3", "-o"])
            .arg(&reduced)
            .arg("--json")
            .output()
            .unwrap(),
    );
    assert_eq!(v["input"], lossy(&frames));
    assert_eq!(v["points"], 1200);

    let log = dir.join(awkward("laser", "log"));
    let ranges = vec!["2.0"; 90].join(" ");
    std::fs::write(
        &log,
        format!("FLASER 90 {ranges} 0 0 0 0 0 0 1.0 host 1.0\n"),
    )
    .unwrap();
    for extra in [&[][..], &["--all"][..]] {
        let v = json_of(
            &octoquant(&dir)
                .arg("segment")
                .arg(&log)
                .args(extra)
                .arg("--json")
                .output()
                .unwrap(),
        );
        assert_eq!(v["file"], lossy(&log));
    }
}

#[test]
fn bench_names_a_program_it_cannot_run_before_any_work() {
    let dir = scratch("cli-bench-programs");
    // the input does not exist: the program's error must come first
    let not_executable = dir.join("ref.txt");
    std::fs::write(&not_executable, b"not a program").unwrap();
    for (args, needles) in [
        (
            vec![
                "--reference".to_string(),
                dir.join("gone").display().to_string(),
            ],
            vec!["reference program", "gone", "no such file"],
        ),
        (
            vec![
                "--reference".to_string(),
                not_executable.display().to_string(),
            ],
            vec!["reference program", "ref.txt", "not an executable"],
        ),
        (
            vec![
                "--peer".to_string(),
                "ghost=octoquant-no-such-peer".to_string(),
            ],
            vec!["peer ghost", "octoquant-no-such-peer", "PATH"],
        ),
    ] {
        let o = octoquant(&dir)
            .args(["bench", "absent.frames"])
            .args(&args)
            .output()
            .unwrap();
        let err = stderr(&o);
        assert!(!o.status.success(), "{args:?}");
        for n in needles {
            assert!(
                err.contains(n) && !err.contains("absent"),
                "{args:?}: {err}"
            );
        }
    }
}

#[test]
fn output_names_are_checked_before_reading_and_list_the_accepted_extensions() {
    let dir = scratch("cli-output-names");
    // the inputs do not exist: the output's error must come first
    let cases: [(&[&str], &str); 9] = [
        (&["convert", "absent.bt", "out.png"], ".bt, .ot"),
        (&["import", "absent.binvox", "-o", "out.png"], ".bt, .ot"),
        (
            &["compare", "absent.bt", "absent2.bt", "--png", "out.jpg"],
            ".png",
        ),
        (&["render", "absent.bt", "-o", "out.jpg"], ".png"),
        (&["export", "absent.bt", "-o", "out.obj"], ".ply, .pcd"),
        (
            &["reduce", "absent.ply", "--cell", "0.1", "-o", "out.pcd"],
            ".ply",
        ),
        (&["segment", "absent.log", "--png", "out.svg"], ".png"),
        (&["grid", "absent.bt", "-o", "out.png"], ".yaml or .yml"),
        (
            &["convert", "absent.bt", "no/such/dir/out.bt"],
            "does not exist",
        ),
    ];
    for (args, needle) in cases {
        let o = octoquant(&dir).args(args).output().unwrap();
        let err = stderr(&o);
        assert!(!o.status.success(), "{args:?}");
        assert!(
            err.contains(needle) && !err.contains("absent"),
            "{args:?}: {err}"
        );
    }
    // an output that is the input
    std::fs::write(dir.join("in.ply"), b"ply\n").unwrap();
    let o = octoquant(&dir)
        .args(["reduce", "in.ply", "--cell", "0.1", "-o", "in.ply"])
        .output()
        .unwrap();
    assert!(stderr(&o).contains("also an input"), "{}", stderr(&o));
    assert_eq!(std::fs::read(dir.join("in.ply")).unwrap(), b"ply\n");
    assert_eq!(names(&dir), ["in.ply"]);
}

#[test]
fn unknown_input_extension_names_format_and_its_values() {
    let dir = scratch("cli-unknown-extension");
    std::fs::write(dir.join("scan.xyzw"), b"1 2 3\n").unwrap();
    let o = octoquant(&dir)
        .args(["map", "scan.xyzw", "-o", "m.bt"])
        .output()
        .unwrap();
    let err = stderr(&o);
    assert!(!o.status.success());
    assert!(
        err.contains(".xyzw") && err.contains("--format") && err.contains("vtk-seq, pcd"),
        "{err}"
    );
    // and --format's help lists its values
    let o = octoquant(&dir).args(["map", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&o.stdout);
    assert!(
        help.contains("possible values: graph, frames, text"),
        "{help}"
    );
}

#[test]
fn a_resolution_that_puts_every_point_outside_the_map_is_an_error() {
    use nalgebra::Point3;
    let dir = scratch("cli-res-outside");
    // a wall 3 m away; at 0.05 mm the map spans only ±1.6 m
    let wall = vec![octoquant::Frame::new_f32(
        Point3::origin(),
        (0..100)
            .map(|j| Point3::new(3.0, (j % 10) as f32 * 0.1, (j / 10) as f32 * 0.1))
            .collect(),
    )];
    octoquant::formats::frames::write_frames_file(&dir.join("wall.frames"), &wall).unwrap();
    let o = octoquant(&dir)
        .args(["map", "wall.frames", "--res", "0.00005", "-o", "m.bt"])
        .output()
        .unwrap();
    let err = stderr(&o);
    assert!(!o.status.success());
    assert!(
        err.contains("all 100 points lie outside the map") && err.contains("--res"),
        "{err}"
    );
    assert!(!dir.join("m.bt").exists());
    // a resolution that keeps them is fine
    let o = octoquant(&dir)
        .args(["map", "wall.frames", "--res", "0.001", "-o", "m.bt"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn vtk_directories_take_a_trajectory_or_identity_poses() {
    let dir = scratch("cli-vtk-identity");
    let scans = dir.join("run/scans");
    std::fs::create_dir_all(&scans).unwrap();
    let wall: String = (0..50)
        .map(|j| format!("2 {} {}\n", (j % 10) as f64 * 0.1, (j / 10) as f64 * 0.1))
        .collect();
    for stamp in ["cloud_10_0.vtk", "cloud_11_500000000.vtk"] {
        std::fs::write(
            scans.join(stamp),
            format!(
                "# vtk DataFile Version 3.0\nx\nASCII\nDATASET POLYDATA\nPOINTS 50 float\n{wall}"
            ),
        )
        .unwrap();
    }
    let map = |extra: &[&str], out: &str| {
        octoquant(&dir)
            .args(["map", "run", "--res", "0.1", "-o", out])
            .args(extra)
            .output()
            .unwrap()
    };
    let o = map(&[], "a.bt");
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("--trajectory") && stderr(&o).contains("--identity-poses"),
        "{}",
        stderr(&o)
    );
    let o = map(&["--identity-poses"], "identity.bt");
    assert!(o.status.success(), "{}", stderr(&o));
    // the same as a trajectory of identity poses
    std::fs::write(
        dir.join("poses.csv"),
        "header.stamp.sec,header.stamp.nanosec,pose.pose.position.x,pose.pose.position.y,pose.pose.position.z,pose.pose.orientation.x,pose.pose.orientation.y,pose.pose.orientation.z,pose.pose.orientation.w\n\
         10,0,0,0,0,0,0,0,1\n11,500000000,0,0,0,0,0,0,1\n",
    )
    .unwrap();
    let o = map(&["--trajectory", "poses.csv"], "trajectory.bt");
    assert!(o.status.success(), "{}", stderr(&o));
    let a = std::fs::read(dir.join("identity.bt")).unwrap();
    assert_eq!(a, std::fs::read(dir.join("trajectory.bt")).unwrap());
    // and a shifted trajectory gives another map
    std::fs::write(
        dir.join("shifted.csv"),
        "header.stamp.sec,header.stamp.nanosec,pose.pose.position.x,pose.pose.position.y,pose.pose.position.z,pose.pose.orientation.x,pose.pose.orientation.y,pose.pose.orientation.z,pose.pose.orientation.w\n\
         10,0,1,0,0,0,0,0,1\n11,500000000,1,0,0,0,0,0,1\n",
    )
    .unwrap();
    let o = map(&["--trajectory", "shifted.csv"], "shifted.bt");
    assert!(o.status.success(), "{}", stderr(&o));
    assert_ne!(a, std::fs::read(dir.join("shifted.bt")).unwrap());
}

#[test]
fn reader_options_are_on_the_command_line() {
    let dir = scratch("cli-reader-options");
    let o = octoquant(&dir).args(["map", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&o.stdout);
    for option in [
        "--intrinsics <FX> <FY> <CX> <CY>",
        "--depth-scale",
        "--trajectory",
        "--identity-poses",
        "--pcd-viewpoint",
        "possible values: origin, apply, ignore",
    ] {
        assert!(help.contains(option), "{option} missing from\n{help}");
    }
    // bad intrinsics reach the reader's check, which names the file
    std::fs::write(dir.join("d.png"), b"").unwrap();
    let o = octoquant(&dir)
        .args([
            "map",
            "d.png",
            "--intrinsics",
            "0",
            "525",
            "319.5",
            "239.5",
            "-o",
            "m.bt",
        ])
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("d.png") && stderr(&o).contains("focal"),
        "{}",
        stderr(&o)
    );
}

/// `map --threads N`: one and two threads write the same bytes from real LiDAR frames (the
/// plain loop with one, the pipelined one with two), a checkpointed run may be resumed with
/// another count, and a count of 0 is refused before any work.
#[test]
fn map_threads_changes_nothing_in_the_map() {
    let Some(scans) = crate::common::data_file("lidar3d/norlab_icp_mapper_example") else {
        return;
    };
    let dir = scratch("cli-map-threads");
    // the summary says how many threads the run had
    let map = |args: &[&str], threads: u64| {
        let o = octoquant(&dir)
            .arg("map")
            .args(args)
            .args(["-q", "--json"])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        assert_eq!(json_of(&o)["threads"], threads, "{}", stderr(&o));
    };
    let s = scans.to_str().unwrap();
    let two = [
        s,
        "--res",
        "0.2",
        "--threads",
        "2",
        "-o",
        "two.bt",
        "--checkpoint",
        "ck",
        "--every",
        "4",
    ];
    map(&[s, "--res", "0.2", "--threads", "1", "-o", "one.bt"], 1);
    map(&two, 2);
    let one = std::fs::read(dir.join("one.bt")).unwrap();
    assert!(one.len() > 100_000, "{} bytes", one.len());
    assert!(
        one == std::fs::read(dir.join("two.bt")).unwrap(),
        "1 and 2 threads differ"
    );
    // the finished checkpoint resumed on one thread writes its outputs again, the same
    std::fs::remove_file(dir.join("two.bt")).unwrap();
    map(&["--resume", "ck", "--threads", "1"], 1);
    assert!(
        one == std::fs::read(dir.join("two.bt")).unwrap(),
        "resumed on 1 thread"
    );
    let o = octoquant(&dir)
        .args(["map", s, "--threads", "0", "-o", "zero.bt"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(stderr(&o).contains("--threads"), "{}", stderr(&o));
    assert!(!dir.join("zero.bt").exists());
}

/// A wall 3 m in front of the origin, as `dir/wall.frames`; with `map`, also its map
/// `dir/wall.bt` at 0.2 m.
fn wall_input(dir: &Path, map: bool) {
    use nalgebra::Point3;
    let wall = vec![octoquant::Frame::new_f32(
        Point3::origin(),
        (0..100)
            .map(|j| Point3::new(3.0, (j % 10) as f32 * 0.1, (j / 10) as f32 * 0.1))
            .collect(),
    )];
    octoquant::formats::frames::write_frames_file(&dir.join("wall.frames"), &wall).unwrap();
    if map {
        let o = octoquant(dir)
            .args(["map", "wall.frames", "--res", "0.2", "-q", "-o", "wall.bt"])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
    }
}

/// `args` succeeds (in `dir`).
fn accepted(dir: &Path, args: &[&str]) {
    let o = octoquant(dir).args(args).output().unwrap();
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
}

/// `args` fails with an error naming `option`, and `output` (in `dir`) is not written.
fn refused(dir: &Path, args: &[&str], option: &str, output: &str) {
    let o = octoquant(dir).args(args).output().unwrap();
    let err = stderr(&o);
    assert_eq!(
        o.status.code(),
        Some(if err.starts_with("error:") { 2 } else { 1 }),
        "{args:?}: {err}"
    );
    assert!(!err.contains("panicked"), "{args:?}: {err}");
    assert!(err.contains(option), "{args:?} should name {option}: {err}");
    assert!(!dir.join(output).exists(), "{args:?} wrote {output}");
}

/// Sensor models under which a map could hold one class only are refused, naming the
/// option: a lower clamp at or above the occupancy threshold (0.5: nothing free), an upper one
/// below it (nothing occupied), a miss of 0.5 (every voxel a ray crosses stays at the
/// threshold, occupied). Before, each wrote a map of one class. Negative probabilities reach
/// the check instead of reading as options.
#[test]
fn sensor_models_with_one_reachable_class_are_refused() {
    let dir = scratch("cli-sensor-classes");
    wall_input(&dir, false);
    for bad in [
        ["--clamping", "0.6", "0.9"],
        ["--clamping", "0.5", "0.9"],
        ["--clamping", "0.1", "0.4"],
        ["--clamping", "-0.1", "0.9"],
    ] {
        let mut args = vec!["map", "wall.frames", "--res", "0.2", "-o", "m.bt"];
        args.extend(bad);
        refused(&dir, &args, "--clamping", "m.bt");
    }
    for bad in [["--sensor", "0.5", "0.7"], ["--sensor", "-0.4", "0.7"]] {
        let mut args = vec!["map", "wall.frames", "--res", "0.2", "-o", "m.bt"];
        args.extend(bad);
        refused(&dir, &args, "--sensor", "m.bt");
    }
    // the edges that keep both classes reachable are fine
    accepted(
        &dir,
        &[
            "map",
            "wall.frames",
            "--res",
            "0.2",
            "-q",
            "-o",
            "m.bt",
            "--clamping",
            "0.1",
            "0.5",
            "--sensor",
            "0.49",
            "0.5",
        ],
    );
}

/// Thread counts far beyond any core count are refused before any work (thousands of
/// insertion threads took minutes on a tiny input), in `map` and `bench`; `bench` also
/// refuses 0 threads (it ran single-threaded), `--frames 0` and `--repeat 0` (a table of
/// zeros, or one repetition instead of none).
#[test]
fn absurd_thread_frame_and_repeat_counts_are_refused() {
    let dir = scratch("cli-thread-counts");
    wall_input(&dir, false);
    for n in ["257", "65535", "100000"] {
        refused(
            &dir,
            &["map", "wall.frames", "--threads", n, "-o", "m.bt"],
            "--threads",
            "m.bt",
        );
    }
    for (option, value) in [
        ("--threads", "0"),
        ("--threads", "100000"),
        ("--frames", "0"),
        ("--repeat", "0"),
    ] {
        refused(
            &dir,
            &["bench", "wall.frames", "--res", "0.2", option, value],
            option,
            "m.bt",
        );
    }
    // an input without frames is an error too, not a table of zeros
    octoquant::formats::frames::write_frames_file(&dir.join("none.frames"), &[]).unwrap();
    let o = octoquant(&dir)
        .args(["bench", "none.frames", "--res", "0.2"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(stderr(&o).contains("no frames"), "{}", stderr(&o));
}

/// `--res` so coarse that voxel coordinates overflow 32-bit floats is refused: before, the
/// map was written and `export` then wrote `inf` coordinates.
#[test]
fn a_resolution_beyond_float_coordinates_is_refused() {
    let dir = scratch("cli-res-coarse");
    wall_input(&dir, false);
    for r in ["1e300", "1e34"] {
        refused(
            &dir,
            &["map", "wall.frames", "--res", r, "-o", "m.bt"],
            "--res",
            "m.bt",
        );
    }
    accepted(
        &dir,
        &["map", "wall.frames", "--res", "1e6", "-q", "-o", "m.bt"],
    );
}

/// `compare --png` with a huge `--max-pixels` is refused: two points 6.5 km apart at 0.1 m
/// asked for a 65 000 × 65 000 picture (13 GB, killed after a minute).
#[test]
fn compare_max_pixels_is_bounded() {
    let dir = scratch("cli-compare-pixels");
    wall_input(&dir, true);
    for n in ["4294967295", "8193", "0"] {
        refused(
            &dir,
            &[
                "compare",
                "wall.bt",
                "wall.bt",
                "--png",
                "c.png",
                "--max-pixels",
                n,
            ],
            "--max-pixels",
            "c.png",
        );
    }
    accepted(
        &dir,
        &[
            "compare",
            "wall.bt",
            "wall.bt",
            "--png",
            "c.png",
            "--max-pixels",
            "16",
        ],
    );
    assert!(dir.join("c.png").exists());
}

/// `distance --max-dist` beyond what its f32 holds names the option and the value given
/// (it said "invalid maximum distance inf m").
#[test]
fn distance_max_dist_beyond_f32_names_the_option() {
    let dir = scratch("cli-distance-max");
    wall_input(&dir, true);
    for d in ["1e300", "1e39", "-1"] {
        refused(
            &dir,
            &[
                "distance",
                "wall.bt",
                "--max-dist",
                d,
                "--at",
                "0",
                "0",
                "0",
            ],
            "--max-dist",
            "wall.png",
        );
    }
}

/// The demo checks its scanners' options before it makes its directory: a bad `--spacing`
/// left an empty `octoquant-demo/` behind and named `frame_spacing`, not the option.
#[test]
fn demo_checks_scanner_options_before_making_a_directory() {
    let dir = scratch("cli-demo-scanner-options");
    for (option, value) in [
        ("--spacing", "0"),
        ("--step", "0"),
        ("--rings", "0"),
        ("--noise", "inf"),
    ] {
        let o = octoquant(&dir)
            .args(["demo", option, value])
            .output()
            .unwrap();
        assert!(!o.status.success());
        assert!(stderr(&o).contains(option), "{option}: {}", stderr(&o));
        assert!(names(&dir).is_empty(), "{option}: {:?}", names(&dir));
    }
}

/// `--pixel-step 0` is refused (it was read as 1).
#[test]
fn pixel_step_zero_is_refused() {
    let dir = scratch("cli-pixel-step");
    wall_input(&dir, false);
    refused(
        &dir,
        &["map", "wall.frames", "--pixel-step", "0", "-o", "m.bt"],
        "--pixel-step",
        "m.bt",
    );
}

/// A cell size or offset under which no finite point of the real PCL cloud has a cell index
/// is refused, naming the input and `--cell`/`--offset`, without output (batch and stream);
/// the summary splits the rejected points by cause (the cloud holds 97 920 NaN points).
#[test]
fn reduce_refuses_a_grid_that_holds_no_point() {
    let Some(pcd) = crate::common::data_file(
        "pcd/pcl_table_scene_mug_stereo_textured/table_scene_mug_stereo_textured.pcd",
    ) else {
        return;
    };
    let dir = scratch("cli-reduce-range");
    let input = pcd.to_str().unwrap();
    for stream in [false, true] {
        let with = |args: &[&'static str]| {
            let mut v = vec!["reduce", input];
            v.extend_from_slice(args);
            if stream {
                v.push("--stream");
            }
            v
        };
        refused(
            &dir,
            &with(&["--cell", "1e-300", "-o", "r.ply"]),
            "--cell 1e-300",
            "r.ply",
        );
        refused(
            &dir,
            &with(&["--cell", "0.01", "--offset", "1e300,0,0", "-o", "r.ply"]),
            "--offset 1e300",
            "r.ply",
        );
        let o = octoquant(&dir)
            .args(with(&["--cell", "0.01", "-o", "r.ply", "--json"]))
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        let j = json_of(&o);
        assert_eq!(
            (&j["rejected"], &j["non_finite"], &j["out_of_range"]),
            (&97_920.into(), &97_920.into(), &0.into()),
            "{j}"
        );
        std::fs::remove_file(dir.join("r.ply")).unwrap();
    }
}

/// `--ground-iterations` is bounded (4e9 iterations per frame would run for hours).
#[test]
fn ground_iterations_are_bounded() {
    let dir = scratch("cli-ground-iterations");
    wall_input(&dir, false);
    for n in ["0", "100001", "4000000000"] {
        refused(
            &dir,
            &[
                "map",
                "wall.frames",
                "--ground",
                "0.1",
                "--ground-iterations",
                n,
                "-o",
                "m.bt",
            ],
            "--ground-iterations",
            "m.bt",
        );
    }
    accepted(
        &dir,
        &[
            "map",
            "wall.frames",
            "--ground",
            "0.1",
            "--ground-iterations",
            "100000",
            "-o",
            "m.bt",
        ],
    );
}

/// `simulate` and `segment` name the option a bad value came from, not the library's field.
#[test]
fn simulate_and_segment_name_their_options() {
    let dir = scratch("cli-option-names");
    for (args, option) in [
        (&["--rings", "0"][..], "--rings"),
        (&["--columns", "0"], "--columns"),
        (&["--frames", "0"], "--frames"),
        (&["--blocks", "0", "2"], "--blocks"),
        (&["--noise=-1"], "--noise"),
    ] {
        let mut v = vec!["simulate", "-o", "s.frames"];
        v.extend_from_slice(args);
        refused(&dir, &v, option, "s.frames");
    }
    let Some(log) = crate::common::data_file("laser2d/radish_clf/intel.clf.bz2") else {
        return;
    };
    let log = log.to_str().unwrap();
    for (args, option) in [
        (&["--min-points", "0"][..], "--min-points 0"),
        (&["--eps-dist=-1"], "--eps-dist -1"),
        (&["--split-min-points", "0"], "--split-min-points 0"),
        (&["--split-spacing-factor=-1"], "--split-spacing-factor -1"),
        (&["--resegment=-1"], "--resegment -1"),
        (
            &["--resegment", "0.1", "--resegment-eps=-1"],
            "--resegment-eps -1",
        ),
    ] {
        let mut v = vec!["segment", log, "--png", "s.png"];
        v.extend_from_slice(args);
        refused(&dir, &v, option, "s.png");
    }
}

/// `map --color` applies the point filters and reports what they dropped, as `map` does:
/// the z band's count equals the points of the real PCL cloud above the band, counted here.
#[test]
fn map_color_reports_its_filters() {
    let Some(pcd) = crate::common::data_file(
        "pcd/pcl_table_scene_mug_stereo_textured/table_scene_mug_stereo_textured.pcd",
    ) else {
        return;
    };
    let frames = octoquant::formats::read_frames(&pcd, &Default::default()).unwrap();
    let mut z: Vec<f32> = frames[0]
        .points
        .iter()
        .map(|p| p.z)
        .filter(|z| z.is_finite())
        .collect();
    z.sort_by(f32::total_cmp);
    // the band's bound as the command line reads it (f64), the points widened as the filter does
    let zmax = z[z.len() / 2].to_string();
    let bound: f64 = zmax.parse().unwrap();
    let above = z.iter().filter(|&&v| f64::from(v) > bound).count();
    let dir = scratch("cli-color-filters");
    let o = octoquant(&dir)
        .args([
            "map",
            pcd.to_str().unwrap(),
            "--color",
            "--res",
            "0.01",
            "--json",
            "-o",
            "c.ot",
        ])
        .args(["--zmax", &zmax])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let j = json_of(&o);
    assert_eq!(j["dropped"]["z_band"], above, "{j}");
    assert!(above > 1000, "{above}");
}

/// `map --color` names the inputs on the colour mapper's own errors (a frame without colours),
/// and leaves read errors, which name their file and place, as they are: a coloured `.frames`
/// file cut inside its second frame fails with the reader's message alone.
#[test]
fn map_color_errors_name_the_inputs_once() {
    use octoquant::octree::Color;
    use octoquant::Frame;
    let dir = scratch("cli-color-errors");
    let frame = |x: f32| {
        let points: Vec<nalgebra::Point3<f32>> = (0..200)
            .map(|i| nalgebra::Point3::new(x, 0.01 * i as f32, 0.5))
            .collect();
        let colors = vec![Color::new(10, 20, 30); points.len()];
        Frame {
            colors: Some(colors),
            ..Frame::new_f32(nalgebra::Point3::origin(), points)
        }
    };
    let whole = dir.join("whole.frames");
    octoquant::formats::frames::write_frames_file(&whole, &[frame(2.0), frame(3.0)]).unwrap();
    let bytes = std::fs::read(&whole).unwrap();
    std::fs::write(dir.join("cut.frames"), &bytes[..bytes.len() - 100]).unwrap();
    let o = octoquant(&dir)
        .args(["map", "cut.frames", "--color", "--res", "0.1", "-o", "c.ot"])
        .output()
        .unwrap();
    let e = stderr(&o);
    assert!(!o.status.success());
    assert!(e.contains("cut.frames is truncated"), "{e}");
    assert!(!e.contains("in colour"), "{e}");
    assert!(!dir.join("c.ot").exists(), "no output after a failed read");
    // a frame without colours: the mapper's error, with the inputs named
    let plain = dir.join("plain.frames");
    let mut f = frame(2.0);
    f.colors = None;
    octoquant::formats::frames::write_frames_file(&plain, &[f]).unwrap();
    let o = octoquant(&dir)
        .args([
            "map",
            "plain.frames",
            "--color",
            "--res",
            "0.1",
            "-o",
            "c.ot",
        ])
        .output()
        .unwrap();
    let e = stderr(&o);
    assert!(!o.status.success());
    assert!(
        e.contains("plain.frames in colour: frame 0 has no colours"),
        "{e}"
    );
}
