//! The synthetic city: the same seed gives the same city, route and frames bit for bit;
//! another seed another city; the route drives street centre lines and never enters a
//! building; every scanned point lies where a naive ray–box/ray–sphere check of the city's
//! objects says the beam stops; the frame count is the one asked for; and the `simulate`
//! command writes those frames.

use crate::common::scratch;
use nalgebra::{Point3, Vector3};
use octoquant::formats::{read_frames, ReadOptions};
use octoquant::scene::{
    scan_lidar, City, CityBox, CityOptions, MissPolicy, ScanOptions, SpinningLidar,
    MAX_CITY_FRAMES, MAX_ROUTE_LENGTH, MOUNT_HEIGHT, STREET_WIDTH,
};
use octoquant::Frame;

fn small(seed: u64) -> City {
    City::generate(&CityOptions {
        seed,
        blocks_x: 3,
        blocks_y: 2,
    })
    .unwrap()
}

/// A coarse sensor, quick to scan.
fn coarse(city: &City, frames: usize) -> SpinningLidar {
    let mut l = city.lidar(frames).unwrap();
    l.columns = 120;
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
fn same_seed_same_city_and_frames_other_seed_differs() {
    let (a, b, c) = (small(11), small(11), small(12));
    assert_eq!(a, b);
    assert_ne!(a.buildings, c.buildings);
    assert_ne!(a.streets_x, c.streets_x);
    assert_ne!(a.route(300.0), c.route(300.0));
    assert!(a.buildings.len() >= 6 && !a.trees.is_empty() && !a.cars.is_empty());
    let opts = ScanOptions {
        seed: 11,
        ..ScanOptions::default()
    };
    let (fa, _) = scan_lidar(&a.scene(), &coarse(&a, 4), &opts).unwrap();
    let (fb, _) = scan_lidar(&b.scene(), &coarse(&b, 4), &opts).unwrap();
    let (fc, _) = scan_lidar(&c.scene(), &coarse(&c, 4), &opts).unwrap();
    assert_eq!(bits(&fa), bits(&fb));
    assert_ne!(bits(&fa), bits(&fc));
}

/// Horizontal distance from `(x, y)` to the footprint of `b` (0 inside it).
fn footprint_distance(b: &CityBox, x: f64, y: f64) -> f64 {
    let dx = (b.min.x - x).max(x - b.max.x).max(0.0);
    let dy = (b.min.y - y).max(y - b.max.y).max(0.0);
    (dx * dx + dy * dy).sqrt()
}

#[test]
fn the_route_follows_street_centre_lines_and_stays_out_of_buildings() {
    for seed in [0, 5, 99] {
        let city = small(seed);
        let lidar = city.lidar(700).unwrap();
        let path = &lidar.path;
        assert!(path.len() > 5, "seed {seed}: {} waypoints", path.len());
        let on_line = |lines: &[f64], v: f64| lines.iter().any(|l| (l - v).abs() < 1e-9);
        for w in path.windows(2) {
            let ([x0, y0], [x1, y1]) = (w[0], w[1]);
            // each leg runs along one street: x fixed on a north–south one or y on an east–west one
            assert!(
                (x0 == x1 && on_line(&city.streets_x, x0))
                    || (y0 == y1 && on_line(&city.streets_y, y0)),
                "seed {seed}: leg {:?} is not on a street",
                w
            );
            // every 0.25 m of the leg is half a street from every building, outside every car
            let n = ((x1 - x0).abs() + (y1 - y0).abs()).ceil() as usize * 4 + 1;
            for k in 0..=n {
                let t = k as f64 / n as f64;
                let (x, y) = (x0 + t * (x1 - x0), y0 + t * (y1 - y0));
                for b in &city.buildings {
                    let d = footprint_distance(b, x, y);
                    assert!(
                        d >= STREET_WIDTH / 2.0 - 1e-9,
                        "seed {seed}: ({x}, {y}) {d} m from {b:?}"
                    );
                }
                for c in &city.cars {
                    assert!(
                        footprint_distance(&c.body, x, y) > 2.0,
                        "seed {seed}: car at ({x}, {y})"
                    );
                }
                assert!(city.on_centre_line(x, y));
            }
        }
        // the sensor rides at the mount height above the road
        let (frames, _) = scan_lidar(
            &city.scene(),
            &SpinningLidar {
                rings: 1,
                columns: 1,
                ..city.lidar(30).unwrap()
            },
            &ScanOptions::default(),
        )
        .unwrap();
        for f in &frames {
            let o = f.origin.cast::<f64>();
            assert!((o.z - MOUNT_HEIGHT).abs() < 1e-6, "{o}");
            assert!(!city.is_solid(&o));
        }
    }
}

/// Distance along the unit `dir` from `o` to box `b` (slab method), if the ray meets it.
fn ray_box(o: &Point3<f64>, dir: &Vector3<f64>, b: &CityBox) -> Option<f64> {
    let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
    for i in 0..3 {
        if dir[i] == 0.0 {
            if o[i] < b.min[i] || o[i] > b.max[i] {
                return None;
            }
            continue;
        }
        let (a, c) = ((b.min[i] - o[i]) / dir[i], (b.max[i] - o[i]) / dir[i]);
        t0 = t0.max(a.min(c));
        t1 = t1.min(a.max(c));
    }
    (t0 <= t1).then_some(t0)
}

/// Distance along the unit `dir` from `o` (outside the sphere) to the sphere, if it meets it.
fn ray_sphere(o: &Point3<f64>, dir: &Vector3<f64>, c: &Point3<f64>, r: f64) -> Option<f64> {
    let oc = o - c;
    let b = oc.dot(dir);
    let disc = b * b - (oc.norm_squared() - r * r);
    if disc < 0.0 {
        return None;
    }
    let t = -b - disc.sqrt();
    (t >= 0.0).then_some(t)
}

/// The first surface along the beam, by trying every object of the city.
fn naive_hit(city: &City, o: &Point3<f64>, dir: &Vector3<f64>) -> Option<f64> {
    let boxes = city.boxes().filter_map(|b| ray_box(o, dir, b));
    let crowns = city
        .trees
        .iter()
        .filter_map(|t| ray_sphere(o, dir, &t.crown_centre, t.crown_radius));
    boxes.chain(crowns).min_by(f64::total_cmp)
}

#[test]
fn scanned_points_lie_where_a_naive_ray_check_stops_the_beam() {
    let city = small(3);
    let mut lidar = coarse(&city, 3);
    lidar.path = city.route(60.0);
    lidar.frame_spacing = 25.0;
    let opts = ScanOptions {
        seed: 0,
        range_noise: 0.0,
        misses: MissPolicy::MaxRange,
    };
    let (frames, stats) = scan_lidar(&city.scene(), &lidar, &opts).unwrap();
    assert_eq!(frames.len(), 3);
    let (mut hits, mut misses) = (0, 0);
    for f in &frames {
        let o = f.origin.cast::<f64>();
        for p in &f.points {
            let v = p.cast::<f64>() - o;
            let (range, dir) = (v.norm(), v.normalize());
            match naive_hit(&city, &o, &dir) {
                Some(d) if d <= lidar.max_range => {
                    // points are f32: a few tens of micrometres over 80 m, parry casts in f32
                    assert!(
                        (d - range).abs() < 2e-3,
                        "naive {d} m, scanned {range} m along {dir}"
                    );
                    hits += 1;
                }
                other => {
                    // a miss: returned beyond the range, and nothing within it
                    assert!(
                        range > lidar.max_range,
                        "naive {other:?}, scanned {range} m"
                    );
                    misses += 1;
                }
            }
        }
    }
    assert_eq!(hits, stats.iter().map(|s| s.hits).sum::<usize>());
    assert_eq!(misses, stats.iter().map(|s| s.misses).sum::<usize>());
    assert!(hits > 1000 && misses > 0, "{hits} hits, {misses} misses");
}

#[test]
fn frame_count_is_the_one_asked_for() {
    let city = small(1);
    for n in [1, 2, 7, 60] {
        let mut l = city.lidar(n).unwrap();
        l.rings = 2;
        l.columns = 4;
        let (frames, _) = scan_lidar(&city.scene(), &l, &ScanOptions::default()).unwrap();
        assert_eq!(frames.len(), n);
    }
    assert!(city.lidar(0).is_err());
    assert!(city.lidar(MAX_CITY_FRAMES + 1).is_err());
    // routes are as long as asked, within bounds
    let length = |p: &[[f64; 2]]| -> f64 {
        p.windows(2)
            .map(|w| ((w[1][0] - w[0][0]).powi(2) + (w[1][1] - w[0][1]).powi(2)).sqrt())
            .sum()
    };
    for l in [0.5, 37.0, 1234.5] {
        assert!((length(&city.route(l)) - l).abs() < 1e-6, "{l}");
    }
    for l in [0.0, -3.0, f64::NAN, f64::INFINITY] {
        assert_eq!(city.route(l).len(), 1, "{l}");
    }
    assert!((length(&city.route(1e300)) - MAX_ROUTE_LENGTH).abs() < 1e-2);
    for (bx, by) in [(0, 2), (2, 0), (65, 1)] {
        let o = CityOptions {
            seed: 0,
            blocks_x: bx,
            blocks_y: by,
        };
        assert!(City::generate(&o).is_err(), "{bx} × {by}");
    }
}

#[test]
fn simulate_writes_the_city_frames() {
    let dir = scratch("city-simulate");
    let out = dir.join("city.frames");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .args([
            "simulate", "--scene", "city", "--frames", "5", "--seed", "4",
        ])
        .args(["--blocks", "3", "2", "--columns", "120", "--json", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let summary: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(summary["frames"], 5);
    let written = read_frames(&out, &ReadOptions::default()).unwrap();
    let city = City::generate(&CityOptions {
        seed: 4,
        blocks_x: 3,
        blocks_y: 2,
    })
    .unwrap();
    let opts = ScanOptions {
        seed: 4,
        misses: MissPolicy::Drop,
        ..ScanOptions::default()
    };
    let (frames, _) = scan_lidar(&city.scene(), &coarse(&city, 5), &opts).unwrap();
    assert_eq!(bits(&written), bits(&frames));
    // a wrong output name is refused before any work
    let bad = std::process::Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .args(["simulate", "--frames", "5", "-o"])
        .arg(dir.join("city.bt"))
        .output()
        .unwrap();
    assert!(!bad.status.success());
}
