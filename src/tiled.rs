//! The tiled build over the pipeline: frames cast into per-tile update lists
//! ([`cast_frames`]), the lists applied per tile and the tiles joined (the
//! [`octoquant_tiles`] crate), and [`build_tiled`], the whole build in one process: what a
//! distributed build (the Python package's `octoquant.distributed`) does across machines, and
//! the reference its tests compare with. The tree is the one [`Mapper`](crate::Mapper)
//! builds from the same frames and options, node for node (see [`octoquant_tiles`] for why).

use crate::pipeline::{CasterError, FrameCaster, MapStats, MapperOptions};
use crate::Frame;
use octoquant_octree::OcTree;
use octoquant_tiles::{
    apply_tile_updates, join_tiles, write_index, write_tile, Tile, TileError, TileIndex,
    TileSplitter, TileUpdates,
};
use std::collections::BTreeMap;

/// Why a tiled build failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TiledError {
    /// The options have no per-frame voxel sets (mode `simple`) or no valid resolution.
    #[error(transparent)]
    Caster(#[from] CasterError),
    /// Lazy insertion: its trees keep stale inner nodes, which the join does not reproduce.
    #[error("a tiled build applies frames eagerly; lazy insertion is not supported")]
    Lazy,
    /// Splitting, applying or joining tiles failed.
    #[error(transparent)]
    Tiles(#[from] TileError),
}

/// The tile depth used when none is given: tiles of about 25.6 m a side (`2^k` voxels for
/// the `k` nearest `25.6 / resolution`), at least depth 1 and at most 14 (bricks of 4x4x4
/// voxels).
pub fn default_tile_depth(resolution: f64) -> u8 {
    let voxels = (25.6 / resolution).log2().round();
    let k = if voxels.is_finite() { voxels } else { 8.0 };
    (16.0 - k).clamp(1.0, 14.0) as u8
}

/// Cast `frames` (their run indices `first`, `first + 1`, ...) with `caster` and split their
/// voxel sets by tile at `tile_depth`: each tile's lists, in tile order, and the frames'
/// statistics.
pub fn cast_frames<'a>(
    caster: &mut FrameCaster,
    tile_depth: u8,
    first: u64,
    frames: impl IntoIterator<Item = &'a Frame>,
) -> Result<(Vec<TileUpdates>, MapStats), TileError> {
    let mut splitter = TileSplitter::new(tile_depth)?;
    let mut stats = MapStats::default();
    for (i, f) in frames.into_iter().enumerate() {
        let (update, st) = caster.cast(f);
        splitter.add(first + i as u64, update)?;
        stats.add(&st);
    }
    Ok((splitter.finish(), stats))
}

/// Build the map of `frames` under `options` the tiled way in this process: frames cast in
/// batches of `frames_per_batch`, each tile's lists applied to its own tree, the tiles
/// joined. Returns the tree (equal to [`Mapper`](crate::Mapper)'s) and the statistics.
pub fn build_tiled(
    options: &MapperOptions,
    tile_depth: u8,
    frames: &[Frame],
    frames_per_batch: usize,
) -> Result<(OcTree, MapStats), TiledError> {
    let (per_tile, stats) = lists_by_tile(options, tile_depth, frames, frames_per_batch)?;
    let mut trees = Vec::with_capacity(per_tile.len());
    for (tile, lists) in per_tile {
        let t = tile_tree(options, tile, &lists)?;
        trees.push(t);
    }
    let tree = join_tiles(options.resolution, options.params, tile_depth, &trees)?;
    Ok((tree, stats))
}

/// [`build_tiled`] out of core: each tile tree, once built, is written into the directory
/// `dir` (which must exist) as one `.ot` file and dropped, then the index is written
/// ([`octoquant_tiles::write_index`]); [`octoquant_tiles::join_dir`] (`octoquant join`)
/// assembles the directory into the tree [`build_tiled`] returns. Returns the index and the
/// statistics.
pub fn build_tiled_to_dir(
    options: &MapperOptions,
    tile_depth: u8,
    frames: &[Frame],
    frames_per_batch: usize,
    dir: &std::path::Path,
) -> Result<(TileIndex, MapStats), TiledError> {
    let (per_tile, stats) = lists_by_tile(options, tile_depth, frames, frames_per_batch)?;
    let mut tiles = Vec::with_capacity(per_tile.len());
    for (tile, lists) in per_tile {
        let t = tile_tree(options, tile, &lists)?;
        tiles.extend(write_tile(dir, &t, tile_depth)?);
    }
    let index = TileIndex {
        resolution: options.resolution,
        params: options.params,
        tile_depth,
        tiles,
    };
    write_index(dir, &index)?;
    Ok((index, stats))
}

/// The update lists of `frames`, cast in batches of `frames_per_batch` and grouped by tile in
/// tile order, each tile's lists in frame order; the statistics of the casting.
fn lists_by_tile(
    options: &MapperOptions,
    tile_depth: u8,
    frames: &[Frame],
    frames_per_batch: usize,
) -> Result<(BTreeMap<Tile, Vec<TileUpdates>>, MapStats), TiledError> {
    if options.lazy {
        return Err(TiledError::Lazy);
    }
    let mut caster = FrameCaster::new(options.clone())?;
    let mut per_tile: BTreeMap<Tile, Vec<TileUpdates>> = BTreeMap::new();
    let mut stats = MapStats::default();
    let batch = frames_per_batch.max(1);
    for (b, chunk) in frames.chunks(batch).enumerate() {
        let (lists, st) = cast_frames(&mut caster, tile_depth, (b * batch) as u64, chunk)?;
        for l in lists {
            per_tile.entry(l.tile).or_default().push(l);
        }
        stats.merge(&st);
    }
    Ok((per_tile, stats))
}

/// The tree of one tile: its lists applied in frame order to an empty tree of the options'
/// resolution and sensor model.
fn tile_tree(
    options: &MapperOptions,
    tile: Tile,
    lists: &[TileUpdates],
) -> Result<OcTree, TiledError> {
    let mut t = OcTree::with_params(options.resolution, options.params).map_err(TileError::from)?;
    apply_tile_updates(&mut t, tile, lists)?;
    Ok(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_depths_give_tiles_of_about_25_m() {
        assert_eq!(default_tile_depth(0.1), 8);
        assert_eq!(default_tile_depth(0.05), 7);
        assert_eq!(default_tile_depth(0.2), 9);
        assert_eq!(default_tile_depth(1e-6), 1);
        assert_eq!(default_tile_depth(100.0), 14);
        for res in [0.01, 0.1, 0.3, 2.0] {
            let d = default_tile_depth(res);
            let edge = res * f64::from(1u32 << (16 - d));
            assert!((12.0..=52.0).contains(&edge), "res {res}: edge {edge}");
        }
    }
}
