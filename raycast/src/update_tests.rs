use super::*;
use crate::dda::{compute_ray_keys_f32, KeyRay};
use crate::discretize::discretize_f32;
use proptest::prelude::*;
use std::collections::HashSet;

fn conv(res: f64) -> KeyConverter {
    KeyConverter::new(res).unwrap()
}

/// facts §3.2, literally, with std sets: the naive definition to compare against.
fn naive_update(
    c: &KeyConverter,
    points: &[Point3<f32>],
    origin: &Point3<f32>,
    max_range: f64,
) -> (HashSet<Key>, HashSet<Key>) {
    naive_clearing_update(c, points, points.len(), origin, max_range)
}

/// [`naive_update`] where the points from `clear_from` on mark no end voxel occupied
/// (octomap_server's ground points: their rays only clear).
fn naive_clearing_update(
    c: &KeyConverter,
    points: &[Point3<f32>],
    clear_from: usize,
    origin: &Point3<f32>,
    max_range: f64,
) -> (HashSet<Key>, HashSet<Key>) {
    let mut free = HashSet::new();
    let mut occ = HashSet::new();
    let mut ray = KeyRay::new();
    for (i, p) in points.iter().enumerate() {
        let d = p - origin;
        let dist = ((d.x * d.x + d.y * d.y + d.z * d.z) as f64).sqrt();
        if max_range < 0.0 || dist <= max_range {
            if compute_ray_keys_f32(c, origin, p, &mut ray) {
                free.extend(ray.iter().copied());
            }
            if let Some(k) = key_of(c, p).filter(|_| i < clear_from) {
                occ.insert(k);
            }
        } else {
            let n = dist as f32;
            let dir = if dist > 0.0 { d / n } else { d };
            let new_end = origin + dir * max_range as f32;
            if compute_ray_keys_f32(c, origin, &new_end, &mut ray) {
                free.extend(ray.iter().copied());
            }
        }
    }
    free.retain(|k| !occ.contains(k));
    (free, occ)
}

fn sorted_by_morton(keys: &[Key]) -> bool {
    keys.windows(2).all(|w| morton(w[0]) < morton(w[1]))
}

#[test]
fn morton_round_trips_and_interleaves() {
    let naive = |k: Key| -> u64 {
        let mut c = 0u64;
        for b in 0..16 {
            for a in 0..3 {
                c |= (((k[a] >> b) & 1) as u64) << (3 * b + a);
            }
        }
        c
    };
    let mut s = 1u64;
    for _ in 0..10_000 {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        let k = Key::new(s as u16, (s >> 16) as u16, (s >> 32) as u16);
        assert_eq!(morton(k), naive(k), "{k:?}");
        assert_eq!(Key::from_morton(morton(k)), k);
    }
    for k in [
        Key::new(0, 0, 0),
        Key::new(65535, 65535, 65535),
        Key::new(1, 0, 65535),
    ] {
        assert_eq!(Key::from_morton(morton(k)), k);
    }
    // the tree's child order: x is the lowest bit of a triple, z the highest
    assert!(morton(Key::new(1, 0, 0)) < morton(Key::new(0, 1, 0)));
    assert!(morton(Key::new(0, 1, 0)) < morton(Key::new(0, 0, 1)));
    assert!(morton(Key::new(0, 0, 1)) < morton(Key::new(2, 0, 0)));
}

#[test]
fn max_range_ray_frees_up_to_the_cut_voxel() {
    // facts §3.2: origin 0.05, a point at x = 1.05, maxrange 0.5 -> free 32768..=32772
    let c = conv(0.1);
    let mut out = ScanUpdate::new();
    let s = compute_update_f32(
        &c,
        &[Point3::new(1.05, 0.05, 0.05)],
        &Point3::new(0.05, 0.05, 0.05),
        Some(0.5),
        &mut out,
    );
    let xs: Vec<u16> = out.free().iter().map(|k| k.x()).collect();
    assert_eq!(xs, vec![32768, 32769, 32770, 32771, 32772]);
    assert!(out.occupied().is_empty());
    assert_eq!((s.max_range_rays, s.rays, s.free, s.occupied), (1, 1, 5, 0));
}

