//! A frame: one scan's sensor origin and end points, in world coordinates.

use nalgebra::Point3;

/// One scan ready for insertion: every ray starts at `origin` and ends at one of `points`.
///
/// Coordinates are `f32` in the world (map) frame, as OctoMap's `Pointcloud` holds them, so
/// the same frame gives the same keys and rays in both implementations.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Frame {
    /// Sensor origin in world coordinates.
    pub origin: Point3<f32>,
    /// Ray end points in world coordinates (may contain NaN/inf; insertion skips and counts
    /// them).
    pub points: Vec<Point3<f32>>,
    /// Acquisition time in seconds, when the source records one.
    pub stamp: Option<f64>,
}

impl Frame {
    /// A frame from an origin and points, without a time stamp.
    pub fn new(origin: Point3<f32>, points: Vec<Point3<f32>>) -> Self {
        Frame {
            origin,
            points,
            stamp: None,
        }
    }
}
