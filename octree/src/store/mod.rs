//! Node storage: arenas of 8-child blocks addressed by `u32` indices, and the per-tree palette
//! of depth-16 values.
//!
//! - [`slot`]: a node's value slot, its log-odds or the absent marker of a missing child.
//! - [`arena`]: a pool of blocks with a free list.
//! - [`inner_block`]: the block of eight inner nodes.
//! - [`palette`]: the distinct depth-16 values and the memoized voxel updates over them.
//! - [`voxel_blocks`]: the depth-16 blocks, as palette indices or, past its limit, as values.
//! - [`nodes`]: [`NodeStore`], the tree's nodes over inner and voxel blocks, and [`NodeRef`].
//! - [`memory`]: where the bytes go ([`MemoryUsage`]).
//!
//! The tree ([`crate::OcTree`]) sees only [`NodeStore`] and its handles; the layers below it
//! use only the layers listed above them.

mod arena;
mod inner_block;
mod memory;
mod nodes;
mod palette;
mod slot;
mod voxel_blocks;

pub(crate) use arena::NO_BLOCK;
pub use memory::MemoryUsage;
pub(crate) use nodes::{NodeRef, NodeStore};
#[cfg(test)]
pub(crate) use palette::PALETTE_LIMIT;
pub(crate) use palette::{clamp_sum, Adder};
pub(crate) use slot::present;
pub(crate) use voxel_blocks::Outcome;