#[test]
fn occupied_wins_and_bad_points_are_counted() {
    let c = conv(0.1);
    let o = Point3::new(0.05f32, 0.05, 0.05);
    let pts = [
        Point3::new(1.05, 0.05, 0.05),
        Point3::new(0.55, 0.05, 0.05), // on the first ray: occupied wins
        Point3::new(f32::NAN, 0.0, 0.0),
        Point3::new(0.0, f32::NEG_INFINITY, 0.0),
        Point3::new(0.0, 0.0, 1e7),
        Point3::new(0.07, 0.02, 0.01), // same voxel as the origin: occupied, no free
    ];
    let mut out = ScanUpdate::new();
    let s = compute_update_f32(&c, &pts, &o, None, &mut out);
    assert_eq!(s.points, 6);
    assert_eq!(s.non_finite, 2);
    assert_eq!(s.outside_map, 1);
    assert_eq!(s.failed_rays, 1);
    assert_eq!(s.rays, 3);
    let occ: Vec<u16> = out.occupied().iter().map(|k| k.x()).collect();
    assert_eq!(occ, vec![32768, 32773, 32778]);
    let free: Vec<u16> = out.free().iter().map(|k| k.x()).collect();
    assert_eq!(
        free,
        vec![32769, 32770, 32771, 32772, 32774, 32775, 32776, 32777]
    );
}

#[test]
fn origin_outside_the_map_still_marks_endpoints() {
    let c = conv(0.1);
    let mut out = ScanUpdate::new();
    let s = compute_update_f32(
        &c,
        &[Point3::new(1.0, 1.0, 1.0)],
        &Point3::new(5000.0, 0.0, 0.0),
        None,
        &mut out,
    );
    assert_eq!((s.failed_rays, s.occupied, s.free), (1, 1, 0));
}

#[test]
fn max_range_zero_and_nan() {
    let c = conv(0.1);
    let o = Point3::new(0.05f32, 0.05, 0.05);
    let pts = [Point3::new(1.05, 0.05, 0.05), o];
    let mut out = ScanUpdate::new();
    // 0 is a real limit: only the point at the origin is a hit
    let s = compute_update_f32(&c, &pts, &o, Some(0.0), &mut out);
    assert_eq!((s.occupied, s.free, s.max_range_rays), (1, 0, 1));
    // NaN: every point is a max-range reading whose ray cannot be cast
    let s = compute_update_f32(&c, &pts, &o, Some(f64::NAN), &mut out);
    assert_eq!((s.occupied, s.free, s.failed_rays), (0, 0, 2));
    // negative: no limit
    let s = compute_update_f32(&c, &pts, &o, Some(-3.0), &mut out);
    assert_eq!((s.occupied, s.free), (2, 9));
}

