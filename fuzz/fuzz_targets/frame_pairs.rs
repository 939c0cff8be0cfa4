//! Structure-aware: a few small frames (any `f32` coordinates, NaN, infinities and points
//! outside the key range included; empty frames; origins anywhere) inserted by
//! `Mapper::insert_frames` on two threads with frames cast in pairs (`FramePairs::Always`)
//! and one at a time (`FramePairs::Never`), and by one `Mapper::insert` per frame. No call may
//! panic, all three must give the same `.ot` bytes, and the pipelined runs the serial run's
//! per-frame counts, in order.
#![no_main]
use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use nalgebra::Point3;
use octoquant::octree::io::write_ot;
use octoquant::pipeline::{FramePairs, FrameStats, InsertMode, Mapper, MapperOptions};
use octoquant::Frame;
use std::sync::OnceLock;

#[derive(Arbitrary, Debug)]
struct FuzzFrame {
    /// The origin: near the map's centre, or any `f32`s.
    origin: Place,
    points: Vec<Place>,
}

#[derive(Arbitrary, Debug, Clone, Copy)]
enum Place {
    /// Within a few metres of the map's centre (tenths of a metre).
    Near(i8, i8, i8),
    /// Any coordinates.
    Raw(f32, f32, f32),
}

impl Place {
    fn point(self) -> Point3<f32> {
        match self {
            Place::Near(x, y, z) => {
                Point3::new(f32::from(x) * 0.1, f32::from(y) * 0.1, f32::from(z) * 0.1)
            }
            Place::Raw(x, y, z) => Point3::new(x, y, z),
        }
    }
}

#[derive(Arbitrary, Debug)]
struct Input {
    frames: Vec<FuzzFrame>,
    mode: u8,
    resolution: u8,
    max_range: Option<u8>,
}

/// The counts of a frame's statistics that do not depend on timing.
fn counts(s: &FrameStats) -> [usize; 6] {
    [
        s.points,
        s.non_finite,
        s.outside_map,
        s.rays,
        s.free,
        s.occupied,
    ]
}

fn two_threads() -> &'static rayon::ThreadPool {
    static POOL: OnceLock<rayon::ThreadPool> = OnceLock::new();
    POOL.get_or_init(|| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .expect("a pool of two threads")
    })
}

fn ot(m: Mapper) -> Vec<u8> {
    let mut out = Vec::new();
    write_ot(&m.into_tree(), &mut out).expect("writing into memory");
    out
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
    let want_stats: Vec<[usize; 6]> = frames.iter().map(|f| counts(&serial.insert(f))).collect();
    let want = ot(serial);
    for pairs in [FramePairs::Always, FramePairs::Never] {
        let (got, stats) = two_threads().install(|| {
            let mut m = Mapper::new(options.clone())
                .expect("a valid resolution")
                .with_frame_pairs(pairs);
            let stats = m.insert_frames(&frames);
            (ot(m), stats)
        });
        assert!(
            got == want,
            "{pairs:?}: another tree than one insert per frame"
        );
        let got_stats: Vec<[usize; 6]> = stats.iter().map(counts).collect();
        assert_eq!(got_stats, want_stats, "{pairs:?}: other per-frame counts");
    }
});
