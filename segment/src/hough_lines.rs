//! Hough transform line extraction from one 2D scan, the fourth baseline of Nguyen et al.,
//! "A comparison of line extraction algorithms using 2D range data for indoor mobile robotics"
//! (2007), against which the angular segmentation is compared.
//!
//! Lines are `x cos(theta) + y sin(theta) = rho`. The accumulator has one row per angle bin,
//! `theta_i = i pi / n` for `i` in `0..n` with `n = ceil(pi / angle_step)` (the step is rounded
//! down so that whole bins cover `[0, pi)`), and one column per distance bin: a point votes,
//! in every row, for the column `floor(rho / distance_step + 0.5)` of its `rho` at that
//! row's angle (columns from `-J` to `J`, `J = ceil(R / distance_step)`, `R` the largest
//! distance of a point from the origin).
//!
//! Then, as in the paper: the cell with the most votes wins (the first in row-major order on
//! ties); when it has fewer than [`HoughParams::min_votes`] the search stops. Otherwise the
//! points that voted for it (its supporters) are fitted by total least squares (TLS), the
//! points within [`HoughParams::inlier_distance`] of that fit are taken and fitted again, and
//! the points within the distance of the refit are the line's inliers (or the first inliers,
//! when the refit has fewer). The Hough transform finds infinite lines, so the inliers are cut
//! where consecutive ones (by position along the line) are farther apart than
//! [`HoughParams::max_gap`], as RANSAC does; every piece with at least
//! [`HoughParams::min_line_points`] points is a [`Line`](crate::Line). The inliers and the
//! supporters withdraw their votes and leave the pool, and the next peak is sought. Each
//! round removes at least the winning cell's votes, so the search ends.

use crate::error::{check_non_negative, SegmentError};
use crate::laser_lines::{fit_line, Found, Line, Segmentation};
use std::f64::consts::PI;

/// The largest accumulator [`hough_lines`] and [`hough_peak`] build (64 MiB of `u32` votes):
/// with the default steps, points up to about 2.3 km from the origin.
const MAX_CELLS: usize = 1 << 24;

/// Knobs of [`hough_lines`] and [`hough_peak`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HoughParams {
    /// Width of an angle bin, radians, in `(0, pi]` (default 1°: a 5 m wall seen with its
    /// normal half a bin off spreads its `rho` over 4.4 cm, within one or two distance bins).
    pub angle_step: f64,
    /// Width of a distance bin, metres (default 0.05: about five times the range noise of a
    /// SICK LMS, so that the points of a wall at the right angle fall into one or two bins).
    pub distance_step: f64,
    /// A peak with fewer votes ends the search (default 5, never below 2).
    pub min_votes: usize,
    /// Largest distance of an inlier from the fitted line, metres (default 0.05, the angular
    /// segmentation's `eps_dist`).
    pub inlier_distance: f64,
    /// Inliers farther apart than this along the line make separate lines, metres (default
    /// 0.5, the angular segmentation's `split_eps`).
    pub max_gap: f64,
    /// Lines need at least this many points (default 5, never below 2).
    pub min_line_points: usize,
}

impl Default for HoughParams {
    fn default() -> Self {
        Self {
            angle_step: 1f64.to_radians(),
            distance_step: 0.05,
            min_votes: 5,
            inlier_distance: 0.05,
            max_gap: 0.5,
            min_line_points: 5,
        }
    }
}

impl HoughParams {
    fn validate(&self) -> Result<(), SegmentError> {
        if !(self.angle_step > 0.0 && self.angle_step <= PI) {
            return Err(SegmentError::InvalidParameter {
                name: "angle_step",
                value: self.angle_step,
                reason: "must be in (0, pi]",
            });
        }
        if !(self.distance_step > 0.0 && self.distance_step.is_finite()) {
            return Err(SegmentError::InvalidParameter {
                name: "distance_step",
                value: self.distance_step,
                reason: "must be finite and > 0",
            });
        }
        check_non_negative(&[
            ("inlier_distance", self.inlier_distance),
            ("max_gap", self.max_gap),
        ])?;
        Ok(())
    }
}

