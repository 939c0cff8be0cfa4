//! `.bt`: OctoMap's binary max-likelihood format (`writeBinary` / `readBinary`).

use super::header::{read_header_any, write_header, write_header_id};
use super::stream::Stream;
use crate::error::OctreeError;
use crate::key::TREE_DEPTH;
use crate::store::NodeRef;
use crate::tree::OcTree;
use std::io::{Read, Write};

pub(crate) const BT_HEADER: &str = "# Octomap OcTree binary file";
const FMT: &str = ".bt";

/// Write `tree` as OctoMap's `writeBinary` does: convert to max-likelihood, prune, then write.
///
/// Like OctoMap this changes the tree (every node ends at a clamp, equal siblings merge).
pub fn write_bt<W: Write>(tree: &mut OcTree, w: W) -> std::io::Result<()> {
    tree.to_max_likelihood();
    tree.prune();
    write_bt_const(tree, w)
}

/// [`write_bt`] with the header naming another OctoMap tree type (`id ColorOcTree`,
/// `id OcTreeStamped`), as OctoMap's `writeBinary` names the type of the tree it is called on.
/// The node bits are the max-likelihood, pruned occupancy of `tree`: what OctoMap writes for a
/// `ColorOcTree` (colours never stop a collapse) and for an `OcTreeStamped` whose stamps are
/// all equal (as after reading an `.ot`, which keeps none).
pub fn write_bt_typed<W: Write>(tree: &mut OcTree, id: &str, w: W) -> std::io::Result<()> {
    tree.to_max_likelihood();
    tree.prune();
    write_bt_const_typed(tree, id, w)
}

/// [`write_bt_const`] with the header naming another OctoMap tree type, as OctoMap's
/// `writeBinaryConst` names the type of the tree it is called on: for a tree with a payload
/// per node whose own max-likelihood conversion and prune (by its payload's rules) came first.
pub fn write_bt_const_typed<W: Write>(tree: &OcTree, id: &str, w: W) -> std::io::Result<()> {
    let mut w = std::io::BufWriter::with_capacity(1 << 16, w);
    write_header_id(&mut w, BT_HEADER, id, tree.size(), tree.resolution())?;
    if !tree.is_empty() {
        let mut out = Vec::with_capacity(2 * tree.size() / 4 + 2);
        write_node(tree, NodeRef::ROOT, &mut out);
        w.write_all(&out)?;
    }
    w.flush()
}

/// Write `tree` as it is (OctoMap's `writeBinaryConst`): occupancy by the threshold, no
/// max-likelihood conversion or pruning.
pub fn write_bt_const<W: Write>(tree: &OcTree, w: W) -> std::io::Result<()> {
    let mut w = std::io::BufWriter::with_capacity(1 << 16, w);
    write_header(&mut w, BT_HEADER, tree.size(), tree.resolution())?;
    if !tree.is_empty() {
        let mut out = Vec::with_capacity(2 * tree.size() / 4 + 2);
        write_node(tree, NodeRef::ROOT, &mut out);
        w.write_all(&out)?;
    }
    w.flush()
}

fn write_node(tree: &OcTree, n: NodeRef, out: &mut Vec<u8>) {
    let store = &tree.store;
    let p = tree.params();
    let mut bytes = [0u8; 2];
    let mut inner = [None; 8];
    for (i, slot) in inner.iter_mut().enumerate() {
        if let Some(c) = store.child(n, i) {
            let bits: u8 = if store.has_children(c) {
                *slot = Some(c);
                3
            } else if p.is_occupied(store.value(c)) {
                2
            } else {
                1
            };
            bytes[i / 4] |= bits << (2 * (i % 4));
        }
    }
    out.extend_from_slice(&bytes);
    for c in inner.into_iter().flatten() {
        write_node(tree, c, out);
    }
}

