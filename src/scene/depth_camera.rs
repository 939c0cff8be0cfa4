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

/// A depth camera at fixed poses. `image` gives its size, intrinsics and its orientation at
/// heading 0; a pose turns it about the world's z axis. Pixel `(u, v)` looks along
/// `((u − cx)/fx, (v − cy)/fy, 1)` in the camera frame (x right, y down, z forward), as in
/// TUM RGB-D.
#[derive(Debug, Clone, PartialEq)]
pub struct DepthCamera {
    /// Camera positions and headings (radians from +x towards +y), one frame each.
    pub poses: Vec<(Point3<f64>, f64)>,
    /// The image and the camera's orientation at heading 0.
    pub image: PinholeCamera,
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
            image: PinholeCamera {
                width: 320,
                height: 240,
                fx: 262.5,
                fy: 262.5,
                cx: 159.5,
                cy: 119.5,
                rotation: looking_along_x(10f64.to_radians()),
            },
            min_range: 0.5,
            max_range: 8.0,
        }
    }

    /// The camera-to-world rotation at heading `yaw`.
    pub fn rotation(&self, yaw: f64) -> Rotation3<f64> {
        Rotation3::from_axis_angle(&Vector3::z_axis(), yaw) * self.image.rotation
    }

    fn validate(&self) -> Result<(), SceneError> {
        check_ranges(self.min_range, self.max_range)?;
        let c = &self.image;
        let intrinsics = [c.fx, c.fy, c.cx, c.cy];
        if !intrinsics.iter().all(|v| v.is_finite()) || c.fx <= 0.0 || c.fy <= 0.0 {
            return Err(invalid(
                "fx",
                format!("intrinsics {intrinsics:?} are not finite with positive focal lengths"),
            ));
        }
        let pixels = c.width as u64 * c.height as u64;
        if pixels == 0 || pixels > MAX_RAYS_PER_FRAME {
            return Err(invalid(
                "width",
                format!(
                    "{} x {} pixels (1 to {MAX_RAYS_PER_FRAME} per frame)",
                    c.width, c.height
                ),
            ));
        }
        if !c.rotation.matrix().iter().all(|v| v.is_finite()) {
            return Err(invalid("rotation", "the rotation is not finite".into()));
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

/// The orientation of a camera looking along +x, tilted down by `tilt` radians: its columns
/// are the camera's right, down and forward axes in the world.
pub fn looking_along_x(tilt: f64) -> Rotation3<f64> {
    let (st, ct) = tilt.sin_cos();
    let forward = Vector3::new(ct, 0.0, -st);
    let right = Vector3::new(0.0, -1.0, 0.0);
    let down = forward.cross(&right);
    Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[right, down, forward]))
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
        let image = &camera.image;
        for v in 0..image.height {
            for u in 0..image.width {
                let ray = Vector3::new(
                    (u as f64 - image.cx) / image.fx,
                    (v as f64 - image.cy) / image.fy,
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
                    pixels.push(v * image.width + u);
                }
            }
        }
        let mut frame = Frame::new_f32(origin.cast::<f32>(), points);
        frame.stamp = Some(i as f64 / 30.0);
        frame.camera = Some(CameraPixels {
            camera: PinholeCamera { rotation, ..*image },
            pixels,
        });
        frames.push(frame);
        all_stats.push(stats);
    }
    Ok((frames, all_stats))
}
