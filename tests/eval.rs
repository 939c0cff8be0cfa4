//! `octoquant eval` against OctoMap's own `eval_octree_accuracy` (Debian octomap-tools) on a
//! real scan sequence: a `.graph` of the norlab LiDAR scans with their trajectory poses
//! (written by our graph writer, read by both). The counts must be equal and the share
//! correct equal at the six significant digits the tool prints.

use crate::common::{self, scratch};
use octoquant::formats::graph::{write_graph_file, Pose6D, ScanGraph, ScanNode};
use octoquant::formats::vtk::{list_scans, read_trajectory_csv, read_vtk_points_f32};
use std::path::Path;
use std::process::Command;

/// The norlab scans as ScanGraph nodes: points in the scan frame (every `stride`-th), the
/// trajectory pose, node ids 0, 1, ... in time order.
fn norlab_graph(dir: &Path, stride: usize) -> ScanGraph {
    let traj = read_trajectory_csv(&dir.join("trajectory.csv")).unwrap();
    let scans = list_scans(&dir.join("scans")).unwrap();
    assert_eq!(scans.len(), 14);
    let nodes = scans
        .iter()
        .zip(0u32..)
        .map(|((sec, nsec, path), id)| {
            let pose = traj
                .iter()
                .find(|p| p.sec == *sec && p.nanosec == *nsec)
                .expect("a pose per scan");
            let q = pose.rotation.quaternion();
            ScanNode {
                id,
                pose: Pose6D {
                    translation: pose.translation.cast::<f32>(),
                    rotation: nalgebra::Quaternion::new(q.w, q.i, q.j, q.k).cast::<f32>(),
                },
                points: read_vtk_points_f32(path)
                    .unwrap()
                    .into_iter()
                    .step_by(stride)
                    .collect(),
            }
        })
        .collect();
    ScanGraph {
        nodes,
        edges: Vec::new(),
    }
}

/// The tool's figures: (points evaluated, points in graph, correct, wrong, unknown, share).
#[derive(Debug)]
struct ToolFigures {
    points: u64,
    in_graph: u64,
    correct: u64,
    wrong: u64,
    unknown: u64,
    share: f64,
}

fn eval_octree_accuracy(graph: &Path, args: &[&str]) -> ToolFigures {
    let out = Command::new("eval_octree_accuracy")
        .arg(graph)
        .args(args)
        .output()
        .expect("eval_octree_accuracy (apt-get install octomap-tools)");
    assert!(out.status.success(), "{out:?}");
    let text = String::from_utf8_lossy(&out.stdout);
    let after = |prefix: &str| -> &str {
        let at = text
            .find(prefix)
            .unwrap_or_else(|| panic!("no {prefix:?} in {text}"));
        &text[at + prefix.len()..]
    };
    let number = |s: &str| -> String {
        s.trim_start()
            .chars()
            .take_while(|c| c.is_ascii_digit() || "+-.eE".contains(*c) || c.is_alphabetic())
            .collect::<String>()
    };
    let digits = |s: &str| -> u64 {
        let d: String = s
            .trim_start()
            .chars()
            .take_while(char::is_ascii_digit)
            .collect();
        d.parse().unwrap_or_else(|e| panic!("{e}: {s:?}"))
    };
    let int = |prefix: &str| digits(after(prefix));
    let evaluated = after("Finished evaluating ");
    let (points, in_graph) = evaluated.split_once('/').unwrap();
    let share = number(after("% correct: "));
    ToolFigures {
        points: digits(points),
        in_graph: digits(in_graph),
        correct: int("Voxels correct: "),
        wrong: int("#wrong: "),
        unknown: int("#unknown: "),
        share: share.parse().unwrap(),
    }
}

