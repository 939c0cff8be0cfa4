//! The `octoquant._octoquant` extension module: octoquant's occupancy octree for Python, a
//! drop-in for octomap-python (`octoquant.OcTree`) with NumPy in and out.
//!
//! Layout: [`engine`] is the only file that names the octoquant library's paths and free
//! functions; [`convert`] checks and converts Python arguments; [`tree`], [`color_tree`],
//! [`stamped_tree`], [`node`], [`iter`], [`mapper`], [`color_mapper`] and [`stamped_mapper`]
//! are the Python classes; [`cloud`] and [`bbx`] hold the array queries and the
//! bounding-box insertion they call; [`density`] and [`segment`] wrap the density reducer and
//! the 1-D DBSCAN / laser-line segmentation; [`tiles`] the pieces of the exact tiled build
//! that `octoquant.distributed` runs on Dask.
#![deny(missing_docs)]

mod bbx;
mod cloud;
mod color_mapper;
mod color_tree;
mod convert;
mod density;
mod distance;
mod engine;
mod iter;
mod mapper;
mod node;
mod occupancy_api;
mod segment;
mod stamped_mapper;
mod stamped_tree;
mod tiles;
mod tree;

use numpy::ndarray::Array2;
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::PyTuple;

pyo3::create_exception!(
    octoquant,
    NullPointerException,
    pyo3::exceptions::PyException,
    "A node or iterator that stands for nothing (unknown space, or past the end)."
);

/// One frame for Python: its points and its origin.
type FrameArrays<'py> = (Bound<'py, PyArray2<f32>>, Bound<'py, PyArray1<f32>>);

/// Read a sensor file (or scan directory) the way the octoquant CLI does: every format it
/// reads (ScanGraph ``.graph``, ``.frames``, text/``.dat``/``.log``, VTK and VTK sequences,
/// PCD, PLY, TUM RGB-D, MCAP bags, ``.gz``/``.bz2`` compressed). Returns
/// ``[(points, origin), ...]``: float32 (N, 3) world points and the (3,) sensor origin of each
/// frame.
///
/// The reader options of ``octoquant map``, as keywords: ``format`` (its ``--format`` names:
/// graph, frames, text, vtk, vtk-seq, pcd, tum-png, tum, mcap, ply; default: from the path),
/// ``points_global`` (``--global``: .graph points already in world coordinates), ``topic``
/// and ``fixed_frame`` (MCAP), ``pixel_step`` (TUM depth images: every N-th pixel). Beyond
/// the CLI: ``trajectory`` (the CSV of a VTK sequence), ``depth_scale`` and ``intrinsics``
/// ``(fx, fy, cx, cy)`` (TUM depth), ``viewpoint`` (PCD ``VIEWPOINT``: ``"origin"`` as PCL,
/// ``"apply"`` or ``"ignore"``). ``first`` and ``count``: only frames ``first .. first +
/// count`` (all from ``first`` without a count), read one at a time and no further than
/// needed (what a distributed task reads), the frames before ``first`` passed over without
/// reading their points where the input allows (``.frames`` seeks, VTK sequences and TUM
/// associations skip their files); an input with fewer frames raises ValueError.
/// ``colors``: also return each frame's colours, ``[(points, origin, colors), ...]`` with
/// ``colors`` a uint8 (N, 3) RGB array (PCD ``rgb``/``rgba``, PLY ``red green blue``, TUM RGB
/// images, PointCloud2 ``rgb``/``rgba``, ``.frames`` files that store them; what
/// :class:`ColorMapper` takes); a frame without colours raises ValueError. ``stamps``: also
/// return each frame's time in seconds (a float, or None where the input has none), as the
/// last element of its tuple: the file name of a TUM depth image, an MCAP cloud's header
/// stamp, a VTK sequence scan's time, a ``.frames`` file's stored time (what
/// ``octoquant map --stamped`` stamps a frame with, and :class:`StampedMapper` takes).
/// Releases the GIL while reading.
#[pyfunction]
#[pyo3(signature = (path, format=None, *, points_global=false, topic=None, fixed_frame=None,
    pixel_step=1, trajectory=None, depth_scale=None, intrinsics=None, viewpoint=None,
    first=0, count=None, colors=false, stamps=false))]
