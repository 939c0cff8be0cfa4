//! `octoquant.reduce`, `octoquant.DensityReducer` and its `OutputCycle`: the online grid
//! density reducer (the octoquant-density crate) from NumPy.

use crate::convert::{real_array, rows_array, rows_f64};
use crate::engine::{
    CentreDistance, CycleCounts, DensityError, DensityGrid, GridSpec, OutputCycle, Selection,
};
use numpy::PyArray1;
use pyo3::exceptions::{PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::collections::HashMap;

/// A per-axis argument: one number for all three axes, or three.
fn per_axis(obj: Option<&Bound<'_, PyAny>>, name: &str, default: f64) -> PyResult<[f64; 3]> {
    let Some(obj) = obj else {
        return Ok([default; 3]);
    };
    if let Ok(v) = obj.extract::<f64>() {
        return Ok([v; 3]);
    }
    let (v, _) = real_array(obj, name, 1, None)
        .map_err(|_| PyTypeError::new_err(format!("{name} must be a number or 3 numbers")))?;
    match v[..] {
        [x, y, z] => Ok([x, y, z]),
        _ => Err(PyValueError::new_err(format!(
            "{name} must be a number or 3 numbers (x, y, z), got {}",
            v.len()
        ))),
    }
}

fn grid_error(e: DensityError) -> PyErr {
    match e {
        DensityError::StaleCycle { .. } => PyRuntimeError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}

/// The grid geometry from Python's `cell`, `offset` and `distance`.
fn spec(
    cell: &Bound<'_, PyAny>,
    offset: Option<&Bound<'_, PyAny>>,
    distance: &str,
) -> PyResult<GridSpec<3>> {
    let size = per_axis(Some(cell), "cell", 0.0)?;
    let offset = per_axis(offset, "offset", 0.0)?;
    let metric = match distance {
        "euclidean" => CentreDistance::Euclidean,
        "cell_units" => CentreDistance::CellUnits,
        _ => {
            return Err(PyValueError::new_err(format!(
                "distance must be \"euclidean\" or \"cell_units\", got {distance:?}"
            )))
        }
    };
    Ok(GridSpec::new(size, offset)
        .map_err(grid_error)?
        .with_centre_distance(metric))
}

/// A selection rule by name.
fn selection(name: &str) -> PyResult<Selection<3>> {
    match name {
        "centre" | "center" => Ok(Selection::CentreClosest),
        "mean" => Ok(Selection::MeanClosest),
        _ => Err(PyValueError::new_err(format!(
            "selection must be \"centre\" or \"mean\", got {name:?}"
        ))),
    }
}

fn selection_name(s: &Selection<3>) -> &'static str {
    match s {
        Selection::MeanClosest => "mean",
        _ => "centre",
    }
}

fn cycle_dict<'py>(py: Python<'py>, c: CycleCounts) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("emitted", c.emitted)?;
    d.set_item("eliminated", c.eliminated)?;
    d.set_item("deferred", c.deferred)?;
    Ok(d)
}

/// Bit pattern of a point, for finding it again among the inputs.
fn bits(p: &[f64; 3]) -> [u64; 3] {
    p.map(f64::to_bits)
}

