//! `octoquant.Mapper`: the library's mapping pipeline (insertion modes, maximum range,
//! threads, density reduction) for NumPy frames.

use crate::convert::{self, vec3, vec3_f32};
use crate::engine::{self, FrameStats, InsertMode, Mapper, MapperOptions};
use crate::tree::PyOcTree;
use nalgebra::{Isometry3, Matrix3, Point3, Quaternion, Rotation3, Translation3, UnitQuaternion};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Builds a map from frames with octoquant's pipeline.
///
/// ``mode``: ``"exact"`` (OctoMap's ``insertPointCloud``), ``"discretize"`` (its
/// ``discretize=True``), ``"quantized"`` (the same map as discretize, faster),
/// ``"quantized+bresenham"`` (fastest, not OctoMap-identical) or ``"simple"`` (per-point rays
/// without deduplication). ``max_range``: readings beyond only clear space. ``threads``: worker
/// threads for ray casting (None: all cores). ``lazy``: skip inner-node upkeep until ``tree``
/// is read. ``reduce``: thin each frame with the density reducer first (cell edge in metres,
/// one number or three). The sensor model is OctoMap's unless given.
///
/// Point filters (keyword-only; none by default, which keeps the map OctoMap's; see the
/// library's ``filters`` module): ``drop_zero`` (points exactly at the sensor origin),
/// ``min_range`` (metres), ``crop_sensor`` (drop points inside this box around the sensor:
/// ``(xmin, ymin, zmin, xmax, ymax, zmax)``, in the pose's axes when inserted with ``pose``,
/// the world's otherwise), ``crop_world`` (keep only points inside this world box), ``zmin`` /
/// ``zmax`` (world height band), ``ground`` (drop the RANSAC ground plane's points within this
/// distance; ``ground_angle``, ``ground_iterations``, ``ground_seed``; ``ground_clears=True``
/// inserts them as octomap_server does, as free space: their rays clear, their end voxels
/// are left alone). The statistics count
/// ``zero`` points and the points each filter ``dropped``.
#[pyclass(module = "octoquant", name = "Mapper")]
pub struct PyMapper {
    /// Boxed: the tree inside is 64-byte aligned, more than Python's allocator guarantees.
    mapper: Box<Mapper>,
    pool: Option<rayon::ThreadPool>,
}

/// The insertion mode named `name` (ValueError listing the names otherwise).
pub(crate) fn mode(name: &str) -> PyResult<InsertMode> {
    engine::INSERT_MODES
        .into_iter()
        .find(|m| m.name() == name)
        .ok_or_else(|| {
            let names: Vec<&str> = engine::INSERT_MODES.iter().map(|m| m.name()).collect();
            PyValueError::new_err(format!(
                "unknown mode {name:?}; expected one of {}",
                names.join(", ")
            ))
        })
}

pub(crate) fn stats_dict<'py>(py: Python<'py>, s: &FrameStats) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("points", s.points)?;
    d.set_item("non_finite", s.non_finite)?;
    d.set_item("outside_map", s.outside_map)?;
    d.set_item("zero", s.zero)?;
    let dropped = PyDict::new(py);
    for (name, n) in s.dropped.named() {
        dropped.set_item(name, n)?;
    }
    d.set_item("dropped", dropped)?;
    d.set_item("ground_clearing", s.clearing)?;
    d.set_item("reduced", s.reduced)?;
    d.set_item("rays", s.rays)?;
    d.set_item("free", s.free)?;
    d.set_item("occupied", s.occupied)?;
    d.set_item("seconds", s.seconds)?;
    Ok(d)
}

