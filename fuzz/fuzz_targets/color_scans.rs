//! Structure-aware: a few small coloured frames (any `f32` coordinates, NaN, infinities and
//! points outside the key range included; empty frames; origins anywhere; now and then a
//! frame without colours) inserted by `ColorMapper::insert` frame by frame on one thread and
//! by `ColorMapper::insert_stream` pipelined on two. No call may panic; both must stop at the
//! same frame with the same error, and give the same coloured `.ot` bytes and per-frame
//! counts. And each frame's rays, walked in the SIMD lanes and handed on ray by ray
//! (`walk_rays_in_order_f32`, the colour scan's walk), must fill a `KeySet` exactly as
//! OctoMap's walk does one ray and one key at a time (`walk_ray_keys_f32`).
#![no_main]
use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use octoquant::color_map::{ColorMapError, ColorMapper, ColorMerge};
use octoquant::octree::io::write_color_ot;
use octoquant::octree::{Color, Key, KeySetLog};
use octoquant::pipeline::MapperOptions;
use octoquant::raycast::{
    walk_ray_keys_f32, walk_rays_in_order_f32, RayKeys, RayOrderScratch, RayWalk,
};
use octoquant::Frame;
use octoquant::KeyConverter;
use octoquant_fuzz::{frame_counts, pool, written, Place};

#[derive(Arbitrary, Debug)]
struct FuzzFrame {
    /// The origin: near the map's centre, or any `f32`s.
    origin: Place,
    /// Points with their colours.
    points: Vec<(Place, [u8; 3])>,
    /// The frame carries no colours (an error for the colour mapper).
    colourless: bool,
}

#[derive(Arbitrary, Debug)]
struct Input {
    frames: Vec<FuzzFrame>,
    integrate: bool,
    resolution: u8,
    max_range: Option<u8>,
}

fuzz_target!(|input: Input| {
    let frames: Vec<Frame> = input
        .frames
        .iter()
        .take(6)
        .map(|f| {
            let points = f.points.iter().take(48);
            let colors = points.clone().map(|(_, [r, g, b])| Color::new(*r, *g, *b));
            Frame {
                colors: (!f.colourless).then(|| colors.collect()),
                ..Frame::new_f32(f.origin.point(), points.map(|(p, _)| p.point()).collect())
            }
        })
        .collect();
    let options = MapperOptions {
        resolution: [0.05, 0.1, 0.25, 1.0][usize::from(input.resolution % 4)],
        max_range: input.max_range.map(|r| f64::from(r) * 0.1),
        ..MapperOptions::default()
    };
    let merge = if input.integrate {
        ColorMerge::Integrate
    } else {
        ColorMerge::Average
    };
    let conv = KeyConverter::new(options.resolution).expect("a valid resolution");
    let mut scratch = RayOrderScratch::default();
    for f in &frames {
        // a membership window around the origin (when it has a key) and hashing beyond it
        let window = |k: Key| {
            let span = |c: u16, d: i32| (i32::from(c) + d).clamp(0, 65535) as u16;
            let corner = |d| Key::new(span(k[0], d), span(k[1], d), span(k[2], d));
            KeySetLog::with_window(corner(-40), corner(40))
        };
        let origin = f.origin;
        let make = || {
            conv.point_to_key(&origin.cast::<f64>())
                .map_or_else(KeySetLog::new, window)
        };
        let (mut by_keys, mut by_bricks) = (make(), make());
        for p in &f.points {
            let mut range = by_keys.range();
            match walk_ray_keys_f32(&conv, &origin, p, |k| {
                range.key(k);
                true
            }) {
                RayWalk::Complete | RayWalk::SameVoxel => range.finish(),
                _ => range.cancel(),
            }
        }
        walk_rays_in_order_f32(&conv, &origin, &f.points, &mut scratch, |_, ray| {
            let mut range = by_bricks.range();
            match ray {
                Ok(RayKeys::Bricks { bricks, step }) => range.bricks(bricks, step),
                Ok(RayKeys::Keys(keys)) => keys.iter().for_each(|&k| range.key(k)),
                Err(_) => return range.cancel(),
            }
            range.finish();
        });
        assert_eq!(by_bricks.len(), by_keys.len(), "other keys");
        assert_eq!(
            by_bricks.bucket_count(),
            by_keys.bucket_count(),
            "another growth"
        );
        assert!(by_bricks.order() == by_keys.order(), "another KeySet order");
    }
    let new = || ColorMapper::new(options.clone(), merge).expect("a valid resolution");
    let (want, want_stats, want_err) = pool(1).install(|| {
        let mut m = new();
        let mut stats = Vec::new();
        let mut err = None;
        for f in &frames {
            match m.insert(f) {
                Ok(st) => stats.push(frame_counts(&st)),
                Err(e) => {
                    err = Some(e.to_string());
                    break;
                }
            }
        }
        (written(|w| write_color_ot(m.tree(), w)), stats, err)
    });
    let (got, got_stats, got_err) = pool(2).install(|| {
        let mut m = new();
        let mut stats = Vec::new();
        let r = m.insert_stream(frames.iter().map(Ok::<_, ColorMapError>), |_, st| {
            stats.push(frame_counts(st));
            Ok(())
        });
        (
            written(|w| write_color_ot(m.tree(), w)),
            stats,
            r.err().map(|e| e.to_string()),
        )
    });
    assert_eq!(got_err, want_err, "another error than frame by frame");
    assert_eq!(got_stats, want_stats, "other per-frame counts");
    assert!(got == want, "another tree than one insert per frame");
});
