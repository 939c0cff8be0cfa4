//! `octoquant.OcTreeStamped` and `OcTreeNodeStamped`: OctoMap's `OcTreeStamped` (an
//! occupancy octree whose nodes carry the time of their last update) over the Rust library's
//! `StampedOcTree`, with the `.ot` bytes OctoMap writes. octomap-python has no such class, so
//! the names are those of OctoMap's C++ API, in octomap-python's style where the calls are
//! shared with `OcTree`.

use crate::bbx::{self, Bbx};
use crate::convert::{self, child_idx, source};
use crate::engine::{
    self, probability, InnerNodes, Key, NodeInfo, NodeItem, OcTree, StampedOcTree, TREE_DEPTH,
};
use crate::iter::{
    max_depth, node_value, IteratorBase, LeafBbxIterator, LeafIterator, TreeIterator,
};
use crate::node::PyKey;
use crate::occupancy_api::{live_node, occupancy_api, surgery_api, OccupancyHost};
use crate::tree::{
    bbx_items, bytes_or_true, cast_ray_into, cast_rays_arrays, iterator_items, target, update_arg,
    CastArrays, Target,
};
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyBytes;

/// A node of an OcTreeStamped as it was when it was looked up: occupancy and time stamp
/// (OctoMap's ``OcTreeNodeStamped``; a snapshot, not a pointer into the live tree).
#[pyclass(module = "octoquant", name = "OcTreeNodeStamped", frozen)]
#[derive(Clone, Copy)]
pub struct PyStampedNode {
    value: f32,
    has_children: bool,
    depth: u8,
    key: Key,
    timestamp: u32,
}

impl PyStampedNode {
    /// The node `info` found with `key`, whose stamp is `timestamp`.
    fn found(info: NodeInfo, key: Key, timestamp: u32) -> Self {
        PyStampedNode {
            value: info.value,
            has_children: info.has_children,
            depth: info.depth,
            key: if info.depth < TREE_DEPTH {
                key.at_depth(info.depth)
            } else {
                key
            },
            timestamp,
        }
    }
}

#[pymethods]
impl PyStampedNode {
    /// The node's log-odds (same as `getLogOdds`).
    #[pyo3(name = "getValue")]
    fn get_value(&self) -> f32 {
        self.value
    }

    /// The node's log-odds occupancy.
    #[pyo3(name = "getLogOdds")]
    fn get_log_odds(&self) -> f32 {
        self.value
    }

    /// The node's occupancy probability, `1 - 1/(1 + exp(log_odds))`.
    #[pyo3(name = "getOccupancy")]
    fn get_occupancy(&self) -> f64 {
        probability(self.value as f64)
    }

    /// Whether the node had children when it was looked up.
    #[pyo3(name = "hasChildren")]
    fn has_children_py(&self) -> bool {
        self.has_children
    }

    /// The node's depth (16 = voxel; smaller for a pruned node covering many voxels).
    #[pyo3(name = "getDepth")]
    fn get_depth(&self) -> u8 {
        self.depth
    }

    /// The node's key at its depth.
    #[pyo3(name = "getKey")]
    fn get_key(&self) -> PyKey {
        PyKey::new(self.key)
    }

    /// The time of the node's last update in whole seconds (OctoMap's ``getTimestamp``); 0
    /// for a node never stamped, e.g. every node of a tree read from a file.
    #[pyo3(name = "getTimestamp")]
    fn get_timestamp(&self) -> u32 {
        self.timestamp
    }

    fn __repr__(&self) -> String {
        format!(
            "OcTreeNodeStamped(log_odds={}, depth={}, timestamp={})",
            self.value, self.depth, self.timestamp
        )
    }
}

