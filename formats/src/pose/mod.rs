//! Pose maths of every format, in one place.
//!
//! - OctoMap's `f32` arithmetic (`octomap.rs`): [`Pose6D`], [`rotate`],
//!   [`quaternion_from_euler`], the exact operations OctoMap performs, for `.graph` files and
//!   OctoMap logs.
//! - Rigid `f64` poses (`rigid.rs`): a unit quaternion from stored components, and points
//!   turned by the rotation matrix (VTK trajectories, TUM, PCD viewpoints) or by a tf
//!   isometry (MCAP), each rounded to `f32` at the end.
//! - Planar poses of 2D laser logs (`planar.rs`): [`Pose2`].
//!
//! Each helper keeps the operations and their order of the reader it came from, so the frames
//! are bit-identical to what those readers produced (and to OctoMap where it applies).

mod octomap;
mod planar;
mod rigid;

pub use octomap::{quaternion_from_euler, rotate, Pose6D};
pub use planar::Pose2;
pub(crate) use rigid::{isometry, isometry_transform, rigid_transform, unit_quaternion};
