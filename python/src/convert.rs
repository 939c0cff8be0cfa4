//! Python values in and out: NumPy point arrays, 3-vectors, paths or serialized bytes, and the
//! library's errors as Python exceptions. Every check happens here, before any Rust call, so a
//! bad argument is a clear `TypeError`/`ValueError`, never a panic.

use crate::engine::{logodds, Color, Key, OctreeError};
use nalgebra::Point3;
use numpy::ndarray::Array2;
use numpy::{
    PyArray1, PyArray2, PyArrayDescrMethods, PyArrayDyn, PyArrayMethods, PyReadonlyArray2,
    PyUntypedArray, PyUntypedArrayMethods,
};
use pyo3::exceptions::{
    PyFileNotFoundError, PyOSError, PyPermissionError, PyTypeError, PyValueError,
};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyString};
use std::path::PathBuf;

/// A library error as `ValueError`, prefixed with what was being done.
pub fn value_error(context: &str, e: &OctreeError) -> PyErr {
    PyValueError::new_err(format!("{context}: {e}"))
}

/// An I/O error as the matching `OSError` subclass, naming the file.
pub fn io_error(action: &str, path: &std::path::Path, e: &std::io::Error) -> PyErr {
    let msg = format!("cannot {action} {}: {e}", path.display());
    match e.kind() {
        std::io::ErrorKind::NotFound => PyFileNotFoundError::new_err(msg),
        std::io::ErrorKind::PermissionDenied => PyPermissionError::new_err(msg),
        _ => PyOSError::new_err(msg),
    }
}

/// The name of an array's dtype, for messages.
fn dtype_name(a: &Bound<'_, PyUntypedArray>) -> String {
    a.dtype()
        .str()
        .map(|s| s.to_string())
        .unwrap_or_else(|_| "?".into())
}

/// A float (N, 3) array: the two element types we read without a copy.
enum Cloud<'py> {
    F32(Bound<'py, PyArray2<f32>>),
    F64(Bound<'py, PyArray2<f64>>),
}

/// Check that `obj` is an (N, 3) float32 or float64 array (any order or strides); lists and
/// tuples are converted with `numpy.asarray(obj, dtype=float64)` first.
fn cloud<'py>(obj: &Bound<'py, PyAny>, name: &str) -> PyResult<Cloud<'py>> {
    let py = obj.py();
    let owned;
    let obj = if obj.cast::<PyUntypedArray>().is_ok() {
        obj
    } else if obj.cast::<PyString>().is_ok() || obj.cast::<PyBytes>().is_ok() {
        return Err(PyTypeError::new_err(format!(
            "{name} must be an (N, 3) float array, got {}",
            obj.get_type().name()?
        )));
    } else {
        let np = py.import("numpy")?;
        owned = np
            .call_method1("asarray", (obj, np.getattr("float64")?))
            .map_err(|e| {
                PyTypeError::new_err(format!(
                    "{name} must be an (N, 3) float array: {}",
                    e.value(py)
                ))
            })?;
        &owned
    };
    let a = obj.cast::<PyUntypedArray>()?;
    let shape = a.shape();
    if shape.len() != 2 || shape[1] != 3 {
        return Err(PyValueError::new_err(format!(
            "{name} must have shape (N, 3), got {shape:?}"
        )));
    }
    if let Ok(a) = obj.cast::<PyArray2<f64>>() {
        Ok(Cloud::F64(a.clone()))
    } else if let Ok(a) = obj.cast::<PyArray2<f32>>() {
        Ok(Cloud::F32(a.clone()))
    } else {
        Err(PyTypeError::new_err(format!(
            "{name} must be a float32 or float64 array, got dtype {} (use .astype(numpy.float64))",
            dtype_name(a)
        )))
    }
}

/// Rows of a 2-D array, contiguous or not, mapped through `f`.
fn rows<T: numpy::Element + Copy, O>(
    a: &Bound<'_, PyArray2<T>>,
    name: &str,
    f: impl Fn([T; 3]) -> O,
) -> PyResult<Vec<O>> {
    let ro = a
        .try_readonly()
        .map_err(|e| PyValueError::new_err(format!("{name}: {e}")))?;
    // as_slice also accepts Fortran order, whose memory is column by column
    if ro.is_c_contiguous() {
        if let Ok(s) = ro.as_slice() {
            return Ok(s.chunks_exact(3).map(|c| f([c[0], c[1], c[2]])).collect());
        }
    }
    let v = ro.as_array();
    Ok(v.rows()
        .into_iter()
        .map(|r| f([r[0], r[1], r[2]]))
        .collect())
}

