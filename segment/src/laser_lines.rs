//! Line segments from one 2D laser scan by angular segmentation (Meglicki, arXiv:2103.16245).
//!
//! Each point gets a local normal angle from a total-least-squares (TLS) fit to itself and its
//! two neighbours in beam order, taken modulo pi. Circular [`dbscan1d`](crate::dbscan1d) on the
//! sorted angles groups points of parallel surfaces; inside each angular group, the signed
//! distances to the line through the origin with the group's mean normal are clustered again,
//! which separates parallel walls. Every final cluster becomes a [`Line`] with its own TLS fit.

use crate::dbscan1d::{recluster_in_place, BorderPolicy, Clustering, Dbscan1dParams, NOISE};
use crate::error::SegmentError;
use std::f64::consts::PI;

/// Knobs of [`segment_scan`]. The defaults suit 1° SICK scans with centimetre range resolution.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineParams {
    /// Neighbourhood radius for the local normal angles, radians (default 2°).
    pub eps_theta: f64,
    /// Core-point threshold for the angles (default 5).
    pub min_points_theta: usize,
    /// Neighbourhood radius for the distances to the origin line, metres (default 0.05).
    pub eps_dist: f64,
    /// Core-point threshold for the distances (default 5).
    pub min_points_dist: usize,
    /// Clusters with fewer points are not reported as lines (default 5, never below 2).
    pub min_line_points: usize,
    /// Border policy of both clustering steps (default [`BorderPolicy::First`]).
    pub border: BorderPolicy,
}

impl Default for LineParams {
    fn default() -> Self {
        Self {
            eps_theta: 2f64.to_radians(),
            min_points_theta: 5,
            eps_dist: 0.05,
            min_points_dist: 5,
            min_line_points: 5,
            border: BorderPolicy::First,
        }
    }
}

impl LineParams {
    /// The two clustering parameter sets, or an error naming the bad field.
    pub fn validate(&self) -> Result<(Dbscan1dParams, Dbscan1dParams), SegmentError> {
        let rename = |name: &'static str| {
            move |e: SegmentError| match e {
                SegmentError::InvalidParameter { value, reason, .. } => {
                    SegmentError::InvalidParameter {
                        name,
                        value,
                        reason,
                    }
                }
                other => other,
            }
        };
        let theta = Dbscan1dParams::new(self.eps_theta, self.min_points_theta.max(1))
            .map_err(rename("eps_theta"))?
            .with_border(self.border)
            .with_period(PI)?;
        let dist = Dbscan1dParams::new(self.eps_dist, self.min_points_dist.max(1))
            .map_err(rename("eps_dist"))?
            .with_border(self.border);
        if self.min_points_theta == 0 || self.min_points_dist == 0 {
            return Err(SegmentError::InvalidParameter {
                name: "min_points",
                value: 0.0,
                reason: "must be at least 1",
            });
        }
        Ok((theta, dist))
    }
}

/// One fitted line segment: `x cos(normal_angle) + y sin(normal_angle) = distance`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Line {
    /// Direction of the line's normal, radians in `[0, 2 pi)`, pointing away from the origin.
    pub normal_angle: f64,
    /// Distance of the line from the origin (`>= 0`), metres.
    pub distance: f64,
    /// First end point: the extreme member projected onto the line.
    pub start: [f64; 2],
    /// Second end point: the other extreme member projected onto the line.
    pub end: [f64; 2],
    /// Number of member points.
    pub n_points: usize,
    /// Root mean square of the members' distances to the line, metres.
    pub rms_residual: f64,
    /// Largest member distance to the line, metres.
    pub max_residual: f64,
}

impl Line {
    /// Length of the segment between its end points.
    pub fn length(&self) -> f64 {
        (self.end[0] - self.start[0]).hypot(self.end[1] - self.start[1])
    }

    /// Signed distance of `p` from the line (positive on the side away from the origin).
    pub fn signed_distance(&self, p: [f64; 2]) -> f64 {
        p[0] * self.normal_angle.cos() + p[1] * self.normal_angle.sin() - self.distance
    }
}

/// Lines found by [`segment_scan`], plus the scratch buffers reused by the next call.
#[derive(Clone, Debug, Default)]
pub struct Segmentation {
    lines: Vec<Line>,
    labels: Vec<u32>,
    members: Vec<u32>,
    member_ranges: Vec<(usize, usize)>,
    angles: Vec<(f64, u32)>,
    dists: Vec<(f64, u32)>,
    angle_clusters: Clustering,
    dist_clusters: Clustering,
    cluster_members: Vec<usize>,
    sub_members: Vec<usize>,
}

