//! Line segments from one 2D laser scan by angular segmentation (Meglicki, arXiv:2103.16245).
//!
//! The steps, in the paper's order:
//!
//! 1. Each point gets a local normal angle from a total-least-squares (TLS) fit to itself and
//!    its two neighbours in beam order, taken modulo pi. Circular [`dbscan1d`](crate::dbscan1d)
//!    on the sorted angles groups points of parallel surfaces.
//! 2. Inside each angular group, the signed distances to the line through the origin with the
//!    group's mean normal are clustered again, which separates parallel walls.
//! 3. Optionally ([`LineParams::resegment`], the paper's first named shortcoming: close
//!    features merge), a distance cluster whose TLS fit leaves an rms residual above a bound is
//!    clustered once more on the same distances, with a stricter epsilon.
//! 4. Collinear lines separation (the paper's section 3.6, on by default): the points of each
//!    cluster are projected on the cluster's TLS line and clustered by that 1D position, so
//!    that one infinite line seen in pieces (a wall broken by a doorway) gives one segment per
//!    piece. The epsilon is [`LineParams::split_eps`], widened on sparse lines by
//!    [`LineParams::split_spacing_factor`] (our addition).
//!
//! Every final cluster becomes a [`Line`] with its own TLS fit.

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
    /// Neighbourhood radius of the collinear lines separation, metres along the line (default
    /// 0.5): members of one cluster farther apart than this along their fitted line, with no
    /// chain of members in between, become separate lines. `f64::INFINITY` turns the step off
    /// (the segmentation before this step existed).
    ///
    /// Our reading of the paper: its section 3.6 makes this step the last one of the angular
    /// segmentation itself (after the angle and distance steps), not an option, so it is on
    /// by default. The 0.5 m default is ours: about half a narrow doorway and several times
    /// the spacing of 1° beams along a wall seen from a few metres (9 cm at 5 m head-on), so
    /// doorways and gaps between pieces of furniture split a line while the sparser far ends
    /// of a wall seen at a grazing angle mostly do not.
    pub split_eps: f64,
    /// Core-point threshold of the collinear lines separation (default 2: a member with no
    /// other member within the epsilon along the line is noise). With 1 every member is a core
    /// point and the step only cuts the line at gaps wider than the epsilon.
    pub split_min_points: usize,
    /// Scale of the collinear separation's epsilon with the point spacing (default 3): the
    /// epsilon of a cluster is the larger of [`split_eps`](Self::split_eps) and this factor
    /// times the median spacing of the cluster's points along the line. 0 gives the paper's
    /// fixed epsilon.
    ///
    /// This is our addition: beams a fixed angle apart hit a wall farther apart the farther it
    /// is, and with a fixed 0.5 m a wall 20 m away (35 cm between 1° beams head-on, more at an
    /// angle) breaks into pieces too short to be lines; on the long-range Freiburg clinic log
    /// that lost a quarter of the points on lines. A doorway is still cut wherever it is wider
    /// than three beam spacings.
    pub split_spacing_factor: f64,
    /// Clusters with fewer points are not reported as lines (default 5, never below 2).
    pub min_line_points: usize,
    /// Border policy of every clustering step (default [`BorderPolicy::First`]).
    pub border: BorderPolicy,
    /// Re-segmentation of merged clusters with a stricter epsilon (default `None`: off).
    pub resegment: Option<Resegment>,
}

impl Default for LineParams {
    fn default() -> Self {
        Self {
            eps_theta: 2f64.to_radians(),
            min_points_theta: 5,
            eps_dist: 0.05,
            min_points_dist: 5,
            split_eps: 0.5,
            split_min_points: 2,
            split_spacing_factor: 3.0,
            min_line_points: 5,
            border: BorderPolicy::First,
            resegment: None,
        }
    }
}

