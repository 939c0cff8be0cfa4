//! Streaming input: `Mapper::insert_stream` over `formats::frame_stream` builds the same tree,
//! byte for byte, as reading every frame first, with one thread or two, on the real data and
//! the built-in scene; it holds a bounded number of frames whatever their number; and `map`
//! reports progress on stderr as asked (`--quiet`, `--progress-every`).

use crate::common::{self, first_diff, scratch};
use octoquant::formats::{count_frames, frame_stream, read_frames, ReadOptions};
use octoquant::octree::io::write_bt;
use octoquant::pipeline::{FramePairs, InsertMode, Mapper, MapperOptions, READ_AHEAD};
use octoquant::scene::{
    scan_lidar, scan_terrestrial, ScanOptions, Scene, SpinningLidar, TerrestrialScanner,
};
use octoquant::Frame;
use std::path::Path;
use std::process::Command;
use std::sync::atomic::{AtomicUsize, Ordering};

fn scene_frames() -> Vec<Frame> {
    let scene = Scene::builtin();
    let opts = ScanOptions::default();
    let (mut frames, _) =
        scan_terrestrial(&scene, &TerrestrialScanner::builtin(&scene), &opts).unwrap();
    frames.extend(
        scan_lidar(&scene, &SpinningLidar::builtin_path(), &opts)
            .unwrap()
            .0,
    );
    frames
}

fn bt(m: Mapper) -> Vec<u8> {
    let mut out = Vec::new();
    write_bt(&mut m.into_tree(), &mut out).unwrap();
    out
}

/// The tree of `path` read whole then inserted, against the tree of its stream, with one and
/// two threads.
fn check_stream_equals_read_all(path: &Path, options: &MapperOptions) {
    let read = ReadOptions::default();
    let frames = read_frames(path, &read).unwrap_or_else(|e| panic!("{e}"));
    assert!(!frames.is_empty(), "{}", path.display());
    let mut whole = Mapper::new(options.clone()).unwrap();
    whole.insert_frames(&frames);
    let expect = bt(whole);
    drop(frames);
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let got = pool.install(|| {
            let mut m = Mapper::new(options.clone()).unwrap();
            m.insert_stream(frame_stream(path, &read).unwrap(), None, |_| {})
                .unwrap();
            bt(m)
        });
        assert!(
            got == expect,
            "{} with {threads} threads: {}",
            path.display(),
            first_diff(&got, &expect)
        );
    }
}

#[test]
fn stream_equals_read_all_on_real_data_and_the_scene() {
    let dir = scratch("stream_equals");
    let scene = dir.join("scene.frames");
    octoquant::formats::frames::write_frames_file(&scene, &scene_frames()).unwrap();
    let options = MapperOptions {
        resolution: 0.2,
        ..MapperOptions::default()
    };
    check_stream_equals_read_all(&scene, &options);
    for rel in [
        "lidar3d/norlab_icp_mapper_example",
        "mcap/pointcloudset_ouster_os1/test.mcap",
        "rgbd/tum_fr2_pioneer_slam2_subset/my_association.txt",
    ] {
        if let Some(p) = common::data_file(rel) {
            check_stream_equals_read_all(&p, &options);
        }
    }
}

/// The frame count an input announces before any point is read ([`count_frames`], which
/// `map` sums for its ETA over several inputs) and the one its stream hints after opening
/// are the frames it gives, on every kind of real input that announces one; text logs
/// announce none.
#[test]
fn announced_frame_counts_are_the_frames_read() {
    let read = ReadOptions::default();
    let mut checked = 0;
    for rel in [
        "lidar3d/norlab_icp_mapper_example",
        "mcap/pointcloudset_ouster_os1/test.mcap",
        "rgbd/tum_fr2_pioneer_slam2_subset/my_association.txt",
        "rgbd/tum_fr2_pioneer_slam2_subset",
        "octomap_reference/spherical_scan.graph",
        "octomap_reference/derived/scan.frames",
        "pcd/pcl_table_scene_mug_stereo_textured/table_scene_mug_stereo_textured.pcd",
    ] {
        let Some(p) = common::data_file(rel) else {
            continue;
        };
        let n = read_frames(&p, &read)
            .unwrap_or_else(|e| panic!("{e}"))
            .len();
        assert!(n > 0, "{rel}");
        assert_eq!(count_frames(&p, &read), Some(n), "{rel}");
        let stream = frame_stream(&p, &read).unwrap();
        assert_eq!(stream.size_hint().0, n, "{rel}");
        checked += 1;
    }
    if let Some(p) = common::data_file("octomap_reference/derived/tiny.txt") {
        assert!(!read_frames(&p, &read).unwrap().is_empty());
        assert_eq!(count_frames(&p, &read), None);
    }
    if common::data_dir().is_some() {
        assert_eq!(checked, 7);
    }
}

