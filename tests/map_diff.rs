//! Whole maps from real sensor files, through octoquant's readers and pipeline, against the
//! real OctoMap: graph2tree for ScanGraphs, the project's reference program for the rest.
//! `.bt` and `.ot` must be byte-identical for every resolution, max range and discretize
//! setting, in every exact insertion mode, whatever the thread count.

use crate::common::{self, first_diff};
use octoquant::formats::graph::{graph_from_frames, write_graph_file};
use octoquant::formats::{read_frames, ReadOptions, TumOptions};
use octoquant::octree::io::{write_bt, write_ot};
use octoquant::pipeline::{InsertMode, Mapper, MapperOptions};
use octoquant::Frame;
use std::path::Path;
use std::process::Command;

/// Build a map with octoquant; returns (.ot bytes, .bt bytes).
fn ours(
    frames: &[Frame],
    res: f64,
    max_range: Option<f64>,
    mode: InsertMode,
    threads: usize,
) -> (Vec<u8>, Vec<u8>) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let mut m = Mapper::new(MapperOptions {
            resolution: res,
            max_range,
            mode,
            ..MapperOptions::default()
        })
        .unwrap();
        if threads > 1 {
            // the pipelined path (rays of the next frame while the tree takes this one)
            m.insert_frames(frames);
        } else {
            for f in frames {
                m.insert(f);
            }
        }
        let mut tree = m.into_tree();
        let (mut ot, mut bt) = (Vec::new(), Vec::new());
        write_ot(&tree, &mut ot).unwrap();
        write_bt(&mut tree, &mut bt).unwrap();
        (ot, bt)
    })
}

/// OctoMap through graph2tree on a .graph file; returns (.ot, .bt).
fn graph2tree(
    graph: &Path,
    global: bool,
    res: f64,
    max_range: Option<f64>,
    discretize: bool,
    dir: &Path,
) -> (Vec<u8>, Vec<u8>) {
    let out = dir.join("g2t.bt");
    let mut cmd = Command::new("graph2tree");
    cmd.arg("-i")
        .arg(graph)
        .arg("-o")
        .arg(&out)
        .args(["-res", &format!("{res:.17e}")]);
    if global {
        cmd.arg("-g");
    }
    if let Some(m) = max_range {
        cmd.args(["-m", &format!("{m:.17e}")]);
    }
    if discretize {
        cmd.arg("-discretize");
    }
    let st = cmd
        .output()
        .expect("graph2tree (apt-get install octomap-tools)");
    assert!(
        st.status.success(),
        "graph2tree failed: {}",
        String::from_utf8_lossy(&st.stderr)
    );
    let ot = std::fs::read(dir.join("g2t.bt.ot")).unwrap();
    (ot, std::fs::read(&out).unwrap())
}

/// OctoMap through the reference program on a .frames file; returns (.ot, .bt).
fn reference(
    refprog: &Path,
    frames_file: &Path,
    res: f64,
    max_range: Option<f64>,
    discretize: bool,
    dir: &Path,
) -> (Vec<u8>, Vec<u8>) {
    let mut ins = format!("insert {}", frames_file.display());
    if let Some(m) = max_range {
        ins.push_str(&format!(" maxrange {m:.17e}"));
    }
    if discretize {
        ins.push_str(" discretize");
    }
    let (ot, bt) = (dir.join("ref.ot"), dir.join("ref.bt"));
    let script = format!(
        "tree {res:.17e}\n{ins}\nwrite_ot {}\nwrite_bt {}\n",
        ot.display(),
        bt.display()
    );
    let sp = dir.join("script.txt");
    std::fs::write(&sp, script).unwrap();
    let out = Command::new(refprog)
        .arg("script")
        .arg(&sp)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    (std::fs::read(ot).unwrap(), std::fs::read(bt).unwrap())
}

