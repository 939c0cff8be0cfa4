//! `octoquant.OcTree`: octomap-python's `OcTree` (same names, signatures and results) plus
//! vectorised extras, over the Rust library's tree.

use crate::bbx::{self, Bbx};
use crate::cloud;
use crate::convert::{self, array_n3, child_idx, depth, path, source, vec3, vec3_f32};
use crate::engine::{
    self, InnerNodes, Key, KeyConverter, OcTree, OccupancyParams, Update, TREE_DEPTH,
};
use crate::iter::{
    max_depth, node_value, IteratorBase, LeafBbxIterator, LeafIterator, TreeIterator,
};
use crate::node::{key_arg, PyKey, PyNode};
use crate::occupancy_api::{live_node, occupancy_api, surgery_api, OccupancyHost};
use nalgebra::Point3;
use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::exceptions::{PyMemoryError, PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyBytes, PyDict, PyTuple};
use rayon::prelude::*;

/// OctoMap's probabilistic occupancy octree, built by octoquant.
///
/// ``OcTree(resolution)`` makes an empty tree with leaves of that edge length (metres);
/// ``OcTree(filename)`` reads a ``.bt`` or ``.ot`` file (str, bytes or os.PathLike).
/// Method names, signatures and results follow octomap-python, so porting a script is changing
/// the import; ``.bt``/``.ot`` bytes are identical to OctoMap's for the same calls.
#[pyclass(module = "octoquant", name = "OcTree")]
pub struct PyOcTree {
    /// Boxed: the tree's blocks are cache-line aligned (64 bytes), more than Python's
    /// allocator guarantees for the object that holds it.
    pub tree: Box<OcTree>,
    pub bbx: Bbx,
    /// The distance map of `dynamicEDT_generate`, if any.
    pub edt: Option<Box<engine::DistanceMap>>,
}

/// `cast_rays`' result: hit flags and end points.
pub type CastArrays<'py> = (Bound<'py, PyArray1<bool>>, Bound<'py, PyArray2<f64>>);

/// `extractPointCloud`'s result: occupied and free voxel centres.
type CloudArrays<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<f64>>);

/// A key-or-point argument (`updateNode`, `search`, ...).
pub(crate) enum Target {
    Key(Key),
    Point(Point3<f64>),
}

pub(crate) fn target(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Target> {
    if obj.cast::<PyKey>().is_ok() {
        Ok(Target::Key(key_arg(obj, name)?))
    } else {
        Ok(Target::Point(vec3(obj, name)?))
    }
}

/// `update` of `updateNode`: a Python bool is a hit or a miss, anything else a log-odds delta.
pub(crate) fn update_arg(obj: &Bound<'_, PyAny>) -> PyResult<Update> {
    if let Ok(b) = obj.cast::<PyBool>() {
        return Ok(if b.is_true() {
            Update::Hit
        } else {
            Update::Miss
        });
    }
    let v: f32 = obj.extract().map_err(|_| {
        pyo3::exceptions::PyTypeError::new_err(
            "update must be a bool (hit/miss) or a float (log-odds delta)",
        )
    })?;
    Ok(Update::LogOdds(v))
}

/// The keys of ``updateNodes``' ``values`` (a sequence of keys and points, or an (N, 3)
/// array of points), in order; points outside the map are skipped.
pub(crate) fn keys_arg(conv: &KeyConverter, values: &Bound<'_, PyAny>) -> PyResult<Vec<Key>> {
    Ok(match convert::points_f32(values, "values") {
        Ok(points) => points
            .iter()
            .filter_map(|p| conv.point_to_key(&p.cast::<f64>()))
            .collect(),
        Err(_) => {
            let mut keys = Vec::new();
            for v in values.try_iter()? {
                match target(&v?, "values")? {
                    Target::Key(k) => keys.push(k),
                    Target::Point(p) => {
                        keys.extend(conv.point_to_key(&p.cast::<f32>().cast::<f64>()))
                    }
                }
            }
            keys
        }
    })
}

pub(crate) fn bytes_or_true<'py>(
    py: Python<'py>,
    data: Vec<u8>,
    filename: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    match filename {
        None => Ok(PyBytes::new(py, &data).into_any()),
        Some(f) => {
            let p = path(f, "filename")?;
            py.detach(|| engine::write_file(&p, &data))
                .map_err(PyOSError::new_err)?;
            Ok(PyBool::new(py, true).to_owned().into_any())
        }
    }
}

impl PyOcTree {
    /// Wrap a tree (no bounding box).
    pub fn wrap(tree: OcTree) -> Self {
        PyOcTree {
            tree: Box::new(tree),
            bbx: Bbx::default(),
            edt: None,
        }
    }

    /// A tree from a path or serialized bytes, `.bt` or `.ot`.
    fn load(py: Python<'_>, obj: &Bound<'_, PyAny>, bt_only: bool) -> PyResult<OcTree> {
        let (data, name) = source(obj, "filename")?.bytes()?;
        py.detach(|| {
            if bt_only {
                engine::read_bt(&data)
            } else {
                engine::read_tree(&data)
            }
        })
        .map_err(|e| convert::value_error(&name, &e))
    }

    /// The node `search` finds for `key` down to depth `d`, as a Python node of `slf`.
    fn node_at(slf: &Bound<'_, Self>, key: Key, d: u8) -> Option<PyNode> {
        let found = slf.borrow().tree.search(key, d);
        found.map(|n| PyNode::found(n, key, Some(slf.clone().into_any().unbind())))
    }

    fn key_of_point(&self, p: &Point3<f64>) -> Option<Key> {
        self.tree.converter().point_to_key(p)
    }

    fn iterator_base(&self, py: Python<'_>, nodes: bool, d: u8) -> IteratorBase {
        let items = iterator_items(py, &self.tree, nodes, d);
        IteratorBase::new(items, self.tree.converter().clone(), d)
    }
}

