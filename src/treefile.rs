//! Reading and writing `.bt`/`.ot` files by path, with errors that name the file.

use crate::output::{write_atomic, OutputError};
use octoquant_octree::io::{self, TreeFormat};
use octoquant_octree::{OcTree, OctreeError};
use std::path::{Path, PathBuf};

/// The extensions of tree files, as [`TreeFormat::from_path`] knows them (lowercase, no
/// dot): what an output name may end in.
pub const TREE_EXTENSIONS: [&str; 2] = ["bt", "ot"];

/// Errors from tree files, naming the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TreeFileError {
    /// The file could not be opened.
    #[error("cannot open {}: {source}", path.display())]
    Open {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// The contents are invalid.
    #[error("{}: {source}", path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// What is wrong and where.
        #[source]
        source: OctreeError,
    },
    /// The extension is neither `.bt` nor `.ot`.
    #[error("{}: unknown tree format (expected a .bt or .ot extension)", path.display())]
    UnknownFormat {
        /// The file.
        path: PathBuf,
    },
    /// Writing failed.
    #[error(transparent)]
    Write(#[from] OutputError),
}

/// Read a `.bt` or `.ot` file; the format is recognised from the first header line.
pub fn read_tree_file(path: &Path) -> Result<OcTree, TreeFileError> {
    let f = std::fs::File::open(path).map_err(|source| TreeFileError::Open {
        path: path.to_path_buf(),
        source,
    })?;
    io::read_tree(f).map_err(|source| TreeFileError::Parse {
        path: path.to_path_buf(),
        source,
    })
}

/// Write a tree to `path` atomically, in the format its extension names. `.bt` converts the
/// tree to max-likelihood and prunes it first, in place, as OctoMap's `writeBinary` does; use
/// [`save_tree_file`] to keep the tree as it is.
pub fn write_tree_file(tree: &mut OcTree, path: &Path) -> Result<(), TreeFileError> {
    match TreeFormat::from_path(path) {
        Some(TreeFormat::Bt) => Ok(write_atomic(path, |w| io::write_bt(tree, w))?),
        Some(TreeFormat::Ot) => Ok(write_atomic(path, |w| io::write_ot(tree, w))?),
        None => Err(TreeFileError::UnknownFormat {
            path: path.to_path_buf(),
        }),
    }
}

/// Write a tree to `path` atomically, in the format its extension names, leaving the tree as
/// it is: `.ot` holds it unchanged, `.bt` holds what OctoMap's `writeBinary` writes (the
/// max-likelihood, pruned tree), converted on a copy, so the bytes equal
/// [`write_tree_file`]'s at the cost of the copy's memory while it is written.
pub fn save_tree_file(tree: &OcTree, path: &Path) -> Result<(), TreeFileError> {
    match TreeFormat::from_path(path) {
        Some(TreeFormat::Bt) => {
            let mut copy = tree.clone();
            Ok(write_atomic(path, |w| io::write_bt(&mut copy, w))?)
        }
        Some(TreeFormat::Ot) => Ok(write_atomic(path, |w| io::write_ot(tree, w))?),
        None => Err(TreeFileError::UnknownFormat {
            path: path.to_path_buf(),
        }),
    }
}