#[allow(clippy::too_many_arguments)]
fn read_frames<'py>(
    py: Python<'py>,
    path: &Bound<'py, PyAny>,
    format: Option<&str>,
    points_global: bool,
    topic: Option<String>,
    fixed_frame: Option<String>,
    pixel_step: i64,
    trajectory: Option<&Bound<'py, PyAny>>,
    depth_scale: Option<f64>,
    intrinsics: Option<(f64, f64, f64, f64)>,
    viewpoint: Option<&str>,
    first: i64,
    count: Option<i64>,
    colors: bool,
    stamps: bool,
) -> PyResult<Vec<Bound<'py, PyTuple>>> {
    use pyo3::exceptions::PyValueError;
    let p = existing_path(path)?;
    let mut options = reader_options(
        format,
        points_global,
        topic,
        fixed_frame,
        pixel_step,
        trajectory,
        depth_scale,
        intrinsics,
        viewpoint,
    )?;
    options.colors = colors;
    let first = usize::try_from(first)
        .map_err(|_| PyValueError::new_err(format!("first must be >= 0, got {first}")))?;
    let count = count
        .map(|c| {
            usize::try_from(c)
                .map_err(|_| PyValueError::new_err(format!("count must be >= 0, got {c}")))
        })
        .transpose()?;
    let frames = py
        .detach(|| {
            if first == 0 && count.is_none() {
                engine::read_frames(&p, &options)
            } else {
                engine::read_frame_range(&p, &options, first, count)
            }
        })
        .map_err(PyValueError::new_err)?;
    let mut out = Vec::with_capacity(frames.len());
    for (i, f) in frames.into_iter().enumerate() {
        let n = f.points.len();
        let flat: Vec<f32> = f.points.iter().flat_map(|q| [q.x, q.y, q.z]).collect();
        let pts = Array2::from_shape_vec((n, 3), flat).unwrap_or_else(|_| Array2::zeros((0, 3)));
        let (pts, origin): FrameArrays<'py> = (
            PyArray2::from_owned_array(py, pts),
            PyArray1::from_slice(py, &[f.origin.x, f.origin.y, f.origin.z]),
        );
        let mut items = vec![pts.into_any(), origin.into_any()];
        if colors {
            let rgb = match &f.colors {
                Some(c) if c.len() == n => c,
                _ => {
                    return Err(PyValueError::new_err(format!(
                        "{}: frame {} has no colours (coloured inputs: PCD rgb/rgba, PLY \
                         red/green/blue, a TUM association with its RGB images, PointCloud2 \
                         rgb/rgba)",
                        p.display(),
                        first + i
                    )))
                }
            };
            let flat: Vec<u8> = rgb.iter().flat_map(|c| c.to_array()).collect();
            let rgb =
                Array2::from_shape_vec((n, 3), flat).unwrap_or_else(|_| Array2::zeros((0, 3)));
            items.push(PyArray2::from_owned_array(py, rgb).into_any());
        }
        if stamps {
            items.push(f.stamp.into_pyobject(py)?.into_any());
        }
        out.push(PyTuple::new(py, items)?);
    }
    Ok(out)
}

/// How many frames :func:`read_frames` would return for ``path`` with these reader options,
/// known without reading the points: the count in a ``.frames`` or ``.graph`` header, one for
/// a single scan, the scans of a VTK sequence, the rows of a TUM association, the clouds in an
/// MCAP summary. ``None`` when the input does not say (text logs, MCAP without statistics) or
/// cannot be read (the read itself then says why). What a distributed build plans its slices
/// by.
#[pyfunction]
#[pyo3(signature = (path, format=None, *, points_global=false, topic=None, fixed_frame=None,
    pixel_step=1, trajectory=None, depth_scale=None, intrinsics=None, viewpoint=None))]
#[allow(clippy::too_many_arguments)]
fn count_frames<'py>(
    py: Python<'py>,
    path: &Bound<'py, PyAny>,
    format: Option<&str>,
    points_global: bool,
    topic: Option<String>,
    fixed_frame: Option<String>,
    pixel_step: i64,
    trajectory: Option<&Bound<'py, PyAny>>,
    depth_scale: Option<f64>,
    intrinsics: Option<(f64, f64, f64, f64)>,
    viewpoint: Option<&str>,
) -> PyResult<Option<usize>> {
    let p = existing_path(path)?;
    let options = reader_options(
        format,
        points_global,
        topic,
        fixed_frame,
        pixel_step,
        trajectory,
        depth_scale,
        intrinsics,
        viewpoint,
    )?;
    Ok(py.detach(|| engine::count_frames(&p, &options)))
}

