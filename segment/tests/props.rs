//! Property tests: DBSCAN1D against a naive O(N^2) DBSCAN, and line segmentation of synthetic
//! rooms against their known walls.

use octoquant_segment::{
    dbscan1d, segment_scan, BorderPolicy, Clustering, Dbscan1dParams, LineParams, Segmentation,
    NOISE,
};
use proptest::prelude::*;
use std::f64::consts::PI;

/// The distance DBSCAN1D documents: `b - a` for `a <= b`, or `min(b - a, (a + P) - b)` on a
/// circle of period `P`.
fn dist(a: f64, b: f64, period: Option<f64>) -> f64 {
    let (a, b) = if a <= b { (a, b) } else { (b, a) };
    match period {
        None => b - a,
        Some(p) => (b - a).min((a + p) - b),
    }
}

/// Result of the textbook algorithm.
#[derive(Debug)]
struct Naive {
    core: Vec<bool>,
    labels: Vec<u32>,
    second: Vec<Option<u32>>,
    n_clusters: u32,
}

/// DBSCAN as in Ester et al. (1996): visit points in index order, expand each new cluster from
/// its first core point with a queue over full O(N) neighbourhood scans; a border point keeps
/// the first cluster that reaches it. Then the border policy is applied from the definitions.
fn naive(
    x: &[f64],
    eps: f64,
    min_points: usize,
    border: BorderPolicy,
    period: Option<f64>,
) -> Naive {
    const UNCLASSIFIED: u32 = u32::MAX - 1;
    let n = x.len();
    let neighbours = |i: usize| -> Vec<usize> {
        (0..n)
            .filter(|&j| dist(x[i], x[j], period) <= eps)
            .collect()
    };
    let core: Vec<bool> = (0..n).map(|i| neighbours(i).len() >= min_points).collect();
    let mut labels = vec![UNCLASSIFIED; n];
    let mut cid = 0u32;
    for i in 0..n {
        if labels[i] != UNCLASSIFIED {
            continue;
        }
        if !core[i] {
            labels[i] = NOISE;
            continue;
        }
        labels[i] = cid;
        let mut queue = neighbours(i);
        while let Some(q) = queue.pop() {
            if labels[q] == UNCLASSIFIED || labels[q] == NOISE {
                labels[q] = cid;
                if core[q] {
                    queue.extend(neighbours(q));
                }
            }
        }
        cid += 1;
    }
    let mut second = vec![None; n];
    for i in 0..n {
        if core[i] {
            continue;
        }
        match border {
            BorderPolicy::First => {}
            BorderPolicy::Noise => labels[i] = NOISE,
            BorderPolicy::All => {
                let mut reach: Vec<u32> = neighbours(i)
                    .into_iter()
                    .filter(|&j| core[j])
                    .map(|j| labels[j])
                    .collect();
                reach.sort_unstable();
                reach.dedup();
                assert!(
                    reach.len() <= 2,
                    "in 1D a point is reached by at most two clusters"
                );
                if let Some(&first) = reach.first() {
                    assert_eq!(labels[i], first);
                }
                second[i] = reach.get(1).copied();
            }
        }
    }
    Naive {
        core,
        labels,
        second,
        n_clusters: cid,
    }
}

