use super::*;
use octoquant_octree::Brick;
use proptest::prelude::*;

fn conv(res: f64) -> KeyConverter {
    KeyConverter::new(res).unwrap()
}

fn keys(c: &KeyConverter, o: [f32; 3], e: [f32; 3]) -> (bool, Vec<Key>) {
    let mut ray = KeyRay::new();
    let ok = compute_ray_keys_f32(c, &Point3::from(o), &Point3::from(e), &mut ray);
    (ok, ray.into_vec())
}

/// A xorshift generator of uniform `f64`s in [0, 1) from `seed`: many rays per test, without
/// proptest's shrinking.
fn uniform(seed: u64) -> impl FnMut() -> f64 {
    let mut s = seed;
    move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn k(x: u16, y: u16, z: u16) -> Key {
    Key::new(x, y, z)
}

#[test]
fn ties_go_to_z_then_y_then_x() {
    // facts §2: for (0,0,0) -> (0.3,0.3,0) y steps first
    let c = conv(0.1);
    let (ok, r) = keys(&c, [0.0; 3], [0.3, 0.3, 0.0]);
    assert!(ok);
    assert_eq!(r[0], k(32768, 32768, 32768));
    assert_eq!(r[1], k(32768, 32769, 32768));
    assert_eq!(r[2], k(32769, 32769, 32768));
    // the 3-D diagonal steps z, y, x
    let (_, r) = keys(&c, [0.05; 3], [0.35; 3]);
    assert_eq!(
        &r[..4],
        &[
            k(32768, 32768, 32768),
            k(32768, 32768, 32769),
            k(32768, 32769, 32769),
            k(32769, 32769, 32769)
        ]
    );
}

#[test]
fn end_voxel_excluded_origin_included() {
    let c = conv(0.1);
    let (ok, r) = keys(&c, [0.05, 0.05, 0.05], [1.05, 0.05, 0.05]);
    assert!(ok);
    let xs: Vec<u16> = r.iter().map(|k| k.x()).collect();
    assert_eq!(xs, (32768..32778).collect::<Vec<_>>());
    // negative direction
    let (_, r) = keys(&c, [0.05, 0.05, 0.05], [-0.25, 0.05, 0.05]);
    let xs: Vec<u16> = r.iter().map(|k| k.x()).collect();
    assert_eq!(xs, vec![32768, 32767, 32766]);
}

#[test]
fn same_voxel_and_outside_map() {
    let c = conv(0.1);
    assert_eq!(keys(&c, [0.01; 3], [0.09; 3]), (true, vec![]));
    assert_eq!(keys(&c, [0.0; 3], [4000.0, 0.0, 0.0]), (false, vec![]));
    assert_eq!(keys(&c, [0.0; 3], [0.0, 0.0, -3276.9]), (false, vec![]));
    assert_eq!(keys(&c, [f32::NAN, 0.0, 0.0], [1.0; 3]), (false, vec![]));
    assert_eq!(
        keys(&c, [0.0; 3], [f32::INFINITY, 0.0, 0.0]),
        (false, vec![])
    );
    // the last voxel of the map is inside
    assert!(keys(&c, [3276.0, 0.0, 0.0], [3276.79, 0.0, 0.0]).0);
}

#[test]
fn a_failed_ray_clears_the_buffer() {
    let c = conv(0.1);
    let mut ray = KeyRay::new();
    assert!(compute_ray_keys_f32(
        &c,
        &Point3::new(0.0, 0.0, 0.0),
        &Point3::new(1.05, 0.0, 0.0),
        &mut ray
    ));
    assert_eq!(ray.len(), 10);
    assert!(!compute_ray_keys_f32(
        &c,
        &Point3::new(0.0, 0.0, 0.0),
        &Point3::new(1e6, 0.0, 0.0),
        &mut ray
    ));
    assert!(ray.is_empty());
}

#[test]
fn end_on_a_boundary_drops_the_last_voxel() {
    // the border adds (f32)(res/2), slightly more than res/2: the voxel before an end lying
    // exactly on its border is left on the "overshoot" test, as in OctoMap
    let c = conv(0.1);
    let (ok, r) = keys(&c, [0.0; 3], [1.0, 0.0, 0.0]);
    assert!(ok);
    let xs: Vec<u16> = r.iter().map(|k| k.x()).collect();
    assert_eq!(xs, (32768..32777).collect::<Vec<_>>());
}

#[test]
fn visitor_can_stop() {
    let c = conv(0.1);
    let mut seen = 0;
    let w = walk_ray_keys_f32(
        &c,
        &Point3::new(0.0, 0.0, 0.0),
        &Point3::new(5.0, 0.0, 0.0),
        |_| {
            seen += 1;
            seen < 3
        },
    );
    assert_eq!((w, seen), (RayWalk::Stopped, 3));
}

#[test]
fn underflowing_length_still_ends_when_octomap_does() {
    // |end - origin|^2 underflows to 0 in f32: direction becomes (inf, NaN, NaN), but the
    // walk reaches the end voxel in one step, as in OctoMap
    let c = conv(0.1);
    let (ok, r) = keys(&c, [-1e-30, 0.0, 0.0], [1e-30, 0.0, 0.0]);
    assert!(ok);
    assert_eq!(r, vec![k(32767, 32768, 32768)]);
}

#[test]
fn degenerate_rays_terminate() {
    // two axes with an infinite direction: OctoMap steps y forever (until its assert aborts)
    let c = conv(0.1);
    let mut n = 0;
    let w = walk_ray_keys_f32(
        &c,
        &Point3::new(-1e-30, -1e-30, 0.0),
        &Point3::new(1e-30, 1e-30, 0.0),
        |_| {
            n += 1;
            true
        },
    );
    assert_eq!(w, RayWalk::Degenerate);
    assert!(n <= 1 + 2 + 16);
    assert_eq!(
        keys(&c, [-1e-30, -1e-30, 0.0], [1e-30, 1e-30, 0.0]),
        (false, vec![])
    );
    // a resolution so large that the f32 squared length overflows: no axis can step
    let c = conv(1e33);
    assert_eq!(
        keys(&c, [-1e37, 0.0, 0.0], [1e37, 0.0, 0.0]),
        (false, vec![])
    );
}

/// Segment-box test in f64 (slab method) against the box grown by `pad` on every side.
fn segment_hits_box(o: [f64; 3], e: [f64; 3], lo: [f64; 3], hi: [f64; 3], pad: f64) -> bool {
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for i in 0..3 {
        let d = e[i] - o[i];
        let (l, h) = (lo[i] - pad, hi[i] + pad);
        if d == 0.0 {
            if o[i] < l || o[i] > h {
                return false;
            }
        } else {
            let (a, b) = ((l - o[i]) / d, (h - o[i]) / d);
            let (a, b) = if a < b { (a, b) } else { (b, a) };
            t0 = t0.max(a);
            t1 = t1.min(b);
            if t0 > t1 {
                return false;
            }
        }
    }
    true
}

fn voxel_box(c: &KeyConverter, key: Key) -> ([f64; 3], [f64; 3]) {
    let r = c.resolution();
    let lo = [0, 1, 2].map(|i| (key[i] as f64 - 32768.0) * r);
    (lo, lo.map(|v| v + r))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(3000))]

    /// Against the geometric definition: the keys form a 6-connected, axis-monotone path from
    /// the origin voxel; every key's voxel touches the segment; and every voxel the segment
    /// crosses robustly (through its interior, shrunk by a margin) is on the ray or is the end
    /// voxel, except a voxel whose border the end point lies on.
    #[test]
    fn keys_are_the_voxels_the_segment_crosses(
        res in prop::sample::select(vec![0.05, 0.1, 0.2, 0.37]),
        o in prop::array::uniform3(-3.0f32..3.0),
        e in prop::array::uniform3(-3.0f32..3.0),
    ) {
        let c = conv(res);
        let (ok, ray) = keys(&c, o, e);
        prop_assert!(ok);
        let po = Point3::from(o);
        let pe = Point3::from(e);
        let ko = key_of(&c, &po).unwrap();
        let ke = key_of(&c, &pe).unwrap();
        if ko == ke {
            prop_assert!(ray.is_empty());
            return Ok(());
        }
        prop_assert_eq!(ray[0], ko);
        prop_assert!(!ray.contains(&ke));
        for w in ray.windows(2) {
            let d: Vec<i32> = (0..3).map(|i| w[1][i] as i32 - w[0][i] as i32).collect();
            prop_assert_eq!(d.iter().map(|v| v.abs()).sum::<i32>(), 1, "{:?}", w);
            for i in 0..3 {
                prop_assert!(d[i] == 0 || d[i].signum() == (e[i] - o[i]).signum() as i32);
            }
        }
        let of = o.map(|v| v as f64);
        let ef = e.map(|v| v as f64);
        let tol = 1e-4 * res;
        for key in &ray {
            let (lo, hi) = voxel_box(&c, *key);
            prop_assert!(segment_hits_box(of, ef, lo, hi, tol), "{:?} not on the segment", key);
        }
        // brute force over the keys' bounding box
        let (lo_k, hi_k) = ([0, 1, 2].map(|i| ko[i].min(ke[i])), [0, 1, 2].map(|i| ko[i].max(ke[i])));
        for x in lo_k[0]..=hi_k[0] {
            for y in lo_k[1]..=hi_k[1] {
                for z in lo_k[2]..=hi_k[2] {
                    let key = Key::new(x, y, z);
                    let (lo, hi) = voxel_box(&c, key);
                    // OctoMap's overshoot test may drop the last voxel before an end lying on
                    // (within float rounding of) that voxel's border
                    let end_on_border = segment_hits_box(ef, ef, lo, hi, 1e-5);
                    if segment_hits_box(of, ef, lo, hi, -tol) && !end_on_border {
                        prop_assert!(key == ke || ray.contains(&key), "{:?} crossed but missing", key);
                    }
                }
            }
        }
    }
}

