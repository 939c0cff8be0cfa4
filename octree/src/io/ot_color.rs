//! `.ot` files of tree type `ColorOcTree` (OctoMap's `AbstractOcTree::write` / `read` with
//! `ColorOcTreeNode::writeData` / `readData`).
//!
//! The layout is the plain `.ot` one with `id ColorOcTree` in the header and a longer node
//! record: per node, pre-order, the `f32` log-odds (little-endian), the colour as three bytes
//! `r g b`, then the child bitmask.

use super::header::write_header_id;
use super::ot::{read_typed_header, OT_HEADER};
use super::stream::Stream;
use crate::color::Color;
use crate::color_tree::ColorOcTree;
use crate::error::OctreeError;
use crate::key::{Key, TREE_DEPTH};
use crate::node_id::{child_id, node_id, NodeId};
use crate::store::NodeRef;
use crate::tree::OcTree;
use std::io::{Read, Write};

const FMT: &str = ".ot";

/// The tree type name OctoMap writes for a [`ColorOcTree`].
pub const COLOR_OCTREE_ID: &str = "ColorOcTree";

/// Write a [`ColorOcTree`] as it is, as OctoMap's `ColorOcTree::write` does: per node its
/// `f32` log-odds, its colour `r g b` and a child bitmask, pre-order. No pruning.
pub fn write_color_ot<W: Write>(tree: &ColorOcTree, w: W) -> std::io::Result<()> {
    let mut w = std::io::BufWriter::with_capacity(1 << 16, w);
    write_header_id(
        &mut w,
        OT_HEADER,
        COLOR_OCTREE_ID,
        tree.size(),
        tree.resolution(),
    )?;
    if !tree.is_empty() {
        let mut out = Vec::with_capacity(8 * tree.size());
        write_node(tree, NodeRef::ROOT, node_id(Key::default(), 0), &mut out);
        w.write_all(&out)?;
    }
    w.flush()
}

fn write_node(tree: &ColorOcTree, n: NodeRef, id: NodeId, out: &mut Vec<u8>) {
    let store = &tree.base.tree.store;
    out.extend_from_slice(&store.value(n).to_le_bytes());
    out.extend_from_slice(&tree.color_of(id).to_array());
    let mut mask = 0u8;
    let mut kids = [None; 8];
    for (i, k) in kids.iter_mut().enumerate() {
        if let Some(c) = store.child(n, i) {
            mask |= 1 << i;
            *k = Some((c, child_id(id, i)));
        }
    }
    out.push(mask);
    for (c, cid) in kids.into_iter().flatten() {
        write_node(tree, c, cid, out);
    }
}

/// Read an `.ot` stream holding a `ColorOcTree`; any other tree type is
/// [`OctreeError::WrongTreeType`]. Values and colours are taken as stored; NaN values,
/// trees deeper than 16 levels, truncated data and node counts that disagree with the header
/// are rejected with the byte offset.
pub fn read_color_ot<R: Read>(reader: R) -> Result<ColorOcTree, OctreeError> {
    let mut s = Stream::new(reader);
    let h = read_typed_header(&mut s, FMT, COLOR_OCTREE_ID)?;
    let mut tree = ColorOcTree::from_occupancy(OcTree::new(h.res)?);
    if h.size > 0 {
        let data_start = s.offset;
        tree.base.tree.store.root_val = Some(0.0);
        tree.base.tree.add_size(1);
        read_node(&mut tree, &mut s, NodeRef::ROOT, node_id(Key::default(), 0))?;
        if tree.size() as u64 != h.size {
            return Err(s.format_err(
                FMT,
                data_start,
                format!(
                    "header says {} nodes but the data holds {}",
                    h.size,
                    tree.size()
                ),
            ));
        }
    }
    Ok(tree)
}

fn read_node<R: Read>(
    tree: &mut ColorOcTree,
    s: &mut Stream<R>,
    n: NodeRef,
    id: NodeId,
) -> Result<(), OctreeError> {
    let at = s.offset;
    let mut rec = [0u8; 8];
    s.exact(&mut rec, FMT, "a node record")?;
    let v = f32::from_le_bytes([rec[0], rec[1], rec[2], rec[3]]);
    if v.is_nan() {
        return Err(s.format_err(FMT, at, "node log-odds is NaN".into()));
    }
    tree.base.tree.store.set_value(n, v);
    tree.put_color(id, Color::new(rec[4], rec[5], rec[6]));
    let mask = rec[7];
    if mask != 0 && n.depth >= TREE_DEPTH {
        return Err(s.format_err(
            FMT,
            at,
            format!(
                "node at depth {} claims children (deeper than 16 levels)",
                n.depth
            ),
        ));
    }
    for i in 0..8 {
        if mask & (1 << i) != 0 {
            // placeholder value, overwritten by the child's own record
            let c = tree.base.tree.store.create_child(n, i, 0.0);
            tree.base.tree.add_size(1);
            read_node(tree, s, c, child_id(id, i))?;
        }
    }
    Ok(())
}