/// OctoMap's ``OcTreeStamped``: an occupancy octree whose nodes also carry the time (whole
/// seconds, OctoMap's ``unsigned int``) of their last update, so a long-running robot can
/// forget obstacles it has not seen for a while (``degradeOutdatedNodes``).
///
/// ``OcTreeStamped(resolution)`` makes an empty tree; ``OcTreeStamped(filename)`` reads a
/// ``.ot`` file of type OcTreeStamped (str, bytes or os.PathLike, or the bytes ``write()``
/// returned). OctoMap's stamp rules hold: an update stamps the voxel and, eagerly, the inner
/// nodes on its way; equal-valued leaves with different stamps are not pruned. OctoMap reads
/// the clock (``time(NULL)``) inside each stamping call; here each of them also takes
/// ``now=`` (seconds) to stamp with a given time instead, for replays and tests. ``.ot`` files
/// hold no stamps (as OctoMap's): a tree read back has every stamp 0.
#[pyclass(module = "octoquant", name = "OcTreeStamped")]
pub struct PyStampedOcTree {
    /// Boxed: the tree's blocks are cache-line aligned (64 bytes), more than Python's
    /// allocator guarantees for the object that holds it.
    tree: Box<StampedOcTree>,
    /// The query box of ``insertPointCloud`` (``setBBXMin``, ``useBBXLimit``, ...).
    bbx: Bbx,
}

/// A time in whole seconds as OctoMap stores it (`unsigned int`): ValueError naming `name`
/// for anything outside 0 ..= 4294967295.
pub(crate) fn seconds(v: i64, name: &str) -> PyResult<u32> {
    u32::try_from(v).map_err(|_| {
        PyValueError::new_err(format!(
            "{name} must be whole seconds in 0 ..= 4294967295, got {v}"
        ))
    })
}

/// The time a stamping call uses: `now` when given (checked), else the system clock as
/// OctoMap reads it.
fn clock(now: Option<i64>) -> PyResult<u32> {
    match now {
        Some(t) => seconds(t, "now"),
        None => Ok(engine::now_seconds()),
    }
}

impl PyStampedOcTree {
    /// A Python object for `tree`.
    pub(crate) fn wrap(tree: StampedOcTree) -> Self {
        PyStampedOcTree {
            tree: Box::new(tree),
            bbx: Bbx::default(),
        }
    }

    fn load(py: Python<'_>, obj: &Bound<'_, PyAny>) -> PyResult<StampedOcTree> {
        let (data, name) = source(obj, "filename")?.bytes()?;
        py.detach(|| engine::read_stamped_ot(&data))
            .map_err(|e| convert::value_error(&name, &e))
    }

    /// The key of a key-or-point argument (points as `float32`, like octomap-python's
    /// `point3d`); `None` outside the map.
    fn key_of(&self, value: &Bound<'_, PyAny>) -> PyResult<Option<Key>> {
        Ok(match target(value, "value")? {
            Target::Key(k) => Some(k),
            Target::Point(p) => self
                .tree
                .converter()
                .point_to_key(&p.cast::<f32>().cast::<f64>()),
        })
    }

    /// The node `search` finds at `key` down to `depth` (0 = 16), with its stamp.
    fn node_at(&self, key: Key, depth: u8) -> Option<PyStampedNode> {
        let n = self.tree.search(key, depth)?;
        Some(PyStampedNode::found(n.node, key, n.timestamp))
    }

    /// An iterator over `items` of this tree with their stamps.
    fn stamped(&self, py: Python<'_>, items: Vec<NodeItem>, d: u8) -> IteratorBase {
        let tree = &self.tree;
        let stamps = py.detach(|| {
            items
                .iter()
                .map(|n| stamp_of_item(tree, n))
                .collect::<Vec<u32>>()
        });
        IteratorBase::with_stamps(items, stamps, tree.converter().clone(), d)
    }

    fn empty_iterator(&self) -> IteratorBase {
        IteratorBase::with_stamps(
            Vec::new(),
            Vec::new(),
            self.tree.converter().clone(),
            TREE_DEPTH,
        )
    }
}

/// The stamp of an iterated node (the root's is the last update time: `search` reads a depth
/// of 0 as 16).
fn stamp_of_item(tree: &StampedOcTree, n: &NodeItem) -> u32 {
    if n.depth == 0 {
        tree.last_update_time()
    } else {
        tree.search(n.key, n.depth).map_or(0, |s| s.timestamp)
    }
}