/// Compare every exact mode with OctoMap over the resolution / max range / discretize matrix.
fn check_matrix(
    name: &str,
    frames: &[Frame],
    max_range: f64,
    mut octomap: impl FnMut(f64, Option<f64>, bool) -> (Vec<u8>, Vec<u8>),
) {
    let points: usize = frames.iter().map(|f| f.points.len()).sum();
    assert!(points > 1000, "{name}: only {points} points");
    for res in [0.05, 0.1, 0.2] {
        for mr in [None, Some(max_range)] {
            for discretize in [false, true] {
                let (rot, rbt) = octomap(res, mr, discretize);
                let modes: &[InsertMode] = if discretize {
                    &[InsertMode::Discretize, InsertMode::Quantized]
                } else {
                    &[InsertMode::Exact]
                };
                for &mode in modes {
                    for threads in [1, 2] {
                        let (ot, bt) = ours(frames, res, mr, mode, threads);
                        let what =
                            format!("{name} res {res} max range {mr:?} {mode:?} {threads} threads");
                        assert!(ot == rot, "{what}: .ot {}", first_diff(&ot, &rot));
                        assert!(bt == rbt, "{what}: .bt {}", first_diff(&bt, &rbt));
                    }
                }
            }
        }
    }
}

#[test]
fn spherical_scan_graph_matches_graph2tree() {
    let Some(graph) = common::data_file("octomap_reference/spherical_scan.graph") else {
        return;
    };
    let frames = read_frames(&graph, &ReadOptions::default()).unwrap();
    let dir = common::scratch("map_diff_sph");
    check_matrix("spherical_scan.graph", &frames, 3.0, |res, mr, disc| {
        graph2tree(&graph, false, res, mr, disc, &dir)
    });
}

#[test]
fn scan_dat_matches_graph2tree() {
    let Some(dat) = common::data_file("lidar3d/octomap_scan_dat/scan.dat.bz2") else {
        return;
    };
    let frames = read_frames(&dat, &ReadOptions::default()).unwrap();
    assert_eq!(frames[0].points.len(), 88_206);
    let dir = common::scratch("map_diff_scan");
    // our .graph writer feeds graph2tree (-g: points already in world coordinates)
    let graph = dir.join("scan.graph");
    write_graph_file(&graph, &graph_from_frames(&frames)).unwrap();
    check_matrix("scan.dat", &frames, 10.0, |res, mr, disc| {
        graph2tree(&graph, true, res, mr, disc, &dir)
    });
}

fn subsample(frames: Vec<Frame>, keep_frames: usize, stride: usize) -> Vec<Frame> {
    frames
        .into_iter()
        .take(keep_frames)
        .map(|f| Frame {
            points: f.points.into_iter().step_by(stride).collect(),
            ..f
        })
        .collect()
}

#[test]
fn norlab_lidar_sequence_matches_octomap() {
    let Some(refprog) = common::reference_program() else {
        return;
    };
    let Some(dir_in) = common::data_file("lidar3d/norlab_icp_mapper_example") else {
        return;
    };
    let frames = read_frames(&dir_in, &ReadOptions::default()).unwrap();
    assert_eq!(frames.len(), 14);
    // 3 frames, every 8th point: ~15k rays of up to 195 m keep OctoMap's time reasonable
    let frames = subsample(frames, 3, 8);
    let dir = common::scratch("map_diff_norlab");
    let ff = dir.join("norlab.frames");
    octoquant::formats::frames::write_frames_file(&ff, &frames).unwrap();
    check_matrix("norlab", &frames, 20.0, |res, mr, disc| {
        reference(&refprog, &ff, res, mr, disc, &dir)
    });
}

/// The first `keep` of the 10 TUM depth frames read every `pixel_step`-th pixel, written as a
/// .frames file in a new scratch directory `scratch`: (frames, directory, file); `None`
/// without the shared data.
fn tum_frames_file(
    pixel_step: u32,
    keep: usize,
    scratch: &str,
) -> Option<(Vec<Frame>, std::path::PathBuf, std::path::PathBuf)> {
    let assoc = common::data_file("rgbd/tum_fr2_pioneer_slam2_subset/my_association.txt")?;
    let opts = ReadOptions {
        tum: TumOptions {
            pixel_step,
            ..TumOptions::default()
        },
        ..ReadOptions::default()
    };
    let frames = read_frames(&assoc, &opts).unwrap();
    assert_eq!(frames.len(), 10);
    let frames = subsample(frames, keep, 1);
    let dir = common::scratch(scratch);
    let ff = dir.join("tum.frames");
    octoquant::formats::frames::write_frames_file(&ff, &frames).unwrap();
    Some((frames, dir, ff))
}

