//! Incremental (line tracking) line extraction from one 2D scan, the third baseline of Nguyen et
//! al., "A comparison of line extraction algorithms using 2D range data for indoor mobile
//! robotics" (2007), against which the angular segmentation is compared.
//!
//! The points are taken in beam order. A line starts with two consecutive points; the next
//! point is added and the line refitted by total least squares (TLS) while the *line
//! condition* holds: the new point is within [`IncrementalParams::max_gap`] of the previous one,
//! and every member of the line is within [`IncrementalParams::max_distance`] of the refitted
//! line. The first point that breaks the condition is put back: the line ends before it, and
//! the next line starts with it and its successor. Lines with fewer than
//! [`IncrementalParams::min_line_points`] members are not reported; their points stay on no
//! line.
//!
//! The refit is O(1) per point (running centroid and co-moments). Checking every member on
//! every step would cost O(L) per point on a line of L points; instead a bound on how far the
//! members can have moved since the last full check (the change of the normal times the
//! line's extent, plus the shift of the offset) certifies the condition without visiting them,
//! and the members are visited only when the bound does not. The result is the same as the
//! check on every member, and a long straight wall costs O(L), not O(L^2).

use crate::error::{check_non_negative, SegmentError};
use crate::laser_lines::Segmentation;
use std::f64::consts::PI;

/// Knobs of [`incremental_lines`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IncrementalParams {
    /// The line condition: every member within this of the TLS line through the members,
    /// metres (default 0.05, the angular segmentation's `eps_dist`, about five times the
    /// range noise of a SICK LMS).
    pub max_distance: f64,
    /// Consecutive points farther apart than this end the line, metres (default 0.5, the
    /// angular segmentation's `split_eps`: half a narrow doorway).
    pub max_gap: f64,
    /// Lines with fewer members are not reported (default 5, never below 2).
    pub min_line_points: usize,
}

impl Default for IncrementalParams {
    fn default() -> Self {
        Self {
            max_distance: 0.05,
            max_gap: 0.5,
            min_line_points: 5,
        }
    }
}

impl IncrementalParams {
    fn validate(&self) -> Result<(), SegmentError> {
        check_non_negative(&[
            ("max_distance", self.max_distance),
            ("max_gap", self.max_gap),
        ])?;
        Ok(())
    }
}

/// Running TLS fit of the points of one line, relative to its first point `o` (which keeps the
/// sums small when the coordinates are large).
#[derive(Clone, Copy, Debug)]
struct Moments {
    n: f64,
    /// Centroid, relative to `o`.
    cx: f64,
    cy: f64,
    /// Co-moments about the centroid (Welford's updates).
    sxx: f64,
    syy: f64,
    sxy: f64,
    /// Largest distance of a member from `o`.
    reach: f64,
}

impl Moments {
    fn new() -> Self {
        Self {
            n: 0.0,
            cx: 0.0,
            cy: 0.0,
            sxx: 0.0,
            syy: 0.0,
            sxy: 0.0,
            reach: 0.0,
        }
    }

    /// Add the point `(x, y)`, relative to `o`.
    fn add(&mut self, x: f64, y: f64) {
        self.n += 1.0;
        let (dx, dy) = (x - self.cx, y - self.cy);
        self.cx += dx / self.n;
        self.cy += dy / self.n;
        let (ex, ey) = (x - self.cx, y - self.cy);
        self.sxx += dx * ex;
        self.syy += dy * ey;
        self.sxy += dx * ey;
        self.reach = self.reach.max(x.hypot(y));
    }

    /// Unit normal of the TLS line (any, when the points coincide).
    fn normal(&self) -> [f64; 2] {
        let phi = 0.5 * (2.0 * self.sxy).atan2(self.sxx - self.syy) + PI / 2.0;
        [phi.cos(), phi.sin()]
    }
}

/// A line of the tracking: a normal and the centroid it passes through (relative to `o`).
#[derive(Clone, Copy, Debug)]
struct Checked {
    normal: [f64; 2],
    centroid: [f64; 2],
    /// Largest member distance from this line, of the members at the last full check and every
    /// one added since.
    max_residual: f64,
}

impl Checked {
    fn residual(&self, x: f64, y: f64) -> f64 {
        (self.normal[0] * (x - self.centroid[0]) + self.normal[1] * (y - self.centroid[1])).abs()
    }
}

/// Incremental (line tracking) lines of one scan into `out` (read with
/// [`Segmentation::lines`], [`Segmentation::labels`] and [`Segmentation::line_members`]).
/// `points` are the valid returns in beam order. Every reported line's members are consecutive
/// points, and its `max_residual` is at most `max_distance`.
///
/// Errors on a non-finite coordinate or bad `params`.
pub fn incremental_lines(
    points: &[[f64; 2]],
    params: &IncrementalParams,
    out: &mut Segmentation,
) -> Result<(), SegmentError> {
    params.validate()?;
    let found = out.start(points)?;
    let n = points.len();
    let min_line = params.min_line_points.max(2);
    let tol = params.max_distance;
    let mut ids: Vec<u32> = Vec::new();
    let mut s = 0;
    while s < n {
        let e = track(points, s, tol, params.max_gap);
        if e - s >= min_line {
            ids.clear();
            ids.extend((s..e).map(|i| i as u32));
            found.emit(points, &ids);
        }
        s = e;
    }
    Ok(())
}

