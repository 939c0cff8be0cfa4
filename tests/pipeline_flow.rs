//! The free-running pipeline (`exact` mode on at most `FLOW_MAX_THREADS` threads:
//! `Mapper::insert_frames` from `FLOW_MIN_FRAMES` frames on, and every `insert_stream`): each
//! thread casts whole frames and whichever thread finds the tree free applies the next one.
//! On real LiDAR frames it gives the tree of one `Mapper::insert` per frame, byte for byte in
//! `.ot` (log-odds), and each frame's own statistics, lazily or not, with a maximum range or
//! not, on 2 to `FLOW_MAX_THREADS` threads (and beyond, where the run goes in steps), in
//! memory and streamed, and when called from a thread outside the pool; a checkpoint that
//! cannot be saved stops the run with the frames before it in the tree; a panicking progress
//! callback comes back as a panic.

use crate::common::{self, first_diff, scratch};
use octoquant::checkpoint::RunIdentity;
use octoquant::formats::{frame_stream, ReadOptions};
use octoquant::octree::io::write_ot;
use octoquant::pipeline::{
    CheckpointOptions, FrameStats, InsertMode, Mapper, MapperOptions, FLOW_MAX_THREADS,
    FLOW_MIN_FRAMES,
};
use octoquant::Frame;

/// The `.ot` bytes: log-odds, not only the classes a `.bt` keeps (after a lazy run's
/// `finish`, which `into_tree` does).
fn ot(m: Mapper) -> Vec<u8> {
    let mut out = Vec::new();
    write_ot(&m.into_tree(), &mut out).unwrap();
    out
}

fn counts(s: &FrameStats) -> (usize, usize, usize, usize, usize) {
    (s.points, s.non_finite, s.rays, s.free, s.occupied)
}

/// The first `n` norlab LiDAR frames, every 4th point (to keep the unoptimised test build
/// quick), or `None` without the data (a failure under CI).
fn norlab(n: usize) -> Option<Vec<Frame>> {
    let dir = common::data_file("lidar3d/norlab_icp_mapper_example")?;
    let frames = frame_stream(&dir, &ReadOptions::default())
        .unwrap()
        .take(n)
        .map(|f| {
            let mut f = f.unwrap();
            f.points = f.points.iter().step_by(4).copied().collect();
            f
        })
        .collect();
    Some(frames)
}

/// One `insert` per frame: the tree's bytes and each frame's counts.
fn serial(frames: &[Frame], options: &MapperOptions) -> (Vec<u8>, Vec<FrameStats>) {
    let mut m = Mapper::new(options.clone()).unwrap();
    let stats = frames.iter().map(|f| m.insert(f)).collect();
    (ot(m), stats)
}

fn check(what: &str, got: (Vec<u8>, Vec<FrameStats>), want: &(Vec<u8>, Vec<FrameStats>)) {
    assert!(got.0 == want.0, "{what}: {}", first_diff(&got.0, &want.0));
    assert_eq!(got.1.len(), want.1.len(), "{what}: one statistic per frame");
    for (i, (g, w)) in got.1.iter().zip(&want.1).enumerate() {
        assert_eq!(counts(g), counts(w), "{what}: frame {i}");
        assert!(
            g.seconds > 0.0 && g.seconds.is_finite(),
            "{what}: frame {i}"
        );
    }
}

