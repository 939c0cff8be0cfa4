//! The point filters (`MapperOptions::filters`, `map --min-range/--crop-sensor/--crop-world/
//! --zmin/--zmax/--ground/--drop-zero`): each against a naive definition written here, the
//! RANSAC ground filter on a scene with a known plane and on real LiDAR data, the counts in
//! the statistics and in `map --json`, and checkpoints refusing a resume with other filters.

use crate::common::{self, scratch};
use nalgebra::{Isometry3, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};
use octoquant::checkpoint::RunIdentity;
use octoquant::filters::{fit_ground_plane, CropBox, DroppedPoints, GroundFilter, PointFilters};
use octoquant::frame::CameraPixels;
use octoquant::octree::io::write_bt;
use octoquant::pipeline::{FrameStats, InsertMode, Mapper, MapperOptions};
use octoquant::raycast::PinholeCamera;
use octoquant::Frame;
use std::path::Path;
use std::process::Command;

/// A deterministic generator (64-bit LCG, high bits), independent of the library's.
struct Lcg(u64);

impl Lcg {
    fn unit(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
}

/// Points around `origin` up to 8 m away, with NaN/inf points, points exactly at the origin and
/// points exactly on the test boxes' faces mixed in.
fn cloud(origin: Point3<f32>, n: usize, seed: u64) -> Vec<Point3<f32>> {
    let mut r = Lcg(seed);
    let mut pts = Vec::with_capacity(n);
    for i in 0..n {
        let p = match i % 50 {
            0 => Point3::new(f32::NAN, 1.0, 1.0),
            1 => Point3::new(1.0, f32::INFINITY, 0.0),
            2 | 3 => origin,
            4 => Point3::new(origin.x + 1.0, origin.y - 0.5, -0.5), // on the crop_sensor face x
            5 => Point3::new(2.0, 3.0, 4.0),                        // on the world box's max
            6 => Point3::new(0.5, -1.0, -0.25),                     // exactly z_min
            _ => Point3::new(
                origin.x + r.range(-8.0, 8.0) as f32,
                origin.y + r.range(-8.0, 8.0) as f32,
                origin.z + r.range(-3.0, 3.0) as f32,
            ),
        };
        pts.push(p);
    }
    pts
}

/// The filters by the book, one point at a time: which points are kept, and the reason each
/// dropped point is counted under (the first that applies, in the documented order). The
/// sensor-frame point is `rotation⁻¹ (p − origin)`.
fn naive(
    f: &PointFilters,
    origin: Point3<f32>,
    rotation: Rotation3<f64>,
    pts: &[Point3<f32>],
) -> (Vec<usize>, usize, usize, DroppedPoints) {
    let mut kept = Vec::new();
    let (mut non_finite, mut zero) = (0, 0);
    let mut d = DroppedPoints::default();
    let inside = |b: &CropBox, x: f64, y: f64, z: f64| {
        b.min.x <= x && x <= b.max.x && b.min.y <= y && y <= b.max.y && b.min.z <= z && z <= b.max.z
    };
    for (i, p) in pts.iter().enumerate() {
        if !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()) {
            non_finite += 1;
            continue;
        }
        let is_zero = p.x == origin.x && p.y == origin.y && p.z == origin.z;
        if is_zero {
            zero += 1;
            if f.drop_zero {
                d.zero += 1;
                continue;
            }
        }
        let (dx, dy, dz) = (
            p.x as f64 - origin.x as f64,
            p.y as f64 - origin.y as f64,
            p.z as f64 - origin.z as f64,
        );
        if let Some(m) = f.min_range {
            if (dx * dx + dy * dy + dz * dz).sqrt() < m {
                d.min_range += 1;
                continue;
            }
        }
        if let Some(b) = &f.crop_sensor {
            let s = rotation.transpose() * Vector3::new(dx, dy, dz);
            if inside(b, s.x, s.y, s.z) {
                d.crop_sensor += 1;
                continue;
            }
        }
        if let Some(b) = &f.crop_world {
            if !inside(b, p.x as f64, p.y as f64, p.z as f64) {
                d.crop_world += 1;
                continue;
            }
        }
        let z = p.z as f64;
        if f.z_min.is_some_and(|m| z < m) || f.z_max.is_some_and(|m| z > m) {
            d.z_band += 1;
            continue;
        }
        kept.push(i);
    }
    (kept, non_finite, zero, d)
}

fn crop(v: [f64; 6]) -> Option<CropBox> {
    Some(CropBox::from_slice("test", &v).unwrap())
}

