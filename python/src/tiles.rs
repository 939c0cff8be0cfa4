//! The pieces of the exact tiled build for Python (used by `octoquant.distributed`): frames
//! cast into per-tile update lists, a tile's lists applied to its own tree, tile trees
//! joined. Lists travel as the tiles crate's checked bytes, tile trees as `.ot` bytes.

use crate::convert::{self, vec3_f32};
use crate::engine::{self, MapperOptions, OcTree};
use crate::tree::PyOcTree;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};

fn tile_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

fn depth_arg(depth: i64) -> PyResult<u8> {
    u8::try_from(depth)
        .ok()
        .filter(|&d| d <= 16)
        .ok_or_else(|| PyValueError::new_err(format!("tile_depth must be 0..=16, got {depth}")))
}

fn resolution_arg(resolution: f64) -> PyResult<f64> {
    if resolution.is_finite() && resolution > 0.0 {
        Ok(resolution)
    } else {
        Err(PyValueError::new_err(format!(
            "resolution must be finite and > 0, got {resolution}"
        )))
    }
}

/// The tile depth a build uses when none is given: tiles of about 25.6 m a side.
#[pyfunction]
pub fn default_tile_depth(resolution: f64) -> PyResult<u8> {
    Ok(engine::default_tile_depth(resolution_arg(resolution)?))
}

/// Cast frames ``[(points, origin), ...]`` (world coordinates; their run indices ``first``,
/// ``first + 1``, ...) as ``octoquant map`` would with these options, and split each frame's
/// voxel sets by tile at ``tile_depth``. Returns ``({tile_index: bytes}, stats)``: each
/// touched tile's update lists as bytes (for :func:`apply_tile`) and the totals (frames,
/// points, rays, free, occupied, seconds). Releases the GIL.
#[pyfunction]
#[pyo3(signature = (frames, first, resolution, tile_depth, max_range=None, mode="exact"))]
pub fn cast_tiles<'py>(
    py: Python<'py>,
    frames: &Bound<'py, PyAny>,
    first: u64,
    resolution: f64,
    tile_depth: i64,
    max_range: Option<f64>,
    mode: &str,
) -> PyResult<(Bound<'py, PyDict>, Bound<'py, PyDict>)> {
    let depth = depth_arg(tile_depth)?;
    if max_range.is_some_and(f64::is_nan) {
        return Err(PyValueError::new_err("max_range must not be NaN"));
    }
    let mode = engine::INSERT_MODES
        .into_iter()
        .find(|m| m.name() == mode)
        .ok_or_else(|| PyValueError::new_err(format!("unknown mode {mode:?}")))?;
    let options = MapperOptions {
        resolution: resolution_arg(resolution)?,
        max_range,
        mode,
        ..MapperOptions::default()
    };
    let mut list = Vec::new();
    for item in frames.try_iter()? {
        let (pts, origin): (Bound<'py, PyAny>, Bound<'py, PyAny>) = item?.extract()?;
        list.push(engine::Frame::new_f32(
            vec3_f32(&origin, "origin")?,
            convert::points_f32(&pts, "points")?,
        ));
    }
    let (encoded, stats) = py
        .detach(|| -> Result<_, String> {
            let mut caster = engine::FrameCaster::new(options).map_err(|e| e.to_string())?;
            let (lists, stats) =
                engine::cast_frames(&mut caster, depth, first, &list).map_err(|e| e.to_string())?;
            let encoded = lists
                .iter()
                .map(|l| Ok((l.tile.index(), l.to_bytes()?)))
                .collect::<Result<Vec<(u64, Vec<u8>)>, engine::TileError>>()
                .map_err(|e| e.to_string())?;
            Ok((encoded, stats))
        })
        .map_err(PyValueError::new_err)?;
    let out = PyDict::new(py);
    for (index, bytes) in encoded {
        out.set_item(index, PyBytes::new(py, &bytes))?;
    }
    let st = PyDict::new(py);
    let t = &stats.total;
    st.set_item("frames", stats.frames)?;
    st.set_item("points", t.points)?;
    st.set_item("rays", t.rays)?;
    st.set_item("free", t.free)?;
    st.set_item("occupied", t.occupied)?;
    st.set_item("seconds", t.seconds)?;
    Ok((out, st))
}

/// Apply the update lists ``buffers`` (bytes from :func:`cast_tiles`, any number, in any
/// order) of the tile ``tile_index`` at ``tile_depth`` to a new tree of ``resolution``, in
/// frame order, with OctoMap's ``updateNode``. Returns ``(ot_bytes, stats)``: the tile's tree
/// as ``.ot`` bytes (for :func:`join_tiles`) and the counts (frames, free, occupied). A bad
/// buffer raises ValueError. Releases the GIL.
#[pyfunction]
pub fn apply_tile<'py>(
    py: Python<'py>,
    tile_depth: i64,
    tile_index: u64,
    buffers: Vec<Bound<'py, PyBytes>>,
    resolution: f64,
) -> PyResult<(Bound<'py, PyBytes>, Bound<'py, PyDict>)> {
    // one copy each (a memcpy), so that the work below runs without the GIL
    let buffers: Vec<Vec<u8>> = buffers.iter().map(|b| b.as_bytes().to_vec()).collect();
    let tile = engine::Tile::new(depth_arg(tile_depth)?, tile_index).map_err(tile_error)?;
    let resolution = resolution_arg(resolution)?;
    let (ot, stats) = py
        .detach(|| -> Result<_, String> {
            let lists = buffers
                .iter()
                .enumerate()
                .map(|(i, b)| {
                    engine::TileUpdates::from_bytes(b).map_err(|e| format!("buffer {i}: {e}"))
                })
                .collect::<Result<Vec<_>, _>>()?;
            let mut tree = OcTree::new(resolution).map_err(|e| e.to_string())?;
            let stats =
                engine::apply_tile_updates(&mut tree, tile, &lists).map_err(|e| e.to_string())?;
            let ot = engine::write_ot(&tree).map_err(|e| e.to_string())?;
            Ok((ot, stats))
        })
        .map_err(PyValueError::new_err)?;
    let st = PyDict::new(py);
    st.set_item("frames", stats.frames)?;
    st.set_item("free", stats.free)?;
    st.set_item("occupied", stats.occupied)?;
    Ok((PyBytes::new(py, &ot), st))
}

