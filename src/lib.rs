//! octoquant: OctoMap-compatible occupancy mapping, fast.
//!
//! # Quick start
//!
//! Build a map from frames (a sensor origin and the end points of its rays, in world
//! coordinates) with a [`Mapper`], query it, cast a ray through it and save it:
//!
//! ```
//! use nalgebra::{Point3, Vector3};
//! use octoquant::raycast::{cast_ray, CastOptions};
//! use octoquant::treefile::{read_tree_file, save_tree_file};
//! use octoquant::{Frame, Mapper, MapperOptions};
//!
//! let mut mapper = Mapper::new(MapperOptions {
//!     resolution: 0.1,
//!     max_range: Some(20.0),
//!     ..MapperOptions::default()
//! })?;
//! // one frame: a sensor at (0, 0.52, 0.52) facing a wall 2 m away
//! let wall: Vec<Point3<f64>> = (0..400)
//!     .map(|i| Point3::new(2.02, 0.02 + 0.05 * (i % 20) as f64, 0.02 + 0.05 * (i / 20) as f64))
//!     .collect();
//! mapper.insert(&Frame::new(Point3::new(0.0, 0.52, 0.52), &wall));
//! let tree = mapper.into_tree();
//!
//! // the wall is occupied, the space in front of it free, the space behind it unknown
//! assert!(tree.probability_at(&Point3::new(2.02, 0.52, 0.52)).unwrap() > 0.5);
//! assert!(tree.probability_at(&Point3::new(1.05, 0.52, 0.52)).unwrap() < 0.5);
//! assert_eq!(tree.probability_at(&Point3::new(3.05, 0.52, 0.52)), None);
//!
//! // a ray along +x from the sensor stops at the wall, in the voxel centred at x = 2.05
//! let ray = cast_ray(
//!     &tree,
//!     &Point3::new(0.0, 0.52, 0.52),
//!     &Vector3::new(1.0, 0.0, 0.0),
//!     &CastOptions::default(),
//! );
//! assert!(ray.hit && (ray.end.unwrap().x - 2.05).abs() < 1e-9);
//!
//! // save as OctoMap's .bt (the tree itself is left as it is) and read it back
//! let path = std::env::temp_dir().join(format!("quick-start-{}.bt", std::process::id()));
//! save_tree_file(&tree, &path)?;
//! let back = read_tree_file(&path)?;
//! assert!(back.probability_at(&Point3::new(2.02, 0.52, 0.52)).unwrap() > 0.5);
//! # std::fs::remove_file(&path)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Precision: coordinates are `f64` everywhere in the public API (as above), and the `f32`
//! fast paths, which compute in OctoMap's `float` exactly as OctoMap does, carry `_f32` in
//! their names (`cast_ray_f32`, `compute_update_f32`, [`Frame::new_f32`], ...); a [`Frame`]
//! stores `f32`, as OctoMap's `Pointcloud` does, and [`Frame::new`] narrows into it.
//!
//! This crate wires the workspace together: it re-exports the octree crate and the sensor
//! formats (with their atomic file output), and adds the insertion pipeline, tree file reading
//! with errors that name the file, rendering, export, collision queries, the scene simulator
//! and the `octoquant` command-line tool.
#![deny(missing_docs)]

pub mod checkpoint;
pub mod color_map;
pub mod compare_image;
pub mod eval;
pub mod export;
pub mod filters;
pub mod grid;
pub mod import;
pub mod keyset_order;
mod map_stats;
mod mapper_options;
pub mod pipeline;
pub mod query;
pub mod render;
pub mod rows;
pub mod scene;
pub mod stamped_map;
pub mod tiled;
pub mod treefile;

/// Distance maps with the numbers of OctoMap's dynamicEDT3D (the `octoquant-distance` crate).
pub use octoquant_distance as distance;
pub use octoquant_formats as formats;
pub use octoquant_formats::{frame, output, Frame};
pub use octoquant_octree as octree;
pub use octoquant_octree::{InnerNodes, Key, KeyConverter, OcTree, OccupancyParams, Update};
/// OctoMap's rays, `castRay` and `insertPointCloud` (the `octoquant-raycast` crate), for
/// callers that use only this crate (the Python bindings).
pub use octoquant_raycast as raycast;
/// Exact tiled map building (the `octoquant-tiles` crate): a frame's voxel sets split by
/// tile, applied per tile, joined; see [`tiled`] for frames in, tile lists out.
pub use octoquant_tiles as tiles;
pub use parry3d;
pub use pipeline::{
    FramePairs, Mapper, MapperOptions, FLOW_MAX_THREADS, FLOW_MIN_FRAMES, SMALL_FRAME_BRICKS,
};