#[test]
fn tum_rgbd_frames_match_octomap() {
    let Some(refprog) = common::reference_program() else {
        return;
    };
    let Some((frames, dir, ff)) = tum_frames_file(6, 4, "map_diff_tum") else {
        return;
    };
    check_matrix("tum", &frames, 4.0, |res, mr, disc| {
        reference(&refprog, &ff, res, mr, disc, &dir)
    });
}

/// Full-resolution TUM depth frames carry their pixel grid, so exact insertion walks most
/// rays only from where their neighbours stop covering them: the maps stay byte-identical to
/// OctoMap's, and the key sets to those of the plain `computeUpdate`, while most rays skip.
#[test]
fn tum_full_frames_skip_ray_heads_and_match_octomap() {
    let Some(assoc) = common::data_file("rgbd/tum_fr2_pioneer_slam2_subset/my_association.txt")
    else {
        return;
    };
    let frames = read_frames(&assoc, &ReadOptions::default()).unwrap();
    assert_eq!(frames.len(), 10);
    for f in &frames {
        assert!(f.camera.is_some(), "TUM frames carry their pixels");
        for (res, mr) in [(0.05, None), (0.02, Some(2.0)), (0.1, None)] {
            assert_grid_path_is_plain(f, res, mr);
        }
    }
    let Some(refprog) = common::reference_program() else {
        return;
    };
    let frames = subsample(frames, 2, 1);
    let dir = common::scratch("map_diff_tum_full");
    let ff = dir.join("tum.frames");
    octoquant::formats::frames::write_frames_file(&ff, &frames).unwrap();
    for mr in [None, Some(2.5)] {
        let what = format!("tum full frames, max range {mr:?}");
        assert_exact_is_octomaps(&refprog, &frames, &ff, &dir, 0.05, mr, &what);
    }
}

/// The key sets of `f` (a frame with its pixel grid) at `res` and max range `mr` through
/// the depth-image path equal the plain `computeUpdate`'s, with the same counts, while more
/// than half the rays skip their heads.
fn assert_grid_path_is_plain(f: &Frame, res: f64, mr: Option<f64>) {
    use octoquant_raycast::{compute_update_f32, compute_update_grid_f32, ScanUpdate};
    let camera = f.camera.as_ref().expect("a frame with its pixels");
    let conv = octoquant::octree::KeyConverter::new(res).unwrap();
    let (mut plain, mut fast) = (ScanUpdate::new(), ScanUpdate::new());
    let a = compute_update_f32(&conv, &f.points, &f.origin, mr, &mut plain);
    let b = compute_update_grid_f32(&conv, &f.points, &camera.grid(), &f.origin, mr, &mut fast);
    assert!(
        b.heads_skipped * 2 > b.rays,
        "res {res}: {} of {} rays skipped their heads",
        b.heads_skipped,
        b.rays
    );
    assert_eq!(
        (a.rays, a.non_finite, a.free, a.occupied),
        (b.rays, b.non_finite, b.free, b.occupied)
    );
    assert!(
        plain.free_bricks() == fast.free_bricks(),
        "res {res}: free sets differ"
    );
    assert!(plain.occupied_bricks() == fast.occupied_bricks());
}

/// Exact insertion of `frames` (also written to `ff`) at `res` and max range `mr`, with one
/// thread and two, gives OctoMap's `.ot` and `.bt` bytes.
fn assert_exact_is_octomaps(
    refprog: &Path,
    frames: &[Frame],
    ff: &Path,
    dir: &Path,
    res: f64,
    mr: Option<f64>,
    what: &str,
) {
    let (rot, rbt) = reference(refprog, ff, res, mr, false, dir);
    for threads in [1, 2] {
        let (ot, bt) = ours(frames, res, mr, InsertMode::Exact, threads);
        let what = format!("{what}, {threads} threads");
        assert!(ot == rot, "{what}: .ot {}", first_diff(&ot, &rot));
        assert!(bt == rbt, "{what}: .bt {}", first_diff(&bt, &rbt));
    }
}