/// The strongest cell of a Hough accumulator: the line `x cos(normal_angle) + y
/// sin(normal_angle) = distance` at the cell's centre, and its votes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HoughPeak {
    /// The cell's angle `theta_i = i pi / n`, radians in `[0, pi)`.
    pub normal_angle: f64,
    /// The cell's distance `j * distance_step`, metres (signed: the normal angle stays in
    /// `[0, pi)`).
    pub distance: f64,
    /// Angle bin (row) of the cell.
    pub angle_bin: usize,
    /// Distance bin of the cell, from `-J` to `J`.
    pub distance_bin: i64,
    /// Number of points that voted for the cell.
    pub votes: usize,
}

/// The vote table, with each row's maximum kept up to date as votes are withdrawn.
struct Accumulator {
    cos_sin: Vec<(f64, f64)>,
    /// `J`: distance bins run from `-J` to `J`, stored at `J + j`.
    half: i64,
    cols: usize,
    step: f64,
    votes: Vec<u32>,
    /// Per row: the first column with the row's most votes, and those votes.
    row_max: Vec<(usize, u32)>,
    dirty: Vec<bool>,
}

impl Accumulator {
    /// An empty accumulator for `points`, or an error when it would be too large.
    fn new(points: &[[f64; 2]], params: &HoughParams) -> Result<Self, SegmentError> {
        let reach = points
            .iter()
            .map(|p| p[0].hypot(p[1]))
            .fold(0.0f64, f64::max);
        let rows = (PI / params.angle_step - 1e-9).ceil().max(1.0);
        let half = (reach / params.distance_step).ceil();
        let cells = rows * (2.0 * half + 1.0);
        if cells.is_nan() || cells > MAX_CELLS as f64 {
            return Err(SegmentError::AccumulatorTooLarge {
                cells,
                reach,
                max: MAX_CELLS,
            });
        }
        let (rows, half) = (rows as usize, half as i64);
        let cols = 2 * half as usize + 1;
        Ok(Self {
            cos_sin: (0..rows)
                .map(|i| {
                    let (s, c) = (i as f64 * PI / rows as f64).sin_cos();
                    (c, s)
                })
                .collect(),
            half,
            cols,
            step: params.distance_step,
            votes: vec![0; rows * cols],
            row_max: vec![(0, 0); rows],
            dirty: vec![true; rows],
        })
    }

    /// Distance bin (from `-J` to `J`) of `p` in row `i`.
    fn bin(&self, i: usize, p: [f64; 2]) -> i64 {
        let (c, s) = self.cos_sin[i];
        let rho = p[0] * c + p[1] * s;
        let x = rho / self.step + 0.5;
        // floor(x) without a call into libm (x is at most J + 1 in size, far below 2^53).
        let t = x as i64;
        let floor = t - i64::from((t as f64) > x);
        // |rho| <= R, so the bin is within [-J, J]; the clamp only guards rounding.
        floor.clamp(-self.half, self.half)
    }

    /// Add (`add`) or withdraw the votes of the points `ids`, a row at a time (each row is a
    /// small slice, so its counts stay in cache).
    fn tally(&mut self, points: &[[f64; 2]], ids: &[u32], add: bool) {
        for i in 0..self.cos_sin.len() {
            let mut touched_max = false;
            for &k in ids {
                let col = (self.bin(i, points[k as usize]) + self.half) as usize;
                let v = &mut self.votes[i * self.cols + col];
                if add {
                    *v += 1;
                } else {
                    *v = v.saturating_sub(1);
                    touched_max |= self.row_max[i].0 == col;
                }
            }
            // Adding may raise any cell; lowering any but the row's first maximum leaves it.
            if add || touched_max {
                self.dirty[i] = true;
            }
        }
    }