fn point_strategy() -> impl Strategy<Value = Point3<f32>> {
    prop_oneof![
        30 => prop::array::uniform3(-2.0f32..2.0).prop_map(Point3::from),
        3 => prop::array::uniform3(-20.0f32..20.0).prop_map(Point3::from),
        // outside the map at every tested resolution (wraps into it with discretize)
        1 => (-1.0e6f32..1.0e6).prop_map(|x| Point3::new(x.signum() * 1.0e6 + x, 0.5, -0.5)),
        2 => Just(Point3::new(f32::NAN, 0.0, 1.0)),
        1 => Just(Point3::new(0.0, f32::INFINITY, 1.0)),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    /// The sorted, cache-filtered sets equal the naive HashSet sets of facts §3.2.
    #[test]
    fn compute_update_equals_naive_sets(
        res in prop::sample::select(vec![0.05, 0.1, 0.25]),
        pts in prop::collection::vec(point_strategy(), 0..300),
        o in prop::array::uniform3(-0.5f32..0.5),
        max_range in prop::sample::select(vec![-1.0, 0.0, 0.7, 1.5, 100.0]),
        discrete in any::<bool>(),
    ) {
        let c = conv(res);
        let origin = Point3::from(o);
        let mut out = ScanUpdate::new();
        let m = if max_range < 0.0 { None } else { Some(max_range) };
        let counts;
        let (free, occ) = if discrete {
            let s = compute_discrete_update_f32(&c, &pts, &origin, m, &mut out);
            let mut centres = Vec::new();
            discretize_f32(&c, &pts, &mut centres);
            // naive discretize: first-seen keys of finite points
            let mut seen = HashSet::new();
            let naive: Vec<Point3<f32>> = pts
                .iter()
                .filter(|p| p.iter().all(|v| v.is_finite()))
                .map(|p| c.point_to_key_unchecked(&p.cast::<f64>()))
                .filter(|k| seen.insert(*k))
                .map(|k| c.key_to_point_f32(&k))
                .collect();
            prop_assert_eq!(&centres, &naive);
            prop_assert_eq!(s.duplicates + naive.len() + s.non_finite, pts.len());
            counts = (s.free, s.occupied);
            naive_update(&c, &naive, &origin, max_range)
        } else {
            let s = compute_update_f32(&c, &pts, &origin, m, &mut out);
            prop_assert_eq!(s.points, pts.len());
            counts = (s.free, s.occupied);
            naive_update(&c, &pts, &origin, max_range)
        };
        prop_assert!(sorted_by_morton(out.free()));
        prop_assert!(sorted_by_morton(out.occupied()));
        // the bricks the tree takes: strictly sorted, none empty, the keys' bricks
        for bricks in [out.free_bricks(), out.occupied_bricks()] {
            prop_assert!(bricks.windows(2).all(|w| w[0].code < w[1].code));
            prop_assert!(bricks.iter().all(|b| b.voxels != 0));
        }
        for (bricks, keys) in [(out.free_bricks(), out.free()), (out.occupied_bricks(), out.occupied())] {
            let n: u32 = bricks.iter().map(|b| b.voxels.count_ones()).sum();
            prop_assert_eq!(n as usize, keys.len());
            for k in keys {
                let code = morton(*k);
                prop_assert!(bricks.iter().any(|b| b.code == code >> 6 && b.voxels >> (code & 63) & 1 == 1));
            }
        }
        prop_assert_eq!((counts.0, counts.1), (out.free().len(), out.occupied().len()));
        let f: HashSet<Key> = out.free().iter().copied().collect();
        let oc: HashSet<Key> = out.occupied().iter().copied().collect();
        prop_assert_eq!(f, free);
        prop_assert_eq!(oc, occ);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// Points that only clear: their rays' voxels are free, their end voxels not occupied
    /// (unless a hit's), against the naive sets; and with no clearing points the update is
    /// the plain one.
    #[test]
    fn clearing_points_free_their_rays_and_occupy_nothing(
        res in prop::sample::select(vec![0.05, 0.25]),
        pts in prop::collection::vec(point_strategy(), 0..200),
        o in prop::array::uniform3(-0.5f32..0.5),
        max_range in prop::sample::select(vec![-1.0, 0.7, 100.0]),
        clearing_share in 0.0f64..=1.0,
    ) {
        let c = conv(res);
        let origin = Point3::from(o);
        let m = if max_range < 0.0 { None } else { Some(max_range) };
        let clearing = (pts.len() as f64 * clearing_share) as usize;
        let mut out = ScanUpdate::new();
        compute_update_clearing_f32(&c, &pts, clearing, None, &origin, m, RayModel::Dda, &mut out);
        let (free, occ) = naive_clearing_update(&c, &pts, pts.len() - clearing, &origin, max_range);
        prop_assert_eq!(out.free().iter().copied().collect::<HashSet<_>>(), free);
        prop_assert_eq!(out.occupied().iter().copied().collect::<HashSet<_>>(), occ);
        if clearing == 0 {
            let mut plain = ScanUpdate::new();
            compute_update_f32(&c, &pts, &origin, m, &mut plain);
            prop_assert_eq!(out.free(), plain.free());
            prop_assert_eq!(out.occupied(), plain.occupied());
        }
    }
}

/// A frame large enough to be split across threads in blocks: the clearing points are found
/// by their index in the whole frame, whichever block holds them.
#[test]
fn clearing_points_split_across_threads() {
    let c = conv(0.1);
    let origin = Point3::new(0.05f32, -0.02, 0.3);
    // a deterministic spray of points around the origin, 3 m at most
    let mut state = 12345u64;
    let mut next = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 40) as f32 / (1u64 << 24) as f32) * 6.0 - 3.0
    };
    let pts: Vec<Point3<f32>> = (0..3 * PARALLEL_MIN_POINTS + 77)
        .map(|_| Point3::new(next(), next(), next()))
        .collect();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    for clearing in [0, 1, PARALLEL_BLOCK + 3, pts.len() / 2, pts.len()] {
        let mut out = ScanUpdate::new();
        pool.install(|| {
            compute_update_clearing_f32(
                &c,
                &pts,
                clearing,
                None,
                &origin,
                None,
                RayModel::Dda,
                &mut out,
            )
        });
        let (free, occ) = naive_clearing_update(&c, &pts, pts.len() - clearing, &origin, -1.0);
        assert_eq!(
            out.free().iter().copied().collect::<HashSet<_>>(),
            free,
            "{clearing}"
        );
        assert_eq!(
            out.occupied().iter().copied().collect::<HashSet<_>>(),
            occ,
            "{clearing}"
        );
    }
}

