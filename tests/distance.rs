//! `octoquant distance`: look-ups at points and the slice picture, against the library's
//! `DistanceMap` on the same map (the library itself is checked against brute force in the
//! distance crate and against octomap-python in python/tests/test_distance.py).

use crate::common::scratch;
use nalgebra::Point3;
use octoquant::distance::{DistanceMap, DistanceOptions, DISTANCE_OUTSIDE};
use octoquant::treefile::write_tree_file;
use octoquant::{InnerNodes, Key, OcTree, Update};
use std::path::Path;
use std::process::Command;

/// A 0.1 m map of about 1.6 m per side: scattered hits and misses around a free room with
/// a wall, unknown space left here and there.
fn room() -> OcTree {
    let mut tree = OcTree::new(0.1).unwrap();
    let mut s = 7u64;
    for x in 0..16u16 {
        for y in 0..16u16 {
            for z in 0..6u16 {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let r = (s >> 33) % 100;
                let key = Key::new(32760 + x, 32760 + y, 32766 + z);
                let u = if x == 9 && y < 11 || r < 3 {
                    Update::Hit
                } else if r < 85 {
                    Update::Miss
                } else {
                    continue;
                };
                tree.update_node(key, u, InnerNodes::Refresh);
            }
        }
    }
    tree
}

fn run(args: &[&dyn AsRef<std::ffi::OsStr>]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .arg("distance")
        .args(args)
        .output()
        .unwrap()
}

fn json(args: &[&dyn AsRef<std::ffi::OsStr>]) -> serde_json::Value {
    let out = run(args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

fn write_map(dir: &Path) -> (std::path::PathBuf, OcTree) {
    let mut tree = room();
    let path = dir.join("room.bt");
    write_tree_file(&mut tree, &path).unwrap();
    (path, tree)
}

const LO: [f64; 3] = [-0.75, -0.75, -0.15];
const HI: [f64; 3] = [0.65, 0.65, 0.35];

fn options(unknown_occupied: bool) -> DistanceOptions {
    DistanceOptions {
        max_dist: 0.45,
        bbx_min: Point3::from(LO),
        bbx_max: Point3::from(HI),
        unknown_occupied,
    }
}

#[test]
fn points_equal_the_library_in_and_around_the_box() {
    let dir = scratch("distance_points");
    let (map, tree) = write_map(&dir);
    for unknown in [false, true] {
        let lib = DistanceMap::new(&tree, &options(unknown)).unwrap();
        // every voxel centre of the box and one voxel around it, as a points file
        let mut pts = vec![];
        for x in -9..9 {
            for y in -9..9 {
                for z in -3..6 {
                    pts.push(Point3::new(x as f64 + 0.5, y as f64 + 0.5, z as f64 + 0.5) * 0.1);
                }
            }
        }
        let file = dir.join("points.txt");
        let text: String = pts
            .iter()
            .map(|p| format!("{} {} {}\n", p.x, p.y, p.z))
            .collect();
        std::fs::write(&file, text).unwrap();
        let mut args: Vec<String> = vec![
            map.display().to_string(),
            "--max-dist".into(),
            "0.45".into(),
            "--bbx-min".into(),
        ];
        args.extend(LO.iter().map(|v| v.to_string()));
        args.push("--bbx-max".into());
        args.extend(HI.iter().map(|v| v.to_string()));
        if unknown {
            args.push("--unknown-occupied".into());
        }
        args.extend([
            "--points".into(),
            file.display().to_string(),
            "--json".into(),
        ]);
        let refs: Vec<&dyn AsRef<std::ffi::OsStr>> = args.iter().map(|a| a as _).collect();
        let v = json(&refs);
        assert_eq!(v["max_dist"].as_f64().unwrap() as f32, lib.max_dist());
        let got = v["points"].as_array().unwrap();
        assert_eq!(got.len(), pts.len());
        let (mut outside, mut zero, mut between) = (0, 0, 0);
        for (p, g) in pts.iter().zip(got) {
            let (d, o) = lib.distance_and_closest_obstacle(p).unwrap();
            assert_eq!(g["distance"].as_f64().unwrap() as f32, d, "{p}");
            let go = g["closest_obstacle"].as_array().map(|a| {
                Point3::new(
                    a[0].as_f64().unwrap(),
                    a[1].as_f64().unwrap(),
                    a[2].as_f64().unwrap(),
                )
            });
            assert_eq!(go, o, "{p}");
            assert_eq!(g["inside"].as_bool().unwrap(), d != DISTANCE_OUTSIDE);
            match d {
                DISTANCE_OUTSIDE => outside += 1,
                0.0 => zero += 1,
                _ => between += 1,
            }
        }
        assert!(
            outside > 0 && zero > 0 && between > 0,
            "{outside} {zero} {between}"
        );
    }
}

fn decode_gray(path: &Path) -> (u32, u32, Vec<u8>) {
    let decoder = png::Decoder::new(std::fs::File::open(path).unwrap());
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Grayscale);
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf)
}

