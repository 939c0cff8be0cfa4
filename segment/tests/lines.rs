//! Collinear lines separation and re-segmentation on simulated scans with known walls,
//! doorways and gaps, and the separation step against a naive DBSCAN written from the
//! definition.

mod scan_sim;

use octoquant_segment::{
    segment_scan, BorderPolicy, Line, LineParams, Resegment, Segmentation, NOISE,
};
use proptest::prelude::*;
use scan_sim::{beams, scan, spacing, Scan, Wall};

fn segment(points: &[[f64; 2]], params: &LineParams) -> Segmentation {
    let mut seg = Segmentation::new();
    segment_scan(points, params, &mut seg).unwrap();
    seg
}

fn no_split() -> LineParams {
    LineParams {
        split_eps: f64::INFINITY,
        ..LineParams::default()
    }
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// The ends of what the sensor saw of each wall: the extreme noiseless hits along it, with
/// the allowed error at each (two beam spacings there, for end points lost to the corner
/// neighbourhoods or moved by noise, plus `extra`).
fn seen_ends(walls: &[Wall], s: &Scan, step: f64, extra: f64) -> Vec<[([f64; 2], f64); 2]> {
    let mut out = Vec::new();
    for (k, w) in walls.iter().enumerate() {
        let len = dist(w[0], w[1]);
        let u = [(w[1][0] - w[0][0]) / len, (w[1][1] - w[0][1]) / len];
        let hits: Vec<[f64; 2]> = (0..s.clean.len())
            .filter(|&i| s.wall[i] == k)
            .map(|i| s.clean[i])
            .collect();
        if hits.is_empty() {
            continue;
        }
        let t = |p: &[f64; 2]| (p[0] - w[0][0]) * u[0] + (p[1] - w[0][1]) * u[1];
        let lo = *hits.iter().min_by(|a, b| t(a).total_cmp(&t(b))).unwrap();
        let hi = *hits.iter().max_by(|a, b| t(a).total_cmp(&t(b))).unwrap();
        out.push([
            (lo, 2.0 * spacing(lo, u, step) + extra),
            (hi, 2.0 * spacing(hi, u, step) + extra),
        ]);
    }
    out
}

/// Whether `l`'s end points match `ends` (in either order) within their tolerances.
fn matches(l: &Line, ends: &[([f64; 2], f64); 2]) -> bool {
    let ok = |p: [f64; 2], (q, tol): ([f64; 2], f64)| dist(p, q) <= tol;
    (ok(l.start, ends[0]) && ok(l.end, ends[1])) || (ok(l.start, ends[1]) && ok(l.end, ends[0]))
}

/// Every seen wall piece matched by exactly one line, and every line by one piece.
fn assert_lines_are_walls(lines: &[Line], ends: &[[([f64; 2], f64); 2]], ctx: &str) {
    assert_eq!(lines.len(), ends.len(), "{ctx}: lines {lines:#?}");
    for e in ends {
        let n = lines.iter().filter(|l| matches(l, e)).count();
        assert_eq!(n, 1, "{ctx}: wall piece {e:?} matched by {n} of {lines:#?}");
    }
}

/// A wall 2 m in front of the sensor, 8 m long, broken by a 1 m doorway.
const DOORWAY: [Wall; 2] = [[[-4.0, 2.0], [0.5, 2.0]], [[1.5, 2.0], [4.0, 2.0]]];

#[test]
fn doorway_gives_two_lines_noiseless() {
    let step = 1f64.to_radians();
    let s = scan(&DOORWAY, &beams(0.0, 180.0, 181), 30.0, 0.0, 1);
    let seg = segment(&s.points, &LineParams::default());
    let ends = seen_ends(&DOORWAY, &s, step, 0.0);
    assert_lines_are_walls(seg.lines(), &ends, "noiseless doorway");
    // Noiseless: the ends are exactly the extreme hits, and the door edges are within one
    // beam spacing (3.7 cm at 2.06 m) of the true jambs.
    for l in seg.lines() {
        assert!(
            (l.distance - 2.0).abs() < 1e-9 && l.max_residual < 1e-9,
            "{l:?}"
        );
        let xs = [l.start[0].min(l.end[0]), l.start[0].max(l.end[0])];
        assert!(
            (xs[1] - 0.5).abs() < 0.04 || (xs[0] - 1.5).abs() < 0.04,
            "door edge of {l:?}"
        );
    }
    for l in seg.lines() {
        let exact = ends.iter().any(|e| {
            let (a, b) = (e[0].0, e[1].0);
            (dist(l.start, a) < 1e-9 && dist(l.end, b) < 1e-9)
                || (dist(l.start, b) < 1e-9 && dist(l.end, a) < 1e-9)
        });
        assert!(exact, "{l:?} against {ends:?}");
    }
    // Without the separation step the doorway does not split the wall.
    let one = segment(&s.points, &no_split());
    assert_eq!(one.lines().len(), 1, "{:?}", one.lines());
    // The doorway is wider than split_eps; a split_eps wider than the doorway keeps one line.
    let wide = LineParams {
        split_eps: 1.5,
        ..LineParams::default()
    };
    assert_eq!(segment(&s.points, &wide).lines().len(), 1);
}

/// Lines of at least this many points are the main lines of a wall piece; shorter ones may
/// come from the angle step, whose three-point local angles are noisy where beams are dense.
const MAJOR: usize = 10;

/// With noise: the main lines are the wall pieces, one each, and every shorter line lies on a
/// piece too (duplicates of a few points from noisy local angles exist with or without the
/// separation step).
fn assert_major_lines_are_walls(
    lines: &[Line],
    walls: &[Wall],
    ends: &[[([f64; 2], f64); 2]],
    tol: f64,
    ctx: &str,
) {
    let major: Vec<Line> = lines
        .iter()
        .copied()
        .filter(|l| l.n_points >= MAJOR)
        .collect();
    assert_lines_are_walls(&major, ends, ctx);
    for l in lines {
        let on = walls.iter().any(|w| {
            [l.start, l.end]
                .iter()
                .all(|&p| point_segment_distance(p, w) < tol)
        });
        assert!(on, "{ctx}: line {l:?} on no wall");
    }
}

fn point_segment_distance(p: [f64; 2], w: &Wall) -> f64 {
    let e = [w[1][0] - w[0][0], w[1][1] - w[0][1]];
    let len2 = e[0] * e[0] + e[1] * e[1];
    let s = (((p[0] - w[0][0]) * e[0] + (p[1] - w[0][1]) * e[1]) / len2).clamp(0.0, 1.0);
    dist(p, [w[0][0] + s * e[0], w[0][1] + s * e[1]])
}

#[test]
fn doorway_gives_two_lines_with_noise() {
    let step = 1f64.to_radians();
    for seed in 0..40 {
        for sigma in [0.002, 0.005, 0.01] {
            let s = scan(&DOORWAY, &beams(0.0, 180.0, 181), 30.0, sigma, seed);
            let seg = segment(&s.points, &LineParams::default());
            let ends = seen_ends(&DOORWAY, &s, step, 3.0 * sigma);
            let ctx = format!("seed {seed} sigma {sigma}");
            assert_major_lines_are_walls(seg.lines(), &DOORWAY, &ends, 0.05, &ctx);
            for l in seg.lines().iter().filter(|l| l.n_points >= MAJOR) {
                assert!((l.distance - 2.0).abs() < sigma, "{ctx}: {l:?}");
            }
            let whole = segment(&s.points, &no_split());
            let n = whole.lines().iter().filter(|l| l.n_points >= MAJOR).count();
            assert_eq!(n, 1, "{ctx}: without separation {:?}", whole.lines());
        }
    }
}

#[test]
fn narrow_gap_keeps_one_line() {
    // A 20 cm gap (a pillar seen edge-on, a missing panel) is below split_eps; the hits are
    // at most 9 cm apart elsewhere on this wall.
    let walls: [Wall; 2] = [[[-1.5, 2.0], [0.5, 2.0]], [[0.7, 2.0], [2.5, 2.0]]];
    let step = 1f64.to_radians();
    for seed in 0..20 {
        let s = scan(&walls, &beams(0.0, 180.0, 181), 30.0, 0.002, seed);
        let ctx = format!("seed {seed}");
        let seg = segment(&s.points, &LineParams::default());
        let n = seg.lines().iter().filter(|l| l.n_points >= MAJOR).count();
        assert_eq!(n, 1, "{ctx}: {:?}", seg.lines());
        // A split_eps below the gap (and above the beam spacing) splits it.
        let strict = LineParams {
            split_eps: 0.15,
            ..LineParams::default()
        };
        let seg = segment(&s.points, &strict);
        let ends = seen_ends(&walls, &s, step, 0.006);
        assert_major_lines_are_walls(seg.lines(), &walls, &ends, 0.02, &ctx);
    }
}

/// A room 8 m by 5 m around the sensor with two doorways and an open gap.
fn room() -> Vec<Wall> {
    vec![
        // North wall y = 3 with a 1 m doorway at x in [1, 2].
        [[-3.0, 3.0], [1.0, 3.0]],
        [[2.0, 3.0], [5.0, 3.0]],
        // West wall x = -3 with a 0.9 m doorway at y in [0, 0.9].
        [[-3.0, -2.0], [-3.0, 0.0]],
        [[-3.0, 0.9], [-3.0, 3.0]],
        // East wall x = 5, whole.
        [[5.0, -2.0], [5.0, 3.0]],
        // South wall y = -2 with a 2 m opening at x in [0, 2].
        [[-3.0, -2.0], [0.0, -2.0]],
        [[2.0, -2.0], [5.0, -2.0]],
    ]
}

#[test]
fn room_with_doorways_gives_one_line_per_wall_piece() {
    let walls = room();
    let step = 1f64.to_radians();
    for seed in 0..30 {
        let s = scan(&walls, &beams(-179.0, 180.0, 360), 30.0, 0.01, seed);
        let seg = segment(&s.points, &LineParams::default());
        let ends = seen_ends(&walls, &s, step, 0.03);
        assert_eq!(ends.len(), 7);
        assert_lines_are_walls(seg.lines(), &ends, &format!("seed {seed}"));
        // Without the separation, the doorways no longer split: one line per wall.
        let whole = segment(&s.points, &no_split());
        assert_eq!(whole.lines().len(), 4, "seed {seed}: {:?}", whole.lines());
    }
}

/// Naive DBSCAN over 1D values written from the definition (Ester et al. 1996), O(n^2):
/// members of each cluster under `border`, clusters numbered by their lowest-index core point.
fn naive_dbscan(t: &[f64], eps: f64, min_points: usize, border: BorderPolicy) -> Vec<Vec<usize>> {
    let n = t.len();
    let near = |i: usize, j: usize| (t[i] - t[j]).abs() <= eps;
    let core: Vec<bool> = (0..n)
        .map(|i| (0..n).filter(|&j| near(i, j)).count() >= min_points)
        .collect();
    let mut cluster = vec![usize::MAX; n];
    let mut count = 0;
    for i in 0..n {
        if !core[i] || cluster[i] != usize::MAX {
            continue;
        }
        let mut stack = vec![i];
        cluster[i] = count;
        while let Some(q) = stack.pop() {
            for j in 0..n {
                if core[j] && cluster[j] == usize::MAX && near(q, j) {
                    cluster[j] = count;
                    stack.push(j);
                }
            }
        }
        count += 1;
    }
    let mut members = vec![Vec::new(); count];
    for i in 0..n {
        if core[i] {
            members[cluster[i]].push(i);
            continue;
        }
        let mut reach: Vec<usize> = (0..n)
            .filter(|&j| core[j] && near(i, j))
            .map(|j| cluster[j])
            .collect();
        reach.sort_unstable();
        reach.dedup();
        match border {
            BorderPolicy::First => {
                if let Some(&c) = reach.first() {
                    members[c].push(i);
                }
            }
            BorderPolicy::All => {
                for c in reach {
                    members[c].push(i);
                }
            }
            BorderPolicy::Noise => {}
        }
    }
    members
}

fn border_policy() -> impl Strategy<Value = BorderPolicy> {
    prop_oneof![
        Just(BorderPolicy::First),
        Just(BorderPolicy::All),
        Just(BorderPolicy::Noise)
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 500, ..ProptestConfig::default() })]

    /// Exactly collinear points (one angle cluster, one distance cluster) at random positions
    /// along a random line: the lines are the clusters of the naive DBSCAN of those positions
    /// that have at least `min_line_points` members, point for point, with the epsilon
    /// computed from the definition (the larger of `split_eps` and the spacing factor times the
    /// lower median gap).
    #[test]
    fn separation_matches_naive_dbscan(
        gaps in prop::collection::vec(
            prop_oneof![0.001f64..0.2, 0.2f64..1.0, 1.0f64..5.0], 2..60),
        normal in -3.2f64..3.2,
        offset in 0.5f64..20.0,
        start in -10.0f64..10.0,
        split_eps in 0.05f64..1.5,
        factor in prop_oneof![Just(0.0), 0.0f64..6.0],
        split_min_points in 1usize..6,
        min_line_points in 2usize..6,
        border in border_policy(),
    ) {
        let mut t = vec![start];
        for g in &gaps {
            t.push(t[t.len() - 1] + g);
        }
        // The epsilon as documented: split_eps or the factor times the lower median gap.
        let mut sorted_gaps = gaps.clone();
        sorted_gaps.sort_by(f64::total_cmp);
        let eps = split_eps.max(factor * sorted_gaps[(sorted_gaps.len() - 1) / 2]);
        // No pair at the boundary of a neighbourhood up to rounding: the code measures
        // positions on the fitted line, the oracle on the generated ones.
        for i in 0..t.len() {
            for j in i + 1..t.len() {
                prop_assume!(((t[j] - t[i]) - eps).abs() > 1e-6);
            }
        }
        let (s, c) = normal.sin_cos();
        // Points in order of increasing t, which is beam order seen from the origin.
        let points: Vec<[f64; 2]> =
            t.iter().map(|&ti| [offset * c - ti * s, offset * s + ti * c]).collect();
        let params = LineParams {
            min_points_theta: 3,
            min_points_dist: 3,
            split_eps,
            split_spacing_factor: factor,
            split_min_points,
            min_line_points,
            border,
            ..LineParams::default()
        };
        let seg = segment(&points, &params);
        let mut want: Vec<Vec<usize>> = naive_dbscan(&t, eps, split_min_points, border)
            .into_iter()
            .filter(|m| m.len() >= min_line_points)
            .collect();
        let mut got: Vec<Vec<usize>> = (0..seg.lines().len())
            .map(|k| {
                let mut m: Vec<usize> = seg.line_members(k).iter().map(|&i| i as usize).collect();
                m.sort_unstable();
                m
            })
            .collect();
        // Lines come in order along the fitted direction (-sin, cos) of the normal pointing
        // away from the origin, which is the generated direction: same order as the oracle's.
        prop_assert_eq!(&got, &want, "t = {:?}", t);
        got.sort();
        want.sort();
        prop_assert_eq!(got, want);
        // Labels: the first line holding the point, NOISE for none.
        for i in 0..t.len() {
            let first = (0..seg.lines().len()).find(|&k| seg.line_members(k).contains(&(i as u32)));
            prop_assert_eq!(seg.labels()[i], first.map_or(NOISE, |k| k as u32), "point {}", i);
        }
        for (k, l) in seg.lines().iter().enumerate() {
            prop_assert_eq!(l.n_points, seg.line_members(k).len());
            prop_assert!((l.distance - offset).abs() < 1e-6, "{:?}", l);
        }
    }
}