#[test]
fn code_walk_visits_the_same_voxels_as_the_key_walk() {
    let mut u = uniform(0x9e37_79b9_7f4a_7c15u64);
    let mut r = || (u() * 2.0 - 1.0) as f32;
    for res in [0.05, 0.1, 0.37] {
        let conv = KeyConverter::new(res).unwrap();
        for i in 0..20_000 {
            let scale = [1.0, 10.0, 300.0][i % 3];
            let o = Point3::new(r() * scale, r() * scale, r() * scale);
            let mut e = Point3::new(r() * scale, r() * scale, r() * scale);
            if i % 7 == 0 {
                e.y = o.y; // in a plane: steps on two axes only
            }
            let mut keys = Vec::new();
            let wk = walk_ray_keys_f32(&conv, &o, &e, |k| {
                keys.push(k.morton());
                true
            });
            let mut codes = Vec::new();
            let wc = walk_ray_codes_f32(&conv, &o, &e, |c| codes.push(c));
            assert_eq!(wk, wc);
            assert_eq!(keys, codes, "ray {o:?} -> {e:?} at {res}");
        }
    }
}

/// [`walk_ray_codes_f32`] for set-building callers that cannot take keys back: `None` (nothing
/// visited) when the ray's float set-up is not well-conditioned, otherwise the same voxels and
/// the same outcome. The voxels are handed out per 4x4x4 brick (`code >> 6`) as a bit mask of
/// the brick's visited voxels (bit `code & 63`): `flush` runs once per brick entered, not once
/// per voxel, after the walk (which records the bricks in `buf`, kept by the caller from ray
/// to ray). `origin_key` must be `key_of(conv, origin)`, computed once for all the rays of a
/// scan. It is safe to visit without buffering the keys: only the rays refused here can
/// degenerate (see `RaySetup::well_conditioned`), so [`RayWalk::Degenerate`] never follows a
/// visit.
fn try_walk_ray_bricks<F>(
    conv: &KeyConverter,
    origin: &Point3<f32>,
    origin_key: Option<Key>,
    end: &Point3<f32>,
    buf: &mut Vec<Brick>,
    mut flush: F,
) -> Option<RayWalk>
where
    F: crate::brickset::BrickSink,
{
    let r = match setup_from(conv, origin, origin_key, end) {
        Ok(r) => r,
        Err(w) => return Some(w),
    };
    if !r.well_conditioned {
        return None;
    }
    Some(crate::lanes::BrickWalk::start(&r, buf).finish_into(buf, &mut flush))
}

