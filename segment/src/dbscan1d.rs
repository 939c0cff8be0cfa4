//! DBSCAN on sorted 1D data in linear time (Meglicki, "Linear time DBSCAN for sorted 1D data
//! and laser range scan segmentation", arXiv:2103.16245).
//!
//! On sorted data every epsilon-neighbourhood is a contiguous index range. Two monotone pointers
//! give the range of every point, so the neighbourhood size (and the core test) is O(1) per
//! point. Core points that are neighbours of the next core point form one cluster, so clusters
//! are runs of consecutive cores; the members of a cluster are the index range from the first
//! neighbour of its first core to the last neighbour of its last core. Everything is O(N),
//! whatever epsilon and `min_points`.
//!
//! For linear data the constant does not depend on epsilon either: the ranges come from one
//! branch-free merge walk (`bounds_linear`) and the core flags, clusters and labels from one
//! sweep over them (`sweep_linear`), so every point costs the same whether it ends up noise
//! or deep inside a cluster; only the start of each cluster takes a branch.
//!
//! Circular data (angles with any period) is handled with virtual indices: index `t` outside
//! `0..n` stands for point `t mod n` shifted by whole periods, so a neighbourhood or a cluster
//! that crosses the seam is still one contiguous virtual range.

use crate::error::SegmentError;

/// Label of a point that belongs to no cluster.
pub const NOISE: u32 = u32::MAX;

/// What happens to border points: non-core points within epsilon of a core point.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BorderPolicy {
    /// The first cluster that reaches the point, in the order the original DBSCAN (Ester et
    /// al. 1996) discovers clusters when it visits points in index order. The default.
    #[default]
    First,
    /// Every cluster that reaches the point (at most two in 1D); see [`Clustering::second_label`].
    All,
    /// Border points are noise; clusters hold only core points (DBSCAN*, Campello et al. 2013).
    Noise,
}

/// Validated DBSCAN1D parameters.
///
/// Two points are neighbours when their distance is at most `eps`; a point is a core point when
/// its neighbourhood, itself included, holds at least `min_points` points. With a period `P` the
/// distance between `a <= b` is `min(b - a, (a + P) - b)`, computed exactly in that form.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dbscan1dParams {
    eps: f64,
    min_points: usize,
    border: BorderPolicy,
    period: Option<f64>,
}

impl Dbscan1dParams {
    /// Parameters for linear (non-circular) data with [`BorderPolicy::First`].
    ///
    /// `eps` must be finite and `>= 0`; `min_points` must be at least 1.
    pub fn new(eps: f64, min_points: usize) -> Result<Self, SegmentError> {
        if !(eps.is_finite() && eps >= 0.0) {
            return Err(SegmentError::InvalidParameter {
                name: "eps",
                value: eps,
                reason: "must be finite and >= 0",
            });
        }
        if min_points == 0 {
            return Err(SegmentError::InvalidParameter {
                name: "min_points",
                value: 0.0,
                reason: "must be at least 1",
            });
        }
        Ok(Self {
            eps,
            min_points,
            border: BorderPolicy::First,
            period: None,
        })
    }

    /// The same parameters with another border policy.
    pub fn with_border(mut self, border: BorderPolicy) -> Self {
        self.border = border;
        self
    }

    /// The same parameters for circular data of the given period; values must lie in
    /// `[0, period)`. `period` must be finite and `> 0`.
    pub fn with_period(mut self, period: f64) -> Result<Self, SegmentError> {
        if !(period.is_finite() && period > 0.0) {
            return Err(SegmentError::InvalidParameter {
                name: "period",
                value: period,
                reason: "must be finite and > 0",
            });
        }
        self.period = Some(period);
        Ok(self)
    }

    /// Neighbourhood radius.
    pub fn eps(&self) -> f64 {
        self.eps
    }

    /// Minimum neighbourhood size (the point itself included) of a core point.
    pub fn min_points(&self) -> usize {
        self.min_points
    }