#[test]
fn out_of_map_points_at_fine_resolution() {
    // at res 0.001 the map ends at +-32.768 m
    let c = conv(0.001);
    let pts = [Point3::new(40.0f32, 0.0, 0.0), Point3::new(0.01, 0.0, 0.0)];
    let mut out = ScanUpdate::new();
    let s = compute_update_f32(&c, &pts, &Point3::origin(), None, &mut out);
    let (free, occ) = naive_update(&c, &pts, &Point3::origin(), -1.0);
    assert_eq!((s.outside_map, s.failed_rays), (1, 1));
    assert_eq!(out.free().iter().copied().collect::<HashSet<_>>(), free);
    assert_eq!(out.occupied().iter().copied().collect::<HashSet<_>>(), occ);
}

/// facts §3.2's sets with Bresenham lines instead of OctoMap's DDA: the line from the
/// origin's key to the (cut) end's key when both are in the map, by the scalar key walk.
fn naive_bresenham_update(
    c: &KeyConverter,
    points: &[Point3<f32>],
    origin: &Point3<f32>,
    max_range: Option<f64>,
) -> (HashSet<Key>, HashSet<Key>) {
    let mut free = HashSet::new();
    let mut occ = HashSet::new();
    let okey = key_of(c, origin);
    for p in points.iter().filter(|p| p.iter().all(|v| v.is_finite())) {
        let diff = [p.x - origin.x, p.y - origin.y, p.z - origin.z];
        let end = match beyond_range(origin, diff, max_range.unwrap_or(-1.0)) {
            None => {
                occ.extend(key_of(c, p));
                *p
            }
            Some(e) => e,
        };
        if let (Some(a), Some(b)) = (okey, key_of(c, &end)) {
            crate::walk_bresenham_keys(a, b, |k| {
                free.insert(k);
            });
        }
    }
    free.retain(|k| !occ.contains(k));
    (free, occ)
}

/// Points for the Bresenham scans: near and far, outside the map, NaN and infinite, on the
/// origin and in its voxel (degenerate rays).
fn line_point_strategy(origin: Point3<f32>) -> impl Strategy<Value = Point3<f32>> {
    use nalgebra::Vector3;
    prop_oneof![
        20 => prop::array::uniform3(-2.0f32..2.0).prop_map(Point3::from),
        6 => prop::array::uniform3(-30.0f32..30.0).prop_map(Point3::from),
        1 => (-1.0e6f32..1.0e6).prop_map(|x| Point3::new(x.signum() * 1.0e6 + x, 0.5, -0.5)),
        1 => Just(Point3::new(f32::NAN, 0.0, 1.0)),
        1 => Just(Point3::new(0.0, f32::NEG_INFINITY, 1.0)),
        1 => Just(origin),
        1 => prop::array::uniform3(-0.01f32..0.01).prop_map(move |d| origin + Vector3::from(d)),
    ]
}