/// Each filter alone, then all together: the kept points (exactly) and the counts.
fn filter_cases() -> Vec<(&'static str, PointFilters)> {
    let none = PointFilters::default();
    let sensor_box = crop([-1.0, -0.5, -0.5, 1.0, 0.5, 0.5]);
    let world_box = crop([-4.0, -3.0, -1.0, 2.0, 3.0, 4.0]);
    vec![
        (
            "drop_zero",
            PointFilters {
                drop_zero: true,
                ..none
            },
        ),
        (
            "min_range",
            PointFilters {
                min_range: Some(2.5),
                ..none
            },
        ),
        (
            "crop_sensor",
            PointFilters {
                crop_sensor: sensor_box,
                ..none
            },
        ),
        (
            "crop_world",
            PointFilters {
                crop_world: world_box,
                ..none
            },
        ),
        (
            "z_band",
            PointFilters {
                z_min: Some(-0.25),
                z_max: Some(1.5),
                ..none
            },
        ),
        (
            "z_min only",
            PointFilters {
                z_min: Some(0.75),
                ..none
            },
        ),
        (
            "all",
            PointFilters {
                drop_zero: true,
                min_range: Some(1.0),
                crop_sensor: crop([-3.0, -0.5, -0.5, 1.0, 0.5, 0.5]),
                crop_world: world_box,
                z_min: Some(-0.25),
                z_max: Some(1.5),
                ground: None,
            },
        ),
    ]
}

#[test]
fn each_filter_keeps_exactly_what_its_definition_keeps() {
    let origin = Point3::new(0.25f32, -0.5, 0.0);
    let pts = cloud(origin, 5000, 1);
    for rotation in [
        Rotation3::identity(),
        Rotation3::from_euler_angles(0.1, -0.2, 1.3),
    ] {
        let q = UnitQuaternion::from_rotation_matrix(&rotation);
        for (name, f) in filter_cases() {
            let (kept, non_finite, zero, dropped) = naive(&f, origin, rotation, &pts);
            let mut out = Vec::new();
            let mut px = Vec::new();
            let c = f.apply(&origin, &q, &pts, None, &mut out, &mut px);
            let expect: Vec<Point3<f32>> = kept.iter().map(|&i| pts[i]).collect();
            assert_eq!(out, expect, "{name}");
            assert_eq!(c.dropped, dropped, "{name}");
            assert_eq!((c.non_finite, c.zero), (non_finite, zero), "{name}");
            assert!(dropped.total() > 0, "{name}");
            assert_eq!(
                non_finite + dropped.total() + kept.len(),
                pts.len(),
                "{name}"
            );
            // the pixels follow their points
            let pixels: Vec<u32> = (0..pts.len() as u32).map(|i| i * 3).collect();
            let (mut out2, mut px2) = (Vec::new(), Vec::new());
            f.apply(&origin, &q, &pts, Some(&pixels), &mut out2, &mut px2);
            let expect_px: Vec<u32> = kept.iter().map(|&i| pixels[i]).collect();
            assert_eq!((out2, px2), (expect, expect_px), "{name}");
        }
    }
}

fn bt(tree: &mut octoquant::OcTree) -> Vec<u8> {
    let mut v = Vec::new();
    write_bt(tree, &mut v).unwrap();
    v
}

/// The counts a filtered mapper reports per frame and in total, and the tree: the same as an
/// unfiltered mapper given only the points the naive definition keeps, in every mode.
#[test]
fn mapper_with_filters_equals_mapper_on_prefiltered_points() {
    let frames: Vec<Frame> = (0..4)
        .map(|i| {
            let o = Point3::new(0.25 * i as f32, -0.5, 0.1 * i as f32);
            Frame::new_f32(o, cloud(o, 3000, 10 + i as u64))
        })
        .collect();
    for mode in [
        InsertMode::Exact,
        InsertMode::Discretize,
        InsertMode::Quantized,
        InsertMode::QuantizedBresenham,
        InsertMode::Simple,
    ] {
        for (name, f) in filter_cases() {
            let base = MapperOptions {
                resolution: 0.2,
                mode,
                max_range: Some(6.0),
                ..MapperOptions::default()
            };
            let mut filtered = Mapper::new(MapperOptions {
                filters: f,
                ..base.clone()
            })
            .unwrap();
            let got = filtered.insert_frames(&frames);
            let mut plain = Mapper::new(base.clone()).unwrap();
            let mut total = DroppedPoints::default();
            for (fr, st) in frames.iter().zip(&got) {
                let (kept, non_finite, zero, dropped) =
                    naive(&f, fr.origin, Rotation3::identity(), &fr.points);
                let pre = Frame::new_f32(fr.origin, kept.iter().map(|&i| fr.points[i]).collect());
                let p = plain.insert(&pre);
                assert_eq!(st.dropped, dropped, "{name} {}", mode.name());
                assert_eq!(st.zero, zero, "{name}");
                assert_eq!(st.non_finite, non_finite, "{name}");
                assert_eq!(st.points, fr.points.len());
                assert_eq!(
                    (st.rays, st.free, st.occupied),
                    (p.rays, p.free, p.occupied)
                );
                total.add(&dropped);
            }
            assert_eq!(filtered.stats().total.dropped, total, "{name}");
            assert_eq!(
                bt(&mut filtered.into_tree()),
                bt(&mut plain.into_tree()),
                "{name} {}",
                mode.name()
            );
        }
    }
}