    /// What happens to border points.
    pub fn border(&self) -> BorderPolicy {
        self.border
    }

    /// The period of circular data, `None` for linear data.
    pub fn period(&self) -> Option<f64> {
        self.period
    }
}

/// The result of [`dbscan1d`], and the buffers it reuses on the next call.
///
/// Cluster ids are `0..n_clusters()` in the order the original DBSCAN discovers them when it
/// visits points in index order (the cluster holding the lowest-index core point is 0).
///
/// The per-point buffers keep the largest size seen and are overwritten, not cleared, by the next
/// call, so reusing one `Clustering` costs no allocation and no extra pass over memory.
#[derive(Clone, Debug, Default)]
pub struct Clustering {
    n: usize,
    border: BorderPolicy,
    /// Per point `i`: `i - ` the virtual index of its first neighbour.
    back: Vec<u32>,
    /// Per point `i`: the virtual index of its last neighbour `- i`.
    fwd: Vec<u32>,
    core: Vec<bool>,
    labels: Vec<u32>,
    second: Vec<u32>,
    /// Circular data only: per cluster, virtual index of its first and last core point.
    runs: Vec<(i64, i64)>,
    /// Per cluster: virtual index range `[start, end]` of the points it reaches.
    ranges: Vec<(i64, i64)>,
}

impl Clustering {
    /// An empty result; pass it to [`dbscan1d`] and reuse it across calls.
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of points clustered by the last call.
    pub fn len(&self) -> usize {
        self.n
    }

    /// `true` when the last call had no points.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Number of clusters found.
    pub fn n_clusters(&self) -> usize {
        self.ranges.len()
    }

    /// Cluster of each point, [`NOISE`] for noise. Under [`BorderPolicy::All`] a border point
    /// reached by two clusters carries the lower id here and the other in [`Self::second_label`].
    pub fn labels(&self) -> &[u32] {
        &self.labels[..self.n]
    }

    /// Cluster of point `i`, `None` for noise or an index out of range.
    pub fn label(&self, i: usize) -> Option<u32> {
        self.labels().get(i).copied().filter(|&l| l != NOISE)
    }

    /// Under [`BorderPolicy::All`], the second cluster of a border point reached by two
    /// clusters; `None` otherwise (in 1D no point is reached by more than two clusters).
    pub fn second_label(&self, i: usize) -> Option<u32> {
        if self.border != BorderPolicy::All || i >= self.n {
            return None;
        }
        self.second.get(i).copied().filter(|&l| l != NOISE)
    }

    /// Whether point `i` is a core point (`false` out of range).
    pub fn is_core(&self, i: usize) -> bool {
        self.core().get(i).copied().unwrap_or(false)
    }

    /// Core flag of every point.
    pub fn core(&self) -> &[bool] {
        &self.core[..self.n]
    }

    /// Size of the epsilon-neighbourhood of point `i`, itself included (0 out of range).
    pub fn neighbour_count(&self, i: usize) -> usize {
        if i >= self.n {
            return 0;
        }
        (self.back[i] as usize + self.fwd[i] as usize + 1).min(self.n)
    }

    /// Number of points labelled noise.
    pub fn noise_count(&self) -> usize {
        self.labels().iter().filter(|&&l| l == NOISE).count()
    }

    /// Indices of the members of cluster `c`, in (circular) index order starting from the
    /// cluster's first point, appended to `out` after clearing it. Linear in the cluster size.
    pub fn members(&self, c: u32, out: &mut Vec<usize>) {
        out.clear();
        let Some(&(start, end)) = self.ranges.get(c as usize) else {
            return;
        };
        let n = self.n as i64;
        for t in start..=end {
            let j = t.rem_euclid(n) as usize;
            let member = match self.border {
                BorderPolicy::First => self.labels[j] == c,
                BorderPolicy::All => true,
                BorderPolicy::Noise => self.core[j],
            };
            if member {
                out.push(j);
            }
        }
    }

