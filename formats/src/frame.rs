//! A frame: one scan's sensor origin and end points, in world coordinates.

use nalgebra::Point3;
use octoquant_raycast::{PinholeCamera, PixelGrid};

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
    /// The depth camera's pixel of each point, when the frame comes from a depth image: exact
    /// insertion then skips the ray stretches that neighbouring rays cover (same map, faster).
    pub camera: Option<CameraPixels>,
}

/// Where a depth image frame's points were measured: a pinhole camera and each point's pixel
/// (see [`PixelGrid`]).
#[derive(Debug, Clone, PartialEq)]
pub struct CameraPixels {
    /// The camera.
    pub camera: PinholeCamera,
    /// The pixel `v·width + u` of each point, in point order.
    pub pixels: Vec<u32>,
}

impl CameraPixels {
    /// The grid as the ray caster takes it.
    pub fn grid(&self) -> PixelGrid<'_> {
        PixelGrid {
            camera: self.camera,
            pixels: &self.pixels,
        }
    }
}

impl Frame {
    /// A frame from an origin and points, without a time stamp.
    pub fn new(origin: Point3<f32>, points: Vec<Point3<f32>>) -> Self {
        Frame {
            origin,
            points,
            stamp: None,
            camera: None,
        }
    }
}
