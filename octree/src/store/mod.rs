//! Node storage: arenas of 8-child blocks addressed by `u32` indices ([`nodes`]), and the
//! depth-16 voxel blocks with their palette of values ([`voxel_blocks`]).

mod nodes;
mod voxel_blocks;

pub use nodes::MemoryUsage;
pub(crate) use nodes::{present, NodeRef, NodeStore, NO_BLOCK};
pub(crate) use voxel_blocks::{Adder, Outcome};
