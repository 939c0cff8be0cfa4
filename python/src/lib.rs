//! The `octoquant._octoquant` extension module: octoquant's occupancy octree for Python, a
//! drop-in for octomap-python (`octoquant.OcTree`) with NumPy in and out.
//!
//! Layout: [`engine`] is the only file that names the octoquant library's paths and free
//! functions; [`convert`] checks and converts Python arguments; [`tree`], [`node`], [`iter`]
//! and [`mapper`] are the Python classes; [`cloud`] and [`bbx`] hold the array queries and the
//! bounding-box insertion they call.
#![deny(missing_docs)]

mod bbx;
mod cloud;
mod convert;
mod engine;
mod iter;
mod mapper;
mod node;
mod tree;

use numpy::ndarray::Array2;
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;

pyo3::create_exception!(
    octoquant,
    NullPointerException,
    pyo3::exceptions::PyException,
    "A node or iterator that stands for nothing (unknown space, or past the end)."
);

/// One frame for Python: its points and its origin.
type FrameArrays<'py> = (Bound<'py, PyArray2<f32>>, Bound<'py, PyArray1<f32>>);

/// Read a sensor file (or scan directory) the way the octoquant CLI does: every format it
/// reads (ScanGraph ``.graph``, text/``.dat``/``.log``, VTK, PCD, PLY, TUM RGB-D, MCAP bags,
/// ``.gz``/``.bz2`` compressed). Returns ``[(points, origin), ...]``: float32 (N, 3) world
/// points and the (3,) sensor origin of each frame. ``format`` forces a format by its CLI name.
/// Releases the GIL while reading.
#[pyfunction]
#[pyo3(signature = (path, format=None))]
fn read_frames<'py>(
    py: Python<'py>,
    path: &Bound<'py, PyAny>,
    format: Option<&str>,
) -> PyResult<Vec<FrameArrays<'py>>> {
    let p = convert::path(path, "path")?;
    if !p.exists() {
        return Err(pyo3::exceptions::PyFileNotFoundError::new_err(format!(
            "no such file or directory: {}",
            p.display()
        )));
    }
    let frames = py
        .detach(|| engine::read_frames(&p, format))
        .map_err(pyo3::exceptions::PyValueError::new_err)?;
    Ok(frames
        .into_iter()
        .map(|f| {
            let n = f.points.len();
            let flat: Vec<f32> = f.points.iter().flat_map(|q| [q.x, q.y, q.z]).collect();
            let pts =
                Array2::from_shape_vec((n, 3), flat).unwrap_or_else(|_| Array2::zeros((0, 3)));
            (
                PyArray2::from_owned_array(py, pts),
                PyArray1::from_slice(py, &[f.origin.x, f.origin.y, f.origin.z]),
            )
        })
        .collect())
}

/// octoquant: OctoMap-compatible occupancy octrees from NumPy, fast.
#[pymodule]
fn _octoquant(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<tree::PyOcTree>()?;
    m.add_class::<mapper::PyMapper>()?;
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
    m.add_function(wrap_pyfunction!(read_frames, m)?)?;
    Ok(())
}