impl OccupancyHost for PyOcTree {
    type Tree = OcTree;
    fn tree(&self) -> &OcTree {
        &self.tree
    }
    fn tree_mut(&mut self) -> &mut OcTree {
        &mut self.tree
    }
    fn bbx(&self) -> &Bbx {
        &self.bbx
    }
    fn bbx_mut(&mut self) -> &mut Bbx {
        &mut self.bbx
    }
    fn resolution_changed(&mut self) {
        // a distance map made at the old size would answer in the wrong units
        self.edt = None;
    }
}

surgery_api!(PyOcTree);
occupancy_api!(PyOcTree);

#[pymethods]
impl PyOcTree {
    #[new]
    fn py_new(py: Python<'_>, arg: &Bound<'_, PyAny>) -> PyResult<Self> {
        let is_number = arg.extract::<f64>().is_ok()
            && arg.cast::<pyo3::types::PyString>().is_err()
            && arg.cast::<PyBytes>().is_err();
        if is_number {
            let r: f64 = arg.extract()?;
            let tree = OcTree::new(r).map_err(|e| convert::value_error("OcTree", &e))?;
            Ok(Self::wrap(tree))
        } else {
            Ok(Self::wrap(Self::load(py, arg, false)?))
        }
    }

    /// Read a tree from a ``.ot`` or ``.bt`` file, or from the bytes ``write()`` /
    /// ``writeBinary()`` returned. Raises OSError (FileNotFoundError, ...) or ValueError.
    #[staticmethod]
    fn read(py: Python<'_>, filename: &Bound<'_, PyAny>) -> PyResult<Self> {
        Ok(Self::wrap(Self::load(py, filename, false)?))
    }

    /// A tree from ``.bt`` or ``.ot`` bytes.
    #[staticmethod]
    fn from_bytes(py: Python<'_>, data: &[u8]) -> PyResult<Self> {
        let tree = py
            .detach(|| engine::read_tree(data))
            .map_err(|e| convert::value_error("serialized tree", &e))?;
        Ok(Self::wrap(tree))
    }

    /// Replace this tree by a ``.bt`` file (or ``.bt`` bytes); the sensor model is kept.
    /// Returns True; raises OSError or ValueError instead of returning False.
    #[pyo3(name = "readBinary")]
    fn read_binary(&mut self, py: Python<'_>, filename: &Bound<'_, PyAny>) -> PyResult<bool> {
        let mut tree = Self::load(py, filename, true)?;
        tree.set_params(*self.tree.params());
        *self.tree = tree;
        Ok(true)
    }