/// The unbuffered walk agrees with the buffered one whenever it accepts a ray, never ends
/// `Degenerate` after a visit, and refuses only rays whose length or direction is not finite
/// and positive.
fn check_try_walk(conv: &KeyConverter, o: Point3<f32>, e: Point3<f32>) -> Result<(), String> {
    let mut want = Vec::new();
    let w = walk_ray_codes_f32(conv, &o, &e, |c| want.push(c));
    let mut got = Vec::new();
    let mut walked = Vec::new();
    let mut buf = Vec::new();
    match try_walk_ray_bricks(conv, &o, key_of(conv, &o), &e, &mut buf, |b: Brick| {
        got.push(b.code);
        let mut bits = b.voxels;
        while bits != 0 {
            walked.push((b.code << 6) | bits.trailing_zeros() as u64);
            bits &= bits - 1;
        }
    }) {
        Some(t) => {
            // bricks are flushed as the walk leaves them: the same voxels, brick by brick
            let mut runs = want.iter().map(|c| c >> 6).collect::<Vec<_>>();
            runs.dedup();
            let mut want_set = want.clone();
            want_set.sort_unstable();
            want_set.dedup();
            walked.sort_unstable();
            if t != w || walked != want_set || (w == RayWalk::Complete && got != runs) {
                return Err(format!(
                    "{o:?} -> {e:?}: {t:?} {} keys vs {w:?} {}",
                    got.len(),
                    want.len()
                ));
            }
            if t == RayWalk::Degenerate {
                return Err(format!("{o:?} -> {e:?}: accepted but degenerate"));
            }
            // the eight-lane walk skips its end checks until three steps before the Manhattan
            // distance (`lanes::refill::first_stop`): no accepted walk may stop earlier
            if let Ok(r) = setup_from(conv, &o, key_of(conv, &o), &e) {
                let manhattan = (r.budget - STEP_MARGIN) as usize;
                if want.len() + 3 < manhattan {
                    return Err(format!(
                        "{o:?} -> {e:?}: stopped after {} of {manhattan} steps",
                        want.len()
                    ));
                }
            }
        }
        None => {
            if !got.is_empty() {
                return Err(format!("{o:?} -> {e:?}: refused after visiting"));
            }
            if w == RayWalk::Complete && want.len() > 1 {
                // refused rays are the ill-conditioned ones: all of them are tiny or huge
                let d = sub_f32(&e, &o);
                let n = norm_f32(d) as f32;
                if n.is_finite() && n > 0.0 {
                    return Err(format!("{o:?} -> {e:?}: refused a regular ray"));
                }
            }
        }
    }
    Ok(())
}

