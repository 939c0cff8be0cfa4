//! A tile directory joined straight into a `.bt` or `.ot` file, one tile in memory at a time:
//! the out-of-core counterpart of [`crate::join_dir`], for maps larger than memory.
//!
//! The bytes are those of [`crate::join_dir`]'s tree written by `write_ot`, or by `write_bt`
//! (OctoMap's `writeBinary`: max-likelihood, then `prune`). Two passes over the tile files:
//!
//! 1. Each tile is read and summarised: its node's value and whether it is a leaf (what the
//!    levels above the tile depth are computed from, as [`crate::join_tiles`] does), its node
//!    count, and for `.bt` what OctoMap's `prune()` does inside it after the max-likelihood
//!    conversion, level by level.
//! 2. The header (its node count is known now), then the levels above the tile depth with
//!    each tile's subtree written in place as it is read again.
//!
//! `prune()` stops at the first level, counted over the whole tree, that prunes nothing, and
//! never prunes the root. Pass 1 therefore records per tile how many nodes each level prunes
//! when every level is run; summed over tiles (and for the levels above the tiles, counted on
//! their summaries) they say where the whole tree's loop stops, and pass 2 prunes each tile
//! down to exactly that level.

use crate::error::TileError;
use crate::join::{record_of, subtree_records, RECORD};
use crate::spill::{read_index, read_tile_file, tile_paths, TileIndex};
use crate::tile::Tile;
use octoquant_octree::io::{self, TreeFormat};
use octoquant_octree::{OcTree, OccupancyParams, TREE_DEPTH};
use std::io::Write;
use std::path::{Path, PathBuf};

/// A node's value and whether it is a leaf.
type NodeState = (f32, bool);

/// What pass 1 learns of one tile.
struct TileSummary {
    tile: Tile,
    /// The tile's node in the joined tree (log-odds).
    node: NodeState,
    /// Nodes of the tile's subtree in the joined tree.
    nodes: usize,
    /// `.bt`: the tile's node after max-likelihood, before and after pruning at the tile
    /// depth; nodes after max-likelihood; nodes pruned at each depth (every level run).
    ml_before: NodeState,
    ml_after: NodeState,
    pruned: [usize; TREE_DEPTH as usize],
}

/// A child of a node above the tile depth.
#[derive(Clone, Copy)]
enum Child {
    /// A tile (index into the summaries).
    Tile(usize),
    /// A node above the tile depth (index into the arena).
    Upper(usize),
}

/// A node above the tile depth.
struct Upper {
    depth: u8,
    value: f32,
    children: [Option<Child>; 8],
}

impl Upper {
    fn is_leaf(&self) -> bool {
        self.children.iter().all(Option::is_none)
    }
}

/// A piece of the joined file's node stream.
enum Piece {
    /// Bytes computed in pass 1 (nodes above the tile depth).
    Bytes(Vec<u8>),
    /// The subtree of the tile with this summary index, read in pass 2.
    Tile(usize),
}

/// A tile directory's map planned for writing one tile at a time ([`StreamJoin::plan`],
/// then [`StreamJoin::write`]).
pub struct StreamJoin {
    dir: PathBuf,
    index: TileIndex,
    format: TreeFormat,
    summaries: Vec<TileSummary>,
    /// `.bt`: the deepest level each tile is pruned to (the whole tree's `prune()` runs the
    /// levels from 15 down to this one and stops there).
    prune_to: u8,
    pieces: Vec<Piece>,
    nodes: usize,
}

impl std::fmt::Debug for StreamJoin {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StreamJoin")
            .field("dir", &self.dir)
            .field("format", &self.format)
            .field("tiles", &self.summaries.len())
            .field("nodes", &self.nodes)
            .finish()
    }
}

impl StreamJoin {
    /// Pass 1: read and summarise every tile of the directory `dir` for a file in `format`.
    /// Every error a join can meet (a bad index, a missing or wrong tile file) comes here,
    /// before anything is written. Memory: one tile tree and a summary per tile.
    pub fn plan(dir: &Path, format: TreeFormat) -> Result<StreamJoin, TileError> {
        let index = read_index(dir)?;
        let depth = index.tile_depth;
        let mut summaries = Vec::with_capacity(index.tiles.len());
        for ((tile, _), path) in index.tiles.iter().zip(tile_paths(dir, &index)) {
            let mut tree = read_tile_file(&path, *tile, &index)?;
            let (node, records) = tile_node(&tree, depth)?;
            let mut s = TileSummary {
                tile: *tile,
                node,
                nodes: records,
                ml_before: node,
                ml_after: node,
                pruned: [0; TREE_DEPTH as usize],
            };
            if format == TreeFormat::Bt {
                tree.to_max_likelihood();
                for d in (depth.max(1)..TREE_DEPTH).rev() {
                    if d == depth {
                        s.ml_before = tile_state(&tree, *tile, depth)?;
                    }
                    s.pruned[d as usize] = tree.prune_depth(d);
                }
                s.ml_after = tile_state(&tree, *tile, depth)?;
                if depth == 0 {
                    s.ml_before = s.ml_after;
                }
            }
            summaries.push(s);
        }
        let mut join = StreamJoin {
            dir: dir.to_path_buf(),
            index,
            format,
            summaries,
            prune_to: 1,
            pieces: Vec::new(),
            nodes: 0,
        };
        join.lay_out();
        Ok(join)
    }

