use super::*;
use crate::dda::{key_of, setup_with_keys};
use nalgebra::{Rotation3, Vector3};
use proptest::prelude::*;

/// The paths of [`set_up`]: the plain one, telling stops or not, the one it chooses (AVX-512
/// or AVX2 where the CPU has them) and the AVX2 build where the CPU has AVX2; each with
/// whether it told the stops ([`first_watch`]).
fn both_paths(p: &Pending, s: &Shared) -> Vec<(Setups, bool)> {
    let (mut plain, mut telling) = (Setups::default(), Setups::default());
    set_up_lanes::<false>(p, s, &mut plain);
    set_up_lanes::<true>(p, s, &mut telling);
    let mut chosen = Setups::default();
    set_up(p, s, &mut chosen);
    let chosen_tells = cfg!(target_arch = "x86_64") && crate::cpu::has_avx512() && s.tell_stops;
    let mut paths = vec![(plain, false), (telling, true), (chosen, chosen_tells)];
    #[cfg(target_arch = "x86_64")]
    if crate::cpu::has_avx2() {
        let mut avx2 = Setups::default();
        // SAFETY: the CPU has AVX2, checked just above.
        #[allow(unsafe_code)]
        unsafe {
            set_up_avx2(p, s, &mut avx2)
        };
        paths.push((avx2, false));
    }
    paths
}

/// Coordinates on a grid of quarter voxels (ends on corners, faces and centres, and axes
/// parallel to the ray), or anywhere.
fn coordinate(res: f64) -> impl Strategy<Value = f32> {
    prop_oneof![
        (-60i32..60).prop_map(move |q| (q as f64 * res / 4.0) as f32),
        -4.0f32..4.0,
        Just(0.0f32),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    /// Every column's set-up is [`setup_with_keys`]'s, bit for bit (steps, `tMax`, `tDelta`,
    /// length, budget, conditioning), on both paths, whatever the other columns hold.
    #[test]
    fn columns_set_up_rays_as_one_by_one(
        res in prop::sample::select(vec![0.02, 0.05, 0.1, 1.0]),
        origin in prop::array::uniform3(-2.0f32..2.0),
        ends in prop::collection::vec(prop::array::uniform3(coordinate(0.05)), 1..=PENDING),
    ) {
        let conv = KeyConverter::new(res).unwrap();
        let o = Point3::from(origin);
        let Some(okey) = key_of(&conv, &o) else { return Ok(()) };
        let ocoded = (okey, okey.morton());
        let shared = Shared::new(&conv, &o, okey, None);
        let mut p = Pending::default();
        let mut wanted = Vec::new();
        for e in ends {
            let e = Point3::from(e);
            let Some(ek) = key_of(&conv, &e) else { continue };
            if ek == okey {
                continue;
            }
            p.push(&e, (ek, ek.morton()));
            wanted.push(setup_with_keys(&conv, &o, Some(ocoded), &e, Some((ek, ek.morton()))).unwrap());
        }
        for (out, tells) in both_paths(&p, &shared) {
            for (i, w) in wanted.iter().enumerate() {
                let got = p.ray(&out, i, ocoded);
                prop_assert_eq!(got.key_end, w.key_end);
                prop_assert_eq!(got.code_end, w.code_end);
                prop_assert_eq!(got.step, w.step);
                prop_assert_eq!(got.t_max.map(f64::to_bits), w.t_max.map(f64::to_bits));
                prop_assert_eq!(got.t_delta.map(f64::to_bits), w.t_delta.map(f64::to_bits));
                prop_assert_eq!(got.length.to_bits(), w.length.to_bits());
                prop_assert_eq!(got.budget, w.budget);
                prop_assert_eq!(got.well_conditioned, w.well_conditioned);
                // no plan: nothing skips
                prop_assert_eq!(out.head(i), None);
                // the first step to watch: told, or four before the Manhattan distance
                let keys = [0, 1, 2].map(|a| u32::from(okey[a].abs_diff(w.key_end[a])));
                let manhattan: u64 = keys.iter().map(|&k| u64::from(k)).sum();
                let watch = if tells {
                    crate::dda::first_watch(w.t_max, w.t_delta, w.length, keys)
                } else {
                    manhattan.saturating_sub(4)
                };
                prop_assert_eq!(out.watches()[i], watch);
            }
        }
    }

    /// With a skip plan's values, a column skips exactly when the one-ray checks say so:
    /// a head cap, its time `min(cap, length − margin)` at least the shortest head, the
    /// direction along the pixel ([`fits_dir`]) and a well-conditioned ray; as a sample it
    /// gives its length exactly when it is well-conditioned and along its pixel.
    #[test]
    fn columns_decide_the_heads_as_one_by_one(
        origin in prop::array::uniform3(-1.0f32..1.0),
        angles in prop::array::uniform3(-3.2f64..3.2),
        rays in prop::collection::vec(
            (-0.6f32..0.6, -0.45f32..0.45, 0.3f32..6.0, 0.0f64..7.0, any::<bool>(), -1e-3f32..1e-3),
            1..=PENDING,
        ),
    ) {
        let conv = KeyConverter::new(0.05).unwrap();
        let o = Point3::from(origin);
        let okey = key_of(&conv, &o).unwrap();
        let ocoded = (okey, okey.morton());
        let rot = Rotation3::from_euler_angles(angles[0], angles[1], angles[2]);
        let axes: [[f32; 3]; 3] = [0, 1, 2].map(|c| [0, 1, 2].map(|r| rot.matrix()[(r, c)] as f32));
        let (end_margin, min_head) = (0.101, 0.15);
        let shared = Shared {
            axes,
            end_margin,
            min_head,
            ..Shared::new(&conv, &o, okey, None)
        };
        let mut p = Pending::default();
        let mut wanted = Vec::new();
        for (a, b, depth, cap, skip, off) in rays {
            // the pixel's direction, the point a little off it (or not)
            let dir = rot * Vector3::new(a as f64, b as f64, 1.0);
            let e = o + (dir * depth as f64).cast::<f32>() + Vector3::new(off, 0.0, 0.0);
            let Some(ek) = key_of(&conv, &e) else { continue };
            if ek == okey {
                continue;
            }
            p.push(&e, (ek, ek.morton()));
            let cap = if skip { cap } else { f64::NEG_INFINITY };
            p.may_skip(cap, a, b);
            let r = setup_with_keys(&conv, &o, Some(ocoded), &e, Some((ek, ek.morton()))).unwrap();
            let diff = [e.x - o.x, e.y - o.y, e.z - o.z];
            let t = cap.min(r.length - end_margin);
            let fits = fits_dir(&axes, a, b, diff);
            let skips = skip && t >= min_head && fits && r.well_conditioned;
            // what the ray gives as a sample: its length when it is surely walked and points
            // along its pixel
            let sample = if r.well_conditioned && fits { r.length } else { 0.0 };
            wanted.push((skips.then_some(t), sample));
        }
        for (out, _) in both_paths(&p, &shared) {
            for (i, (head, sample)) in wanted.iter().enumerate() {
                prop_assert_eq!(out.head(i).map(f64::to_bits), head.map(f64::to_bits));
                prop_assert_eq!(out.walked_length(i).to_bits(), sample.to_bits());
            }
        }
    }
}
