//! Online grid density reducer: grid geometry and point selection rules.
//!
//! The reducer ("An online density reduction algorithm for non-homogenous multidimensional
//! datasets") thins dense regions to about one point per grid cell while sparse regions keep
//! every point, and it never invents points. It runs in two stages that may overlap in time:
//!
//! * **input** ([`DensityGrid::insert`], [`DensityGrid::remove`]): each point goes to the cell
//!   `floor((x - offset) / size)` per axis. The cells sit in an ordered index (a `BTreeMap`
//!   keyed by the cell index, the paper's red-black tree; after a batch into an empty grid
//!   simply the slot order until the first change) and, for look-ups, in a hash index over
//!   the same keys. A cell keeps the member chosen by its [`Selection`] rule, and all
//!   cells stay sorted by the distance of that point to the cell centre. Deleting a point
//!   repairs only its own cell.
//! * **output** ([`DensityGrid::begin_cycle`], [`DensityGrid::step_cycle`]): a read cycle with
//!   its own id visits the cells in ascending distance; each visited point is emitted, and a
//!   point of any of the 3^D - 1 neighbouring cells that lies closer than half a cell size on
//!   every axis is skipped for this cycle. Cells created or changed after the cycle began are
//!   left to the next cycle.
//!
//! Files: this one holds the geometry ([`GridSpec`]) and [`Selection`]; `grid.rs` the
//! store, `batch.rs` batch insertion (counting sort by cell, one-pass build of an
//! empty store), `index.rs` the hash index, key packing and the sorts,
//! `order.rs` the ordered index and distance order (compact `Vec` form after a build,
//! B-trees once changed), `arena.rs` the `f32` form of the member arena,
//! `output.rs` the read cycles, `shared.rs` the two-thread wrapper and
//! `reduce.rs` the one-call helpers.

use crate::index::floor_index;
use crate::error::DensityError;
use std::cmp::Ordering;
use std::fmt;
use std::sync::Arc;

/// The index of a cell: one signed integer per axis, `floor((x - offset) / size)`.
pub type CellIndex<const D: usize> = [i64; D];

/// Largest accepted magnitude of a cell index on any axis (2^53); points beyond it are rejected.
///
/// Up to 2^53 every integer is exact in `f64`, so cell centres and neighbour indexes are exact.
pub const MAX_CELL_INDEX: i64 = 1 << 53;

/// Grid geometry: per-axis cell sizes and offsets.
#[derive(Debug, Clone, PartialEq)]
pub struct GridSpec<const D: usize> {
    size: [f64; D],
    offset: [f64; D],
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
        Ok(GridSpec { size, offset })
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

    /// Squared distance from `p` to the centre of cell `index`, each axis in cell units.
    ///
    /// Scaling by the cell size keeps axes of different units comparable; with equal sizes the
    /// order is that of the Euclidean distance. 0 at the centre, at most `D / 4` inside the cell.
    pub fn centre_distance(&self, p: &[f64; D], index: &CellIndex<D>) -> f64 {
        let c = self.cell_centre(index);
        scaled_distance(p, &c, &self.size)
    }

    /// The minimum-difference check: `true` when `a` and `b` are closer than half a cell size
    /// on every axis (strictly), so one of them is redundant.
    pub fn within_half_cell(&self, a: &[f64; D], b: &[f64; D]) -> bool {
        (0..D).all(|k| (a[k] - b[k]).abs() < 0.5 * self.size[k])
    }
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

