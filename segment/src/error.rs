//! The segment crate's single error type.

use thiserror::Error;

/// Everything that can go wrong in 1D clustering and scan segmentation.
///
/// Input variants carry the index of the offending value so callers can name it.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum SegmentError {
    /// A parameter is out of its valid range (NaN, negative, zero where positive is needed).
    #[error("invalid parameter {name} = {value}: {reason}")]
    InvalidParameter {
        /// Which parameter.
        name: &'static str,
        /// The rejected value.
        value: f64,
        /// Why it was rejected.
        reason: &'static str,
    },
    /// An input value is NaN or infinite.
    #[error("value {value} at index {index} is not finite")]
    NonFinite {
        /// Position in the input.
        index: usize,
        /// The rejected value.
        value: f64,
    },
    /// The input is not sorted in non-decreasing order.
    #[error("input is not sorted: value at index {index} is smaller than its predecessor")]
    NotSorted {
        /// Position of the first value smaller than the one before it.
        index: usize,
    },
    /// In circular mode a value lies outside `[0, period)`.
    #[error("value {value} at index {index} is outside [0, {period})")]
    OutOfPeriod {
        /// Position in the input.
        index: usize,
        /// The rejected value.
        value: f64,
        /// The period of the circle.
        period: f64,
    },
    /// More points than the `u32` labels can address.
    #[error("{len} points is more than the supported {max}")]
    TooManyPoints {
        /// The input length.
        len: usize,
        /// The largest supported length.
        max: usize,
    },
    /// The Hough accumulator for these points and steps would need more cells than supported
    /// (points very far from the origin, or tiny steps).
    #[error(
        "the Hough accumulator would need about {cells:.3e} cells (points up to {reach} m from \
         the origin), more than the supported {max}"
    )]
    AccumulatorTooLarge {
        /// Cells the accumulator would need.
        cells: f64,
        /// Distance of the farthest point from the origin, metres.
        reach: f64,
        /// The largest supported number of cells.
        max: usize,
    },
}

/// `Ok` when every named value is finite and `>= 0` (distances, gaps, tolerances); else the
/// first that is not, as [`SegmentError::InvalidParameter`].
pub(crate) fn check_non_negative(values: &[(&'static str, f64)]) -> Result<(), SegmentError> {
    for &(name, value) in values {
        if !(value.is_finite() && value >= 0.0) {
            return Err(SegmentError::InvalidParameter {
                name,
                value,
                reason: "must be finite and >= 0",
            });
        }
    }
    Ok(())
}
