//! Structure-aware: a few small frames (any `f32` coordinates, NaN, infinities and points
//! outside the key range included; empty frames; origins anywhere) inserted by
//! `Mapper::insert_frames` on two threads with frames cast in pairs (`FramePairs::Always`)
//! and one at a time (`FramePairs::Never`) (in `exact` mode from `FLOW_MIN_FRAMES` frames
//! on, the free-running pipeline, whatever the policy), by `Mapper::insert_stream` (in `exact`
//! mode free-running) on two and three threads, and by one `Mapper::insert` per frame. No call may
//! panic, all must give the same `.ot` bytes, and the pipelined runs the serial run's
//! per-frame counts, in order (progress, for the streams).
#![no_main]
use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use octoquant::octree::io::write_ot;
use octoquant::pipeline::{FramePairs, InsertMode, Mapper, MapperOptions};
use octoquant::Frame;
use octoquant_fuzz::{frame_counts, pool, written, Place};

#[derive(Arbitrary, Debug)]
struct FuzzFrame {
    /// The origin: near the map's centre, or any `f32`s.
    origin: Place,
    points: Vec<Place>,
}

#[derive(Arbitrary, Debug)]
struct Input {
    frames: Vec<FuzzFrame>,
    mode: u8,
    resolution: u8,
    max_range: Option<u8>,
}

fuzz_target!(|input: Input| {
    let frames: Vec<Frame> = input
        .frames
        .iter()
        .take(6)
        .map(|f| {
            let points = f.points.iter().take(48).map(|p| p.point()).collect();
            Frame::new_f32(f.origin.point(), points)
        })
        .collect();
    let mode = [
        InsertMode::Exact,
        InsertMode::Discretize,
        InsertMode::Quantized,
        InsertMode::QuantizedBresenham,
    ][usize::from(input.mode % 4)];
    let options = MapperOptions {
        resolution: [0.05, 0.1, 0.25, 1.0][usize::from(input.resolution % 4)],
        max_range: input.max_range.map(|r| f64::from(r) * 0.1),
        mode,
        ..MapperOptions::default()
    };
    let mut serial = Mapper::new(options.clone()).expect("a valid resolution");
    let want_stats: Vec<[usize; 6]> = frames
        .iter()
        .map(|f| frame_counts(&serial.insert(f)))
        .collect();
    let want = written(|w| write_ot(serial.tree(), w));
    for pairs in [FramePairs::Always, FramePairs::Never] {
        let (got, stats) = pool(2).install(|| {
            let mut m = Mapper::new(options.clone())
                .expect("a valid resolution")
                .with_frame_pairs(pairs);
            let stats = m.insert_frames(&frames);
            (written(|w| write_ot(m.tree(), w)), stats)
        });
        assert!(
            got == want,
            "{pairs:?}: another tree than one insert per frame"
        );
        let got_stats: Vec<[usize; 6]> = stats.iter().map(frame_counts).collect();
        assert_eq!(got_stats, want_stats, "{pairs:?}: other per-frame counts");
    }
    for threads in [2, 3] {
        let (got, seen) = pool(threads).install(|| {
            let mut m = Mapper::new(options.clone()).expect("a valid resolution");
            let source = frames.iter().cloned().map(Ok::<Frame, std::io::Error>);
            let mut seen = Vec::new();
            m.insert_stream(source, None, |s| seen.push(s.frames))
                .expect("frames in memory do not fail");
            (written(|w| write_ot(m.tree(), w)), seen)
        });
        assert!(
            got == want,
            "streamed, {threads} threads: another tree than one insert per frame"
        );
        assert_eq!(seen, (1..=frames.len()).collect::<Vec<_>>());
    }
});