/// A Bresenham scan through the lanes `widest` at most, and how many batches each path walked.
fn bresenham_scan(
    c: &KeyConverter,
    pts: &[Point3<f32>],
    origin: &Point3<f32>,
    max_range: Option<f64>,
    widest: crate::lanes::LinePath,
) -> (ScanUpdate, ScanStats, [usize; 3]) {
    let mut out = ScanUpdate::new();
    let (stats, paths) = crate::lanes::test_paths::capped(widest, || {
        compute_update_with_f32(c, pts, origin, max_range, RayModel::Bresenham, &mut out)
    });
    (out, stats, paths)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// The Bresenham scan's sets are the same whichever lanes walk the lines: the AVX2 lanes
    /// (forced, and proven to have run where the CPU has AVX2), the widest the CPU has, and the
    /// scalar walk all give the same free and occupied bricks and counts, equal to the naive
    /// sets of the scalar key walk.
    #[test]
    fn bresenham_scans_match_across_lanes(
        (res, origin, max_range, pts) in (
            prop::sample::select(vec![0.05, 0.1, 0.2]),
            prop_oneof![
                8 => prop::array::uniform3(-3.0f32..3.0),
                1 => Just([1.0e6f32, 0.0, 0.0]),
            ],
            prop::option::of(0.5f64..20.0),
        )
            .prop_flat_map(|(res, o, max_range)| {
                let origin = Point3::from(o);
                (
                    Just(res),
                    Just(origin),
                    Just(max_range),
                    prop::collection::vec(line_point_strategy(origin), 0..400),
                )
            }),
    ) {
        use crate::lanes::LinePath;
        let c = conv(res);
        let (scalar, s_stats, s_paths) = bresenham_scan(&c, &pts, &origin, max_range, LinePath::Scalar);
        let (avx2, a_stats, a_paths) = bresenham_scan(&c, &pts, &origin, max_range, LinePath::Avx2);
        let (widest, w_stats, _) = bresenham_scan(&c, &pts, &origin, max_range, LinePath::Avx512);
        prop_assert_eq!(s_paths[LinePath::Avx2 as usize] + s_paths[LinePath::Avx512 as usize], 0);
        #[cfg(target_arch = "x86_64")]
        if crate::cpu::has_avx2() {
            // every batch went through the AVX2 lanes, and there were batches when lines were
            prop_assert_eq!(a_paths[LinePath::Scalar as usize] + a_paths[LinePath::Avx512 as usize], 0);
            prop_assert_eq!(a_paths[LinePath::Avx2 as usize] > 0, s_paths[LinePath::Scalar as usize] > 0);
        }
        let (free, occ) = naive_bresenham_update(&c, &pts, &origin, max_range);
        for out in [&scalar, &avx2, &widest] {
            prop_assert_eq!(out.free_bricks(), scalar.free_bricks());
            prop_assert_eq!(out.occupied_bricks(), scalar.occupied_bricks());
            prop_assert_eq!(out.free().iter().copied().collect::<HashSet<_>>(), free.clone());
            prop_assert_eq!(out.occupied().iter().copied().collect::<HashSet<_>>(), occ.clone());
        }
        prop_assert_eq!(a_stats, s_stats);
        prop_assert_eq!(w_stats, s_stats);
    }
}