    /// Make room for `n` points. Buffers only grow; their old contents are left in place,
    /// since every call overwrites the first `n` entries of each.
    fn reset(&mut self, n: usize, border: BorderPolicy) {
        self.n = n;
        self.border = border;
        grow(&mut self.back, n, 0);
        grow(&mut self.fwd, n, 0);
        grow(&mut self.core, n, false);
        grow(&mut self.labels, n, NOISE);
        if border == BorderPolicy::All {
            self.second.clear();
            self.second.resize(n, NOISE);
        }
        self.runs.clear();
        self.ranges.clear();
    }
}

fn grow<T: Copy>(v: &mut Vec<T>, len: usize, fill: T) {
    if v.len() < len {
        v.resize(len, fill);
    }
}

/// Cluster sorted values `x` with DBSCAN in O(N), writing into `out` (buffers are reused).
///
/// Errors when a value is not finite, `x` is not sorted, or (circular) a value is outside
/// `[0, period)`; `out` is then left empty.
///
/// ```
/// use octoquant_segment::{dbscan1d, Clustering, Dbscan1dParams, NOISE};
/// let x = [0.0, 0.1, 0.2, 5.0, 9.0, 9.1, 9.2];
/// let mut out = Clustering::new();
/// dbscan1d(&x, &Dbscan1dParams::new(0.15, 2).unwrap(), &mut out).unwrap();
/// assert_eq!(out.labels(), &[0, 0, 0, NOISE, 1, 1, 1]);
/// ```
pub fn dbscan1d(
    x: &[f64],
    params: &Dbscan1dParams,
    out: &mut Clustering,
) -> Result<(), SegmentError> {
    dbscan1d_by(x, |v| *v, params, out)
}

/// [`dbscan1d`] on items sorted by `key`, for clustering records without copying their keys.
pub fn dbscan1d_by<T, F>(
    items: &[T],
    key: F,
    params: &Dbscan1dParams,
    out: &mut Clustering,
) -> Result<(), SegmentError>
where
    F: Fn(&T) -> f64,
{
    out.reset(0, params.border);
    validate(items, &key, params)?;
    let n = items.len();
    out.reset(n, params.border);
    if n == 0 {
        return Ok(());
    }
    match params.period {
        None => {
            bounds_linear(items, &key, params.eps, &mut out.back, &mut out.fwd);
            sweep_linear(out, params.min_points);
        }
        Some(p) => {
            bounds_circular(&|i: usize| key(&items[i]), n, p, params.eps, out);
            let nn = n as i64;
            for i in 0..n {
                let count = (out.back[i] as i64 + out.fwd[i] as i64 + 1).min(nn);
                out.core[i] = count >= params.min_points as i64;
            }
            out.labels[..n].fill(NOISE);
            find_runs_circular(out);
            assign_circular(out);
        }
    }
    Ok(())
}

/// Re-cluster a group of items in place: sort `items` by `key`, then run [`dbscan1d_by`].
///
/// This is how one cluster is split again on another quantity (the laser segmentation sorts
/// each angular cluster by distance) without copying it out of its buffer.
pub fn recluster_in_place<T, F>(
    items: &mut [T],
    key: F,
    params: &Dbscan1dParams,
    out: &mut Clustering,
) -> Result<(), SegmentError>
where
    F: Fn(&T) -> f64,
{
    items.sort_unstable_by(|a, b| key(a).total_cmp(&key(b)));
    dbscan1d_by(items, key, params, out)
}

