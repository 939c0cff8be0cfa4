//! A growable pool of fixed-size blocks addressed by `u32` indices, with a free list.
//!
//! Both kinds of node blocks (inner blocks and depth-16 voxel blocks) live in arenas: a node
//! refers to its children by the index of their block, and a freed block is reset to empty and
//! handed out again before the pool grows.
//!
//! The blocks sit in a [`PageVec`]: a large arena grows by remapping pages instead of copying
//! into a buffer twice its size, so growing never holds the arena twice (which would set the
//! peak memory of a whole mapping run).

use octoquant_pages::PageVec;

/// An index no arena hands out: as a child-block index, "this node has no children".
pub(crate) const NO_BLOCK: u32 = u32::MAX;

/// A growable pool of blocks with a free list; freed blocks are reset to empty.
#[derive(Clone)]
pub(crate) struct Arena<B: Copy> {
    pub blocks: PageVec<B>,
    free: Vec<u32>,
    empty: B,
}

impl<B: Copy> Arena<B> {
    /// An empty arena whose blocks start (and are reset to) `empty`.
    pub fn new(empty: B) -> Self {
        Arena {
            blocks: PageVec::new(),
            free: Vec::new(),
            empty,
        }
    }

    /// An empty block: a freed one if any, else a new one at the end.
    #[inline]
    pub fn alloc(&mut self) -> u32 {
        if let Some(i) = self.free.pop() {
            i
        } else {
            let i = self.blocks.len();
            assert!(
                i < NO_BLOCK as usize,
                "octree node arena exhausted (2^32 blocks)"
            );
            self.blocks.push(self.empty);
            i as u32
        }
    }

    /// Free block `i`: reset it to empty and keep it for reuse.
    #[inline]
    pub fn release(&mut self, i: u32) {
        self.blocks[i as usize] = self.empty;
        self.free.push(i);
    }

    /// Drop every block (capacity is kept).
    pub fn clear(&mut self) {
        self.blocks.clear();
        self.free.clear();
    }

    /// The same arena with every block converted by `f` (indices and free list kept).
    pub fn map_blocks<C: Copy>(&self, empty: C, f: impl Fn(&B) -> C) -> Arena<C> {
        Arena {
            blocks: self.blocks.iter().map(f).collect(),
            free: self.free.clone(),
            empty,
        }
    }

    /// Blocks in use (allocated and not on the free list).
    pub fn live(&self) -> usize {
        self.blocks.len() - self.free.len()
    }

    /// Bytes held by the blocks in use, and by the freed blocks awaiting reuse with the free
    /// list.
    pub fn split_bytes(&self) -> (usize, usize) {
        let size = std::mem::size_of::<B>();
        (self.live() * size, self.free.len() * (size + 4))
    }
}
