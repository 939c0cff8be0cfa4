//! Rigid poses in `f64`: a translation and a unit quaternion, as trajectories, TUM association
//! files, PCD viewpoints and tf messages store them.
//!
//! Two ways of turning a point are kept apart on purpose, because their results can differ in
//! the last bit: [`rigid_transform`] goes through the rotation matrix (VTK sequences, TUM, PCD)
//! and [`isometry_transform`] through nalgebra's quaternion rotation (MCAP's tf chains).

use nalgebra::{Isometry3, Point3, Quaternion, Rotation3, Translation3, UnitQuaternion, Vector3};

/// `R·p + t` in `f64` with `R` the rotation matrix of the pose's quaternion
/// (`q.to_rotation_matrix()`, made once per frame by the caller, not per point), rounded to
/// `f32` at the end.
#[inline]
pub(crate) fn rigid_transform(
    r: &Rotation3<f64>,
    t: &Vector3<f64>,
    p: &Point3<f64>,
) -> Point3<f32> {
    (r * p + t).cast::<f32>()
}

/// A unit quaternion from (w, x, y, z), or `None` when it is not finite or has zero norm.
pub(crate) fn unit_quaternion(w: f64, x: f64, y: f64, z: f64) -> Option<UnitQuaternion<f64>> {
    let q = Quaternion::new(w, x, y, z);
    let n = q.norm();
    (n.is_finite() && n > 0.0).then(|| UnitQuaternion::from_quaternion(q))
}

/// The isometry `p ↦ R(q)·p + t` of a stored translation and quaternion, the quaternion
/// normalised (a tf `geometry_msgs/Transform`).
pub(crate) fn isometry(t: Vector3<f64>, q: Quaternion<f64>) -> Isometry3<f64> {
    Isometry3::from_parts(Translation3::from(t), UnitQuaternion::from_quaternion(q))
}

/// `pose · p` in `f64` through the quaternion rotation, rounded to `f32`.
pub(crate) fn isometry_transform(pose: &Isometry3<f64>, p: &Point3<f32>) -> Point3<f32> {
    (pose * p.cast::<f64>()).cast::<f32>()
}