/// Join tile trees (``.ot`` bytes from :func:`apply_tile`, one per tile, any order) built at
/// ``tile_depth`` into one ``OcTree`` of ``resolution``: the tree a sequential
/// ``octoquant map`` of the same frames builds, node for node. Releases the GIL.
#[pyfunction]
pub fn join_tiles(
    py: Python<'_>,
    tile_depth: i64,
    trees: Vec<Bound<'_, PyBytes>>,
    resolution: f64,
) -> PyResult<PyOcTree> {
    let trees: Vec<Vec<u8>> = trees.iter().map(|b| b.as_bytes().to_vec()).collect();
    let depth = depth_arg(tile_depth)?;
    let resolution = resolution_arg(resolution)?;
    let tree = py
        .detach(|| -> Result<OcTree, String> {
            let parsed = trees
                .iter()
                .enumerate()
                .map(|(i, b)| engine::read_tree(b).map_err(|e| format!("tile tree {i}: {e}")))
                .collect::<Result<Vec<_>, _>>()?;
            engine::join_tiles(resolution, depth, &parsed).map_err(|e| e.to_string())
        })
        .map_err(PyValueError::new_err)?;
    Ok(PyOcTree::wrap(tree))
}

/// :func:`apply_tile`, out of core: the tile's tree is written into the directory
/// ``spill_dir`` (which must exist; on a file system every worker and the driver see) as one
/// ``.ot`` file instead of being returned. Returns ``(file_name, nbytes, stats)``
/// (``file_name`` is ``None`` when the tree is empty). Releases the GIL.
#[pyfunction]
pub fn apply_tile_to_dir<'py>(
    py: Python<'py>,
    tile_depth: i64,
    tile_index: u64,
    buffers: Vec<Bound<'py, PyBytes>>,
    resolution: f64,
    spill_dir: &Bound<'py, PyAny>,
) -> PyResult<(Option<String>, u64, Bound<'py, PyDict>)> {
    let buffers: Vec<Vec<u8>> = buffers.iter().map(|b| b.as_bytes().to_vec()).collect();
    let depth = depth_arg(tile_depth)?;
    let tile = engine::Tile::new(depth, tile_index).map_err(tile_error)?;
    let resolution = resolution_arg(resolution)?;
    let dir = convert::path(spill_dir, "spill_dir")?;
    let (name, nbytes, stats) = py
        .detach(|| -> Result<_, String> {
            let lists = buffers
                .iter()
                .enumerate()
                .map(|(i, b)| {
                    engine::TileUpdates::from_bytes(b).map_err(|e| format!("buffer {i}: {e}"))
                })
                .collect::<Result<Vec<_>, _>>()?;
            let mut tree = OcTree::new(resolution).map_err(|e| e.to_string())?;
            let stats =
                engine::apply_tile_updates(&mut tree, tile, &lists).map_err(|e| e.to_string())?;
            let written = engine::write_tile(&dir, &tree, depth).map_err(|e| e.to_string())?;
            let nbytes = match &written {
                Some((_, n)) => std::fs::metadata(dir.join(n)).map_or(0, |m| m.len()),
                None => 0,
            };
            Ok((written.map(|(_, n)| n), nbytes, stats))
        })
        .map_err(PyValueError::new_err)?;
    let st = PyDict::new(py);
    st.set_item("frames", stats.frames)?;
    st.set_item("free", stats.free)?;
    st.set_item("occupied", stats.occupied)?;
    Ok((name, nbytes, st))
}

/// Write the index of the tile directory ``spill_dir`` once every tile file is in place:
/// ``tiles`` is ``[(tile_index, file_name), ...]`` (from :func:`apply_tile_to_dir`), the
/// sensor model OctoMap's default (as :func:`apply_tile` builds). After this, ``octoquant
/// join`` or :func:`join_tile_dir` assembles the map.
#[pyfunction]
pub fn write_tile_index(
    spill_dir: &Bound<'_, PyAny>,
    resolution: f64,
    tile_depth: i64,
    tiles: Vec<(u64, String)>,
) -> PyResult<()> {
    let dir = convert::path(spill_dir, "spill_dir")?;
    let depth = depth_arg(tile_depth)?;
    let tiles = tiles
        .into_iter()
        .map(|(i, n)| Ok((engine::Tile::new(depth, i).map_err(tile_error)?, n)))
        .collect::<PyResult<Vec<_>>>()?;
    let index = engine::TileIndex {
        resolution: resolution_arg(resolution)?,
        params: engine::OccupancyParams::default(),
        tile_depth: depth,
        tiles,
    };
    engine::write_index(&dir, &index).map_err(tile_error)
}

/// Assemble the tile directory ``spill_dir`` (tile files and their index) into one
/// ``OcTree``, as ``octoquant join`` does. Releases the GIL.
#[pyfunction]
pub fn join_tile_dir(py: Python<'_>, spill_dir: &Bound<'_, PyAny>) -> PyResult<PyOcTree> {
    let dir = convert::path(spill_dir, "spill_dir")?;
    let tree = py.detach(|| engine::join_dir(&dir)).map_err(tile_error)?;
    Ok(PyOcTree::wrap(tree))
}