    /// ``.bt`` bytes of the tree, or write them to ``filename`` and return True. Like
    /// OctoMap, converts the tree to max-likelihood and prunes it first.
    #[pyo3(name = "writeBinary", signature = (filename=None))]
    fn write_binary<'py>(
        &mut self,
        py: Python<'py>,
        filename: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let tree = &mut self.tree;
        let data = py
            .detach(|| engine::write_bt(tree))
            .map_err(|e| PyOSError::new_err(e.to_string()))?;
        bytes_or_true(py, data, filename)
    }

    /// ``.ot`` bytes of the tree (every node's log-odds), or write them to ``filename`` and
    /// return True.
    #[pyo3(signature = (filename=None))]
    fn write<'py>(
        &self,
        py: Python<'py>,
        filename: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let tree = &self.tree;
        let data = py
            .detach(|| engine::write_ot(tree))
            .map_err(|e| PyOSError::new_err(e.to_string()))?;
        bytes_or_true(py, data, filename)
    }

    /// The tree serialized: ``kind="bt"`` (max-likelihood, pruned first, like
    /// ``writeBinary``) or ``"ot"`` (full, like ``write``).
    #[pyo3(name = "to_bytes", signature = (kind="bt"))]
    fn serialize<'py>(&mut self, py: Python<'py>, kind: &str) -> PyResult<Bound<'py, PyBytes>> {
        let tree = &mut self.tree;
        let data = match kind {
            "bt" => py.detach(|| engine::write_bt(tree)),
            "ot" => py.detach(|| engine::write_ot(tree)),
            _ => {
                return Err(PyValueError::new_err(format!(
                    "kind must be \"bt\" or \"ot\", got {kind:?}"
                )))
            }
        }
        .map_err(|e| PyOSError::new_err(e.to_string()))?;
        Ok(PyBytes::new(py, &data))
    }

    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        let tree = &self.tree;
        let data = py
            .detach(|| engine::write_ot(tree))
            .map_err(|e| PyOSError::new_err(e.to_string()))?;
        let p = self.tree.params();
        let restore = py.import("octoquant._octoquant")?.getattr("_restore")?;
        let args = (
            PyBytes::new(py, &data),
            p.hit,
            p.miss,
            p.clamp_min,
            p.clamp_max,
            p.occupancy_threshold,
        );
        PyTuple::new(py, [restore.into_any(), args.into_pyobject(py)?.into_any()])
    }

    /// Integrate a scan: ``pointcloud`` (N, 3) end points and the sensor ``origin`` in the map
    /// frame. Each voxel is updated once per scan, occupied before free, exactly as OctoMap.
    /// ``maxrange`` < 0: no limit; ``lazy_eval``: skip inner-node upkeep (call
    /// ``updateInnerOccupancy()`` afterwards); ``discretize``: one ray per end-point voxel.
    /// NaN/inf points are skipped. Releases the GIL.
    #[pyo3(
        name = "insertPointCloud",
        signature = (pointcloud, origin, maxrange=-1.0, lazy_eval=false, discretize=false)
    )]
    fn insert_point_cloud(
        &mut self,
        py: Python<'_>,
        pointcloud: &Bound<'_, PyAny>,
        origin: &Bound<'_, PyAny>,
        maxrange: f64,
        lazy_eval: bool,
        discretize: bool,
    ) -> PyResult<()> {
        let (points, origin) = convert::scan_args(pointcloud, origin, maxrange)?;
        let tree = &mut self.tree;
        let bbx = self.bbx;
        py.detach(|| {
            if bbx.enabled {
                bbx::insert_point_cloud(
                    tree, &bbx, &points, &origin, maxrange, lazy_eval, discretize,
                )
            } else {
                let max_range = (maxrange >= 0.0).then_some(maxrange);
                engine::insert_point_cloud(tree, &points, &origin, max_range, lazy_eval, discretize)
            }
        });
        Ok(())
    }

    /// Follow a ray from ``origin`` along ``direction`` to the first occupied voxel. Writes the
    /// centre of the voxel where it stopped into ``end`` (a float array of 3, changed in place)
    /// and returns True only for an occupied voxel; stops at unknown space unless
    /// ``ignoreUnknownCells``, and beyond ``maxRange`` when it is > 0.
    #[pyo3(
        name = "castRay",
        signature = (origin, direction, end, ignoreUnknownCells=false, maxRange=-1.0)
    )]
    #[allow(non_snake_case)]
    fn cast_ray(
        &self,
        origin: &Bound<'_, PyAny>,
        direction: &Bound<'_, PyAny>,
        end: &Bound<'_, PyAny>,
        ignoreUnknownCells: bool,
        maxRange: f64,
    ) -> PyResult<bool> {
        cast_ray_into(
            &self.tree,
            origin,
            direction,
            end,
            ignoreUnknownCells,
            maxRange,
        )
    }

    /// Many casts at once: ``origins`` (N, 3) or one (3,) origin for all, ``directions``
    /// (N, 3). Returns ``(hit, ends)``: bool (N,) and float64 (N, 3), NaN rows where the
    /// ray could not be cast. Parallel, without the GIL.
    #[pyo3(signature = (origins, directions, ignore_unknown=false, max_range=None))]
    fn cast_rays<'py>(
        &self,
        py: Python<'py>,
        origins: &Bound<'py, PyAny>,
        directions: &Bound<'py, PyAny>,
        ignore_unknown: bool,
        max_range: Option<f64>,
    ) -> PyResult<CastArrays<'py>> {
        cast_rays_arrays(
            py,
            &self.tree,
            origins,
            directions,
            ignore_unknown,
            max_range,
        )
    }

    /// The node holding ``value`` (an OcTreeKey or a point), descending at most to ``depth``
    /// (0 = 16, the voxel level): the node, the pruned leaf covering it, or None in unknown
    /// space or outside the map.
    #[pyo3(signature = (value, depth=0))]
    fn search(
        slf: &Bound<'_, Self>,
        value: &Bound<'_, PyAny>,
        depth: i64,
    ) -> PyResult<Option<PyNode>> {
        let d = convert::depth(depth, "depth")?;
        let key = match target(value, "value")? {
            Target::Key(k) => k,
            Target::Point(p) => match slf.borrow().key_of_point(&p) {
                Some(k) => k,
                None => return Ok(None),
            },
        };
        Ok(Self::node_at(slf, key, d))
    }

    /// Whether a node (from ``search``/``updateNode``, or an iterator) is occupied under the
    /// current threshold. ``None`` (unknown space) raises NullPointerException.
    #[pyo3(name = "isNodeOccupied")]
    fn is_node_occupied(&self, node: &Bound<'_, PyAny>) -> PyResult<bool> {
        Ok(self.tree.params().is_occupied(node_value(node)?))
    }

    /// Integrate one observation of the voxel at ``value`` (OcTreeKey or point):
    /// ``update`` True = hit, False = miss, a float = log-odds delta. Returns the updated
    /// node, or None for a point outside the map.
    #[pyo3(name = "updateNode", signature = (value, update, lazy_eval=false))]
    fn update_node(
        slf: &Bound<'_, Self>,
        value: &Bound<'_, PyAny>,
        update: &Bound<'_, PyAny>,
        lazy_eval: bool,
    ) -> PyResult<Option<PyNode>> {
        let u = update_arg(update)?;
        let key = match target(value, "value")? {
            Target::Key(k) => k,
            Target::Point(p) => match slf.borrow().key_of_point(&p.cast::<f32>().cast::<f64>()) {
                Some(k) => k,
                None => return Ok(None),
            },
        };
        slf.borrow_mut()
            .tree
            .update_node(key, u, InnerNodes::from_lazy(lazy_eval));
        Ok(Self::node_at(slf, key, TREE_DEPTH))
    }

    /// ``updateNode`` for many keys or points (a sequence, or an (N, 3) array of points), in
    /// order. Points outside the map are skipped.
    #[pyo3(name = "updateNodes", signature = (values, update, lazy_eval=false))]
    fn update_nodes(
        &mut self,
        py: Python<'_>,
        values: &Bound<'_, PyAny>,
        update: &Bound<'_, PyAny>,
        lazy_eval: bool,
    ) -> PyResult<()> {
        let u = update_arg(update)?;
        if values.is_none() {
            return Ok(());
        }
        let keys = keys_arg(self.tree.converter(), values)?;
        let tree = &mut self.tree;
        py.detach(|| tree.update_keys(&keys, u, InnerNodes::from_lazy(lazy_eval)));
        Ok(())
    }

    /// Bring inner nodes up to date after ``lazy_eval`` updates.
    #[pyo3(name = "updateInnerOccupancy")]
    fn update_inner_occupancy(&mut self, py: Python<'_>) {
        let tree = &mut self.tree;
        py.detach(|| tree.update_inner_occupancy());
    }

    /// Set every node to the clamping bound on its side of the threshold.
    #[pyo3(name = "toMaxLikelihood")]
    fn max_likelihood(&mut self, py: Python<'_>) {
        let tree = &mut self.tree;
        py.detach(|| tree.to_max_likelihood());
    }

    /// Merge children that all have the same value into their parent (OctoMap's ``prune``).
    fn prune(&mut self, py: Python<'_>) {
        let tree = &mut self.tree;
        py.detach(|| tree.prune());
    }

    /// Expand every pruned node down to voxels (OctoMap's ``expand``). An expansion that
    /// could not fit (a coarse leaf, e.g. a root left childless by deletes, becomes up to 8^16
    /// voxels) raises MemoryError before allocating anything; ``max_nodes`` sets the most
    /// nodes it may add (default: what the machine's physical memory could hold at all).
    #[pyo3(signature = (max_nodes=None))]
    fn expand(&mut self, py: Python<'_>, max_nodes: Option<u64>) -> PyResult<()> {
        let limit = expansion_limit(py, max_nodes)?;
        let tree = &mut self.tree;
        py.detach(|| tree.try_expand(limit))
            .map(drop)
            .map_err(expansion_error)
    }

    /// Fuse ``other`` (a map built separately) into this tree: each leaf of ``other`` is applied
    /// to the voxels it covers as a log-odds update, exactly as OctoMap's
    /// ``updateNode(voxel, leaf_log_odds)`` voxel by voxel, with this tree's clamping; pruned
    /// leaves are applied whole. ``ValueError`` (and this tree unchanged) when the resolutions
    /// differ or a leaf of ``other`` is not finite. Returns ``{"leaves", "pruned_leaves",
    /// "voxels"}``: what was applied.
    fn merge<'py>(
        slf: &Bound<'py, Self>,
        other: &Bound<'py, PyOcTree>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let py = slf.py();
        let copy;
        let guard;
        let b: &OcTree = if slf.is(other) {
            copy = (*slf.borrow().tree).clone();
            &copy
        } else {
            guard = other.borrow();
            &guard.tree
        };
        let mut me = slf.borrow_mut();
        let tree: &mut OcTree = &mut me.tree;
        let stats = py
            .detach(|| tree.merge(b))
            .map_err(|e| convert::value_error("merge", &e))?;
        let out = PyDict::new(py);
        out.set_item("leaves", stats.leaves)?;
        out.set_item("pruned_leaves", stats.pruned_leaves)?;
        out.set_item("voxels", stats.voxels)?;
        Ok(out)
    }

    /// Remove every node (the resolution and sensor model stay).
    fn clear(&mut self) {
        self.tree.clear();
    }

    /// Delete the node at ``depth`` (0 = 16) holding point ``value``, with its subtree
    /// (octomap-python's default depth is 1: a whole octant). Returns OctoMap's value: True
    /// only when the tree was empty or is left without children.
    #[pyo3(name = "deleteNode", signature = (value, depth=1))]
    fn delete_node(&mut self, value: &Bound<'_, PyAny>, depth: i64) -> PyResult<bool> {
        let d = convert::depth(depth, "depth")?;
        let key = match target(value, "value")? {
            Target::Key(k) => k,
            Target::Point(p) => match self.key_of_point(&p.cast::<f32>().cast::<f64>()) {
                Some(k) => k,
                None => return Ok(false),
            },
        };
        if self.tree.is_empty() {
            return Ok(true);
        }
        let deleted = self.tree.delete_node(key, d);
        // OctoMap's deleteNodeRecurs reports whether the root was left without children
        Ok(deleted && self.tree.nodes().nth(1).is_none())
    }

    /// ``(occupied, empty)``: float64 (N, 3) arrays of the centres of every voxel inside the
    /// occupied and the free leaves (a pruned leaf gives all the voxels it covers).
    #[pyo3(name = "extractPointCloud")]
    fn extract_point_cloud<'py>(&self, py: Python<'py>) -> PyResult<CloudArrays<'py>> {
        let tree = &self.tree;
        let (occ, free) = py
            .detach(|| cloud::extract_point_cloud(tree))
            .map_err(|e| {
                PyMemoryError::new_err(format!("extractPointCloud would return {} points", e.0))
            })?;
        Ok((array_n3(py, occ), array_n3(py, free)))
    }

    /// int32 label per point of an (N, 3) array: 1 occupied, 0 free, -1 unknown (also for
    /// NaN points and points outside the map).
    #[pyo3(name = "getLabels")]
    fn get_labels<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<i32>>> {
        let pts = convert::points_f32(points, "points")?;
        let tree = &self.tree;
        let labels = py.detach(|| cloud::labels(tree, &pts));
        Ok(PyArray1::from_vec(py, labels))
    }

    /// octomap-python's ``dynamicEDT_generate``: a distance map over the box between two
    /// points (metres), distances clamped at ``maxdist``, unknown space occupied or free.
    /// Distances are computed by ``dynamicEDT_update``. ValueError for a NaN, negative or
    /// huge ``maxdist``, a corner outside the map, an empty or too large box.
    #[pyo3(name = "dynamicEDT_generate", signature = (maxdist, bbx_min, bbx_max, treatUnknownAsOccupied=false))]
    #[allow(non_snake_case)]
    fn dynamic_edt_generate(
        &mut self,
        py: Python<'_>,
        maxdist: f64,
        bbx_min: &Bound<'_, PyAny>,
        bbx_max: &Bound<'_, PyAny>,
        treatUnknownAsOccupied: bool,
    ) -> PyResult<()> {
        let m = crate::distance::generate(
            &self.tree,
            py,
            maxdist,
            bbx_min,
            bbx_max,
            treatUnknownAsOccupied,
        )?;
        self.edt = Some(Box::new(m));
        self.tree.enable_change_detection(true);
        Ok(())
    }

    /// ``dynamicEDT_update``: take in the voxels changed since the last update and recompute
    /// the distances they affect (squared distances only when ``updateRealDist`` is false).
    #[pyo3(name = "dynamicEDT_update")]
    #[allow(non_snake_case)]
    fn dynamic_edt_update(&mut self, py: Python<'_>, updateRealDist: bool) -> PyResult<()> {
        crate::distance::update(&mut self.tree, self.edt.as_deref_mut(), py, updateRealDist)
    }

    /// ``dynamicEDT_getMaxDist``: the distance clamp in metres.
    #[pyo3(name = "dynamicEDT_getMaxDist")]
    fn dynamic_edt_max_dist(&self) -> PyResult<f32> {
        crate::distance::max_dist(self.edt.as_deref())
    }

    /// ``dynamicEDT_checkConsistency``: whether the map's obstacles are the tree's.
    #[pyo3(name = "dynamicEDT_checkConsistency")]
    fn dynamic_edt_check_consistency(&self) -> PyResult<bool> {
        crate::distance::check_consistency(&self.tree, self.edt.as_deref())
    }

    /// ``dynamicEDT_getDistance``: distance (metres) from a point or an ``OcTreeKey`` to the
    /// nearest obstacle; -1.0 outside the box.
    #[pyo3(name = "dynamicEDT_getDistance")]
    fn dynamic_edt_get_distance(&self, p: &Bound<'_, PyAny>) -> PyResult<f32> {
        crate::distance::distance(self.edt.as_deref(), p)
    }

    /// ``dynamicEDT_getDistanceAndClosestObstacle``: ``(distance, obstacle)``, the obstacle
    /// voxel's centre as a (3,) array, ``None`` outside the box or beyond the maximum.
    #[pyo3(name = "dynamicEDT_getDistanceAndClosestObstacle")]
    fn dynamic_edt_get_distance_and_closest_obstacle<'py>(
        &self,
        py: Python<'py>,
        p: &Bound<'py, PyAny>,
    ) -> PyResult<(f32, crate::distance::Obstacle<'py>)> {
        crate::distance::distance_and_closest_obstacle(self.edt.as_deref(), py, p)
    }

    /// ``dynamicEDT_getDistance`` of every row of an (N, 3) array, as float32.
    fn distances<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<f32>>> {
        crate::distance::distances(self.edt.as_deref(), py, points)
    }

    /// The occupancy probability at one point (metres), that of the node holding it (the
    /// voxel, or the pruned leaf covering it); ``None`` in unknown space and outside the map.
    /// The same value as ``search(point).getOccupancy()`` without a node in between.
    fn probability_at(&self, point: &Bound<'_, PyAny>) -> PyResult<Option<f64>> {
        Ok(self.tree.probability_at(&convert::vec3(point, "point")?))
    }

    /// Occupancy probability per point of an (N, 3) array; NaN in unknown space.
    fn occupancy<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let pts = convert::points_f64(points, "points")?;
        let tree = &self.tree;
        let p = py.detach(|| cloud::occupancy(tree, &pts));
        Ok(PyArray1::from_vec(py, p))
    }

    /// A 2D occupancy grid of the height band ``[zmin, zmax]`` (``None``: no limit), as
    /// octomap_server's projected map: ``(cells, origin, resolution)`` where ``cells`` is an
    /// int8 (height, width) array in ``nav_msgs/OccupancyGrid`` values (100 occupied, 0 free,
    /// -1 unknown), row 0 at the smallest y; ``origin`` the (x, y) of cell (0, 0)'s lower
    /// corner; ``resolution`` the cell size (the map's at ``depth=16``, doubled per level
    /// less). ``unknown="free"`` marks unknown cells free. ``write_grid`` saves it for Nav2.
    #[pyo3(signature = (zmin=None, zmax=None, depth=16, unknown="unknown"))]
    fn grid<'py>(
        &self,
        py: Python<'py>,
        zmin: Option<f64>,
        zmax: Option<f64>,
        depth: i64,
        unknown: &str,
    ) -> PyResult<GridArrays<'py>> {
        let options = grid_options(zmin, zmax, depth, unknown)?;
        let tree = &self.tree;
        let g = py
            .detach(|| engine::grid(tree, &options))
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let values: Vec<i8> = g.cells.iter().map(|c| c.occupancy()).collect();
        let arr = numpy::ndarray::Array2::from_shape_vec((g.height, g.width), values)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok((
            PyArray2::from_owned_array(py, arr),
            (g.origin.x, g.origin.y),
            g.resolution,
        ))
    }

    /// Write the grid of ``grid(...)`` as a ROS map_server / Nav2 map: ``yaml`` (a .yaml
    /// path) and a trinary PGM beside it with the same stem; returns the image's path.
    #[pyo3(signature = (yaml, zmin=None, zmax=None, depth=16, unknown="unknown"))]
    fn write_grid(
        &self,
        py: Python<'_>,
        yaml: std::path::PathBuf,
        zmin: Option<f64>,
        zmax: Option<f64>,
        depth: i64,
        unknown: &str,
    ) -> PyResult<String> {
        let options = grid_options(zmin, zmax, depth, unknown)?;
        let tree = &self.tree;
        let image = py.detach(|| {
            let g = engine::grid(tree, &options)?;
            engine::write_grid(&g, &yaml)
        });
        match image {
            Ok(p) => Ok(p.display().to_string()),
            Err(e @ engine::GridError::Output(_)) => Err(PyOSError::new_err(e.to_string())),
            Err(e) => Err(PyValueError::new_err(e.to_string())),
        }
    }

    /// ``(centres, sizes)`` of the occupied leaves: float64 (N, 3) and (N,).
    fn occupied_voxels<'py>(
        &self,
        py: Python<'py>,
    ) -> (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray1<f64>>) {
        let tree = &self.tree;
        let (c, s) = py.detach(|| cloud::voxels(tree, true));
        (array_n3(py, c), PyArray1::from_vec(py, s))
    }

    /// ``(centres, sizes)`` of the free leaves: float64 (N, 3) and (N,).
    fn free_voxels<'py>(
        &self,
        py: Python<'py>,
    ) -> (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray1<f64>>) {
        let tree = &self.tree;
        let (c, s) = py.detach(|| cloud::voxels(tree, false));
        (array_n3(py, c), PyArray1::from_vec(py, s))
    }

    /// Every leaf (down to ``max_depth``, 0 = 16; inside ``bbx = (min, max)`` if given) as a
    /// structured array with fields x, y, z (centre), size, depth, log_odds.
    #[pyo3(signature = (bbx=None, max_depth=0))]
    fn leaves<'py>(
        &self,
        py: Python<'py>,
        bbx: Option<(Bound<'py, PyAny>, Bound<'py, PyAny>)>,
        max_depth: i64,
    ) -> PyResult<Bound<'py, PyAny>> {
        let d = crate::iter::max_depth(convert::depth(max_depth, "max_depth")?);
        let items = match &bbx {
            None => {
                let tree = &self.tree;
                py.detach(|| engine::leaves(tree, d))
            }
            Some((lo, hi)) => bbx_items(py, &self.tree, lo, hi, d)?,
        };
        let conv = self.tree.converter();
        let np = py.import("numpy")?;
        let dtype = np.call_method1(
            "dtype",
            (vec![
                ("x", "f8"),
                ("y", "f8"),
                ("z", "f8"),
                ("size", "f8"),
                ("depth", "u1"),
                ("log_odds", "f4"),
            ],),
        )?;
        let out = np.call_method1("empty", (items.len(), dtype))?;
        for (a, name) in ["x", "y", "z"].iter().enumerate() {
            let col: Vec<f64> = items
                .iter()
                .map(|n| conv.key_to_coord_at_depth(n.key[a], n.depth))
                .collect();
            out.set_item(*name, PyArray1::from_vec(py, col))?;
        }
        let sizes: Vec<f64> = items.iter().map(|n| conv.node_size(n.depth)).collect();
        out.set_item("size", PyArray1::from_vec(py, sizes))?;
        let depths: Vec<u8> = items.iter().map(|n| n.depth).collect();
        out.set_item("depth", PyArray1::from_vec(py, depths))?;
        let values: Vec<f32> = items.iter().map(|n| n.value).collect();
        out.set_item("log_odds", PyArray1::from_vec(py, values))?;
        Ok(out)
    }

    /// Leaf size in metres.
    #[pyo3(name = "getResolution")]
    fn get_resolution(&self) -> f64 {
        self.tree.resolution()
    }

    /// ``b"OcTree"``.
    #[pyo3(name = "getTreeType")]
    fn get_tree_type<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        PyBytes::new(py, b"OcTree")
    }

    /// Number of nodes, inner and leaves.
    fn size(&self) -> usize {
        self.tree.size()
    }

    /// Number of leaves.
    #[pyo3(name = "getNumLeafNodes")]
    fn get_num_leaf_nodes(&self, py: Python<'_>) -> usize {
        let tree = &self.tree;
        py.detach(|| tree.num_leaves())
    }

    /// Child ``idx`` (0..8) of a node, or None when it does not exist (octomap-python returns a
    /// null node).
    #[pyo3(name = "getNodeChild")]
    fn get_node_child(
        slf: &Bound<'_, Self>,
        node: &Bound<'_, PyAny>,
        idx: i64,
    ) -> PyResult<Option<PyNode>> {
        let i = child_idx(idx)?;
        let (key, d) = live_node(&*slf.borrow().tree, node)?;
        let child = slf.borrow().tree.node_child(key, d, i);
        let tree = || Some(slf.clone().into_any().unbind());
        Ok(child
            .zip(OcTree::child_key(key, d, i))
            .map(|(info, k)| PyNode::found(info, k, tree())))
    }

    /// Create child ``idx`` (0..8) of a node with log-odds 0, as OctoMap's
    /// ``createNodeChild``; returns it. ``ValueError`` when the child exists already or the
    /// node is a voxel.
    #[pyo3(name = "createNodeChild")]
    fn create_node_child(
        slf: &Bound<'_, Self>,
        node: &Bound<'_, PyAny>,
        idx: i64,
    ) -> PyResult<PyNode> {
        let (key, d) = live_node(&*slf.borrow().tree, node)?;
        let i = child_idx(idx)?;
        if d >= TREE_DEPTH {
            return Err(PyValueError::new_err(
                "createNodeChild: a voxel (depth 16) has no children",
            ));
        }
        let child = slf
            .borrow_mut()
            .tree
            .create_node_child(key, d, i)
            .zip(OcTree::child_key(key, d, i));
        let (info, k) = child.ok_or_else(|| {
            PyValueError::new_err(format!("createNodeChild: child {i} exists already"))
        })?;
        Ok(PyNode::found(
            info,
            k,
            Some(slf.clone().into_any().unbind()),
        ))
    }

    /// The root node, or None for an empty tree.
    #[pyo3(name = "getRoot")]
    fn get_root(slf: &Bound<'_, Self>) -> Option<PyNode> {
        let this = slf.borrow();
        this.tree.root_value().map(|v| PyNode {
            value: v,
            has_children: this.tree.size() > 1,
            depth: 0,
            key: Key::new(0, 0, 0),
            tree: Some(slf.clone().into_any().unbind()),
        })
    }

    // ---- iteration ----

    /// Iterator over every node, inner ones too, down to ``maxDepth`` (0 = 16).
    #[pyo3(signature = (maxDepth=0))]
    #[allow(non_snake_case)]
    fn begin_tree(&self, py: Python<'_>, maxDepth: i64) -> PyResult<Py<TreeIterator>> {
        let d = max_depth(depth(maxDepth, "maxDepth")?);
        TreeIterator::create(py, self.iterator_base(py, true, d))
    }

    /// Iterator over the leaves, treating nodes at ``maxDepth`` (0 = 16) as leaves.
    #[pyo3(signature = (maxDepth=0))]
    #[allow(non_snake_case)]
    fn begin_leafs(&self, py: Python<'_>, maxDepth: i64) -> PyResult<Py<LeafIterator>> {
        let d = max_depth(depth(maxDepth, "maxDepth")?);
        LeafIterator::create(py, self.iterator_base(py, false, d))
    }

    /// Iterator over the leaves whose cube overlaps the box ``[bbx_min, bbx_max]``; empty when
    /// a corner is outside the map.
    #[pyo3(signature = (bbx_min, bbx_max, maxDepth=0))]
    #[allow(non_snake_case)]
    fn begin_leafs_bbx(
        &self,
        py: Python<'_>,
        bbx_min: &Bound<'_, PyAny>,
        bbx_max: &Bound<'_, PyAny>,
        maxDepth: i64,
    ) -> PyResult<Py<LeafBbxIterator>> {
        let d = max_depth(depth(maxDepth, "maxDepth")?);
        let items = bbx_items(py, &self.tree, bbx_min, bbx_max, d)?;
        let base = IteratorBase::new(items, self.tree.converter().clone(), d);
        LeafBbxIterator::create(py, base)
    }

    /// An iterator past the last node.
    fn end_tree(&self, py: Python<'_>) -> PyResult<Py<TreeIterator>> {
        TreeIterator::create(py, self.empty_iterator())
    }

    /// An iterator past the last leaf.
    fn end_leafs(&self, py: Python<'_>) -> PyResult<Py<LeafIterator>> {
        LeafIterator::create(py, self.empty_iterator())
    }

    /// An iterator past the last leaf of a box.
    fn end_leafs_bbx(&self, py: Python<'_>) -> PyResult<Py<LeafBbxIterator>> {
        LeafBbxIterator::create(py, self.empty_iterator())
    }

    fn __repr__(&self) -> String {
        format!(
            "octoquant.OcTree(resolution={}, size={})",
            self.tree.resolution(),
            self.tree.size()
        )
    }

    fn __copy__(&self) -> Self {
        PyOcTree {
            tree: self.tree.clone(),
            bbx: self.bbx,
            edt: self.edt.clone(),
        }
    }

    fn __deepcopy__(&self, _memo: &Bound<'_, PyDict>) -> Self {
        self.__copy__()
    }
}

