//! A brick: the 4x4x4 voxels below one depth-14 node, the unit in which whole voxel sets reach
//! the tree ([`OcTree::update_bricks`](crate::OcTree::update_bricks)).

/// The voxels of one brick of 4x4x4 voxels: the brick's code and a 64-bit mask of the voxels
/// it holds.
///
/// A key's Morton code ([`Key::morton`](crate::Key::morton)) splits into its brick
/// (`code >> 6`, the Morton code of its depth-14 node) and its bit in the brick (`code & 63`,
/// itself the Morton order of the brick's 64 voxels). So bricks sorted by code list their
/// voxels in Morton order, the tree's own depth-first order, and a scan's voxel sets travel
/// as a brick per 64 voxels instead of a key per voxel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Brick {
    /// The Morton code of the brick's depth-14 node: `key.morton() >> 6` of any voxel in it
    /// (bits above the 42nd are ignored by the tree).
    pub code: u64,
    /// The brick's voxels: bit `i` stands for the voxel at Morton offset `i` inside the brick
    /// (`key.morton() & 63`).
    pub voxels: u64,
}

impl Brick {
    /// The brick of the voxel whose Morton code is `code`, holding that voxel alone.
    #[inline(always)]
    pub fn of_voxel(code: u64) -> Self {
        Brick {
            code: code >> 6,
            voxels: 1u64 << (code & 63),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Key;

    #[test]
    fn a_voxel_splits_into_its_brick_and_bit() {
        let k = Key::new(4, 9, 14);
        let b = Brick::of_voxel(k.morton());
        assert_eq!(b.code, k.morton() >> 6);
        assert_eq!(b.voxels, 1 << (k.morton() & 63));
        assert_eq!(b.voxels.count_ones(), 1);
    }
}