/// Two parallel walls 5 cm apart side by side (a cabinet front before a wall): with 3 mm
/// noise the gap between their distances, less the spread, is below the default `eps_dist`.
const STEP_WALLS: [Wall; 2] = [[[-3.0, 2.0], [0.0, 2.0]], [[0.0, 1.95], [3.0, 1.95]]];

#[test]
fn resegment_separates_close_parallel_walls() {
    let step = 1f64.to_radians();
    let reseg = LineParams {
        resegment: Some(Resegment::default()),
        ..LineParams::default()
    };
    for seed in 0..40 {
        let s = scan(&STEP_WALLS, &beams(0.0, 180.0, 181), 30.0, 0.003, seed);
        let ctx = format!("seed {seed}");
        // The defaults merge them: one line, its TLS fit tilted between the two, with an rms
        // residual above the default bound of 1 cm.
        let merged = segment(&s.points, &LineParams::default());
        assert_eq!(merged.lines().len(), 1, "{ctx}: {:?}", merged.lines());
        assert!(
            merged.lines()[0].rms_residual > 0.012,
            "{ctx}: {:?}",
            merged.lines()
        );
        let seg = segment(&s.points, &reseg);
        let ends = seen_ends(&STEP_WALLS, &s, step, 0.01);
        assert_lines_are_walls(seg.lines(), &ends, &ctx);
        let mut d: Vec<f64> = seg.lines().iter().map(|l| l.distance).collect();
        d.sort_by(f64::total_cmp);
        assert!(
            (d[0] - 1.95).abs() < 0.005 && (d[1] - 2.0).abs() < 0.005,
            "{ctx}: {d:?}"
        );
        for l in seg.lines() {
            assert!(l.rms_residual < 0.006, "{ctx}: {l:?}");
        }
    }
    // A single clean wall is left alone: its fit is within the bound.
    let s = scan(&DOORWAY[..1], &beams(0.0, 180.0, 181), 30.0, 0.003, 7);
    let a = segment(&s.points, &reseg);
    let b = segment(&s.points, &LineParams::default());
    assert_eq!(a.lines(), b.lines());
    assert_eq!(a.labels(), b.labels());
}