/// An organised PCD (PCL's stereo table scene, 640 x 480 points in pixel order) gets a pinhole
/// camera fitted to its points, so exact insertion skips the ray heads neighbouring pixels
/// cover, as for TUM depth images: the key sets of the plain `computeUpdate`, and maps
/// byte-identical to OctoMap's.
#[test]
fn organized_pcd_skips_ray_heads_and_matches_octomap() {
    let Some(pcd) = common::data_file(
        "pcd/pcl_table_scene_mug_stereo_textured/table_scene_mug_stereo_textured.pcd",
    ) else {
        return;
    };
    let frames = read_frames(&pcd, &ReadOptions::default()).unwrap();
    assert_eq!(frames.len(), 1);
    let f = &frames[0];
    let camera = f
        .camera
        .as_ref()
        .expect("an organised depth cloud gets a camera");
    let c = &camera.camera;
    assert_eq!((c.width, c.height), (640, 480));
    assert_eq!(camera.pixels.len(), f.points.len());
    // the stereo rig's focal length and principal point, as the points imply them
    assert!(
        (c.fx - 964.36).abs() < 0.05 && (c.fy - 964.36).abs() < 0.05,
        "{c:?}"
    );
    for (res, mr) in [(0.01, None), (0.005, Some(1.5)), (0.02, None)] {
        assert_grid_path_is_plain(f, res, mr);
    }
    let Some(refprog) = common::reference_program() else {
        return;
    };
    let dir = common::scratch("map_diff_organized_pcd");
    let ff = dir.join("table.frames");
    octoquant::formats::frames::write_frames_file(&ff, &frames).unwrap();
    assert_exact_is_octomaps(
        &refprog,
        &frames,
        &ff,
        &dir,
        0.01,
        None,
        "organised table scene",
    );
}