    /// The first cell in row-major order with the most votes; `None` when no cell has any.
    fn peak(&mut self) -> Option<HoughPeak> {
        let mut best: Option<(usize, usize, u32)> = None;
        for i in 0..self.cos_sin.len() {
            if self.dirty[i] {
                let row = &self.votes[i * self.cols..(i + 1) * self.cols];
                // The maximum first (a loop the compiler vectorises), then its first column.
                let v = row.iter().copied().max().unwrap_or(0);
                let j = row.iter().position(|&x| x == v).unwrap_or(0);
                self.row_max[i] = (j, v);
                self.dirty[i] = false;
            }
            let (j, v) = self.row_max[i];
            if v > 0 && best.is_none_or(|b| v > b.2) {
                best = Some((i, j, v));
            }
        }
        best.map(|(i, j, v)| {
            let distance_bin = j as i64 - self.half;
            HoughPeak {
                normal_angle: i as f64 * PI / self.cos_sin.len() as f64,
                distance: distance_bin as f64 * self.step,
                angle_bin: i,
                distance_bin,
                votes: v as usize,
            }
        })
    }
}

/// The strongest cell of the Hough accumulator of all `points` (the first peak
/// [`hough_lines`] starts from), `None` without points. Only the steps of `params` matter.
///
/// Errors on a non-finite coordinate, bad `params` or an accumulator that would be too large.
pub fn hough_peak(
    points: &[[f64; 2]],
    params: &HoughParams,
) -> Result<Option<HoughPeak>, SegmentError> {
    params.validate()?;
    Segmentation::new().start(points)?;
    let mut acc = Accumulator::new(points, params)?;
    let all: Vec<u32> = (0..points.len() as u32).collect();
    acc.tally(points, &all, true);
    Ok(acc.peak())
}

/// Hough transform lines of one scan into `out` (read with [`Segmentation::lines`],
/// [`Segmentation::labels`] and [`Segmentation::line_members`]). The points may be in any
/// order (beam order is not used).
///
/// Errors on a non-finite coordinate, bad `params` or an accumulator that would be too large
/// (then `out` holds no lines).
pub fn hough_lines(
    points: &[[f64; 2]],
    params: &HoughParams,
    out: &mut Segmentation,
) -> Result<(), SegmentError> {
    params.validate()?;
    let found = out.start(points)?;
    let mut acc = Accumulator::new(points, params)?;
    let min_votes = params.min_votes.max(2);
    let min_line = params.min_line_points.max(2);
    let tol = params.inlier_distance;
    let mut pool: Vec<u32> = (0..points.len() as u32).collect();
    acc.tally(points, &pool, true);
    let mut supporters: Vec<u32> = Vec::new();
    let mut inliers: Vec<u32> = Vec::new();
    let mut refit: Vec<u32> = Vec::new();
    let mut scratch: Vec<(f64, u32)> = Vec::new();
    let mut piece: Vec<u32> = Vec::new();
    let near = |pool: &[u32], l: &Line, into: &mut Vec<u32>| {
        into.clear();
        into.extend(
            pool.iter()
                .copied()
                .filter(|&i| l.signed_distance(points[i as usize]).abs() <= tol),
        );
    };
    while let Some(peak) = acc.peak() {
        if peak.votes < min_votes {
            break;
        }
        supporters.clear();
        supporters.extend(
            pool.iter()
                .copied()
                .filter(|&i| acc.bin(peak.angle_bin, points[i as usize]) == peak.distance_bin),
        );
        inliers.clear();
        if let Some(first) = fit_line(points, &supporters) {
            near(&pool, &first, &mut inliers);
            if let Some(second) = fit_line(points, &inliers) {
                near(&pool, &second, &mut refit);
                if refit.len() >= inliers.len() {
                    std::mem::swap(&mut inliers, &mut refit);
                }
            }
            split_at_gaps(
                points,
                &inliers,
                params.max_gap,
                min_line,
                &mut scratch,
                &mut piece,
                found,
            );
        }
        // Withdraw the inliers and the supporters (a superset of one cell's votes, so the
        // search ends).
        inliers.extend_from_slice(&supporters);
        inliers.sort_unstable();
        inliers.dedup();
        acc.tally(points, &inliers, false);
        pool.retain(|i| inliers.binary_search(i).is_err());
    }
    Ok(())
}

