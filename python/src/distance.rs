//! octomap-python's `dynamicEDT_*` methods of `OcTree` (a distance map over the tree, with
//! dynamicEDT3D's numbers) and the vectorised `distances`.

use crate::convert;
use crate::engine::{DistanceError, DistanceMap, DistanceOptions};
use crate::node::{key_arg, PyKey};
use crate::tree::PyOcTree;
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

fn map(t: &PyOcTree) -> PyResult<&DistanceMap> {
    t.edt.as_deref().ok_or_else(no_map)
}

/// `dynamicEDT_generate`: copy the box's occupancy into a new distance map (distances are
/// computed by `dynamicEDT_update`) and turn on the tree's change detection.
pub(crate) fn generate(
    t: &mut PyOcTree,
    py: Python<'_>,
    maxdist: f64,
    bbx_min: &Bound<'_, PyAny>,
    bbx_max: &Bound<'_, PyAny>,
    unknown_occupied: bool,
) -> PyResult<()> {
    let options = DistanceOptions {
        max_dist: maxdist as f32,
        bbx_min: convert::vec3(bbx_min, "bbx_min")?,
        bbx_max: convert::vec3(bbx_max, "bbx_max")?,
        unknown_occupied,
    };
    let tree = &t.tree;
    let m = py
        .detach(|| DistanceMap::staged(tree, &options))
        .map_err(|e| value_error(&e))?;
    t.edt = Some(Box::new(m));
    t.tree.enable_change_detection(true);
    Ok(())
}

/// `dynamicEDT_update`: take in the tree's changes and propagate.
pub(crate) fn update(t: &mut PyOcTree, py: Python<'_>, real_dist: bool) -> PyResult<()> {
    let PyOcTree { tree, edt, .. } = t;
    let m = edt.as_deref_mut().ok_or_else(no_map)?;
    py.detach(|| m.update(tree, real_dist))
        .map_err(|e| value_error(&e))
}

/// `dynamicEDT_getMaxDist`.
pub(crate) fn max_dist(t: &PyOcTree) -> PyResult<f32> {
    Ok(map(t)?.max_dist())
}

/// `dynamicEDT_checkConsistency`.
pub(crate) fn check_consistency(t: &PyOcTree) -> PyResult<bool> {
    Ok(map(t)?.check_consistency(&t.tree))
}

/// `dynamicEDT_getDistance` of a point or an `OcTreeKey`.
pub(crate) fn distance(t: &PyOcTree, p: &Bound<'_, PyAny>) -> PyResult<f32> {
    let m = map(t)?;
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
    t: &PyOcTree,
    py: Python<'py>,
    p: &Bound<'py, PyAny>,
) -> PyResult<(f32, Obstacle<'py>)> {
    let (d, o) = map(t)?
        .distance_and_closest_obstacle(&convert::vec3(p, "p")?)
        .map_err(|e| value_error(&e))?;
    Ok((d, o.map(|o| convert::array3(py, [o.x, o.y, o.z]))))
}

/// `distances`: `dynamicEDT_getDistance` of every row of an (N, 3) array, as float32.
pub(crate) fn distances<'py>(
    t: &PyOcTree,
    py: Python<'py>,
    points: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArray1<f32>>> {
    let m = map(t)?;
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
