use super::*;
use crate::dda::{key_of, setup_with_keys, STEP_MARGIN};
use crate::update::{compute_update_f32, compute_update_grid_f32, ScanUpdate};
use nalgebra::{Point3, Rotation3, Vector3};
use octoquant_octree::KeyConverter;
use proptest::prelude::*;

/// The DDA's state after every crossing earlier than `t`, and the bits of its steps inside
/// the 3x3x3 block: the plain loop, step by step.
fn naive_state(r: &RaySetup, t: f64) -> (Key, [f64; 3], u32) {
    let mut tm = r.t_max;
    let mut off = [0i32; 3];
    let mut near = 1 << 13;
    let mut inside = true;
    loop {
        let a = min_axis(&tm);
        // the DDA takes the crossing only when it is earlier than `t` (not NaN)
        let earlier = tm[a] < t;
        if !earlier {
            break;
        }
        off[a] += r.step[a];
        tm[a] += r.t_delta[a];
        if inside {
            match near_bit(off) {
                Some(bit) => near |= 1 << bit,
                None => inside = false,
            }
        }
    }
    let key = Key(std::array::from_fn(|i| {
        (r.key_origin.0[i] as i32 + off[i]) as u16
    }));
    (key, tm, near)
}

/// A ray's set-up from `origin` to `end` at resolution `res`, when it is walked by the lanes.
fn lane_ray(res: f64, origin: [f32; 3], end: [f32; 3]) -> Option<RaySetup> {
    let conv = KeyConverter::new(res).ok()?;
    let (o, e) = (Point3::from(origin), Point3::from(end));
    let ok = key_of(&conv, &o).map(|k| (k, k.morton()));
    let ek = key_of(&conv, &e).map(|k| (k, k.morton()));
    setup_with_keys(&conv, &o, ok, &e, ek)
        .ok()
        .filter(|r| r.well_conditioned)
}

/// Coordinates on a grid of quarter voxels, so that origins and ends sit on voxel corners,
/// faces and centres and the `tMax` of different axes tie.
fn on_quarters(res: f64) -> impl Strategy<Value = [f32; 3]> {
    prop::array::uniform3(-40i32..40).prop_map(move |q| q.map(|v| (v as f64 * res / 4.0) as f32))
}

fn anywhere() -> impl Strategy<Value = [f32; 3]> {
    prop::array::uniform3(-3.0f32..3.0)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    /// The jump lands on the plain loop's state, with its near bits, on every path (eight
    /// lanes, four lanes and one by one), for rays with and without ties.
    #[test]
    fn jump_lands_where_the_plain_walk_is(
        res in prop::sample::select(vec![0.02, 0.05, 0.1, 0.25]),
        rays in prop::collection::vec(
            (prop_oneof![anywhere(), on_quarters(0.05)], prop_oneof![anywhere(), on_quarters(0.05)], 0.0f64..1.2),
            1..40,
        ),
    ) {
        let queued: Vec<(RaySetup, f64)> = rays
            .iter()
            .filter_map(|&(o, e, f)| lane_ray(res, o, e).map(|r| (r, f * r.length)))
            .collect();
        // every path (those the CPU lacks fall back to the next narrower one)
        let paths = [ReplayPath::Avx512, ReplayPath::Avx2, ReplayPath::Scalar];
        let mut outs = Vec::new();
        let mut nears = Vec::new();
        for path in paths {
            let mut out = Vec::new();
            nears.push(jump_with(&queued, &mut out, path));
            prop_assert_eq!(out.len(), queued.len());
            outs.push(out);
        }
        let mut near = 0;
        for (i, (r, t)) in queued.iter().enumerate() {
            let (key, tm, bits) = naive_state(r, *t);
            near |= bits;
            for got in outs.iter().map(|o| &o[i]) {
                prop_assert_eq!(got.key_origin, key);
                prop_assert_eq!(got.code_origin, key.morton());
                prop_assert_eq!(got.t_max.map(f64::to_bits), tm.map(f64::to_bits));
                let manhattan: u32 = (0..3)
                    .map(|i| (key.0[i] as i32 - r.key_end.0[i] as i32).unsigned_abs())
                    .sum();
                prop_assert_eq!(got.budget, manhattan + STEP_MARGIN);
            }
        }
        for got in nears {
            prop_assert_eq!(got, near);
        }
    }
}