    /// Nodes the joined file will hold (its header's `size`).
    pub fn nodes(&self) -> usize {
        self.nodes
    }

    /// Pass 2: write the joined map to `w` (header, then nodes), reading each tile file
    /// again. A tile file that changed since [`StreamJoin::plan`] is an error (the output is
    /// then incomplete: write through a temporary file and rename, as the CLI does).
    pub fn write(&self, w: &mut dyn Write) -> Result<(), TileError> {
        io::write_tree_header(w, self.format, self.nodes, self.index.resolution)
            .map_err(TileError::Write)?;
        let paths = tile_paths(&self.dir, &self.index);
        for piece in &self.pieces {
            match piece {
                Piece::Bytes(b) => w.write_all(b).map_err(TileError::Write)?,
                Piece::Tile(i) => {
                    let s = &self.summaries[*i];
                    let bytes = self.tile_bytes(&paths[*i], s)?;
                    w.write_all(&bytes).map_err(TileError::Write)?;
                }
            }
        }
        w.flush().map_err(TileError::Write)
    }

    /// A tile's subtree as the joined file's bytes, read again from `path`.
    fn tile_bytes(&self, path: &Path, s: &TileSummary) -> Result<Vec<u8>, TileError> {
        let depth = self.index.tile_depth;
        let mut tree = read_tile_file(path, s.tile, &self.index)?;
        let changed = || TileError::BadTileFile {
            path: path.to_path_buf(),
            message: "changed while the tiles were being joined".into(),
        };
        match self.format {
            TreeFormat::Ot => {
                let part = subtree_records(&tree, depth)?.ok_or_else(changed)?;
                let (value, leaf) = record_of(&part.records);
                let nodes = part.records.len() / RECORD;
                if value.to_bits() != s.node.0.to_bits() || leaf != s.node.1 || nodes != s.nodes {
                    return Err(changed());
                }
                Ok(part.records)
            }
            TreeFormat::Bt => {
                tree.to_max_likelihood();
                for d in (depth.max(1).max(self.prune_to)..TREE_DEPTH).rev() {
                    if tree.prune_depth(d) != s.pruned[d as usize] {
                        return Err(changed());
                    }
                }
                let mut out = Vec::new();
                io::write_bt_const(&tree, &mut out).map_err(TileError::Write)?;
                bt_subtree(&out, depth, s.tile).ok_or_else(changed)
            }
        }
    }

    /// The levels above the tile depth and the order of the pieces; the node count.
    fn lay_out(&mut self) {
        let depth = self.index.tile_depth;
        let mut arena: Vec<Upper> = Vec::new();
        let order: Vec<usize> = (0..self.summaries.len()).collect();
        let root = if order.is_empty() {
            None
        } else {
            Some(build_upper(&self.summaries, &order, 0, depth, &mut arena))
        };
        if self.format == TreeFormat::Bt {
            self.prune_to = self.bt_prune(&mut arena, depth);
        }
        let mut pieces = Vec::new();
        let mut nodes = 0;
        if let Some(root) = root {
            match self.format {
                TreeFormat::Ot => self.emit_ot(&arena, root, &mut pieces, &mut nodes),
                TreeFormat::Bt => self.emit_bt_root(&arena, root, &mut pieces, &mut nodes),
            }
        }
        self.pieces = merge_bytes(pieces);
        self.nodes = nodes;
    }