fn check_against_naive(
    x: &[f64],
    eps: f64,
    min_points: usize,
    border: BorderPolicy,
    period: Option<f64>,
) {
    let mut p = Dbscan1dParams::new(eps, min_points)
        .unwrap()
        .with_border(border);
    if let Some(per) = period {
        p = p.with_period(per).unwrap();
    }
    let mut out = Clustering::new();
    dbscan1d(x, &p, &mut out).unwrap();
    let want = naive(x, eps, min_points, border, period);
    let ctx = format!("x={x:?} eps={eps} min={min_points} {border:?} period={period:?}");
    assert_eq!(out.core(), &want.core[..], "core points, {ctx}");
    assert_eq!(out.labels(), &want.labels[..], "labels, {ctx}");
    assert_eq!(
        out.n_clusters() as u32,
        want.n_clusters,
        "cluster count, {ctx}"
    );
    let noise: Vec<usize> = (0..x.len()).filter(|&i| want.labels[i] == NOISE).collect();
    assert_eq!(out.noise_count(), noise.len(), "noise, {ctx}");
    for i in 0..x.len() {
        assert_eq!(
            out.second_label(i),
            want.second[i],
            "second label of {i}, {ctx}"
        );
        let count = (0..x.len())
            .filter(|&j| dist(x[i], x[j], period) <= eps)
            .count();
        assert_eq!(out.neighbour_count(i), count, "neighbourhood of {i}, {ctx}");
    }
    let mut members = Vec::new();
    for c in 0..want.n_clusters {
        out.members(c, &mut members);
        members.sort_unstable();
        let expect: Vec<usize> = (0..x.len())
            .filter(|&i| want.labels[i] == c || want.second[i] == Some(c))
            .collect();
        assert_eq!(members, expect, "members of cluster {c}, {ctx}");
    }
}