impl Segmentation {
    /// An empty result; pass it to [`segment_scan`] and reuse it across scans.
    pub fn new() -> Self {
        Self::default()
    }

    /// The fitted lines, in the order found (by local angle, then by distance).
    pub fn lines(&self) -> &[Line] {
        &self.lines
    }

    /// Line of each input point, [`NOISE`] for points on no line (the first line when a
    /// border point belongs to two under [`BorderPolicy::All`]).
    pub fn labels(&self) -> &[u32] {
        &self.labels
    }

    /// Indices (into the input points) of the members of line `k`; empty when out of range.
    pub fn line_members(&self, k: usize) -> &[u32] {
        match self.member_ranges.get(k) {
            Some(&(a, b)) => &self.members[a..b],
            None => &[],
        }
    }

    /// The local normal angle of every point in `[0, pi)`, sorted, with its point index.
    pub fn local_angles(&self) -> &[(f64, u32)] {
        &self.angles
    }
}

/// Normal angle in `[0, pi)` of the TLS line through `pts`, or `None` when they coincide.
fn tls_normal(pts: &[[f64; 2]]) -> Option<(f64, [f64; 2])> {
    let n = pts.len() as f64;
    let (mut cx, mut cy) = (0.0, 0.0);
    for p in pts {
        cx += p[0];
        cy += p[1];
    }
    cx /= n;
    cy /= n;
    let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
    for p in pts {
        let (dx, dy) = (p[0] - cx, p[1] - cy);
        sxx += dx * dx;
        syy += dy * dy;
        sxy += dx * dy;
    }
    if sxx + syy <= 0.0 || !(sxx + syy).is_finite() {
        return None;
    }
    let direction = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    Some((wrap_pi(direction + PI / 2.0), [cx, cy]))
}

/// `a` modulo pi, in `[0, pi)` even after rounding.
fn wrap_pi(a: f64) -> f64 {
    let w = a.rem_euclid(PI);
    if w >= PI {
        0.0
    } else {
        w
    }
}

/// TLS fit of the points `idx` of `pts` as a [`Line`]; `None` when they all coincide.
fn fit_line(pts: &[[f64; 2]], idx: &[u32]) -> Option<Line> {
    let (mut cx, mut cy) = (0.0, 0.0);
    for &i in idx {
        cx += pts[i as usize][0];
        cy += pts[i as usize][1];
    }
    let n = idx.len() as f64;
    cx /= n;
    cy /= n;
    let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
    for &i in idx {
        let (dx, dy) = (pts[i as usize][0] - cx, pts[i as usize][1] - cy);
        sxx += dx * dx;
        syy += dy * dy;
        sxy += dx * dy;
    }
    if sxx + syy <= 0.0 {
        return None;
    }
    let mut phi = 0.5 * (2.0 * sxy).atan2(sxx - syy) + PI / 2.0;
    let mut d = cx * phi.cos() + cy * phi.sin();
    if d < 0.0 {
        phi += PI;
        d = -d;
    }
    let phi = phi.rem_euclid(2.0 * PI);
    let (c, s) = (phi.cos(), phi.sin());
    let (mut tmin, mut tmax) = (f64::INFINITY, f64::NEG_INFINITY);
    let (mut sq, mut max_r) = (0.0, 0.0f64);
    for &i in idx {
        let p = pts[i as usize];
        let r = p[0] * c + p[1] * s - d;
        sq += r * r;
        max_r = max_r.max(r.abs());
        let t = -p[0] * s + p[1] * c;
        tmin = tmin.min(t);
        tmax = tmax.max(t);
    }
    let foot = |t: f64| [d * c - t * s, d * s + t * c];
    Some(Line {
        normal_angle: phi,
        distance: d,
        start: foot(tmin),
        end: foot(tmax),
        n_points: idx.len(),
        rms_residual: (sq / n).sqrt(),
        max_residual: max_r,
    })
}