#[test]
fn unbuffered_walk_matches_on_regular_and_extreme_rays() {
    let mut u = uniform(0x2545_f491_4f6c_dd1du64);
    let mut r = || (u() * 2.0 - 1.0) as f32;
    for res in [0.01, 0.1, 1.0] {
        let conv = KeyConverter::new(res).unwrap();
        let edge = (32767.0 * res) as f32;
        for i in 0..6_000 {
            // a few rays across the whole map (up to 196 605 voxels each)
            let scale = if i % 500 == 0 {
                edge
            } else {
                [1.0, 20.0, 1e-30][i % 3]
            };
            let o = Point3::new(r() * scale, r() * scale, r() * scale);
            let e = Point3::new(r() * scale, r() * scale, r() * scale);
            check_try_walk(&conv, o, e).unwrap();
        }
        // straddling the zero borders with subnormal differences, and along the map's edge
        for (o, e) in [
            ([-1e-38f32, 0.0, 0.0], [1e-38f32, 0.0, 0.0]),
            ([-1e-45, -1e-45, -1e-45], [1e-45, 1e-45, 1e-45]),
            ([-edge, -edge, -edge], [edge, edge, edge]),
            ([-edge, 0.0, edge], [edge, 0.0, -edge]),
        ] {
            check_try_walk(&conv, Point3::from(o), Point3::from(e)).unwrap();
        }
    }
}

