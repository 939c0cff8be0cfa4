//! The built-in scene and simulated scanners: determinism, density falling with range,
//! misses, and a map that shows the building.

use nalgebra::{Isometry3, Point3};
use octoquant::parry3d::shape::SharedShape;
use octoquant::scene::{
    scan_lidar, scan_terrestrial, MissPolicy, ScanOptions, Scene, SceneError, SpinningLidar,
    TerrestrialScanner, MISS_RANGE_FACTOR,
};
use octoquant::{Frame, OcTree};
use octoquant_raycast::{insert_point_cloud_f32, InsertOptions};

fn quick_lidar() -> SpinningLidar {
    let mut l = SpinningLidar::builtin_path();
    l.columns = 360;
    l.frame_spacing = 4.0;
    l
}

fn bits(frames: &[Frame]) -> Vec<u32> {
    frames
        .iter()
        .flat_map(|f| {
            std::iter::once(f.origin)
                .chain(f.points.iter().copied())
                .flat_map(|p| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
        })
        .collect()
}

#[test]
fn same_seed_gives_same_bits_and_another_seed_differs() {
    let scene = Scene::builtin();
    let opts = |seed| ScanOptions {
        seed,
        range_noise: 0.02,
        ..ScanOptions::default()
    };
    let (a, _) = scan_lidar(&scene, &quick_lidar(), &opts(42)).unwrap();
    let (b, _) = scan_lidar(&scene, &quick_lidar(), &opts(42)).unwrap();
    let (c, _) = scan_lidar(&scene, &quick_lidar(), &opts(43)).unwrap();
    assert!(a.len() > 10);
    assert_eq!(bits(&a), bits(&b));
    assert_ne!(bits(&a), bits(&c));
    // without noise the seed does not matter
    let quiet = |seed| ScanOptions {
        seed,
        range_noise: 0.0,
        ..ScanOptions::default()
    };
    let (d, _) = scan_lidar(&scene, &quick_lidar(), &quiet(1)).unwrap();
    let (e, _) = scan_lidar(&scene, &quick_lidar(), &quiet(2)).unwrap();
    assert_eq!(bits(&d), bits(&e));
}

/// A 400 m × 400 m flat ground with its top at z = 0.
fn ground() -> Scene {
    Scene::from_shapes(vec![(
        Isometry3::translation(0.0, 0.0, -0.5),
        SharedShape::cuboid(200.0, 200.0, 0.5),
    )])
    .unwrap()
}

/// Points per square metre of ground between horizontal distances `r0` and `r1` from `o`.
fn density(frame: &Frame, r0: f64, r1: f64) -> f64 {
    let o = frame.origin.cast::<f64>();
    let n = frame
        .points
        .iter()
        .filter(|p| {
            let r = ((p.x as f64 - o.x).powi(2) + (p.y as f64 - o.y).powi(2)).sqrt();
            (p.z as f64).abs() < 0.05 && r >= r0 && r < r1
        })
        .count();
    n as f64 / (std::f64::consts::PI * (r1 * r1 - r0 * r0))
}

#[test]
fn terrestrial_density_falls_with_range() {
    let scene = ground();
    let tls = TerrestrialScanner {
        stations: vec![Point3::new(0.0, 0.0, 1.5)],
        angular_step_deg: 0.5,
        min_elevation_deg: -80.0,
        max_elevation_deg: 30.0,
        min_range: 0.1,
        max_range: 60.0,
    };
    let opts = ScanOptions {
        misses: MissPolicy::Drop,
        ..ScanOptions::default()
    };
    let (frames, stats) = scan_terrestrial(&scene, &tls, &opts).unwrap();
    assert_eq!(frames.len(), 1);
    assert_eq!(stats[0].rays, 720 * 221);
    let (near, mid, far) = (
        density(&frames[0], 2.0, 3.0),
        density(&frames[0], 6.0, 8.0),
        density(&frames[0], 15.0, 20.0),
    );
    assert!(
        near > 3.0 * mid && mid > 3.0 * far && far > 0.0,
        "{near} {mid} {far}"
    );
    // every beam above the horizon misses; with Drop they are not in the frame
    assert!(stats[0].misses > 720 * 60);
    assert_eq!(frames[0].points.len(), stats[0].hits);
}

#[test]
fn lidar_density_falls_with_range() {
    let scene = ground();
    let mut lidar = SpinningLidar::builtin_path();
    lidar.path = vec![[0.0, 0.0]];
    lidar.rings = 32;
    let (frames, stats) = scan_lidar(&scene, &lidar, &ScanOptions::default()).unwrap();
    assert_eq!(frames.len(), 1);
    assert_eq!(stats[0].rays, 32 * 1024);
    assert!(
        (frames[0].origin.z - 1.0).abs() < 1e-6,
        "origin 1 m above the ground"
    );
    let (near, far) = (
        density(&frames[0], 3.7, 6.0),
        density(&frames[0], 10.0, 29.0),
    );
    assert!(near > 3.0 * far && far > 0.0, "{near} {far}");
}

#[test]
fn misses_land_beyond_max_range_or_are_dropped() {
    let scene = Scene::builtin();
    let lidar = quick_lidar();
    let (frames, stats) = scan_lidar(&scene, &lidar, &ScanOptions::default()).unwrap();
    let mut beyond = 0;
    let mut total_misses = 0;
    for (f, s) in frames.iter().zip(&stats) {
        assert_eq!(s.rays, s.hits + s.misses + s.too_close);
        assert_eq!(f.points.len(), s.hits + s.misses);
        let o = f.origin;
        for p in &f.points {
            let d = (p - o).norm() as f64;
            if d > lidar.max_range {
                beyond += 1;
                assert!(
                    (d - lidar.max_range * MISS_RANGE_FACTOR).abs() < 1e-3,
                    "{d}"
                );
            }
        }
        total_misses += s.misses;
    }
    assert!(total_misses > 0);
    assert_eq!(beyond, total_misses);

    let drop = ScanOptions {
        misses: MissPolicy::Drop,
        ..ScanOptions::default()
    };
    let (frames, stats) = scan_lidar(&scene, &lidar, &drop).unwrap();
    for (f, s) in frames.iter().zip(&stats) {
        assert_eq!(f.points.len(), s.hits);
    }
}

#[test]
fn the_map_shows_walls_and_a_free_corridor() {
    let scene = Scene::builtin();
    let lidar = quick_lidar();
    let (frames, _) = scan_lidar(&scene, &lidar, &ScanOptions::default()).unwrap();
    let mut tree = OcTree::new(0.1).unwrap();
    let opts = InsertOptions {
        max_range: Some(lidar.max_range),
        ..InsertOptions::default()
    };
    for f in &frames {
        insert_point_cloud_f32(&mut tree, &f.points, &f.origin, &opts);
    }
    // (occupied, free) leaf counts and the occupied centres in a metric box
    let scan_box = |lo: [f64; 3], hi: [f64; 3]| {
        let conv = tree.converter();
        let k0 = conv.point_to_key(&Point3::from(lo)).unwrap();
        let k1 = conv.point_to_key(&Point3::from(hi)).unwrap();
        let (mut occ, mut free) = (Vec::new(), 0);
        for l in tree.leaves_in_bbx(k0, k1) {
            if tree.params().is_occupied(l.value) {
                occ.push(conv.key_to_point_at_depth(&l.key, l.depth));
            } else {
                free += 1;
            }
        }
        (occ, free)
    };
    // the corridor's south wall (y 6.9..7.1) and north wall (8.9..9.1) near x = 22
    let (south, _) = scan_box([21.0, 6.95, 0.5], [23.0, 7.15, 1.5]);
    let (north, _) = scan_box([21.0, 8.85, 0.5], [23.0, 9.05, 1.5]);
    assert!(
        south.len() > 20 && north.len() > 20,
        "{} {}",
        south.len(),
        north.len()
    );
    // the corridor between them is free
    let (inside, free) = scan_box([21.0, 7.5, 0.5], [23.0, 8.5, 1.5]);
    assert!(inside.is_empty(), "{inside:?}");
    assert!(free > 20, "{free}");
    // on the slope (a strip without crates) the occupied voxels follow the rising surface
    let (slope, _) = scan_box([26.0, 7.0, -1.0], [38.0, 9.0, 4.0]);
    assert!(slope.len() > 20, "{}", slope.len());
    for p in &slope {
        let surface = (p.x - 24.0) / 16.0 * 2.5;
        assert!((p.z - surface).abs() < 0.2, "{p} vs surface {surface}");
    }
}

#[test]
fn invalid_inputs_are_errors() {
    assert!(matches!(Scene::from_shapes(vec![]), Err(SceneError::Empty)));
    let scene = Scene::builtin();
    let mut tls = TerrestrialScanner::builtin(&scene);
    tls.angular_step_deg = 0.0;
    assert!(scan_terrestrial(&scene, &tls, &ScanOptions::default()).is_err());
    tls.angular_step_deg = 1e-4;
    assert!(scan_terrestrial(&scene, &tls, &ScanOptions::default()).is_err());
    let mut l = SpinningLidar::builtin_path();
    l.path.clear();
    assert!(scan_lidar(&scene, &l, &ScanOptions::default()).is_err());
    let mut l = SpinningLidar::builtin_path();
    l.max_range = f64::NAN;
    assert!(scan_lidar(&scene, &l, &ScanOptions::default()).is_err());
    let noisy = ScanOptions {
        range_noise: -1.0,
        ..ScanOptions::default()
    };
    assert!(scan_lidar(&scene, &SpinningLidar::builtin_path(), &noisy).is_err());
}

/// The built-in depth camera: its frames carry their pixels, every point lies on its pixel's
/// ray, exact insertion through the pixel grid skips most ray heads and gives the plain
/// `computeUpdate` sets, and a broken camera is an error.
#[test]
fn depth_camera_frames_carry_their_pixels() {
    use octoquant::scene::{scan_depth, DepthCamera};
    use octoquant_raycast::{compute_update_f32, compute_update_grid_f32, ScanUpdate};
    let scene = Scene::builtin();
    let mut camera = DepthCamera::builtin(&scene);
    camera.poses.truncate(2);
    for misses in [MissPolicy::Drop, MissPolicy::MaxRange] {
        let options = ScanOptions {
            misses,
            ..ScanOptions::default()
        };
        let (frames, stats) = scan_depth(&scene, &camera, &options).unwrap();
        assert_eq!(frames.len(), 2);
        for (f, s) in frames.iter().zip(&stats) {
            assert_eq!(s.rays, 320 * 240);
            let kept = match misses {
                MissPolicy::Drop => s.hits,
                MissPolicy::MaxRange => s.hits + s.misses,
            };
            assert_eq!(f.points.len(), kept);
            assert!(s.hits > s.rays / 2, "{s:?}");
            let c = f.camera.as_ref().expect("depth frames carry their pixels");
            assert_eq!(c.pixels.len(), f.points.len());
            assert!(c.pixels.windows(2).all(|w| w[0] < w[1]));
            // each point on its pixel's ray
            let cam = &c.camera;
            for (p, &px) in f.points.iter().zip(&c.pixels) {
                let (u, v) = ((px % cam.width) as f64, (px / cam.width) as f64);
                let ray = cam.rotation
                    * nalgebra::Vector3::new((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1.0);
                let d = (p - f.origin).cast::<f64>();
                assert!(d.angle(&ray) < 1e-5, "pixel {px}: {}", d.angle(&ray));
            }
            for (res, max_range) in [(0.1, Some(8.0)), (0.05, None)] {
                let conv = octoquant::octree::KeyConverter::new(res).unwrap();
                let (mut plain, mut grid) = (ScanUpdate::new(), ScanUpdate::new());
                let a = compute_update_f32(&conv, &f.points, &f.origin, max_range, &mut plain);
                let b = compute_update_grid_f32(
                    &conv,
                    &f.points,
                    &c.grid(),
                    &f.origin,
                    max_range,
                    &mut grid,
                );
                assert!(b.heads_skipped * 2 > b.rays, "{res}: {b:?}");
                assert_eq!((a.rays, a.free, a.occupied), (b.rays, b.free, b.occupied));
                assert!(
                    plain.free_bricks() == grid.free_bricks(),
                    "{res}: free sets differ"
                );
                assert!(plain.occupied_bricks() == grid.occupied_bricks());
            }
        }
    }
    // the built-in camera looks along +x, a little down, with image rows running down
    let r = octoquant::scene::looking_along_x(0.2);
    let (right, down, forward) = (
        r * nalgebra::Vector3::x(),
        r * nalgebra::Vector3::y(),
        r * nalgebra::Vector3::z(),
    );
    assert!(forward.x > 0.9 && forward.z < 0.0 && down.z < -0.9 && right.y < -0.99);
    assert!((right.cross(&down) - forward).norm() < 1e-12);
    let mut bad = camera.clone();
    bad.image.fx = 0.0;
    assert!(scan_depth(&scene, &bad, &ScanOptions::default()).is_err());
    let mut bad = camera.clone();
    bad.image.width = 0;
    assert!(scan_depth(&scene, &bad, &ScanOptions::default()).is_err());
    let mut bad = camera;
    bad.poses[0].1 = f64::NAN;
    assert!(scan_depth(&scene, &bad, &ScanOptions::default()).is_err());
}

/// The density reducer paper's scanner settings (issue 27): 0.075° steps over a full turn and
/// elevations −40°..40° (50°–130° from the zenith), 2–2000 m. Over a flat ground reaching past
/// 2000 m, 1.5 m below the scanner, a beam returns when 2 ≤ 1.5 / sin(−elevation) ≤ 2000 m:
/// the 533 rows from −40° to −0.1° (at −0.025° the ground is 3438 m away).
#[test]
fn issue_27_riegl_preset_beam_pattern() {
    let scene = Scene::from_shapes(vec![(
        Isometry3::translation(0.0, 0.0, -0.5),
        SharedShape::cuboid(3000.0, 3000.0, 0.5),
    )])
    .unwrap();
    let tls = TerrestrialScanner::riegl_lms_z620(vec![Point3::new(0.0, 0.0, 1.5)]);
    let opts = ScanOptions {
        range_noise: 0.0,
        misses: MissPolicy::Drop,
        ..ScanOptions::default()
    };
    let (frames, stats) = scan_terrestrial(&scene, &tls, &opts).unwrap();
    assert_eq!(stats[0].rays, 4800 * 1067);
    assert_eq!(stats[0].hits, 4800 * 533);
    let p = &frames[0].points;
    assert_eq!(p.len(), 4800 * 533);
    // The first two returns: neighbouring azimuths on the −40° row, 1.5 / tan 40° = 1.788 m
    // out, a chord of 2 · 1.788 · sin(0.0375°) = 2.34 mm apart.
    let rho = 1.5 / 40f64.to_radians().tan();
    let want = 2.0 * rho * (0.0375f64).to_radians().sin();
    let got = (p[1] - p[0]).norm() as f64;
    assert!((got - want).abs() < 1e-3 * want, "{got} {want}");
    assert!((p[0].z as f64).abs() < 1e-6);
}
