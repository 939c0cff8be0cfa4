//! Every `f64` door gives what its `_f32` path gives for the input narrowed by hand, on any
//! input: NaN, infinities, values beyond `f32`'s range, points outside the map.

use super::*;
use crate::cast::CastStop;
use crate::discretize::discretize_f32;
use crate::insert::insert_point_cloud_f32;
use octoquant_octree::io::write_bt;
use proptest::prelude::*;

/// One coordinate: mostly ordinary values in a few metres, some far outside the map at any of
/// the tested resolutions, some beyond `f32`'s range, some not finite.
fn coord() -> impl Strategy<Value = f64> {
    prop_oneof![
        8 => -4.0f64..4.0,
        1 => prop::sample::select(vec![
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            1e40,
            -1e40,
            1e4,
            -3276.9,
            0.0,
            -0.0,
            0.05,
        ]),
    ]
}

fn point() -> impl Strategy<Value = Point3<f64>> {
    (coord(), coord(), coord()).prop_map(|(x, y, z)| Point3::new(x, y, z))
}

fn points() -> impl Strategy<Value = Vec<Point3<f64>>> {
    prop::collection::vec(point(), 0..60)
}

fn resolution() -> impl Strategy<Value = f64> {
    prop::sample::select(vec![0.05, 0.1, 0.37])
}

fn max_range() -> impl Strategy<Value = Option<f64>> {
    prop::sample::select(vec![None, Some(-1.0), Some(0.0), Some(1.5), Some(f64::NAN)])
}

/// Narrowing by hand, the way a caller of the `_f32` paths would.
fn by_hand(p: &Point3<f64>) -> Point3<f32> {
    Point3::new(p.x as f32, p.y as f32, p.z as f32)
}

fn all_by_hand(ps: &[Point3<f64>]) -> Vec<Point3<f32>> {
    ps.iter().map(by_hand).collect()
}

fn bt(tree: &mut OcTree) -> Vec<u8> {
    let mut out = Vec::new();
    write_bt(tree, &mut out).unwrap();
    out
}