impl PyOcTree {
    fn empty_iterator(&self) -> IteratorBase {
        IteratorBase::new(Vec::new(), self.tree.converter().clone(), TREE_DEPTH)
    }
}

// The pieces of iteration and ray casting an OcTree and a ColorOcTree (through its occupancy
// tree) share.

/// Every node (`nodes`) or every leaf down to depth `d`, collected without the GIL in
/// OctoMap's iterator order: what `begin_tree` / `begin_leafs` walk.
pub fn iterator_items(py: Python<'_>, tree: &OcTree, nodes: bool, d: u8) -> Vec<engine::NodeItem> {
    py.detach(|| {
        if nodes {
            engine::nodes(tree, d)
        } else {
            engine::leaves(tree, d)
        }
    })
}

/// Leaves down to depth `d` overlapping the box between two points as OctoMap's
/// `begin_leafs_bbx` finds them; none when a corner is outside the map (OctoMap's end
/// iterator).
pub fn bbx_items(
    py: Python<'_>,
    tree: &OcTree,
    lo: &Bound<'_, PyAny>,
    hi: &Bound<'_, PyAny>,
    d: u8,
) -> PyResult<Vec<engine::NodeItem>> {
    let lo = vec3_f32(lo, "bbx_min")?.cast::<f64>();
    let hi = vec3_f32(hi, "bbx_max")?.cast::<f64>();
    let conv = tree.converter();
    let (Some(a), Some(b)) = (conv.point_to_key(&lo), conv.point_to_key(&hi)) else {
        return Ok(Vec::new());
    };
    Ok(py.detach(|| {
        engine::leaves(tree, d)
            .into_iter()
            .filter(|n| octomap_bbx_overlap(n, &a, &b))
            .collect()
    }))
}

