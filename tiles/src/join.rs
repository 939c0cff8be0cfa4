//! Tile trees joined into one tree, the levels above the tile depth recomputed as OctoMap
//! keeps them.
//!
//! The join works on OctoMap's `.ot` node records (per node in pre-order: its `f32`
//! log-odds and a byte of child bits): a tile tree written with
//! [`octoquant_octree::io::write_ot`] is the path from the root down to its tile, one record
//! per level with a single child bit, then the tile's subtree. The joined stream is the
//! records of the levels above the tile depth, computed here, with each tile's subtree in
//! place, read back with [`octoquant_octree::io::read_ot`], which checks it.

use crate::error::TileError;
use crate::tile::Tile;
use crate::tile_check::check_depth;
use octoquant_octree::{io, OcTree, OccupancyParams};
use std::io::Read;

/// Bytes per `.ot` node record.
pub(crate) const RECORD: usize = 5;

/// A tile's subtree as `.ot` records.
pub(crate) struct Part {
    /// The tile.
    pub(crate) tile: Tile,
    /// Its subtree's records, the tile's node first.
    pub(crate) records: Vec<u8>,
}

/// The tile at `depth` a tile tree's nodes lie in and its subtree's `.ot` records; `None`
/// for an empty tree.
pub(crate) fn subtree_records(tree: &OcTree, depth: u8) -> Result<Option<Part>, TileError> {
    check_depth(depth)?;
    if tree.is_empty() {
        return Ok(None);
    }
    let mut bytes = Vec::with_capacity(64 + RECORD * tree.size());
    io::write_ot(tree, &mut bytes).map_err(|e| TileError::Mismatch(e.to_string()))?;
    let start = bytes
        .windows(6)
        .position(|w| w == b"\ndata\n")
        .map(|p| p + 6)
        .ok_or_else(|| TileError::Mismatch("an .ot without its data line".into()))?;
    let mut at = start;
    let mut index = 0u64;
    for d in 0..depth {
        let Some(rec) = bytes.get(at..at + RECORD) else {
            return Err(TileError::Mismatch("an .ot ends inside its records".into()));
        };
        let mask = rec[4];
        if mask.count_ones() != 1 {
            let tile = Tile::new(d, index)?;
            let message = if mask == 0 {
                format!("has no node at the tile depth {depth} (its path ends at depth {d})")
            } else {
                format!("spans more than one tile at depth {depth}: it branches below {tile}")
            };
            // name the tile by the path so far
            return Err(TileError::NotATileTree { tile, message });
        }
        index = (index << 3) | mask.trailing_zeros() as u64;
        at += RECORD;
    }
    let tile = Tile::new(depth, index)?;
    bytes.drain(..at);
    Ok(Some(Part {
        tile,
        records: bytes,
    }))
}

/// The tile at `depth` that holds every node of `tree` below that depth (the tree's single
/// path down to it), `None` for an empty tree; an error when the tree branches above
/// `depth` (nodes in several tiles) or stops short of it.
pub fn tile_of_tree(tree: &OcTree, depth: u8) -> Result<Option<Tile>, TileError> {
    Ok(subtree_records(tree, depth)?.map(|p| p.tile))
}

/// A record's value and whether it is a leaf.
pub(crate) fn record_of(records: &[u8]) -> (f32, bool) {
    let v = f32::from_le_bytes(records[0..4].try_into().expect("4 bytes"));
    (v, records[4] == 0)
}

/// Append the records of the node at depth `d` holding `parts` (non-empty, sorted by tile,
/// all below it), and return its value and whether it is a leaf.
fn build(parts: &[Part], d: u8, depth: u8, out: &mut Vec<u8>) -> (f32, bool) {
    if d == depth {
        let p = &parts[0];
        out.extend_from_slice(&p.records);
        return record_of(&p.records);
    }
    let pos = out.len();
    out.extend_from_slice(&[0; RECORD]);
    let mut children: [Option<(f32, bool)>; 8] = [None; 8];
    let mut rest = parts;
    while let Some(first) = rest.first() {
        let i = first.tile.child_index_at(d);
        let n = rest
            .iter()
            .position(|p| p.tile.child_index_at(d) != i)
            .unwrap_or(rest.len());
        children[i] = Some(build(&rest[..n], d + 1, depth, out));
        rest = &rest[n..];
    }
    // OctoMap's pruneNode: eight leaf children of equal value (float ==) collapse into
    // child 0's value
    if let Some((v0, true)) = children[0] {
        if children
            .iter()
            .all(|c| matches!(c, Some((v, true)) if *v == v0))
        {
            out.truncate(pos);
            out.extend_from_slice(&v0.to_le_bytes());
            out.push(0);
            return (v0, true);
        }
    }
    // else updateOccupancyChildren: the max of the existing children
    let mut mask = 0u8;
    let mut m = -f32::MAX;
    for (i, c) in children.iter().enumerate() {
        if let Some((v, _)) = c {
            mask |= 1 << i;
            if *v > m {
                m = *v;
            }
        }
    }
    out[pos..pos + 4].copy_from_slice(&m.to_le_bytes());
    out[pos + 4] = mask;
    (m, false)
}

/// Join tile trees (each built by [`crate::apply_tile_updates`] from one tile's lists at
/// tile depth `depth`, given in any order; empty trees are skipped) into one tree of
/// resolution `resolution` and sensor model `params`: each tile's subtree in place, and the
/// nodes above the tile depth computed bottom-up as OctoMap's non-lazy updates leave them:
/// pruned when their eight children are leaves of equal value, else the max of their
/// children (root included). The result equals, node for node, the tree a sequential
/// insertion of the same frames builds (see the crate docs for why).
///
/// Errors for a tree whose resolution differs, a tree that is not one tile's at this depth
/// ([`tile_of_tree`]), and the same tile twice.
pub fn join_tiles<'a>(
    resolution: f64,
    params: OccupancyParams,
    depth: u8,
    tiles: impl IntoIterator<Item = &'a OcTree>,
) -> Result<OcTree, TileError> {
    check_depth(depth)?;
    let mut parts = Vec::new();
    for t in tiles {
        if t.resolution() != resolution {
            return Err(TileError::Mismatch(format!(
                "a tile tree has resolution {}, the join {resolution}",
                t.resolution()
            )));
        }
        if let Some(p) = subtree_records(t, depth)? {
            parts.push(p);
        }
    }
    parts.sort_unstable_by_key(|p| p.tile);
    if let Some(w) = parts.windows(2).find(|w| w[0].tile == w[1].tile) {
        return Err(TileError::DuplicateTile { tile: w[0].tile });
    }
    let mut tree = if parts.is_empty() {
        OcTree::new(resolution)?
    } else {
        let total: usize = parts.iter().map(|p| p.records.len()).sum();
        let mut records = Vec::with_capacity(total + RECORD * 8 * depth as usize);
        build(&parts, 0, depth, &mut records);
        drop(parts);
        let header = format!(
            "# Octomap OcTree file\n# (feel free to add / change comments, but leave the first line as it is!)\n#\nid OcTree\nsize {}\nres {}\ndata\n",
            records.len() / RECORD,
            io::format_resolution(resolution)
        );
        let tree = io::read_ot(header.as_bytes().chain(&records[..]))?;
        if tree.resolution() != resolution {
            // the header's %g text keeps 6 significant digits: more cannot pass through it
            return Err(TileError::Mismatch(format!(
                "resolution {resolution} does not survive the .ot header (read back as {})",
                tree.resolution()
            )));
        }
        tree
    };
    tree.set_params(params);
    Ok(tree)
}
