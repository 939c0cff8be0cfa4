//! A tile: one node at a fixed depth of OctoMap's key space, named by its Morton prefix.
//!
//! What a tile is and where it lies. The constructors that check a caller's depth and index,
//! [`Tile::new`] and [`Tile::of_key`], are in `tile_check.rs`, beside the error they return:
//! the error's variants name tiles, so the error module uses this one, and this one uses
//! neither.

use octoquant_octree::{Key, TREE_DEPTH};

/// The bits of a voxel's Morton code ([`Key::morton`]): three per level, 16 levels.
pub(crate) const CODE_BITS: u32 = 3 * TREE_DEPTH as u32;

/// One node at depth `depth` (0 = the root, the whole map; 16 = one voxel) and its subtree.
///
/// `index` is the node's Morton prefix: the top `3 * depth` bits of the Morton code of any
/// voxel inside it (`code >> 3 * (16 - depth)`). Its digits, three bits per level from the
/// most significant, are the child indices (OctoMap's `computeChildIdx`) on the way from the
/// root, so tiles sorted by index are in the tree's depth-first order, as are the voxels
/// sorted by code.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Tile {
    depth: u8,
    index: u64,
}

impl std::fmt::Display for Tile {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "tile {} at depth {}", self.index, self.depth)
    }
}

impl Tile {
    /// The tile at `depth` with Morton prefix `index`, both already checked (the checked
    /// constructor is [`Tile::new`]): for code that has validated them against the error it
    /// returns.
    pub(crate) fn from_checked(depth: u8, index: u64) -> Tile {
        debug_assert!(depth <= TREE_DEPTH && index >> (3 * depth as u32) == 0);
        Tile { depth, index }
    }

    /// The tile at `depth` (at most 16) holding the voxel with Morton code `code` (bits above
    /// the 48th ignored).
    pub(crate) fn of_code(code: u64, depth: u8) -> Tile {
        debug_assert!(depth <= TREE_DEPTH);
        let code = code & ((1u64 << CODE_BITS) - 1);
        Tile {
            depth,
            index: code >> shift(depth),
        }
    }

    /// The tile's depth (0 = root .. 16 = voxel).
    pub fn depth(&self) -> u8 {
        self.depth
    }

    /// The tile's Morton prefix.
    pub fn index(&self) -> u64 {
        self.index
    }

    /// Whether the voxel with Morton code `code` lies in this tile.
    pub fn contains_code(&self, code: u64) -> bool {
        code >> CODE_BITS == 0 && code >> shift(self.depth) == self.index
    }

    /// The child index (0..8, OctoMap's `computeChildIdx`) taken below the node at depth
    /// `d < depth` on the way from the root to this tile.
    pub fn child_index_at(&self, d: u8) -> usize {
        debug_assert!(d < self.depth);
        ((self.index >> (3 * (self.depth - 1 - d) as u32)) & 7) as usize
    }

    /// The smallest voxel key inside the tile.
    pub fn min_key(&self) -> Key {
        Key::from_morton(self.index << shift(self.depth))
    }
}

/// How far a voxel code is shifted to give its tile's index at `depth`.
fn shift(depth: u8) -> u32 {
    3 * (TREE_DEPTH - depth) as u32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tile_holds_the_voxels_on_its_path() {
        let key = Key::new(40000, 1234, 65535);
        for depth in 0..=TREE_DEPTH {
            let t = Tile::of_key(key, depth).unwrap();
            assert!(t.contains_code(key.morton()));
            // the digits of the index are the child indices of the key's path
            for d in 0..depth {
                assert_eq!(
                    t.child_index_at(d),
                    key.child_index(d),
                    "depth {depth}, level {d}"
                );
            }
            assert_eq!(t.min_key(), key.min_at_depth(depth));
            assert_eq!(Tile::new(depth, t.index()).unwrap(), t);
        }
        let other = Key::new(40000, 1234, 0);
        assert!(!Tile::of_key(key, 1).unwrap().contains_code(other.morton()));
        assert!(Tile::of_key(key, 0).unwrap().contains_code(other.morton()));
    }
}