fn policy() -> impl Strategy<Value = BorderPolicy> {
    prop_oneof![
        Just(BorderPolicy::First),
        Just(BorderPolicy::All),
        Just(BorderPolicy::Noise)
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    /// Values on a quarter grid: exact arithmetic, many ties and duplicates, eps on the grid too.
    #[test]
    fn grid_data_matches_naive(
        mut ticks in prop::collection::vec(0u32..48, 0..60),
        eps_ticks in 0u32..30,
        min_points in 1usize..7,
        border in policy(),
        circular in any::<bool>(),
    ) {
        ticks.sort_unstable();
        let x: Vec<f64> = ticks.iter().map(|&t| t as f64 * 0.25).collect();
        let period = circular.then_some(12.0);
        check_against_naive(&x, eps_ticks as f64 * 0.25, min_points, border, period);
    }

    /// Real-valued data, epsilon from tiny to huge.
    #[test]
    fn real_data_matches_naive(
        mut x in prop::collection::vec(0.0f64..100.0, 0..120),
        log_eps in -7.0f64..4.0,
        min_points in 1usize..8,
        border in policy(),
        circular in any::<bool>(),
    ) {
        x.sort_unstable_by(f64::total_cmp);
        let period = circular.then_some(100.0);
        check_against_naive(&x, 10f64.powf(log_eps), min_points, border, period);
    }

    /// Clustered data (dense groups, gaps, repeated values) on a circle of random period.
    #[test]
    fn clustered_circular_matches_naive(
        groups in prop::collection::vec((0.0f64..1.0, 1usize..12, 0.0f64..0.02), 1..8),
        period in 0.5f64..10.0,
        eps_frac in 0.0f64..0.6,
        min_points in 1usize..6,
        border in policy(),
    ) {
        let mut x = Vec::new();
        for (centre, count, spread) in groups {
            for k in 0..count {
                let v = (centre + spread * k as f64) * period;
                x.push(v.rem_euclid(period).min(period * (1.0 - f64::EPSILON)));
            }
        }
        x.sort_unstable_by(f64::total_cmp);
        check_against_naive(&x, eps_frac * period, min_points, border, Some(period));
    }
}

#[test]
fn paper_example_circular() {
    // Meglicki's example: eps = pi/2 on [0, pi/4, pi, 7pi/4] (period 2pi).
    let x = [0.0, PI / 4.0, PI, 7.0 * PI / 4.0];
    for min_points in 1..=4 {
        for border in [BorderPolicy::First, BorderPolicy::All, BorderPolicy::Noise] {
            check_against_naive(&x, PI / 2.0, min_points, border, Some(2.0 * PI));
        }
    }
    let p = Dbscan1dParams::new(PI / 2.0, 2)
        .unwrap()
        .with_period(2.0 * PI)
        .unwrap();
    let mut out = Clustering::new();
    dbscan1d(&x, &p, &mut out).unwrap();
    assert_eq!(out.labels(), &[0, 0, NOISE, 0]);
    assert_eq!(out.n_clusters(), 1);
}

#[test]
fn reused_buffers_give_the_same_answer() {
    let big: Vec<f64> = (0..500)
        .map(|i| (i / 7) as f64 + 0.01 * (i % 7) as f64)
        .collect();
    let small = [0.0, 0.1, 5.0];
    let p = Dbscan1dParams::new(0.05, 3).unwrap();
    let mut reused = Clustering::new();
    dbscan1d(&big, &p, &mut reused).unwrap();
    dbscan1d(&small, &p, &mut reused).unwrap();
    let mut fresh = Clustering::new();
    dbscan1d(&small, &p, &mut fresh).unwrap();
    assert_eq!(reused.labels(), fresh.labels());
    assert_eq!(reused.core(), fresh.core());
    assert_eq!(reused.n_clusters(), 0);
}

/// A tiny deterministic generator for range noise (splitmix64).
struct Rng(u64);
impl Rng {
    fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Angle difference wrapped to [-pi, pi].
fn angle_diff(a: f64, b: f64) -> f64 {
    (a - b + PI).rem_euclid(2.0 * PI) - PI
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// A rectangular room scanned at 1 degree over 360 degrees with +-5 mm range noise: each wall
    /// comes back as a line within 1 degree and 2 cm, and every line found lies on one of the walls.
    #[test]
    fn synthetic_rooms_recover_walls(
        w in 3.0f64..9.0,
        h in 3.0f64..9.0,
        fx in 0.15f64..0.85,
        fy in 0.15f64..0.85,
        heading in -PI..PI,
        seed in any::<u64>(),
    ) {
        let (sx, sy) = (fx * w, fy * h);
        // Walls as world lines n . p = d with unit normal angle.
        let walls = [(0.0, w), (PI / 2.0, h), (PI, 0.0), (-PI / 2.0, 0.0)];
        let mut rng = Rng(seed);
        let mut pts = Vec::new();
        for i in 0..360 {
            let a = (i as f64).to_radians();
            let (c, s) = ((a + heading).cos(), (a + heading).sin());
            let mut r = f64::INFINITY;
            for &(phi, d) in &walls {
                let (nx, ny): (f64, f64) = (f64::cos(phi), f64::sin(phi));
                let denom = nx * c + ny * s;
                if denom > 1e-12 {
                    r = r.min((d - nx * sx - ny * sy) / denom);
                }
            }
            let r = r + (rng.uniform() - 0.5) * 0.01;
            pts.push([r * a.cos(), r * a.sin()]);
        }
        // The same walls in the sensor frame, normalised to distance >= 0.
        let expected: Vec<(f64, f64)> = walls
            .iter()
            .map(|&(phi, d)| {
                let ds = d - (phi.cos() * sx + phi.sin() * sy);
                let ps = phi - heading;
                if ds < 0.0 { (ps + PI, -ds) } else { (ps, ds) }
            })
            .collect();
        let mut seg = Segmentation::new();
        segment_scan(&pts, &LineParams::default(), &mut seg).unwrap();
        let close = |l: &octoquant_segment::Line, &(phi, d): &(f64, f64)| {
            angle_diff(l.normal_angle, phi).abs() < 1f64.to_radians() && (l.distance - d).abs() < 0.02
        };
        for wall in &expected {
            prop_assert!(
                seg.lines().iter().any(|l| close(l, wall)),
                "wall {:?} not found among {:?}", wall, seg.lines()
            );
        }
        for l in seg.lines() {
            // Short pieces may be fitted less precisely, but every line must lie on one wall.
            let on_wall = |&(phi, d): &(f64, f64)| {
                [l.start, l.end]
                    .iter()
                    .all(|p| (p[0] * phi.cos() + p[1] * phi.sin() - d).abs() < 0.03)
            };
            prop_assert!(expected.iter().any(on_wall), "spurious line {:?}", l);
            prop_assert!(l.rms_residual < 0.01, "residual {:?}", l);
        }
    }
}
