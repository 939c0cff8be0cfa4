//! `octoquant.ColorMapper`: coloured scans into a `ColorOcTree` as octomap_server's colour
//! server inserts them (the library's `color_map::ColorMapper`), for NumPy frames.

use crate::color_tree::PyColorOcTree;
use crate::convert;
use crate::engine::{self, ColorMapError, ColorMapper, ColorMerge, MapperOptions};
use crate::mapper::{origin_or_zero, read_frames, stats_dict, FilterArgs, Placement};
use nalgebra::Point3;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Builds a ``ColorOcTree`` from coloured scans, scan by scan, as octomap_server's colour
/// server (``octomap_color_server``) does: each end point's colour merges into the node that
/// holds its voxel before the scan's occupancy updates (so a voxel is coloured from its
/// second sighting on), then one miss per free voxel and one hit per end-point voxel, then
/// ``prune()``. The same bytes as ``octoquant map --color`` and as liboctomap's
/// ``ColorOcTree`` doing the same.
///
/// ``merge``: ``"average"`` (octomap_server's ``averageNodeColor``) or ``"integrate"``
/// (OctoMap's occupancy-weighted ``integrateNodeColor``). ``max_range``: octomap_server's
/// ``sensor_model/max_range``: a farther point colours nothing and only clears its ray, cut at
/// the range, and the voxel where it is cut. The sensor model is OctoMap's unless given.
/// The point filters of :class:`Mapper` (keyword-only: ``drop_zero``, ``min_range``,
/// ``crop_sensor``, ``crop_world``, ``zmin``, ``zmax``, ``ground`` ...) drop points with their
/// colours before the insertion (the sensor crop box in the world's axes, in the pose's when
/// inserted with ``pose``).
#[pyclass(module = "octoquant", name = "ColorMapper")]
pub struct PyColorMapper {
    /// Boxed: the tree inside is 64-byte aligned, more than Python's allocator guarantees.
    mapper: Box<ColorMapper>,
}