/// Re-segmentation of a cluster that merged close parallel features (two walls a few
/// centimetres apart fall into one distance cluster when `eps_dist` exceeds their separation
/// minus the noise): the paper names this shortcoming and suggests re-segmenting such a cluster
/// with a stricter epsilon.
///
/// After the distance step, each distance cluster is fitted by TLS; when its rms residual
/// exceeds [`max_rms`](Self::max_rms), its members' distances (the distance step's values,
/// along the mean normal of their angular cluster) are clustered again with [`eps`](Self::eps) and [`min_points`](Self::min_points), once (no
/// recursion), and each resulting cluster goes on to the collinear separation. `max_rms` must
/// stay above the sensor's range noise, or clean but noisy walls get their tails cut off.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Resegment {
    /// Rms residual of the cluster's TLS fit above which it is re-clustered, metres (default
    /// 0.01).
    pub max_rms: f64,
    /// Neighbourhood radius of the re-clustering, metres (default 0.01; meant to be below
    /// [`LineParams::eps_dist`]).
    pub eps: f64,
    /// Core-point threshold of the re-clustering (default 5).
    pub min_points: usize,
}

impl Default for Resegment {
    fn default() -> Self {
        Self {
            max_rms: 0.01,
            eps: 0.01,
            min_points: 5,
        }
    }
}

/// The validated clustering parameters of every step.
struct Steps {
    theta: Dbscan1dParams,
    dist: Dbscan1dParams,
    /// `None` when the collinear separation is off; else its parameters with the smallest
    /// epsilon, and the spacing factor.
    split: Option<(Dbscan1dParams, f64)>,
    /// The rms bound and the re-clustering parameters, `None` when off.
    resegment: Option<(f64, Dbscan1dParams)>,
}

/// Rename the parameter of an [`SegmentError::InvalidParameter`] to the field it came from.
fn rename(name: &'static str) -> impl Fn(SegmentError) -> SegmentError {
    move |e: SegmentError| match e {
        SegmentError::InvalidParameter { value, reason, .. } => SegmentError::InvalidParameter {
            name,
            value,
            reason,
        },
        other => other,
    }
}

/// A `min_points` field, rejected when 0.
fn at_least_one(name: &'static str, v: usize) -> Result<usize, SegmentError> {
    if v == 0 {
        return Err(SegmentError::InvalidParameter {
            name,
            value: 0.0,
            reason: "must be at least 1",
        });
    }
    Ok(v)
}

impl LineParams {
    /// The angle and distance clustering parameter sets, or an error naming the bad field.
    /// Every other field is checked too.
    pub fn validate(&self) -> Result<(Dbscan1dParams, Dbscan1dParams), SegmentError> {
        let steps = self.steps()?;
        Ok((steps.theta, steps.dist))
    }

    fn steps(&self) -> Result<Steps, SegmentError> {
        let theta = Dbscan1dParams::new(
            self.eps_theta,
            at_least_one("min_points_theta", self.min_points_theta)?,
        )
        .map_err(rename("eps_theta"))?
        .with_border(self.border)
        .with_period(PI)?;
        let dist = Dbscan1dParams::new(
            self.eps_dist,
            at_least_one("min_points_dist", self.min_points_dist)?,
        )
        .map_err(rename("eps_dist"))?
        .with_border(self.border);
        let split_min = at_least_one("split_min_points", self.split_min_points)?;
        let factor = self.split_spacing_factor;
        if !(factor.is_finite() && factor >= 0.0) {
            return Err(SegmentError::InvalidParameter {
                name: "split_spacing_factor",
                value: factor,
                reason: "must be finite and >= 0",
            });
        }
        let split = if self.split_eps == f64::INFINITY {
            None
        } else {
            let p = Dbscan1dParams::new(self.split_eps, split_min)
                .map_err(rename("split_eps"))?
                .with_border(self.border);
            Some((p, factor))
        };
        let resegment = match self.resegment {
            None => None,
            Some(r) => {
                if !(r.max_rms.is_finite() && r.max_rms >= 0.0) {
                    return Err(SegmentError::InvalidParameter {
                        name: "resegment.max_rms",
                        value: r.max_rms,
                        reason: "must be finite and >= 0",
                    });
                }
                let p =
                    Dbscan1dParams::new(r.eps, at_least_one("resegment.min_points", r.min_points)?)
                        .map_err(rename("resegment.eps"))?
                        .with_border(self.border);
                Some((r.max_rms, p))
            }
        };
        Ok(Steps {
            theta,
            dist,
            split,
            resegment,
        })
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
    found: Found,
    angles: Vec<(f64, u32)>,
    dists: Vec<(f64, u32)>,
    angle_clusters: Clustering,
    dist_clusters: Clustering,
    cluster_members: Vec<usize>,
    sub_members: Vec<usize>,
    /// Point ids of the distance cluster being refined.
    group: Vec<u32>,
    refine: Refine,
}

/// The output of [`segment_scan`]: lines, their members and the label of every point.
#[derive(Clone, Debug, Default)]
pub(crate) struct Found {
    lines: Vec<Line>,
    labels: Vec<u32>,
    members: Vec<u32>,
    member_ranges: Vec<(usize, usize)>,
}

/// Scratch of the re-segmentation step.
#[derive(Clone, Debug, Default)]
struct Refine {
    values: Vec<(f64, u32)>,
    clusters: Clustering,
    members: Vec<usize>,
    /// Point ids of the re-segmented cluster being split.
    sub: Vec<u32>,
    split: Split,
}

/// Scratch of the collinear separation step.
#[derive(Clone, Debug, Default)]
struct Split {
    along: Vec<(f64, u32)>,
    gaps: Vec<f64>,
    clusters: Clustering,
    members: Vec<usize>,
    ids: Vec<u32>,
}

impl Segmentation {
    /// An empty result; pass it to [`segment_scan`] and reuse it across scans.
    pub fn new() -> Self {
        Self::default()
    }