/// A pose: a 4x4 homogeneous matrix, or (translation (3,), quaternion (x, y, z, w)).
/// Shared by the ``pose=`` of every mapper's ``insert``.
pub(crate) fn pose(obj: &Bound<'_, PyAny>) -> PyResult<Isometry3<f64>> {
    if let Ok((t, q)) = obj.extract::<(Bound<'_, PyAny>, Bound<'_, PyAny>)>() {
        let t = vec3(&t, "pose translation")?;
        let q: Vec<f64> = q
            .extract()
            .map_err(|_| PyValueError::new_err("pose quaternion must be 4 numbers (x, y, z, w)"))?;
        let [x, y, z, w] = q[..] else {
            return Err(PyValueError::new_err(
                "pose quaternion must be 4 numbers (x, y, z, w)",
            ));
        };
        let q = Quaternion::new(w, x, y, z);
        if !(q.norm() > 0.0 && q.norm().is_finite()) {
            return Err(PyValueError::new_err(
                "pose quaternion must be finite and non-zero",
            ));
        }
        return Ok(Isometry3::from_parts(
            Translation3::from(t.coords),
            UnitQuaternion::from_quaternion(q),
        ));
    }
    let m: Vec<Vec<f64>> = obj.extract().or_else(|_| {
        obj.call_method0("tolist")
            .and_then(|l| l.extract())
            .map_err(|_| {
                PyValueError::new_err("pose must be a 4x4 matrix or (translation, quaternion)")
            })
    })?;
    if m.len() != 4 || m.iter().any(|r| r.len() != 4) || m.iter().flatten().any(|v| !v.is_finite())
    {
        return Err(PyValueError::new_err("pose must be a finite 4x4 matrix"));
    }
    let r = Matrix3::from_fn(|i, j| m[i][j]);
    let rot = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix(&r));
    Ok(Isometry3::from_parts(
        Translation3::new(m[0][3], m[1][3], m[2][3]),
        rot,
    ))
}

/// Where an ``insert``'s points are given: in the world, seen from a sensor position, or in
/// the sensor's own frame, with the sensor's pose. The ``origin=`` / ``pose=`` pair of every
/// mapper's ``insert``, read in one place so that they all take and refuse the same things.
pub(crate) enum Placement {
    /// Points in the world frame; the sensor position (default 0).
    Origin(Point3<f32>),
    /// Points in the sensor frame; the sensor pose (sensor to world).
    Pose(Isometry3<f64>),
}

impl Placement {
    /// The ``origin`` and ``pose`` keywords, at most one of them given (ValueError otherwise,
    /// and for an invalid origin or pose).
    pub(crate) fn from_args(
        origin: Option<&Bound<'_, PyAny>>,
        pose: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        match (origin, pose) {
            (Some(_), Some(_)) => Err(PyValueError::new_err("give origin or pose, not both")),
            (None, Some(p)) => Ok(Placement::Pose(self::pose(p)?)),
            (o, None) => Ok(Placement::Origin(origin_or_zero(o)?)),
        }
    }

    /// The origin to build the frame with: the sensor position, or 0 for sensor-frame points
    /// (whose origin the pose's translation replaces when they are inserted).
    pub(crate) fn frame_origin(&self) -> Point3<f32> {
        match self {
            Placement::Origin(o) => *o,
            Placement::Pose(_) => Point3::origin(),
        }
    }
}

/// An ``origin`` argument: 3 numbers, or None for the world's origin.
pub(crate) fn origin_or_zero(origin: Option<&Bound<'_, PyAny>>) -> PyResult<Point3<f32>> {
    origin.map_or_else(|| Ok(Point3::origin()), |o| vec3_f32(o, "origin"))
}

/// The frames of an ``insert_frames`` call, each read by `read` (given its position in the
/// list), all read before any is inserted: an error names the frame (``frames[i]: ...``, the
/// exception type kept, the original as its cause) and leaves the map as it was. A library
/// check that names the frame itself is given the list position `i` as the frame's number,
/// and its ``frame i`` becomes ``frames[i]``, so the frame is named once.
pub(crate) fn read_frames<'py, T>(
    frames: &Bound<'py, PyAny>,
    mut read: impl FnMut(usize, Bound<'py, PyAny>) -> PyResult<T>,
) -> PyResult<Vec<T>> {
    let py = frames.py();
    let mut out = Vec::new();
    for (i, item) in frames.try_iter()?.enumerate() {
        let frame = item.and_then(|item| read(i, item)).map_err(|e| {
            let message = e.value(py).to_string();
            let own = format!("frame {i}");
            let named = match message.strip_prefix(&own) {
                Some(rest) if rest.starts_with([':', ' ']) => format!("frames[{i}]{rest}"),
                _ => format!("frames[{i}]: {message}"),
            };
            let named = PyErr::from_type(e.get_type(py), named);
            named.set_cause(py, Some(e));
            named
        })?;
        out.push(frame);
    }
    Ok(out)
}