#[test]
fn invalid_new_parameters_are_named() {
    let pts = [[0.0, 1.0], [1.0, 1.0], [2.0, 1.0]];
    let mut seg = Segmentation::new();
    let bad = [
        (
            LineParams {
                split_eps: f64::NAN,
                ..LineParams::default()
            },
            "split_eps",
        ),
        (
            LineParams {
                split_eps: -0.1,
                ..LineParams::default()
            },
            "split_eps",
        ),
        (
            LineParams {
                split_min_points: 0,
                ..LineParams::default()
            },
            "split_min_points",
        ),
        (
            LineParams {
                resegment: Some(Resegment {
                    max_rms: f64::NAN,
                    ..Resegment::default()
                }),
                ..LineParams::default()
            },
            "resegment.max_rms",
        ),
        (
            LineParams {
                resegment: Some(Resegment {
                    eps: -1.0,
                    ..Resegment::default()
                }),
                ..LineParams::default()
            },
            "resegment.eps",
        ),
        (
            LineParams {
                resegment: Some(Resegment {
                    min_points: 0,
                    ..Resegment::default()
                }),
                ..LineParams::default()
            },
            "resegment.min_points",
        ),
    ];
    for (p, name) in bad {
        let e = segment_scan(&pts, &p, &mut seg).unwrap_err();
        assert!(e.to_string().contains(name), "{name}: {e}");
        assert!(p.validate().is_err());
    }
}