/// octomap-python's `castRay` on `tree`: writes the end voxel's centre into `end` (a float
/// array of 3, changed in place) and returns whether an occupied voxel stopped the ray.
pub fn cast_ray_into(
    tree: &OcTree,
    origin: &Bound<'_, PyAny>,
    direction: &Bound<'_, PyAny>,
    end: &Bound<'_, PyAny>,
    ignore_unknown: bool,
    max_range: f64,
) -> PyResult<bool> {
    let o = vec3_f32(origin, "origin")?;
    let d = vec3_f32(direction, "direction")?;
    let out = end_array(end)?;
    let r = engine::cast_ray(tree, &o, &d, ignore_unknown, max_range);
    if let Some(e) = r.end {
        out.set(e)?;
    }
    Ok(r.hit)
}

/// `cast_rays` on `tree`: many casts in parallel without the GIL, `(hit, ends)` arrays with
/// NaN rows where a ray could not be cast.
pub fn cast_rays_arrays<'py>(
    py: Python<'py>,
    tree: &OcTree,
    origins: &Bound<'py, PyAny>,
    directions: &Bound<'py, PyAny>,
    ignore_unknown: bool,
    max_range: Option<f64>,
) -> PyResult<CastArrays<'py>> {
    let dirs = convert::points_f32(directions, "directions")?;
    let origins = match vec3_f32(origins, "origins") {
        Ok(o) => vec![o; dirs.len()],
        Err(_) => convert::points_f32(origins, "origins")?,
    };
    if origins.len() != dirs.len() {
        return Err(PyValueError::new_err(format!(
            "origins has {} rows but directions has {}",
            origins.len(),
            dirs.len()
        )));
    }
    let mr = max_range.unwrap_or(-1.0);
    let results: Vec<(bool, [f64; 3])> = py.detach(|| {
        origins
            .par_iter()
            .zip(dirs.par_iter())
            .map(|(o, d)| {
                let r = engine::cast_ray(tree, o, d, ignore_unknown, mr);
                let e = r
                    .end
                    .map_or([f64::NAN; 3], |e| [e.x as f64, e.y as f64, e.z as f64]);
                (r.hit, e)
            })
            .collect()
    });
    let hits: Vec<bool> = results.iter().map(|r| r.0).collect();
    let ends: Vec<[f64; 3]> = results.into_iter().map(|r| r.1).collect();
    Ok((PyArray1::from_vec(py, hits), array_n3(py, ends)))
}