#[test]
fn slice_pixels_are_the_distances_at_their_voxels() {
    let dir = scratch("distance_slice");
    let (map, _) = write_map(&dir);
    let png = dir.join("slice.png");
    let mut args: Vec<String> = vec![
        map.display().to_string(),
        "--max-dist".into(),
        "0.45".into(),
    ];
    args.push("--bbx-min".into());
    args.extend(LO.iter().map(|v| v.to_string()));
    args.push("--bbx-max".into());
    args.extend(HI.iter().map(|v| v.to_string()));
    args.extend([
        "--slice".into(),
        "0.12".into(),
        "-o".into(),
        png.display().to_string(),
    ]);
    // look up every pixel's voxel centre through the CLI in the same run
    let (nx, ny) = (15, 15);
    for row in 0..ny {
        for col in 0..nx {
            let x = -0.75 + 0.1 * col as f64;
            let y = 0.65 - 0.1 * row as f64;
            args.extend(["--at".into(), x.to_string(), y.to_string(), "0.15".into()]);
        }
    }
    args.push("--json".into());
    let refs: Vec<&dyn AsRef<std::ffi::OsStr>> = args.iter().map(|a| a as _).collect();
    let v = json(&refs);
    let (w, h, gray) = decode_gray(&png);
    assert_eq!((w, h), (nx as u32, ny as u32));
    assert_eq!(v["slice"]["width"], 15);
    let max = v["max_dist"].as_f64().unwrap();
    let pts = v["points"].as_array().unwrap();
    let mut levels = std::collections::BTreeSet::new();
    for (i, g) in gray.iter().enumerate() {
        let d = pts[i]["distance"].as_f64().unwrap();
        assert!(d >= 0.0);
        assert_eq!(*g, (255.0 * d / max).round() as u8, "pixel {i}");
        levels.insert(*g);
    }
    assert!(levels.contains(&0) && levels.len() > 3, "{levels:?}");
}

#[test]
fn bad_arguments_fail_with_a_message_and_write_nothing() {
    let dir = scratch("distance_errors");
    let (map, _) = write_map(&dir);
    let png = dir.join("out.png");
    let m = map.display().to_string();
    let p = png.display().to_string();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec![&m, "--max-dist", "0.4", "--at", "nan", "0", "0"],
            "finite",
        ),
        (
            vec![&m, "--max-dist", "-1", "--at", "0", "0", "0"],
            "--max-dist -1: must not be negative",
        ),
        (
            vec![&m, "--max-dist", "1e30", "--at", "0", "0", "0"],
            "maximum distance",
        ),
        (
            vec![
                &m,
                "--max-dist",
                "0.4",
                "--bbx-min",
                "1",
                "1",
                "1",
                "--bbx-max",
                "0",
                "0",
                "0",
                "--at",
                "0",
                "0",
                "0",
            ],
            "empty bounding box",
        ),
        (
            vec![
                &m,
                "--max-dist",
                "0.4",
                "--bbx-min",
                "-1e6",
                "0",
                "0",
                "--bbx-max",
                "0",
                "0",
                "0",
                "--at",
                "0",
                "0",
                "0",
            ],
            "outside the map",
        ),
        (
            vec![&m, "--max-dist", "0.4", "--slice", "9", "-o", &p],
            "outside the box",
        ),
        (vec![&m, "--max-dist", "0.4"], "nothing to do"),
    ];
    for (args, msg) in cases {
        let refs: Vec<&dyn AsRef<std::ffi::OsStr>> = args.iter().map(|a| a as _).collect();
        let out = run(&refs);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?}");
        assert!(err.contains(msg), "{args:?}: {err}");
        assert!(!png.exists(), "{args:?} left an output");
    }
}
