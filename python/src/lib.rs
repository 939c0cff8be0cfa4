//! The `octoquant._octoquant` extension module: octoquant's occupancy octree for Python, a
//! drop-in for octomap-python (`octoquant.OcTree`) with NumPy in and out.
//!
//! Layout: [`engine`] is the only file that calls the octoquant library; [`convert`] checks
//! and converts Python arguments; [`tree`], [`node`], [`iter`] and [`mapper`] are the Python
//! classes;
//! [`cloud`] and [`bbx`] hold the array queries and the bounding-box insertion they call.
#![deny(missing_docs)]

mod bbx;
mod cloud;
mod convert;
mod engine;
mod iter;
mod mapper;
mod node;
mod tree;

use pyo3::prelude::*;

pyo3::create_exception!(
    octoquant,
    NullPointerException,
    pyo3::exceptions::PyException,
    "A node or iterator that stands for nothing (unknown space, or past the end)."
);

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
    Ok(())
}
