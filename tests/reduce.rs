//! Issue 5: the online grid density reducer on real clouds, the PLY format and `octoquant reduce`.

use crate::common;
use nalgebra::Point3;
use octoquant::formats::ply::{read_ply_f32, write_ply, PlyEncoding};
use octoquant::formats::{read_frames, ReadOptions};
use octoquant_density::{reduce, reduce_points_counted, CentreDistance, DensityGrid, GridSpec};
use std::collections::{HashMap, HashSet};
use std::path::Path;
use std::process::Command;

const TABLE_PCD: &str =
    "pcd/pcl_table_scene_mug_stereo_textured/table_scene_mug_stereo_textured.pcd";
const SCAN_DAT: &str = "lidar3d/octomap_scan_dat/scan.dat.bz2";
const NORLAB_SCANS: &str = "lidar3d/norlab_icp_mapper_example/scans";

fn load(path: &Path) -> Vec<Point3<f32>> {
    read_frames(path, &ReadOptions::default())
        .unwrap_or_else(|e| panic!("{e}"))
        .into_iter()
        .flat_map(|f| f.points)
        .collect()
}

fn f64s(p: &Point3<f32>) -> [f64; 3] {
    [f64::from(p.x), f64::from(p.y), f64::from(p.z)]
}

fn key(p: &Point3<f32>) -> [u32; 3] {
    [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]
}

/// Every reducer property on one real cloud; returns (grid cells, output points).
fn check_real(points: &[Point3<f32>], cell: [f64; 3]) -> (usize, usize) {
    let spec = GridSpec::with_sizes(cell).unwrap();
    let valid = points
        .iter()
        .filter(|p| p.x.is_finite() && p.y.is_finite() && p.z.is_finite())
        .count();
    let (out, counts) = reduce_points_counted(points, cell).unwrap();
    assert_eq!(counts.input as usize, points.len());
    assert_eq!(counts.rejected as usize, points.len() - valid);
    assert_eq!(counts.output as usize, out.len());
    assert!(out.len() as u64 <= counts.grid && counts.grid <= valid as u64);

    // Subset of the input, bit for bit, no duplicates.
    let input: HashSet<[u32; 3]> = points.iter().map(key).collect();
    let mut seen = HashSet::new();
    for p in &out {
        assert!(input.contains(&key(p)), "{p:?} is not an input point");
        assert!(seen.insert(key(p)), "{p:?} emitted twice");
    }

    // The grid stage, for per-cell checks.
    let mut grid = DensityGrid::new(spec.clone());
    grid.extend(points.iter().map(f64s));
    grid.validate().unwrap();
    assert_eq!(grid.len() as u64, counts.grid);

    // Output cells, then: no two output points in neighbouring cells within half a cell on
    // every axis; every cell not output is eliminated by an output neighbour that comes
    // earlier in distance order and is within half a cell.
    let mut out_by_cell: HashMap<[i64; 3], [f64; 3]> = HashMap::new();
    for p in &out {
        let q = f64s(p);
        let i = spec.cell_index(&q).unwrap();
        assert!(
            out_by_cell.insert(i, q).is_none(),
            "two output points in cell {i:?}"
        );
        assert_eq!(
            grid.get(&i).unwrap().point(),
            q,
            "output is not the cell's point"
        );
    }
    let rank = |i: &[i64; 3]| {
        let c = grid.get(i).unwrap();
        (c.distance(), *i)
    };
    let mut eliminated = 0;
    for c in grid.cells() {
        let i = c.index();
        let mut eliminated_by = None;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if (dx, dy, dz) == (0, 0, 0) {
                        continue;
                    }
                    let j = [i[0] + dx, i[1] + dy, i[2] + dz];
                    if let Some(q) = out_by_cell.get(&j) {
                        if spec.within_half_cell(&c.point(), q) {
                            assert!(
                                !out_by_cell.contains_key(&i),
                                "output points {:?} and {q:?} are too close",
                                c.point()
                            );
                            let (dj, jj) = rank(&j);
                            let (di, ii) = rank(&i);
                            if dj.total_cmp(&di).then(jj.cmp(&ii)).is_lt() {
                                eliminated_by = Some(j);
                            }
                        }
                    }
                }
            }
        }
        if !out_by_cell.contains_key(&i) {
            assert!(
                eliminated_by.is_some(),
                "cell {i:?} neither output nor eliminated"
            );
            eliminated += 1;
        }
    }
    assert_eq!(eliminated + out.len(), grid.len());

    // Input order does not matter.
    let reversed: Vec<_> = points.iter().rev().copied().collect();
    let (out_rev, _) = reduce_points_counted(&reversed, cell).unwrap();
    assert_eq!(
        out_rev.iter().map(key).collect::<Vec<_>>(),
        out.iter().map(key).collect::<Vec<_>>()
    );
    (grid.len(), out.len())
}