/// `insert_sensor_frame` (and its `_f32` twin) takes the crop box in the pose's axes.
#[test]
fn sensor_crop_box_follows_the_pose() {
    let pose = Isometry3::from_parts(
        Translation3::new(1.0, 2.0, 0.5),
        UnitQuaternion::from_euler_angles(0.0, 0.0, std::f64::consts::FRAC_PI_2),
    );
    let local = cloud(Point3::origin(), 4000, 3);
    let b = crop([-2.0, -0.5, -1.0, 0.5, 0.5, 1.0]);
    let f = PointFilters {
        crop_sensor: b,
        ..PointFilters::default()
    };
    let base = MapperOptions {
        resolution: 0.2,
        ..MapperOptions::default()
    };
    let mut m = Mapper::new(MapperOptions {
        filters: f,
        ..base.clone()
    })
    .unwrap();
    let st = m.insert_sensor_frame_f32(&local, &pose);
    // the f64 method on the widened points is the same insertion, bit for bit
    let mut wide = Mapper::new(MapperOptions {
        filters: f,
        ..base.clone()
    })
    .unwrap();
    let widened: Vec<Point3<f64>> = local.iter().map(|p| p.cast::<f64>()).collect();
    let untimed = |s: FrameStats| FrameStats {
        seconds: 0.0,
        ray_seconds: 0.0,
        tree_seconds: 0.0,
        ..s
    };
    assert_eq!(
        untimed(wide.insert_sensor_frame(&widened, &pose)),
        untimed(st)
    );
    // the naive definition in the sensor frame itself: the points as given
    let b = b.unwrap();
    let keep: Vec<Point3<f32>> = local
        .iter()
        .filter(|p| !p.iter().all(|c| c.is_finite()) || !b.contains(&p.cast::<f64>()))
        .copied()
        .collect();
    assert!(st.dropped.crop_sensor > 100, "{st:?}");
    assert_eq!(st.dropped.crop_sensor, local.len() - keep.len());
    let mut plain = Mapper::new(base).unwrap();
    plain.insert_sensor_frame_f32(&keep, &pose);
    let tree = bt(&mut m.into_tree());
    assert_eq!(tree, bt(&mut plain.into_tree()));
    assert_eq!(tree, bt(&mut wide.into_tree()));
}

/// A depth-image frame keeps its pixel grid through the filters: the same tree as the naive
/// prefiltered points without a camera, and the grid is still used.
#[test]
fn filtered_depth_frame_keeps_its_pixel_grid() {
    let camera = PinholeCamera {
        width: 64,
        height: 48,
        fx: 50.0,
        fy: 50.0,
        cx: 32.0,
        cy: 24.0,
        rotation: Rotation3::from_euler_angles(-std::f64::consts::FRAC_PI_2, 0.0, 0.0),
    };
    let origin = Point3::new(0.0f32, 0.0, 1.0);
    let mut r = Lcg(9);
    let (mut points, mut pixels) = (Vec::new(), Vec::new());
    for v in 0..camera.height {
        for u in 0..camera.width {
            let d = camera.rotation
                * Vector3::new(
                    (u as f64 - camera.cx) / camera.fx,
                    (v as f64 - camera.cy) / camera.fy,
                    1.0,
                );
            let depth = if (u + v) % 37 == 0 {
                0.0
            } else {
                r.range(3.0, 6.0)
            };
            let p = origin.cast::<f64>() + d * depth;
            points.push(p.cast::<f32>());
            pixels.push(v * camera.width + u);
        }
    }
    let frame = Frame {
        camera: Some(CameraPixels { camera, pixels }),
        ..Frame::new_f32(origin, points)
    };
    let f = PointFilters {
        drop_zero: true,
        z_max: Some(1.8),
        ..PointFilters::default()
    };
    let base = MapperOptions {
        resolution: 0.05,
        ..MapperOptions::default()
    };
    let mut m = Mapper::new(MapperOptions {
        filters: f,
        ..base.clone()
    })
    .unwrap();
    let st = m.insert(&frame);
    let (kept, _, zero, dropped) = naive(&f, origin, Rotation3::identity(), &frame.points);
    assert!(zero > 0 && dropped.z_band > 0, "{dropped:?}");
    assert_eq!(st.dropped, dropped);
    assert!(st.heads_skipped > 0, "{st:?}");
    let mut plain = Mapper::new(base).unwrap();
    plain.insert(&Frame::new_f32(
        origin,
        kept.iter().map(|&i| frame.points[i]).collect(),
    ));
    assert_eq!(bt(&mut m.into_tree()), bt(&mut plain.into_tree()));
}

/// Without filters, zero points are counted and inserted as OctoMap's insertPointCloud does.
#[test]
fn zero_points_are_counted_and_kept_by_default() {
    let origin = Point3::new(0.3f32, 0.2, 0.1);
    let pts = cloud(origin, 2000, 4);
    let zeros = pts.iter().filter(|p| **p == origin).count();
    assert!(zeros > 0);
    let mut m = Mapper::new(MapperOptions::default()).unwrap();
    let st = m.insert(&Frame::new_f32(origin, pts.clone()));
    assert_eq!((st.zero, st.dropped.total()), (zeros, 0));
    let mut tree = octoquant::OcTree::new(0.1).unwrap();
    octoquant::raycast::insert_point_cloud_f32(
        &mut tree,
        &pts,
        &origin,
        &octoquant::raycast::InsertOptions::default(),
    );
    assert_eq!(bt(&mut m.into_tree()), bt(&mut tree));
}