proptest! {
    #[test]
    fn unbuffered_walk_matches_on_any_floats(
        o in any::<[f32; 3]>(),
        e in any::<[f32; 3]>(),
        res in prop::sample::select(vec![0.02, 0.1, 0.5]),
    ) {
        let conv = KeyConverter::new(res).unwrap();
        prop_assert!(check_try_walk(&conv, Point3::from(o), Point3::from(e)).is_ok());
    }
}

/// Whether the set-up of `o -> e` tells its stop ([`stop_is_told`]), checked against the
/// reference walk: a told walk ends complete after exactly its Manhattan key distance in keys
/// (the origin's included, the end's not), and no complete walk ends before [`first_watch`].
/// `None` for rays without a set-up.
fn check_told(conv: &KeyConverter, o: Point3<f32>, e: Point3<f32>) -> Result<Option<bool>, String> {
    let Ok(r) = setup_from(conv, &o, key_of(conv, &o), &e) else {
        return Ok(None);
    };
    let keys = [0, 1, 2].map(|a| u32::from(r.key_origin[a].abs_diff(r.key_end[a])));
    let manhattan: u64 = keys.iter().map(|&k| u64::from(k)).sum();
    let told = stop_is_told(r.t_max, r.t_delta, r.length, keys);
    let mut visited = 0u64;
    let walk = walk_ray_codes_f32(conv, &o, &e, |_| visited += 1);
    if told && (walk != RayWalk::Complete || visited != manhattan) {
        return Err(format!(
            "{o:?} -> {e:?}: told to stop at {manhattan}, walked {visited} ({walk:?})"
        ));
    }
    let watch = first_watch(r.t_max, r.t_delta, r.length, keys);
    if walk == RayWalk::Complete && visited < watch {
        return Err(format!(
            "{o:?} -> {e:?}: stopped at {visited} before {watch}"
        ));
    }
    Ok(Some(told))
}

/// `e` with coordinate `axis` moved onto the nearest voxel face and then `ulps` floats on.
fn on_face(conv: &KeyConverter, mut e: [f32; 3], axis: usize, ulps: i32) -> [f32; 3] {
    let res = conv.resolution();
    let face = ((e[axis] as f64 / res).round() * res) as f32;
    let bits = face.to_bits() as i64 + i64::from(ulps) * if face < 0.0 { -1 } else { 1 };
    e[axis] = f32::from_bits(bits.clamp(0, u32::MAX as i64) as u32);
    e
}

