//! Split-and-merge line extraction from one 2D scan, the first baseline of Nguyen et al.,
//! "A comparison of line extraction algorithms using 2D range data for indoor mobile robotics"
//! (2007), against which the angular segmentation is compared.
//!
//! The points, in beam order, are first cut where consecutive points are farther apart than
//! [`SplitMergeParams::max_gap`]. Each piece is split recursively (iterative end-point fit):
//! the line through its first and last points is drawn, and the piece is split at its farthest
//! point when that point is more than [`SplitMergeParams::split_distance`] from it; the split
//! point belongs to both halves. Then consecutive segments are merged while the total least
//! squares (TLS) line through both keeps every point within `split_distance`. Every segment
//! with enough points becomes a [`Line`](crate::Line) fitted by TLS, as in
//! [`segment_scan`](crate::segment_scan).

use crate::error::{check_non_negative, SegmentError};
use crate::laser_lines::{fit_line, Segmentation};

/// Knobs of [`split_and_merge`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplitMergeParams {
    /// A segment is split at its farthest point from the line through its end points when that
    /// point is farther than this, metres; also the merge test (default 0.05, the angular
    /// segmentation's `eps_dist`).
    pub split_distance: f64,
    /// Consecutive points farther apart than this start a new segment, metres (default 0.5, the
    /// angular segmentation's `split_eps`).
    pub max_gap: f64,
    /// Segments with fewer points are not reported as lines (default 5, never below 2).
    pub min_line_points: usize,
    /// Whether consecutive segments are merged after splitting (default `true`).
    pub merge: bool,
}

impl Default for SplitMergeParams {
    fn default() -> Self {
        Self {
            split_distance: 0.05,
            max_gap: 0.5,
            min_line_points: 5,
            merge: true,
        }
    }
}

impl SplitMergeParams {
    fn validate(&self) -> Result<(), SegmentError> {
        check_non_negative(&[
            ("split_distance", self.split_distance),
            ("max_gap", self.max_gap),
        ])?;
        Ok(())
    }
}

/// Distance of `p` from the line through `a` and `b` (from `a` when they coincide).
fn distance_to_chord(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (ex, ey) = (b[0] - a[0], b[1] - a[1]);
    let len = ex.hypot(ey);
    let (dx, dy) = (p[0] - a[0], p[1] - a[1]);
    if len > 0.0 && len.is_finite() {
        (dx * ey - dy * ex).abs() / len
    } else {
        dx.hypot(dy)
    }
}

/// Split-and-merge lines of one scan into `out` (read with [`Segmentation::lines`],
/// [`Segmentation::labels`] and [`Segmentation::line_members`]; a split point shared by two
/// lines is labelled with the first). `points` are the valid returns in beam order.
///
/// Errors on a non-finite coordinate or bad `params`.
pub fn split_and_merge(
    points: &[[f64; 2]],
    params: &SplitMergeParams,
    out: &mut Segmentation,
) -> Result<(), SegmentError> {
    params.validate()?;
    let found = out.start(points)?;
    let n = points.len();
    let min_line = params.min_line_points.max(2);
    let near = |a: usize, b: usize| {
        let (p, q) = (points[a], points[b]);
        (p[0] - q[0]).hypot(p[1] - q[1]) <= params.max_gap
    };
    // Index ranges [a, b) of the final segments, in beam order.
    let mut segments: Vec<(usize, usize)> = Vec::new();
    let mut stack: Vec<(usize, usize)> = Vec::new();
    let mut ids: Vec<u32> = Vec::new();
    let mut start = 0;
    while start < n {
        let mut end = start + 1;
        while end < n && near(end - 1, end) {
            end += 1;
        }
        let first = segments.len();
        stack.push((start, end));
        while let Some((a, b)) = stack.pop() {
            let farthest = (a + 1..b.saturating_sub(1))
                .map(|k| (distance_to_chord(points[k], points[a], points[b - 1]), k))
                .max_by(|x, y| x.0.total_cmp(&y.0));
            match farthest {
                Some((d, k)) if d > params.split_distance => {
                    // Right half first on the stack, so the left one is finished first.
                    stack.push((k, b));
                    stack.push((a, k + 1));
                }
                _ => segments.push((a, b)),
            }
        }
        if params.merge {
            merge_run(
                points,
                params.split_distance,
                &mut segments,
                first,
                &mut ids,
            );
        }
        start = end;
    }
    for &(a, b) in &segments {
        if b - a >= min_line {
            ids.clear();
            ids.extend((a..b).map(|i| i as u32));
            found.emit(points, &ids);
        }
    }
    Ok(())
}

/// Merge consecutive segments of `segments[first..]` (one gap-free run, neighbours sharing
/// their split point) while the TLS line through both keeps every point within `tol`.
fn merge_run(
    points: &[[f64; 2]],
    tol: f64,
    segments: &mut Vec<(usize, usize)>,
    first: usize,
    ids: &mut Vec<u32>,
) {
    let mut i = first;
    while i + 1 < segments.len() {
        let (a, _) = segments[i];
        let (_, b) = segments[i + 1];
        ids.clear();
        ids.extend((a..b).map(|k| k as u32));
        match fit_line(points, ids) {
            Some(l) if l.max_residual <= tol => {
                segments[i] = (a, b);
                segments.remove(i + 1);
                // The merged segment may now merge with its predecessor too.
                i = i.saturating_sub(1).max(first);
            }
            _ => i += 1,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corner_and_gap() {
        // Wall x = 3 then wall y = 2 (a corner), then a gap and a third piece.
        let mut pts: Vec<[f64; 2]> = (0..30).map(|i| [3.0, -1.0 + 0.1 * i as f64]).collect();
        pts.extend((0..30).map(|i| [2.9 - 0.1 * i as f64, 2.0]));
        pts.extend((0..10).map(|i| [-1.0 - 0.1 * i as f64, 2.0]));
        let mut out = Segmentation::new();
        split_and_merge(&pts, &SplitMergeParams::default(), &mut out).unwrap();
        let l = out.lines();
        assert_eq!(l.len(), 3, "{l:?}");
        assert!(l.iter().all(|l| l.max_residual < 1e-9), "{l:?}");
        assert!((l[0].distance - 3.0).abs() < 1e-9 && (l[1].distance - 2.0).abs() < 1e-9);
        // Without the gap cut, the collinear third piece merges into the second line.
        let p = SplitMergeParams {
            max_gap: 10.0,
            ..SplitMergeParams::default()
        };
        split_and_merge(&pts, &p, &mut out).unwrap();
        assert_eq!(out.lines().len(), 2);
        assert!(split_and_merge(&[[f64::NAN, 0.0]], &p, &mut out).is_err());
        let bad = SplitMergeParams {
            split_distance: -1.0,
            ..p
        };
        assert!(split_and_merge(&pts, &bad, &mut out).is_err());
    }
}
