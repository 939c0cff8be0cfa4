//! Organised point clouds: clouds stored as an image of `width × height` points in row-major
//! pixel order (PCL's `height > 1` clouds, a depth camera's output saved as PCD). When their
//! points lie on the rays of a pinhole camera, that camera and each point's pixel
//! ([`CameraPixels`]) let exact insertion skip the ray heads that neighbouring pixels' rays
//! cover, as for TUM depth images: the same map, bit for bit, in a fraction of the time.
//!
//! The camera is not stored in such files; it is fitted to the points. Nothing rests on the
//! fit being right: a ray whose direction does not match its pixel within the ray caster's
//! tolerance is walked whole ([`octoquant_raycast::PixelGrid`]), so a poor fit costs speed,
//! never exactness. The fit is only offered when most points match it.

use crate::frame::CameraPixels;
use nalgebra::{Point3, Rotation3, Vector3};
use octoquant_raycast::PinholeCamera;

/// A point matches the fitted camera when its pixel coordinates, projected through the fit,
/// lie within this many radians (times the focal length, in pixels) of its pixel: half the
/// ray caster's direction tolerance, so that matching points are also matched there.
const MATCH_RADIANS: f64 = 0.5e-4;

/// Fewest points with a usable direction for a fit.
const MIN_POINTS: usize = 64;

/// A point's direction in the camera frame, as `(a, b) = (x/z, y/z)`, and its pixel `(u, v)`:
/// a pinhole camera maps it to `u = fx·a + cx`, `v = fy·b + cy`.
#[derive(Debug, Clone, Copy)]
struct Sighting {
    a: f64,
    b: f64,
    u: f64,
    v: f64,
}

/// Intrinsics `(fx, cx, fy, cy)` in pixels.
type Intrinsics = (f64, f64, f64, f64);

/// How far (in pixels, along u and v) a sighting lies from where `k` projects its direction.
fn residual(k: &Intrinsics, s: &Sighting) -> (f64, f64) {
    ((k.0 * s.a + k.1 - s.u).abs(), (k.2 * s.b + k.3 - s.v).abs())
}

/// The pinhole camera of an organised cloud, when its points fit one.
///
/// `points` (world coordinates, `width × height` of them in row-major pixel order, invalid
/// ones NaN) were measured from `origin` by a camera turned by `rotation` (its `z` axis looks
/// forward, `x` right, `y` down, as PCL and ROS optical frames). The intrinsics are fitted by
/// least squares to the points' directions in the camera frame, twice (the second time
/// without points more than a pixel off the first fit); `None` when the cloud is not
/// organised, has too few points in front of the camera, or fewer than half of them match
/// the fit.
pub fn fit_pinhole_camera(
    points: &[Point3<f32>],
    origin: &Point3<f32>,
    rotation: Rotation3<f64>,
    width: u64,
    height: u64,
) -> Option<CameraPixels> {
    let n = usize::try_from(width.checked_mul(height)?).ok()?;
    if height < 2 || width < 2 || n != points.len() || u32::try_from(n).is_err() {
        return None;
    }
    let w = width as usize;
    let inverse = rotation.inverse();
    let o = origin.cast::<f64>();
    let rays: Vec<Sighting> = points
        .iter()
        .enumerate()
        .filter_map(|(i, p)| {
            let d: Vector3<f64> = inverse * (p.cast::<f64>() - o);
            let (a, b) = (d.x / d.z, d.y / d.z);
            (d.z > 0.0 && a.is_finite() && b.is_finite()).then_some(Sighting {
                a,
                b,
                u: (i % w) as f64,
                v: (i / w) as f64,
            })
        })
        .collect();
    if rays.len() < MIN_POINTS {
        return None;
    }
    let first = fit(&rays, |_| true)?;
    let k = fit(&rays, |s| {
        let (du, dv) = residual(&first, s);
        du <= 1.0 && dv <= 1.0
    })?;
    let (fx, cx, fy, cy) = k;
    let matching = rays
        .iter()
        .filter(|s| {
            let (du, dv) = residual(&k, s);
            du <= MATCH_RADIANS * fx && dv <= MATCH_RADIANS * fy
        })
        .count();
    if matching * 2 < rays.len() {
        return None;
    }
    Some(CameraPixels {
        camera: PinholeCamera {
            width: width as u32,
            height: height as u32,
            fx,
            fy,
            cx,
            cy,
            rotation,
        },
        pixels: (0..n as u32).collect(),
    })
}