#[pymethods]
impl PyStampedOcTree {
    #[new]
    fn py_new(py: Python<'_>, arg: &Bound<'_, PyAny>) -> PyResult<Self> {
        let is_number = arg.extract::<f64>().is_ok()
            && arg.cast::<pyo3::types::PyString>().is_err()
            && arg.cast::<PyBytes>().is_err();
        let tree = if is_number {
            StampedOcTree::new(arg.extract()?)
                .map_err(|e| convert::value_error("OcTreeStamped", &e))?
        } else {
            Self::load(py, arg)?
        };
        Ok(Self::wrap(tree))
    }

    /// Read an OcTreeStamped from a ``.ot`` file or the bytes ``write()`` returned (every
    /// stamp 0: the format holds none). Raises OSError (FileNotFoundError, ...) or ValueError
    /// (damaged file, another tree type such as OcTree or ColorOcTree, a ``.bt`` file).
    #[staticmethod]
    fn read(py: Python<'_>, filename: &Bound<'_, PyAny>) -> PyResult<Self> {
        Ok(Self::wrap(Self::load(py, filename)?))
    }

    /// ``.ot`` bytes of the tree (every node's log-odds under ``id OcTreeStamped``, as
    /// OctoMap writes them: no stamps), or write them to ``filename`` and return True.
    #[pyo3(signature = (filename=None))]
    fn write<'py>(
        &self,
        py: Python<'py>,
        filename: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let tree = &self.tree;
        let data = py
            .detach(|| engine::write_stamped_ot(tree))
            .map_err(|e| PyOSError::new_err(e.to_string()))?;
        bytes_or_true(py, data, filename)
    }

    /// ``b"OcTreeStamped"``.
    #[pyo3(name = "getTreeType")]
    fn get_tree_type<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        PyBytes::new(py, b"OcTreeStamped")
    }

    /// The leaf edge length in metres.
    #[pyo3(name = "getResolution")]
    fn get_resolution(&self) -> f64 {
        self.tree.resolution()
    }

    /// Number of nodes, inner and leaves.
    fn size(&self) -> usize {
        self.tree.size()
    }

    /// Number of leaves.
    #[pyo3(name = "getNumLeafNodes")]
    fn get_num_leaf_nodes(&self) -> usize {
        self.tree.occupancy().num_leaves()
    }

    /// Remove every node (the resolution and sensor model stay).
    fn clear(&mut self) {
        self.tree.clear();
    }

    /// The root's stamp (OctoMap's ``getLastUpdateTime``): the time of the last eager update
    /// anywhere in the tree; 0 for an empty tree or one read from a file.
    #[pyo3(name = "getLastUpdateTime")]
    fn get_last_update_time(&self) -> u32 {
        self.tree.last_update_time()
    }

    /// Integrate one observation of the voxel at ``value`` (OcTreeKey or point) at time
    /// ``now`` (seconds; default the system clock): ``update`` True = hit, False = miss, a
    /// float = log-odds delta. The voxel gets the time, and so does every inner node on its
    /// way unless ``lazy_eval``. An update that cannot change the voxel (already at the clamp
    /// it pushes towards) stamps nothing, as in OctoMap. Returns the updated node, or None
    /// for a point outside the map.
    #[pyo3(name = "updateNode", signature = (value, update, lazy_eval=false, *, now=None))]
    fn update_node(
        &mut self,
        value: &Bound<'_, PyAny>,
        update: &Bound<'_, PyAny>,
        lazy_eval: bool,
        now: Option<i64>,
    ) -> PyResult<Option<PyStampedNode>> {
        let u = update_arg(update)?;
        let now = clock(now)?;
        let Some(key) = self.key_of(value)? else {
            return Ok(None);
        };
        self.tree
            .update_node_at(key, u, InnerNodes::from_lazy(lazy_eval), now);
        Ok(self.node_at(key, TREE_DEPTH))
    }

    /// Integrate a scan at time ``now`` (seconds; default the system clock), as OctoMap's
    /// ``insertPointCloud`` on an ``OcTreeStamped``: ``pointcloud`` (N, 3) end points and the
    /// sensor ``origin`` in the map frame; a miss on every free voxel, then a hit on every
    /// occupied one, each voxel once per scan, every update stamped ``now`` (and, unless
    /// ``lazy_eval``, the inner nodes on its way). ``maxrange`` < 0: no limit;
    /// ``discretize``: one ray per end-point voxel. NaN/inf points are skipped. Releases the
    /// GIL.
    #[pyo3(
        name = "insertPointCloud",
        signature = (pointcloud, origin, maxrange=-1.0, lazy_eval=false, discretize=false, *, now=None)
    )]
    #[allow(clippy::too_many_arguments)]
    fn insert_point_cloud(
        &mut self,
        py: Python<'_>,
        pointcloud: &Bound<'_, PyAny>,
        origin: &Bound<'_, PyAny>,
        maxrange: f64,
        lazy_eval: bool,
        discretize: bool,
        now: Option<i64>,
    ) -> PyResult<()> {
        let (points, origin) = convert::scan_args(pointcloud, origin, maxrange)?;
        let now = clock(now)?;
        let max_range = (maxrange >= 0.0).then_some(maxrange);
        let (tree, bbx) = (&mut self.tree, self.bbx);
        py.detach(|| {
            if bbx.enabled {
                let (free, occupied) = bbx::sorted_sets(
                    tree.converter(),
                    &bbx,
                    &points,
                    &origin,
                    maxrange,
                    discretize,
                );
                let inner = InnerNodes::from_lazy(lazy_eval);
                tree.insert_update_at(free, occupied, inner, now);
            } else {
                engine::insert_stamped_point_cloud(
                    tree, &points, &origin, max_range, lazy_eval, discretize, now,
                )
            }
        });
        Ok(())
    }

    /// The node holding ``value`` (an OcTreeKey or a point), descending at most to ``depth``
    /// (0 = 16), with its stamp: the node, the pruned leaf covering it, or None in unknown
    /// space.
    #[pyo3(signature = (value, depth=0))]
    fn search(&self, value: &Bound<'_, PyAny>, depth: i64) -> PyResult<Option<PyStampedNode>> {
        let d = convert::depth(depth, "depth")?;
        Ok(self.key_of(value)?.and_then(|k| self.node_at(k, d)))
    }

    /// The root node, or None for an empty tree.
    #[pyo3(name = "getRoot")]
    fn get_root(&self) -> Option<PyStampedNode> {
        let key = Key::new(32768, 32768, 32768);
        let info = self.tree.occupancy().node_at_depth(key, 0)?;
        Some(PyStampedNode::found(
            info,
            key,
            self.tree.last_update_time(),
        ))
    }

    /// Forget stale obstacles (OctoMap's ``degradeOutdatedNodes``): every occupied leaf whose
    /// stamp is more than ``time_thres`` seconds before ``now`` (default the system clock;
    /// ``now - stamp`` in 32-bit unsigned arithmetic, as OctoMap's) gets one miss, clamped,
    /// keeping its stamp. Inner nodes are not refreshed (``updateInnerOccupancy`` does that),
    /// exactly as in OctoMap.
    #[pyo3(name = "degradeOutdatedNodes", signature = (time_thres, *, now=None))]
    fn degrade_outdated_nodes(
        &mut self,
        py: Python<'_>,
        time_thres: i64,
        now: Option<i64>,
    ) -> PyResult<()> {
        let time_thres = seconds(time_thres, "time_thres")?;
        let now = clock(now)?;
        let tree = &mut self.tree;
        py.detach(|| tree.degrade_outdated_nodes_at(time_thres, now));
        Ok(())
    }

    /// Whether a node is occupied under the current threshold.
    #[pyo3(name = "isNodeOccupied")]
    fn is_node_occupied(&self, node: &Bound<'_, PyAny>) -> PyResult<bool> {
        if let Ok(n) = node.cast::<PyStampedNode>() {
            return Ok(self.tree.params().is_occupied(n.get().value));
        }
        Ok(self.tree.params().is_occupied(node_value(node)?))
    }

    /// Bring every inner node up to date: log-odds to the max of its children, stamp to
    /// ``now`` (default the system clock), as OctoMap's ``updateInnerOccupancy``.
    #[pyo3(name = "updateInnerOccupancy", signature = (*, now=None))]
    fn update_inner_occupancy(&mut self, py: Python<'_>, now: Option<i64>) -> PyResult<()> {
        let now = clock(now)?;
        let tree = &mut self.tree;
        py.detach(|| tree.update_inner_occupancy_at(now));
        Ok(())
    }

    /// Set every node to the clamping bound on its side of the threshold (stamps stay).
    #[pyo3(name = "toMaxLikelihood")]
    fn max_likelihood(&mut self, py: Python<'_>) {
        let tree = &mut self.tree;
        py.detach(|| tree.to_max_likelihood());
    }

    /// Merge eight leaves with equal log-odds *and* equal stamps into their parent, which
    /// takes child 0's stamp (OctoMap's ``prune`` with ``OcTreeNodeStamped::operator==``).
    fn prune(&mut self, py: Python<'_>) {
        let tree = &mut self.tree;
        py.detach(|| tree.prune());
    }

    /// Expand every pruned node down to voxels; children take the parent's log-odds and
    /// stamp.
    /// An expansion that could not fit raises MemoryError before allocating anything
    /// (``max_nodes``: the most nodes it may add; as ``OcTree.expand``).
    #[pyo3(signature = (max_nodes=None))]
    fn expand(&mut self, py: Python<'_>, max_nodes: Option<u64>) -> PyResult<()> {
        let limit = crate::tree::expansion_limit(py, max_nodes)?;
        let tree = &mut self.tree;
        py.detach(|| tree.try_expand(limit))
            .map(drop)
            .map_err(crate::tree::expansion_error)
    }

    /// Delete the node at ``depth`` (0 = 16) holding ``value`` with its subtree
    /// (octomap-python's default depth is 1); the parent left with children is stamped with
    /// ``now`` (default the system clock). Returns OctoMap's value: True only when the tree
    /// was empty or is left without children.
    #[pyo3(name = "deleteNode", signature = (value, depth=1, *, now=None))]
    fn delete_node(
        &mut self,
        value: &Bound<'_, PyAny>,
        depth: i64,
        now: Option<i64>,
    ) -> PyResult<bool> {
        let d = convert::depth(depth, "depth")?;
        let now = clock(now)?;
        let Some(key) = self.key_of(value)? else {
            return Ok(false);
        };
        if self.tree.is_empty() {
            return Ok(true);
        }
        let deleted = self.tree.delete_node_at(key, d, now);
        Ok(deleted && self.tree.occupancy().nodes().nth(1).is_none())
    }

    /// Follow a ray from ``origin`` along ``direction`` to the first occupied voxel, as
    /// ``OcTree.castRay``: writes the centre of the voxel where it stopped into ``end`` (a
    /// float array of 3, changed in place) and returns True only for an occupied voxel; stops
    /// at unknown space unless ``ignoreUnknownCells``, and beyond ``maxRange`` when > 0.
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
            self.tree.occupancy(),
            origin,
            direction,
            end,
            ignoreUnknownCells,
            maxRange,
        )
    }

    /// Many casts at once, as ``OcTree.cast_rays``: ``(hit, ends)``, bool (N,) and float64
    /// (N, 3), NaN rows where the ray could not be cast.
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
            self.tree.occupancy(),
            origins,
            directions,
            ignore_unknown,
            max_range,
        )
    }

    /// Iterator over every node, inner ones too, down to ``maxDepth`` (0 = 16); its
    /// ``getTimestamp()`` gives each node's stamp.
    #[pyo3(signature = (maxDepth=0))]
    #[allow(non_snake_case)]
    fn begin_tree(&self, py: Python<'_>, maxDepth: i64) -> PyResult<Py<TreeIterator>> {
        let d = max_depth(convert::depth(maxDepth, "maxDepth")?);
        let items = iterator_items(py, self.tree.occupancy(), true, d);
        TreeIterator::create(py, self.stamped(py, items, d))
    }

    /// Iterator over the leaves, treating nodes at ``maxDepth`` (0 = 16) as leaves; its
    /// ``getTimestamp()`` gives each leaf's stamp.
    #[pyo3(signature = (maxDepth=0))]
    #[allow(non_snake_case)]
    fn begin_leafs(&self, py: Python<'_>, maxDepth: i64) -> PyResult<Py<LeafIterator>> {
        let d = max_depth(convert::depth(maxDepth, "maxDepth")?);
        let items = iterator_items(py, self.tree.occupancy(), false, d);
        LeafIterator::create(py, self.stamped(py, items, d))
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
        let d = max_depth(convert::depth(maxDepth, "maxDepth")?);
        let items = bbx_items(py, self.tree.occupancy(), bbx_min, bbx_max, d)?;
        LeafBbxIterator::create(py, self.stamped(py, items, d))
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
            "OcTreeStamped(resolution={}, size={}, last_update={})",
            self.tree.resolution(),
            self.tree.size(),
            self.tree.last_update_time()
        )
    }
}