#[test]
fn issue_5_reduce_table_scene_pcd() {
    let Some(path) = common::data_file(TABLE_PCD) else {
        return;
    };
    let points = load(&path);
    assert_eq!(points.len(), 307_200);
    let valid = points.iter().filter(|p| p.x.is_finite()).count();
    assert_eq!(valid, 209_280, "PROVENANCE: 209 280 valid points");
    let (cells, out) = check_real(&points, [0.01; 3]);
    // A stereo depth frame is dense: 1 cm cells must thin it a lot.
    assert!(cells < valid / 2, "{cells} cells for {valid} points");
    assert!(out < cells);
}

#[test]
fn issue_5_reduce_octomap_scan_dat() {
    let Some(path) = common::data_file(SCAN_DAT) else {
        return;
    };
    let points = load(&path);
    assert_eq!(points.len(), 88_206);
    let (cells, out) = check_real(&points, [0.1, 0.1, 0.05]);
    assert!(out < cells && cells < points.len());
}

#[test]
fn issue_5_reduce_norlab_vtk_scans() {
    let Some(dir) = common::data_file(NORLAB_SCANS) else {
        return;
    };
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "vtk"))
        .collect();
    files.sort();
    assert_eq!(files.len(), 14);
    // The robot stands still: 14 scans of one scene merged in the sensor frame.
    let points: Vec<_> = files.iter().flat_map(|f| load(f)).collect();
    assert!(points.len() > 570_000);
    let (cells, out) = check_real(&points, [0.2; 3]);
    // Repeated scans of a static scene collapse onto far fewer cells.
    assert!(cells * 3 < points.len(), "{cells} cells");
    assert!(out < cells);
}

/// Deleting real points restores the never-inserted state, cell for cell.
#[test]
fn issue_5_deletion_on_real_data() {
    let Some(path) = common::data_file(SCAN_DAT) else {
        return;
    };
    let points: Vec<_> = load(&path).iter().map(f64s).collect();
    let spec = GridSpec::with_sizes([0.2; 3]).unwrap();
    let (kept, extra): (Vec<_>, Vec<_>) = points.iter().enumerate().partition(|(k, _)| k % 3 != 0);
    let mut never = DensityGrid::new(spec.clone());
    never.extend(kept.iter().map(|(_, p)| **p));
    let mut g = DensityGrid::new(spec);
    g.extend(points.iter().copied());
    for (_, p) in &extra {
        assert!(g.remove(p));
    }
    g.validate().unwrap();
    assert_eq!(g.state(), never.state());
    assert_eq!(g.output_cycle(), never.output_cycle());
}

