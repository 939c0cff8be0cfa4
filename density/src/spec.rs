//! Grid geometry: the cell of a point, a cell's centre, distances in cell units, and the exact
//! `floor` behind the cell index.

use crate::error::DensityError;
use std::cmp::Ordering;

/// The index of a cell: one signed integer per axis, `floor((x - offset) / size)`.
pub type CellIndex<const D: usize> = [i64; D];

/// Largest accepted magnitude of a cell index on any axis (2^53); points beyond it are rejected.
///
/// Up to 2^53 every integer is exact in `f64`, so cell centres and neighbour indexes are exact.
pub const MAX_CELL_INDEX: i64 = 1 << 53;

/// How the distance from a point to its cell's centre is measured: the criterion that picks a
/// cell's point ([`crate::Selection::CentreClosest`]) and orders the output stage.
///
/// With the same size on every axis both give the same order; they differ only when cell
/// sizes differ per axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CentreDistance {
    /// The paper's criterion (its Eq. 3): the Euclidean distance in the input's units (metres),
    /// over all axes, whatever the cell sizes. The default.
    #[default]
    Euclidean,
    /// Each axis divided by its cell size first (distance in cell units), so that axes of
    /// different units (metres and seconds, say) weigh alike. A point at a cell's corner is
    /// then as far from the centre as any other corner point, whatever the cell's shape.
    CellUnits,
}

/// Grid geometry: per-axis cell sizes and offsets, and how distances to a cell's centre are
/// measured.
#[derive(Debug, Clone, PartialEq)]
pub struct GridSpec<const D: usize> {
    size: [f64; D],
    offset: [f64; D],
    metric: CentreDistance,
}

impl<const D: usize> GridSpec<D> {
    /// A grid with the given cell size and offset per axis.
    ///
    /// Sizes must be finite and positive, offsets finite, and `D >= 1`.
    pub fn new(size: [f64; D], offset: [f64; D]) -> Result<Self, DensityError> {
        if D == 0 {
            return Err(DensityError::NoAxes);
        }
        for (axis, &value) in size.iter().enumerate() {
            if !(value.is_finite() && value > 0.0) {
                return Err(DensityError::InvalidCellSize { axis, value });
            }
        }
        for (axis, &value) in offset.iter().enumerate() {
            if !value.is_finite() {
                return Err(DensityError::InvalidOffset { axis, value });
            }
        }
        Ok(GridSpec {
            size,
            offset,
            metric: CentreDistance::default(),
        })
    }

    /// This grid with `metric` as its centre distance (the default is
    /// [`CentreDistance::Euclidean`], the paper's).
    pub fn with_centre_distance(mut self, metric: CentreDistance) -> Self {
        self.metric = metric;
        self
    }

    /// How distances to a cell's centre are measured.
    pub fn centre_distance_metric(&self) -> CentreDistance {
        self.metric
    }

    /// A grid with per-axis sizes and offset 0 on every axis.
    pub fn with_sizes(size: [f64; D]) -> Result<Self, DensityError> {
        Self::new(size, [0.0; D])
    }

    /// A grid with the same cell size on every axis and offset 0.
    pub fn cubic(size: f64) -> Result<Self, DensityError> {
        Self::new([size; D], [0.0; D])
    }

    /// Cell size per axis.
    pub fn size(&self) -> &[f64; D] {
        &self.size
    }

    /// Grid offset per axis: cell 0 starts there.
    pub fn offset(&self) -> &[f64; D] {
        &self.offset
    }

    /// The cell holding `p`: `floor((x - offset) / size)` per axis.
    ///
    /// `None` for a NaN or infinite coordinate, or an index beyond [`MAX_CELL_INDEX`].
    pub fn cell_index(&self, p: &[f64; D]) -> Option<CellIndex<D>> {
        let mut index = [0i64; D];
        for a in 0..D {
            index[a] = floor_index((p[a] - self.offset[a]) / self.size[a], MAX_CELL_INDEX)?;
        }
        Some(index)
    }

    /// The centre of cell `index`: `offset + (index + 0.5) * size` per axis.
    pub fn cell_centre(&self, index: &CellIndex<D>) -> [f64; D] {
        let mut c = [0.0; D];
        for a in 0..D {
            c[a] = self.offset[a] + (index[a] as f64 + 0.5) * self.size[a];
        }
        c
    }

    /// Squared distance from `p` to the centre of cell `index`, measured as the grid's
    /// [`CentreDistance`] says: in the input's units (the default) or each axis in cell units.
    ///
    /// 0 at the centre; inside the cell at most [`GridSpec::max_centre_distance`].
    pub fn centre_distance(&self, p: &[f64; D], index: &CellIndex<D>) -> f64 {
        let c = self.cell_centre(index);
        self.distance(p, &c)
    }

