//! The comparison the paper calls for (Nguyen et al. 2007), on simulated scans of rooms with
//! known walls: the angular segmentation (`segment_scan`) against split-and-merge, incremental
//! (line tracking), RANSAC and the Hough transform, by true positives, false positives, angular and distance error, and time per scan.
//!
//! Scenes: rectangular rooms 4 to 10 m a side at a random heading, each wall with a doorway
//! (0.8 to 1.2 m) at random with probability one half, and up to three boxes (0.3 to 1.2 m a
//! side, at random angles) as furniture; 360 beams at 1° from a random point inside, Gaussian
//! range noise of standard deviation 0, 1 and 2 cm (SICK LMS scanners are specified at about
//! 1 cm). The ground truth is every visible wall piece: a maximal run of consecutive beams on
//! one wall segment; pieces of at least `MIN_TRUE` hits are scored.
//!
//! A line matches a piece when its normal is within 3° of the piece's, its distance from the
//! sensor within 5 cm, and at least half its length projects inside the seen part of the
//! piece. The first line matching a scored piece is a true positive; a line matching only
//! pieces too short to score is ignored; every other line (a duplicate of a found piece, or a
//! line on nothing, such as one spanning a doorway) is a false positive. The angular and distance errors are the
//! means over true positives; recall is also given apart for the pieces seen over less than
//! 1 m and for the longer ones. Run with `--nocapture` to see the table; the test asserts only
//! floors that every method must clear, and that the metric itself scores a perfect answer as
//! perfect. Times are printed, never asserted.

mod scan_sim;

use octoquant_segment::{
    hough_lines, incremental_lines, ransac_lines, segment_scan, split_and_merge, HoughParams,
    IncrementalParams, Line, LineParams, RansacParams, Segmentation, SplitMergeParams,
};
use scan_sim::{beams, scan, Rng, Scan, Wall};
use std::f64::consts::PI;
use std::time::Instant;

/// Fewest hits for a wall piece to be ground truth.
const MIN_TRUE: usize = 8;

/// A random room with doorways and boxes, in the sensor frame (sensor at the origin).
fn scene(rng: &mut Rng) -> Vec<Wall> {
    let w = 4.0 + 6.0 * rng.uniform();
    let h = 4.0 + 6.0 * rng.uniform();
    let mut walls: Vec<Wall> = Vec::new();
    let corners = [[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]];
    for k in 0..4 {
        let (a, b) = (corners[k], corners[(k + 1) % 4]);
        let len = if k % 2 == 0 { w } else { h };
        if rng.uniform() < 0.5 {
            let door = 0.8 + 0.4 * rng.uniform();
            let at = 0.3 + (len - door - 0.6) * rng.uniform();
            let lerp = |t: f64| {
                [
                    a[0] + (b[0] - a[0]) * t / len,
                    a[1] + (b[1] - a[1]) * t / len,
                ]
            };
            walls.push([a, lerp(at)]);
            walls.push([lerp(at + door), b]);
        } else {
            walls.push([a, b]);
        }
    }
    // The sensor somewhere inside, then boxes that stay clear of it.
    let s = [
        0.5 + (w - 1.0) * rng.uniform(),
        0.5 + (h - 1.0) * rng.uniform(),
    ];
    let boxes = (rng.uniform() * 4.0) as usize;
    let mut placed = 0;
    while placed < boxes {
        let c = [w * rng.uniform(), h * rng.uniform()];
        let (bw, bh) = (0.3 + 0.9 * rng.uniform(), 0.3 + 0.9 * rng.uniform());
        let r = bw.hypot(bh) / 2.0;
        if (c[0] - s[0]).hypot(c[1] - s[1]) < r + 0.5
            || c[0] < r
            || c[1] < r
            || c[0] > w - r
            || c[1] > h - r
        {
            continue;
        }
        let a = PI * rng.uniform();
        let (sa, ca) = a.sin_cos();
        let corner = |x: f64, y: f64| [c[0] + x * ca - y * sa, c[1] + x * sa + y * ca];
        let q = [
            corner(-bw / 2.0, -bh / 2.0),
            corner(bw / 2.0, -bh / 2.0),
            corner(bw / 2.0, bh / 2.0),
            corner(-bw / 2.0, bh / 2.0),
        ];
        for k in 0..4 {
            walls.push([q[k], q[(k + 1) % 4]]);
        }
        placed += 1;
    }
    // Into the sensor frame, at a random heading.
    let heading = 2.0 * PI * rng.uniform();
    let (sh, ch) = heading.sin_cos();
    let to_sensor = |p: [f64; 2]| {
        let (x, y) = (p[0] - s[0], p[1] - s[1]);
        [x * ch + y * sh, -x * sh + y * ch]
    };
    walls
        .iter()
        .map(|w| [to_sensor(w[0]), to_sensor(w[1])])
        .collect()
}

