//! Tiles from a caller's numbers, checked: [`Tile::new`] and [`Tile::of_key`] validate a
//! depth and an index and return the [`TileError`] that says what is wrong.
//!
//! They are apart from the [`Tile`] type itself because the error's variants name tiles:
//! this module uses both [`crate::tile`] and [`crate::error`], and neither uses it back.

use crate::error::TileError;
use crate::tile::Tile;
use octoquant_octree::{Key, TREE_DEPTH};

/// Checks a tile depth: 0..=16.
pub(crate) fn check_depth(depth: u8) -> Result<(), TileError> {
    if depth > TREE_DEPTH {
        return Err(TileError::InvalidDepth { depth });
    }
    Ok(())
}

impl Tile {
    /// The tile at `depth` with Morton prefix `index`; errors for a depth above 16 or an index
    /// of more than `3 * depth` bits.
    pub fn new(depth: u8, index: u64) -> Result<Tile, TileError> {
        check_depth(depth)?;
        if index >> (3 * depth as u32) != 0 {
            return Err(TileError::InvalidTile { depth, index });
        }
        Ok(Tile::from_checked(depth, index))
    }

    /// The tile at `depth` holding voxel `key`; errors for a depth above 16.
    pub fn of_key(key: Key, depth: u8) -> Result<Tile, TileError> {
        check_depth(depth)?;
        Ok(Tile::of_code(key.morton(), depth))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_tiles_are_errors() {
        assert!(matches!(
            Tile::new(17, 0),
            Err(TileError::InvalidDepth { depth: 17 })
        ));
        assert!(Tile::new(2, 63).is_ok());
        assert!(matches!(
            Tile::new(2, 64),
            Err(TileError::InvalidTile {
                depth: 2,
                index: 64
            })
        ));
        assert!(Tile::of_key(Key::new(0, 0, 0), 17).is_err());
        assert!(!Tile::new(0, 0).unwrap().contains_code(1 << 48));
    }
}