/// A tree with some occupied, free and unknown space around the origin.
fn scene(res: f64, cloud: &[Point3<f64>]) -> OcTree {
    let mut t = OcTree::new(res).unwrap();
    let wall: Vec<Point3<f32>> = (0..100)
        .map(|i| {
            Point3::new(
                1.5,
                (i % 10) as f32 * 0.1 - 0.5,
                (i / 10) as f32 * 0.1 - 0.5,
            )
        })
        .collect();
    insert_point_cloud_f32(&mut t, &wall, &Point3::origin(), &InsertOptions::default());
    insert_point_cloud_f32(
        &mut t,
        &all_by_hand(cloud),
        &Point3::new(0.01, 0.02, 0.03),
        &InsertOptions::default(),
    );
    t
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn cast_ray_is_the_narrowed_f32_cast(
        res in resolution(),
        cloud in points(),
        o in point(),
        d in point(),
        ignore_unknown in any::<bool>(),
        max_range in max_range(),
    ) {
        let t = scene(res, &cloud);
        let options = CastOptions { ignore_unknown, max_range };
        let got = cast_ray(&t, &o, &d.coords, &options);
        let want = cast_ray_f32(&t, &by_hand(&o), &by_hand(&d), &options);
        prop_assert_eq!(got, want);
        // the f64 end is the key's exact centre; narrowed, OctoMap's float centre
        prop_assert_eq!(got.end, got.key.map(|k| t.converter().key_to_point(&k)));
        prop_assert_eq!(got.end_f32(), got.key.map(|k| t.converter().key_to_point_f32(&k)));
        prop_assert_eq!(got.end.is_none(), matches!(got.stop, CastStop::OriginOutsideMap | CastStop::BadDirection));
    }

    #[test]
    fn insert_ray_is_the_narrowed_f32_insertion(
        res in resolution(),
        rays in prop::collection::vec((point(), point()), 1..8),
        max_range in max_range(),
        lazy in any::<bool>(),
    ) {
        let options = InsertRayOptions { max_range, lazy };
        let (mut a, mut b) = (OcTree::new(res).unwrap(), OcTree::new(res).unwrap());
        for (o, e) in &rays {
            let got = insert_ray(&mut a, o, e, &options);
            let want = insert_ray_f32(&mut b, &by_hand(o), &by_hand(e), &options);
            prop_assert_eq!(got, want);
        }
        a.update_inner_occupancy();
        b.update_inner_occupancy();
        prop_assert_eq!(bt(&mut a), bt(&mut b));
    }

    #[test]
    fn compute_ray_keys_is_the_narrowed_f32_walk(res in resolution(), o in point(), e in point()) {
        let conv = KeyConverter::new(res).unwrap();
        let (mut a, mut b) = (KeyRay::new(), KeyRay::new());
        let got = compute_ray_keys(&conv, &o, &e, &mut a);
        let want = compute_ray_keys_f32(&conv, &by_hand(&o), &by_hand(&e), &mut b);
        prop_assert_eq!(got, want);
        prop_assert_eq!(a.keys(), b.keys());
    }

    #[test]
    fn insert_point_cloud_is_the_narrowed_f32_insertion(
        res in resolution(),
        scans in prop::collection::vec((points(), point()), 1..4),
        max_range in max_range(),
        discretize in any::<bool>(),
        lazy in any::<bool>(),
    ) {
        let options = InsertOptions { max_range, discretize, lazy };
        let (mut a, mut b) = (OcTree::new(res).unwrap(), OcTree::new(res).unwrap());
        for (pts, o) in &scans {
            let got = insert_point_cloud(&mut a, pts, o, &options);
            let want = insert_point_cloud_f32(&mut b, &all_by_hand(pts), &by_hand(o), &options);
            prop_assert_eq!(got, want);
        }
        a.update_inner_occupancy();
        b.update_inner_occupancy();
        prop_assert_eq!(bt(&mut a), bt(&mut b));
    }

    #[test]
    fn insert_point_cloud_rays_is_the_narrowed_f32_insertion(
        res in resolution(),
        scans in prop::collection::vec((points(), point()), 1..4),
        lazy in any::<bool>(),
    ) {
        let options = ApplyOptions { lazy };
        let (mut a, mut b) = (OcTree::new(res).unwrap(), OcTree::new(res).unwrap());
        for (pts, o) in &scans {
            let got = insert_point_cloud_rays(&mut a, pts, o, &options);
            let want = insert_point_cloud_rays_f32(&mut b, &all_by_hand(pts), &by_hand(o), &options);
            prop_assert_eq!(got, want);
        }
        a.update_inner_occupancy();
        b.update_inner_occupancy();
        prop_assert_eq!(bt(&mut a), bt(&mut b));
    }

    /// Both update doors, with one `ScanUpdate` reused across scans of different sizes (its
    /// narrowing buffer must not leak points from one scan into the next).
    #[test]
    fn update_doors_are_the_narrowed_f32_updates(
        res in resolution(),
        scans in prop::collection::vec((points(), point()), 1..4),
        max_range in max_range(),
        discrete in any::<bool>(),
    ) {
        let conv = KeyConverter::new(res).unwrap();
        let (mut a, mut b) = (ScanUpdate::new(), ScanUpdate::new());
        for (pts, o) in &scans {
            let (got, want) = if discrete {
                (
                    compute_discrete_update(&conv, pts, o, max_range, &mut a),
                    compute_discrete_update_f32(&conv, &all_by_hand(pts), &by_hand(o), max_range, &mut b),
                )
            } else {
                (
                    compute_update(&conv, pts, o, max_range, &mut a),
                    compute_update_f32(&conv, &all_by_hand(pts), &by_hand(o), max_range, &mut b),
                )
            };
            prop_assert_eq!(got, want);
            prop_assert_eq!(a.free(), b.free());
            prop_assert_eq!(a.occupied(), b.occupied());
        }
    }

    #[test]
    fn discretize_is_the_narrowed_f32_discretize(res in resolution(), pts in points()) {
        let conv = KeyConverter::new(res).unwrap();
        let (mut a, mut b) = (vec![Point3::new(9.0, 9.0, 9.0)], Vec::new());
        let got = discretize(&conv, &pts, &mut a);
        let want = discretize_f32(&conv, &all_by_hand(&pts), &mut b);
        prop_assert_eq!(got, want);
        // the same voxels in the same order, exact centres that narrow to the f32 ones
        prop_assert_eq!(all_by_hand(&a), b);
        for c in &a {
            let k = conv.point_to_key_unchecked(c);
            prop_assert_eq!(*c, conv.key_to_point(&k));
        }
    }
}

/// Narrowing is the caller's `as f32`: a finite `f64` beyond `f32`'s range becomes infinite
/// and is counted as non-finite, and a value between two floats rounds to the nearer, so the
/// door lands in OctoMap's voxel for the float, not in the voxel of the exact `f64` value.
#[test]
fn narrowing_rounds_to_nearest_and_overflows_to_infinity() {
    let conv = KeyConverter::new(0.1).unwrap();
    let mut out = ScanUpdate::new();
    let pts = [Point3::new(1e39, 0.0, 0.0), Point3::new(0.5, 0.0, 0.0)];
    let s = compute_update(&conv, &pts, &Point3::new(0.05, 0.05, 0.05), None, &mut out);
    assert_eq!((s.non_finite, s.outside_map, s.rays), (1, 0, 1));

    // 1e-9 below 0.1 in f64, but the nearest float is 0.1f32, which lies above 0.1
    let below = Point3::new(0.1 - 1e-9, 0.05, 0.05);
    assert_eq!(below.x as f32, 0.1f32);
    assert!(0.1f32 as f64 > 0.1);
    let exact = conv.point_to_key(&below).unwrap();
    let float = conv.point_to_key(&Point3::new(0.15, 0.05, 0.05)).unwrap();
    assert_ne!(exact, float);
    let mut ray = KeyRay::new();
    assert!(compute_ray_keys(
        &conv,
        &below,
        &Point3::new(0.35, 0.05, 0.05),
        &mut ray
    ));
    assert_eq!(ray.len(), 2);
    assert_eq!(ray.keys()[0], float);
}
