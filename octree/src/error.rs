//! The octree crate's single error type.

use thiserror::Error;

/// Everything that can go wrong in key conversion, tree configuration and `.bt`/`.ot` I/O.
///
/// I/O variants carry the byte offset in the stream where the problem was found; callers that
/// know the file name wrap the error with it.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum OctreeError {
    /// The resolution is zero, negative, NaN or infinite.
    #[error("invalid resolution {resolution}: must be finite and > 0")]
    InvalidResolution {
        /// The rejected value.
        resolution: f64,
    },
    /// A point lies outside the key range `[-32768·res, 32768·res)` or has a NaN coordinate.
    #[error("point ({}, {}, {}) is outside the map", point[0], point[1], point[2])]
    OutOfMap {
        /// The rejected point.
        point: [f64; 3],
    },
    /// A sensor-model probability is outside its valid range.
    #[error("invalid {name} probability {value}: {reason}")]
    InvalidProbability {
        /// Which parameter.
        name: &'static str,
        /// The rejected value.
        value: f64,
        /// Why it was rejected.
        reason: &'static str,
    },
    /// A log-odds value that is NaN cannot be stored in the tree.
    #[error("log-odds value is NaN")]
    NanValue,
    /// Two maps that must share a resolution do not.
    #[error("resolutions differ: {first} and {second}")]
    ResolutionMismatch {
        /// The first map's resolution.
        first: f64,
        /// The second map's resolution.
        second: f64,
    },
    /// A node holds a NaN or infinite log-odds where a finite one is needed (a leaf of the
    /// tree merged in by [`crate::OcTree::merge`]).
    #[error("the node at key {key:?}, depth {depth} has the non-finite log-odds {value}")]
    NonFiniteValue {
        /// The node's key (iterator convention).
        key: [u16; 3],
        /// Its depth.
        depth: u8,
        /// The value.
        value: f32,
    },
    /// [`OcTree::try_expand`](crate::OcTree::try_expand) was asked to expand a tree into more
    /// nodes than its limit.
    #[error("expanding the tree would add {nodes} nodes, more than the limit of {limit}")]
    ExpansionTooLarge {
        /// The nodes the expansion would add.
        nodes: u64,
        /// The limit it was given.
        limit: u64,
    },
    /// An operation that this tree's configuration does not support.
    #[error("unsupported: {what}")]
    Unsupported {
        /// What was asked.
        what: &'static str,
    },
    /// A depth outside 0..=16 was requested.
    #[error("depth {depth} is outside 0..=16")]
    InvalidDepth {
        /// The rejected depth.
        depth: u32,
    },
    /// The stream ended or failed while reading.
    #[error("read failed at byte {offset}: {source}")]
    Io {
        /// Byte offset from the start of the stream.
        offset: u64,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The file's structure is invalid (bad header, garbage, wrong counts).
    #[error("invalid {format} data at byte {offset}: {message}")]
    Format {
        /// `.bt` or `.ot`.
        format: &'static str,
        /// Byte offset from the start of the stream.
        offset: u64,
        /// What is wrong.
        message: String,
    },
    /// The file holds a tree type other than `OcTree` (for example a `ColorOcTree`, which
    /// [`crate::io::read_color_ot`] reads, or an `OcTreeStamped`, which
    /// [`crate::io::read_stamped_ot`] reads).
    #[error("unsupported tree type {id:?} (OcTree readers take OcTree only; ColorOcTree and OcTreeStamped files have their own readers)")]
    UnsupportedTreeType {
        /// The id from the file header.
        id: String,
    },
    /// A reader for one tree type met a file of another (a `ColorOcTree` reader given an
    /// `OcTree`, say).
    #[error("the file holds a tree of type {id:?}, not the {expected} this reader takes")]
    WrongTreeType {
        /// The id from the file header.
        id: String,
        /// The tree type the reader takes.
        expected: &'static str,
    },
}