/// The CLI end to end: `octoquant map` on the norlab directory writes the same .bt as the
/// library, and reports what it skipped.
#[test]
fn cli_map_on_real_files() {
    let Some(dat) = common::data_file("lidar3d/octomap_scan_dat/scan.dat.bz2") else {
        return;
    };
    let Some(expected) = common::data_file("octomap_reference/expected/scan_r01_m10.bt") else {
        return;
    };
    let dir = common::scratch("map_cli");
    let out = dir.join("m.bt");
    let o = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .arg("map")
        .arg(&dat)
        .args(["--res", "0.1", "--max-range", "10", "--json", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json = String::from_utf8(o.stdout).unwrap();
    assert!(
        json.contains("\"frames\":1") && json.contains("\"points\":88206"),
        "{json}"
    );
    // a LiDAR scan has no pixel grid: every ray is walked whole
    assert_eq!(json_count(&json, "heads_skipped"), Some(0), "{json}");
    assert_eq!(
        std::fs::read(&out).unwrap(),
        std::fs::read(expected).unwrap()
    );
    // TUM depth frames: most rays skip their heads, and the summary says how many
    if let Some(assoc) = common::data_file("rgbd/tum_fr2_pioneer_slam2_subset/my_association.txt") {
        let o = Command::new(env!("CARGO_BIN_EXE_octoquant"))
            .arg("map")
            .arg(&assoc)
            .args(["--res", "0.05", "--json", "-o"])
            .arg(dir.join("tum.bt"))
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let json = String::from_utf8(o.stdout).unwrap();
        let rays = json_count(&json, "rays").unwrap();
        let skipped = json_count(&json, "heads_skipped").unwrap();
        assert_eq!(rays, 2_573_870, "{json}");
        assert!(skipped * 2 > rays && skipped < rays, "{json}");
    }
    // a missing input names the file
    let bad = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .args(["map", "/nonexistent/scan.pcd", "-o"])
        .arg(dir.join("x.bt"))
        .output()
        .unwrap();
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("/nonexistent/scan.pcd"));
    assert!(!dir.join("x.bt").exists());
}

/// The whole number after `"key":` in a one-line JSON object.
fn json_count(json: &str, key: &str) -> Option<usize> {
    let at = json.find(&format!("\"{key}\":"))? + key.len() + 3;
    let digits: String = json[at..]
        .chars()
        .take_while(char::is_ascii_digit)
        .collect();
    digits.parse().ok()
}

/// A failing command prints the error and each cause once, on one line, naming the file.
#[test]
fn cli_errors_name_each_cause_once() {
    let dir = common::scratch("cli_errors");
    for args in [
        vec!["info".to_string(), "/nonexistent/map.bt".to_string()],
        vec![
            "map".to_string(),
            "/nonexistent/scan.graph".to_string(),
            "-o".to_string(),
            dir.join("x.bt").display().to_string(),
        ],
        // the built-in scene, written where no directory is
        vec![
            "map".to_string(),
            "--res".to_string(),
            "0.5".to_string(),
            "-o".to_string(),
            "/nonexistent/dir/map.bt".to_string(),
        ],
    ] {
        let o = Command::new(env!("CARGO_BIN_EXE_octoquant"))
            .args(&args)
            .output()
            .unwrap();
        assert!(!o.status.success(), "{args:?}");
        let stderr = String::from_utf8_lossy(&o.stderr);
        let errors: Vec<&str> = stderr
            .lines()
            .filter(|l| l.starts_with("octoquant: error:"))
            .collect();
        assert_eq!(errors.len(), 1, "{args:?}: {stderr}");
        assert!(errors[0].contains("/nonexistent/"), "{args:?}: {stderr}");
        assert_eq!(
            errors[0].matches("(os error 2)").count(),
            1,
            "{args:?}: {stderr}"
        );
    }
}

/// Output into a pipe whose reader has gone (`octoquant info m.bt | head -0`) ends the program
/// quietly with SIGPIPE's status, 141, instead of a panic; a stderr whose reader has gone
/// loses the status lines, and the run goes on.
#[test]
fn cli_output_into_a_closed_pipe_is_not_a_panic() {
    let dir = common::scratch("cli_closed_pipe");
    let map = dir.join("m.bt");
    let made = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .args(["map", "--res", "0.5", "-o"])
        .arg(&map)
        .output()
        .unwrap();
    assert!(
        made.status.success(),
        "{}",
        String::from_utf8_lossy(&made.stderr)
    );
    for args in [vec!["info"], vec!["info", "--json"]] {
        let (reader, writer) = std::io::pipe().unwrap();
        drop(reader);
        let o = Command::new(env!("CARGO_BIN_EXE_octoquant"))
            .args(&args)
            .arg(&map)
            .stdout(writer)
            .stderr(std::process::Stdio::piped())
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(141), "{args:?}: {stderr}");
        assert!(stderr.is_empty(), "{args:?}: {stderr}");
    }
    // status lines go to stderr: a stderr whose reader has gone loses them, not the run
    let ot = dir.join("m.ot");
    let again = dir.join("again.bt");
    for (args, out) in [
        (vec!["map", "--res", "0.5", "-o"], &again),
        (vec!["convert", map.to_str().unwrap()], &ot),
    ] {
        let (reader, writer) = std::io::pipe().unwrap();
        drop(reader);
        let o = Command::new(env!("CARGO_BIN_EXE_octoquant"))
            .args(&args)
            .arg(out)
            .stderr(writer)
            .output()
            .unwrap();
        assert!(o.status.success(), "{args:?}: {:?}", o.status);
        assert!(
            std::fs::metadata(out).is_ok_and(|m| m.len() > 0),
            "{args:?}"
        );
    }
    assert_eq!(std::fs::read(&again).unwrap(), std::fs::read(&map).unwrap());
}

