//! `octoquant.dbscan1d`, `octoquant.segment_scan` and `octoquant.read_laser_scans`: 1-D DBSCAN
//! and laser-scan line segmentation (the octoquant-segment crate) from NumPy.

use crate::convert::{path, real_array};
use crate::engine::{
    self, BorderPolicy, Clustering, Dbscan1dParams, LineParams, SegmentError, Segmentation, NOISE,
};
use numpy::ndarray::Array2;
use numpy::{PyArray1, PyArray2};
use octoquant_segment::Resegment;
use pyo3::exceptions::{PyFileNotFoundError, PyValueError};
use pyo3::prelude::*;

fn segment_error(e: SegmentError) -> PyErr {
    PyValueError::new_err(e.to_string())
}

fn border(name: &str) -> PyResult<BorderPolicy> {
    match name {
        "first" => Ok(BorderPolicy::First),
        "all" => Ok(BorderPolicy::All),
        "noise" => Ok(BorderPolicy::Noise),
        _ => Err(PyValueError::new_err(format!(
            "border must be \"first\", \"all\" or \"noise\", got {name:?}"
        ))),
    }
}

fn min_points(v: i64, name: &str) -> PyResult<usize> {
    if v >= 1 {
        Ok(usize::try_from(v).unwrap_or(usize::MAX))
    } else {
        Err(PyValueError::new_err(format!(
            "{name} must be at least 1, got {v}"
        )))
    }
}

fn label(l: u32) -> i64 {
    if l == NOISE {
        -1
    } else {
        i64::from(l)
    }
}

/// DBSCAN on 1-D values in O(N) after sorting (the octoquant-segment crate's ``dbscan1d``).
///
/// Two values are neighbours when their distance is at most ``eps``; a value is a core point
/// when at least ``min_points`` values (itself included) are its neighbours. With ``period``
/// the values lie on a circle: each must be in ``[0, period)`` and the distance of ``a <= b``
/// is ``min(b - a, a + period - b)``. Returns int64 labels, one per value, ``-1`` for noise;
/// clusters are numbered ``0, 1, ...`` in the order the original DBSCAN finds them visiting the
/// values in ascending order (unsorted input is sorted first, stably; the labels come back in
/// the input's order). ``border``: a border point (non-core, reached by a core point) joins
/// the first cluster reaching it (``"first"``), is noise (``"noise"``, DBSCAN*), or joins every
/// cluster reaching it (``"all"``: the result is then ``(labels, second_labels)``, the second
/// cluster or -1). NaN/inf values and values outside ``[0, period)`` raise ``ValueError``
/// naming the index. Releases the GIL.
#[pyfunction]
#[pyo3(signature = (x, eps, min_points, period=None, *, border="first"))]
pub fn dbscan1d<'py>(
    py: Python<'py>,
    x: &Bound<'py, PyAny>,
    eps: f64,
    min_points: i64,
    period: Option<f64>,
    border: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let policy = self::border(border)?;
    let mut params = Dbscan1dParams::new(eps, self::min_points(min_points, "min_points")?)
        .map_err(segment_error)?
        .with_border(policy);
    if let Some(p) = period {
        params = params.with_period(p).map_err(segment_error)?;
    }
    let (values, _) = real_array(x, "x", 1, None)?;
    for (i, &v) in values.iter().enumerate() {
        if !v.is_finite() {
            return Err(segment_error(SegmentError::NonFinite {
                index: i,
                value: v,
            }));
        }
        if let Some(p) = period {
            if !(0.0..p).contains(&v) {
                return Err(segment_error(SegmentError::OutOfPeriod {
                    index: i,
                    value: v,
                    period: p,
                }));
            }
        }
    }
    let (labels, second) = py
        .detach(|| {
            let sorted = values.windows(2).all(|w| w[0] <= w[1]);
            // (value, index) pairs sorted together: the comparisons read contiguous memory
            // (an index sort reading values[a] at random was 15x the clustering at 10^7);
            // ties by index keep the stable order
            let (order, xs): (Vec<usize>, Vec<f64>) = if sorted {
                ((0..values.len()).collect(), values.clone())
            } else {
                let mut pairs: Vec<(f64, usize)> =
                    values.iter().enumerate().map(|(i, &v)| (v, i)).collect();
                pairs.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                pairs.into_iter().map(|(v, i)| (i, v)).unzip()
            };
            let mut c = Clustering::new();
            engine::dbscan1d(&xs, &params, &mut c)?;
            let mut labels = vec![-1i64; values.len()];
            let mut second = vec![-1i64; values.len()];
            for (k, &i) in order.iter().enumerate() {
                labels[i] = label(c.labels()[k]);
                second[i] = c.second_label(k).map_or(-1, i64::from);
            }
            Ok((labels, second))
        })
        .map_err(segment_error)?;
    let labels = PyArray1::from_vec(py, labels);
    if policy == BorderPolicy::All {
        Ok((labels, PyArray1::from_vec(py, second))
            .into_pyobject(py)?
            .into_any())
    } else {
        Ok(labels.into_any())
    }
}