/// A scene with a known ground plane (tilted 1.5°, 1.6 m below the sensor, ±1 cm noise),
/// walls, boxes and a larger ceiling above the sensor.
fn ground_scene(seed: u64) -> (Vec<Point3<f32>>, Vec<bool>, Vector3<f64>, f64) {
    let normal = Vector3::new(0.02, -0.015, 1.0).normalize();
    let offset = 1.6; // normal · p + offset = 0 passes 1.6 m below the origin (approximately)
    let mut r = Lcg(seed);
    let (mut pts, mut is_ground) = (Vec::new(), Vec::new());
    for _ in 0..6000 {
        let (x, y) = (r.range(-10.0, 10.0), r.range(-10.0, 10.0));
        let z = -(normal.x * x + normal.y * y + offset) / normal.z + r.range(-0.01, 0.01);
        pts.push(Point3::new(x as f32, y as f32, z as f32));
        is_ground.push(true);
    }
    // a larger ceiling 2 m above the sensor: never the ground
    for _ in 0..9000 {
        let (x, y) = (r.range(-12.0, 12.0), r.range(-12.0, 12.0));
        pts.push(Point3::new(x as f32, y as f32, 2.0));
        is_ground.push(false);
    }
    // walls and boxes standing at least 10 cm above the ground
    for _ in 0..4000 {
        let (y, z) = (r.range(-10.0, 10.0), r.range(-1.3, 1.9));
        pts.push(Point3::new(9.5, y as f32, z as f32));
        is_ground.push(false);
        let (x, y, z) = (r.range(2.0, 3.0), r.range(-1.0, 1.0), r.range(-1.4, -0.5));
        pts.push(Point3::new(x as f32, y as f32, z as f32));
        is_ground.push(false);
    }
    (pts, is_ground, normal, offset)
}

#[test]
fn ransac_ground_recovers_a_known_plane_deterministically() {
    let (pts, is_ground, normal, offset) = ground_scene(5);
    let p64: Vec<Point3<f64>> = pts.iter().map(|p| p.cast()).collect();
    let g = GroundFilter::with_distance(0.05);
    let plane = fit_ground_plane(&p64, &Point3::origin(), &g).expect("a ground plane");
    assert!((plane.normal - normal).norm() < 2e-3, "{plane:?}");
    assert!((plane.offset - offset).abs() < 5e-3, "{plane:?}");
    for seed in [1, 2, 99] {
        let other = fit_ground_plane(&p64, &Point3::origin(), &GroundFilter { seed, ..g }).unwrap();
        assert!(
            (other.normal - normal).norm() < 2e-3,
            "seed {seed}: {other:?}"
        );
    }

    // every ground point dropped, no other point
    let f = PointFilters {
        ground: Some(g),
        ..PointFilters::default()
    };
    let (mut out, mut px) = (Vec::new(), Vec::new());
    let c = f.apply(
        &Point3::origin(),
        &UnitQuaternion::identity(),
        &pts,
        None,
        &mut out,
        &mut px,
    );
    let others: Vec<Point3<f32>> = pts
        .iter()
        .zip(&is_ground)
        .filter(|(_, g)| !**g)
        .map(|(p, _)| *p)
        .collect();
    assert_eq!(c.dropped.ground, is_ground.iter().filter(|g| **g).count());
    assert_eq!(out, others);

    // the same map on every run and for any thread count
    let frames: Vec<Frame> = (0..4)
        .map(|i| {
            let (p, ..) = ground_scene(20 + i);
            Frame::new_f32(Point3::new(0.0, 0.0, 0.0), p)
        })
        .collect();
    let options = MapperOptions {
        resolution: 0.2,
        filters: f,
        ..MapperOptions::default()
    };
    let mut runs = Vec::new();
    for threads in [1, 2, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let (bytes, stats) = pool.install(|| {
            let mut m = Mapper::new(options.clone()).unwrap();
            m.insert_frames(&frames);
            let s = m.stats().total.dropped;
            (bt(&mut m.into_tree()), s)
        });
        assert!(stats.ground >= 4 * 5900, "{stats:?}");
        runs.push((bytes, stats));
    }
    assert!(runs.windows(2).all(|w| w[0] == w[1]));
}

