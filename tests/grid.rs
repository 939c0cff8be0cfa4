//! 2D grid maps: the projection against a brute-force oracle (every voxel looked up one by
//! one), on random trees and on a real OctoMap map, and the Nav2 files read back with
//! map_server's trinary rule.

use crate::common;
use nalgebra::Point2;
use octoquant::grid::{project, write_nav2, Cell, GridOptions, OccupancyGrid, UnknownCells};
use octoquant::treefile::read_tree_file;
use octoquant::{InnerNodes, Key, OcTree, Update};
use proptest::prelude::*;
use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

/// The grid straight from the definition: every depth-16 key in the tree's key box is looked
/// up; a known voxel whose z extent overlaps the band marks its column's cell at `depth`,
/// occupied over free over unknown; the grid spans the marked cells.
fn oracle(
    tree: &OcTree,
    zmin: f64,
    zmax: f64,
    depth: u8,
    unknown_free: bool,
) -> Option<OccupancyGrid> {
    let res = tree.resolution();
    let leaves: Vec<_> = tree.leaves().collect();
    // the key box of the known space (from the leaves' corners, widths included)
    let lo = |f: fn(&Key) -> u16| leaves.iter().map(|l| u32::from(f(&l.min_key()))).min();
    let hi = |f: fn(&Key) -> u16| {
        leaves
            .iter()
            .map(|l| u32::from(f(&l.min_key())) + l.width() - 1)
            .max()
    };
    let (x0, x1) = (lo(Key::x)?, hi(Key::x)?);
    let (y0, y1) = (lo(Key::y)?, hi(Key::y)?);
    let (z0, z1) = (lo(Key::z)?, hi(Key::z)?);
    let shift = 16 - u32::from(depth);
    let mut marked: BTreeMap<(u32, u32), Cell> = BTreeMap::new();
    for z in z0..=z1 {
        let bottom = (f64::from(z) - 32768.0) * res;
        let top = (f64::from(z) + 1.0 - 32768.0) * res;
        if !(top > zmin && bottom < zmax) {
            continue;
        }
        for y in y0..=y1 {
            for x in x0..=x1 {
                let key = Key::new(x as u16, y as u16, z as u16);
                let Some(occupied) = tree.is_occupied(key) else {
                    continue;
                };
                let state = if occupied { Cell::Occupied } else { Cell::Free };
                let e = marked.entry((x >> shift, y >> shift)).or_insert(state);
                *e = (*e).max(state);
            }
        }
    }
    let cx0 = marked.keys().map(|k| k.0).min()?;
    let cx1 = marked.keys().map(|k| k.0).max()?;
    let cy0 = marked.keys().map(|k| k.1).min()?;
    let cy1 = marked.keys().map(|k| k.1).max()?;
    let (width, height) = ((cx1 - cx0 + 1) as usize, (cy1 - cy0 + 1) as usize);
    let mut cells = vec![
        if unknown_free {
            Cell::Free
        } else {
            Cell::Unknown
        };
        width * height
    ];
    for ((cx, cy), c) in marked {
        cells[(cy - cy0) as usize * width + (cx - cx0) as usize] = c;
    }
    Some(OccupancyGrid {
        resolution: res * f64::from(1u32 << shift),
        origin: Point2::new(
            (f64::from(cx0 << shift) - 32768.0) * res,
            (f64::from(cy0 << shift) - 32768.0) * res,
        ),
        width,
        height,
        cells,
    })
}

