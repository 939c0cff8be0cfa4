//! The tiles crate's error type.

use crate::tile::Tile;
use thiserror::Error;

/// Everything that can go wrong splitting, shipping, applying and joining tiles.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum TileError {
    /// A tile depth above 16 (the voxel level).
    #[error("invalid tile depth {depth}: must be 0..=16")]
    InvalidDepth {
        /// The rejected depth.
        depth: u8,
    },
    /// A tile index with more bits than its depth allows.
    #[error("invalid tile index {index} at depth {depth}: must be below 8^{depth}")]
    InvalidTile {
        /// The tile's depth.
        depth: u8,
        /// The rejected index.
        index: u64,
    },
    /// A tile update buffer that is not one [`crate::TileUpdates::to_bytes`] wrote.
    #[error("bad tile update buffer at byte {offset}: {message}")]
    Decode {
        /// Where in the buffer the problem was found.
        offset: usize,
        /// What is wrong.
        message: String,
    },
    /// Update lists of another tile than the one being built.
    #[error("update lists of {found} given to {expected}")]
    WrongTile {
        /// The tile being built.
        expected: Tile,
        /// The tile the lists belong to.
        found: Tile,
    },
    /// The same frame twice in one tile's lists (a batch shipped twice?).
    #[error("{tile}: frame {frame} appears twice in its update lists")]
    DuplicateFrame {
        /// The tile.
        tile: Tile,
        /// The repeated frame index.
        frame: u64,
    },
    /// Frames given out of order, or a list that breaks its own invariants.
    #[error("{tile}: {message}")]
    BadList {
        /// The tile.
        tile: Tile,
        /// What is wrong.
        message: String,
    },
    /// A tile tree with nodes outside its tile, or none inside it.
    #[error("the tree given for {tile} {message}")]
    NotATileTree {
        /// The tile.
        tile: Tile,
        /// What is wrong.
        message: String,
    },
    /// The same tile twice in a join.
    #[error("{tile} is given twice")]
    DuplicateTile {
        /// The tile.
        tile: Tile,
    },
    /// Tiles or trees that disagree on depth, resolution or sensor model.
    #[error("tiles disagree: {0}")]
    Mismatch(String),
    /// Reading or writing a file of a tile directory failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: std::path::PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// A tile directory's index is malformed.
    #[error("{}, line {line}: {message}", path.display())]
    BadIndex {
        /// The index file.
        path: std::path::PathBuf,
        /// The line (1-based; 0 for the file as a whole).
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// A tile file that is not the tile tree its index names.
    #[error("{}: {message}", path.display())]
    BadTileFile {
        /// The tile file.
        path: std::path::PathBuf,
        /// What is wrong.
        message: String,
    },
    /// Writing a joined map to its output failed.
    #[error("writing the joined map: {0}")]
    Write(#[source] std::io::Error),
    /// The octree refused (a resolution, or the joined tree's stream).
    #[error(transparent)]
    Octree(#[from] octoquant_octree::OctreeError),
}
