//! `.ot` files of tree type `OcTreeStamped` (OctoMap's `AbstractOcTree::write` / `read` on an
//! `OcTreeStamped`).
//!
//! `OcTreeNodeStamped` does not override `writeData` / `readData`, so the node records are the
//! plain `.ot` ones (the `f32` log-odds and the child bitmask, pre-order) and the header says
//! `id OcTreeStamped`: the time stamps are not saved, and a tree read back has every stamp 0.

use super::ot::{read_ot_body, read_typed_header, write_ot_typed};
use super::stream::Stream;
use crate::error::OctreeError;
use crate::stamped_tree::StampedOcTree;
use std::io::{Read, Write};

const FMT: &str = ".ot";

/// The tree type name OctoMap writes for a [`StampedOcTree`].
pub const STAMPED_OCTREE_ID: &str = "OcTreeStamped";

/// Write a [`StampedOcTree`] as OctoMap's `OcTreeStamped::write` does: the plain `.ot` node
/// records (log-odds and child bitmask, pre-order, no pruning) under `id OcTreeStamped`.
pub fn write_stamped_ot<W: Write>(tree: &StampedOcTree, w: W) -> std::io::Result<()> {
    write_ot_typed(tree.occupancy(), STAMPED_OCTREE_ID, w)
}

/// Read an `.ot` stream holding an `OcTreeStamped` (every stamp 0, as OctoMap reads it); any
/// other tree type is [`OctreeError::WrongTreeType`]. Damaged data gets the plain `.ot`
/// reader's errors, with the byte offset.
pub fn read_stamped_ot<R: Read>(reader: R) -> Result<StampedOcTree, OctreeError> {
    let mut s = Stream::new(reader);
    let h = read_typed_header(&mut s, FMT, STAMPED_OCTREE_ID)?;
    Ok(StampedOcTree::from_occupancy(read_ot_body(&mut s, &h)?))
}
