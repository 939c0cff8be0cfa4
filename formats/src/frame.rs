//! A frame: one scan's sensor origin and end points, in world coordinates.

use crate::error::FormatError;
use nalgebra::Point3;
use octoquant_octree::Color;
use octoquant_raycast::{PinholeCamera, PixelGrid};

/// One scan ready for insertion: every ray starts at `origin` and ends at one of `points`.
///
/// The coordinates are stored as `f32` in the world (map) frame, as OctoMap's `Pointcloud`
/// holds them, so the same frame gives the same keys and rays in both implementations and
/// goes to the `_f32` paths of the ray caster without a copy. Build one from `f64`
/// coordinates with [`Frame::new`] (narrowing, as OctoMap's callers do) or from `f32` storage
/// with [`Frame::new_f32`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Frame {
    /// Sensor origin in world coordinates, stored as `f32` (OctoMap's `point3d`).
    pub origin: Point3<f32>,
    /// Ray end points in world coordinates, stored as `f32` (OctoMap's `Pointcloud`); may
    /// contain NaN/inf, which insertion skips and counts.
    pub points: Vec<Point3<f32>>,
    /// Acquisition time in seconds, when the source records one.
    pub stamp: Option<f64>,
    /// The depth camera's pixel of each point, when the frame comes from a depth image: exact
    /// insertion then skips the ray stretches that neighbouring rays cover (same map, faster).
    pub camera: Option<CameraPixels>,
    /// The colour of each point, in point order, when the source carries colour and it was
    /// asked for ([`crate::ReadOptions::colors`]): PCD `rgb`/`rgba`, PLY `red green blue`,
    /// TUM RGB images registered to the depth images, PointCloud2 `rgb`/`rgba`. `None`
    /// otherwise, so colourless reads pay nothing; `Some` always has one colour per point.
    pub colors: Option<Vec<Color>>,
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
    /// A frame from an origin and points in `f64`, without a time stamp: each coordinate is
    /// narrowed to the `f32` storage with `as f32` (round to nearest; finite values beyond
    /// `f32`'s range become infinite and are skipped as non-finite on insertion), exactly as
    /// OctoMap's C++ and Python callers fill a `Pointcloud`. The points are copied; with `f32`
    /// points already, [`Frame::new_f32`] takes them as they are.
    pub fn new(origin: Point3<f64>, points: &[Point3<f64>]) -> Self {
        let narrow = |p: &Point3<f64>| Point3::new(p.x as f32, p.y as f32, p.z as f32);
        Frame::new_f32(narrow(&origin), points.iter().map(narrow).collect())
    }

    /// A frame from an origin and points in the `f32` storage type, taken as they are,
    /// without a time stamp.
    pub fn new_f32(origin: Point3<f32>, points: Vec<Point3<f32>>) -> Self {
        Frame {
            origin,
            points,
            stamp: None,
            camera: None,
            colors: None,
        }
    }
}

/// Frames made one at a time from a list of rows known in advance (the scan files of a VTK
/// sequence, the rows of a TUM association): `make` reads a row's files only when its frame
/// is asked for, and [`RowFrames::skip_frames`] passes over rows without reading anything.
pub struct RowFrames<T> {
    rows: std::vec::IntoIter<T>,
    make: MakeFrame<T>,
}

/// How a [`RowFrames`] turns a row into its frame.
type MakeFrame<T> = Box<dyn FnMut(T) -> Result<Frame, FormatError> + Send>;

impl<T> RowFrames<T> {
    /// Frames from `rows`, each made by `make`.
    pub fn new(
        rows: Vec<T>,
        make: impl FnMut(T) -> Result<Frame, FormatError> + Send + 'static,
    ) -> Self {
        RowFrames {
            rows: rows.into_iter(),
            make: Box::new(make),
        }
    }

    /// Pass over the next `n` frames (fewer when fewer rows are left) without reading their
    /// files; returns how many were passed. Errors those frames would have given are not
    /// seen: whoever reads them reports them.
    pub fn skip_frames(&mut self, n: usize) -> usize {
        let k = n.min(self.rows.len());
        if k > 0 {
            self.rows.nth(k - 1);
        }
        k
    }
}

impl<T> Iterator for RowFrames<T> {
    type Item = Result<Frame, FormatError>;

    fn next(&mut self) -> Option<Self::Item> {
        self.rows.next().map(&mut self.make)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        self.rows.size_hint()
    }
}

impl<T> std::fmt::Debug for RowFrames<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RowFrames")
            .field("rows_left", &self.rows.len())
            .finish_non_exhaustive()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bits(p: &Point3<f32>) -> [u32; 3] {
        [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]
    }

    /// `Frame::new` is `Frame::new_f32` of the coordinates narrowed by hand with `as f32`,
    /// bit for bit: rounding to nearest, overflow to infinity, NaN and signed zero kept.
    #[test]
    fn new_narrows_like_as_f32() {
        let coords = [
            0.1,
            -0.0,
            0.1 - 1e-9,
            1e39,
            -1e39,
            f64::NAN,
            f64::INFINITY,
            3276.85,
            1.0 + f64::EPSILON,
            f64::MIN_POSITIVE,
        ];
        let points: Vec<Point3<f64>> = coords
            .iter()
            .enumerate()
            .map(|(i, &c)| Point3::new(c, coords[(i + 3) % coords.len()], -c))
            .collect();
        let origin = Point3::new(0.05, 1e39, -0.0);
        let f = Frame::new(origin, &points);
        let by_hand = |p: &Point3<f64>| Point3::new(p.x as f32, p.y as f32, p.z as f32);
        let g = Frame::new_f32(by_hand(&origin), points.iter().map(by_hand).collect());
        assert_eq!(bits(&f.origin), bits(&g.origin));
        assert_eq!(f.points.len(), g.points.len());
        for (a, b) in f.points.iter().zip(&g.points) {
            assert_eq!(bits(a), bits(b));
        }
        assert_eq!(f.origin.y, f32::INFINITY);
        assert_eq!(f.points[2].x, 0.1f32);
        assert_eq!((f.stamp, f.camera, f.colors), (None, None, None));
    }
}
