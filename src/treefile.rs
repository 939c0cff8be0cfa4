//! Reading and writing `.bt`/`.ot` files by path, with errors that name the file.

use crate::output::{write_atomic, OutputError};
use octoquant_octree::io::{self, TreeFormat, COLOR_OCTREE_ID, STAMPED_OCTREE_ID};
use octoquant_octree::{ColorOcTree, OcTree, OctreeError, StampedOcTree};
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
    /// A coloured tree asked to be written as `.bt`, which holds occupancy only.
    #[error("{}: a ColorOcTree is written as .ot (a .bt holds occupancy only)", path.display())]
    ColorNeedsOt {
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

/// The tree of a `.bt`/`.ot` file, of whichever OctoMap type the file holds.
#[derive(Debug, Clone)]
pub enum AnyTree {
    /// `OcTree` (every `.bt`, and `.ot` files of that type).
    Plain(OcTree),
    /// `ColorOcTree` (`.ot` only): occupancy and a colour per node.
    Color(ColorOcTree),
    /// `OcTreeStamped` (`.ot` only; OctoMap does not save the stamps, so every node's stamp
    /// is 0 when read).
    Stamped(StampedOcTree),
}

impl AnyTree {
    /// OctoMap's name of the tree type, as in the `.ot` header (`OcTree`, `ColorOcTree`,
    /// `OcTreeStamped`).
    pub fn type_name(&self) -> &'static str {
        match self {
            AnyTree::Plain(_) => "OcTree",
            AnyTree::Color(_) => COLOR_OCTREE_ID,
            AnyTree::Stamped(_) => STAMPED_OCTREE_ID,
        }
    }

    /// The occupancy tree (what a `.bt` keeps of any type).
    pub fn occupancy(&self) -> &OcTree {
        match self {
            AnyTree::Plain(t) => t,
            AnyTree::Color(t) => t.occupancy(),
            AnyTree::Stamped(t) => t.occupancy(),
        }
    }

    /// The occupancy tree, consuming the colours or stamps.
    pub fn into_occupancy(self) -> OcTree {
        match self {
            AnyTree::Plain(t) => t,
            AnyTree::Color(t) => t.into_occupancy(),
            AnyTree::Stamped(t) => t.into_occupancy(),
        }
    }

    /// The coloured tree, when the file held one.
    pub fn colors(&self) -> Option<&ColorOcTree> {
        match self {
            AnyTree::Color(t) => Some(t),
            _ => None,
        }
    }
}

/// Read a `.bt` or `.ot` file of any OctoMap tree type this crate knows (`OcTree`,
/// `ColorOcTree`, `OcTreeStamped`); other types are an error naming the type and the file.
pub fn read_any_tree_file(path: &Path) -> Result<AnyTree, TreeFileError> {
    let id = match read_tree_file(path) {
        Ok(t) => return Ok(AnyTree::Plain(t)),
        Err(TreeFileError::Parse {
            source: OctreeError::UnsupportedTreeType { id },
            ..
        }) => id,
        Err(e) => return Err(e),
    };
    let open = || {
        std::fs::File::open(path).map_err(|source| TreeFileError::Open {
            path: path.to_path_buf(),
            source,
        })
    };
    let parse = |source| TreeFileError::Parse {
        path: path.to_path_buf(),
        source,
    };
    match id.as_str() {
        COLOR_OCTREE_ID => Ok(AnyTree::Color(io::read_color_ot(open()?).map_err(parse)?)),
        STAMPED_OCTREE_ID => Ok(AnyTree::Stamped(
            io::read_stamped_ot(open()?).map_err(parse)?,
        )),
        _ => Err(parse(OctreeError::UnsupportedTreeType { id })),
    }
}

/// Write a `ColorOcTree` to `path` atomically as `.ot` (the only format that holds colours);
/// `.bt` is [`TreeFileError::ColorNeedsOt`], another extension
/// [`TreeFileError::UnknownFormat`].
pub fn save_color_tree_file(tree: &ColorOcTree, path: &Path) -> Result<(), TreeFileError> {
    match TreeFormat::from_path(path) {
        Some(TreeFormat::Ot) => Ok(write_atomic(path, |w| io::write_color_ot(tree, w))?),
        Some(TreeFormat::Bt) => Err(TreeFileError::ColorNeedsOt {
            path: path.to_path_buf(),
        }),
        None => Err(TreeFileError::UnknownFormat {
            path: path.to_path_buf(),
        }),
    }
}
