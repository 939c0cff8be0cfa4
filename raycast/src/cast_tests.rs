use super::*;
use octoquant_octree::validate::assert_well_formed;
use proptest::prelude::*;

fn wall_tree() -> OcTree {
    // a free corridor along +x from the origin and an occupied voxel at x = 2.05
    let mut t = OcTree::new(0.1).unwrap();
    let origin = Point3::new(0.05f32, 0.05, 0.05);
    assert!(insert_ray_f32(
        &mut t,
        &origin,
        &Point3::new(2.05, 0.05, 0.05),
        &InsertRayOptions::default()
    ));
    t
}

/// OctoMap's defaults.
const DEFAULTS: CastOptions = CastOptions {
    ignore_unknown: false,
    max_range: None,
};

/// OctoMap's defaults, but through unknown space.
const IGNORE: CastOptions = CastOptions {
    ignore_unknown: true,
    max_range: None,
};

/// OctoMap's defaults, but with a maximum range.
fn within(max_range: f64) -> CastOptions {
    CastOptions {
        max_range: Some(max_range),
        ..DEFAULTS
    }
}

/// `insertRay` with a maximum range.
fn cut_at(max_range: f64) -> InsertRayOptions {
    InsertRayOptions {
        max_range: Some(max_range),
        lazy: false,
    }
}

fn p(x: f32, y: f32, z: f32) -> Point3<f32> {
    Point3::new(x, y, z)
}

#[test]
fn hits_the_first_occupied_voxel() {
    let t = wall_tree();
    let r = cast_ray_f32(&t, &p(0.05, 0.05, 0.05), &p(3.0, 0.0, 0.0), &DEFAULTS);
    assert_eq!(r.stop, CastStop::Occupied);
    assert!(r.hit);
    assert_eq!(r.end_f32(), Some(p(2.05, 0.05, 0.05)));
    assert_eq!(r.key, Some(Key::new(32788, 32768, 32768)));
}

#[test]
fn origin_voxel_counts() {
    let t = wall_tree();
    // starting inside the occupied voxel: a hit at its centre
    let r = cast_ray_f32(&t, &p(2.01, 0.02, 0.09), &p(-1.0, 0.0, 0.0), &DEFAULTS);
    assert_eq!((r.hit, r.end_f32()), (true, Some(p(2.05, 0.05, 0.05))));
    // starting in unknown space: stop there unless unknown is ignored
    let r = cast_ray_f32(&t, &p(0.05, 5.0, 0.05), &p(1.0, 0.0, 0.0), &DEFAULTS);
    assert_eq!(
        (r.stop, r.end_f32()),
        (CastStop::Unknown, Some(p(0.05, 5.05, 0.05)))
    );
    assert!(!r.hit);
}

#[test]
fn unknown_max_range_and_ignore_unknown() {
    let t = wall_tree();
    // leaving the corridor sideways: unknown
    let r = cast_ray_f32(&t, &p(0.05, 0.05, 0.05), &p(0.0, 1.0, 0.0), &DEFAULTS);
    assert_eq!(
        (r.stop, r.end_f32()),
        (CastStop::Unknown, Some(p(0.05, 0.15, 0.05)))
    );
    // max range: the voxel centre 1.0 away is beyond 0.95
    let r = cast_ray_f32(&t, &p(0.05, 0.05, 0.05), &p(1.0, 0.0, 0.0), &within(0.95));
    assert_eq!(
        (r.stop, r.end_f32()),
        (CastStop::MaxRange, Some(p(1.05, 0.05, 0.05)))
    );
    // max range 0 means none (OctoMap tests `maxRange > 0`)
    let r = cast_ray_f32(&t, &p(0.05, 0.05, 0.05), &p(1.0, 0.0, 0.0), &within(0.0));
    assert_eq!(r.stop, CastStop::Occupied);
    // ignoring unknown space, a ray along -y runs to the map boundary
    let r = cast_ray_f32(&t, &p(0.05, 0.05, 0.05), &p(0.0, -1.0, 0.0), &IGNORE);
    assert_eq!(r.stop, CastStop::MapBoundary);
    assert_eq!(r.key, Some(Key::new(32768, 0, 32768)));
    assert!(!r.hit);
}

#[test]
fn bad_inputs_leave_end_untouched() {
    let t = wall_tree();
    let o = p(0.05, 0.05, 0.05);
    for d in [
        p(0.0, 0.0, 0.0),
        p(f32::NAN, 0.0, 0.0),
        p(f32::INFINITY, 0.0, 0.0),
        p(f32::INFINITY, 1.0, -1.0),
    ] {
        let r = cast_ray_f32(&t, &o, &d, &DEFAULTS);
        assert_eq!(
            (r.stop, r.end_f32(), r.hit),
            (CastStop::BadDirection, None, false)
        );
    }
    let r = cast_ray_f32(&t, &p(1e6, 0.0, 0.0), &p(1.0, 0.0, 0.0), &DEFAULTS);
    assert_eq!((r.stop, r.end_f32()), (CastStop::OriginOutsideMap, None));
    let r = cast_ray_f32(&t, &p(f32::NAN, 0.0, 0.0), &p(1.0, 0.0, 0.0), &IGNORE);
    assert_eq!(r.stop, CastStop::OriginOutsideMap);
    // a NaN component only disables its axis, as in OctoMap
    let r = cast_ray_f32(&t, &o, &p(f32::NAN, 1.0, 0.0), &DEFAULTS);
    assert_eq!(
        (r.stop, r.end_f32()),
        (CastStop::Unknown, Some(p(0.05, 0.15, 0.05)))
    );
}

