//! OctoMap-compatible probabilistic occupancy octree: keys, log-odds updates, pruning,
//! queries and byte-identical `.bt`/`.ot` files.
//!
//! The main types: [`KeyConverter`] turns coordinates into [`Key`]s exactly as OctoMap 1.9.7
//! does; [`OcTree`] stores log-odds per node under an [`OccupancyParams`] sensor model and
//! reproduces OctoMap's `updateNode`, `prune`, `toMaxLikelihood` bit for bit; [`io`] reads and
//! writes the two OctoMap file formats. Nodes live in arenas of 8-child blocks addressed by
//! `u32` indices, voxels as `u16` indices into a per-tree palette of values (4-8 bytes per node
//! on real maps, against OctoMap's ~27).
//!
//! ```
//! use octoquant_octree::{io, InnerNodes, OcTree, Update};
//! use nalgebra::Point3;
//!
//! let mut tree = OcTree::new(0.1).unwrap();
//! let key = tree.converter().point_to_key(&Point3::new(1.0, 2.0, 0.5)).unwrap();
//! tree.update_node(key, Update::Hit, InnerNodes::Refresh);
//! assert_eq!(tree.is_occupied(key), Some(true));
//!
//! let mut bytes = Vec::new();
//! io::write_bt(&mut tree, &mut bytes).unwrap();
//! let back = io::read_bt(&bytes[..]).unwrap();
//! assert_eq!(back.size(), tree.size());
//! ```
#![deny(missing_docs)]
#![forbid(unsafe_code)]

mod brick;
mod color;
mod color_batch;
mod color_tree;
mod compare;
mod crop;
mod error;
mod free_list;
pub mod io;
mod iter;
mod key;
mod key_hasher;
mod key_set_log;
pub mod key_table;
mod merge;
mod node_id;
mod packed_slabs;
mod params;
mod payload_tree;
mod slab_index;
mod stamped_tree;
mod store;
mod tree;
mod tree_batch;
mod tree_prune;
mod tree_surgery;
pub mod validate;

pub use brick::Brick;
pub use color::Color;
pub use color_tree::{ColorNodeInfo, ColorOcTree};
pub use compare::{
    compare_classes, for_each_class_cube, kl_divergence, voxel_kld, ClassComparison, ClassCube,
    Divergence, VoxelClass, KLD_ORDERED_VOXELS,
};
pub use error::OctreeError;
pub use iter::{NodeItem, TreeIter};
pub use key::{Key, KeyConverter, KEY_CENTER, TREE_DEPTH};
pub use key_set_log::{KeySetLog, KeySetPart, PartRange, RangeInsert, MAX_WINDOW_VOXELS};
pub use key_table::KeyTable;
pub use merge::MergeStats;
pub use params::{logodds, probability, OccupancyParams, SensorPreset, SensorProbabilities};
pub use stamped_tree::{now_seconds, StampedNodeInfo, StampedOcTree};
pub use store::MemoryUsage;
pub use tree::{Counts, InnerNodes, NodeInfo, OcTree, Update};