/// Segment one scan into lines; `points` are the valid returns in beam order, in any frame
/// (distances are measured from that frame's origin, normally the laser).
///
/// Fewer than three points give no lines. Errors on a non-finite coordinate or bad `params`.
pub fn segment_scan(
    points: &[[f64; 2]],
    params: &LineParams,
    out: &mut Segmentation,
) -> Result<(), SegmentError> {
    let (theta_params, dist_params) = params.validate()?;
    out.lines.clear();
    out.members.clear();
    out.member_ranges.clear();
    out.angles.clear();
    out.labels.clear();
    out.labels.resize(points.len(), NOISE);
    for (index, p) in points.iter().enumerate() {
        if !(p[0].is_finite() && p[1].is_finite()) {
            return Err(SegmentError::NonFinite {
                index,
                value: if p[0].is_finite() { p[1] } else { p[0] },
            });
        }
    }
    if points.len() >= NOISE as usize {
        return Err(SegmentError::TooManyPoints {
            len: points.len(),
            max: NOISE as usize - 1,
        });
    }
    let n = points.len();
    if n < 3 {
        return Ok(());
    }
    for i in 0..n {
        let a = i.clamp(1, n - 2) - 1;
        if let Some((phi, _)) = tls_normal(&points[a..a + 3]) {
            out.angles.push((phi, i as u32));
        }
    }
    out.angles.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
    crate::dbscan1d::dbscan1d_by(&out.angles, |a| a.0, &theta_params, &mut out.angle_clusters)?;
    let min_line = params.min_line_points.max(2);
    for c in 0..out.angle_clusters.n_clusters() as u32 {
        out.angle_clusters.members(c, &mut out.cluster_members);
        // Circular mean of angles with period pi: average the doubled angle.
        let (mut sc, mut ss) = (0.0, 0.0);
        for &m in &out.cluster_members {
            let a = 2.0 * out.angles[m].0;
            sc += a.cos();
            ss += a.sin();
        }
        let mean = 0.5 * ss.atan2(sc);
        let (cm, sm) = (mean.cos(), mean.sin());
        out.dists.clear();
        for &m in &out.cluster_members {
            let id = out.angles[m].1;
            let p = points[id as usize];
            out.dists.push((p[0] * cm + p[1] * sm, id));
        }
        recluster_in_place(
            &mut out.dists,
            |d| d.0,
            &dist_params,
            &mut out.dist_clusters,
        )?;
        for k in 0..out.dist_clusters.n_clusters() as u32 {
            out.dist_clusters.members(k, &mut out.sub_members);
            if out.sub_members.len() < min_line {
                continue;
            }
            let a = out.members.len();
            out.members
                .extend(out.sub_members.iter().map(|&m| out.dists[m].1));
            let Some(line) = fit_line(points, &out.members[a..]) else {
                out.members.truncate(a);
                continue;
            };
            let id = out.lines.len() as u32;
            for &m in &out.members[a..] {
                if out.labels[m as usize] == NOISE {
                    out.labels[m as usize] = id;
                }
            }
            out.lines.push(line);
            out.member_ranges.push((a, out.members.len()));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_wall_with_outlier() {
        // Wall y = 2 seen from the origin, one spike in the middle.
        let mut pts: Vec<[f64; 2]> = (0..40).map(|i| [-2.0 + 0.1 * i as f64, 2.0]).collect();
        pts[20] = [0.0, 1.0];
        let mut out = Segmentation::new();
        segment_scan(&pts, &LineParams::default(), &mut out).unwrap();
        assert_eq!(out.lines().len(), 1);
        let l = out.lines()[0];
        assert!((l.distance - 2.0).abs() < 1e-9, "{l:?}");
        assert!((l.normal_angle - PI / 2.0).abs() < 1e-9, "{l:?}");
        assert_eq!(out.labels()[20], NOISE);
        assert!(l.max_residual < 1e-9);
        assert!((l.length() - 3.9).abs() < 1e-9);
    }

    #[test]
    fn tiny_and_bad_input() {
        let mut out = Segmentation::new();
        segment_scan(&[[1.0, 1.0]], &LineParams::default(), &mut out).unwrap();
        assert!(out.lines().is_empty());
        let bad = [[0.0, 0.0], [f64::NAN, 1.0], [1.0, 1.0]];
        assert!(segment_scan(&bad, &LineParams::default(), &mut out).is_err());
        let p = LineParams {
            eps_theta: -1.0,
            ..LineParams::default()
        };
        assert!(matches!(
            segment_scan(&[], &p, &mut out),
            Err(SegmentError::InvalidParameter {
                name: "eps_theta",
                ..
            })
        ));
        // All points equal: no direction, no line, no panic.
        segment_scan(&[[1.0, 1.0]; 10], &LineParams::default(), &mut out).unwrap();
        assert!(out.lines().is_empty());
    }
}