    /// The fitted lines, in the order found: by local angle, then by distance, then by
    /// position along the line.
    pub fn lines(&self) -> &[Line] {
        &self.found.lines
    }

    /// Line of each input point, [`NOISE`] for points on no line (the first line when a
    /// border point belongs to two under [`BorderPolicy::All`]).
    pub fn labels(&self) -> &[u32] {
        &self.found.labels
    }

    /// Indices (into the input points) of the members of line `k`; empty when out of range.
    pub fn line_members(&self, k: usize) -> &[u32] {
        match self.found.member_ranges.get(k) {
            Some(&(a, b)) => &self.found.members[a..b],
            None => &[],
        }
    }

    /// The local normal angle of every point in `[0, pi)`, sorted, with its point index
    /// (empty after the other extractors, which compute none).
    pub fn local_angles(&self) -> &[(f64, u32)] {
        &self.angles
    }

    /// Check `points` and clear the result for them, for another line extractor; returns the
    /// output to fill.
    pub(crate) fn start(&mut self, points: &[[f64; 2]]) -> Result<&mut Found, SegmentError> {
        self.found.clear(0);
        self.angles.clear();
        check_points(points)?;
        self.found.clear(points.len());
        Ok(&mut self.found)
    }
}

/// Errors on a non-finite coordinate or more points than the `u32` labels address.
fn check_points(points: &[[f64; 2]]) -> Result<(), SegmentError> {
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
    Ok(())
}

impl Found {
    fn clear(&mut self, n: usize) {
        self.lines.clear();
        self.members.clear();
        self.member_ranges.clear();
        self.labels.clear();
        self.labels.resize(n, NOISE);
    }