/// Write frames to a ``.frames`` file, the CLI's lossless frame store: what ``octoquant map``,
/// ``bench``, the distributed build and :func:`read_frames` read back bit for bit. ``frames``
/// holds tuples laid out as :func:`read_frames` returns them with the same ``colors`` and
/// ``stamps`` flags: ``(points (N, 3), origin (3,))``, then the (N, 3) uint8 colours with
/// ``colors=True``, then the time in seconds (or ``None``) with ``stamps=True``. Points are
/// stored as float32 (float64 is rounded, as ``Mapper.insert`` rounds it), NaN points too (the
/// mapper counts and skips them); origins and stamps must be finite. Every frame is checked
/// before anything is written; a bad one raises ``TypeError``/``ValueError`` naming
/// ``frames[i]``. The file is written through a temporary file and a rename, so a failed write
/// (``OSError``) leaves no partial file.
#[pyfunction]
#[pyo3(signature = (path, frames, *, colors=false, stamps=false))]
fn write_frames(
    py: Python<'_>,
    path: &Bound<'_, PyAny>,
    frames: &Bound<'_, PyAny>,
    colors: bool,
    stamps: bool,
) -> PyResult<()> {
    use pyo3::exceptions::{PyOSError, PyValueError};
    let p = convert::path(path, "path")?;
    let fields = 2 + usize::from(colors) + usize::from(stamps);
    let list = mapper::read_frames(frames, |_, item| {
        let parts: Vec<Bound<'_, PyAny>> = item.extract().map_err(|_| {
            pyo3::exceptions::PyTypeError::new_err(format!(
                "a frame must be a tuple of {fields} items, got {}",
                item.get_type()
                    .name()
                    .map(|n| n.to_string())
                    .unwrap_or_default()
            ))
        })?;
        if parts.len() != fields {
            return Err(PyValueError::new_err(format!(
                "a frame must have {fields} items (points, origin{}{}), got {}",
                if colors { ", colors" } else { "" },
                if stamps { ", stamp" } else { "" },
                parts.len()
            )));
        }
        let origin = convert::vec3_f32(&parts[1], "origin")?;
        if !(origin.x.is_finite() && origin.y.is_finite() && origin.z.is_finite()) {
            return Err(PyValueError::new_err(format!(
                "origin must be finite, got ({}, {}, {})",
                origin.x, origin.y, origin.z
            )));
        }
        let mut frame = if colors {
            color_mapper::coloured_frame(&parts[0], &parts[2], origin)?
        } else {
            engine::Frame::new_f32(origin, convert::points_f32(&parts[0], "points")?)
        };
        if stamps {
            let stamp: Option<f64> = parts[fields - 1].extract().map_err(|_| {
                pyo3::exceptions::PyTypeError::new_err("stamp must be a number or None")
            })?;
            if stamp.is_some_and(|t| !t.is_finite()) {
                return Err(PyValueError::new_err(format!(
                    "stamp must be finite, got {}",
                    stamp.unwrap_or_default()
                )));
            }
            frame.stamp = stamp;
        }
        Ok(frame)
    })?;
    py.detach(|| engine::write_frames_file(&p, &list))
        .map_err(PyOSError::new_err)
}

/// The path argument of a reader, which must exist (FileNotFoundError otherwise).
fn existing_path(path: &Bound<'_, PyAny>) -> PyResult<std::path::PathBuf> {
    let p = convert::path(path, "path")?;
    if !p.exists() {
        return Err(pyo3::exceptions::PyFileNotFoundError::new_err(format!(
            "no such file or directory: {}",
            p.display()
        )));
    }
    Ok(p)
}

