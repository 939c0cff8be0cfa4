//! Frames cast two at once (`FramePairs`): the pipelined insertion gives the tree of one
//! `Mapper::insert` per frame, byte for byte in `.ot` (log-odds), whatever the policy, the
//! number of frames (odd or even, so that a pair is left open at the end), the mode and the
//! input; pairs apply their frames in order; each frame gets its own statistics, in order; a
//! source error stops the run after the frames before it, also in the middle of a pair;
//! progress is reported once per frame. Runs of `FLOW_MIN_FRAMES` frames and more, and the
//! streams, go through the free-running pipeline whatever the policy (tests/pipeline_flow.rs),
//! so the prefixes of every length here cover both.

use crate::common::{self, first_diff};
use octoquant::formats::{read_frames, ReadOptions};
use octoquant::octree::io::write_ot;
use octoquant::pipeline::{FramePairs, InsertMode, Mapper, MapperOptions};
use octoquant::scene::{scan_lidar, ScanOptions, Scene, SpinningLidar};
use octoquant::Frame;

const POLICIES: [FramePairs; 3] = [FramePairs::Never, FramePairs::Auto, FramePairs::Always];

/// The `.ot` bytes: log-odds, not only the classes a `.bt` keeps.
fn ot(m: Mapper) -> Vec<u8> {
    let mut out = Vec::new();
    write_ot(&m.into_tree(), &mut out).unwrap();
    out
}

fn two_threads<T: Send>(f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap()
        .install(f)
}

fn lidar_frames() -> Vec<Frame> {
    let scene = Scene::builtin();
    let (frames, _) = scan_lidar(
        &scene,
        &SpinningLidar::builtin_path(),
        &ScanOptions::default(),
    )
    .unwrap();
    frames
}

/// `frames` inserted one `insert` at a time against `insert_frames` on two threads under
/// every policy, for every prefix length up to `most`; the per-frame statistics must be the
/// serial ones but for the times.
fn check_pairs_match_one_by_one(
    frames: &[Frame],
    options: &MapperOptions,
    most: usize,
    what: &str,
) {
    for n in 1..=most.min(frames.len()) {
        let mut serial = Mapper::new(options.clone()).unwrap();
        let want_stats: Vec<_> = frames[..n].iter().map(|f| serial.insert(f)).collect();
        let want = ot(serial);
        for pairs in POLICIES {
            let (got, stats) = two_threads(|| {
                let mut m = Mapper::new(options.clone())
                    .unwrap()
                    .without_checkpoints()
                    .with_frame_pairs(pairs);
                let stats = m.insert_frames(&frames[..n]);
                assert_eq!(m.stats().frames, n);
                (ot(m), stats)
            });
            assert!(
                got == want,
                "{what}, {n} frames, {pairs:?}, {:?}: {}",
                options.mode,
                first_diff(&got, &want)
            );
            assert_eq!(stats.len(), n, "{what}: one statistic per frame");
            for (i, (g, w)) in stats.iter().zip(&want_stats).enumerate() {
                let counts =
                    |s: &octoquant::pipeline::FrameStats| (s.points, s.rays, s.free, s.occupied);
                assert_eq!(counts(g), counts(w), "{what}, {pairs:?}: frame {i}");
                assert!(
                    g.seconds > 0.0 && g.seconds.is_finite(),
                    "{what}: frame {i}"
                );
            }
        }
    }
}

#[test]
fn pairs_give_the_tree_of_one_insert_per_frame_on_the_scene() {
    let frames: Vec<Frame> = lidar_frames()
        .into_iter()
        .take(5)
        .map(|f| Frame::new_f32(f.origin, f.points.iter().step_by(8).copied().collect()))
        .collect();
    assert_eq!(frames.len(), 5);
    for mode in [
        InsertMode::Exact,
        InsertMode::Quantized,
        InsertMode::QuantizedBresenham,
    ] {
        let options = MapperOptions {
            resolution: 0.2,
            mode,
            ..MapperOptions::default()
        };
        check_pairs_match_one_by_one(&frames, &options, 5, "scene");
    }
}