/// A synthetic depth image seen by a pinhole camera: a slanted plane, a box nearer or farther,
/// holes (a rectangle and scattered pixels); points in the map, `f32`, with their pixels.
struct Scene {
    points: Vec<Point3<f32>>,
    pixels: Vec<u32>,
    width: u32,
    height: u32,
    f: (f64, f64),
    c: (f64, f64),
    rotation: Rotation3<f64>,
    origin: Point3<f32>,
}

#[derive(Debug, Clone)]
struct SceneParams {
    size: (u32, u32),
    f: f64,
    depth: f64,
    slope: (f64, f64),
    block: (u32, u32, u32, u32, f64),
    hole: (u32, u32, u32, u32),
    speckle: u32,
    turn: [f64; 3],
    origin: [f64; 3],
    snap: bool,
}

fn scene_params() -> impl Strategy<Value = SceneParams> {
    (
        (24u32..80, 18u32..60),
        30.0f64..120.0,
        0.3f64..3.0,
        (-0.02f64..0.02, -0.02f64..0.02),
        (0u32..80, 0u32..60, 0u32..30, 0u32..30, -0.8f64..1.5),
        (0u32..80, 0u32..60, 0u32..12, 0u32..12),
        0u32..20,
        prop::array::uniform3(-3.2f64..3.2),
        prop::array::uniform3(-2.0f64..2.0),
        any::<bool>(),
    )
        .prop_map(
            |(size, f, depth, slope, block, hole, speckle, turn, origin, snap)| SceneParams {
                size,
                f,
                depth,
                slope,
                block,
                hole,
                speckle,
                turn,
                origin,
                snap,
            },
        )
}

fn scene(p: &SceneParams, res: f64) -> Scene {
    let (w, h) = p.size;
    let (fx, fy) = (p.f, p.f * 1.01);
    let (cx, cy) = ((w as f64 - 1.0) / 2.0 + 0.3, (h as f64 - 1.0) / 2.0 - 0.2);
    let rotation = Rotation3::from_scaled_axis(Vector3::from(p.turn));
    let mut o = Vector3::from(p.origin);
    if p.snap {
        // a voxel corner: rays through it tie on every axis
        o = o.map(|c| (c / res).round() * res);
    }
    let (bu, bv, bw, bh, bd) = p.block;
    let (hu, hv, hw, hh) = p.hole;
    let mut points = Vec::new();
    let mut pixels = Vec::new();
    for v in 0..h {
        for u in 0..w {
            let in_hole = (hu..hu + hw).contains(&u) && (hv..hv + hh).contains(&v);
            let speckled = p.speckle > 0 && (u * 7 + v * 13) % (p.speckle * 5 + 3) == 0;
            if in_hole || speckled {
                continue;
            }
            let mut z = p.depth + p.slope.0 * u as f64 + p.slope.1 * v as f64;
            if (bu..bu + bw).contains(&u) && (bv..bv + bh).contains(&v) {
                z += bd;
            }
            if z <= 0.05 {
                continue;
            }
            let cam = Vector3::new((u as f64 - cx) * z / fx, (v as f64 - cy) * z / fy, z);
            points.push(Point3::from((rotation * cam + o).map(|c| c as f32)));
            pixels.push(v * w + u);
        }
    }
    Scene {
        points,
        pixels,
        width: w,
        height: h,
        f: (fx, fy),
        c: (cx, cy),
        rotation,
        origin: Point3::from(o.map(|c| c as f32)),
    }
}

impl Scene {
    fn grid(&self) -> PixelGrid<'_> {
        PixelGrid {
            camera: PinholeCamera {
                width: self.width,
                height: self.height,
                fx: self.f.0,
                fy: self.f.1,
                cx: self.c.0,
                cy: self.c.1,
                rotation: self.rotation,
            },
            pixels: &self.pixels,
        }
    }
}