impl PyMapper {
    fn run<T: Send>(&mut self, py: Python<'_>, f: impl FnOnce(&mut Mapper) -> T + Send) -> T {
        let PyMapper { mapper, pool } = self;
        py.detach(|| match pool {
            Some(p) => p.install(|| f(mapper)),
            None => f(mapper),
        })
    }
}

/// The point-filter keywords of ``Mapper`` and ``ColorMapper``, as given.
pub(crate) struct FilterArgs {
    pub drop_zero: bool,
    pub min_range: Option<f64>,
    pub crop_sensor: Option<Vec<f64>>,
    pub crop_world: Option<Vec<f64>>,
    pub zmin: Option<f64>,
    pub zmax: Option<f64>,
    pub ground: Option<f64>,
    pub ground_angle: f64,
    pub ground_iterations: u32,
    pub ground_seed: u64,
    pub ground_clears: bool,
}

impl FilterArgs {
    /// The library's filters, checked (ValueError naming the keyword otherwise).
    pub(crate) fn filters(self) -> PyResult<engine::PointFilters> {
        let filter_err = |e: engine::FilterError| PyValueError::new_err(e.to_string());
        let crop = |name: &str, v: Option<Vec<f64>>| {
            v.map(|v| engine::CropBox::from_slice(name, &v))
                .transpose()
                .map_err(filter_err)
        };
        let filters = engine::PointFilters {
            drop_zero: self.drop_zero,
            min_range: self.min_range,
            crop_sensor: crop("crop_sensor", self.crop_sensor)?,
            crop_world: crop("crop_world", self.crop_world)?,
            z_min: self.zmin,
            z_max: self.zmax,
            ground: self.ground.map(|distance| engine::GroundFilter {
                distance,
                angle: self.ground_angle,
                iterations: self.ground_iterations,
                seed: self.ground_seed,
                clear: self.ground_clears,
            }),
        };
        filters.validate().map_err(filter_err)?;
        Ok(filters)
    }
}