surgery_api!(PyStampedOcTree);
occupancy_api!(PyStampedOcTree, StampedOcTree);

/// OctoMap's node surgery calls that return a node (the others come from `surgery_api!`).
#[pymethods]
impl PyStampedOcTree {
    /// Child ``idx`` (0..8) of a node with its stamp, or None when it does not exist.
    #[pyo3(name = "getNodeChild")]
    fn get_node_child(&self, node: &Bound<'_, PyAny>, idx: i64) -> PyResult<Option<PyStampedNode>> {
        let i = child_idx(idx)?;
        let (key, d) = live_node(&*self.tree, node)?;
        Ok(self
            .tree
            .node_child(key, d, i)
            .zip(OcTree::child_key(key, d, i))
            .map(|(c, k)| PyStampedNode::found(c.node, k, c.timestamp)))
    }

    /// Create child ``idx`` (0..8) of a node with log-odds 0 and stamp 0, as OctoMap's
    /// ``createNodeChild`` (no clock is read); returns it. ``ValueError`` when the child
    /// exists already or the node is a voxel.
    #[pyo3(name = "createNodeChild")]
    fn create_node_child(&mut self, node: &Bound<'_, PyAny>, idx: i64) -> PyResult<PyStampedNode> {
        let i = child_idx(idx)?;
        let (key, d) = live_node(&*self.tree, node)?;
        if d >= TREE_DEPTH {
            return Err(PyValueError::new_err(
                "createNodeChild: a voxel (depth 16) has no children",
            ));
        }
        let child = self.tree.create_node_child(key, d, i);
        let (c, k) = child.zip(OcTree::child_key(key, d, i)).ok_or_else(|| {
            PyValueError::new_err(format!("createNodeChild: child {i} exists already"))
        })?;
        Ok(PyStampedNode::found(c.node, k, c.timestamp))
    }
}

