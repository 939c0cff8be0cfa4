//! `octoquant.StampedMapper`: scans into an `OcTreeStamped`, each stamped with its own time,
//! optionally forgetting obstacles not seen for a while (the library's
//! `stamped_map::StampedMapper`, what `octoquant map --stamped` runs), for NumPy frames.

use crate::convert;
use crate::engine::{self, MapperOptions, StampedMapError, StampedMapper};
use crate::mapper::{self, origin_or_zero, read_frames, stats_dict, FilterArgs, Placement};
use crate::stamped_tree::{seconds, PyStampedOcTree};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Builds an ``OcTreeStamped`` scan by scan, as OctoMap's ``insertPointCloud`` puts a scan
/// into an ``OcTreeStamped``: one miss per free voxel, then one hit per end-point voxel,
/// eager, every voxel and inner node an update reaches stamped with the scan's time in whole
/// seconds. The same bytes as ``octoquant map --stamped`` (and liboctomap's ``OcTreeStamped``
/// with its clock at each scan's second) on the same scans with the same times.
///
/// ``degrade_older_than``: after each scan, every occupied leaf whose stamp is more than this
/// many seconds older than the scan gets one miss (OctoMap's ``degradeOutdatedNodes``; the
/// CLI's ``--degrade-older-than``). ``mode``: as :class:`Mapper`'s, but ``"simple"`` (which
/// has no per-scan voxel sets). ``max_range``: readings beyond only clear space. ``lazy``:
/// refused (ValueError): stamped maps are built with eager updates. The sensor model is
/// OctoMap's unless given. The point filters of :class:`Mapper` (keyword-only: ``drop_zero``,
/// ``min_range``, ``crop_sensor``, ``crop_world``, ``zmin``, ``zmax``, ``ground`` ...) drop
/// points before the insertion (the sensor crop box in the world's axes, in the pose's when
/// inserted with ``pose``).
#[pyclass(module = "octoquant", name = "StampedMapper")]
pub struct PyStampedMapper {
    /// Boxed: the tree inside is 64-byte aligned, more than Python's allocator guarantees.
    mapper: Box<StampedMapper>,
    degrade_older_than: Option<u32>,
}

