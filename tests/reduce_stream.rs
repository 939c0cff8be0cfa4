//! Issue 27: `octoquant reduce --stream`, the density reducer's two threads on real data: the
//! last cycle equals the batch reduction for any piece size and storage, every intermediate
//! cycle is a valid reduction of input points, deleted points are gone.

use crate::common;
use nalgebra::Point3;
use octoquant::formats::ply::{read_ply_f32, write_ply_file, PlyEncoding};
use octoquant::formats::{read_frames, ReadOptions};
use octoquant_density::{reduce, GridSpec};
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const SCAN_DAT: &str = "lidar3d/octomap_scan_dat/scan.dat.bz2";
const NORLAB: &str = "lidar3d/norlab_icp_mapper_example";

fn load(path: &Path) -> Vec<Point3<f32>> {
    read_frames(path, &ReadOptions::default())
        .unwrap_or_else(|e| panic!("{e}"))
        .into_iter()
        .flat_map(|f| f.points)
        .collect()
}

fn key(p: &Point3<f32>) -> [u32; 3] {
    [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]
}

fn f64s(p: &Point3<f32>) -> [f64; 3] {
    [f64::from(p.x), f64::from(p.y), f64::from(p.z)]
}

fn reduce_cmd(input: &Path, out: &Path, extra: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .arg("reduce")
        .arg(input)
        .args(["--cell", "0.1", "--json", "-o"])
        .arg(out)
        .args(extra)
        .output()
        .unwrap()
}

fn json(o: &Output) -> serde_json::Value {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).unwrap()
}

/// The numbered cycle files of `dir`, checked to be `cycle-000001.ply` up without a gap.
fn cycle_files(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    for (k, f) in files.iter().enumerate() {
        assert_eq!(
            f.file_name().unwrap().to_str().unwrap(),
            format!("cycle-{:06}.ply", k + 1)
        );
    }
    files
}

/// A cycle's output: input points, at most one per cell, no two within half a cell on every
/// axis (the guarantee of a read cycle, also of those that ran while input arrived).
fn check_cycle(points: &[Point3<f32>], input: &HashSet<[u32; 3]>, spec: &GridSpec<3>) {
    let mut cells = HashMap::new();
    for p in points {
        assert!(input.contains(&key(p)), "{p:?} is not an input point");
        let q = f64s(p);
        let i = spec.cell_index(&q).unwrap();
        assert!(cells.insert(i, q).is_none(), "two points in cell {i:?}");
    }
    for (i, p) in &cells {
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let j = [i[0] + dx, i[1] + dy, i[2] + dz];
                    if j == *i {
                        continue;
                    }
                    if let Some(q) = cells.get(&j) {
                        assert!(!spec.within_half_cell(p, q), "{p:?} and {q:?} both kept");
                    }
                }
            }
        }
    }
}

/// One input through `reduce` and `reduce --stream` with several piece sizes and both
/// storages: the streamed output file is byte for byte the batch one (so it does not depend
/// on pieces, storage or the threads' timing), and every cycle written on the way is valid.
fn stream_equals_batch(name: &str, input: &Path, extra: &[&str]) {
    let dir = common::scratch(name);
    let batch = dir.join("batch.ply");
    let b = json(&reduce_cmd(input, &batch, extra));
    let batch_bytes = std::fs::read(&batch).unwrap();
    let points = load(input);
    let input_keys: HashSet<[u32; 3]> = points.iter().map(key).collect();
    let spec = GridSpec::with_sizes([0.1; 3]).unwrap();
    for (chunk, storage) in [
        ("997", "one-node"),
        ("20000", "all-members"),
        ("1000000", "one-node"),
    ] {
        let out = dir.join(format!("stream-{chunk}-{storage}.ply"));
        let cycles = dir.join(format!("cycles-{chunk}-{storage}"));
        let mut args = vec![
            "--stream",
            "--chunk",
            chunk,
            "--storage",
            storage,
            "--every-cycle",
        ];
        args.extend(extra);
        let mut cmd = reduce_cmd_with_dir(input, &out, &args, &cycles);
        let s = json(&cmd.output().unwrap());
        assert_eq!(
            std::fs::read(&out).unwrap(),
            batch_bytes,
            "chunk {chunk} {storage}"
        );
        for f in ["points", "rejected", "grid", "eliminated", "reduced"] {
            assert_eq!(s[f], b[f], "{f}, chunk {chunk} {storage}");
        }
        assert_eq!(s["storage"], storage);
        let stored = s["stored"].as_u64().unwrap();
        if storage == "one-node" {
            assert_eq!(stored, b["grid"].as_u64().unwrap());
        } else {
            assert_eq!(
                stored,
                b["points"].as_u64().unwrap() - b["rejected"].as_u64().unwrap()
            );
        }
        let files = cycle_files(&cycles);
        assert_eq!(files.len() as u64, s["cycles"].as_u64().unwrap());
        assert_eq!(std::fs::read(files.last().unwrap()).unwrap(), batch_bytes);
        if chunk == "997" {
            // Small pieces: the output thread ran cycles before the input ended.
            assert!(files.len() >= 2, "{} cycles", files.len());
        }
        for f in &files {
            check_cycle(&read_ply_f32(f).unwrap(), &input_keys, &spec);
        }
    }
}