/// Emit the pieces of `ids` (points of one line) cut where consecutive ones along their TLS
/// line are more than `max_gap` apart, every piece of at least `min_line` points.
fn split_at_gaps(
    points: &[[f64; 2]],
    ids: &[u32],
    max_gap: f64,
    min_line: usize,
    along: &mut Vec<(f64, u32)>,
    piece: &mut Vec<u32>,
    found: &mut Found,
) {
    let Some(fit) = fit_line(points, ids) else {
        return;
    };
    let (s, c) = fit.normal_angle.sin_cos();
    along.clear();
    along.extend(ids.iter().map(|&i| {
        let p = points[i as usize];
        (-p[0] * s + p[1] * c, i)
    }));
    along.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
    let mut k = 0;
    while k < along.len() {
        let mut e = k + 1;
        while e < along.len() && along[e].0 - along[e - 1].0 <= max_gap {
            e += 1;
        }
        if e - k >= min_line {
            piece.clear();
            piece.extend(along[k..e].iter().map(|v| v.1));
            piece.sort_unstable();
            found.emit(points, piece);
        }
        k = e;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corner_and_collinear_pieces() {
        let mut pts: Vec<[f64; 2]> = (0..30).map(|i| [3.0, -1.0 + 0.1 * i as f64]).collect();
        pts.extend((0..30).map(|i| [2.9 - 0.1 * i as f64, 2.0]));
        pts.extend((0..10).map(|i| [-1.0 - 0.1 * i as f64, 2.0]));
        let mut out = Segmentation::new();
        hough_lines(&pts, &HoughParams::default(), &mut out).unwrap();
        let mut d: Vec<(f64, usize)> = out
            .lines()
            .iter()
            .map(|l| ((l.distance * 1e6).round() / 1e6, l.n_points))
            .collect();
        d.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        assert_eq!(d, vec![(2.0, 10), (2.0, 30), (3.0, 30)]);
        // The first peak is the wall y = 2 (40 points), at theta = pi / 2.
        let peak = hough_peak(&pts, &HoughParams::default()).unwrap().unwrap();
        assert_eq!(
            (peak.angle_bin, peak.distance_bin, peak.votes),
            (90, 40, 40)
        );
        assert!(
            (peak.normal_angle - PI / 2.0).abs() < 1e-12 && (peak.distance - 2.0).abs() < 1e-12
        );
    }

    #[test]
    fn bad_and_degenerate_input() {
        let mut out = Segmentation::new();
        let p = HoughParams::default();
        hough_lines(&[], &p, &mut out).unwrap();
        assert!(out.lines().is_empty());
        assert_eq!(hough_peak(&[], &p).unwrap(), None);
        assert!(matches!(
            hough_lines(&[[0.0, 0.0], [1.0, f64::NEG_INFINITY]], &p, &mut out),
            Err(SegmentError::NonFinite { index: 1, .. })
        ));
        assert!(hough_peak(&[[f64::NAN, 0.0]], &p).is_err());
        for bad in [
            HoughParams {
                angle_step: 0.0,
                ..p
            },
            HoughParams {
                angle_step: f64::NAN,
                ..p
            },
            HoughParams {
                distance_step: f64::INFINITY,
                ..p
            },
            HoughParams {
                inlier_distance: -1.0,
                ..p
            },
        ] {
            assert!(matches!(
                hough_lines(&[], &bad, &mut out),
                Err(SegmentError::InvalidParameter { .. })
            ));
        }
        // Far points or tiny steps: a clear error, no huge allocation, and no lines left over.
        let short: Vec<[f64; 2]> = (0..5).map(|i| [1.0, 1.0 + 0.1 * i as f64]).collect();
        hough_lines(&short, &p, &mut out).unwrap();
        assert_eq!(out.lines().len(), 1);
        assert!(matches!(
            hough_lines(&[[1e12, 0.0]], &p, &mut out),
            Err(SegmentError::AccumulatorTooLarge { .. })
        ));
        assert!(out.lines().is_empty());
        let tiny = HoughParams {
            angle_step: 1e-300,
            ..p
        };
        assert!(hough_peak(&[[1.0, 0.0]], &tiny).is_err());
        // Coinciding points: one cell, no direction, no line, no panic.
        hough_lines(&[[1.0, 1.0]; 10], &p, &mut out).unwrap();
        assert!(out.lines().is_empty());
    }
}