/// `octoquant map bag.mcap --topic T` works like any other input: the real Ouster recording
/// gives two frames holding the non-zero returns of its two clouds.
#[test]
fn cli_map_reads_a_ros_bag() {
    let Some(bag) = common::data_file("mcap/pointcloudset_ouster_os1/test.mcap") else {
        return;
    };
    let dir = common::scratch("map_cli_mcap");
    let out = dir.join("bag.bt");
    let o = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .arg("map")
        .arg(&bag)
        .args([
            "--topic",
            "/os1_cloud_node/points",
            "--res",
            "0.1",
            "--json",
            "-o",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json = String::from_utf8(o.stdout).unwrap();
    assert!(json.contains("\"frames\":2"), "{json}");
    assert!(
        json.contains(&format!("\"points\":{}", 45_716 + 45_809)),
        "{json}"
    );
    let tree = octoquant::treefile::read_tree_file(&out).unwrap();
    let occupied = tree.counts().occupied_leaves;
    assert!(occupied > 1_000, "{occupied} occupied leaves");
    // an unknown topic names the topics the bag has
    let bad = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .arg("map")
        .arg(&bag)
        .args(["--topic", "/nope", "-o"])
        .arg(dir.join("y.bt"))
        .output()
        .unwrap();
    assert!(!bad.status.success());
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(
        err.contains("/nope") && err.contains("/os1_cloud_node/points"),
        "{err}"
    );
}

/// `octoquant bench` on real multi-frame data with the reference program: the exact and
/// quantized runs (1 and 2 threads, the latter pipelined) write OctoMap's `.bt` byte for byte,
/// the class agreement it reports is 1 for a map with itself and a real share for the
/// Bresenham map, and it counts the exact rays that skipped their heads.
#[test]
fn cli_bench_matches_octomap_and_measures_agreement() {
    let Some(assoc) = common::data_file("rgbd/tum_fr2_pioneer_slam2_subset/my_association.txt")
    else {
        return;
    };
    let Some(reference) = common::reference_program() else {
        return;
    };
    let o = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .arg("bench")
        .arg(&assoc)
        .args(["--res", "0.05", "--frames", "3", "--pixel-step", "8"])
        .args(["--threads", "2", "--repeat", "1", "--json", "--reference"])
        .arg(&reference)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json = String::from_utf8(o.stdout).unwrap();
    let field = |run: &str, name: &str| -> String {
        let at = run
            .find(&format!("\"{name}\":"))
            .unwrap_or_else(|| panic!("{name} in {run}"));
        run[at + name.len() + 3..]
            .split([',', '}'])
            .next()
            .unwrap()
            .to_string()
    };
    let runs: Vec<&str> = json.split("{\"mode\":").skip(1).collect();
    assert_eq!(runs.len(), 6, "{json}");
    for run in &runs {
        let agree: f64 = field(run, "class_agreement_with_exact").parse().unwrap();
        let agree_q: f64 = field(run, "class_agreement_with_quantized")
            .parse()
            .unwrap();
        let rays: usize = field(run, "rays").parse().unwrap();
        let skipped: usize = field(run, "heads_skipped").parse().unwrap();
        if run.starts_with("\"exact\"") {
            assert_eq!(field(run, "bt_identical_to_octomap"), "true", "{run}");
            assert_eq!(agree, 1.0);
            // depth frames: some rays skip their heads, with either thread count
            assert!(skipped > 0 && skipped < rays, "{run}");
        } else {
            // the quantized modes cast one ray per voxel, without the pixel grid
            assert_eq!(skipped, 0, "{run}");
        }
        if run.starts_with("\"exact\"") {
        } else if run.starts_with("\"quantized\"") {
            assert_eq!(field(run, "bt_identical_to_octomap"), "true", "{run}");
            assert_eq!(agree_q, 1.0);
        } else {
            assert!(run.starts_with("\"quantized+bresenham\""), "{run}");
            assert!(agree_q > 0.5 && agree_q < 1.0, "{run}");
        }
    }
}

/// Kwon and Yoon's sensor model (`--sensor-model kwon-yoon-2015`) on real depth frames: the
/// map equals OctoMap's given the paper's numbers through its setters (log-odds 0.2 / -0.1 as
/// probabilities, clamps 0.1 / 0.9, written here from the paper, not from the preset), differs
/// from the default model's map, and `bench` gives OctoMap the same model (its exact and
/// quantized maps stay identical to OctoMap's).
#[test]
fn cli_kwon_yoon_sensor_model_matches_octomap() {
    let Some(refprog) = common::reference_program() else {
        return;
    };
    let Some((_, dir, ff)) = tum_frames_file(8, 3, "map_diff_kwon_yoon") else {
        return;
    };
    let logistic = |l: f64| 1.0 / (1.0 + (-l).exp());
    let (hit, miss) = (logistic(0.2), logistic(-0.1));
    let (rot, rbt) = (dir.join("ref.ot"), dir.join("ref.bt"));
    let script = format!(
        "tree {:.17e}\nparams {hit:.17e} {miss:.17e} {:.17e} {:.17e} {:.17e}\ninsert {}\nwrite_ot {}\nwrite_bt {}\n",
        0.05,
        0.1,
        0.9,
        0.5,
        ff.display(),
        rot.display(),
        rbt.display()
    );
    let sp = dir.join("script.txt");
    std::fs::write(&sp, script).unwrap();
    let out = Command::new(&refprog)
        .arg("script")
        .arg(&sp)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // (.ot, .bt) of `octoquant map` with a sensor model
    let map = |model: &str| {
        let (ot, bt) = (
            dir.join(format!("{model}.ot")),
            dir.join(format!("{model}.bt")),
        );
        let o = Command::new(env!("CARGO_BIN_EXE_octoquant"))
            .arg("map")
            .arg(&ff)
            .args(["--res", "0.05", "--quiet", "--sensor-model", model, "--ot"])
            .arg(&ot)
            .arg("-o")
            .arg(&bt)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        (std::fs::read(ot).unwrap(), std::fs::read(bt).unwrap())
    };
    let (theirs_ot, theirs_bt) = (std::fs::read(&rot).unwrap(), std::fs::read(&rbt).unwrap());
    let (ot, bt) = map("kwon-yoon-2015");
    assert!(ot == theirs_ot, ".ot {}", first_diff(&ot, &theirs_ot));
    assert!(bt == theirs_bt, ".bt {}", first_diff(&bt, &theirs_bt));
    let (default_ot, _) = map("octomap");
    assert!(default_ot != ot, "the sensor model changed nothing");

    let o = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .arg("bench")
        .arg(&ff)
        .args(["--res", "0.05", "--sensor-model", "kwon-yoon-2015"])
        .args(["--threads", "1", "--repeat", "1", "--json", "--reference"])
        .arg(&refprog)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json = String::from_utf8(o.stdout).unwrap();
    let identical = json.matches("\"bt_identical_to_octomap\":true").count();
    assert_eq!(identical, 2, "exact and quantized: {json}");
}

/// Negative numbers are values: `--res -0.1` is refused for its value (before any input is
/// read), and `--max-range` of 0 or less means no range limit, as OctoMap's -1.
#[test]
fn cli_negative_numbers_are_values() {
    let Some(scan) = common::data_file("lidar3d/octomap_scan_dat/scan.dat.bz2") else {
        return;
    };
    let exe = env!("CARGO_BIN_EXE_octoquant");
    let dir = common::scratch("cli_negative_numbers");
    let o = Command::new(exe)
        .args(["map", "missing-input.pcd", "--res", "-0.1", "-o"])
        .arg(dir.join("x.bt"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("--res -0.1"), "{err}");
    let map = |extra: &[&str], out: &str| {
        let o = Command::new(exe)
            .arg("map")
            .arg(&scan)
            .args(["--res", "0.4"])
            .args(extra)
            .arg("-o")
            .arg(dir.join(out))
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        std::fs::read(dir.join(out)).unwrap()
    };
    let none = map(&[], "none.bt");
    assert_eq!(map(&["--max-range", "-1"], "minus.bt"), none);
    assert_eq!(map(&["--max-range", "0"], "zero.bt"), none);
    assert_ne!(map(&["--max-range", "5"], "five.bt"), none);
}