fn reduce_cmd_with_dir(input: &Path, out: &Path, args: &[&str], dir: &Path) -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_octoquant"));
    cmd.arg("reduce")
        .arg(input)
        .args(["--cell", "0.1", "--json", "-o"])
        .arg(out);
    // `--every-cycle` is last in `args`: its value follows.
    cmd.args(args.iter().take_while(|a| **a != "--every-cycle"));
    cmd.arg("--every-cycle").arg(dir);
    cmd.args(args.iter().skip_while(|a| **a != "--every-cycle").skip(1));
    cmd
}

#[test]
fn issue_27_reduce_stream_equals_batch_on_scan_dat() {
    let Some(path) = common::data_file(SCAN_DAT) else {
        return;
    };
    stream_equals_batch("issue_27_stream_scan_dat", &path, &[]);
}

/// A VTK sequence is read one scan (frame) at a time.
#[test]
fn issue_27_reduce_stream_equals_batch_on_norlab_frames() {
    let Some(path) = common::data_file(NORLAB) else {
        return;
    };
    stream_equals_batch("issue_27_stream_norlab", &path, &[]);
}

/// `--delete`: the deleted points are absent and the output is the batch reduction of the
/// input without them; points that were never input are counted as not stored; the
/// one-node storage refuses deletion and writes nothing.
#[test]
fn issue_27_reduce_stream_delete() {
    let Some(path) = common::data_file(SCAN_DAT) else {
        return;
    };
    let dir = common::scratch("issue_27_stream_delete");
    let points = load(&path);
    let mut count: HashMap<[u32; 3], usize> = HashMap::new();
    for p in &points {
        *count.entry(key(p)).or_default() += 1;
    }
    // Every third point that occurs once, and the batch output's first hundred points
    // (chosen points: deleting them changes which point a cell keeps).
    let batch = dir.join("batch.ply");
    json(&reduce_cmd(&path, &batch, &[]));
    let mut delete: Vec<Point3<f32>> = read_ply_f32(&batch).unwrap()[..100].to_vec();
    let chosen: HashSet<[u32; 3]> = delete.iter().map(key).collect();
    delete.extend(
        points
            .iter()
            .step_by(3)
            .filter(|p| count[&key(p)] == 1 && !chosen.contains(&key(p))),
    );
    let gone: HashSet<[u32; 3]> = delete.iter().map(key).collect();
    assert_eq!(gone.len(), delete.len());
    let strangers = [Point3::new(1e4f32, 0.5, 0.5), Point3::new(-3.0, 1e5, 2.0)];
    let mut file_points = delete.clone();
    file_points.extend(strangers);
    let delete_file = dir.join("delete.ply");
    write_ply_file(&delete_file, &file_points, PlyEncoding::Ascii).unwrap();

    let out = dir.join("out.ply");
    let arg = delete_file.to_str().unwrap();
    let s = json(&reduce_cmd(
        &path,
        &out,
        &["--stream", "--chunk", "5000", "--delete", arg],
    ));
    assert_eq!(s["storage"], "all-members");
    assert_eq!(s["deleted"].as_u64().unwrap(), delete.len() as u64);
    assert_eq!(s["not_deleted"].as_u64().unwrap(), strangers.len() as u64);
    let got = read_ply_f32(&out).unwrap();
    for p in &got {
        assert!(!gone.contains(&key(p)), "deleted point {p:?} in the output");
    }
    let rest = points.iter().filter(|p| !gone.contains(&key(p))).map(f64s);
    let (want, _) = reduce(rest, GridSpec::with_sizes([0.1; 3]).unwrap());
    let got: Vec<[f64; 3]> = got.iter().map(f64s).collect();
    assert_eq!(got, want);

    // Explicit all-members storage: the same; one node per cell: refused, nothing written.
    let again = dir.join("again.ply");
    let o = reduce_cmd(
        &path,
        &again,
        &["--stream", "--storage", "all-members", "--delete", arg],
    );
    json(&o);
    assert_eq!(std::fs::read(&again).unwrap(), std::fs::read(&out).unwrap());
    let refused = dir.join("refused.ply");
    let o = reduce_cmd(
        &path,
        &refused,
        &["--stream", "--storage", "one-node", "--delete", arg],
    );
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--delete needs --storage all-members"));
    assert!(!refused.exists());
    // The stream options need --stream, and a piece holds at least one point.
    let o = reduce_cmd(&path, &refused, &["--delete", arg]);
    assert!(!o.status.success());
    let o = reduce_cmd(&path, &refused, &["--stream", "--chunk", "0"]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--chunk"));
    assert!(!refused.exists());
    // A cycle directory that holds an earlier run's cycle files is refused before any output.
    let used = dir.join("used");
    std::fs::create_dir_all(&used).unwrap();
    std::fs::write(used.join("cycle-000001.ply"), b"old").unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .arg("reduce")
        .arg(&path)
        .args(["--cell", "0.1", "--stream", "-o"])
        .arg(&refused)
        .arg("--every-cycle")
        .arg(&used)
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("already holds cycle files"));
    assert!(!refused.exists());
    assert_eq!(
        std::fs::read(used.join("cycle-000001.ply")).unwrap(),
        b"old"
    );
    // A delete file that cannot be read fails before any output.
    let o = reduce_cmd(
        &path,
        &refused,
        &["--stream", "--delete", "no-such-file.ply"],
    );
    assert!(!o.status.success());
    assert!(!refused.exists());
}