fn octoquant_eval(args: &[&dyn AsRef<std::ffi::OsStr>]) -> serde_json::Value {
    let out = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .arg("eval")
        .args(args)
        .arg("--json")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

fn assert_same(what: &str, ours: &serde_json::Value, theirs: &ToolFigures) {
    let n = |k: &str| {
        ours[k]
            .as_u64()
            .unwrap_or_else(|| panic!("{what}: {k}: {ours}"))
    };
    assert_eq!(
        (
            n("points_evaluated"),
            n("correct"),
            n("wrong"),
            n("unknown")
        ),
        (theirs.points, theirs.correct, theirs.wrong, theirs.unknown),
        "{what}: ours {ours}, the tool's {theirs:?}"
    );
    let share = ours["share_correct"].as_f64().unwrap();
    // the tool prints six significant digits
    assert_eq!(
        format!("{share:.5e}"),
        format!("{:.5e}", theirs.share),
        "{what}"
    );
    // a real evaluation: most voxels checked, most of them right, some wrong
    assert!(
        theirs.correct > 10 * theirs.wrong && theirs.wrong > 0,
        "{what}: {theirs:?}"
    );
}

#[test]
fn eval_matches_eval_octree_accuracy_on_a_real_scan_graph() {
    let Some(dir) = common::data_file("lidar3d/norlab_icp_mapper_example") else {
        return;
    };
    let work = scratch("eval_octree_accuracy");
    let graph = norlab_graph(&dir, 6);
    let file = work.join("norlab.graph");
    write_graph_file(&file, &graph).unwrap();
    let total: u64 = graph.nodes.iter().map(|n| n.points.len() as u64).sum();

    for (res, max_range) in [("0.2", "30"), ("0.1", "12"), ("0.25", "-1")] {
        let what = format!("res {res}, max range {max_range}");
        let theirs = eval_octree_accuracy(&file, &["-res", res, "-m", max_range]);
        assert_eq!(theirs.in_graph, total, "{what}");
        // scans 5 and 10 are held out
        let held: u64 = [4, 9]
            .iter()
            .map(|&i| graph.nodes[i].points.len() as u64)
            .sum();
        assert_eq!(theirs.points, held, "{what}");
        let ours = octoquant_eval(&[&file, &"--res", &res, &"--max-range", &max_range]);
        assert_eq!(ours["scans_inserted"], 12);
        assert_eq!(ours["scans_evaluated"], 2);
        assert_eq!(ours["points_considered"].as_u64(), Some(total));
        assert_same(&what, &ours, &theirs);
    }

    // -n: only the first scans
    let theirs = eval_octree_accuracy(&file, &["-res", "0.2", "-m", "20", "-n", "7"]);
    let ours = octoquant_eval(&[
        &file,
        &"--res",
        &"0.2",
        &"--max-range",
        &"20",
        &"--max-scans",
        &"7",
    ]);
    assert_eq!(ours["scans_evaluated"], 1);
    assert_same("-n 7", &ours, &theirs);

    // A map given: the map of the scans not held out (built by `octoquant map`, saved as .bt)
    // evaluated against the held-out scans gives the tool's figures again, since a .bt keeps
    // every voxel's class.
    let (train, test): (Vec<_>, Vec<_>) = graph
        .nodes
        .iter()
        .cloned()
        .enumerate()
        .partition(|(i, _)| (i + 1) % 5 != 0);
    let split = |nodes: Vec<(usize, ScanNode)>, name: &str| {
        let p = work.join(name);
        let g = ScanGraph {
            nodes: nodes.into_iter().map(|(_, n)| n).collect(),
            edges: Vec::new(),
        };
        write_graph_file(&p, &g).unwrap();
        p
    };
    let (train, test) = (split(train, "train.graph"), split(test, "test.graph"));
    let map = work.join("train.bt");
    let st = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .arg("map")
        .arg(&train)
        .args(["--res", "0.2", "--max-range", "30", "--quiet", "-o"])
        .arg(&map)
        .output()
        .unwrap();
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    let theirs = eval_octree_accuracy(&file, &["-res", "0.2", "-m", "30"]);
    let ours = octoquant_eval(&[&map, &test, &"--max-range", &"30"]);
    assert_eq!(ours["scans_evaluated"], 2);
    assert_same("map given", &ours, &theirs);
}