/// The grid path's sets and counts against the plain `computeUpdate` (itself checked against
/// OctoMap's definition and OctoMap): the same bricks, the same counts.
fn same_as_plain(
    conv: &KeyConverter,
    points: &[Point3<f32>],
    grid: &PixelGrid<'_>,
    origin: &Point3<f32>,
    max_range: Option<f64>,
) -> Result<usize, TestCaseError> {
    let (mut plain, mut fast) = (ScanUpdate::new(), ScanUpdate::new());
    let a = compute_update_f32(conv, points, origin, max_range, &mut plain);
    let mut b = compute_update_grid_f32(conv, points, grid, origin, max_range, &mut fast);
    let skipped = std::mem::take(&mut b.heads_skipped);
    prop_assert_eq!(a, b);
    prop_assert_eq!(plain.free_bricks(), fast.free_bricks());
    prop_assert_eq!(plain.occupied_bricks(), fast.occupied_bricks());
    Ok(skipped)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// Depth images of planes, boxes and holes from any pose, origins on voxel corners
    /// included, with and without a maximum range: the same key sets as without the grid.
    #[test]
    fn depth_images_give_the_plain_key_sets(
        p in scene_params(),
        res in prop::sample::select(vec![0.02, 0.05, 0.1]),
        max_range in prop::option::of(0.2f64..3.0),
    ) {
        let conv = KeyConverter::new(res).unwrap();
        let s = scene(&p, res);
        same_as_plain(&conv, &s.points, &s.grid(), &s.origin, max_range)?;
    }

    /// A grid that lies (points moved off their pixel's ray, pixels swapped, out of range, a
    /// wrong focal length) changes nothing but the speed.
    #[test]
    fn a_wrong_grid_changes_nothing(
        p in scene_params(),
        res in prop::sample::select(vec![0.02, 0.05]),
        moved in prop::collection::vec((any::<prop::sample::Index>(), prop::array::uniform3(-0.3f32..0.3)), 0..8),
        swapped in prop::collection::vec((any::<prop::sample::Index>(), any::<prop::sample::Index>()), 0..8),
        focal in 0.8f64..1.25,
    ) {
        let conv = KeyConverter::new(res).unwrap();
        let mut s = scene(&p, res);
        if s.points.is_empty() {
            return Ok(());
        }
        for (i, d) in &moved {
            let q = &mut s.points[i.index(s.pixels.len())];
            *q += Vector3::from(*d);
        }
        for (i, j) in &swapped {
            let n = s.pixels.len();
            s.pixels.swap(i.index(n), j.index(n));
        }
        s.pixels[0] = u32::MAX;
        s.f.0 *= focal;
        same_as_plain(&conv, &s.points, &s.grid(), &s.origin, None)?;
    }
}

/// On an ordinary scene most rays do skip their heads (the tests above compare something),
/// and two threads give the same sets as one.
#[test]
fn most_rays_of_a_plain_scene_skip_their_heads() {
    let p = SceneParams {
        size: (160, 120),
        f: 150.0,
        depth: 2.0,
        slope: (0.002, 0.001),
        block: (40, 30, 30, 20, -0.6),
        hole: (100, 70, 6, 4),
        speckle: 0,
        turn: [0.3, -1.2, 0.4],
        origin: [0.31, -0.72, 1.05],
        snap: false,
    };
    let conv = KeyConverter::new(0.05).unwrap();
    let s = scene(&p, 0.05);
    let skipped = same_as_plain(&conv, &s.points, &s.grid(), &s.origin, None).unwrap();
    assert!(
        skipped * 10 > s.points.len() * 7,
        "{skipped} of {} rays skipped their heads",
        s.points.len()
    );
    let mut one = ScanUpdate::new();
    compute_update_grid_f32(&conv, &s.points, &s.grid(), &s.origin, None, &mut one);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let mut two = ScanUpdate::new();
    let st = pool.install(|| {
        compute_update_grid_f32(&conv, &s.points, &s.grid(), &s.origin, None, &mut two)
    });
    assert_eq!(st.heads_skipped, skipped);
    assert_eq!(one.free_bricks(), two.free_bricks());
    assert_eq!(one.occupied_bricks(), two.occupied_bricks());
}