#[test]
fn issue_5_cli_reduce_writes_ply_and_counts() {
    let Some(path) = common::data_file(SCAN_DAT) else {
        return;
    };
    let dir = common::scratch("issue_5_cli_reduce");
    let out = dir.join("scan.ply");
    let o = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .args([
            "reduce",
            path.to_str().unwrap(),
            "--cell",
            "0.1,0.1,0.05",
            "-o",
        ])
        .arg(&out)
        .arg("--json")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json = String::from_utf8(o.stdout).unwrap();
    let field = |name: &str| -> u64 {
        let at = json
            .find(&format!("\"{name}\":"))
            .unwrap_or_else(|| panic!("{json}"));
        json[at + name.len() + 3..]
            .chars()
            .take_while(char::is_ascii_digit)
            .collect::<String>()
            .parse()
            .unwrap()
    };
    let points = load(&path);
    let (want, counts) = reduce_points_counted(&points, [0.1, 0.1, 0.05]).unwrap();
    assert_eq!(field("points"), 88_206);
    assert_eq!(field("grid"), counts.grid);
    assert_eq!(field("reduced"), counts.output);
    assert_eq!(field("eliminated"), counts.grid - counts.output);
    let got = read_ply_f32(&out).unwrap();
    assert_eq!(got, want);

    // The PLY it wrote reads back as an input too (ASCII this time), and reducing a reduced
    // cloud again with the same grid changes nothing.
    let again = dir.join("again.ply");
    let o = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .args([
            "reduce",
            out.to_str().unwrap(),
            "--cell",
            "0.1,0.1,0.05",
            "--ascii",
            "-o",
        ])
        .arg(&again)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(
        text.contains("grid stage:") && text.contains("elimination:"),
        "{text}"
    );
    let mut a: Vec<_> = read_ply_f32(&again).unwrap().iter().map(key).collect();
    let mut b: Vec<_> = want.iter().map(key).collect();
    a.sort();
    b.sort();
    assert_eq!(a, b);

    // Bad arguments fail with a message and leave no output.
    let bad = dir.join("bad.ply");
    let o = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .args([
            "reduce",
            path.to_str().unwrap(),
            "--cell",
            "0.1,-1,0.1",
            "-o",
        ])
        .arg(&bad)
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("cell size"));
    assert!(!bad.exists());
}

/// `reduce --distance`: the paper's Euclidean centre distance by default, cell units on
/// request; on unequal cells of a real scan they keep different points, and each equals the
/// library's grid with that metric.
#[test]
fn issue_27_cli_reduce_centre_distance() {
    let Some(path) = common::data_file(SCAN_DAT) else {
        return;
    };
    let dir = common::scratch("issue_27_cli_reduce_distance");
    let points: Vec<[f64; 3]> = load(&path).iter().map(f64s).collect();
    let cell = [0.1, 0.1, 0.05];
    let mut outputs = Vec::new();
    for (flag, metric) in [
        (None, CentreDistance::Euclidean),
        (Some("cell-units"), CentreDistance::CellUnits),
    ] {
        let out = dir.join(format!("{metric:?}.ply"));
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_octoquant"));
        cmd.args([
            "reduce",
            path.to_str().unwrap(),
            "--cell",
            "0.1,0.1,0.05",
            "-o",
        ])
        .arg(&out);
        if let Some(f) = flag {
            cmd.args(["--distance", f]);
        }
        let o = cmd.output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let spec = GridSpec::with_sizes(cell)
            .unwrap()
            .with_centre_distance(metric);
        let (want, _) = reduce(points.iter().copied(), spec);
        let got: Vec<[f64; 3]> = read_ply_f32(&out).unwrap().iter().map(f64s).collect();
        let want: Vec<[f64; 3]> = want
            .iter()
            .map(|p| p.map(|v| f64::from(v as f32)))
            .collect();
        assert_eq!(got, want, "{metric:?}");
        outputs.push(got);
    }
    assert_ne!(
        outputs[0], outputs[1],
        "the two metrics kept the same points"
    );
}

/// PLY in both encodings through the reducer: same result as from the PCD it came from.
#[test]
fn issue_5_ply_round_trip_of_real_cloud() {
    let Some(path) = common::data_file(TABLE_PCD) else {
        return;
    };
    let points = load(&path);
    let dir = common::scratch("issue_5_ply_round_trip");
    for enc in [PlyEncoding::Ascii, PlyEncoding::BinaryLittleEndian] {
        let p = dir.join(format!("{enc:?}.ply"));
        let mut buf = Vec::new();
        write_ply(&mut buf, &points, enc).unwrap();
        std::fs::write(&p, &buf).unwrap();
        let back = read_ply_f32(&p).unwrap();
        assert_eq!(back.len(), points.len());
        assert!(back
            .iter()
            .zip(&points)
            .all(|(a, b)| { key(a) == key(b) || (a.x.is_nan() && b.x.is_nan()) }));
    }
}