    /// Fit the points `ids` and record them as the next line (nothing when they coincide).
    pub(crate) fn emit(&mut self, points: &[[f64; 2]], ids: &[u32]) {
        let a = self.members.len();
        self.members.extend_from_slice(ids);
        let Some(line) = fit_line(points, &self.members[a..]) else {
            self.members.truncate(a);
            return;
        };
        let id = self.lines.len() as u32;
        for &m in &self.members[a..] {
            if self.labels[m as usize] == NOISE {
                self.labels[m as usize] = id;
            }
        }
        self.lines.push(line);
        self.member_ranges.push((a, self.members.len()));
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
pub(crate) fn fit_line(pts: &[[f64; 2]], idx: &[u32]) -> Option<Line> {
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
    if !(sxx + syy > 0.0 && (sxx + syy).is_finite()) {
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
    let steps = params.steps()?;
    out.start(points)?;
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
    crate::dbscan1d::dbscan1d_by(&out.angles, |a| a.0, &steps.theta, &mut out.angle_clusters)?;
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
        recluster_in_place(&mut out.dists, |d| d.0, &steps.dist, &mut out.dist_clusters)?;
        for k in 0..out.dist_clusters.n_clusters() as u32 {
            out.dist_clusters.members(k, &mut out.sub_members);
            // Later steps only shrink clusters: a small one can give no line.
            if out.sub_members.len() < min_line {
                continue;
            }
            out.group.clear();
            out.group
                .extend(out.sub_members.iter().map(|&m| out.dists[m].1));
            resegment(
                points,
                &out.group,
                [cm, sm],
                &steps,
                min_line,
                &mut out.refine,
                &mut out.found,
            )?;
        }
    }
    Ok(())
}

/// Step 3: when the TLS fit of `ids` is poor, cluster their distances along `normal` (the
/// angular cluster's mean normal, as in step 2) again with the stricter epsilon; then pass
/// each part (or `ids` whole) to the collinear separation.
///
/// The distances are taken along the mean normal of the local angles rather than the TLS
/// normal: a TLS fit of two side-by-side parallel walls tilts to pass between them, and the
/// distances along its normal then overlap; the local angles mostly see the walls themselves.
fn resegment(
    points: &[[f64; 2]],
    ids: &[u32],
    normal: [f64; 2],
    steps: &Steps,
    min_line: usize,
    scratch: &mut Refine,
    found: &mut Found,
) -> Result<(), SegmentError> {
    let Some((max_rms, params)) = steps.resegment else {
        return split(
            points,
            ids,
            steps.split,
            min_line,
            &mut scratch.split,
            found,
        );
    };
    let Some(fit) = fit_line(points, ids) else {
        return Ok(());
    };
    if fit.rms_residual <= max_rms {
        return split(
            points,
            ids,
            steps.split,
            min_line,
            &mut scratch.split,
            found,
        );
    }
    scratch.values.clear();
    scratch.values.extend(ids.iter().map(|&i| {
        let p = points[i as usize];
        (p[0] * normal[0] + p[1] * normal[1], i)
    }));
    recluster_in_place(&mut scratch.values, |v| v.0, &params, &mut scratch.clusters)?;
    for k in 0..scratch.clusters.n_clusters() as u32 {
        scratch.clusters.members(k, &mut scratch.members);
        if scratch.members.len() < min_line {
            continue;
        }
        scratch.sub.clear();
        scratch
            .sub
            .extend(scratch.members.iter().map(|&m| scratch.values[m].1));
        split(
            points,
            &scratch.sub,
            steps.split,
            min_line,
            &mut scratch.split,
            found,
        )?;
    }
    Ok(())
}

/// Step 4, collinear lines separation: cluster `ids` by their position along their TLS line
/// and emit every part of at least `min_line` points as a line (`ids` whole when the step is
/// off).
///
/// The epsilon is the larger of `split_eps` and the spacing factor times the lower median of
/// the gaps between consecutive sorted positions.
fn split(
    points: &[[f64; 2]],
    ids: &[u32],
    params: Option<(Dbscan1dParams, f64)>,
    min_line: usize,
    scratch: &mut Split,
    found: &mut Found,
) -> Result<(), SegmentError> {
    let Some((params, factor)) = params else {
        found.emit(points, ids);
        return Ok(());
    };
    let Some(fit) = fit_line(points, ids) else {
        return Ok(());
    };
    // Position along the line direction (-sin, cos) of the normal, as in `fit_line`.
    let (s, c) = fit.normal_angle.sin_cos();
    scratch.along.clear();
    scratch.along.extend(ids.iter().map(|&i| {
        let p = points[i as usize];
        (-p[0] * s + p[1] * c, i)
    }));
    scratch
        .along
        .sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    scratch.gaps.clear();
    scratch
        .gaps
        .extend(scratch.along.windows(2).map(|w| w[1].0 - w[0].0));
    let mut eps = params.eps();
    if factor > 0.0 && !scratch.gaps.is_empty() {
        let mid = (scratch.gaps.len() - 1) / 2;
        let (_, median, _) = scratch.gaps.select_nth_unstable_by(mid, f64::total_cmp);
        let scaled = factor * *median;
        if scaled > eps {
            eps = scaled;
        }
    }
    let border = params.border();
    let Ok(params) = Dbscan1dParams::new(eps, params.min_points()) else {
        // Positions so far apart that the scaled epsilon overflows: nothing to separate by.
        found.emit(points, ids);
        return Ok(());
    };
    let params = params.with_border(border);
    crate::dbscan1d::dbscan1d_by(&scratch.along, |v| v.0, &params, &mut scratch.clusters)?;
    for k in 0..scratch.clusters.n_clusters() as u32 {
        scratch.clusters.members(k, &mut scratch.members);
        if scratch.members.len() < min_line {
            continue;
        }
        scratch.ids.clear();
        scratch
            .ids
            .extend(scratch.members.iter().map(|&m| scratch.along[m].1));
        found.emit(points, &scratch.ids);
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