/// TUM depth images, where pairs pay (cheap tree updates, the pixel grid's head skip), in the
/// exact and the quantized mode.
#[test]
fn pairs_give_the_tree_of_one_insert_per_frame_on_tum() {
    let Some(assoc) = common::data_file("rgbd/tum_fr2_pioneer_slam2_subset/my_association.txt")
    else {
        return;
    };
    let frames = read_frames(&assoc, &ReadOptions::default()).unwrap();
    assert_eq!(frames.len(), 10);
    assert!(frames.iter().all(|f| f.camera.is_some()), "depth images");
    for mode in [InsertMode::Exact, InsertMode::Quantized] {
        let options = MapperOptions {
            resolution: 0.05,
            mode,
            ..MapperOptions::default()
        };
        for n in [5, 10] {
            check_pairs_match_one_by_one(&frames[..n], &options, n, "TUM");
        }
    }
}

/// A source error stops a paired run with that error after exactly the frames before it,
/// whether it falls on the first or the second frame of a pair; progress is reported once
/// per frame, counting up.
#[test]
fn pairs_stop_at_a_source_error_and_report_every_frame() {
    let frames = lidar_frames();
    for bad in [5usize, 6] {
        two_threads(|| {
            let source = (0..10).map(|i| {
                if i == bad {
                    Err(std::io::Error::other(format!("frame {i} is damaged")))
                } else {
                    Ok(frames[i % frames.len()].clone())
                }
            });
            let mut m = Mapper::new(MapperOptions::default())
                .unwrap()
                .with_frame_pairs(FramePairs::Always);
            let mut seen = Vec::new();
            let e = m
                .insert_stream(source, None, |s| seen.push(s.frames))
                .unwrap_err();
            assert!(
                e.to_string().contains(&format!("frame {bad} is damaged")),
                "{e}"
            );
            assert_eq!(m.stats().frames, bad);
            assert_eq!(seen, (1..=bad).collect::<Vec<_>>());
            let mut serial = Mapper::new(MapperOptions::default()).unwrap();
            for i in 0..bad {
                serial.insert(&frames[i % frames.len()]);
            }
            let (got, want) = (ot(m), ot(serial));
            assert!(got == want, "error at {bad}: {}", first_diff(&got, &want));
        });
    }
}

/// Frames whose order shows in the tree (a voxel hit until it is clamped, then missed, ends
/// lower than one missed first): pairs apply their frames in order. The check can fail: the
/// same frames with the two of one pair swapped give another tree.
#[test]
fn pairs_keep_the_order_of_their_frames() {
    use nalgebra::Point3;
    let origin = Point3::new(0.05f32, 0.05, 0.05);
    // `hit` ends in the voxels at x = 2 m, `miss` passes through them to x = 4 m
    let row = |x: f32| -> Vec<Point3<f32>> {
        (0..40)
            .map(|i| Point3::new(x, 0.05 + 0.01 * i as f32, 0.05))
            .collect()
    };
    let hit = Frame::new_f32(origin, row(2.05));
    let miss = Frame::new_f32(origin, row(4.05));
    // clamped after four hits: the miss after the fifth leaves 3.07; swapped, 3.47
    let mut frames = vec![hit; 5];
    frames.push(miss);
    let options = MapperOptions {
        resolution: 0.1,
        ..MapperOptions::default()
    };
    let serial = |frames: &[Frame]| {
        let mut m = Mapper::new(options.clone()).unwrap();
        for f in frames {
            m.insert(f);
        }
        ot(m)
    };
    let want = serial(&frames);
    let mut swapped = frames.clone();
    swapped.swap(4, 5);
    assert!(serial(&swapped) != want, "the order shows in the tree");
    for pairs in POLICIES {
        let got = two_threads(|| {
            let mut m = Mapper::new(options.clone())
                .unwrap()
                .with_frame_pairs(pairs);
            m.insert_frames(&frames);
            ot(m)
        });
        assert!(got == want, "{pairs:?}: {}", first_diff(&got, &want));
    }
}