#[test]
fn told_stops_hold_and_most_lidar_rays_are_told() {
    let mut u = uniform(0x9e37_79b9_7f4a_7c15u64);
    let mut r = || (u() * 2.0 - 1.0) as f32;
    for res in [0.02, 0.1, 0.2] {
        let conv = KeyConverter::new(res).unwrap();
        let (mut told, mut rays, mut faces_told, mut faces) = (0, 0, 0, 0);
        for i in 0..20_000 {
            let o = [r() * 2.0, r() * 2.0, r()];
            let scale = [1.0, 10.0, 60.0][i % 3];
            let e = [
                o[0] + r() * scale,
                o[1] + r() * scale,
                o[2] + r() * scale / 4.0,
            ];
            if let Some(t) = check_told(&conv, Point3::from(o), Point3::from(e)).unwrap() {
                rays += 1;
                told += t as usize;
            }
            // ends on a voxel face, or a few floats off it: some told, some not
            let f = on_face(&conv, e, i % 3, (i % 7) as i32 - 3);
            if let Some(t) = check_told(&conv, Point3::from(o), Point3::from(f)).unwrap() {
                faces += 1;
                faces_told += t as usize;
            }
            // axis-aligned and diagonal rays
            let a = [o[0] + r() * scale, o[1], o[2]];
            check_told(&conv, Point3::from(o), Point3::from(a)).unwrap();
            let d = r() * scale;
            check_told(
                &conv,
                Point3::from(o),
                Point3::from([o[0] + d, o[1] + d, o[2] + d]),
            )
            .unwrap();
        }
        // the shortcut must hold for nearly every ray of a scan, or it buys nothing
        assert!(told * 100 > rays * 99, "{told} of {rays} told at {res}");
        assert!(faces_told < faces, "every end on a face told at {res}");
    }
}

proptest! {
    #[test]
    fn told_stops_hold_for_any_ray(
        o in prop::array::uniform3(-5.0f32..5.0),
        e in prop::array::uniform3(-50.0f32..50.0),
        face in prop::option::of((0usize..3, -4i32..=4)),
        res in prop::sample::select(vec![0.02, 0.1, 0.5]),
    ) {
        let conv = KeyConverter::new(res).unwrap();
        let e = match face {
            Some((axis, ulps)) => on_face(&conv, e, axis, ulps),
            None => e,
        };
        let checked = check_told(&conv, Point3::from(o), Point3::from(e));
        prop_assert!(checked.is_ok(), "{:?}", checked);
    }

    #[test]
    fn told_stops_hold_on_any_floats(
        o in any::<[f32; 3]>(),
        e in any::<[f32; 3]>(),
        res in prop::sample::select(vec![0.02, 0.1, 0.5]),
    ) {
        let conv = KeyConverter::new(res).unwrap();
        let checked = check_told(&conv, Point3::from(o), Point3::from(e));
        prop_assert!(checked.is_ok(), "{:?}", checked);
    }
}

/// Where the chain of additions and the product disagree about a crossing (`t + j·d` rounded
/// once against `j` additions), a length between the two must not be told: the walk counts
/// the chain's crossings. Found by search, so that the tolerance is what decides.
#[test]
fn told_stops_count_the_chain_not_the_product() {
    let mut r = uniform(0x2545_f491_4f6c_dd1du64);
    let mut found = 0;
    for _ in 0..20_000 {
        let (t0, d) = (r() * 0.3, 0.02 + r() * 0.5);
        let mut chain = t0;
        for j in 1..200u32 {
            chain += d;
            let product = t0 + f64::from(j) * d;
            if chain == product {
                continue;
            }
            let length = (chain + product) / 2.0;
            if length == chain || length == product {
                continue;
            }
            found += 1;
            // the chain's crossings at or before the length, one axis moving
            let (mut c, mut n) = (t0, 0u32);
            while c <= length && n < 1_000 {
                n += 1;
                c += d;
            }
            for keys in [j, j + 1] {
                let told = stop_is_told(
                    [t0, f64::MAX, f64::MAX],
                    [d, f64::MAX, f64::MAX],
                    length,
                    [keys, 0, 0],
                );
                assert!(
                    !told || keys == n,
                    "told {keys} crossings, the chain has {n}"
                );
            }
            break;
        }
    }
    assert!(found > 100, "only {found} disagreements found");
}
