//! `.ot`: OctoMap's full-tree format (`AbstractOcTree::write` / `read`) for `OcTree`.

use super::header::{read_header, read_header_any, write_header_id, Header};
use super::stream::Stream;
use crate::error::OctreeError;
use crate::key::TREE_DEPTH;
use crate::store::NodeRef;
use crate::tree::OcTree;
use std::io::{Read, Write};

pub(crate) const OT_HEADER: &str = "# Octomap OcTree file";
const FMT: &str = ".ot";

/// Write the whole tree as it is: per node its `f32` log-odds (little-endian) and a child
/// bitmask, pre-order. No max-likelihood conversion or pruning.
pub fn write_ot<W: Write>(tree: &OcTree, w: W) -> std::io::Result<()> {
    write_ot_typed(tree, "OcTree", w)
}

/// [`write_ot`] with the tree type `id` in the header: the tree types whose nodes write only
/// their log-odds (`OcTree`, `OcTreeStamped`, whose time stamps OctoMap does not save).
pub(crate) fn write_ot_typed<W: Write>(tree: &OcTree, id: &str, w: W) -> std::io::Result<()> {
    let mut w = std::io::BufWriter::with_capacity(1 << 16, w);
    write_header_id(&mut w, OT_HEADER, id, tree.size(), tree.resolution())?;
    if !tree.is_empty() {
        let mut out = Vec::with_capacity(5 * tree.size());
        write_node(tree, NodeRef::ROOT, &mut out);
        w.write_all(&out)?;
    }
    w.flush()
}

fn write_node(tree: &OcTree, n: NodeRef, out: &mut Vec<u8>) {
    let store = &tree.store;
    out.extend_from_slice(&store.value(n).to_le_bytes());
    let mut mask = 0u8;
    let mut kids = [None; 8];
    for (i, k) in kids.iter_mut().enumerate() {
        if let Some(c) = store.child(n, i) {
            mask |= 1 << i;
            *k = Some(c);
        }
    }
    out.push(mask);
    for c in kids.into_iter().flatten() {
        write_node(tree, c, out);
    }
}

/// Read an `.ot` stream holding an `OcTree`; other tree types are a clear error. Values are
/// taken as stored; NaN values, trees deeper than 16 levels and node counts that disagree with
/// the header are rejected.
pub fn read_ot<R: Read>(reader: R) -> Result<OcTree, OctreeError> {
    let mut s = Stream::new(reader);
    let first = s.line(FMT)?;
    if !first.starts_with(OT_HEADER) {
        return Err(s.format_err(
            FMT,
            0,
            format!("first line does not start with {OT_HEADER:?}"),
        ));
    }
    read_ot_after_first_line(&mut s)
}

pub(crate) fn read_ot_after_first_line<R: Read>(s: &mut Stream<R>) -> Result<OcTree, OctreeError> {
    let h = read_header(s, FMT)?;
    read_ot_body(s, &h)
}

/// The first line and header of an `.ot` stream whose tree type must be `id` (the readers of
/// `ColorOcTree` and `OcTreeStamped`); another type is [`OctreeError::WrongTreeType`].
pub(crate) fn read_typed_header<R: Read>(
    s: &mut Stream<R>,
    format: &'static str,
    id: &'static str,
) -> Result<Header, OctreeError> {
    let first = s.line(format)?;
    if !first.starts_with(OT_HEADER) {
        return Err(s.format_err(
            format,
            0,
            format!("first line does not start with {OT_HEADER:?}"),
        ));
    }
    let (h, found) = read_header_any(s, format)?;
    if found != id {
        return Err(OctreeError::WrongTreeType {
            id: found,
            expected: id,
        });
    }
    Ok(h)
}

/// The node records after an `.ot` header whose tree type stores only log-odds per node.
pub(crate) fn read_ot_body<R: Read>(s: &mut Stream<R>, h: &Header) -> Result<OcTree, OctreeError> {
    let mut tree = OcTree::new(h.res)?;
    if h.size > 0 {
        let data_start = s.offset;
        tree.store.root_val = Some(0.0);
        tree.add_size(1);
        read_node(&mut tree, s, NodeRef::ROOT)?;
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

fn read_node<R: Read>(tree: &mut OcTree, s: &mut Stream<R>, n: NodeRef) -> Result<(), OctreeError> {
    let at = s.offset;
    let mut rec = [0u8; 5];
    s.exact(&mut rec, FMT, "a node record")?;
    let v = f32::from_le_bytes(rec[0..4].try_into().unwrap());
    if v.is_nan() {
        return Err(s.format_err(FMT, at, "node log-odds is NaN".into()));
    }
    tree.store.set_value(n, v);
    let mask = rec[4];
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
            let c = tree.store.create_child(n, i, 0.0);
            tree.add_size(1);
            read_node(tree, s, c)?;
        }
    }
    Ok(())
}