/// Read a `.bt` stream (OctoMap's `readBinary`): leaves get the clamp values, inner nodes the
/// max of their children, the root the upper clamp. The node count must match the header.
pub fn read_bt<R: Read>(reader: R) -> Result<OcTree, OctreeError> {
    let mut s = Stream::new(reader);
    if !s
        .peek(BT_HEADER.len())?
        .starts_with(&BT_HEADER.as_bytes()[..2])
    {
        return read_legacy(&mut s);
    }
    let first = s.line(FMT)?;
    if !first.starts_with(BT_HEADER) {
        return Err(s.format_err(
            FMT,
            0,
            format!("first line does not start with {BT_HEADER:?}"),
        ));
    }
    read_bt_after_first_line(&mut s)
}

/// The tree types whose `.bt` files this reader takes: a `.bt` holds occupancy only, whatever
/// type wrote it (OctoMap's `readBinary` reads any), so `ColorOcTree` and `OcTreeStamped`
/// files read as their occupancy.
const BT_TREE_TYPES: [&str; 4] = ["OcTree", "1", "ColorOcTree", "OcTreeStamped"];

pub(crate) fn read_bt_after_first_line<R: Read>(s: &mut Stream<R>) -> Result<OcTree, OctreeError> {
    let (h, id) = read_header_any(s, FMT)?;
    if !BT_TREE_TYPES.contains(&id.as_str()) {
        return Err(OctreeError::UnsupportedTreeType { id });
    }
    read_body(s, h.res, h.size)
}

fn read_body<R: Read>(s: &mut Stream<R>, res: f64, size: u64) -> Result<OcTree, OctreeError> {
    let mut tree = OcTree::new(res)?;
    if size > 0 {
        let data_start = s.offset;
        tree.store.root_val = Some(tree.params().clamp_max);
        tree.add_size(1);
        read_node(&mut tree, s, NodeRef::ROOT)?;
        if tree.size() as u64 != size {
            return Err(s.format_err(
                FMT,
                data_start,
                format!(
                    "header says {size} nodes but the data holds {}",
                    tree.size()
                ),
            ));
        }
    }
    Ok(tree)
}

fn read_node<R: Read>(tree: &mut OcTree, s: &mut Stream<R>, n: NodeRef) -> Result<(), OctreeError> {
    let at = s.offset;
    let mut b = [0u8; 2];
    s.exact(&mut b, FMT, "a node record")?;
    let bits = u16::from_le_bytes(b);
    if bits != 0 && n.depth >= TREE_DEPTH {
        return Err(s.format_err(
            FMT,
            at,
            format!(
                "node at depth {} claims children (deeper than 16 levels)",
                n.depth
            ),
        ));
    }
    let (cmin, cmax) = (tree.params().clamp_min, tree.params().clamp_max);
    let mut inner = [None; 8];
    for (i, slot) in inner.iter_mut().enumerate() {
        match (bits >> (2 * i)) & 3 {
            0 => {}
            1 => {
                tree.store.create_child(n, i, cmin);
                tree.add_size(1);
            }
            2 => {
                tree.store.create_child(n, i, cmax);
                tree.add_size(1);
            }
            _ => {
                *slot = Some(tree.store.create_child(n, i, cmax));
                tree.add_size(1);
            }
        }
    }
    for c in inner.into_iter().flatten() {
        let at = s.offset;
        read_node(tree, s, c)?;
        if !tree.store.has_children(c) {
            return Err(s.format_err(FMT, at, "a node marked as inner has no children".into()));
        }
        let m = tree.store.max_child(c);
        tree.store.set_value(c, m);
    }
    Ok(())
}

/// OctoMap's pre-2010 binary layout: i32 type 3, f64 resolution, u32 size, then the body.
fn read_legacy<R: Read>(s: &mut Stream<R>) -> Result<OcTree, OctreeError> {
    let mut head = [0u8; 16];
    s.exact(&mut head, FMT, "the header")?;
    let ty = i32::from_le_bytes(head[0..4].try_into().expect("4 bytes"));
    let res = f64::from_le_bytes(head[4..12].try_into().expect("8 bytes"));
    let size = u32::from_le_bytes(head[12..16].try_into().expect("4 bytes")) as u64;
    if ty != 3 || !(res.is_finite() && res > 0.0) {
        return Err(s.format_err(
            FMT,
            0,
            format!(
                "first line does not start with {BT_HEADER:?} (nor is it a legacy binary header)"
            ),
        ));
    }
    read_body(s, res, size)
}
