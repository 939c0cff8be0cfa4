//! octoquant-formats: sensor-format readers that turn a file (or a scan directory) into
//! [`Frame`]s in world coordinates, the writers of the exchange formats, and atomic file
//! output.
//!
//! Entry point: [`read_frames`] with [`ReadOptions`] (or [`frame_stream`], the same frames
//! read one at a time); the format comes from the name
//! ([`InputFormat::detect`]) unless given. One module per format, each with free `read_*`
//! functions:
//!
//! | module | input | frames |
//! |---|---|---|
//! | [`graph`] | OctoMap ScanGraph `.graph` (read and write) | one per node, OctoMap's exact `f32` transform |
//! | [`frames`] | `.frames`, the exchange format with the C++ reference program, which also keeps stamps, colours and depth cameras (read and write) | as stored |
//! | [`text`] | `x y z` lists (`.dat`, `.txt`), OctoMap `NODE` logs (`.log`), `origin` frames | see the module |
//! | [`vtk`] | legacy ASCII `.vtk`; a scan directory + trajectory `.csv` | one per scan, in time order |
//! | [`tum`] | TUM depth `.png`; an association file with poses | one per depth image |
//! | [`pcd`] | PCD v0.7 ascii / binary / binary_compressed | one (organised clouds get a fitted camera, [`organized`]) |
//! | [`mcap`] | `sensor_msgs/PointCloud2` in ROS 1 / ROS 2 MCAP bags, posed by tf | one per cloud |
//! | [`ply`] | PLY `vertex` positions (read and write) | one |
//! | [`binvox`] | binvox voxel grids (`binvox2bt`'s input) | voxels, not frames |
//! | [`carmen`] | CARMEN laser logs (`FLASER`, `ROBOTLASER1`) | 2D scans, not frames |
//!
//! Every file may be `.gz`/`.bz2` compressed ([`source`]). Errors are one [`FormatError`]
//! naming the file and the line or byte; no input makes a reader panic, counts read from
//! a file never reserve more memory than the file's bytes can fill, and compressed data may
//! expand only so far ([`DecompressionLimit`], see [`source`]). The pose maths of every
//! reader (OctoMap's exact `f32` poses, rigid `f64` poses, planar poses) is in [`pose`]. Files
//! are written through [`output::write_atomic`], so a failed write never leaves a
//! half-written file.
#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod binvox;
pub mod carmen;
mod error;
pub mod frame;
pub mod frames;
pub mod graph;
mod input;
pub mod mcap;
pub mod organized;
pub mod output;
pub mod packed_color;
pub mod pcd;
pub mod ply;
pub mod pose;
pub mod source;
pub mod text;
pub mod tum;
pub mod vtk;

pub use error::{FormatError, Location};
pub use frame::Frame;
pub use graph::GraphOptions;
pub use input::{count_frames, frame_stream, read_frames, FrameStream, InputFormat, ReadOptions};
pub use octoquant_octree::Color;
pub use octoquant_raycast::PinholeCamera;
pub use pcd::{PcdOptions, ViewpointUse};
pub use source::DecompressionLimit;
pub use tum::{CameraIntrinsics, TumOptions};