#[pymethods]
impl PyMapper {
    #[new]
    #[pyo3(signature = (
        resolution=0.1, mode="exact", max_range=None, threads=None, lazy=false, reduce=None,
        prob_hit=0.7, prob_miss=0.4, clamping_min=0.1192, clamping_max=0.971,
        occupancy_threshold=0.5, *, drop_zero=false, min_range=None, crop_sensor=None,
        crop_world=None, zmin=None, zmax=None, ground=None, ground_angle=0.15,
        ground_iterations=200, ground_seed=0, ground_clears=false
    ))]
    #[allow(clippy::too_many_arguments)]
    fn py_new(
        resolution: f64,
        mode: &str,
        max_range: Option<f64>,
        threads: Option<usize>,
        lazy: bool,
        reduce: Option<&Bound<'_, PyAny>>,
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
        let params = engine::OccupancyParams::from_probabilities(
            prob_hit,
            prob_miss,
            clamping_min,
            clamping_max,
            occupancy_threshold,
        )
        .map_err(|e| convert::value_error("Mapper", &e))?;
        if let Some(r) = max_range {
            if r.is_nan() {
                return Err(PyValueError::new_err("max_range must not be NaN"));
            }
        }
        let reduce = match reduce {
            None => None,
            Some(r) => {
                let cell = match r.extract::<f64>() {
                    Ok(c) => [c; 3],
                    Err(_) => vec3(r, "reduce")?.into(),
                };
                if cell.iter().any(|c| !(c.is_finite() && *c > 0.0)) {
                    return Err(PyValueError::new_err(format!(
                        "reduce cell sizes must be finite and > 0, got {cell:?}"
                    )));
                }
                Some(cell)
            }
        };
        let pool = match threads {
            None => None,
            Some(0) => return Err(PyValueError::new_err("threads must be at least 1")),
            Some(n) => Some(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(n)
                    .build()
                    .map_err(|e| PyValueError::new_err(format!("threads: {e}")))?,
            ),
        };
        let options = MapperOptions {
            resolution,
            params,
            max_range,
            mode: self::mode(mode)?,
            lazy,
            reduce,
            filters,
            ..MapperOptions::default()
        };
        // Python has no checkpoints: no frame needs its fingerprint
        let mapper = Mapper::new(options)
            .map_err(|e| convert::value_error("Mapper", &e))?
            .without_checkpoints();
        Ok(PyMapper {
            mapper: Box::new(mapper),
            pool,
        })
    }

    /// Insert one frame: ``points`` (N, 3); either ``origin`` (the sensor position, points in
    /// the world frame; default 0) or ``pose`` (points in the sensor frame; a 4x4 matrix or
    /// (translation, quaternion (x, y, z, w))). Returns the frame's statistics. Releases the
    /// GIL.
    #[pyo3(signature = (points, origin=None, pose=None))]
    fn insert<'py>(
        &mut self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        origin: Option<&Bound<'py, PyAny>>,
        pose: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let pts = convert::points_f32(points, "points")?;
        let st = match Placement::from_args(origin, pose)? {
            Placement::Pose(iso) => self.run(py, move |m| m.insert_sensor_frame_f32(&pts, &iso)),
            Placement::Origin(origin) => {
                let frame = engine::Frame::new_f32(origin, pts);
                self.run(py, move |m| m.insert(&frame))
            }
        };
        stats_dict(py, &st)
    }

    /// Insert frames ``[(points, origin), ...]`` in order, pipelined over the threads (the
    /// next frame's rays are cast while this one updates the tree, small frames two at a
    /// time; same map as one ``insert`` per frame). Returns the statistics of each. Every
    /// frame is read before any is inserted: a bad one raises, naming it (``frames[i]:
    /// ...``), and the map is unchanged.
    fn insert_frames<'py>(
        &mut self,
        py: Python<'py>,
        frames: &Bound<'py, PyAny>,
    ) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let list = read_frames(frames, |_, item| {
            let (pts, origin): (Bound<'py, PyAny>, Bound<'py, PyAny>) = item.extract()?;
            Ok(engine::Frame::new_f32(
                vec3_f32(&origin, "origin")?,
                convert::points_f32(&pts, "points")?,
            ))
        })?;
        let stats = self.run(py, move |m| m.insert_frames(&list));
        stats.iter().map(|s| stats_dict(py, s)).collect()
    }

    /// A copy of the map so far (inner nodes brought up to date first in lazy mode).
    #[getter]
    fn tree(&mut self, py: Python<'_>) -> PyOcTree {
        let t = self.run(py, |m| {
            m.finish();
            m.tree().clone()
        });
        PyOcTree::wrap(t)
    }

    /// The mode's name.
    #[getter]
    fn mode(&self) -> &'static str {
        self.mapper.options().mode.name()
    }

    /// Leaf size in metres.
    #[getter]
    fn resolution(&self) -> f64 {
        self.mapper.options().resolution
    }

    /// Totals over every frame inserted so far.
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = self.mapper.stats();
        let d = stats_dict(py, &s.total)?;
        d.set_item("frames", s.frames)?;
        Ok(d)
    }

    fn __repr__(&self) -> String {
        let o = self.mapper.options();
        format!(
            "octoquant.Mapper(resolution={}, mode={:?}, hit log-odds={})",
            o.resolution,
            o.mode.name(),
            o.params.hit
        )
    }
}