/// Line segments of one 2D laser scan (Meglicki's angular segmentation; the octoquant-segment
/// crate's ``segment_scan``, what ``octoquant segment`` runs).
///
/// ``points``: (N, 2) valid returns in beam order, in a frame whose origin is the laser
/// (distances are measured from it). ``eps_theta`` (radians, default 2 degrees) and
/// ``min_points_theta`` cluster the local normal angles, ``eps_dist`` (metres, default 0.05)
/// and ``min_points_dist`` the distances of each angular cluster. ``split_eps`` (metres along
/// the line, default 0.5; ``math.inf`` turns the step off), ``split_min_points`` (default 2)
/// and ``split_spacing_factor`` (default 3: the epsilon grows to that many median point
/// spacings on far, sparse lines; 0 keeps it fixed) drive the collinear lines separation,
/// which cuts a line where its points are far apart along it (a wall broken by a doorway
/// gives two lines). ``resegment_rms`` (metres, default
/// ``None``: off) re-clusters a distance cluster whose fitted line leaves a larger rms
/// residual, with ``resegment_eps`` (default 0.01 m) and ``resegment_min_points`` (default 5),
/// to separate close parallel features. Clusters with fewer than ``min_line_points`` points
/// (at least 2) are not lines. Defaults are the library's.
///
/// Returns ``(lines, labels)``: ``lines`` a structured array, one row per line in the order
/// found, with fields ``normal_angle`` (radians in [0, 2 pi), pointing away from the origin),
/// ``distance`` (from the origin, >= 0; the line is ``x cos(a) + y sin(a) = distance``),
/// ``start_x``, ``start_y``, ``end_x``, ``end_y`` (extreme members projected on the line),
/// ``length``, ``n_points``, ``rms_residual`` and ``max_residual`` (metres); ``labels`` the
/// int64 line of each point, -1 for none. NaN/inf points raise ``ValueError``.
#[pyfunction]
#[pyo3(signature = (points, *, eps_theta=None, eps_dist=None, min_points_theta=None,
    min_points_dist=None, min_line_points=None, border="first", split_eps=None,
    split_min_points=None, split_spacing_factor=None, resegment_rms=None, resegment_eps=None,
    resegment_min_points=None))]