/// Reduce a point cloud with the online grid density reducer (one read cycle).
///
/// ``points``: (N, 3) float32 or float64. ``cell``: the cell size, one number or three (x, y,
/// z); ``offset``: where cell 0 starts, one number or three (default 0). Each point goes to cell
/// ``floor((p - offset) / cell)``; each cell keeps one of its points (``selection="centre"``:
/// the one closest to the cell centre, ``"mean"``: the one closest to the mean of the cell's
/// points); the cells are then read in ascending distance of their point to the centre, and a
/// point closer than half a cell on every axis to one already emitted is eliminated.
/// ``distance``: how the distance to the centre is measured, ``"euclidean"`` (in the points'
/// units, the paper's criterion; the default) or ``"cell_units"`` (each axis divided by its
/// cell size; differs only when the cell sizes differ).
///
/// Returns the kept points, a subset of the input in output order, in the input's dtype; with
/// ``return_index=True`` also their row numbers in ``points`` (int64; the first row for
/// duplicated points). NaN and infinite points are skipped (as the Rust library does), never an
/// error. The result does not depend on the input order. Releases the GIL.
#[pyfunction]
#[pyo3(signature = (points, cell, *, offset=None, selection="centre", distance="euclidean", return_index=false))]
#[allow(clippy::too_many_arguments)]
pub fn reduce<'py>(
    py: Python<'py>,
    points: &Bound<'py, PyAny>,
    cell: &Bound<'py, PyAny>,
    offset: Option<&Bound<'py, PyAny>>,
    selection: &str,
    distance: &str,
    return_index: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let spec = spec(cell, offset, distance)?;
    let sel = self::selection(selection)?;
    let (rows, is_f32) = rows_f64(points, "points")?;
    let (out, index) = py.detach(|| {
        let mut grid = DensityGrid::with_selection(spec, sel);
        grid.extend_rewalk(rows.iter().copied());
        let (out, _) = grid.output_cycle();
        let index = return_index.then(|| {
            let mut first: HashMap<[u64; 3], i64> = HashMap::with_capacity(rows.len());
            for (i, p) in rows.iter().enumerate() {
                first.entry(bits(p)).or_insert(i as i64);
            }
            out.iter()
                .map(|p| first.get(&bits(p)).copied().unwrap_or(-1))
                .collect::<Vec<i64>>()
        });
        (out, index)
    });
    let arr = rows_array(py, &out, is_f32);
    match index {
        None => Ok(arr),
        Some(ix) => Ok((arr, PyArray1::from_vec(py, ix))
            .into_pyobject(py)?
            .into_any()),
    }
}

/// The online grid density reducer: insert and remove points at any time, read the reduced
/// cloud in output cycles (the octoquant-density crate's ``DensityGrid``).
///
/// ``DensityReducer(cell, offset=None, selection="centre", distance="euclidean")``: see
/// :func:`reduce` for the arguments. ``len(r)`` is the number of non-empty cells (the points after the grid stage).
/// Points are stored as float64 (float32 input is widened exactly); NaN, infinite and
/// out-of-range points are skipped and counted as rejected. Calls release the GIL but hold the
/// reducer: a call from another thread meanwhile raises ``RuntimeError`` (already borrowed), so
/// interleave input and output from one thread with ``begin_cycle()`` and ``step``.
#[pyclass(module = "octoquant", name = "DensityReducer")]
pub struct PyDensityReducer {
    grid: DensityGrid<3>,
}

#[pymethods]
impl PyDensityReducer {
    #[new]
    #[pyo3(signature = (cell, *, offset=None, selection="centre", distance="euclidean"))]
    fn py_new(
        cell: &Bound<'_, PyAny>,
        offset: Option<&Bound<'_, PyAny>>,
        selection: &str,
        distance: &str,
    ) -> PyResult<Self> {
        Ok(PyDensityReducer {
            grid: DensityGrid::with_selection(
                spec(cell, offset, distance)?,
                self::selection(selection)?,
            ),
        })
    }

    /// Input stage: add an (N, 3) float32/float64 batch. Returns how many points were
    /// rejected (NaN, infinite, outside the index range). Same state as inserting one by one.
    /// Releases the GIL.
    fn insert(&mut self, py: Python<'_>, points: &Bound<'_, PyAny>) -> PyResult<u64> {
        let (rows, _) = rows_f64(points, "points")?;
        let grid = &mut self.grid;
        Ok(py.detach(|| grid.extend_rewalk(rows.iter().copied())))
    }