fn validate<T, F>(items: &[T], key: &F, params: &Dbscan1dParams) -> Result<(), SegmentError>
where
    F: Fn(&T) -> f64,
{
    if items.len() >= NOISE as usize {
        return Err(SegmentError::TooManyPoints {
            len: items.len(),
            max: NOISE as usize - 1,
        });
    }
    // A branch-free scan says whether anything is wrong; only then find the first culprit.
    let period = params.period.unwrap_or(f64::INFINITY);
    let lower = if params.period.is_some() {
        0.0
    } else {
        f64::NEG_INFINITY
    };
    let mut prev = f64::NEG_INFINITY;
    let mut bad = false;
    for item in items {
        let value = key(item);
        bad |= !value.is_finite() | (value < prev) | (value < lower) | (value >= period);
        prev = value;
    }
    if !bad {
        return Ok(());
    }
    let mut prev = f64::NEG_INFINITY;
    for (index, item) in items.iter().enumerate() {
        let value = key(item);
        if !value.is_finite() {
            return Err(SegmentError::NonFinite { index, value });
        }
        if value < prev {
            return Err(SegmentError::NotSorted { index });
        }
        if let Some(period) = params.period {
            if !(0.0..period).contains(&value) {
                return Err(SegmentError::OutOfPeriod {
                    index,
                    value,
                    period,
                });
            }
        }
        prev = value;
    }
    Ok(())
}

/// Independent merge walks interleaved by [`bounds_linear`], so that the processor overlaps
/// their dependency chains.
const STREAMS: usize = 4;

/// First and last neighbour of every point, as `back` and `fwd` offsets, in one branch-free
/// merge walk.
///
/// Point `j` is outside the neighbourhood of a later point `i` when `x[i] - x[j] > eps`. Walking
/// two pointers `j <= i` upward, each step either finds that `j` has left `i`'s neighbourhood
/// (so `j`'s last neighbour is `i - 1`; `j` advances) or that `j` is `i`'s first neighbour (`i`
/// advances). Each step stores both candidate offsets and advances one pointer by a 0/1 flag, so
/// it has no data-dependent branch and costs the same whatever `eps`; the walk takes `2N` steps.
/// The index range is split into [`STREAMS`] contiguous parts walked in lockstep.
fn bounds_linear<T>(
    items: &[T],
    key: &impl Fn(&T) -> f64,
    eps: f64,
    back: &mut [u32],
    fwd: &mut [u32],
) {
    // One length for all three lets one bounds check cover a load and a store.
    let n = items.len();
    let (back, fwd) = (&mut back[..n], &mut fwd[..n]);
    let k = |i: usize| key(&items[i]);
    // First neighbour of point i by binary search (the predicate is monotone in j).
    let first_neighbour = |i: usize| -> usize {
        let (mut a, mut b) = (0, i);
        let ki = k(i);
        while a < b {
            let mid = (a + b) / 2;
            if ki - k(mid) > eps {
                a = mid + 1;
            } else {
                b = mid;
            }
        }
        a
    };
    let mut i = [0usize; STREAMS];
    let mut j = [0usize; STREAMS];
    let mut end = [0usize; STREAMS];
    for s in 0..STREAMS {
        i[s] = s * n / STREAMS;
        end[s] = (s + 1) * n / STREAMS;
        j[s] = first_neighbour(i[s]);
    }
    // Where each walk's `j` must end: the first neighbour of the next part's first point.
    let mut j_end = [n; STREAMS];
    j_end[..STREAMS - 1].copy_from_slice(&j[1..]);
    // Both offsets are stored at every step; the last store to each is the right one.
    let step = |i: &mut usize, j: &mut usize, back: &mut [u32], fwd: &mut [u32]| {
        let (a, b) = (*i, *j);
        let out = k(a) - k(b) > eps;
        fwd[b] = a.wrapping_sub(1).wrapping_sub(b) as u32;
        back[a] = (a - b) as u32;
        *i = a + usize::from(!out);
        *j = b + usize::from(out);
    };
    // Every walk takes at least `end - i` more steps, so that many run safely in lockstep.
    loop {
        let steps = (0..STREAMS).map(|s| end[s] - i[s]).min().unwrap_or(0);
        if steps == 0 {
            break;
        }
        for _ in 0..steps {
            for s in 0..STREAMS {
                step(&mut i[s], &mut j[s], back, fwd);
            }
        }
    }
    for s in 0..STREAMS {
        while i[s] < end[s] {
            step(&mut i[s], &mut j[s], back, fwd);
        }
        // The points this walk's `j` has not passed reach exactly to the end of its part.
        for (t, f) in (j[s]..).zip(&mut fwd[j[s]..j_end[s]]) {
            *f = (end[s] - 1 - t) as u32;
        }
    }
    // A walk's last `j` may be the next part's first one, and its stores there may have come
    // after the right one: redo those few by binary search (the predicate is monotone in i).
    for &t in &j_end[..STREAMS - 1] {
        if t < n {
            let (mut a, mut b) = (t, n);
            let kt = k(t);
            while a < b {
                let mid = (a + b) / 2;
                if k(mid) - kt > eps {
                    b = mid;
                } else {
                    a = mid + 1;
                }
            }
            fwd[t] = (a - 1 - t) as u32;
        }
    }
}