#[allow(clippy::too_many_arguments)]
pub fn segment_scan<'py>(
    py: Python<'py>,
    points: &Bound<'py, PyAny>,
    eps_theta: Option<f64>,
    eps_dist: Option<f64>,
    min_points_theta: Option<i64>,
    min_points_dist: Option<i64>,
    min_line_points: Option<i64>,
    border: &str,
    split_eps: Option<f64>,
    split_min_points: Option<i64>,
    split_spacing_factor: Option<f64>,
    resegment_rms: Option<f64>,
    resegment_eps: Option<f64>,
    resegment_min_points: Option<i64>,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyArray1<i64>>)> {
    let d = LineParams::default();
    let r = Resegment::default();
    if resegment_rms.is_none() && (resegment_eps.is_some() || resegment_min_points.is_some()) {
        return Err(PyValueError::new_err(
            "resegment_eps and resegment_min_points need resegment_rms",
        ));
    }
    let resegment = match resegment_rms {
        None => None,
        Some(max_rms) => Some(Resegment {
            max_rms,
            eps: resegment_eps.unwrap_or(r.eps),
            min_points: match resegment_min_points {
                Some(v) => min_points(v, "resegment_min_points")?,
                None => r.min_points,
            },
        }),
    };
    let params = LineParams {
        eps_theta: eps_theta.unwrap_or(d.eps_theta),
        eps_dist: eps_dist.unwrap_or(d.eps_dist),
        min_points_theta: match min_points_theta {
            Some(v) => min_points(v, "min_points_theta")?,
            None => d.min_points_theta,
        },
        min_points_dist: match min_points_dist {
            Some(v) => min_points(v, "min_points_dist")?,
            None => d.min_points_dist,
        },
        min_line_points: match min_line_points {
            Some(v) => min_points(v, "min_line_points")?,
            None => d.min_line_points,
        },
        border: self::border(border)?,
        split_eps: split_eps.unwrap_or(d.split_eps),
        split_min_points: match split_min_points {
            Some(v) => min_points(v, "split_min_points")?,
            None => d.split_min_points,
        },
        split_spacing_factor: split_spacing_factor.unwrap_or(d.split_spacing_factor),
        resegment,
    };
    let (flat, _) = real_array(points, "points", 2, Some(2))?;
    let pts: Vec<[f64; 2]> = flat.chunks_exact(2).map(|c| [c[0], c[1]]).collect();
    let seg = py
        .detach(|| {
            let mut seg = Segmentation::new();
            engine::segment_scan(&pts, &params, &mut seg).map(|_| seg)
        })
        .map_err(segment_error)?;
    let lines = seg.lines();
    let np = py.import("numpy")?;
    let fields = [
        ("normal_angle", "f8"),
        ("distance", "f8"),
        ("start_x", "f8"),
        ("start_y", "f8"),
        ("end_x", "f8"),
        ("end_y", "f8"),
        ("length", "f8"),
        ("n_points", "i8"),
        ("rms_residual", "f8"),
        ("max_residual", "f8"),
    ];
    let dtype = np.call_method1("dtype", (fields.to_vec(),))?;
    let out = np.call_method1("empty", (lines.len(), dtype))?;
    let col = |f: fn(&engine::Line) -> f64| -> Vec<f64> { lines.iter().map(f).collect() };
    out.set_item(
        "normal_angle",
        PyArray1::from_vec(py, col(|l| l.normal_angle)),
    )?;
    out.set_item("distance", PyArray1::from_vec(py, col(|l| l.distance)))?;
    out.set_item("start_x", PyArray1::from_vec(py, col(|l| l.start[0])))?;
    out.set_item("start_y", PyArray1::from_vec(py, col(|l| l.start[1])))?;
    out.set_item("end_x", PyArray1::from_vec(py, col(|l| l.end[0])))?;
    out.set_item("end_y", PyArray1::from_vec(py, col(|l| l.end[1])))?;
    out.set_item("length", PyArray1::from_vec(py, col(|l| l.length())))?;
    let n: Vec<i64> = lines.iter().map(|l| l.n_points as i64).collect();
    out.set_item("n_points", PyArray1::from_vec(py, n))?;
    out.set_item(
        "rms_residual",
        PyArray1::from_vec(py, col(|l| l.rms_residual)),
    )?;
    out.set_item(
        "max_residual",
        PyArray1::from_vec(py, col(|l| l.max_residual)),
    )?;
    let labels: Vec<i64> = seg.labels().iter().map(|&l| label(l)).collect();
    Ok((out, PyArray1::from_vec(py, labels)))
}

/// One laser scan for Python: its valid returns in the laser frame and the laser's pose.
type ScanArrays<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray1<f64>>);

/// Read the laser scans of a CARMEN log (``FLASER``/``ROBOTLASER1`` lines, ``.gz``/``.bz2``
/// allowed), as ``octoquant segment`` does: ``[(points, pose), ...]`` in file order, with
/// ``points`` the valid returns of each scan as float64 (N, 2) in the laser frame, in beam order
/// (what :func:`segment_scan` takes), and ``pose`` the laser's world pose ``(x, y, theta)``.
/// Releases the GIL.
#[pyfunction]
pub fn read_laser_scans<'py>(
    py: Python<'py>,
    path: &Bound<'py, PyAny>,
) -> PyResult<Vec<ScanArrays<'py>>> {
    let p = self::path(path, "path")?;
    if !p.exists() {
        return Err(PyFileNotFoundError::new_err(format!(
            "no such file: {}",
            p.display()
        )));
    }
    let scans = py
        .detach(|| engine::read_laser_scans(&p))
        .map_err(PyValueError::new_err)?;
    let mut out = Vec::with_capacity(scans.len());
    let mut pts = Vec::new();
    for s in &scans {
        s.laser_points(&mut pts);
        let flat: Vec<f64> = pts.iter().flatten().copied().collect();
        let arr =
            Array2::from_shape_vec((pts.len(), 2), flat).unwrap_or_else(|_| Array2::zeros((0, 2)));
        let pose = [s.laser_pose.x, s.laser_pose.y, s.laser_pose.theta];
        out.push((
            PyArray2::from_owned_array(py, arr),
            PyArray1::from_slice(py, &pose),
        ));
    }
    Ok(out)
}
