//! Structure-aware: up to three small scans (any `f32` coordinates, NaN, infinities and points
//! outside the key range included; empty scans; origins anywhere; an optional maximum range;
//! the last points of a scan only clearing, as octomap_server's ground points), each cast into
//! one reused `ScanUpdate` by `compute_update_clearing_f32` with OctoMap's DDA rays or with
//! Bresenham lines, on one or two threads. Each scan's free and occupied voxels must be the
//! naive definition's, written here from OctoMap's `computeUpdate` (octomap-facts §3.2): per
//! point, the keys of its ray (`computeRayKeys`, one ray at a time) or of the ray cut at the
//! maximum range, the end voxel occupied when in range and not a clearing point, then every
//! occupied voxel taken out of the free ones. Both lists must be in Morton order without
//! repeats, and the counts must match. Nothing may panic.
//!
//! The batched casting under test is the lanes, the brick sets (the small hash and the pages,
//! which the fuzzing build's lower thresholds reach with a few dozen rays), the listing with
//! the occupied voxels taken out, and the split of a scan across threads (also reached with few
//! points in the fuzzing build): everything between the points and the two sorted lists.
#![no_main]
use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use octoquant::octree::{Key, KeyConverter};
use octoquant::raycast::{
    compute_ray_keys_f32, compute_update_clearing_f32, walk_bresenham_keys, KeyRay, RayModel,
    ScanUpdate,
};
use octoquant_fuzz::{pool, Place};
use std::collections::HashSet;

#[derive(Arbitrary, Debug)]
struct Scan {
    origin: Place,
    points: Vec<Place>,
    /// How many of the last points only clear.
    clearing: u8,
}

#[derive(Arbitrary, Debug)]
struct Input {
    scans: Vec<Scan>,
    resolution: u8,
    max_range: Option<u8>,
    bresenham: bool,
    two_threads: bool,
}

/// The key of `p` when it lies in the map (`coordToKeyChecked`).
fn key_of(conv: &KeyConverter, p: &nalgebra::Point3<f32>) -> Option<Key> {
    conv.point_to_key(&p.cast::<f64>())
}

/// OctoMap's `computeUpdate` (facts §3.2), one point and one ray at a time, with std sets;
/// with `bresenham`, the line between the keys of the origin and of the (cut) end instead of
/// the DDA ray, when both keys are in the map.
fn naive(
    conv: &KeyConverter,
    points: &[nalgebra::Point3<f32>],
    clear_from: usize,
    origin: &nalgebra::Point3<f32>,
    max_range: f64,
    bresenham: bool,
) -> (HashSet<Key>, HashSet<Key>) {
    let (mut free, mut occ) = (HashSet::new(), HashSet::new());
    let mut ray = KeyRay::new();
    let mut cast = |end: &nalgebra::Point3<f32>, free: &mut HashSet<Key>| {
        if bresenham {
            if let (Some(a), Some(b)) = (key_of(conv, origin), key_of(conv, end)) {
                walk_bresenham_keys(a, b, |k| {
                    free.insert(k);
                });
            }
        } else if compute_ray_keys_f32(conv, origin, end, &mut ray) {
            free.extend(ray.iter().copied());
        }
    };
    for (i, p) in points.iter().enumerate() {
        if !p.iter().all(|c| c.is_finite()) {
            // OctoMap finds no key on such a ray, nor for its end
            continue;
        }
        // the subtraction and the squared norm in float, the root in double
        let d = p - origin;
        let dist = f64::from(d.x * d.x + d.y * d.y + d.z * d.z).sqrt();
        if max_range < 0.0 || dist <= max_range {
            cast(p, &mut free);
            if i < clear_from {
                occ.extend(key_of(conv, p));
            }
        } else {
            // `normalized()` divides by the float norm when it is not 0 (here it is not: a
            // point at distance 0 is in range); the end is `origin + dir * maxrange`, in float
            let dir = d / dist as f32;
            let end = origin + dir * max_range as f32;
            cast(&end, &mut free);
        }
    }
    free.retain(|k| !occ.contains(k));
    (free, occ)
}

fn check(list: &[Key], want: &HashSet<Key>, what: &str) {
    assert!(
        list.windows(2).all(|w| w[0].morton() < w[1].morton()),
        "{what}: not in Morton order without repeats"
    );
    let got: HashSet<Key> = list.iter().copied().collect();
    assert_eq!(got.len(), want.len(), "{what}: count");
    assert!(got == *want, "{what}: not the naive set");
}

fuzz_target!(|input: Input| {
    let res = [0.05, 0.1, 0.25, 1.0][usize::from(input.resolution % 4)];
    let conv = KeyConverter::new(res).expect("a valid resolution");
    let max_range = input.max_range.map(|r| f64::from(r) * 0.25);
    let model = if input.bresenham {
        RayModel::Bresenham
    } else {
        RayModel::Dda
    };
    let mut update = ScanUpdate::new();
    pool(if input.two_threads { 2 } else { 1 }).install(|| {
        for scan in input.scans.iter().take(3) {
            let origin = scan.origin.point();
            let points: Vec<_> = scan.points.iter().take(64).map(|p| p.point()).collect();
            let clearing = usize::from(scan.clearing).min(points.len());
            let stats = compute_update_clearing_f32(
                &conv,
                &points,
                clearing,
                None,
                &origin,
                max_range,
                model,
                &mut update,
            );
            let clear_from = points.len() - clearing;
            let (free, occ) = naive(
                &conv,
                &points,
                clear_from,
                &origin,
                max_range.unwrap_or(-1.0),
                input.bresenham,
            );
            check(update.free(), &free, "free");
            check(update.occupied(), &occ, "occupied");
            assert_eq!((stats.free, stats.occupied), (free.len(), occ.len()));
        }
    });
});