/// One sweep over the neighbourhood bounds: core flags, clusters and labels together.
///
/// A cluster is a maximal run of core points each a neighbour of the next; a new one starts at
/// a core point whose neighbourhood does not reach back to the previous core point. A point is
/// labelled with the current cluster when the last core point so far reaches it. The only points
/// this misses are those reached first by the first core point of the next cluster: they lie
/// between the previous cluster's reach and that core point, and are filled when it starts
/// (under [`BorderPolicy::All`] the previous cluster's border points it reaches get it as their
/// second label). Per point the work is the same whatever `eps`, with no data-dependent branch
/// but the rare one that starts a cluster.
fn sweep_linear(out: &mut Clustering, min_points: usize) {
    match out.border {
        BorderPolicy::First => sweep_linear_as::<false, false>(out, min_points),
        BorderPolicy::All => sweep_linear_as::<false, true>(out, min_points),
        BorderPolicy::Noise => sweep_linear_as::<true, false>(out, min_points),
    }
}

/// [`sweep_linear`] for one border policy: border points are noise (`NOISE_BORDER`), or also
/// get a second label (`SECOND`), or neither (first cluster wins).
fn sweep_linear_as<const NOISE_BORDER: bool, const SECOND: bool>(
    out: &mut Clustering,
    min_points: usize,
) {
    let n = out.n;
    let min_points = min_points as i64;
    let back = &out.back[..n];
    let fwd = &out.fwd[..n];
    let core = &mut out.core[..n];
    let labels = &mut out.labels[..n];
    let second = &mut out.second;
    let ranges = &mut out.ranges;
    // Current cluster id (NOISE before the first), its first point, how far its core points
    // reach, and the last core point so far (-1 before the first).
    let mut cid = NOISE;
    let mut start = 0i64;
    let mut reach = -1i64;
    let mut last_core = -1i64;
    for i in 0..n {
        let (b, f) = (i64::from(back[i]), i64::from(fwd[i]));
        let ii = i as i64;
        let lo = ii - b;
        let is_core = b + f + 1 >= min_points;
        // All ones for a core point: the updates below are arithmetic, not branches.
        let mask = -i64::from(is_core);
        if (lo - last_core) & mask > 0 {
            if cid != NOISE {
                ranges.push((start, reach));
            }
            cid = cid.wrapping_add(1);
            start = lo;
            if !NOISE_BORDER {
                // Points the previous cluster did not reach: this cluster reaches them first.
                labels[(reach + 1).max(lo) as usize..i].fill(cid);
                if SECOND && reach >= lo {
                    second[lo as usize..=reach as usize].fill(cid);
                }
            }
        }
        last_core += (ii - last_core) & mask;
        reach += (ii + f - reach) & mask;
        let labelled = if NOISE_BORDER {
            is_core
        } else {
            last_core >= lo
        };
        labels[i] = if labelled { cid } else { NOISE };
        core[i] = is_core;
    }
    if cid != NOISE {
        ranges.push((start, reach));
    }
}

