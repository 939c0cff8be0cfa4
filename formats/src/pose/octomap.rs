//! OctoMap's exact `f32` pose arithmetic (`octomath::Pose6D`, `octomath::Quaternion`): the
//! same operations in the same order, so transformed points are bit-identical to OctoMap's.

use nalgebra::{Point3, Quaternion, Vector3};

/// An OctoMap pose: `f32` translation and an `f32` quaternion that is used as stored.
///
/// OctoMap never normalises the quaternion before rotating, so a non-unit quaternion scales
/// points; this type keeps that behaviour.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose6D {
    /// Translation (metres).
    pub translation: Vector3<f32>,
    /// Rotation quaternion; `Quaternion::new(w, x, y, z)`.
    pub rotation: Quaternion<f32>,
}

impl Default for Pose6D {
    fn default() -> Self {
        Pose6D::from_translation(Vector3::zeros())
    }
}

impl Pose6D {
    /// A pose with identity rotation `(1, 0, 0, 0)`.
    pub fn from_translation(translation: Vector3<f32>) -> Self {
        Pose6D {
            translation,
            rotation: Quaternion::new(1.0, 0.0, 0.0, 0.0),
        }
    }

    /// OctoMap's `Pose6D(x, y, z, roll, pitch, yaw)`: the quaternion comes from
    /// [`quaternion_from_euler`].
    pub fn from_euler(translation: Vector3<f32>, roll: f64, pitch: f64, yaw: f64) -> Self {
        Pose6D {
            translation,
            rotation: quaternion_from_euler(roll, pitch, yaw),
        }
    }

    /// `Pose6D::transform`: `rotate(v) + translation`, all in `f32`.
    pub fn transform(&self, p: &Point3<f32>) -> Point3<f32> {
        let r = rotate(&self.rotation, &p.coords);
        Point3::new(
            r.x + self.translation.x,
            r.y + self.translation.y,
            r.z + self.translation.z,
        )
    }

    /// `Pose6D::inv`: rotation `normalized(conj(q))`, translation `rotate(-t)` by it.
    pub fn inverse(&self) -> Pose6D {
        let q = self.rotation;
        let rot = normalized(&Quaternion::new(q.w, -q.i, -q.j, -q.k));
        let neg = Vector3::new(
            -self.translation.x,
            -self.translation.y,
            -self.translation.z,
        );
        Pose6D {
            translation: rotate(&rot, &neg),
            rotation: rot,
        }
    }

    /// The sensor origin graph2tree uses for this pose:
    /// `pose.transform(pose.inv().transform(pose.trans()))`, which is the translation up to
    /// `f32` rounding of the round trip.
    pub fn graph2tree_origin(&self) -> Point3<f32> {
        let t = Point3::from(self.translation);
        self.transform(&self.inverse().transform(&t))
    }
}

/// The quaternion product `a * b` with OctoMap's operand order and left-to-right evaluation
/// (`Quaternion::operator*`).
fn mul(a: &Quaternion<f32>, b: &Quaternion<f32>) -> Quaternion<f32> {
    let (u1, x1, y1, z1) = (a.w, a.i, a.j, a.k);
    let (u2, x2, y2, z2) = (b.w, b.i, b.j, b.k);
    Quaternion::new(
        u1 * u2 - x1 * x2 - y1 * y2 - z1 * z2,
        y1 * z2 - y2 * z1 + u1 * x2 + u2 * x1,
        z1 * x2 - z2 * x1 + u1 * y2 + u2 * y1,
        x1 * y2 - x2 * y1 + u1 * z2 + u2 * z1,
    )
}

/// `Quaternion::rotate`: `(q * (0, v)) * conj(q)` in `f32`; the conjugate is not normalised.
pub fn rotate(q: &Quaternion<f32>, v: &Vector3<f32>) -> Vector3<f32> {
    let pure = Quaternion::new(0.0, v.x, v.y, v.z);
    let conj = Quaternion::new(q.w, -q.i, -q.j, -q.k);
    let r = mul(&mul(q, &pure), &conj);
    Vector3::new(r.i, r.j, r.k)
}

/// `Quaternion::normalized`: squares in `f32` summed in `f64`, the norm cast to `f32`, then
/// each component divided by it (unchanged when the norm is 0).
fn normalized(q: &Quaternion<f32>) -> Quaternion<f32> {
    let c = [q.w, q.i, q.j, q.k];
    let n: f64 = c.iter().map(|&x| f64::from(x * x)).sum();
    let len = n.sqrt() as f32;
    if f64::from(len) > 0.0 {
        Quaternion::new(c[0] / len, c[1] / len, c[2] / len, c[3] / len)
    } else {
        *q
    }
}

/// OctoMap's `Quaternion(roll, pitch, yaw)`: a rotation matrix in `f64`, then the quaternion
/// from its diagonal with signs from the off-diagonal, cast to `f32`.
pub fn quaternion_from_euler(roll: f64, pitch: f64, yaw: f64) -> Quaternion<f32> {
    let (sr, sp, sy) = (roll.sin(), pitch.sin(), yaw.sin());
    let (cr, cp, cy) = (roll.cos(), pitch.cos(), yaw.cos());
    let m = [
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ];
    // std::max(0., v): NaN gives 0.
    let half_sqrt = |v: f64| ((if 0.0 < v { v } else { 0.0 }).sqrt() / 2.0) as f32;
    let u = half_sqrt(1.0 + m[0][0] + m[1][1] + m[2][2]);
    let x = half_sqrt(1.0 + m[0][0] - m[1][1] - m[2][2]);
    let y = half_sqrt(1.0 - m[0][0] + m[1][1] - m[2][2]);
    let z = half_sqrt(1.0 - m[0][0] - m[1][1] + m[2][2]);
    let sign = |d: f64, v: f32| if d >= 0.0 { v.abs() } else { -v.abs() };
    Quaternion::new(
        u,
        sign(m[2][1] - m[1][2], x),
        sign(m[0][2] - m[2][0], y),
        sign(m[1][0] - m[0][1], z),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identity_pose_only_translates() {
        let pose = Pose6D::from_translation(Vector3::new(1.0, 0.0, -0.5));
        let p = pose.transform(&Point3::new(4.01, 0.01, 0.01));
        assert_eq!(p, Point3::new(5.01f32, 0.01, -0.49));
        assert_eq!(pose.graph2tree_origin(), Point3::new(1.0, 0.0, -0.5));
    }

    #[test]
    fn euler_yaw_quarter_turn() {
        let q = quaternion_from_euler(0.0, 0.0, std::f64::consts::FRAC_PI_2);
        let v = rotate(&q, &Vector3::new(1.0, 0.0, 0.0));
        assert!((v - Vector3::new(0.0, 1.0, 0.0)).norm() < 1e-6, "{v:?}");
    }

    #[test]
    fn non_unit_quaternion_scales() {
        // OctoMap does not normalise: q = 2·identity scales by |q|² = 4.
        let v = rotate(
            &Quaternion::new(2.0, 0.0, 0.0, 0.0),
            &Vector3::new(1.0, 2.0, 3.0),
        );
        assert_eq!(v, Vector3::new(4.0, 8.0, 12.0));
    }
}