/// However many frames the source yields, `insert_stream` has pulled at most a few more
/// than it has inserted: the frames in memory are bounded by [`READ_AHEAD`] plus the
/// pipeline's: in `exact` mode, free-running, one in each of `n` threads' hands, one in each
/// of `n` slots and one waiting (`2n + 1`, whatever the pairs policy, which it does not use;
/// only the key sets of those cast are kept); in the other modes, in steps, one frame being
/// cast and one waiting (two each in pairs). Counted at every frame, not timed.
#[test]
fn stream_holds_a_bounded_number_of_frames() {
    let base = scene_frames();
    let policies = [
        (InsertMode::Exact, 1, FramePairs::Auto, 0),
        (InsertMode::Exact, 2, FramePairs::Never, READ_AHEAD + 5),
        (InsertMode::Exact, 3, FramePairs::Always, READ_AHEAD + 7),
        (InsertMode::Quantized, 2, FramePairs::Never, READ_AHEAD + 2),
        (InsertMode::Quantized, 2, FramePairs::Always, READ_AHEAD + 4),
    ];
    for (mode, threads, pairs, bound) in policies {
        for n in [50usize, 1000] {
            let pulled = AtomicUsize::new(0);
            let source = (0..n).map(|i| {
                pulled.fetch_add(1, Ordering::SeqCst);
                let f = &base[i % base.len()];
                // a small frame: every 64th point
                let mut g =
                    Frame::new_f32(f.origin, f.points.iter().step_by(64).copied().collect());
                g.stamp = Some(i as f64);
                Ok::<Frame, std::io::Error>(g)
            });
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let mut most = 0;
            pool.install(|| {
                let mut m = Mapper::new(MapperOptions {
                    resolution: 0.5,
                    mode,
                    ..MapperOptions::default()
                })
                .unwrap()
                .with_frame_pairs(pairs);
                m.insert_stream(source, None, |s| {
                    most = most.max(pulled.load(Ordering::SeqCst) - s.frames);
                })
                .unwrap();
                assert_eq!(m.stats().frames, n);
            });
            assert!(
                most <= bound,
                "{mode:?}, {threads} threads, {pairs:?}, {n} frames: {most} frames pulled ahead of insertion"
            );
        }
    }
}

/// A source error stops the run with that error, after the frames before it.
#[test]
fn stream_error_stops_the_run() {
    let base = scene_frames();
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let source = (0..10).map(|i| {
                if i == 6 {
                    Err(std::io::Error::other("frame 6 is damaged"))
                } else {
                    Ok(base[i].clone())
                }
            });
            let mut m = Mapper::new(MapperOptions::default()).unwrap();
            let e = m.insert_stream(source, None, |_| {}).unwrap_err();
            assert!(e.to_string().contains("frame 6 is damaged"), "{e}");
            assert_eq!(m.stats().frames, 6);
        });
    }
}

fn octoquant() -> Command {
    Command::new(env!("CARGO_BIN_EXE_octoquant"))
}

/// Stderr is a pipe here, not a terminal: `map` writes a plain line every `--progress-every`
/// frames, none with `--quiet`, and `--json` keeps stdout one JSON object.
#[test]
fn map_progress_lines_and_quiet() {
    let dir = scratch("stream_progress");
    let input = dir.join("scene.frames");
    let frames: Vec<Frame> = scene_frames()
        .into_iter()
        .map(|f| Frame::new_f32(f.origin, f.points.iter().step_by(32).copied().collect()))
        .collect();
    let n = frames.len();
    assert!(n >= 10, "{n}");
    octoquant::formats::frames::write_frames_file(&input, &frames).unwrap();
    let run = |extra: &[&str]| {
        let o = octoquant()
            .arg("map")
            .arg(&input)
            .args(["--res", "0.5", "-o"])
            .arg(dir.join("m.bt"))
            .args(extra)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        (
            String::from_utf8(o.stdout).unwrap(),
            String::from_utf8(o.stderr).unwrap(),
        )
    };
    let (_, err) = run(&["--progress-every", "3"]);
    let lines: Vec<&str> = err.lines().filter(|l| l.starts_with("map: ")).collect();
    assert_eq!(lines.len(), n / 3, "{err}");
    assert!(
        lines[0].starts_with(&format!("map: 3/{n} frames inserted")),
        "{err}"
    );
    assert!(
        lines
            .iter()
            .all(|l| l.contains("points/s") && l.contains("ETA")),
        "{err}"
    );
    // two inputs: the total is the sum of the counts they announce
    let (_, err) = run(&[input.to_str().unwrap(), "--progress-every", &n.to_string()]);
    let lines: Vec<&str> = err.lines().filter(|l| l.starts_with("map: ")).collect();
    assert_eq!(lines.len(), 2, "{err}");
    assert!(
        lines[0].starts_with(&format!("map: {n}/{} frames inserted", 2 * n)),
        "{err}"
    );
    // an input that announces nothing (a text log): no total, no ETA
    let text = dir.join("scene.txt");
    let mut t = String::new();
    for f in &frames {
        t.push_str(&format!(
            "NODE {} {} {} 0 0 0\n",
            f.origin.x, f.origin.y, f.origin.z
        ));
        for p in &f.points {
            t.push_str(&format!("{} {} {}\n", p.x, p.y, p.z));
        }
    }
    std::fs::write(&text, t).unwrap();
    let (_, err) = run(&[text.to_str().unwrap(), "--progress-every", &n.to_string()]);
    let lines: Vec<&str> = err.lines().filter(|l| l.starts_with("map: ")).collect();
    assert_eq!(lines.len(), 2, "{err}");
    assert!(
        lines[1].starts_with(&format!("map: {} frames inserted", 2 * n))
            && !lines[1].contains("ETA"),
        "{err}"
    );
    let (_, err) = run(&["--quiet", "--progress-every", "3"]);
    assert_eq!(err, "");
    let (_, err) = run(&["--progress-every", "0"]);
    assert_eq!(err, "");
    let (out, err) = run(&["--json", "--progress-every", "2"]);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap_or_else(|e| panic!("{e}: {out}"));
    assert_eq!(v["frames"], n);
    assert_eq!(err.lines().count(), n / 2, "{err}");
}