/// Least-squares `u = fx·a + cx` and `v = fy·b + cy` over the sightings `keep` selects;
/// `None` when fewer than [`MIN_POINTS`] are kept, the system is singular or a focal length
/// is not positive.
fn fit(rays: &[Sighting], keep: impl Fn(&Sighting) -> bool) -> Option<Intrinsics> {
    let kept: Vec<&Sighting> = rays.iter().filter(|s| keep(s)).collect();
    if kept.len() < MIN_POINTS {
        return None;
    }
    let n = kept.len() as f64;
    // one straight line y = slope·x + offset through the points (x, y), centred for accuracy
    let line = |pair: fn(&Sighting) -> (f64, f64)| {
        let (sx, sy) = kept
            .iter()
            .map(|s| pair(s))
            .fold((0.0, 0.0), |(sx, sy), (x, y)| (sx + x, sy + y));
        let (mx, my) = (sx / n, sy / n);
        let (sxy, sxx) = kept
            .iter()
            .map(|s| pair(s))
            .fold((0.0, 0.0), |(sxy, sxx), (x, y)| {
                (sxy + (x - mx) * (y - my), sxx + (x - mx) * (x - mx))
            });
        let slope = sxy / sxx;
        (slope, my - slope * mx)
    };
    let (fx, cx) = line(|s| (s.a, s.u));
    let (fy, cy) = line(|s| (s.b, s.v));
    let ok = [fx, cx, fy, cy].iter().all(|v| v.is_finite()) && fx > 0.0 && fy > 0.0;
    ok.then_some((fx, cx, fy, cy))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An organised cloud seen by a known camera: every pixel at some depth, a few invalid.
    fn cloud(
        camera: &PinholeCamera,
        origin: Point3<f32>,
        depth: impl Fn(usize, usize) -> f64,
    ) -> Vec<Point3<f32>> {
        let mut points = Vec::new();
        for v in 0..camera.height as usize {
            for u in 0..camera.width as usize {
                let z = depth(u, v);
                let d = Vector3::new(
                    (u as f64 - camera.cx) / camera.fx * z,
                    (v as f64 - camera.cy) / camera.fy * z,
                    z,
                );
                let p = origin.cast::<f64>() + camera.rotation * d;
                points.push(if (u * 7 + v * 3) % 11 == 0 {
                    Point3::new(f32::NAN, f32::NAN, f32::NAN)
                } else {
                    p.cast::<f32>()
                });
            }
        }
        points
    }

    fn camera(rotation: Rotation3<f64>) -> PinholeCamera {
        PinholeCamera {
            width: 80,
            height: 60,
            fx: 70.0,
            fy: 72.5,
            cx: 39.25,
            cy: 30.5,
            rotation,
        }
    }

    #[test]
    fn recovers_the_camera_of_a_pinhole_cloud() {
        for rotation in [
            Rotation3::identity(),
            Rotation3::from_euler_angles(0.3, -1.1, 2.0),
        ] {
            let cam = camera(rotation);
            let origin = Point3::new(1.5, -2.0, 0.25);
            let pts = cloud(&cam, origin, |u, v| {
                1.0 + ((u * 13 + v * 7) % 17) as f64 * 0.1
            });
            let got = fit_pinhole_camera(&pts, &origin, rotation, 80, 60).expect("a fit");
            let c = got.camera;
            // f32 storage of the points limits the fit to about 1e-5 of a pixel here
            for (a, b) in [
                (c.fx, cam.fx),
                (c.fy, cam.fy),
                (c.cx, cam.cx),
                (c.cy, cam.cy),
            ] {
                assert!((a - b).abs() < 1e-3, "{c:?} vs {cam:?}");
            }
            assert_eq!((c.width, c.height, c.rotation), (80, 60, rotation));
            assert_eq!(got.pixels, (0..4800).collect::<Vec<u32>>());
        }
    }

    #[test]
    fn refuses_what_is_not_a_pinhole_image() {
        let cam = camera(Rotation3::identity());
        let o = Point3::origin();
        let pts = cloud(&cam, o, |_, _| 2.0);
        // not organised, or the sizes do not match the points
        assert!(fit_pinhole_camera(&pts, &o, Rotation3::identity(), 4800, 1).is_none());
        assert!(fit_pinhole_camera(&pts, &o, Rotation3::identity(), 80, 61).is_none());
        assert!(fit_pinhole_camera(&pts, &o, Rotation3::identity(), u64::MAX, 2).is_none());
        // pixels shuffled: the points no longer follow their pixels
        let mut shuffled = pts.clone();
        for i in 0..shuffled.len() / 2 {
            let j = (i * 2654435761) % shuffled.len();
            shuffled.swap(i, j);
        }
        assert!(fit_pinhole_camera(&shuffled, &o, Rotation3::identity(), 80, 60).is_none());
        // a spinning scanner's rows (points all around the origin)
        let ring: Vec<Point3<f32>> = (0..4800)
            .map(|i| {
                let (az, el) = ((i % 80) as f32 * 0.0785, (i / 80) as f32 * 0.01 - 0.3);
                Point3::new(az.cos() * 5.0, az.sin() * 5.0, el * 5.0)
            })
            .collect();
        assert!(fit_pinhole_camera(&ring, &o, Rotation3::identity(), 80, 60).is_none());
        // nothing valid
        let nan = vec![Point3::new(f32::NAN, 0.0, 1.0); 4800];
        assert!(fit_pinhole_camera(&nan, &o, Rotation3::identity(), 80, 60).is_none());
    }
}