/// OctoMap's `leaf_bbx_iterator` test of a node against the key box `[lo, hi]` (corners taken
/// as given, not sorted): `lo <= key + half && hi >= key - half` on every axis, where `key` is
/// the node's centre key and `half` its half width in keys. The upper side reaches one key
/// past the node, so a pruned node that ends just below the box is included, as in OctoMap.
/// A node passes only if its parent does, so filtering the leaves equals OctoMap's pruned walk.
fn octomap_bbx_overlap(n: &engine::NodeItem, lo: &Key, hi: &Key) -> bool {
    let half = if n.depth >= TREE_DEPTH {
        0
    } else {
        32768i32 >> n.depth
    };
    (0..3).all(|i| {
        let k = n.key[i] as i32;
        lo[i] as i32 <= k + half && hi[i] as i32 >= k - half
    })
}

/// The `end` argument of `castRay`: a writable float array of at least 3 elements.
enum EndArray<'py> {
    F64(Bound<'py, numpy::PyArrayDyn<f64>>),
    F32(Bound<'py, numpy::PyArrayDyn<f32>>),
}

fn end_array<'py>(obj: &Bound<'py, PyAny>) -> PyResult<EndArray<'py>> {
    let bad = || {
        pyo3::exceptions::PyTypeError::new_err(
            "end must be a writable float64 or float32 NumPy array of 3 elements (castRay writes the end point into it)",
        )
    };
    let e = if let Ok(a) = obj.cast::<numpy::PyArrayDyn<f64>>() {
        EndArray::F64(a.clone())
    } else if let Ok(a) = obj.cast::<numpy::PyArrayDyn<f32>>() {
        EndArray::F32(a.clone())
    } else {
        return Err(bad());
    };
    let len = match &e {
        EndArray::F64(a) => numpy::PyUntypedArrayMethods::len(a),
        EndArray::F32(a) => numpy::PyUntypedArrayMethods::len(a),
    };
    if len < 3 {
        return Err(PyValueError::new_err(format!(
            "end must have at least 3 elements, got {len}"
        )));
    }
    Ok(e)
}

