//! The one error type of the sensor-format readers: every variant names the file and the place.

use crate::output::OutputError;
use std::fmt;
use std::path::{Path, PathBuf};

/// Where in a file an error was found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Location {
    /// A 1-based line number of a text file (after decompression).
    Line(u64),
    /// A 0-based byte offset of a binary file (after decompression).
    Byte(u64),
    /// The file as a whole (opening it, its name, or a decoder that reports no position).
    File,
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Line(l) => write!(f, "line {l}"),
            Location::Byte(b) => write!(f, "byte {b}"),
            Location::File => f.write_str("file"),
        }
    }
}

/// Errors from reading or writing sensor files.
///
/// Every variant carries the file (`path`) and, where the format allows, the line or byte
/// offset, so a message always says which input was bad and where.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FormatError {
    /// Opening or reading (including decompressing) failed.
    #[error("cannot read {} ({at}): {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Where reading stopped.
        at: Location,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The file ends before a complete record.
    #[error("{} is truncated at byte {offset}: expected {what}", path.display())]
    Truncated {
        /// The file.
        path: PathBuf,
        /// Byte offset (after decompression) where data ran out.
        offset: u64,
        /// What was being read.
        what: String,
    },
    /// The contents do not follow the format.
    #[error("{} ({at}): {message}", path.display())]
    Syntax {
        /// The file.
        path: PathBuf,
        /// Where the problem is.
        at: Location,
        /// What is wrong.
        message: String,
    },
    /// A valid file using a feature this reader does not support.
    #[error("{} ({at}): unsupported: {message}", path.display())]
    Unsupported {
        /// The file.
        path: PathBuf,
        /// Where the feature is declared.
        at: Location,
        /// What is unsupported.
        message: String,
    },
    /// A scan has no pose (or a non-finite one).
    #[error("{} ({at}): no usable pose: {message}", path.display())]
    MissingPose {
        /// The scan file (or the pose file when the pose itself is bad).
        path: PathBuf,
        /// Where the scan or pose is referred to.
        at: Location,
        /// Which pose is missing and why.
        message: String,
    },
    /// The format could not be told from the file name or contents.
    #[error("{}: cannot tell the input format ({message}); pass one explicitly", path.display())]
    UnknownFormat {
        /// The file or directory.
        path: PathBuf,
        /// What was looked at.
        message: String,
    },
    /// A reader option is out of range.
    #[error("{}: invalid option: {message}", path.display())]
    InvalidOption {
        /// The input the option was given for.
        path: PathBuf,
        /// Which option and why.
        message: String,
    },
    /// Writing an output file failed (nothing is left under the target name).
    #[error("cannot write {}: {source}", path.display())]
    Write {
        /// The target file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
}

impl FormatError {
    /// The file the error is about.
    pub fn path(&self) -> &Path {
        match self {
            FormatError::Io { path, .. }
            | FormatError::Truncated { path, .. }
            | FormatError::Syntax { path, .. }
            | FormatError::Unsupported { path, .. }
            | FormatError::MissingPose { path, .. }
            | FormatError::UnknownFormat { path, .. }
            | FormatError::InvalidOption { path, .. }
            | FormatError::Write { path, .. } => path,
        }
    }

    pub(crate) fn syntax(path: &Path, at: Location, message: impl Into<String>) -> Self {
        FormatError::Syntax {
            path: path.to_path_buf(),
            at,
            message: message.into(),
        }
    }

    pub(crate) fn unsupported(path: &Path, at: Location, message: impl Into<String>) -> Self {
        FormatError::Unsupported {
            path: path.to_path_buf(),
            at,
            message: message.into(),
        }
    }

    pub(crate) fn io(path: &Path, at: Location, source: std::io::Error) -> Self {
        FormatError::Io {
            path: path.to_path_buf(),
            at,
            source,
        }
    }

    pub(crate) fn missing_pose(path: &Path, at: Location, message: impl Into<String>) -> Self {
        FormatError::MissingPose {
            path: path.to_path_buf(),
            at,
            message: message.into(),
        }
    }
}

impl From<OutputError> for FormatError {
    /// A failed atomic write ([`crate::output::write_atomic`]) of a format writer.
    fn from(e: OutputError) -> Self {
        match e {
            OutputError::Io { path, source } => FormatError::Write { path, source },
        }
    }
}