/// The end (exclusive) of the line that starts at `s`: the first point after it that breaks
/// the line condition, or the end of the scan.
fn track(points: &[[f64; 2]], s: usize, tol: f64, max_gap: f64) -> usize {
    let o = points[s];
    let rel = |i: usize| [points[i][0] - o[0], points[i][1] - o[1]];
    let mut m = Moments::new();
    m.add(0.0, 0.0);
    let mut checked = Checked {
        normal: m.normal(),
        centroid: [0.0, 0.0],
        max_residual: 0.0,
    };
    let mut e = s + 1;
    while e < points.len() {
        let (p, q) = (points[e - 1], points[e]);
        if (q[0] - p[0]).hypot(q[1] - p[1]) > max_gap {
            break;
        }
        let [x, y] = rel(e);
        let mut next = m;
        next.add(x, y);
        let mut normal = next.normal();
        // Orient the new normal like the checked one (a line's normal is defined up to sign).
        if normal[0] * checked.normal[0] + normal[1] * checked.normal[1] < 0.0 {
            normal = [-normal[0], -normal[1]];
        }
        let centroid = [next.cx, next.cy];
        let grown = checked.max_residual.max(checked.residual(x, y));
        // |r_new(p) - r_checked(p)| <= |n_new - n_checked| * |p - o| + |offset change|.
        let dn = (normal[0] - checked.normal[0]).hypot(normal[1] - checked.normal[1]);
        let offset_new = normal[0] * centroid[0] + normal[1] * centroid[1];
        let offset_old =
            checked.normal[0] * checked.centroid[0] + checked.normal[1] * checked.centroid[1];
        let bound = grown + dn * next.reach + (offset_new - offset_old).abs();
        // A margin far above the rounding of the bound, so that a certified step is one the
        // check of every member would accept too.
        let margin = 1e-9 * (1.0 + next.reach);
        if bound + margin <= tol {
            checked.max_residual = grown;
        } else {
            // Visit every member against the new line.
            let line = Checked {
                normal,
                centroid,
                max_residual: 0.0,
            };
            let worst = (s..=e)
                .map(|i| {
                    let [a, b] = rel(i);
                    line.residual(a, b)
                })
                .fold(0.0f64, f64::max);
            if worst > tol {
                break;
            }
            checked = Checked {
                max_residual: worst,
                ..line
            };
        }
        m = next;
        e += 1;
    }
    e
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::NOISE;

    #[test]
    fn corner_gap_and_outlier() {
        // Wall x = 3 then wall y = 2 (a corner), then a gap and a third piece.
        let mut pts: Vec<[f64; 2]> = (0..30).map(|i| [3.0, -1.0 + 0.1 * i as f64]).collect();
        pts.extend((0..30).map(|i| [2.9 - 0.1 * i as f64, 2.0]));
        pts.extend((0..10).map(|i| [-1.0 - 0.1 * i as f64, 2.0]));
        let mut out = Segmentation::new();
        incremental_lines(&pts, &IncrementalParams::default(), &mut out).unwrap();
        let l = out.lines();
        assert_eq!(l.len(), 3, "{l:?}");
        assert!(l.iter().all(|l| l.max_residual < 1e-9), "{l:?}");
        assert_eq!(
            (l[0].n_points, l[1].n_points, l[2].n_points),
            (30, 30, 10),
            "{l:?}"
        );
        assert!((l[0].distance - 3.0).abs() < 1e-9 && (l[1].distance - 2.0).abs() < 1e-9);
        // Without the gap cut the collinear third piece continues the second line.
        let p = IncrementalParams {
            max_gap: 10.0,
            ..IncrementalParams::default()
        };
        incremental_lines(&pts, &p, &mut out).unwrap();
        assert_eq!(out.lines().len(), 2);
        // An outlier breaks the tracking: the wall becomes two lines and the outlier is on
        // neither (it starts a two-point line).
        let mut wall: Vec<[f64; 2]> = (0..40).map(|i| [-2.0 + 0.1 * i as f64, 2.0]).collect();
        wall[20] = [0.0, 1.0];
        incremental_lines(&wall, &IncrementalParams::default(), &mut out).unwrap();
        assert_eq!(out.lines().len(), 2, "{:?}", out.lines());
        assert_eq!(out.labels()[20], NOISE);
    }

    #[test]
    fn bad_and_degenerate_input() {
        let mut out = Segmentation::new();
        let p = IncrementalParams::default();
        incremental_lines(&[], &p, &mut out).unwrap();
        assert!(out.lines().is_empty());
        assert!(matches!(
            incremental_lines(&[[0.0, 0.0], [f64::NAN, 1.0]], &p, &mut out),
            Err(SegmentError::NonFinite { index: 1, .. })
        ));
        assert!(incremental_lines(&[[f64::INFINITY, 0.0]], &p, &mut out).is_err());
        let bad = IncrementalParams {
            max_distance: f64::NAN,
            ..p
        };
        assert!(matches!(
            incremental_lines(&[], &bad, &mut out),
            Err(SegmentError::InvalidParameter {
                name: "max_distance",
                ..
            })
        ));
        // Coinciding points: no direction, no line, no panic.
        incremental_lines(&[[1.0, 1.0]; 10], &p, &mut out).unwrap();
        assert!(out.lines().is_empty());
        // Far from the origin the relative sums keep the fit exact enough.
        let far: Vec<[f64; 2]> = (0..50).map(|i| [1e7 + 0.1 * i as f64, 1e7]).collect();
        incremental_lines(&far, &p, &mut out).unwrap();
        assert_eq!(out.lines().len(), 1);
    }
}
