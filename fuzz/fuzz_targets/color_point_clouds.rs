//! Structure-aware: OctoMap's `insertPointCloud` on a `ColorOcTree`
//! (`color_map::insert_point_cloud`: rays in the SIMD lanes, keys handed on ray by ray into
//! `KeySet`s kept as their history) against the same insertion written plainly from OctoMap's
//! `computeUpdate`: each ray walked one key at a time (`walk_ray_keys_f32`) into one `KeySet`,
//! each end point's key into another, then one update per key in the sets' order. Up to 4
//! frames of up to 32 points (any `f32` coordinates, NaN, infinities and points outside the key range included;
//! empty frames; origins anywhere), with colours set on the nodes of some end points between
//! the frames so that the structure's changes move them; an optional maximum range, lazy
//! updates, `discretize`. No call may panic, and the coloured `.ot` bytes must be equal.
#![no_main]
use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use nalgebra::Point3;
use octoquant::color_map::insert_point_cloud;
use octoquant::octree::io::write_color_ot;
use octoquant::octree::{Color, ColorOcTree, InnerNodes, KeySetLog, Update};
use octoquant::raycast::{discretize_f32, max_range_end_f32, walk_ray_keys_f32, RayWalk};
use octoquant::KeyConverter;
use octoquant_fuzz::{written, Place};

#[derive(Arbitrary, Debug)]
struct FuzzFrame {
    /// The origin: near the map's centre, or any `f32`s.
    origin: Place,
    /// End points.
    points: Vec<Place>,
    /// Colours set, before the frame, on the nodes holding its first end points.
    colors: Vec<[u8; 3]>,
}

#[derive(Arbitrary, Debug)]
struct Input {
    frames: Vec<FuzzFrame>,
    resolution: u8,
    max_range: Option<u8>,
    lazy: bool,
    discretize: bool,
}

/// OctoMap's `insertPointCloud` on a `ColorOcTree`, step by step as `computeUpdate` and
/// `insertPointCloud` read.
fn plain_insert(
    tree: &mut ColorOcTree,
    points: &[Point3<f32>],
    origin: &Point3<f32>,
    max_range: f64,
    inner: InnerNodes,
    discretize: bool,
) {
    let conv = tree.converter().clone();
    let mut centres = Vec::new();
    let points = if discretize {
        discretize_f32(&conv, points, &mut centres);
        &centres[..]
    } else {
        points
    };
    let (mut free, mut occupied) = (KeySetLog::new(), KeySetLog::new());
    for p in points {
        if !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()) {
            continue;
        }
        let cut = max_range_end_f32(origin, p, max_range);
        let end = cut.unwrap_or(*p);
        // free_cells.insert(keyray->begin(), keyray->end()) when computeRayKeys succeeds
        let mut range = free.range();
        match walk_ray_keys_f32(&conv, origin, &end, |k| {
            range.key(k);
            true
        }) {
            RayWalk::Complete | RayWalk::SameVoxel => range.finish(),
            _ => range.cancel(),
        }
        if cut.is_none() {
            if let Some(k) = conv.point_to_key(&p.cast::<f64>()) {
                occupied.insert(k);
            }
        }
    }
    for k in free.order() {
        if !occupied.contains(&k) {
            tree.update_node(k, Update::Miss, inner);
        }
    }
    for k in occupied.order() {
        tree.update_node(k, Update::Hit, inner);
    }
}

fuzz_target!(|input: Input| {
    let resolution = [0.05, 0.1, 0.25, 1.0][usize::from(input.resolution % 4)];
    let max_range = input.max_range.map(|r| f64::from(r) * 0.1);
    let inner = InnerNodes::from_lazy(input.lazy);
    let conv = KeyConverter::new(resolution).expect("a valid resolution");
    let mut ours = ColorOcTree::new(resolution).expect("a valid resolution");
    let mut theirs = ours.clone();
    let frames: Vec<(Point3<f32>, Vec<Point3<f32>>, &[[u8; 3]])> = input
        .frames
        .iter()
        .take(4)
        .map(|f| {
            let points = f.points.iter().take(32).map(|p| p.point()).collect();
            (f.origin.point(), points, &f.colors[..])
        })
        .collect();
    // rays may cross the whole key range, and both insertions update every voxel one by one:
    // inputs whose rays sum to more than this many voxels would outlast libFuzzer's 5 s
    let voxels: f64 = frames
        .iter()
        .flat_map(|(o, ps, _)| ps.iter().map(move |p| f64::from((p - o).norm())))
        .filter(|d| d.is_finite())
        .map(|d| max_range.map_or(d, |m| d.min(m)) / resolution)
        .sum();
    if voxels > 100_000.0 {
        return;
    }
    for (origin, points, colors) in &frames {
        let (origin, f_colors) = (*origin, *colors);
        for (p, [r, g, b]) in points.iter().zip(f_colors) {
            if let Some(k) = conv.point_to_key(&p.cast::<f64>()) {
                for t in [&mut ours, &mut theirs] {
                    t.set_node_color(k, Color::new(*r, *g, *b));
                }
            }
        }
        insert_point_cloud(
            &mut ours,
            points,
            &origin,
            max_range,
            inner,
            input.discretize,
        );
        plain_insert(
            &mut theirs,
            points,
            &origin,
            max_range.unwrap_or(-1.0),
            inner,
            input.discretize,
        );
    }
    let (a, b) = (
        written(|w| write_color_ot(&ours, w)),
        written(|w| write_color_ot(&theirs, w)),
    );
    assert!(a == b, "another tree than OctoMap's steps");
});