/// No ground is found where there is none, and tiny clouds are handled.
#[test]
fn ransac_ground_needs_a_plane_below_the_sensor() {
    let g = GroundFilter::with_distance(0.05);
    let (pts, is_ground, ..) = ground_scene(6);
    let above: Vec<Point3<f64>> = pts
        .iter()
        .zip(&is_ground)
        .filter(|(_, g)| !**g)
        .map(|(p, _)| p.cast())
        .collect();
    // without the ground, every near-horizontal plane through the points passes above a
    // sensor below them all
    let sensor = Point3::new(0.0, 0.0, -5.0);
    assert_eq!(fit_ground_plane(&above, &sensor, &g), None);
    assert_eq!(fit_ground_plane(&above[..2], &Point3::origin(), &g), None);
    assert_eq!(fit_ground_plane(&[], &Point3::origin(), &g), None);
}

/// norlab's outdoor LiDAR: the ground under the (stationary) sensor is found, at the height
/// a brute-force histogram of the points near the sensor gives, and removing it leaves no
/// dense layer there; the same counts on every run.
#[test]
fn ransac_ground_on_real_lidar() {
    let Some(dir) = common::data_file("lidar3d/norlab_icp_mapper_example") else {
        return;
    };
    let frames = octoquant::formats::read_frames(&dir, &Default::default()).unwrap();
    let f = &frames[0];
    let o = f.origin.cast::<f64>();
    let g = GroundFilter::with_distance(0.1);
    let p64: Vec<Point3<f64>> = f
        .points
        .iter()
        .filter(|p| p.iter().all(|c| c.is_finite()))
        .map(|p| p.cast())
        .collect();
    let plane = fit_ground_plane(&p64, &o, &g).expect("ground");
    assert!(plane.normal.z > 0.15f64.cos(), "{plane:?}");
    // The robot stands on the ground: in the sensor's own frame (the trajectory's first pose;
    // the world frame is pitched by about 2 degrees) the ground is level, at the height of the
    // densest 10 cm slice of the points 3 to 8 m away horizontally (nearer, the robot's own
    // body is denser), found by brute force.
    let poses = octoquant::formats::vtk::read_trajectory_csv(&dir.join("trajectory.csv")).unwrap();
    let rot = poses[0].rotation;
    assert_eq!(f.origin, Point3::from(poses[0].translation.cast::<f32>()));
    let local: Vec<Point3<f64>> = p64
        .iter()
        .map(|p| Point3::from(rot.inverse() * (p - o)))
        .collect();
    let mut hist = std::collections::BTreeMap::new();
    for p in &local {
        if (3.0..8.0).contains(&p.x.hypot(p.y)) && p.z < 0.0 {
            *hist.entry((p.z / 0.1).floor() as i64).or_insert(0usize) += 1;
        }
    }
    let (&slice, _) = hist.iter().max_by_key(|(k, n)| (**n, -**k)).unwrap();
    let histogram_z = (slice as f64 + 0.5) * 0.1;
    let normal_local = rot.inverse() * plane.normal;
    let ground_under_sensor = -plane.distance(&o) / normal_local.z;
    assert!(
        normal_local.z > 0.03f64.cos(),
        "the ground is level in the sensor frame: {normal_local:?}"
    );
    assert!(
        (ground_under_sensor - histogram_z).abs() < 0.1,
        "plane at {ground_under_sensor}, histogram at {histogram_z}"
    );
    let filters = PointFilters {
        ground: Some(g),
        ..PointFilters::default()
    };
    let run = || {
        frames[..4]
            .iter()
            .map(|f| {
                let (mut out, mut px) = (Vec::new(), Vec::new());
                let c = filters.apply(
                    &f.origin,
                    &UnitQuaternion::identity(),
                    &f.points,
                    None,
                    &mut out,
                    &mut px,
                );
                c.dropped.ground
            })
            .collect::<Vec<_>>()
    };
    let a = run();
    assert_eq!(a, run());
    // a large part of a ground robot's LiDAR returns are ground
    for (n, fr) in a.iter().zip(&frames) {
        assert!(*n * 10 > fr.points.len(), "{n} of {}", fr.points.len());
    }
}

/// A checkpoint records the filters: resuming with other filters is refused, naming them.
#[test]
fn resume_with_other_filters_is_refused() {
    let frames: Vec<Frame> = (0..3)
        .map(|i| {
            let o = Point3::new(0.0f32, 0.0, i as f32 * 0.1);
            Frame::new_f32(o, cloud(o, 500, 30 + i))
        })
        .collect();
    let a = MapperOptions {
        resolution: 0.2,
        filters: PointFilters {
            z_min: Some(-1.0),
            ..PointFilters::default()
        },
        ..MapperOptions::default()
    };
    let dir = scratch("filters-resume");
    let id = RunIdentity::new(&a, Vec::new(), &frames);
    let mut m = Mapper::new(a.clone()).unwrap();
    m.insert_frames(&frames[..1]);
    m.save_checkpoint(&dir, &id).unwrap();
    for (key, other) in [
        (
            "z_min",
            PointFilters {
                z_min: Some(-0.5),
                ..a.filters
            },
        ),
        (
            "ground",
            PointFilters {
                ground: Some(GroundFilter::with_distance(0.1)),
                ..a.filters
            },
        ),
        (
            "drop_zero",
            PointFilters {
                drop_zero: true,
                ..a.filters
            },
        ),
    ] {
        let b = MapperOptions {
            filters: other,
            ..a.clone()
        };
        let e = Mapper::resume(&dir, &RunIdentity::new(&b, Vec::new(), &frames))
            .err()
            .unwrap_or_else(|| panic!("resume with other {key} accepted"));
        assert!(e.to_string().contains(key), "{key}: {e}");
    }
    let resumed = Mapper::resume(&dir, &id).unwrap();
    assert_eq!(resumed.options().filters, a.filters);
    assert_eq!(resumed.stats(), m.stats());
}