/// OctoMap's occupancy and stamp calls on a node in hand. OctoMap's nodes are pointers into
/// the tree; here a node (from ``search``, ``getRoot``, ``getNodeChild``, ...) names the node at
/// its key and depth, which must still be in the tree (``ValueError`` otherwise). Each call
/// returns what it left in the node; the node object, a snapshot, keeps its old values.
#[pymethods]
impl PyStampedOcTree {
    /// Add ``update`` to the node's log-odds and clamp the sum to the sensor model's bounds
    /// (no early exit at a clamp, no inner node refreshed), then stamp it with ``now``
    /// (default the system clock), as OctoMap's ``OcTreeStamped::updateNodeLogOdds``. Returns
    /// the new log-odds. ``ValueError`` when the sum is NaN.
    #[pyo3(name = "updateNodeLogOdds", signature = (node, update, *, now=None))]
    fn update_node_log_odds(
        &mut self,
        node: &Bound<'_, PyAny>,
        update: f32,
        now: Option<i64>,
    ) -> PyResult<f32> {
        self.log_odds_in_hand(node, engine::Update::LogOdds(update), now)
    }

    /// ``updateNodeLogOdds`` with the sensor model's hit (OctoMap's ``integrateHit``).
    #[pyo3(name = "integrateHit", signature = (node, *, now=None))]
    fn integrate_hit(&mut self, node: &Bound<'_, PyAny>, now: Option<i64>) -> PyResult<f32> {
        self.log_odds_in_hand(node, engine::Update::Hit, now)
    }