impl EndArray<'_> {
    fn set(&self, p: Point3<f32>) -> PyResult<()> {
        let err = |e: numpy::BorrowError| PyValueError::new_err(format!("end: {e}"));
        match self {
            EndArray::F64(a) => {
                let mut rw = a.try_readwrite().map_err(err)?;
                for (v, c) in rw.as_array_mut().iter_mut().zip([p.x, p.y, p.z]) {
                    *v = c as f64;
                }
            }
            EndArray::F32(a) => {
                let mut rw = a.try_readwrite().map_err(err)?;
                for (v, c) in rw.as_array_mut().iter_mut().zip([p.x, p.y, p.z]) {
                    *v = c;
                }
            }
        }
        Ok(())
    }
}

/// Unpickling: a tree from `.ot` bytes and its sensor model (log-odds).
#[pyfunction]
pub fn _restore(
    py: Python<'_>,
    data: &[u8],
    hit: f32,
    miss: f32,
    clamp_min: f32,
    clamp_max: f32,
    threshold: f32,
) -> PyResult<PyOcTree> {
    let mut t = PyOcTree::from_bytes(py, data)?;
    t.tree.set_params(OccupancyParams {
        hit,
        miss,
        clamp_min,
        clamp_max,
        occupancy_threshold: threshold,
    });
    Ok(t)
}