/// One visible wall piece: its line (unit normal away from the origin, distance) and the
/// extent of its noiseless hits along the line direction (-ny, nx).
struct Piece {
    /// Whether the piece has at least `MIN_TRUE` hits.
    scored: bool,
    normal: [f64; 2],
    distance: f64,
    extent: (f64, f64),
}

/// Maximal runs of consecutive beams on one wall (of at least two hits).
fn truth(walls: &[Wall], s: &Scan) -> Vec<Piece> {
    let mut out = Vec::new();
    let mut k = 0;
    while k < s.wall.len() {
        let mut e = k + 1;
        while e < s.wall.len() && s.wall[e] == s.wall[k] {
            e += 1;
        }
        if e - k >= 2 {
            let w = walls[s.wall[k]];
            let (ex, ey) = (w[1][0] - w[0][0], w[1][1] - w[0][1]);
            let len = ex.hypot(ey);
            let mut n = [-ey / len, ex / len];
            let mut d = n[0] * w[0][0] + n[1] * w[0][1];
            if d < 0.0 {
                n = [-n[0], -n[1]];
                d = -d;
            }
            let t = |p: [f64; 2]| -p[0] * n[1] + p[1] * n[0];
            let ts: Vec<f64> = s.clean[k..e].iter().map(|&p| t(p)).collect();
            let lo = ts.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = ts.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            out.push(Piece {
                scored: e - k >= MIN_TRUE,
                normal: n,
                distance: d,
                extent: (lo, hi),
            });
        }
        k = e;
    }
    out
}

/// Angular (radians) and distance errors of `l` against `p` when `l` matches it.
fn match_error(l: &Line, p: &Piece) -> Option<(f64, f64)> {
    let (s, c) = l.normal_angle.sin_cos();
    let da = (c * p.normal[0] + s * p.normal[1]).clamp(-1.0, 1.0).acos();
    let dd = (l.distance - p.distance).abs();
    if da > 3f64.to_radians() || dd > 0.05 {
        return None;
    }
    let t = |q: [f64; 2]| -q[0] * p.normal[1] + q[1] * p.normal[0];
    let (a, b) = (t(l.start).min(t(l.end)), t(l.start).max(t(l.end)));
    let inside = (b.min(p.extent.1) - a.max(p.extent.0)).max(0.0);
    (inside >= 0.5 * (b - a)).then_some((da, dd))
}

#[derive(Default, Debug)]
struct Score {
    pieces: usize,
    true_pos: usize,
    false_pos: usize,
    angle_err: f64,
    dist_err: f64,
    ms: f64,
    scans: usize,
    /// Scored pieces shorter than `SHORT` metres, and how many of them were found.
    short: usize,
    short_found: usize,
}

/// Pieces whose seen part is shorter than this (metres) get their own recall.
const SHORT: f64 = 1.0;

impl Score {
    fn add(&mut self, lines: &[Line], pieces: &[Piece]) {
        let mut found = vec![false; pieces.len()];
        for l in lines {
            let best = pieces
                .iter()
                .enumerate()
                .filter(|(k, p)| p.scored && !found[*k])
                .filter_map(|(k, p)| match_error(l, p).map(|e| (k, e)))
                .min_by(|x, y| x.1 .1.total_cmp(&y.1 .1));
            match best {
                Some((k, (da, dd))) => {
                    found[k] = true;
                    self.true_pos += 1;
                    self.angle_err += da;
                    self.dist_err += dd;
                }
                None if pieces
                    .iter()
                    .any(|p| !p.scored && match_error(l, p).is_some()) => {}
                None => self.false_pos += 1,
            }
        }
        for (k, p) in pieces.iter().enumerate() {
            if p.scored && p.extent.1 - p.extent.0 < SHORT {
                self.short += 1;
                self.short_found += usize::from(found[k]);
            }
        }
        self.pieces += pieces.iter().filter(|p| p.scored).count();
        self.scans += 1;
    }

    fn recall(&self) -> f64 {
        self.true_pos as f64 / self.pieces as f64
    }

    fn precision(&self) -> f64 {
        self.true_pos as f64 / (self.true_pos + self.false_pos).max(1) as f64
    }

    fn row(&self, name: &str) -> String {
        format!(
            "| {name:<24} | {:>5} | {:>5} | {:>5} | {:>6.3} | {:>6.3} | {:>6.3} | {:>6.3} | {:>7.3} | {:>7.2} | {:>7.3} |",
            self.pieces,
            self.true_pos,
            self.false_pos,
            self.recall(),
            self.short_found as f64 / self.short.max(1) as f64,
            (self.true_pos - self.short_found) as f64 / (self.pieces - self.short).max(1) as f64,
            self.precision(),
            (self.angle_err / self.true_pos.max(1) as f64).to_degrees(),
            100.0 * self.dist_err / self.true_pos.max(1) as f64,
            self.ms / self.scans.max(1) as f64,
        )
    }
}