    /// Run OctoMap's `prune()` loop over the whole tree after max-likelihood: the levels
    /// inside the tiles from their per-level counts, the levels above on the arena (changed
    /// in place: leaves get max-likelihood values, collapsed nodes lose their children).
    /// Returns the deepest level the tiles are pruned to.
    fn bt_prune(&self, arena: &mut [Upper], depth: u8) -> u8 {
        let p = *self.params();
        let ml = |v: f32| {
            if p.is_occupied(v) {
                p.clamp_max
            } else {
                p.clamp_min
            }
        };
        for u in arena.iter_mut() {
            u.value = ml(u.value);
        }
        for d in (depth.max(1)..TREE_DEPTH).rev() {
            let total: usize = self.summaries.iter().map(|s| s.pruned[d as usize]).sum();
            if total == 0 {
                return d;
            }
        }
        // every level inside the tiles pruned something: the loop goes on above them
        for d in (1..depth).rev() {
            let mut pruned = 0;
            for i in 0..arena.len() {
                if arena[i].depth != d {
                    continue;
                }
                let states: Vec<Option<NodeState>> = arena[i]
                    .children
                    .iter()
                    .map(|c| c.map(|c| self.bt_state(arena, c, depth.max(1))))
                    .collect();
                if let Some(Some((v0, true))) = states.first() {
                    if states
                        .iter()
                        .all(|s| matches!(s, Some((v, true)) if v == v0))
                    {
                        arena[i].value = *v0;
                        arena[i].children = [None; 8];
                        pruned += 1;
                    }
                }
            }
            if pruned == 0 {
                break;
            }
        }
        depth.max(1)
    }

    /// A child's value and leafness in the `.bt` tree, tiles pruned to `prune_to`.
    fn bt_state(&self, arena: &[Upper], c: Child, prune_to: u8) -> NodeState {
        match c {
            Child::Tile(i) => {
                let s = &self.summaries[i];
                if prune_to <= self.index.tile_depth {
                    s.ml_after
                } else {
                    s.ml_before
                }
            }
            Child::Upper(u) => (arena[u].value, arena[u].is_leaf()),
        }
    }

    fn params(&self) -> &OccupancyParams {
        &self.index.params
    }

    fn emit_ot(&self, arena: &[Upper], c: Child, pieces: &mut Vec<Piece>, nodes: &mut usize) {
        match c {
            Child::Tile(i) => {
                pieces.push(Piece::Tile(i));
                *nodes += self.summaries[i].nodes;
            }
            Child::Upper(u) => {
                let n = &arena[u];
                let mut rec = n.value.to_le_bytes().to_vec();
                let mask = n
                    .children
                    .iter()
                    .enumerate()
                    .filter(|(_, c)| c.is_some())
                    .fold(0u8, |m, (i, _)| m | 1 << i);
                rec.push(mask);
                pieces.push(Piece::Bytes(rec));
                *nodes += 1;
                for ch in n.children.iter().flatten() {
                    self.emit_ot(arena, *ch, pieces, nodes);
                }
            }
        }
    }

    fn emit_bt_root(&self, arena: &[Upper], root: Child, pieces: &mut Vec<Piece>, n: &mut usize) {
        match root {
            Child::Upper(u) if arena[u].is_leaf() => {
                // a root that is a leaf writes its (empty) child bits, as OctoMap does
                pieces.push(Piece::Bytes(vec![0, 0]));
                *n += 1;
            }
            _ => self.emit_bt(arena, root, pieces, n),
        }
    }

    /// The `.bt` stream of an inner node (OctoMap's `writeBinaryNode`): its children's bits,
    /// then its inner children in order.
    fn emit_bt(&self, arena: &[Upper], c: Child, pieces: &mut Vec<Piece>, nodes: &mut usize) {
        match c {
            Child::Tile(i) => {
                let s = &self.summaries[i];
                pieces.push(Piece::Tile(i));
                *nodes += self.bt_tile_nodes(s);
            }
            Child::Upper(u) => {
                let n = &arena[u];
                let mut bits = [0u8; 2];
                let mut inner = Vec::new();
                for (i, ch) in n.children.iter().enumerate() {
                    let Some(ch) = ch else { continue };
                    let (v, leaf) = self.bt_state(arena, *ch, self.prune_to);
                    let b: u8 = if !leaf {
                        inner.push(*ch);
                        3
                    } else {
                        // a leaf child is one node, written as these bits only
                        *nodes += 1;
                        if self.params().is_occupied(v) {
                            2
                        } else {
                            1
                        }
                    };
                    bits[i / 4] |= b << (2 * (i % 4));
                }
                pieces.push(Piece::Bytes(bits.to_vec()));
                *nodes += 1;
                for ch in inner {
                    self.emit_bt(arena, ch, pieces, nodes);
                }
            }
        }
    }

    /// Nodes of a tile's subtree in the `.bt` tree (pruned down to `prune_to`).
    fn bt_tile_nodes(&self, s: &TileSummary) -> usize {
        let pruned: usize = (self.prune_to.max(1)..TREE_DEPTH)
            .filter(|&d| d >= self.index.tile_depth)
            .map(|d| s.pruned[d as usize])
            .sum();
        s.nodes - 8 * pruned
    }
}