fn check_against_oracle(
    tree: &OcTree,
    zmin: Option<f64>,
    zmax: Option<f64>,
    depth: u8,
    unknown_free: bool,
) {
    let options = GridOptions {
        zmin,
        zmax,
        depth,
        unknown: if unknown_free {
            UnknownCells::Free
        } else {
            UnknownCells::Unknown
        },
    };
    let want = oracle(
        tree,
        zmin.unwrap_or(f64::NEG_INFINITY),
        zmax.unwrap_or(f64::INFINITY),
        depth,
        unknown_free,
    );
    match (project(tree, &options), want) {
        (Ok(got), Some(want)) => {
            assert_eq!(
                (got.width, got.height),
                (want.width, want.height),
                "grid size"
            );
            assert!((got.resolution - want.resolution).abs() < 1e-12);
            assert!(
                (got.origin - want.origin).norm() < 1e-9,
                "{} vs {}",
                got.origin,
                want.origin
            );
            let diff = got
                .cells
                .iter()
                .zip(&want.cells)
                .filter(|(a, b)| a != b)
                .count();
            assert_eq!(diff, 0, "{diff} cells differ");
        }
        (Err(octoquant::grid::GridError::Empty { .. }), None) => {}
        (got, want) => panic!("projection {got:?} but oracle {want:?}"),
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    /// Random trees (hits and misses in a small region, some blocks filled so that they are
    /// pruned), random bands and depths: the projection equals the oracle.
    #[test]
    fn projection_matches_brute_force(
        ups in prop::collection::vec((0u16..24, 0u16..24, 0u16..12, any::<bool>()), 1..120),
        blocks in prop::collection::vec((0u16..3, 0u16..3, 0u16..2, any::<bool>()), 0..3),
        band in (-0.4f64..0.8, 0.05f64..1.2),
        bounded in (any::<bool>(), any::<bool>()),
        depth in 12u8..=16,
        unknown_free in any::<bool>(),
    ) {
        let mut tree = OcTree::new(0.1).unwrap();
        let base = 32760u16;
        for (x, y, z, hit) in ups {
            let u = if hit { Update::Hit } else { Update::Miss };
            tree.update_node(Key::new(base + x, base + y, base + z), u, InnerNodes::Refresh);
        }
        // whole 8x8x8 blocks at a pruned value
        for (bx, by, bz, hit) in blocks {
            for i in 0..512u16 {
                let k = Key::new(32768 + bx * 8 + (i & 7), 32768 + by * 8 + ((i >> 3) & 7), 32760 + bz * 8 + (i >> 6));
                let v = if hit { 3.5 } else { -2.0 };
                tree.set_node_value(k, v, InnerNodes::Refresh).unwrap();
            }
        }
        let zmin = bounded.0.then_some(band.0);
        let zmax = bounded.1.then_some(band.0 + band.1);
        check_against_oracle(&tree, zmin, zmax, depth, unknown_free);
    }
}

/// A real OctoMap map (the FR-079 corridor): the projection equals the oracle for a band at
/// the robot's height, at full and at coarser depth.
#[test]
fn real_map_matches_brute_force() {
    let Some(path) = common::data_file("octomap_reference/geb079.bt") else {
        return;
    };
    let tree = read_tree_file(&path).unwrap();
    check_against_oracle(&tree, Some(0.2), Some(1.2), 16, false);
    check_against_oracle(&tree, Some(0.2), Some(1.2), 14, true);
}

/// Read a map the way Nav2's map_server does in trinary mode: the YAML's fields, then each
/// PGM pixel `p` becomes occupied when `(255 - p) / 255 > occupied_thresh`, free when it is
/// `< free_thresh`, unknown otherwise; the image's top row is the largest y.
fn read_as_nav2(yaml: &Path) -> OccupancyGrid {
    let text = std::fs::read_to_string(yaml).unwrap();
    let field = |name: &str| {
        text.lines()
            .find_map(|l| l.strip_prefix(&format!("{name}: ")))
            .unwrap_or_else(|| panic!("no {name} in {text}"))
            .trim()
            .to_string()
    };
    assert_eq!(field("mode"), "trinary");
    assert_eq!(field("negate"), "0");
    let occ: f64 = field("occupied_thresh").parse().unwrap();
    let free: f64 = field("free_thresh").parse().unwrap();
    let resolution: f64 = field("resolution").parse().unwrap();
    let origin: Vec<f64> = field("origin")
        .trim_matches(|c| c == '[' || c == ']')
        .split(',')
        .map(|v| v.trim().parse().unwrap())
        .collect();
    // a YAML double-quoted scalar (our names with spaces are quoted) or a plain one
    let name = field("image");
    let name = name
        .strip_prefix('"')
        .and_then(|n| n.strip_suffix('"'))
        .unwrap_or(&name);
    let image = std::fs::read(yaml.with_file_name(name)).unwrap();
    // P5 header: magic, width, height, maxval, one whitespace byte, then the pixels
    let mut parts = Vec::new();
    let mut at = 0;
    while parts.len() < 4 {
        while image[at].is_ascii_whitespace() {
            at += 1;
        }
        let start = at;
        while !image[at].is_ascii_whitespace() {
            at += 1;
        }
        parts.push(std::str::from_utf8(&image[start..at]).unwrap().to_string());
    }
    let pixels = &image[at + 1..];
    assert_eq!(parts[0], "P5");
    let (w, h): (usize, usize) = (parts[1].parse().unwrap(), parts[2].parse().unwrap());
    assert_eq!(parts[3], "255");
    assert_eq!(pixels.len(), w * h);
    let mut cells = vec![Cell::Unknown; w * h];
    for row in 0..h {
        for x in 0..w {
            let p = f64::from(pixels[row * w + x]);
            let o = (255.0 - p) / 255.0;
            cells[(h - 1 - row) * w + x] = if o > occ {
                Cell::Occupied
            } else if o < free {
                Cell::Free
            } else {
                Cell::Unknown
            };
        }
    }
    assert_eq!(origin.len(), 3);
    OccupancyGrid {
        resolution,
        origin: Point2::new(origin[0], origin[1]),
        width: w,
        height: h,
        cells,
    }
}

/// The files written for the real map read back, as Nav2 reads them, to the same grid.
#[test]
fn nav2_files_read_back_to_the_grid() {
    let Some(path) = common::data_file("octomap_reference/geb079.bt") else {
        return;
    };
    let tree = read_tree_file(&path).unwrap();
    let dir = common::scratch("grid_nav2");
    for (depth, zmin) in [(16, Some(0.2)), (15, None)] {
        let options = GridOptions {
            zmin,
            zmax: Some(1.5),
            depth,
            unknown: UnknownCells::Unknown,
        };
        let grid = project(&tree, &options).unwrap();
        let (u, f, o) = grid.counts();
        assert!(
            u > 0 && f > 0 && o > 0,
            "a corridor map has all three: {u} {f} {o}"
        );
        let yaml = dir.join(format!("map {depth}.yaml"));
        let image = write_nav2(&grid, &yaml).unwrap();
        assert_eq!(image, dir.join(format!("map {depth}.pgm")));
        let back = read_as_nav2(&yaml);
        assert_eq!((back.width, back.height), (grid.width, grid.height));
        assert_eq!(back.resolution, grid.resolution);
        assert_eq!(back.origin, grid.origin);
        assert!(back.cells == grid.cells, "cells differ after reading back");
    }
}

/// The command line: writes both files, prints JSON with serde_json, refuses a wrong
/// extension and a missing directory before reading the map, and an empty band.
#[test]
fn cli_grid() {
    let Some(path) = common::data_file("octomap_reference/geb079.bt") else {
        return;
    };
    let exe = env!("CARGO_BIN_EXE_octoquant");
    let dir = common::scratch("grid_cli");
    let yaml = dir.join("floor.yaml");
    let out = Command::new(exe)
        .args(["grid", path.to_str().unwrap(), "-o", yaml.to_str().unwrap()])
        .args(["--zmin", "-0.5", "--zmax", "1.5", "--depth", "15", "--json"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json = String::from_utf8(out.stdout).unwrap();
    assert!(
        json.contains("\"width\":") && json.contains("\"occupied\":"),
        "{json}"
    );
    let back = read_as_nav2(&yaml);
    let tree = read_tree_file(&path).unwrap();
    let options = GridOptions {
        zmin: Some(-0.5),
        zmax: Some(1.5),
        depth: 15,
        unknown: UnknownCells::Unknown,
    };
    assert!(back.cells == project(&tree, &options).unwrap().cells);

    let fail = |args: &[&str], needle: &str| {
        let out = Command::new(exe).arg("grid").args(args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr).to_string();
        assert!(
            !out.status.success() && err.contains(needle),
            "{args:?}: {err}"
        );
    };
    // output names are checked first, even with a map that does not exist
    fail(
        &["missing.bt", "-o", dir.join("x.png").to_str().unwrap()],
        ".yaml",
    );
    fail(
        &["missing.bt", "-o", dir.join("no/x.yaml").to_str().unwrap()],
        "no such directory",
    );
    fail(
        &[
            path.to_str().unwrap(),
            "-o",
            yaml.to_str().unwrap(),
            "--zmin",
            "500",
        ],
        "no known voxel",
    );
    fail(
        &[
            path.to_str().unwrap(),
            "-o",
            yaml.to_str().unwrap(),
            "--depth",
            "0",
        ],
        "depth",
    );
    // the band's ends are named as options: not a number, or the wrong way round
    for (args, msg) in [
        (["--zmin", "nan", "--zmax", "1"], "--zmin NaN"),
        (["--zmin", "0", "--zmax", "inf"], "--zmax inf"),
        (
            ["--zmin", "2", "--zmax", "1"],
            "--zmin 2 lies above --zmax 1",
        ),
    ] {
        let mut all = vec![path.to_str().unwrap(), "-o", yaml.to_str().unwrap()];
        all.extend(args);
        fail(&all, msg);
    }
}