/// The reader options of ``octoquant map`` from the readers' keywords; bad values raise
/// ValueError.
#[allow(clippy::too_many_arguments)]
fn reader_options(
    format: Option<&str>,
    points_global: bool,
    topic: Option<String>,
    fixed_frame: Option<String>,
    pixel_step: i64,
    trajectory: Option<&Bound<'_, PyAny>>,
    depth_scale: Option<f64>,
    intrinsics: Option<(f64, f64, f64, f64)>,
    viewpoint: Option<&str>,
) -> PyResult<engine::ReadOptions> {
    use pyo3::exceptions::PyValueError;
    let mut options = engine::ReadOptions {
        format: format
            .map(engine::input_format)
            .transpose()
            .map_err(PyValueError::new_err)?,
        ..engine::ReadOptions::default()
    };
    options.graph.points_global = points_global;
    options.mcap.topic = topic;
    options.mcap.fixed_frame = fixed_frame;
    options.tum.pixel_step = u32::try_from(pixel_step)
        .ok()
        .filter(|&s| s >= 1)
        .ok_or_else(|| {
            PyValueError::new_err(format!("pixel_step must be at least 1, got {pixel_step}"))
        })?;
    if let Some(t) = trajectory {
        options.trajectory = Some(convert::path(t, "trajectory")?);
    }
    if let Some(s) = depth_scale {
        options.tum.depth_scale = s;
    }
    if let Some((fx, fy, cx, cy)) = intrinsics {
        options.tum.intrinsics = engine::CameraIntrinsics { fx, fy, cx, cy };
    }
    if let Some(v) = viewpoint {
        options.pcd.viewpoint = match v {
            "origin" => engine::ViewpointUse::OriginOnly,
            "apply" => engine::ViewpointUse::Apply,
            "ignore" => engine::ViewpointUse::Ignore,
            _ => {
                return Err(PyValueError::new_err(format!(
                    "viewpoint must be \"origin\", \"apply\" or \"ignore\", got {v:?}"
                )))
            }
        };
    }
    Ok(options)
}

/// octoquant: OctoMap-compatible occupancy octrees from NumPy, fast.
#[pymodule]
fn _octoquant(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<tree::PyOcTree>()?;
    m.add_class::<color_tree::PyColorOcTree>()?;
    m.add_class::<color_tree::PyColorNode>()?;
    m.add_class::<mapper::PyMapper>()?;
    m.add_class::<color_mapper::PyColorMapper>()?;
    m.add_class::<stamped_tree::PyStampedOcTree>()?;
    m.add_class::<stamped_tree::PyStampedNode>()?;
    m.add_class::<stamped_mapper::PyStampedMapper>()?;
    m.add_class::<node::PyKey>()?;
    m.add_class::<node::PyNode>()?;
    m.add_class::<iter::IteratorBase>()?;
    m.add_class::<iter::TreeIterator>()?;
    m.add_class::<iter::LeafIterator>()?;
    m.add_class::<iter::LeafBbxIterator>()?;
    m.add(
        "NullPointerException",
        m.py().get_type::<NullPointerException>(),
    )?;
    m.add_function(wrap_pyfunction!(tree::_restore, m)?)?;
    m.add_function(wrap_pyfunction!(color_tree::_restore_color, m)?)?;
    m.add_function(wrap_pyfunction!(read_frames, m)?)?;
    m.add_function(wrap_pyfunction!(count_frames, m)?)?;
    m.add_function(wrap_pyfunction!(write_frames, m)?)?;
    m.add_class::<density::PyDensityReducer>()?;
    m.add_class::<density::PyOutputCycle>()?;
    m.add_function(wrap_pyfunction!(density::reduce, m)?)?;
    m.add_function(wrap_pyfunction!(segment::dbscan1d, m)?)?;
    m.add_function(wrap_pyfunction!(segment::segment_scan, m)?)?;
    m.add_function(wrap_pyfunction!(segment::read_laser_scans, m)?)?;
    m.add_function(wrap_pyfunction!(tiles::cast_tiles, m)?)?;
    m.add_function(wrap_pyfunction!(tiles::apply_tile, m)?)?;
    m.add_function(wrap_pyfunction!(tiles::join_tiles, m)?)?;
    m.add_function(wrap_pyfunction!(tiles::apply_tile_to_dir, m)?)?;
    m.add_function(wrap_pyfunction!(tiles::write_tile_index, m)?)?;
    m.add_function(wrap_pyfunction!(tiles::join_tile_dir, m)?)?;
    m.add_function(wrap_pyfunction!(tiles::default_tile_depth, m)?)?;
    Ok(())
}