fn octoquant(args: &[&str], extra: &[&Path]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .args(args)
        .args(extra)
        .output()
        .unwrap()
}

/// The CLI: negative values, errors naming the option, the counts in `--json` equal to the
/// library's, any output name in valid JSON, and `--resume` refusing filter options.
#[test]
fn cli_filters_and_json() {
    let Some(dat) = common::data_file("lidar3d/octomap_scan_dat/scan.dat.bz2") else {
        return;
    };
    let dir = scratch("filters-cli");
    let out = dir.join("we\"ird \\ name.bt");
    let args = [
        "map",
        "--res",
        "0.2",
        "--min-range",
        "0.5",
        "--crop-sensor",
        "-1",
        "-1",
        "-1",
        "1",
        "1",
        "1",
        "--crop-world",
        "-15",
        "-15",
        "-3",
        "15",
        "15",
        "5",
        "--zmin",
        "-0.5",
        "--zmax",
        "2",
        "--drop-zero",
        "--json",
        "--ot",
    ];
    let ot = dir.join("m.ot");
    let o = octoquant(&args, &[&ot, Path::new("-o"), &out, &dat]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(json["outputs"]["bt"], out.to_string_lossy().as_ref());
    assert_eq!(json["output"], out.to_string_lossy().as_ref());
    assert_eq!(json["outputs"]["ot"], ot.to_string_lossy().as_ref());
    assert_eq!(json["resolution"], 0.2);
    assert!(
        json["bounds"]["min"][2].as_f64().unwrap() < json["bounds"]["max"][2].as_f64().unwrap()
    );

    let frames = octoquant::formats::read_frames(&dat, &Default::default()).unwrap();
    let filters = PointFilters {
        drop_zero: true,
        min_range: Some(0.5),
        crop_sensor: crop([-1.0, -1.0, -1.0, 1.0, 1.0, 1.0]),
        crop_world: crop([-15.0, -15.0, -3.0, 15.0, 15.0, 5.0]),
        z_min: Some(-0.5),
        z_max: Some(2.0),
        ground: None,
    };
    let mut m = Mapper::new(MapperOptions {
        resolution: 0.2,
        filters,
        ..MapperOptions::default()
    })
    .unwrap();
    m.insert_frames(&frames);
    let t = m.stats().total;
    let d = &json["dropped"];
    for (name, n) in t.dropped.named() {
        assert_eq!(d[name], n, "{name}: {json}");
    }
    assert!(t.dropped.z_band > 0 && t.dropped.crop_world > 0, "{t:?}");
    assert_eq!(d["non_finite"], t.non_finite);
    assert_eq!(d["outside_map"], t.outside_map);
    assert_eq!(json["zero_points"], t.zero);
    assert_eq!(
        json["dropped_total"],
        t.non_finite + t.outside_map + t.dropped.total()
    );
    assert_eq!(
        std::fs::read(&out).unwrap(),
        bt(&mut m.into_tree()),
        "the CLI's map is the library's"
    );

    // errors name the option
    for (bad, name) in [
        (
            vec!["--crop-world", "1", "0", "0", "0", "1", "1"],
            "--crop-world",
        ),
        (
            vec!["--crop-sensor", "0", "0", "nan", "1", "1", "1"],
            "--crop-sensor",
        ),
        (vec!["--min-range", "-1"], "--min-range"),
        (vec!["--zmin", "2", "--zmax", "1"], "--zmin"),
        (vec!["--ground", "-0.1"], "--ground"),
    ] {
        let mut a = vec!["map"];
        a.extend(&bad);
        let o = octoquant(&a, &[Path::new("-o"), &dir.join("bad.bt"), &dat]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(name), "{bad:?}: {err}");
        assert!(!dir.join("bad.bt").exists());
    }
    // --resume takes the filters from the checkpoint: giving one is refused
    let o = octoquant(&["map", "--resume", "ck", "--zmin", "-1"], &[]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("--zmin"), "{err}");
}

/// The first norlab frame with every 8th point; `None` without the data.
fn norlab_first_frame_every_8th_point() -> Option<Frame> {
    let input = common::data_file("lidar3d/norlab_icp_mapper_example")?;
    let f = octoquant::formats::frame_stream(&input, &Default::default())
        .unwrap()
        .next()
        .unwrap()
        .unwrap();
    Some(Frame::new_f32(
        f.origin,
        f.points.into_iter().step_by(8).collect(),
    ))
}

/// The ground filter at 0.1 m, its points kept to clear space.
fn clearing_ground() -> PointFilters {
    PointFilters {
        ground: Some(GroundFilter {
            clear: true,
            ..GroundFilter::with_distance(0.1)
        }),
        ..PointFilters::default()
    }
}

/// Run a reference-program script (`script` or `color-script` `mode`) in `dir`; it must
/// succeed.
fn run_reference(mode: &str, script: &str, dir: &Path) {
    let Some(refprog) = common::reference_program() else {
        return;
    };
    let sp = dir.join(format!("{mode}.txt"));
    std::fs::write(&sp, script).unwrap();
    let out = Command::new(refprog)
        .current_dir(dir)
        .arg(mode)
        .arg(&sp)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "reference program: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// `octoquant map ARGS` in `dir`, which must succeed; the bytes of the map it wrote to `out`.
fn map_cli(dir: &Path, args: &[&str], out: &str) -> Vec<u8> {
    let o = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .current_dir(dir)
        .arg("map")
        .args(args)
        .args(["-q", "-o", out])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    std::fs::read(dir.join(out)).unwrap()
}

/// `--ground D --ground-clears` inserts the ground points as octomap_server does, as free
/// space: their rays clear, their end voxels stay as they were. On norlab's LiDAR (2 frames,
/// every 8th point, synthetic colours) the library's filter splits each frame into its hits and
/// its ground, and the reference program inserts both with liboctomap: `computeUpdate` of the
/// hits, the ground rays added to its free keys (`insertPointCloud`'s steps), and, for `--color`,
/// octomap_server's colour `insertScan` with the ground loop first. The `.bt` and the colour
/// `.ot` are byte-identical to `map`'s, with and without a maximum range that cuts ground rays;
/// and dropping the ground instead gives another map.
#[test]
fn clearing_ground_points_match_octomap_server() {
    let (Some(_), Some(input)) = (
        common::reference_program(),
        common::data_file("lidar3d/norlab_icp_mapper_example"),
    ) else {
        return;
    };
    let all = octoquant::formats::read_frames(&input, &Default::default()).unwrap();
    let frames: Vec<Frame> = all
        .into_iter()
        .take(2)
        .map(|f| {
            let points: Vec<Point3<f32>> = f.points.into_iter().step_by(8).collect();
            let colors = (0..points.len())
                .map(|i| octoquant::octree::Color::new(i as u8, (i >> 8) as u8, 99))
                .collect();
            Frame {
                colors: Some(colors),
                ..Frame::new_f32(f.origin, points)
            }
        })
        .collect();
    let dir = scratch("filters_ground_clears");
    octoquant::formats::frames::write_frames_file(&dir.join("all.frames"), &frames).unwrap();
    // the library's split: hits first, then the ground points (with their colours)
    let filters = clearing_ground();
    let (mut hits, mut ground, mut hit_colors) = (Vec::new(), Vec::new(), Vec::new());
    hit_colors.extend_from_slice(&(frames.len() as u32).to_le_bytes());
    for f in &frames {
        let index: Vec<u32> = (0..f.points.len() as u32).collect();
        let (mut out, mut kept) = (Vec::new(), Vec::new());
        let id = UnitQuaternion::identity();
        let c = filters.apply(&f.origin, &id, &f.points, Some(&index), &mut out, &mut kept);
        assert_eq!(c.dropped.ground, 0);
        assert!(
            c.clearing * 10 > f.points.len(),
            "{} ground points",
            c.clearing
        );
        let split = out.len() - c.clearing;
        hits.push(Frame::new_f32(f.origin, out[..split].to_vec()));
        ground.push(Frame::new_f32(f.origin, out[split..].to_vec()));
        let colors = f.colors.as_ref().unwrap();
        hit_colors.extend_from_slice(&(split as u32).to_le_bytes());
        for &i in &kept[..split] {
            hit_colors.extend_from_slice(&colors[i as usize].to_array());
        }
    }
    octoquant::formats::frames::write_frames_file(&dir.join("hits.frames"), &hits).unwrap();
    octoquant::formats::frames::write_frames_file(&dir.join("ground.frames"), &ground).unwrap();
    std::fs::write(dir.join("hits.colors"), &hit_colors).unwrap();
    let res = "0.2";
    for range in [None, Some("15")] {
        let mut args = vec![
            "all.frames",
            "--res",
            res,
            "--ground",
            "0.1",
            "--ground-clears",
        ];
        args.extend(range.iter().flat_map(|r| ["--max-range", *r]));
        let ours = map_cli(&dir, &args, "ours.bt");
        let maxrange = range.map_or(String::new(), |r| format!(" maxrange {r}"));
        run_reference(
            "script",
            &format!(
                "tree {res}\ninsert hits.frames{maxrange} ground ground.frames\nwrite_bt ref.bt\n"
            ),
            &dir,
        );
        let theirs = std::fs::read(dir.join("ref.bt")).unwrap();
        assert!(
            ours == theirs,
            "max range {range:?}: {}",
            common::first_diff(&ours, &theirs)
        );
        // dropping the ground is another map
        let drop_args: Vec<&str> = args
            .iter()
            .copied()
            .filter(|a| *a != "--ground-clears")
            .collect();
        let dropped = map_cli(&dir, &drop_args, "drop.bt");
        assert!(dropped != ours);

        args.push("--color");
        let ours = map_cli(&dir, &args, "ours.ot");
        let r = range.unwrap_or("-1");
        run_reference(
            "color-script",
            &format!("tree {res}\ncolorscan hits.frames hits.colors average {r} ground.frames\nwrite_ot ref.ot\n"),
            &dir,
        );
        let theirs = std::fs::read(dir.join("ref.ot")).unwrap();
        assert!(
            ours == theirs,
            "colour, max range {range:?}: {}",
            common::first_diff(&ours, &theirs)
        );
    }
}

/// In every insertion mode, a frame whose ground points clear space: the map that drops them
/// instead holds nothing the clearing map does not (each of its leaves' voxels has the same
/// log-odds there), their occupied voxels are the same, and the clearing map knows more of the
/// space (the ground rays' voxels). One norlab frame, every 8th point.
#[test]
fn clearing_ground_points_only_add_free_space_in_every_mode() {
    let Some(frame) = norlab_first_frame_every_8th_point() else {
        return;
    };
    let known_volume = |t: &octoquant::OcTree| -> f64 {
        t.leaves().map(|l| 8f64.powi(16 - i32::from(l.depth))).sum()
    };
    for mode in [
        InsertMode::Exact,
        InsertMode::Discretize,
        InsertMode::Quantized,
        InsertMode::QuantizedBresenham,
    ] {
        let map = |clear: bool| {
            let options = MapperOptions {
                resolution: 0.2,
                mode,
                filters: PointFilters {
                    ground: Some(GroundFilter {
                        clear,
                        ..GroundFilter::with_distance(0.1)
                    }),
                    ..PointFilters::default()
                },
                ..MapperOptions::default()
            };
            let mut m = Mapper::new(options).unwrap();
            let st = m.insert(&frame);
            (m.into_tree(), st)
        };
        let (dropping, sd) = map(false);
        let (clearing, sc) = map(true);
        assert!(
            sd.dropped.ground > 1000 && sc.dropped.ground == 0,
            "{mode:?}"
        );
        assert_eq!(sc.clearing, sd.dropped.ground, "{mode:?}");
        assert_eq!(sc.occupied, sd.occupied, "{mode:?}");
        assert!(sc.free > sd.free, "{mode:?}");
        let same = |from: &octoquant::OcTree, to: &octoquant::OcTree, only_occupied: bool| {
            for l in from.leaves() {
                if only_occupied && l.value <= 0.0 {
                    continue;
                }
                let there = to.search(l.key, 16).map(|n| n.value);
                assert_eq!(there, Some(l.value), "{mode:?} at {:?}", l.key);
            }
        };
        same(&dropping, &clearing, false);
        same(&clearing, &dropping, true);
        assert!(
            known_volume(&clearing) > known_volume(&dropping) * 1.01,
            "{mode:?}"
        );
    }
}

/// `simple` mode (OctoMap's `insertPointCloudRays`, ray by ray) with the ground kept to clear:
/// the hits' rays as OctoMap inserts them, then each ground point's ray as misses one key at a
/// time (no hit), in order. One norlab frame, every 8th point.
#[test]
fn clearing_ground_points_in_simple_mode_are_rays_of_misses() {
    use octoquant::octree::{InnerNodes, Update};
    use octoquant::raycast::{compute_ray_keys_f32, insert_point_cloud_rays_f32, KeyRay};
    let Some(frame) = norlab_first_frame_every_8th_point() else {
        return;
    };
    let filters = clearing_ground();
    let options = MapperOptions {
        resolution: 0.2,
        mode: InsertMode::Simple,
        filters,
        ..MapperOptions::default()
    };
    let mut m = Mapper::new(options.clone()).unwrap();
    let st = m.insert(&frame);
    let mut ours = m.into_tree();
    // the naive insertion of the library's split
    let (mut kept, mut px) = (Vec::new(), Vec::new());
    let id = UnitQuaternion::identity();
    let c = filters.apply(&frame.origin, &id, &frame.points, None, &mut kept, &mut px);
    assert!(c.clearing > 1000 && st.clearing == c.clearing);
    let (hits, ground) = kept.split_at(kept.len() - c.clearing);
    let mut naive = octoquant::OcTree::with_params(0.2, options.params).unwrap();
    let apply = octoquant::raycast::ApplyOptions { lazy: false };
    insert_point_cloud_rays_f32(&mut naive, hits, &frame.origin, &apply);
    let conv = naive.converter().clone();
    let mut ray = KeyRay::new();
    for p in ground {
        if compute_ray_keys_f32(&conv, &frame.origin, p, &mut ray) {
            for k in ray.keys() {
                naive.update_node(*k, Update::Miss, InnerNodes::Refresh);
            }
        }
    }
    assert!(bt(&mut ours) == bt(&mut naive));
}