/// An (N, 3) float array as `f32` points (OctoMap's `point3d`: float64 input is rounded).
pub fn points_f32(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<Point3<f32>>> {
    match cloud(obj, name)? {
        Cloud::F32(a) => rows(&a, name, |c| Point3::new(c[0], c[1], c[2])),
        Cloud::F64(a) => rows(&a, name, |c| {
            Point3::new(c[0] as f32, c[1] as f32, c[2] as f32)
        }),
    }
}

/// An (N, 3) float array as `f64` points (float32 input is widened exactly).
pub fn points_f64(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<Point3<f64>>> {
    match cloud(obj, name)? {
        Cloud::F32(a) => rows(&a, name, |c| {
            Point3::new(c[0] as f64, c[1] as f64, c[2] as f64)
        }),
        Cloud::F64(a) => rows(&a, name, |c| Point3::new(c[0], c[1], c[2])),
    }
}

/// One 3-vector: a NumPy array of 3 numbers (any real dtype) or a sequence of 3 numbers.
pub fn vec3(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Point3<f64>> {
    let py = obj.py();
    let values: Vec<f64> = if let Ok(a) = obj.cast::<PyUntypedArray>() {
        let kind = a.dtype().kind();
        if !matches!(kind, b'f' | b'i' | b'u') {
            return Err(PyTypeError::new_err(format!(
                "{name} must hold 3 real numbers, got dtype {}",
                dtype_name(a)
            )));
        }
        let as_f64 = obj.call_method1("astype", (py.import("numpy")?.getattr("float64")?,))?;
        let a = as_f64.cast::<PyArrayDyn<f64>>()?;
        let ro = a.readonly();
        ro.as_array().iter().copied().collect()
    } else if obj.cast::<PyString>().is_ok() || obj.cast::<PyBytes>().is_ok() {
        return Err(PyTypeError::new_err(format!(
            "{name} must be 3 numbers, got {}",
            obj.get_type().name()?
        )));
    } else {
        obj.extract::<Vec<f64>>().map_err(|_| {
            PyTypeError::new_err(format!(
                "{name} must be 3 numbers (a sequence or array), got {}",
                obj.get_type()
                    .name()
                    .map(|n| n.to_string())
                    .unwrap_or_default()
            ))
        })?
    };
    if values.len() != 3 {
        return Err(PyValueError::new_err(format!(
            "{name} must have 3 elements, got {}",
            values.len()
        )));
    }
    Ok(Point3::new(values[0], values[1], values[2]))
}

/// A 3-vector as OctoMap's `point3d` (`f32`).
pub fn vec3_f32(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Point3<f32>> {
    Ok(vec3(obj, name)?.cast::<f32>())
}

/// The arguments of an `insertPointCloud` (plain or stamped) checked and converted: the scan's
/// points and the sensor origin; a NaN `maxrange` is refused (negative means no limit).
pub fn scan_args(
    pointcloud: &Bound<'_, PyAny>,
    origin: &Bound<'_, PyAny>,
    maxrange: f64,
) -> PyResult<(Vec<Point3<f32>>, Point3<f32>)> {
    if maxrange.is_nan() {
        return Err(PyValueError::new_err("maxrange must not be NaN"));
    }
    Ok((
        points_f32(pointcloud, "pointcloud")?,
        vec3_f32(origin, "origin")?,
    ))
}

/// A float64 (3,) array.
pub fn array3<'py>(py: Python<'py>, v: [f64; 3]) -> Bound<'py, PyArray1<f64>> {
    PyArray1::from_slice(py, &v)
}

/// A float64 (N, 3) array from rows.
pub fn array_n3<'py>(py: Python<'py>, rows: Vec<[f64; 3]>) -> Bound<'py, PyArray2<f64>> {
    let n = rows.len();
    let flat: Vec<f64> = rows.into_iter().flatten().collect();
    let arr = Array2::from_shape_vec((n, 3), flat).unwrap_or_else(|_| Array2::zeros((0, 3)));
    PyArray2::from_owned_array(py, arr)
}

/// A tree depth argument: 0..=16.
pub fn depth(d: i64, name: &str) -> PyResult<u8> {
    if (0..=16).contains(&d) {
        Ok(d as u8)
    } else {
        Err(PyValueError::new_err(format!(
            "{name} must be between 0 and 16, got {d}"
        )))
    }
}

/// Where a tree comes from: serialized bytes or a file.
pub enum Source {
    /// `.bt`/`.ot` contents.
    Data(Vec<u8>),
    /// A path.
    Path(PathBuf),
}

impl Source {
    /// The bytes, read from the file if needed; errors name the file.
    pub fn bytes(self) -> PyResult<(Vec<u8>, String)> {
        match self {
            Source::Data(d) => Ok((d, "serialized tree".into())),
            Source::Path(p) => {
                let d = std::fs::read(&p).map_err(|e| io_error("read", &p, &e))?;
                Ok((d, p.display().to_string()))
            }
        }
    }
}