    /// Input stage: delete points equal (bit for bit, as float64) to stored ones, one stored
    /// copy per row, repairing only their cells. Returns a bool per row: whether it was found.
    fn remove<'py>(
        &mut self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let (rows, _) = rows_f64(points, "points")?;
        let grid = &mut self.grid;
        let found: Vec<bool> = py.detach(|| rows.iter().map(|p| grid.remove(p)).collect());
        Ok(PyArray1::from_vec(py, found))
    }

    /// Output stage: one complete read cycle; the reduced points (float64 (M, 3)) in output
    /// order. Releases the GIL.
    fn output<'py>(&mut self, py: Python<'py>) -> Bound<'py, PyAny> {
        let grid = &mut self.grid;
        let (out, _) = py.detach(|| grid.output_cycle());
        rows_array(py, &out, false)
    }

    /// Output stage in steps: begin a read cycle (see :class:`OutputCycle`). Cells created or
    /// changed from now on wait for the next cycle; beginning a cycle makes older ones stale.
    fn begin_cycle(slf: Bound<'_, Self>) -> PyResult<PyOutputCycle> {
        let cycle = slf.try_borrow_mut()?.grid.begin_cycle();
        Ok(PyOutputCycle {
            reducer: slf.unbind(),
            cycle,
        })
    }

    /// The point each cell keeps (float64 (len(self), 3)), in cell index order.
    fn selected_points<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        rows_array(py, &self.grid.selected_points(), false)
    }

    /// Number of points stored (all members of all cells).
    #[getter]
    fn point_count(&self) -> u64 {
        self.grid.point_count()
    }

    /// ``{"inserted", "rejected", "removed"}``: points accepted, skipped and deleted so far.
    fn counts<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let c = self.grid.counts();
        let d = PyDict::new(py);
        d.set_item("inserted", c.inserted)?;
        d.set_item("rejected", c.rejected)?;
        d.set_item("removed", c.removed)?;
        Ok(d)
    }

    /// Cell size per axis (x, y, z).
    #[getter]
    fn cell(&self) -> (f64, f64, f64) {
        let s = self.grid.spec().size();
        (s[0], s[1], s[2])
    }

    /// Grid offset per axis (x, y, z).
    #[getter]
    fn offset(&self) -> (f64, f64, f64) {
        let s = self.grid.spec().offset();
        (s[0], s[1], s[2])
    }

    /// The selection rule, ``"centre"`` or ``"mean"``.
    #[getter]
    fn selection(&self) -> &'static str {
        selection_name(self.grid.selection())
    }

    /// How distances to a cell's centre are measured, ``"euclidean"`` or ``"cell_units"``.
    #[getter]
    fn distance(&self) -> &'static str {
        match self.grid.spec().centre_distance_metric() {
            CentreDistance::Euclidean => "euclidean",
            CentreDistance::CellUnits => "cell_units",
        }
    }

    /// Check the store's invariants; raises ``RuntimeError`` naming the broken one (a bug).
    fn validate(&self) -> PyResult<()> {
        self.grid
            .validate()
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))
    }

    fn __len__(&self) -> usize {
        self.grid.len()
    }

    fn __repr__(&self) -> String {
        let c = self.grid.spec().size();
        format!(
            "DensityReducer(cell=({}, {}, {}), selection={:?}, cells={}, points={})",
            c[0],
            c[1],
            c[2],
            self.selection(),
            self.grid.len(),
            self.grid.point_count()
        )
    }
}

/// One read cycle of a :class:`DensityReducer`, from ``begin_cycle()``: call ``step`` until it
/// reports the cycle finished; insertions and removals may happen between steps (cells they
/// touch are left to the next cycle). Only the newest cycle of a reducer may be stepped.
#[pyclass(module = "octoquant", name = "OutputCycle")]
pub struct PyOutputCycle {
    reducer: Py<PyDensityReducer>,
    cycle: OutputCycle<3>,
}

#[pymethods]
impl PyOutputCycle {
    /// Visit up to ``max_cells`` more cells (all when None) in ascending distance. Returns
    /// ``(points, finished)``: the points emitted by this step (float64 (K, 3)) and whether the
    /// cycle is done. ``RuntimeError`` when a newer cycle has begun on the reducer.
    #[pyo3(signature = (max_cells=None))]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        max_cells: Option<usize>,
    ) -> PyResult<(Bound<'py, PyAny>, bool)> {
        let mut reducer = self.reducer.bind(py).try_borrow_mut()?;
        let grid = &mut reducer.grid;
        let cycle = &mut self.cycle;
        let (out, finished) = py
            .detach(|| {
                let mut out = Vec::new();
                let r = grid.step_cycle(cycle, max_cells.unwrap_or(usize::MAX), &mut out);
                r.map(|f| (out, f))
            })
            .map_err(grid_error)?;
        Ok((rows_array(py, &out, false), finished))
    }

    /// The cycle's id (1 for a reducer's first cycle).
    #[getter]
    fn id(&self) -> u64 {
        self.cycle.id()
    }

    /// Whether every cell has been visited.
    #[getter]
    fn finished(&self) -> bool {
        self.cycle.is_finished()
    }

    /// ``{"emitted", "eliminated", "deferred"}`` so far in this cycle.
    fn counts<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        cycle_dict(py, self.cycle.counts())
    }

    fn __repr__(&self) -> String {
        let c = self.cycle.counts();
        format!(
            "OutputCycle(id={}, finished={}, emitted={}, eliminated={}, deferred={})",
            self.cycle.id(),
            if self.cycle.is_finished() {
                "True"
            } else {
                "False"
            },
            c.emitted,
            c.eliminated,
            c.deferred
        )
    }
}
