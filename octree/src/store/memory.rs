//! Where the bytes of the node storage go.

/// Where the bytes of [`crate::OcTree::memory_usage`] go.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MemoryUsage {
    /// Blocks of eight depth 1..=15 children in use (64 bytes each).
    pub inner_blocks: usize,
    /// Blocks of eight depth-16 children in use.
    pub leaf_blocks: usize,
    /// Bytes of one depth-16 block: 16 (palette indices), or 32 (values) once the tree holds
    /// more distinct voxel values than the palette takes.
    pub leaf_block_bytes: usize,
    /// Bytes of the blocks in use.
    pub block_bytes: usize,
    /// Bytes of blocks freed by pruning or deletion and kept for reuse, with their free
    /// lists (0 after [`crate::OcTree::shrink_to_fit`]).
    pub free_bytes: usize,
    /// Bytes of the depth-16 value palette: values, hash index, update memos (0 when wide).
    pub palette_bytes: usize,
    /// Distinct depth-16 values in the palette (`None` when wide).
    pub palette_values: Option<usize>,
    /// The fixed part: the tree and storage structs.
    pub fixed_bytes: usize,
}

impl MemoryUsage {
    /// All bytes: what [`crate::OcTree::memory_usage`] returns.
    pub fn total(&self) -> usize {
        self.block_bytes + self.free_bytes + self.palette_bytes + self.fixed_bytes
    }

    /// All bytes but the freed blocks awaiting reuse: what [`crate::OcTree::shrink_to_fit`]
    /// would leave (up to palette values no voxel holds any more), measured without the copy
    /// that shrinking makes (which briefly holds the tree twice).
    pub fn in_use(&self) -> usize {
        self.block_bytes + self.palette_bytes + self.fixed_bytes
    }
}