    /// ``updateNodeLogOdds`` with the sensor model's miss (OctoMap's ``integrateMiss``).
    #[pyo3(name = "integrateMiss", signature = (node, *, now=None))]
    fn integrate_miss(&mut self, node: &Bound<'_, PyAny>, now: Option<i64>) -> PyResult<f32> {
        self.log_odds_in_hand(node, engine::Update::Miss, now)
    }

    /// One miss on the node, clamped, its stamp kept (OctoMap's ``integrateMissNoTime``, what
    /// ``degradeOutdatedNodes`` gives each stale leaf). Returns the new log-odds.
    #[pyo3(name = "integrateMissNoTime")]
    fn integrate_miss_no_time(&mut self, node: &Bound<'_, PyAny>) -> PyResult<f32> {
        let (key, d) = live_node(&*self.tree, node)?;
        self.tree
            .integrate_miss_no_time(key, d)
            .ok_or_else(|| convert::not_in_tree(key, d))
    }

    /// Set the node to the clamping bound on its side of the threshold, its stamp kept
    /// (OctoMap's ``nodeToMaxLikelihood``). Returns the new log-odds.
    #[pyo3(name = "nodeToMaxLikelihood")]
    fn node_to_max_likelihood(&mut self, node: &Bound<'_, PyAny>) -> PyResult<f32> {
        let (key, d) = live_node(&*self.tree, node)?;
        self.tree
            .node_to_max_likelihood(key, d)
            .ok_or_else(|| convert::not_in_tree(key, d))
    }

