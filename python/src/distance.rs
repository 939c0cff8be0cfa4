//! octomap-python's `dynamicEDT_*` methods of `OcTree` (a distance map over the tree, with
//! dynamicEDT3D's numbers) and the vectorised `distances`.
//!
//! The methods themselves are `PyOcTree`'s (in `tree.rs`); each passes this module the tree
//! and the distance map it holds (`None` before `dynamicEDT_generate`), so that this module
//! needs only the library's types and the class depends on it, not the other way round.

use crate::convert;
use crate::engine::{DistanceError, DistanceMap, DistanceOptions, OcTree};
use crate::node::{key_arg, PyKey};
use crate::NullPointerException;
use numpy::PyArray1;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

fn value_error(e: &DistanceError) -> PyErr {
    PyValueError::new_err(format!("distance map: {e}"))
}

fn no_map() -> PyErr {
    NullPointerException::new_err("no distance map: call dynamicEDT_generate first")
}

/// The tree's distance map, or the NullPointerException that says there is none yet.
fn map(edt: Option<&DistanceMap>) -> PyResult<&DistanceMap> {
    edt.ok_or_else(no_map)
}

/// `dynamicEDT_generate`: copy the box's occupancy of `tree` into a new distance map
/// (distances are computed by `dynamicEDT_update`); the caller keeps it with the tree and
/// turns on the tree's change detection.
pub(crate) fn generate(
    tree: &OcTree,
    py: Python<'_>,
    maxdist: f64,
    bbx_min: &Bound<'_, PyAny>,
    bbx_max: &Bound<'_, PyAny>,
    unknown_occupied: bool,
) -> PyResult<DistanceMap> {
    let options = DistanceOptions {
        max_dist: maxdist as f32,
        bbx_min: convert::vec3(bbx_min, "bbx_min")?,
        bbx_max: convert::vec3(bbx_max, "bbx_max")?,
        unknown_occupied,
    };
    py.detach(|| DistanceMap::staged(tree, &options))
        .map_err(|e| value_error(&e))
}

/// `dynamicEDT_update`: take in the tree's changes and propagate.
pub(crate) fn update(
    tree: &mut OcTree,
    edt: Option<&mut DistanceMap>,
    py: Python<'_>,
    real_dist: bool,
) -> PyResult<()> {
    let m = edt.ok_or_else(no_map)?;
    py.detach(|| m.update(tree, real_dist))
        .map_err(|e| value_error(&e))
}

/// `dynamicEDT_getMaxDist`.
pub(crate) fn max_dist(edt: Option<&DistanceMap>) -> PyResult<f32> {
    Ok(map(edt)?.max_dist())
}

/// `dynamicEDT_checkConsistency`.
pub(crate) fn check_consistency(tree: &OcTree, edt: Option<&DistanceMap>) -> PyResult<bool> {
    Ok(map(edt)?.check_consistency(tree))
}

/// `dynamicEDT_getDistance` of a point or an `OcTreeKey`.
pub(crate) fn distance(edt: Option<&DistanceMap>, p: &Bound<'_, PyAny>) -> PyResult<f32> {
    let m = map(edt)?;
    if p.cast::<PyKey>().is_ok() {
        return Ok(m.distance_at_key(key_arg(p, "p")?));
    }
    m.distance(&convert::vec3(p, "p")?)
        .map_err(|e| value_error(&e))
}

/// The obstacle part of `dynamicEDT_getDistanceAndClosestObstacle`: a (3,) float64 array.
pub(crate) type Obstacle<'py> = Option<Bound<'py, PyArray1<f64>>>;

/// `dynamicEDT_getDistanceAndClosestObstacle`: `(distance, obstacle centre or None)`.
pub(crate) fn distance_and_closest_obstacle<'py>(
    edt: Option<&DistanceMap>,
    py: Python<'py>,
    p: &Bound<'py, PyAny>,
) -> PyResult<(f32, Obstacle<'py>)> {
    let (d, o) = map(edt)?
        .distance_and_closest_obstacle(&convert::vec3(p, "p")?)
        .map_err(|e| value_error(&e))?;
    Ok((d, o.map(|o| convert::array3(py, [o.x, o.y, o.z]))))
}

/// `distances`: `dynamicEDT_getDistance` of every row of an (N, 3) array, as float32.
pub(crate) fn distances<'py>(
    edt: Option<&DistanceMap>,
    py: Python<'py>,
    points: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArray1<f32>>> {
    let m = map(edt)?;
    let pts = convert::points_f64(points, "points")?;
    let out = py.detach(|| {
        pts.iter()
            .enumerate()
            .map(|(i, p)| m.distance(p).map_err(|e| (i, e)))
            .collect::<Result<Vec<f32>, _>>()
    });
    match out {
        Ok(v) => Ok(PyArray1::from_vec(py, v)),
        Err((i, e)) => Err(PyValueError::new_err(format!("points row {i}: {e}"))),
    }
}