/// The circular version of the bounds: virtual index `t` is point `t mod n` shifted by whole
/// periods. The backward range covers `i-n+1..=i`, the forward one `i..=i+n-1`; when they overlap
/// the neighbourhood is the whole circle.
fn bounds_circular(k: &impl Fn(usize) -> f64, n: usize, p: f64, eps: f64, out: &mut Clustering) {
    let nn = n as i64;
    // Distance from virtual t (t <= i) back to i, in the canonical min(b - a, (a + P) - b) forms.
    let back = |i: usize, t: i64| -> f64 {
        if t >= 0 {
            k(i) - k(t as usize)
        } else {
            (k(i) + p) - k((t + nn) as usize)
        }
    };
    // Distance from i forward to virtual t (t >= i).
    let fwd = |i: usize, t: i64| -> f64 {
        if t < nn {
            k(t as usize) - k(i)
        } else {
            (k((t - nn) as usize) + p) - k(i)
        }
    };
    let mut j: i64 = 1 - nn;
    for i in 0..n {
        let ii = i as i64;
        j = j.max(ii - nn + 1);
        while j < ii && back(i, j) > eps {
            j += 1;
        }
        out.back[i] = (ii - j) as u32;
    }
    let mut j: i64 = 0;
    for i in 0..n {
        let ii = i as i64;
        j = j.max(ii);
        while j < ii + nn - 1 && fwd(i, j + 1) <= eps {
            j += 1;
        }
        out.fwd[i] = (j - ii) as u32;
    }
}

/// Circular clusters: maximal runs of consecutive core points each a direct neighbour (without
/// crossing the seam) of the next; the last run joins the first if its last core reaches the
/// first core across the seam. Consecutive cores that are neighbours only the long way round
/// lie, with every other core, in one arc of length `<= eps` over the seam, so this seam join
/// finds them too.
fn find_runs_circular(out: &mut Clustering) {
    let n = out.n;
    let mut prev: Option<usize> = None;
    for i in 0..n {
        if !out.core[i] {
            continue;
        }
        let lo = i as i64 - i64::from(out.back[i]);
        match prev {
            Some(p) if p as i64 >= lo => {
                let c = out.runs.len() - 1;
                out.runs[c].1 = i as i64;
                out.labels[i] = c as u32;
            }
            _ => {
                out.labels[i] = out.runs.len() as u32;
                out.runs.push((i as i64, i as i64));
            }
        }
        prev = Some(i);
    }
    if out.runs.len() > 1 {
        let first = out.runs[0].0 as usize;
        let (last_start, last_end) = out.runs[out.runs.len() - 1];
        let last_hi = last_end + i64::from(out.fwd[last_end as usize]);
        if first as i64 + n as i64 <= last_hi {
            for t in last_start..=last_end {
                if out.core[t as usize] {
                    out.labels[t as usize] = 0;
                }
            }
            out.runs.pop();
            out.runs[0].0 = last_start - n as i64;
        }
    }
}