/// Where the CPU has AVX2 but not AVX-512 (the benchmark hosts of issue 28), a Bresenham scan
/// takes the AVX2 lanes by default; with AVX-512, the eight lanes.
#[test]
fn bresenham_scans_take_the_widest_lanes() {
    use crate::lanes::LinePath;
    let c = conv(0.1);
    let origin = Point3::new(0.05f32, 0.05, 0.05);
    let pts: Vec<Point3<f32>> = (0..500)
        .map(|i| {
            let a = i as f32 * 0.1;
            Point3::new(5.0 * a.cos(), 5.0 * a.sin(), (i % 7) as f32 - 3.0)
        })
        .collect();
    let (out, _, paths) = bresenham_scan(&c, &pts, &origin, None, LinePath::Avx512);
    let (free, occ) = naive_bresenham_update(&c, &pts, &origin, None);
    assert_eq!(out.free().iter().copied().collect::<HashSet<_>>(), free);
    assert_eq!(out.occupied().iter().copied().collect::<HashSet<_>>(), occ);
    // 500 lines: batches of RAY_BATCH (256: two)
    assert_eq!(paths.iter().sum::<usize>(), 500usize.div_ceil(RAY_BATCH));
    #[cfg(target_arch = "x86_64")]
    {
        let want = if crate::cpu::has_avx512() {
            LinePath::Avx512
        } else if crate::cpu::has_avx2() {
            LinePath::Avx2
        } else {
            LinePath::Scalar
        };
        assert_eq!(paths[want as usize], 500usize.div_ceil(RAY_BATCH));
    }
}

