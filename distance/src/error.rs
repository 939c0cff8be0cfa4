//! The distance crate's error type.

use thiserror::Error;

/// Everything that can go wrong building or querying a [`DistanceMap`](crate::DistanceMap).
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum DistanceError {
    /// The maximum distance is NaN, infinite, negative, or so large that its squared value in
    /// cells does not fit the 32-bit integers dynamicEDT3D computes with.
    #[error("invalid maximum distance {max_dist} m: {reason}")]
    InvalidMaxDist {
        /// The rejected value in metres.
        max_dist: f32,
        /// Why it was rejected.
        reason: &'static str,
    },
    /// A bounding-box corner is NaN, infinite or outside the tree's key range.
    #[error("bounding-box {which} corner ({}, {}, {}) is outside the map or not finite", corner[0], corner[1], corner[2])]
    BoxCornerOutOfMap {
        /// `"min"` or `"max"`.
        which: &'static str,
        /// The rejected corner.
        corner: [f64; 3],
    },
    /// The bounding box holds no voxel on some axis (its max corner's key is below its min's).
    #[error(
        "empty bounding box: on axis {axis} the max key {max_key} is below the min key {min_key}"
    )]
    EmptyBox {
        /// 0 = x, 1 = y, 2 = z.
        axis: usize,
        /// Key of the min corner on that axis.
        min_key: u16,
        /// Key of the max corner on that axis.
        max_key: u16,
    },
    /// The bounding box has more voxels than a distance map may hold.
    #[error("bounding box of {cells} voxels is larger than the limit of {limit} voxels")]
    TooLarge {
        /// Voxels in the box.
        cells: u64,
        /// The limit ([`MAX_CELLS`](crate::MAX_CELLS)).
        limit: u64,
    },
    /// The grid could not be allocated.
    #[error("cannot allocate a distance grid of {cells} voxels")]
    OutOfMemory {
        /// Voxels in the box.
        cells: u64,
    },
    /// A query point has a NaN or infinite coordinate.
    #[error("query point ({}, {}, {}) is not finite", point[0], point[1], point[2])]
    NonFinitePoint {
        /// The rejected point.
        point: [f64; 3],
    },
    /// The tree given to an update has another resolution than the map was built from.
    #[error("tree resolution {tree} m differs from the distance map's {map} m")]
    ResolutionMismatch {
        /// The tree's resolution.
        tree: f64,
        /// The map's resolution.
        map: f64,
    },
}