/// A path (str, bytes or os.PathLike) or, for bytes that start with an OctoMap header,
/// serialized tree data, as octomap-python tells them apart.
pub fn source(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Source> {
    if let Ok(b) = obj.cast::<PyBytes>() {
        let data = b.as_bytes();
        if data.starts_with(b"# Octomap OcTree") {
            return Ok(Source::Data(data.to_vec()));
        }
    }
    Ok(Source::Path(path(obj, name)?))
}

/// A file name: str, bytes or os.PathLike (decoded as `os.fsdecode` does).
pub fn path(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<PathBuf> {
    let py = obj.py();
    let decoded = py
        .import("os")?
        .call_method1("fsdecode", (obj,))
        .map_err(|_| {
            PyTypeError::new_err(format!(
                "{name} must be a str, bytes or os.PathLike, got {}",
                obj.get_type()
                    .name()
                    .map(|n| n.to_string())
                    .unwrap_or_default()
            ))
        })?;
    decoded.extract::<PathBuf>()
}

/// An (N, 3) float array as `f64` rows, and whether it was float32 (for results in the
/// caller's dtype). Lists of triples are read as float64.
pub fn rows_f64(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<(Vec<[f64; 3]>, bool)> {
    match cloud(obj, name)? {
        Cloud::F32(a) => Ok((rows(&a, name, |c| c.map(f64::from))?, true)),
        Cloud::F64(a) => Ok((rows(&a, name, |c| c)?, false)),
    }
}

/// Rows as an (N, 3) array of float32 (`f32_out`) or float64.
pub fn rows_array<'py>(py: Python<'py>, rows: &[[f64; 3]], f32_out: bool) -> Bound<'py, PyAny> {
    let n = rows.len();
    if f32_out {
        let flat: Vec<f32> = rows.iter().flatten().map(|&v| v as f32).collect();
        let arr = Array2::from_shape_vec((n, 3), flat).unwrap_or_else(|_| Array2::zeros((0, 3)));
        PyArray2::from_owned_array(py, arr).into_any()
    } else {
        array_n3(py, rows.to_vec()).into_any()
    }
}

/// A real array (any real dtype, or a sequence of numbers) of `ndim` dimensions, the last of
/// length `cols` when given, as float64 values in C order with its shape.
pub fn real_array(
    obj: &Bound<'_, PyAny>,
    name: &str,
    ndim: usize,
    cols: Option<usize>,
) -> PyResult<(Vec<f64>, Vec<usize>)> {
    let py = obj.py();
    if let Ok(a) = obj.cast::<PyUntypedArray>() {
        if !matches!(a.dtype().kind(), b'f' | b'i' | b'u') {
            return Err(PyTypeError::new_err(format!(
                "{name} must hold real numbers, got dtype {}",
                dtype_name(a)
            )));
        }
    } else if obj.cast::<PyString>().is_ok() || obj.cast::<PyBytes>().is_ok() {
        return Err(PyTypeError::new_err(format!(
            "{name} must be an array of numbers, got {}",
            obj.get_type().name()?
        )));
    }
    let np = py.import("numpy")?;
    let arr = np
        .call_method1("ascontiguousarray", (obj, np.getattr("float64")?))
        .map_err(|e| {
            PyTypeError::new_err(format!(
                "{name} must be an array of numbers: {}",
                e.value(py)
            ))
        })?;
    let a = arr.cast::<PyArrayDyn<f64>>()?;
    let shape = a.shape().to_vec();
    let bad_cols = cols.is_some_and(|c| shape.last() != Some(&c));
    if shape.len() != ndim || bad_cols {
        let want = match (ndim, cols) {
            (1, _) => "(N,)".to_string(),
            (_, Some(c)) => format!("(N, {c})"),
            _ => format!("{ndim} dimensions"),
        };
        return Err(PyValueError::new_err(format!(
            "{name} must have shape {want}, got {shape:?}"
        )));
    }
    let ro = a.readonly();
    let values = ro.as_array().iter().copied().collect();
    Ok((values, shape))
}

/// An (N, 3) ``uint8`` array as colours.
pub fn rgb_rows(obj: &Bound<'_, PyAny>) -> PyResult<Vec<Color>> {
    let err = || PyValueError::new_err("colors must be an (N, 3) uint8 array (r, g, b)");
    let a: PyReadonlyArray2<'_, u8> = obj.extract().map_err(|_| err())?;
    let a = a.as_array();
    if a.ncols() != 3 {
        return Err(err());
    }
    Ok(a.rows()
        .into_iter()
        .map(|r| Color::new(r[0], r[1], r[2]))
        .collect())
}

/// A child index argument: 0..8.
pub(crate) fn child_idx(i: i64) -> PyResult<usize> {
    if (0..8).contains(&i) {
        Ok(i as usize)
    } else {
        Err(pyo3::exceptions::PyIndexError::new_err(format!(
            "child index must be between 0 and 7, got {i}"
        )))
    }
}

/// A probability for a sensor-model setter: strictly between 0 and 1.
pub(crate) fn prob(p: f64, name: &str) -> PyResult<f32> {
    if p.is_finite() && p > 0.0 && p < 1.0 {
        Ok(logodds(p))
    } else {
        Err(PyValueError::new_err(format!(
            "{name} must lie strictly between 0 and 1, got {p}"
        )))
    }
}

/// The error for a node argument that is no longer in the tree at its depth.
pub(crate) fn not_in_tree(key: Key, d: u8) -> PyErr {
    PyValueError::new_err(format!(
        "the node (depth {d}, key ({}, {}, {})) is not in this tree (deleted, pruned, or from \
         another tree)",
        key[0], key[1], key[2]
    ))
}