#[pymethods]
impl PyColorMapper {
    #[new]
    #[pyo3(signature = (
        resolution=0.1, merge="average", max_range=None, prob_hit=0.7, prob_miss=0.4,
        clamping_min=0.1192, clamping_max=0.971, occupancy_threshold=0.5, *, drop_zero=false,
        min_range=None, crop_sensor=None, crop_world=None, zmin=None, zmax=None, ground=None,
        ground_angle=0.15, ground_iterations=200, ground_seed=0, ground_clears=false
    ))]
    #[allow(clippy::too_many_arguments)]
    fn py_new(
        resolution: f64,
        merge: &str,
        max_range: Option<f64>,
        prob_hit: f64,
        prob_miss: f64,
        clamping_min: f64,
        clamping_max: f64,
        occupancy_threshold: f64,
        drop_zero: bool,
        min_range: Option<f64>,
        crop_sensor: Option<Vec<f64>>,
        crop_world: Option<Vec<f64>>,
        zmin: Option<f64>,
        zmax: Option<f64>,
        ground: Option<f64>,
        ground_angle: f64,
        ground_iterations: u32,
        ground_seed: u64,
        ground_clears: bool,
    ) -> PyResult<Self> {
        let filters = FilterArgs {
            drop_zero,
            min_range,
            crop_sensor,
            crop_world,
            zmin,
            zmax,
            ground,
            ground_angle,
            ground_iterations,
            ground_seed,
            ground_clears,
        }
        .filters()?;
        let merge = match merge {
            "average" => ColorMerge::Average,
            "integrate" => ColorMerge::Integrate,
            other => {
                return Err(PyValueError::new_err(format!(
                    "unknown merge {other:?}; expected average or integrate"
                )))
            }
        };
        if let Some(r) = max_range {
            if !(r.is_finite() && r > 0.0) {
                return Err(PyValueError::new_err(format!(
                    "max_range must be finite and > 0 (None: no limit), got {r}"
                )));
            }
        }
        let params = engine::OccupancyParams::from_probabilities(
            prob_hit,
            prob_miss,
            clamping_min,
            clamping_max,
            occupancy_threshold,
        )
        .map_err(|e| convert::value_error("ColorMapper", &e))?;
        let options = MapperOptions {
            resolution,
            params,
            max_range,
            filters,
            ..MapperOptions::default()
        };
        let mapper =
            ColorMapper::new(options, merge).map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(PyColorMapper {
            mapper: Box::new(mapper),
        })
    }

    /// Insert one coloured scan: ``points`` (N, 3), ``colors`` (N, 3) ``uint8`` RGB, one per
    /// point, and either ``origin`` (the sensor position, points in the world frame; default 0)
    /// or ``pose`` (points in the sensor frame; a 4x4 matrix or (translation, quaternion (x, y,
    /// z, w)), as :meth:`Mapper.insert` takes it: the same world points, and the
    /// ``crop_sensor`` box in the pose's axes). Returns the scan's statistics. Releases the GIL.
    #[pyo3(signature = (points, colors, origin=None, pose=None))]
    fn insert<'py>(
        &mut self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        colors: &Bound<'py, PyAny>,
        origin: Option<&Bound<'py, PyAny>>,
        pose: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let place = Placement::from_args(origin, pose)?;
        let frame = coloured_frame(points, colors, place.frame_origin())?;
        let mapper = &mut self.mapper;
        let st = py
            .detach(|| match place {
                Placement::Origin(_) => mapper.insert(&frame),
                Placement::Pose(iso) => mapper.insert_sensor_frame_f32(&frame, &iso),
            })
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        stats_dict(py, &st)
    }

    /// Insert coloured scans ``[(points, colors, origin), ...]`` in order (``origin`` may be
    /// None: 0): the same map as one :meth:`insert` per scan. Returns the statistics of each.
    /// Every scan is read and checked before any is inserted: a bad one raises, naming it
    /// (``frames[i]: ...``), and the map is unchanged. Releases the GIL while inserting.
    fn insert_frames<'py>(
        &mut self,
        py: Python<'py>,
        frames: &Bound<'py, PyAny>,
    ) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let list = read_frames(frames, |i, item| {
            let (pts, colors, origin): (
                Bound<'py, PyAny>,
                Bound<'py, PyAny>,
                Option<Bound<'py, PyAny>>,
            ) = item.extract()?;
            let frame = coloured_frame(&pts, &colors, origin_or_zero(origin.as_ref())?)?;
            self.mapper
                .check(&frame, i)
                .map_err(|e| PyValueError::new_err(e.to_string()))?;
            Ok(frame)
        })?;
        let mapper = &mut self.mapper;
        // checked above: no insertion fails; pipelined (a scan's rays are walked while the one
        // before goes into the tree)
        let stats = py
            .detach(|| {
                let mut out = Vec::with_capacity(list.len());
                mapper
                    .insert_stream(list.iter().map(Ok::<_, ColorMapError>), |_, st| {
                        out.push(*st);
                        Ok(())
                    })
                    .map(|()| out)
            })
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        stats.iter().map(|s| stats_dict(py, s)).collect()
    }

    /// A copy of the map so far.
    #[getter]
    fn tree(&self) -> PyColorOcTree {
        PyColorOcTree::wrap(self.mapper.tree().clone())
    }

    /// Scans inserted so far.
    #[getter]
    fn frames(&self) -> usize {
        self.mapper.frames()
    }

    fn __repr__(&self) -> String {
        format!(
            "ColorMapper(resolution={}, frames={})",
            self.mapper.tree().resolution(),
            self.mapper.frames()
        )
    }
}

/// A coloured frame from an ``insert``'s arguments: the points, one colour per point
/// (ValueError otherwise), the origin given.
pub(crate) fn coloured_frame(
    points: &Bound<'_, PyAny>,
    colors: &Bound<'_, PyAny>,
    origin: Point3<f32>,
) -> PyResult<engine::Frame> {
    let pts = convert::points_f32(points, "points")?;
    let colors = convert::rgb_rows(colors)?;
    if colors.len() != pts.len() {
        return Err(PyValueError::new_err(format!(
            "{} colours for {} points: give one per point",
            colors.len(),
            pts.len()
        )));
    }
    Ok(engine::Frame {
        colors: Some(colors),
        ..engine::Frame::new_f32(origin, pts)
    })
}