    /// The largest squared centre distance of a point inside its cell (at a corner):
    /// `sum((size / 2)^2)` in the input's units, `D / 4` in cell units.
    pub fn max_centre_distance(&self) -> f64 {
        match self.metric {
            CentreDistance::Euclidean => self.size.iter().map(|s| 0.25 * s * s).sum(),
            CentreDistance::CellUnits => D as f64 / 4.0,
        }
    }

    /// Squared distance between `a` and `b` under the grid's [`CentreDistance`].
    #[inline]
    pub(crate) fn distance(&self, a: &[f64; D], b: &[f64; D]) -> f64 {
        match self.metric {
            CentreDistance::Euclidean => squared_distance(a, b),
            CentreDistance::CellUnits => scaled_distance(a, b, &self.size),
        }
    }

    /// The minimum-difference check: `true` when `a` and `b` are closer than half a cell size
    /// on every axis (strictly), so one of them is redundant.
    pub fn within_half_cell(&self, a: &[f64; D], b: &[f64; D]) -> bool {
        (0..D).all(|k| (a[k] - b[k]).abs() < 0.5 * self.size[k])
    }
}

/// Squared Euclidean distance between `a` and `b`.
#[inline]
pub(crate) fn squared_distance<const D: usize>(a: &[f64; D], b: &[f64; D]) -> f64 {
    let mut d = 0.0;
    for k in 0..D {
        let t = a[k] - b[k];
        d += t * t;
    }
    d
}

/// Squared distance between `a` and `b`, each axis divided by `scale`.
pub(crate) fn scaled_distance<const D: usize>(a: &[f64; D], b: &[f64; D], scale: &[f64; D]) -> f64 {
    let mut d = 0.0;
    for k in 0..D {
        let t = (a[k] - b[k]) / scale[k];
        d += t * t;
    }
    d
}

/// Lexicographic total order of points, the last tie-break of every selection rule.
pub(crate) fn cmp_points<const D: usize>(a: &[f64; D], b: &[f64; D]) -> Ordering {
    for k in 0..D {
        match a[k].total_cmp(&b[k]) {
            Ordering::Equal => {}
            o => return o,
        }
    }
    Ordering::Equal
}

/// `floor(q)` as an integer when `|floor(q)| <= limit` (`limit < 2^62`), else `None` (also for
/// NaN and infinities). Exactly `q.floor()`, without the libm call that `f64::floor` becomes on
/// x86-64 targets without SSE4.1.
#[inline]
pub(crate) fn floor_index(q: f64, limit: i64) -> Option<i64> {
    // 2^62: beyond it every f64 is an integer far out of range; NaN fails the comparison too.
    if q.is_nan() || q.abs() >= 4_611_686_018_427_387_904.0 {
        return None;
    }
    let t = floor_trunc(q);
    (t.abs() <= limit).then_some(t)
}

/// `floor(q)` as an `i64`, exact for `|q| < 2^63` (saturating beyond, 0 for NaN), inline.
///
/// Truncation toward zero is exact; at or above 2^52 `q` is already an integer, below it the
/// truncation converts back exactly, so one comparison decides floor vs. truncation.
#[inline(always)]
pub(crate) fn floor_trunc(q: f64) -> i64 {
    let t = q as i64;
    if (t as f64) > q {
        t.saturating_sub(1)
    } else {
        t
    }
}

/// `true` when no coordinate of `p` is NaN or infinite, with one branch: `x * 0` is (a signed)
/// 0 for a finite `x` and NaN otherwise.
#[inline]
pub(crate) fn all_finite<const D: usize>(p: &[f64; D]) -> bool {
    let mut z = 0.0;
    for v in p {
        z += v * 0.0;
    }
    z == 0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floor_index_is_floor() {
        let limit = 1i64 << 53;
        let cases = [
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            -1.0000001,
            2.9999999,
            -7.5,
            4503599627370495.5,
            -4503599627370495.5,
            9007199254740992.0,
            -9007199254740992.0,
            9007199254740994.0,
            1e17,
            -1e300,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
        ];
        for q in cases {
            let f = q.floor();
            let want = (f.is_finite() && f.abs() <= limit as f64).then_some(f as i64);
            assert_eq!(floor_index(q, limit), want, "{q}");
        }
    }

    #[test]
    fn all_finite_is_is_finite_on_every_axis() {
        let vals = [
            0.0,
            -0.0,
            1.5,
            -1e300,
            f64::MAX,
            f64::MIN,
            f64::MIN_POSITIVE / 4.0,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        for &a in &vals {
            for &b in &vals {
                for &c in &vals {
                    let p = [a, b, c];
                    assert_eq!(all_finite(&p), p.iter().all(|v| v.is_finite()), "{p:?}");
                }
            }
        }
    }
}
