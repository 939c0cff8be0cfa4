//! Which member of a cell represents it: the selection rules and the ranking of candidates.

use crate::spec::cmp_points;
use std::cmp::Ordering;
use std::fmt;
use std::sync::Arc;

/// A caller-supplied score: lower is better; NaN counts as `+inf`.
pub type ScoreFn<const D: usize> = Arc<dyn Fn(&[f64; D]) -> f64 + Send + Sync>;

/// Which member of a cell represents it.
///
/// Ties are broken by the distance to the cell centre, then by the lexicographic order of the
/// coordinates, so the choice never depends on insertion order.
#[derive(Clone, Default)]
pub enum Selection<const D: usize> {
    /// The point closest to the cell centre (the paper's rule). O(1) per insertion.
    #[default]
    CentreClosest,
    /// The member closest to the mean of the cell's members: a real input point standing for
    /// the centroid. Costs O(members of the cell) per insertion and deletion.
    MeanClosest,
    /// The member with the lowest caller-supplied score (e.g. lowest height, best intensity).
    Score(ScoreFn<D>),
}

impl<const D: usize> Selection<D> {
    /// A [`Selection::Score`] from a closure.
    pub fn score(f: impl Fn(&[f64; D]) -> f64 + Send + Sync + 'static) -> Self {
        Selection::Score(Arc::new(f))
    }

    /// `true` when the choice depends on the other members of the cell (only the mean rule).
    pub(crate) fn needs_members(&self) -> bool {
        matches!(self, Selection::MeanClosest)
    }
}

impl<const D: usize> fmt::Debug for Selection<D> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Selection::CentreClosest => f.write_str("CentreClosest"),
            Selection::MeanClosest => f.write_str("MeanClosest"),
            Selection::Score(_) => f.write_str("Score(..)"),
        }
    }
}

/// Ranking key of a candidate: primary criterion, centre distance, then coordinates.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Rank {
    pub primary: f64,
    pub centre: f64,
}

impl Rank {
    /// `Less` when `(self, a)` should be kept over `(other, b)`.
    pub(crate) fn cmp_with<const D: usize>(
        &self,
        a: &[f64; D],
        other: &Rank,
        b: &[f64; D],
    ) -> Ordering {
        self.primary
            .total_cmp(&other.primary)
            .then(self.centre.total_cmp(&other.centre))
            .then_with(|| cmp_points(a, b))
    }
}

/// NaN scores sort last.
pub(crate) fn sanitize_score(s: f64) -> f64 {
    if s.is_nan() {
        f64::INFINITY
    } else {
        s
    }
}

/// The mean of some points (zeros for none), summed in their order.
pub(crate) fn mean<const D: usize>(points: impl IntoIterator<Item = [f64; D]>) -> [f64; D] {
    let mut m = [0.0; D];
    let mut n = 0usize;
    for p in points {
        for k in 0..D {
            m[k] += p[k];
        }
        n += 1;
    }
    if n == 0 {
        return m;
    }
    let n = n as f64;
    for v in &mut m {
        *v /= n;
    }
    m
}