/// Build the nodes above the tile depth over the tiles `order` (sorted, all below the node
/// at depth `d`), as [`crate::join_tiles`] does: a node whose eight children are leaves of
/// equal value collapses into a leaf of that value, else it takes the max of its children.
fn build_upper(
    summaries: &[TileSummary],
    order: &[usize],
    d: u8,
    depth: u8,
    arena: &mut Vec<Upper>,
) -> Child {
    if d == depth {
        return Child::Tile(order[0]);
    }
    let mut children: [Option<Child>; 8] = [None; 8];
    let mut states: [Option<NodeState>; 8] = [None; 8];
    let mut rest = order;
    while let Some(&first) = rest.first() {
        let i = summaries[first].tile.child_index_at(d);
        let n = rest
            .iter()
            .position(|&t| summaries[t].tile.child_index_at(d) != i)
            .unwrap_or(rest.len());
        let c = build_upper(summaries, &rest[..n], d + 1, depth, arena);
        states[i] = Some(match c {
            Child::Tile(t) => summaries[t].node,
            Child::Upper(u) => (arena[u].value, arena[u].is_leaf()),
        });
        children[i] = Some(c);
        rest = &rest[n..];
    }
    if let Some((v0, true)) = states[0] {
        if states
            .iter()
            .all(|s| matches!(s, Some((v, true)) if *v == v0))
        {
            arena.push(Upper {
                depth: d,
                value: v0,
                children: [None; 8],
            });
            return Child::Upper(arena.len() - 1);
        }
    }
    let value = states
        .iter()
        .flatten()
        .map(|s| s.0)
        .fold(-f32::MAX, |m, v| if v > m { v } else { m });
    arena.push(Upper {
        depth: d,
        value,
        children,
    });
    Child::Upper(arena.len() - 1)
}

/// The tile's node (value, leaf) in a tile tree and its subtree's node count.
fn tile_node(tree: &OcTree, depth: u8) -> Result<(NodeState, usize), TileError> {
    let part = subtree_records(tree, depth)?
        .ok_or_else(|| TileError::Mismatch("an empty tile tree in a tile directory".into()))?;
    Ok((record_of(&part.records), part.records.len() / RECORD))
}

/// The tile's node (value, leaf) in a tile tree, found by a search rather than by writing the
/// tree's records (the root, at tile depth 0, has no search of its own: OctoMap's depth 0
/// means the voxel level).
fn tile_state(tree: &OcTree, tile: Tile, depth: u8) -> Result<NodeState, TileError> {
    if depth == 0 {
        return Ok(tile_node(tree, depth)?.0);
    }
    match tree.search(tile.min_key(), depth) {
        Some(n) if n.depth == depth => Ok((n.value, !n.has_children)),
        _ => Err(TileError::Mismatch(format!(
            "{tile}: its tile tree has no node there"
        ))),
    }
}

/// The `.bt` bytes of the tile's subtree in `bt` (a whole `.bt` file of a tile tree): the
/// body after the path's nodes above the tile depth; empty when the tile's node is a leaf.
/// `None` when the stream is not one tile's.
fn bt_subtree(bt: &[u8], depth: u8, tile: Tile) -> Option<Vec<u8>> {
    let start = bt.windows(6).position(|w| w == b"\ndata\n")? + 6;
    let body = &bt[start..];
    if depth == 0 {
        return Some(body.to_vec());
    }
    let mut at = 0;
    for d in 0..depth {
        let rec = body.get(at..at + 2)?;
        let fields: Vec<u8> = (0..8).map(|i| (rec[i / 4] >> (2 * (i % 4))) & 3).collect();
        let i = tile.child_index_at(d);
        if fields
            .iter()
            .enumerate()
            .any(|(j, &f)| (f != 0) != (j == i))
        {
            return None;
        }
        at += 2;
        if fields[i] != 3 {
            // a leaf: only possible for the tile's own node, which then has no bytes
            return (d + 1 == depth && at == body.len()).then(Vec::new);
        }
    }
    Some(body[at..].to_vec())
}

/// Adjacent byte pieces merged into one.
fn merge_bytes(pieces: Vec<Piece>) -> Vec<Piece> {
    let mut out: Vec<Piece> = Vec::with_capacity(pieces.len());
    for p in pieces {
        match (out.last_mut(), p) {
            (Some(Piece::Bytes(a)), Piece::Bytes(b)) => a.extend_from_slice(&b),
            (_, p) => out.push(p),
        }
    }
    out
}