#[pymethods]
impl PyStampedMapper {
    #[new]
    #[pyo3(signature = (
        resolution=0.1, degrade_older_than=None, mode="exact", max_range=None, lazy=false,
        prob_hit=0.7, prob_miss=0.4, clamping_min=0.1192, clamping_max=0.971,
        occupancy_threshold=0.5, *, drop_zero=false, min_range=None, crop_sensor=None,
        crop_world=None, zmin=None, zmax=None, ground=None, ground_angle=0.15,
        ground_iterations=200, ground_seed=0, ground_clears=false
    ))]
    #[allow(clippy::too_many_arguments)]
    fn py_new(
        resolution: f64,
        degrade_older_than: Option<i64>,
        mode: &str,
        max_range: Option<f64>,
        lazy: bool,
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
        let degrade_older_than = degrade_older_than
            .map(|s| seconds(s, "degrade_older_than"))
            .transpose()?;
        if let Some(r) = max_range {
            if r.is_nan() {
                return Err(PyValueError::new_err("max_range must not be NaN"));
            }
        }
        let params = engine::OccupancyParams::from_probabilities(
            prob_hit,
            prob_miss,
            clamping_min,
            clamping_max,
            occupancy_threshold,
        )
        .map_err(|e| convert::value_error("StampedMapper", &e))?;
        let options = MapperOptions {
            resolution,
            params,
            max_range,
            mode: mapper::mode(mode)?,
            lazy,
            filters,
            ..MapperOptions::default()
        };
        let mapper = StampedMapper::new(options, degrade_older_than)
            .map_err(|e| PyValueError::new_err(format!("StampedMapper: {e}")))?;
        Ok(PyStampedMapper {
            mapper: Box::new(mapper),
            degrade_older_than,
        })
    }

    /// Insert one scan: ``points`` (N, 3) (float32 or float64; NaN/inf points are skipped and
    /// counted), either ``origin`` (the sensor position, points in the world frame; default 0)
    /// or ``pose`` (points in the sensor frame; a 4x4 matrix or (translation, quaternion (x, y,
    /// z, w)), as :meth:`Mapper.insert` takes it: the same world points, and the
    /// ``crop_sensor`` box in the pose's axes), ``stamp`` the scan's time in seconds (a float,
    /// e.g. a ROS or TUM time stamp; stamped with its whole seconds, as the CLI stamps a frame;
    /// default: the system clock, as OctoMap's ``time(NULL)``). Returns the scan's statistics,
    /// with ``"stamp"``: the whole second used. A time OctoMap cannot store (negative, NaN,
    /// 2^32 s or later) raises ValueError and changes nothing. Releases the GIL.
    #[pyo3(signature = (points, origin=None, stamp=None, pose=None))]
    fn insert<'py>(
        &mut self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        origin: Option<&Bound<'py, PyAny>>,
        stamp: Option<f64>,
        pose: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let pts = convert::points_f32(points, "points")?;
        let place = Placement::from_args(origin, pose)?;
        let mut frame = engine::Frame {
            stamp,
            ..engine::Frame::new_f32(place.frame_origin(), pts)
        };
        let now = stamp_frame(&mut frame, self.mapper.frames()).map_err(stamp_error)?;
        let mapper = &mut self.mapper;
        let st = py
            .detach(|| match place {
                Placement::Origin(_) => mapper.insert(&frame),
                Placement::Pose(iso) => mapper.insert_sensor_frame_f32(&frame, &iso),
            })
            .map_err(stamp_error)?;
        let d = stats_dict(py, &st)?;
        d.set_item("stamp", now)?;
        Ok(d)
    }

    /// Insert scans ``[(points, origin, stamp), ...]`` in order (``origin`` may be None: 0;
    /// ``stamp`` None: the system clock when the scan is inserted, as :meth:`insert`): the same
    /// map as one :meth:`insert` per scan. Returns the statistics of each, with ``"stamp"``.
    /// Every scan is read and its time checked before any is inserted: a bad one raises,
    /// naming it (``frames[i]: ...``), and the map is unchanged. Releases the GIL while
    /// inserting.
    fn insert_frames<'py>(
        &mut self,
        py: Python<'py>,
        frames: &Bound<'py, PyAny>,
    ) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let list = read_frames(frames, |i, item| {
            let (pts, origin, stamp): (Bound<'py, PyAny>, Option<Bound<'py, PyAny>>, Option<f64>) =
                item.extract()?;
            let frame = engine::Frame {
                stamp,
                ..engine::Frame::new_f32(
                    origin_or_zero(origin.as_ref())?,
                    convert::points_f32(&pts, "points")?,
                )
            };
            if stamp.is_some() {
                // the clock is read when the scan goes in; a given time is checked now
                StampedMapper::frame_time(&frame, i).map_err(stamp_error)?;
            }
            Ok(frame)
        })?;
        let mapper = &mut self.mapper;
        // checked above: no insertion fails; pipelined (a frame's rays are cast while the one
        // before goes into the tree)
        let stats = py
            .detach(|| {
                let mut out = Vec::with_capacity(list.len());
                mapper
                    .insert_stream(
                        list.iter().map(Ok::<&engine::Frame, StampedMapError>),
                        |_, st, now| {
                            out.push((*st, now));
                            Ok(())
                        },
                    )
                    .map(|()| out)
            })
            .map_err(stamp_error)?;
        stats
            .iter()
            .map(|(st, now)| {
                let d = stats_dict(py, st)?;
                d.set_item("stamp", now)?;
                Ok(d)
            })
            .collect()
    }

    /// A copy of the map so far (an ``OcTreeStamped``, stamps included).
    #[getter]
    fn tree(&self) -> PyStampedOcTree {
        PyStampedOcTree::wrap(self.mapper.tree().clone())
    }

    /// Scans inserted so far.
    #[getter]
    fn frames(&self) -> usize {
        self.mapper.frames()
    }

    /// Leaf size in metres.
    #[getter]
    fn resolution(&self) -> f64 {
        self.mapper.tree().resolution()
    }

    /// The degrade threshold in seconds, None when stale obstacles are kept.
    #[getter]
    fn degrade_older_than(&self) -> Option<u32> {
        self.degrade_older_than
    }

    fn __repr__(&self) -> String {
        format!(
            "StampedMapper(resolution={}, degrade_older_than={}, frames={})",
            self.mapper.tree().resolution(),
            self.degrade_older_than
                .map_or_else(|| "None".to_string(), |s| s.to_string()),
            self.mapper.frames()
        )
    }
}

/// The second `frame` is stamped with ([`StampedMapper::frame_time`], the clock read once
/// when it has no stamp), written into it as its stamp so that the insertion uses the second
/// returned (the statistics tell the time the scan was stamped with).
fn stamp_frame(frame: &mut engine::Frame, index: usize) -> Result<u32, StampedMapError> {
    let now = StampedMapper::frame_time(frame, index)?;
    frame.stamp = Some(frame.stamp.unwrap_or(f64::from(now)));
    Ok(now)
}

/// A stamped insertion's refusal as a Python exception.
fn stamp_error(e: StampedMapError) -> PyErr {
    PyValueError::new_err(e.to_string())
}