#[test]
fn free_running_pipeline_gives_the_tree_of_one_insert_per_frame_on_norlab() {
    let Some(frames) = norlab(6) else {
        return;
    };
    assert!(frames.len() >= FLOW_MIN_FRAMES);
    // `exact` runs are free-running; the others go in steps (the same checks hold)
    for (mode, lazy, max_range) in [
        (InsertMode::Exact, false, None),
        (InsertMode::Exact, true, None),
        (InsertMode::Exact, false, Some(12.0)),
        (InsertMode::QuantizedBresenham, false, None),
    ] {
        let options = MapperOptions {
            resolution: 0.2,
            mode,
            lazy,
            max_range,
            ..MapperOptions::default()
        };
        let want = serial(&frames, &options);
        // up to FLOW_MAX_THREADS free-running, beyond in steps
        for threads in [2, 3, FLOW_MAX_THREADS, FLOW_MAX_THREADS + 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let what = format!("{mode:?}, lazy {lazy}, {max_range:?}, {threads} threads");
            let in_memory = pool.install(|| {
                let mut m = Mapper::new(options.clone()).unwrap();
                let stats = m.insert_frames(&frames);
                (ot(m), stats)
            });
            check(&format!("{what}, in memory"), in_memory, &want);
            let streamed = pool.install(|| {
                let mut m = Mapper::new(options.clone()).unwrap();
                let source = frames.iter().cloned().map(Ok::<Frame, std::io::Error>);
                let mut before = 0;
                m.insert_stream(source, None, |s| {
                    // progress comes once per frame, counting up
                    assert_eq!(s.frames, before + 1);
                    before = s.frames;
                })
                .unwrap();
                assert_eq!(before, frames.len());
                ot(m)
            });
            assert!(
                streamed == want.0,
                "{what}, streamed: {}",
                first_diff(&streamed, &want.0)
            );
        }
    }
}

/// Called from a thread that is not one of the pool's (the test's own thread, the global
/// pool), every pool thread casts and applies, and the tree is the same.
#[test]
fn free_running_pipeline_from_outside_the_pool() {
    let Some(frames) = norlab(5) else {
        return;
    };
    let options = MapperOptions {
        resolution: 0.2,
        ..MapperOptions::default()
    };
    let want = serial(&frames, &options);
    assert!(rayon::current_thread_index().is_none());
    let mut m = Mapper::new(options).unwrap();
    let stats = m.insert_frames(&frames);
    check("outside the pool", (ot(m), stats), &want);
}

/// A checkpoint that cannot be saved (its directory lies under a regular file) stops a run
/// with the error; the frames before it are in the tree, exactly, and none after.
#[test]
fn free_running_pipeline_stops_at_a_checkpoint_that_fails() {
    let Some(frames) = norlab(8) else {
        return;
    };
    let options = MapperOptions {
        resolution: 0.2,
        ..MapperOptions::default()
    };
    let dir = scratch("flow-checkpoint-under-a-file");
    let file = dir.join("not-a-directory");
    std::fs::write(&file, b"a file").unwrap();
    let ck = CheckpointOptions {
        dir: file.join("checkpoint"),
        every: 3,
    };
    let identity = RunIdentity::new(&options, Vec::new(), &frames);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let (got, done) = pool.install(|| {
        let mut m = Mapper::new(options.clone()).unwrap();
        let e = m
            .insert_run(&frames, Some((&ck, &identity)), |_| {})
            .unwrap_err();
        assert!(e.to_string().contains("checkpoint"), "{e}");
        let done = m.stats().frames;
        (ot(m), done)
    });
    assert_eq!(done, 3);
    let (want, _) = serial(&frames[..3], &options);
    assert!(got == want, "{}", first_diff(&got, &want));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A progress callback that panics ends the run with its panic (on the caller's thread), and
/// the threads of the pool do not wait for work that will never come.
#[test]
fn free_running_pipeline_passes_on_a_panic_of_progress() {
    let Some(frames) = norlab(6) else {
        return;
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let caught = pool.install(|| {
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            let mut m = Mapper::new(MapperOptions {
                resolution: 0.2,
                ..MapperOptions::default()
            })
            .unwrap();
            let source = frames.iter().cloned().map(Ok::<Frame, std::io::Error>);
            m.insert_stream(source, None, |s| {
                if s.frames == 2 {
                    panic!("progress gave up at frame 2");
                }
            })
        }))
    });
    let payload = caught.expect_err("the panic comes back");
    assert_eq!(
        payload.downcast_ref::<&str>(),
        Some(&"progress gave up at frame 2")
    );
}