proptest! {
    /// Merging the threads' sorted brick lists gives the union of their voxels, brick by
    /// brick, sorted: checked against a BTreeMap built from every list (0 to 5 lists, so the
    /// two-list path and the general one both run).
    #[test]
    fn merge_sorted_is_the_union(
        lists in prop::collection::vec(
            prop::collection::btree_map(0u64..200, 1u64..u64::MAX, 0..60), 0..6)
    ) {
        let sorted: Vec<Vec<Brick>> = lists
            .iter()
            .map(|m| m.iter().map(|(&code, &voxels)| Brick { code, voxels }).collect())
            .collect();
        let mut naive = std::collections::BTreeMap::new();
        for m in &lists {
            for (&code, &voxels) in m {
                *naive.entry(code).or_insert(0u64) |= voxels;
            }
        }
        let mut out = vec![Brick { code: 7, voxels: 7 }];
        merge_sorted(sorted.iter().map(|l| &l[..]), &mut out);
        let got: Vec<(u64, u64)> = out.iter().map(|b| (b.code, b.voxels)).collect();
        let want: Vec<(u64, u64)> = naive.into_iter().collect();
        prop_assert_eq!(got, want);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// A scan cast with `set_deferred`, its working buffers handed to another update (whose
    /// results held another scan) and finished there, gives that update the naive sets of
    /// facts §3.2 and the counts a plain scan reports; the casting update keeps no results,
    /// and a second `finish_pending` finds nothing.
    #[test]
    fn a_deferred_scan_finishes_in_another_update(
        res in prop::sample::select(vec![0.05, 0.1, 0.25]),
        pts in prop::collection::vec(point_strategy(), 0..300),
        other in prop::collection::vec(point_strategy(), 1..50),
        o in prop::array::uniform3(-0.5f32..0.5),
        max_range in prop::sample::select(vec![-1.0, 0.7, 100.0]),
    ) {
        let c = conv(res);
        let origin = Point3::from(o);
        let m = if max_range < 0.0 { None } else { Some(max_range) };
        let mut cast = ScanUpdate::new();
        cast.set_serial(true);
        cast.set_deferred(true);
        let partial = compute_update_f32(&c, &pts, &origin, m, &mut cast);
        prop_assert!(cast.free_bricks().is_empty() && cast.occupied_bricks().is_empty());
        // the results' update held another scan, listed as keys too
        let mut results = ScanUpdate::new();
        compute_update_f32(&c, &other, &origin, m, &mut results);
        let _ = results.free();
        results.pass_buffers(&mut cast);
        let done = results.finish_pending();
        prop_assert!(done.is_some());
        prop_assert!(results.finish_pending().is_none());
        results.pass_buffers(&mut cast);
        let mut plain = ScanUpdate::new();
        let want = compute_update_f32(&c, &pts, &origin, m, &mut plain);
        let done = done.unwrap_or_default();
        prop_assert_eq!((done.free, done.occupied), (want.free, want.occupied));
        prop_assert_eq!((partial.rays, partial.points), (want.rays, want.points));
        prop_assert_eq!(results.free_bricks(), plain.free_bricks());
        prop_assert_eq!(results.occupied_bricks(), plain.occupied_bricks());
        let (free, occ) = naive_update(&c, &pts, &origin, max_range);
        let f: HashSet<Key> = results.free().iter().copied().collect();
        let oc: HashSet<Key> = results.occupied().iter().copied().collect();
        prop_assert_eq!(f, free);
        prop_assert_eq!(oc, occ);
    }
}

/// A scan large enough for the brick sets' pages (more than 16 384 free bricks, as a LiDAR
/// frame): the sets equal the naive ones, on one thread and split across four, with DDA rays
/// and with Bresenham lines; and a small scan after it in the same update (the pages cleaned,
/// the small table again) too. Once near the map's centre and once from its far corner,
/// whose voxels (keys 65535) fill the last page of all.
#[test]
fn paged_brick_sets_equal_the_naive_sets() {
    let c = conv(0.05);
    // the centre of the voxel of key 65535 on every axis
    let corner = c.key_to_point_f32(&Key::new(65535, 65535, 65535));
    for (origin, toward_centre) in [(Point3::new(0.01f32, -0.02, 0.03), false), (corner, true)] {
        // rays to a sphere of radius 12-30 m (from the corner, its octant towards the
        // centre): about 400 voxels each, few shared
        let mut s = 0x2545_F491_4F6C_DD1Du64;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        let big: Vec<Point3<f32>> = (0..3000)
            .map(|_| {
                let (u, v, r) = (
                    next() * 2.0 - 1.0,
                    next() * std::f64::consts::TAU,
                    12.0 + 18.0 * next(),
                );
                let w = (1.0 - u * u).sqrt();
                let d = [r * w * v.cos(), r * w * v.sin(), r * u];
                let d = if toward_centre {
                    d.map(|x| -x.abs())
                } else {
                    d
                };
                Point3::new(
                    origin.x + d[0] as f32,
                    origin.y + d[1] as f32,
                    origin.z + d[2] as f32,
                )
            })
            .collect();
        let small = &big[..20];
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(4)
            .build()
            .unwrap();
        let mut out = ScanUpdate::new();
        for (pts, paged) in [(&big[..], true), (small, false), (&big[..], true)] {
            let (free, occ) = naive_update(&c, pts, &origin, -1.0);
            for threads in [1, 4] {
                if threads == 1 {
                    out.set_serial(true);
                    compute_update_f32(&c, pts, &origin, None, &mut out);
                } else {
                    out.set_serial(false);
                    pool.install(|| compute_update_f32(&c, pts, &origin, None, &mut out));
                }
                assert_eq!(out.free_bricks().len() > 16_384, paged, "{threads} threads");
                assert!(sorted_by_morton(out.free()));
                assert_eq!(out.free().iter().copied().collect::<HashSet<_>>(), free);
                assert_eq!(out.occupied().iter().copied().collect::<HashSet<_>>(), occ);
            }
            if toward_centre {
                // the origin's voxel is the far corner's: the last page is among the sets
                assert_eq!(
                    out.free_bricks().last().map(|b| b.code),
                    Some((1 << 42) - 1)
                );
            }
            let (bfree, bocc) = naive_bresenham_update(&c, pts, &origin, None);
            out.set_serial(true);
            compute_update_with_f32(&c, pts, &origin, None, RayModel::Bresenham, &mut out);
            assert_eq!(out.free().iter().copied().collect::<HashSet<_>>(), bfree);
            assert_eq!(out.occupied().iter().copied().collect::<HashSet<_>>(), bocc);
        }
    }
}
