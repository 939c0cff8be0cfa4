//! Exact tiled map building: the pieces that let many processes build one OctoMap tree with
//! the bytes of a single sequential run.
//!
//! A *tile* ([`Tile`]) is one node at a fixed depth (`tile_depth`, 0..=16) of OctoMap's key
//! space, with everything below it. The three steps:
//!
//! 1. [`split_update`] / [`TileSplitter`]: one frame's free and occupied voxel sets (the
//!    [`ScanUpdate`](octoquant_raycast::ScanUpdate) of the exact pipeline, each voxel once,
//!    occupied winning) become per-tile [`TileUpdates`]: sorted Morton codes, tagged with the
//!    frame's index. [`TileUpdates::to_bytes`] / [`TileUpdates::from_bytes`] ship them
//!    between processes (little endian, versioned, checked on read).
//! 2. [`apply_tile_updates`]: a tile's lists, merged and applied in frame order to the tile's
//!    own [`OcTree`](octoquant_octree::OcTree) with OctoMap's `updateNode` (clamping,
//!    pruning, inner nodes refreshed), exactly as the sequential map applies them.
//! 3. [`join_tiles`]: the tile trees joined into one tree, the levels above the tile depth
//!    recomputed as OctoMap would have them.
//! 4. Out of core ([`write_tile`], [`write_index`], [`join_dir`]): tile trees kept as one
//!    `.ot` file per tile plus an index, assembled later.
//!
//! # Why the result is the sequential tree, node for node
//!
//! OctoMap's `updateNode` touches only the voxel's path. Within a frame the free and occupied
//! sets are disjoint and each voxel is updated once, so the order inside a frame does not
//! matter (octomap-facts §3.1); across frames, a tile's voxels are updated in frame order in
//! both runs. Below the tile depth, the sequential tree's subtree of a tile therefore
//! evolves exactly like the tile's own tree, with one exception that changes nothing: when a
//! node above the tile depth is pruned (all eight children equal leaves, so the tile itself
//! was a leaf of that value), a later update expands it again into leaves of the same value,
//! which is the tile's own state. The early exit of `updateNode` (a node at the clamp) sees
//! the same value in both. Above the tile depth, non-lazy updates keep the sequential tree
//! canonical after every update: each ancestor of an updated voxel is pruned when its eight
//! children are equal leaves and otherwise set to the max of its children, and no other node
//! changes. So at the end every node above the tile depth is the max of its children, or
//! pruned exactly when its eight children are leaves of equal value (float `==`, child 0's
//! value kept), bottom-up, root included: what [`join_tiles`] computes. The tests check it
//! against the sequential map byte for byte (`.bt` and `.ot`) on random frame sequences and
//! on real data.
//!
//! ```
//! use nalgebra::Point3;
//! use octoquant_octree::{io, OcTree, OccupancyParams};
//! use octoquant_raycast::{apply_update, compute_update_f32, ApplyOptions, ScanUpdate};
//! use octoquant_tiles::{apply_tile_updates, join_tiles, TileSplitter, TileUpdates};
//!
//! let origin = Point3::new(0.05f32, 0.05, 0.05);
//! let wall: Vec<Point3<f32>> = (0..400)
//!     .map(|i| Point3::new(2.0, 0.1 * (i % 20) as f32 - 0.95, 0.1 * (i / 20) as f32 - 0.95))
//!     .collect();
//! let (mut sequential, mut update) = (OcTree::new(0.1)?, ScanUpdate::new());
//! let mut splitter = TileSplitter::new(3)?;
//! for frame in 0..3 {
//!     compute_update_f32(sequential.converter(), &wall, &origin, None, &mut update);
//!     apply_update(&mut sequential, &update, &ApplyOptions::default());
//!     splitter.add(frame, &update)?;
//! }
//! // each tile's lists travel as bytes, are applied to the tile's own tree, then joined
//! let mut tiles = Vec::new();
//! for lists in splitter.finish() {
//!     let back = TileUpdates::from_bytes(&lists.to_bytes()?)?;
//!     let mut tree = OcTree::new(0.1)?;
//!     apply_tile_updates(&mut tree, back.tile, &[back])?;
//!     tiles.push(tree);
//! }
//! let joined = join_tiles(0.1, OccupancyParams::default(), 3, &tiles)?;
//! let (mut a, mut b) = (Vec::new(), Vec::new());
//! io::write_ot(&joined, &mut a)?;
//! io::write_ot(&sequential, &mut b)?;
//! assert_eq!(a, b);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Lazy insertion (`InnerNodes::Defer`) is not covered: its trees keep stale inner nodes and
//! unpruned expansions, which this join does not reproduce.
#![deny(missing_docs)]
#![forbid(unsafe_code)]

mod apply;
mod codec;
mod error;
mod join;
mod join_stream;
mod spill;
mod split;
mod tile;
mod tile_check;

pub use apply::{apply_tile_updates, ApplyStats};
pub use error::TileError;
pub use join::{join_tiles, tile_of_tree};
pub use join_stream::StreamJoin;
pub use spill::{
    join_dir, read_index, tile_file_name, tile_paths, write_index, write_tile, TileIndex,
    INDEX_FILE,
};
pub use split::{split_update, TileFrame, TileSplitter, TileUpdates};
pub use tile::Tile;
