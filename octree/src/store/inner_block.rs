//! The block of eight inner nodes (depths 1..=15): what [`super::nodes`] keeps in its inner
//! arena and what [`super::voxel_blocks`] refreshes when it updates the depth-15 nodes of a
//! brick in place.

use super::arena::NO_BLOCK;
use super::slot::ABSENT;

/// Eight children at depths 1..=15: their log-odds and their own child blocks.
#[derive(Clone, Copy)]
#[repr(C, align(64))]
pub(crate) struct InnerBlock {
    pub vals: [f32; 8],
    pub kids: [u32; 8],
}

/// A block of eight absent children.
pub(crate) const EMPTY_INNER: InnerBlock = InnerBlock {
    vals: [ABSENT; 8],
    kids: [NO_BLOCK; 8],
};