    /// Set the node's stamp to ``timestamp`` whole seconds (OctoMap's
    /// ``node->setTimestamp(t)``; 0 is a node never stamped); nothing else changes, and a
    /// later prune compares the new stamp. Returns it.
    #[pyo3(name = "setNodeTimestamp")]
    fn set_node_timestamp(&mut self, node: &Bound<'_, PyAny>, timestamp: i64) -> PyResult<u32> {
        let t = seconds(timestamp, "timestamp")?;
        let (key, d) = live_node(&*self.tree, node)?;
        self.tree.set_timestamp(key, d, t);
        Ok(t)
    }

    /// Stamp the node with ``now`` (default the system clock: OctoMap's
    /// ``node->updateTimestamp()``). Returns the stamp.
    #[pyo3(name = "updateNodeTimestamp", signature = (node, *, now=None))]
    fn update_node_timestamp(
        &mut self,
        node: &Bound<'_, PyAny>,
        now: Option<i64>,
    ) -> PyResult<u32> {
        let t = clock(now)?;
        let (key, d) = live_node(&*self.tree, node)?;
        self.tree.set_timestamp(key, d, t);
        Ok(t)
    }
}

impl PyStampedOcTree {
    /// `updateNodeLogOdds` of `update` on the live node `node`, stamped `now`.
    fn log_odds_in_hand(
        &mut self,
        node: &Bound<'_, PyAny>,
        update: engine::Update,
        now: Option<i64>,
    ) -> PyResult<f32> {
        let now = clock(now)?;
        let (key, d) = live_node(&*self.tree, node)?;
        self.tree
            .update_node_log_odds_at(key, d, update, now)
            .map_err(|e| convert::value_error("updateNodeLogOdds", &e))?
            .ok_or_else(|| convert::not_in_tree(key, d))
    }
}

/// Copies (stamps included; pickling is not offered, as ``.ot`` files hold no stamps).
#[pymethods]
impl PyStampedOcTree {
    fn __copy__(&self) -> Self {
        PyStampedOcTree {
            tree: self.tree.clone(),
            bbx: self.bbx,
        }
    }

    fn __deepcopy__(&self, _memo: &Bound<'_, pyo3::types::PyDict>) -> Self {
        self.__copy__()
    }
}