type Method = (&'static str, Box<dyn Fn(&[[f64; 2]], &mut Segmentation)>);

fn methods() -> Vec<Method> {
    vec![
        (
            "angular (default)",
            Box::new(|p, s| segment_scan(p, &LineParams::default(), s).unwrap()),
        ),
        (
            "angular, fixed split eps",
            Box::new(|p, s| {
                let params = LineParams {
                    split_spacing_factor: 0.0,
                    ..LineParams::default()
                };
                segment_scan(p, &params, s).unwrap()
            }),
        ),
        (
            "angular, no separation",
            Box::new(|p, s| {
                let params = LineParams {
                    split_eps: f64::INFINITY,
                    ..LineParams::default()
                };
                segment_scan(p, &params, s).unwrap()
            }),
        ),
        (
            "split-and-merge",
            Box::new(|p, s| split_and_merge(p, &SplitMergeParams::default(), s).unwrap()),
        ),
        (
            "incremental",
            Box::new(|p, s| incremental_lines(p, &IncrementalParams::default(), s).unwrap()),
        ),
        (
            "RANSAC",
            Box::new(|p, s| ransac_lines(p, &RansacParams::default(), s).unwrap()),
        ),
        (
            "Hough",
            Box::new(|p, s| hough_lines(p, &HoughParams::default(), s).unwrap()),
        ),
    ]
}

#[test]
fn metric_scores_the_truth_as_perfect() {
    let mut rng = Rng(3);
    for _ in 0..20 {
        let walls = scene(&mut rng);
        let s = scan(&walls, &beams(-179.0, 180.0, 360), 40.0, 0.0, 0);
        let pieces = truth(&walls, &s);
        // The exact lines of the pieces, ends at the extremes of their hits.
        let lines: Vec<Line> = pieces
            .iter()
            .map(|p| {
                let n = p.normal;
                let foot = |t: f64| [p.distance * n[0] - t * n[1], p.distance * n[1] + t * n[0]];
                Line {
                    normal_angle: n[1].atan2(n[0]).rem_euclid(2.0 * PI),
                    distance: p.distance,
                    start: foot(p.extent.0),
                    end: foot(p.extent.1),
                    n_points: MIN_TRUE,
                    rms_residual: 0.0,
                    max_residual: 0.0,
                }
            })
            .collect();
        let scored = pieces.iter().filter(|p| p.scored).count();
        assert!(scored > 0);
        let mut score = Score::default();
        score.add(&lines, &pieces);
        assert_eq!((score.true_pos, score.false_pos), (scored, 0));
        assert!(score.angle_err < 1e-6 && score.dist_err < 1e-9, "{score:?}");
        // Each line twice: the copies of scored pieces are false positives.
        let twice: Vec<Line> = lines.iter().chain(&lines).copied().collect();
        let mut score = Score::default();
        score.add(&twice, &pieces);
        assert_eq!((score.true_pos, score.false_pos), (scored, scored));
        // A line spanning two pieces of a wall broken by a doorway matches neither.
        let mut span = lines[0];
        let len = span.length();
        let (u0, u1) = (
            (span.end[0] - span.start[0]) / len,
            (span.end[1] - span.start[1]) / len,
        );
        span.end = [span.end[0] + 3.0 * len * u0, span.end[1] + 3.0 * len * u1];
        let mut score = Score::default();
        score.add(&[span], &pieces);
        assert_eq!(score.true_pos, 0);
    }
}

#[test]
fn line_extractors_on_simulated_rooms() {
    const SCENES: usize = 200;
    let methods = methods();
    let mut table = String::from(
        "| method                   | walls |    TP |    FP | recall | <1 m   | >=1 m  | precis | ang deg | dist cm | ms/scan |\n\
         |--------------------------|-------|-------|-------|--------|--------|--------|--------|---------|---------|---------|\n",
    );
    for sigma in [0.0, 0.01, 0.02] {
        let mut scores: Vec<Score> = methods.iter().map(|_| Score::default()).collect();
        let mut rng = Rng(2007);
        let mut seg = Segmentation::new();
        for i in 0..SCENES {
            let walls = scene(&mut rng);
            let s = scan(&walls, &beams(-179.0, 180.0, 360), 40.0, sigma, i as u64);
            let pieces = truth(&walls, &s);
            for ((_, run), score) in methods.iter().zip(&mut scores) {
                let t = Instant::now();
                run(&s.points, &mut seg);
                score.ms += t.elapsed().as_secs_f64() * 1e3;
                score.add(seg.lines(), &pieces);
            }
        }
        table.push_str(&format!("| noise sigma {:.0} cm |\n", sigma * 100.0));
        for ((name, _), score) in methods.iter().zip(&scores) {
            table.push_str(&score.row(name));
            table.push('\n');
            // Floors every method must clear; the table is the result.
            assert!(score.recall() > 0.5, "{name} at {sigma}: {score:?}");
            assert!(score.precision() > 0.5, "{name} at {sigma}: {score:?}");
        }
    }
    eprintln!("{table}");
}
