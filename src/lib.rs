//! octoquant: OctoMap-compatible occupancy mapping, fast.
//!
//! This crate wires the workspace together: it re-exports the octree crate and the sensor
//! formats (with their atomic file output), and adds the insertion pipeline, tree file reading
//! with errors that name the file, rendering, export, collision queries, the scene simulator
//! and the `octoquant` command-line tool.
#![deny(missing_docs)]

pub mod checkpoint;
pub mod export;
pub mod filters;
pub mod grid;
pub mod pipeline;
pub mod query;
pub mod render;
pub mod scene;
pub mod treefile;

pub use octoquant_formats as formats;
pub use octoquant_formats::{frame, output, Frame};
pub use octoquant_octree as octree;
pub use octoquant_octree::{InnerNodes, Key, KeyConverter, OcTree, OccupancyParams, Update};
/// OctoMap's rays, `castRay` and `insertPointCloud` (the `octoquant-raycast` crate), for
/// callers that use only this crate (the Python bindings).
pub use octoquant_raycast as raycast;
pub use parry3d;
