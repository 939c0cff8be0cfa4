//! A frame: one scan's sensor origin and end points, in world coordinates.

use nalgebra::{Point3, Rotation3};
use octoquant_raycast::PixelGrid;

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
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CameraPixels {
    /// Pixels per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Focal lengths and principal point, in pixels.
    pub fx: f64,
    /// See `fx`.
    pub fy: f64,
    /// See `fx`.
    pub cx: f64,
    /// See `fx`.
    pub cy: f64,
    /// Camera orientation in the world.
    pub rotation: Rotation3<f64>,
    /// The pixel `v·width + u` of each point, in point order.
    pub pixels: Vec<u32>,
}

impl CameraPixels {
    /// The grid as the ray caster takes it.
    pub fn grid(&self) -> PixelGrid<'_> {
        PixelGrid {
            width: self.width,
            height: self.height,
            fx: self.fx,
            fy: self.fy,
            cx: self.cx,
            cy: self.cy,
            rotation: self.rotation,
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
