//! A simulated depth camera (Kinect or RealSense style): one pinhole depth image per pose,
//! each pixel a beam into the [`Scene`]. Its frames carry their pixel grid
//! ([`Frame::camera`]), so exact insertion skips the ray stretches that neighbouring pixels
//! provably cover, as it does for TUM RGB-D frames.

use super::scanner::{check_options, check_ranges, invalid, BeamCaster, MAX_RAYS_PER_FRAME};
use super::{shapes, ScanOptions, ScanStats, Scene, SceneError};
use crate::frame::CameraPixels;
use crate::Frame;
use nalgebra::{Matrix3, Point3, Rotation3, Vector3};
use octoquant_raycast::PinholeCamera;

/// A depth camera at fixed poses, its optical axis level with the ground but tilted down by
/// `tilt_deg`. Pixel `(u, v)` looks along `((u − cx)/fx, (v − cy)/fy, 1)` in the camera frame
/// (x right, y down, z forward), as in TUM RGB-D.
#[derive(Debug, Clone, PartialEq)]
pub struct DepthCamera {
    /// Camera positions and headings (radians from +x towards +y), one frame each.
    pub poses: Vec<(Point3<f64>, f64)>,
    /// Downward tilt of the optical axis, degrees.
    pub tilt_deg: f64,
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
    /// Hits closer than this are dropped, metres.
    pub min_range: f64,
    /// Beams reach this far, metres.
    pub max_range: f64,
}

impl DepthCamera {
    /// The built-in camera of [`Scene::builtin`]: a 320 x 240 image with a Kinect's field of
    /// view (f = 262.5 px), 1.2 m above the ground at each built-in scanner station, looking
    /// along +x and along −x, tilted down 10°; range 0.5–8 m.
    pub fn builtin(scene: &Scene) -> DepthCamera {
        let poses = shapes::builtin_stations()
            .into_iter()
            .flat_map(|[x, y]| {
                let z = scene.ground_height(x, y).unwrap_or(0.0) + 1.2;
                [0.0, std::f64::consts::PI].map(|yaw| (Point3::new(x, y, z), yaw))
            })
            .collect();
        DepthCamera {
            poses,
            tilt_deg: 10.0,
            width: 320,
            height: 240,
            fx: 262.5,
            fy: 262.5,
            cx: 159.5,
            cy: 119.5,
            min_range: 0.5,
            max_range: 8.0,
        }
    }

    /// The camera-to-world rotation at heading `yaw`: columns right, down and forward.
    pub fn rotation(&self, yaw: f64) -> Rotation3<f64> {
        let (s, c) = yaw.sin_cos();
        let (st, ct) = self.tilt_deg.to_radians().sin_cos();
        let forward = Vector3::new(c * ct, s * ct, -st);
        let right = Vector3::new(s, -c, 0.0);
        let down = forward.cross(&right);
        Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[right, down, forward]))
    }

    fn validate(&self) -> Result<(), SceneError> {
        check_ranges(self.min_range, self.max_range)?;
        let intrinsics = [self.fx, self.fy, self.cx, self.cy];
        if !intrinsics.iter().all(|v| v.is_finite()) || self.fx <= 0.0 || self.fy <= 0.0 {
            return Err(invalid(
                "fx",
                format!("intrinsics {intrinsics:?} are not finite with positive focal lengths"),
            ));
        }
        let pixels = self.width as u64 * self.height as u64;
        if pixels == 0 || pixels > MAX_RAYS_PER_FRAME {
            return Err(invalid(
                "width",
                format!(
                    "{} x {} pixels (1 to {MAX_RAYS_PER_FRAME} per frame)",
                    self.width, self.height
                ),
            ));
        }
        if !self.tilt_deg.is_finite() || self.tilt_deg.abs() > 90.0 {
            return Err(invalid(
                "tilt_deg",
                format!("{} is not in [-90, 90]", self.tilt_deg),
            ));
        }
        let finite = |(p, yaw): &(Point3<f64>, f64)| {
            p.coords.iter().all(|v| v.is_finite()) && yaw.is_finite()
        };
        if !self.poses.iter().all(finite) {
            return Err(invalid("poses", "a pose is not finite".into()));
        }
        Ok(())
    }
}

/// One frame per pose of a [`DepthCamera`], stamped `pose index / 30` s, with each point's
/// pixel (`v·width + u`, row by row) in [`Frame::camera`]. Pixels whose beam hits nothing
/// (or too close) give no point, as a depth camera's invalid pixels; with
/// [`super::MissPolicy::MaxRange`] misses are returned beyond the range. Errors on an invalid
/// camera or options.
pub fn scan_depth(
    scene: &Scene,
    camera: &DepthCamera,
    options: &ScanOptions,
) -> Result<(Vec<Frame>, Vec<ScanStats>), SceneError> {
    camera.validate()?;
    check_options(options)?;
    let mut frames = Vec::with_capacity(camera.poses.len());
    let mut all_stats = Vec::with_capacity(camera.poses.len());
    let ranges = (camera.min_range, camera.max_range);
    for (i, &(origin, yaw)) in camera.poses.iter().enumerate() {
        let rotation = camera.rotation(yaw);
        let mut caster = BeamCaster::new(scene, options, ranges, i as u64);
        let mut points = Vec::new();
        let mut pixels = Vec::new();
        let mut stats = ScanStats::default();
        for v in 0..camera.height {
            for u in 0..camera.width {
                let ray = Vector3::new(
                    (u as f64 - camera.cx) / camera.fx,
                    (v as f64 - camera.cy) / camera.fy,
                    1.0,
                );
                let before = points.len();
                caster.cast(
                    &origin,
                    &(rotation * ray).normalize(),
                    &mut points,
                    &mut stats,
                );
                if points.len() > before {
                    pixels.push(v * camera.width + u);
                }
            }
        }
        let mut frame = Frame::new(origin.cast::<f32>(), points);
        frame.stamp = Some(i as f64 / 30.0);
        frame.camera = Some(CameraPixels {
            camera: PinholeCamera {
                width: camera.width,
                height: camera.height,
                fx: camera.fx,
                fy: camera.fy,
                cx: camera.cx,
                cy: camera.cy,
                rotation,
            },
            pixels,
        });
        frames.push(frame);
        all_stats.push(stats);
    }
    Ok((frames, all_stats))
}