#[test]
fn a_walk_that_cannot_move_stops() {
    // the half-voxel is astronomically large and the direction subnormal: tMax overflows,
    // so only axes that cannot step get chosen; OctoMap would spin forever
    let t = OcTree::new(1e300).unwrap();
    let r = cast_ray_f32(&t, &p(0.0, 0.0, 0.0), &p(1e-45, 0.0, 0.0), &IGNORE);
    assert_eq!(r.stop, CastStop::Stalled);
    assert!(!r.hit);
}

#[test]
fn insert_ray_cuts_at_max_range() {
    let mut t = OcTree::new(0.1).unwrap();
    let o = p(0.05, 0.05, 0.05);
    assert!(insert_ray_f32(
        &mut t,
        &o,
        &p(1.05, 0.05, 0.05),
        &cut_at(0.5)
    ));
    let c = t.converter().clone();
    // misses on 32768..=32772, no hit, the cut voxel untouched
    for x in 32768..=32772u16 {
        assert_eq!(t.is_occupied(Key::new(x, 32768, 32768)), Some(false));
    }
    assert_eq!(t.is_occupied(Key::new(32773, 32768, 32768)), None);
    assert_eq!(
        t.is_occupied(key_of(&c, &p(1.05, 0.05, 0.05)).unwrap()),
        None
    );
    // Some(0) and negative: no cut (OctoMap's `maxrange > 0`)
    assert!(insert_ray_f32(
        &mut t,
        &o,
        &p(1.05, 0.05, 0.05),
        &cut_at(0.0)
    ));
    assert_eq!(t.is_occupied(Key::new(32778, 32768, 32768)), Some(true));
    // outside the map: nothing happens
    let before = t.size();
    assert!(!insert_ray_f32(
        &mut t,
        &o,
        &p(1e6, 0.0, 0.0),
        &InsertRayOptions::default()
    ));
    assert!(!insert_ray_f32(
        &mut t,
        &o,
        &p(f32::NAN, 0.0, 0.0),
        &cut_at(2.0)
    ));
    assert_eq!(t.size(), before);
    assert_well_formed(&t, InnerNodes::Refresh);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(500))]

    /// Whatever the ray, the result is consistent with the tree: a hit is an occupied voxel
    /// whose centre is `end`; an unknown stop is unknown space; a max-range stop lies beyond
    /// the range.
    #[test]
    fn results_agree_with_the_tree(
        o in prop::array::uniform3(-1.0f32..1.0),
        d in prop::array::uniform3(-1.0f32..1.0),
        ignore in any::<bool>(),
        max_range in prop::sample::select(vec![-1.0, 0.0, 0.3, 1.5]),
        seed in 0u64..50,
    ) {
        let mut t = OcTree::new(0.1).unwrap();
        let origin = p(0.0, 0.0, 0.0);
        // a random blob of rays from the origin
        let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        for _ in 0..30 {
            s ^= s << 13; s ^= s >> 7; s ^= s << 17;
            let a = (s % 628) as f32 / 100.0;
            let b = ((s >> 20) % 300) as f32 / 100.0 - 1.5;
            insert_ray_f32(&mut t, &origin, &p(1.2 * a.cos(), 1.2 * a.sin(), b * 0.5), &InsertRayOptions::default());
        }
        let po = Point3::from(o);
        let r = cast_ray_f32(
            &t,
            &po,
            &Point3::from(d),
            &CastOptions { ignore_unknown: ignore, max_range: Some(max_range) },
        );
        let c = t.converter();
        if let (Some(k), Some(e)) = (r.key, r.end_f32()) {
            prop_assert_eq!(c.key_to_point_f32(&k), e);
        }
        match r.stop {
            CastStop::Occupied => {
                prop_assert!(r.hit);
                prop_assert_eq!(t.is_occupied(r.key.unwrap()), Some(true));
            }
            CastStop::Unknown => {
                prop_assert!(!ignore || r.key != key_of(c, &po));
                prop_assert_eq!(t.is_occupied(r.key.unwrap()), None);
            }
            CastStop::MaxRange => {
                prop_assert!(max_range > 0.0);
                let e = r.end_f32().unwrap();
                let dist = ((e - po).norm_squared() as f64).sqrt();
                prop_assert!(dist > max_range - 1e-4);
            }
            CastStop::MapBoundary => prop_assert!(ignore),
            CastStop::BadDirection => prop_assert_eq!(d, [0.0; 3]),
            other => prop_assert!(false, "unexpected {:?}", other),
        }
    }
}