/// The grid options of `grid` / `write_grid`, checked.
fn grid_options(
    zmin: Option<f64>,
    zmax: Option<f64>,
    depth: i64,
    unknown: &str,
) -> PyResult<engine::GridOptions> {
    let depth = match u8::try_from(depth) {
        Ok(d @ 1..=16) => d,
        _ => {
            return Err(PyValueError::new_err(format!(
                "depth must be 1..16, got {depth}"
            )))
        }
    };
    let unknown = match unknown {
        "unknown" => engine::UnknownCells::Unknown,
        "free" => engine::UnknownCells::Free,
        other => {
            return Err(PyValueError::new_err(format!(
                "unknown must be \"unknown\" or \"free\", got {other:?}"
            )))
        }
    };
    Ok(engine::GridOptions {
        zmin,
        zmax,
        depth,
        unknown,
    })
}

/// What `grid` returns: cells (height, width), origin (x, y), cell size.
type GridArrays<'py> = (Bound<'py, PyArray2<i8>>, (f64, f64), f64);

/// The fewest bytes a node added by an expansion takes (a voxel: two bytes of a block of
/// palette indices; inner nodes and colour or stamp side tables take more): the default
/// limit of ``expand()`` refuses only expansions that could not fit at all.
const EXPANSION_MIN_BYTES_PER_NODE: u64 = 2;

/// The arenas address 2^32 blocks of eight nodes: no tree holds more nodes than this.
const MAX_TREE_NODES: u64 = 1 << 35;

/// The most nodes ``expand()`` may add: `max_nodes` when given, else what the machine's
/// physical memory (``os.sysconf``) could hold at [`EXPANSION_MIN_BYTES_PER_NODE`] each;
/// never more than a tree can address.
pub(crate) fn expansion_limit(py: Python<'_>, max_nodes: Option<u64>) -> PyResult<u64> {
    if let Some(n) = max_nodes {
        return Ok(n.min(MAX_TREE_NODES));
    }
    let sysconf = |name: &str| -> Option<u64> {
        let os = py.import("os").ok()?;
        os.call_method1("sysconf", (name,)).ok()?.extract().ok()
    };
    let memory = sysconf("SC_PHYS_PAGES")
        .zip(sysconf("SC_PAGE_SIZE"))
        .map(|(pages, size)| pages.saturating_mul(size));
    Ok(memory.map_or(MAX_TREE_NODES, |m| {
        (m / EXPANSION_MIN_BYTES_PER_NODE).min(MAX_TREE_NODES)
    }))
}

/// ``expand()``'s refusal as a Python MemoryError (any other error as ValueError).
pub(crate) fn expansion_error(e: engine::OctreeError) -> PyErr {
    match e {
        engine::OctreeError::ExpansionTooLarge { nodes, limit } => PyMemoryError::new_err(format!(
            "expand() would add {nodes} nodes (at least {:.1} GiB), more than the limit of \
                 {limit} nodes; nothing was expanded (pass max_nodes= to set the limit)",
            (nodes as f64) * EXPANSION_MIN_BYTES_PER_NODE as f64 / f64::from(1u32 << 30)
        )),
        e => PyValueError::new_err(format!("expand(): {e}")),
    }
}
