//! OctoMap's `.bt` (binary, max-likelihood) and `.ot` (full tree) formats, byte-identical to
//! OctoMap 1.9.7, as free functions over `std::io::Read` / `Write`.
//!
//! Readers track the byte offset and return [`OctreeError`](crate::OctreeError) naming it; they
//! never allocate more than the data they actually read, and reject trees deeper than 16 levels.
//! Writing to a temporary file and renaming it is the caller's job (the `octoquant` crate does).

mod bt;
mod header;
mod ot;
mod ot_color;
mod ot_stamped;
mod stream;

pub use bt::{read_bt, write_bt, write_bt_const, write_bt_const_typed, write_bt_typed};
pub use header::format_resolution;
pub use ot::{read_ot, write_ot};
pub use ot_color::{read_color_ot, write_color_ot, COLOR_OCTREE_ID};
pub use ot_stamped::{read_stamped_ot, write_stamped_ot, STAMPED_OCTREE_ID};

/// Which of the two OctoMap tree formats a file holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TreeFormat {
    /// `.bt`: 2 bits per child, max-likelihood occupancy only.
    Bt,
    /// `.ot`: the full tree with every node's log-odds.
    Ot,
}

impl TreeFormat {
    /// The format a file name's extension stands for (`.bt` or `.ot`, any case).
    pub fn from_path(path: &std::path::Path) -> Option<TreeFormat> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "bt" => Some(TreeFormat::Bt),
            "ot" => Some(TreeFormat::Ot),
            _ => None,
        }
    }
}

/// Read a tree in either format, telling them apart by the first header line.
pub fn read_tree<R: std::io::Read>(reader: R) -> Result<crate::OcTree, crate::OctreeError> {
    let mut s = stream::Stream::new(reader);
    let first = s.line("tree")?;
    if first.starts_with(bt::BT_HEADER) {
        bt::read_bt_after_first_line(&mut s)
    } else if first.starts_with(ot::OT_HEADER) {
        ot::read_ot_after_first_line(&mut s)
    } else {
        Err(s.format_err(
            "tree",
            0,
            "first line is neither an OctoMap .bt nor .ot header".into(),
        ))
    }
}

/// Write the whole header of an `OcTree` file in `format` (first line to `data`, as
/// OctoMap's writers do) announcing `size` nodes of `resolution`: for writers that stream a
/// tree's nodes from pieces instead of a tree in memory.
pub fn write_tree_header<W: std::io::Write + ?Sized>(
    w: &mut W,
    format: TreeFormat,
    size: usize,
    resolution: f64,
) -> std::io::Result<()> {
    let first = match format {
        TreeFormat::Bt => bt::BT_HEADER,
        TreeFormat::Ot => ot::OT_HEADER,
    };
    header::write_header(w, first, size, resolution)
}
