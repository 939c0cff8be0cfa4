//! octoquant: OctoMap-compatible occupancy mapping, fast.
//!
//! This crate wires the workspace together: it re-exports the octree crate, and adds safe
//! file output (temporary file, then rename), tree file reading with errors that name the
//! file, and the `octoquant` command-line tool.
#![deny(missing_docs)]

pub mod export;
pub mod formats;
pub mod frame;
pub mod output;
pub mod pipeline;
pub mod query;
pub mod render;
pub mod scene;
pub mod treefile;

pub use frame::Frame;
pub use octoquant_octree as octree;
pub use octoquant_octree::{Key, KeyConverter, OcTree, OccupancyParams, Update};
/// OctoMap's rays, `castRay` and `insertPointCloud` (the `octoquant-raycast` crate), for
/// callers that use only this crate (the Python bindings).
pub use octoquant_raycast as raycast;
pub use parry3d;