/// Circular member ranges per cluster, then border labels by policy, in cluster order.
fn assign_circular(out: &mut Clustering) {
    let n = out.n as i64;
    let lo_of = |out: &Clustering, t: i64| {
        let j = t.rem_euclid(n) as usize;
        j as i64 - i64::from(out.back[j]) + t.div_euclid(n) * n
    };
    let hi_of = |out: &Clustering, t: i64| {
        let j = t.rem_euclid(n) as usize;
        j as i64 + i64::from(out.fwd[j]) + t.div_euclid(n) * n
    };
    for c in 0..out.runs.len() {
        let (first, last) = out.runs[c];
        let start = lo_of(out, first);
        let end = hi_of(out, last).min(start + n - 1);
        out.ranges.push((start, end));
    }
    if out.border == BorderPolicy::Noise {
        return;
    }
    for c in 0..out.ranges.len() {
        let (start, end) = out.ranges[c];
        let c = c as u32;
        for t in start..=end {
            let j = t.rem_euclid(n) as usize;
            if out.labels[j] == NOISE {
                out.labels[j] = c;
            } else if out.labels[j] != c && out.border == BorderPolicy::All && !out.core[j] {
                out.second[j] = c;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn run(x: &[f64], p: Dbscan1dParams) -> Clustering {
        let mut out = Clustering::new();
        dbscan1d(x, &p, &mut out).unwrap();
        out
    }

    #[test]
    fn paper_circular_example() {
        let x = [0.0, PI / 4.0, PI, 7.0 * PI / 4.0];
        let p = Dbscan1dParams::new(PI / 2.0, 3)
            .unwrap()
            .with_period(2.0 * PI)
            .unwrap();
        let out = run(&x, p);
        assert_eq!(out.labels(), &[0, 0, NOISE, 0]);
        assert_eq!(out.core(), &[true, true, false, true]);
        let mut m = Vec::new();
        out.members(0, &mut m);
        assert_eq!(m, vec![3, 0, 1]);
    }

    #[test]
    fn border_policies_on_shared_border() {
        // Evenly spaced: every interior point is core, so everything is one cluster.
        let x = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        let base = Dbscan1dParams::new(1.0, 3).unwrap();
        // Every point with two neighbours is core, so 3.0 is core: all one cluster.
        assert_eq!(run(&x, base).n_clusters(), 1);
        // Two dense groups; 1.8 has only 0.9 and 2.7 as neighbours: a border of both.
        let x = [0.0, 0.3, 0.6, 0.9, 1.8, 2.7, 3.0, 3.3, 3.6];
        let base = Dbscan1dParams::new(1.0, 4).unwrap();
        let out = run(&x, base);
        let mut core = [true; 9];
        core[4] = false;
        assert_eq!(out.core(), &core);
        assert_eq!(out.labels(), &[0, 0, 0, 0, 0, 1, 1, 1, 1]);
        let out = run(&x, base.with_border(BorderPolicy::All));
        assert_eq!(out.label(4), Some(0));
        assert_eq!(out.second_label(4), Some(1));
        let mut m = Vec::new();
        out.members(1, &mut m);
        assert_eq!(m, vec![4, 5, 6, 7, 8]);
        let out = run(&x, base.with_border(BorderPolicy::Noise));
        assert_eq!(out.label(4), None);
    }

    #[test]
    fn rejects_bad_input() {
        let p = Dbscan1dParams::new(1.0, 2).unwrap();
        let mut out = Clustering::new();
        assert_eq!(
            dbscan1d(&[1.0, 0.0], &p, &mut out),
            Err(SegmentError::NotSorted { index: 1 })
        );
        assert!(matches!(
            dbscan1d(&[0.0, f64::NAN], &p, &mut out),
            Err(SegmentError::NonFinite { index: 1, .. })
        ));
        let pc = p.with_period(1.0).unwrap();
        assert!(matches!(
            dbscan1d(&[0.0, 1.0], &pc, &mut out),
            Err(SegmentError::OutOfPeriod { index: 1, .. })
        ));
        assert!(Dbscan1dParams::new(-1.0, 2).is_err());
        assert!(Dbscan1dParams::new(1.0, 0).is_err());
        assert!(p.with_period(0.0).is_err());
        assert!(out.is_empty());
    }

    #[test]
    fn recluster_sorts_in_place() {
        let mut items = [(3.0, 'a'), (0.0, 'b'), (3.1, 'c'), (0.1, 'd')];
        let mut out = Clustering::new();
        let p = Dbscan1dParams::new(0.2, 2).unwrap();
        recluster_in_place(&mut items, |t| t.0, &p, &mut out).unwrap();
        assert_eq!(items.map(|t| t.1), ['b', 'd', 'a', 'c']);
        assert_eq!(out.labels(), &[0, 0, 1, 1]);
    }
}
