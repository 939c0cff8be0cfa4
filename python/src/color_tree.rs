//! `octoquant.ColorOcTree` and `ColorOcTreeNode`: octomap-python's `ColorOcTree` (same names,
//! signatures and `.ot` bytes) over the Rust library's colour tree.

use crate::bbx::{self, Bbx};
use crate::convert::{self, child_idx, source};
use crate::engine::{
    self, probability, Color, ColorOcTree, InnerNodes, Key, NodeInfo, NodeItem, OcTree,
    OccupancyParams, TREE_DEPTH,
};
use crate::iter::{
    max_depth, node_value, IteratorBase, LeafBbxIterator, LeafIterator, TreeIterator,
};
use crate::node::PyKey;
use crate::occupancy_api::{live_node, occupancy_api, surgery_api, OccupancyHost};
use crate::tree::{
    bbx_items, bytes_or_true, cast_ray_into, cast_rays_arrays, iterator_items, keys_arg, target,
    update_arg, CastArrays, Target,
};
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyBytes;

/// A node of a ColorOcTree as it was when it was looked up: occupancy, colour and the
/// average colour of its children (octomap-python's `ColorOcTreeNode` points into the live
/// tree instead). `setColor` writes through to the tree the node came from.
#[pyclass(module = "octoquant", name = "ColorOcTreeNode")]
pub struct PyColorNode {
    value: f32,
    has_children: bool,
    depth: u8,
    key: Key,
    color: Color,
    child_color: Color,
    tree: Py<PyColorOcTree>,
}

impl PyColorNode {
    /// Call the tree's `method` on this node with `arg`, then keep the log-odds it returns.
    fn write_through(slf: &Bound<'_, Self>, method: &str, arg: f32) -> PyResult<()> {
        let tree = slf.borrow().tree.clone_ref(slf.py());
        let v: f32 = tree
            .bind(slf.py())
            .call_method1(method, (slf, arg))?
            .extract()?;
        slf.borrow_mut().value = v;
        Ok(())
    }

    /// The node `info` found with `key` in `tree`, with its colours read from `t` (the same
    /// tree, borrowed).
    fn found(tree: Py<PyColorOcTree>, t: &ColorOcTree, info: NodeInfo, key: Key) -> Self {
        let key = if info.depth < TREE_DEPTH {
            key.at_depth(info.depth)
        } else {
            key
        };
        PyColorNode {
            value: info.value,
            has_children: info.has_children,
            depth: info.depth,
            key,
            color: t.color_at(key, info.depth).unwrap_or(Color::WHITE),
            child_color: t
                .average_child_color(key, info.depth)
                .unwrap_or(Color::WHITE),
            tree,
        }
    }
}

#[pymethods]
impl PyColorNode {
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

    /// The node's colour ``(r, g, b)``; white (255, 255, 255) when none was set.
    #[pyo3(name = "getColor")]
    fn get_color(&self) -> (u8, u8, u8) {
        (self.color.r, self.color.g, self.color.b)
    }

    /// Whether a colour was set: anything but white (OctoMap's ``isColorSet``).
    #[pyo3(name = "isColorSet")]
    fn is_color_set(&self) -> bool {
        self.color.is_set()
    }

    /// The mean colour of the node's children that have one, white when none has or the
    /// node has no children (OctoMap's ``getAverageChildColor``), as at lookup.
    #[pyo3(name = "getAverageChildColor")]
    fn get_average_child_color(&self) -> (u8, u8, u8) {
        (self.child_color.r, self.child_color.g, self.child_color.b)
    }

    /// Set the node's colour in its tree (inner nodes too). ValueError when the node is no
    /// longer in the tree (deleted, pruned away, or the tree cleared).
    #[pyo3(name = "setColor")]
    fn set_color(&mut self, py: Python<'_>, r: u8, g: u8, b: u8) -> PyResult<()> {
        let c = Color::new(r, g, b);
        let mut tree = self.tree.try_borrow_mut(py)?;
        if !tree.tree.set_color_at(self.key, self.depth, c) {
            return Err(PyValueError::new_err(format!(
                "the node (depth {}, key ({}, {}, {})) is no longer in its tree",
                self.depth, self.key[0], self.key[1], self.key[2]
            )));
        }
        self.color = c;
        Ok(())
    }

    /// Set the node's log-odds in its tree as OctoMap's ``setValue`` does on the live node:
    /// as given, no clamping, no inner node refreshed; its colour stays. ``ValueError`` for
    /// NaN or a node no longer in its tree.
    #[pyo3(name = "setValue")]
    fn set_value(slf: &Bound<'_, Self>, v: f32) -> PyResult<()> {
        Self::write_through(slf, "_set_node_value", v)
    }

    /// Same as ``setValue``.
    #[pyo3(name = "setLogOdds")]
    fn set_log_odds(slf: &Bound<'_, Self>, v: f32) -> PyResult<()> {
        Self::write_through(slf, "_set_node_value", v)
    }

    /// Add ``p`` to the node's log-odds in its tree (OctoMap's ``addValue``: no clamping).
    #[pyo3(name = "addValue")]
    fn add_value(slf: &Bound<'_, Self>, p: f32) -> PyResult<()> {
        Self::write_through(slf, "_add_node_value", p)
    }

    /// Whether child ``i`` (0..8) of the node exists now in its tree.
    #[pyo3(name = "childExists")]
    fn child_exists(slf: &Bound<'_, Self>, i: i64) -> PyResult<bool> {
        let tree = slf.borrow().tree.clone_ref(slf.py());
        tree.bind(slf.py())
            .call_method1("nodeChildExists", (slf, i))?
            .extract()
    }

    fn __repr__(&self) -> String {
        format!(
            "ColorOcTreeNode(log_odds={}, depth={}, color=({}, {}, {}))",
            self.value, self.depth, self.color.r, self.color.g, self.color.b
        )
    }
}

/// OctoMap's ``ColorOcTree``: an occupancy octree whose nodes also carry an RGB colour.
///
/// ``ColorOcTree(resolution)`` makes an empty tree; ``ColorOcTree(filename)`` reads a ``.ot``
/// file of type ColorOcTree (str, bytes or os.PathLike, or the bytes ``write()`` returned).
/// Method names and results follow octomap-python; ``write()`` bytes are identical to
/// OctoMap's for the same calls. Nodes are white (no colour) until ``setNodeColor``,
/// ``averageNodeColor`` or ``integrateNodeColor`` gives them one.
#[pyclass(module = "octoquant", name = "ColorOcTree")]
pub struct PyColorOcTree {
    /// Boxed: the tree's blocks are cache-line aligned (64 bytes), more than Python's
    /// allocator guarantees for the object that holds it.
    tree: Box<ColorOcTree>,
    /// The query box of ``insertPointCloud`` (``setBBXMin``, ``useBBXLimit``, ...).
    bbx: Bbx,
}

impl PyColorOcTree {
    /// A Python object for `tree`.
    pub(crate) fn wrap(tree: ColorOcTree) -> Self {
        PyColorOcTree {
            tree: Box::new(tree),
            bbx: Bbx::default(),
        }
    }

    fn load(py: Python<'_>, obj: &Bound<'_, PyAny>) -> PyResult<ColorOcTree> {
        let (data, name) = source(obj, "filename")?.bytes()?;
        py.detach(|| engine::read_color_ot(&data))
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

    /// The node `search` finds at `key` down to `depth`, as a Python node of `slf`.
    fn node_at(slf: &Bound<'_, Self>, key: Key, depth: u8) -> Option<PyColorNode> {
        let this = slf.borrow();
        let info = this.tree.occupancy().search(key, depth)?;
        Some(PyColorNode::found(
            slf.clone().unbind(),
            &this.tree,
            info,
            key,
        ))
    }

    fn color_op(
        slf: &Bound<'_, Self>,
        value: &Bound<'_, PyAny>,
        color: Color,
        op: fn(&mut ColorOcTree, Key, Color) -> Option<Color>,
    ) -> PyResult<Option<PyColorNode>> {
        let Some(key) = slf.borrow().key_of(value)? else {
            return Ok(None);
        };
        op(&mut slf.borrow_mut().tree, key, color);
        Ok(Self::node_at(slf, key, TREE_DEPTH))
    }

    /// An iterator over `items` of this tree with their colours.
    fn colored(&self, py: Python<'_>, items: Vec<NodeItem>, d: u8) -> IteratorBase {
        let tree = &self.tree;
        let colors = py.detach(|| {
            items
                .iter()
                .map(|n| tree.color_at(n.key, n.depth).unwrap_or(Color::WHITE))
                .collect()
        });
        IteratorBase::with_colors(items, colors, tree.converter().clone(), d)
    }

    fn empty_iterator(&self) -> IteratorBase {
        IteratorBase::with_colors(
            Vec::new(),
            Vec::new(),
            self.tree.converter().clone(),
            TREE_DEPTH,
        )
    }
}

#[pymethods]
impl PyColorOcTree {
    #[new]
    fn py_new(py: Python<'_>, arg: &Bound<'_, PyAny>) -> PyResult<Self> {
        let is_number = arg.extract::<f64>().is_ok()
            && arg.cast::<pyo3::types::PyString>().is_err()
            && arg.cast::<PyBytes>().is_err();
        let tree = if is_number {
            ColorOcTree::new(arg.extract()?).map_err(|e| convert::value_error("ColorOcTree", &e))?
        } else {
            Self::load(py, arg)?
        };
        Ok(Self::wrap(tree))
    }

    /// Read a ColorOcTree from a ``.ot`` file or the bytes ``write()`` returned. Raises
    /// OSError (FileNotFoundError, ...) or ValueError (damaged file, other tree type).
    #[staticmethod]
    fn read(py: Python<'_>, filename: &Bound<'_, PyAny>) -> PyResult<Self> {
        Ok(Self::wrap(Self::load(py, filename)?))
    }

    /// ``.ot`` bytes of the tree (every node's log-odds and colour), or write them to
    /// ``filename`` and return True.
    #[pyo3(signature = (filename=None))]
    fn write<'py>(
        &self,
        py: Python<'py>,
        filename: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let tree = &self.tree;
        let data = py
            .detach(|| engine::write_color_ot(tree))
            .map_err(|e| PyOSError::new_err(e.to_string()))?;
        bytes_or_true(py, data, filename)
    }

    /// ``b"ColorOcTree"``.
    #[pyo3(name = "getTreeType")]
    fn get_tree_type<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        PyBytes::new(py, b"ColorOcTree")
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

    /// Integrate one observation of the voxel at ``value`` (OcTreeKey or point): ``update``
    /// True = hit, False = miss, a float = log-odds delta. Returns the updated node, or None
    /// for a point outside the map.
    #[pyo3(name = "updateNode", signature = (value, update, lazy_eval=false))]
    fn update_node(
        slf: &Bound<'_, Self>,
        value: &Bound<'_, PyAny>,
        update: &Bound<'_, PyAny>,
        lazy_eval: bool,
    ) -> PyResult<Option<PyColorNode>> {
        let u = update_arg(update)?;
        let Some(key) = slf.borrow().key_of(value)? else {
            return Ok(None);
        };
        slf.borrow_mut()
            .tree
            .update_node(key, u, InnerNodes::from_lazy(lazy_eval));
        Ok(Self::node_at(slf, key, TREE_DEPTH))
    }

    /// The node holding ``value`` (an OcTreeKey or a point), descending at most to ``depth``
    /// (0 = 16): the node, the pruned leaf covering it, or None in unknown space.
    #[pyo3(signature = (value, depth=0))]
    fn search(
        slf: &Bound<'_, Self>,
        value: &Bound<'_, PyAny>,
        depth: i64,
    ) -> PyResult<Option<PyColorNode>> {
        let d = convert::depth(depth, "depth")?;
        let key = slf.borrow().key_of(value)?;
        Ok(key.and_then(|k| Self::node_at(slf, k, d)))
    }

    /// The root node, or None for an empty tree.
    #[pyo3(name = "getRoot")]
    fn get_root(slf: &Bound<'_, Self>) -> Option<PyColorNode> {
        let this = slf.borrow();
        let key = Key::new(32768, 32768, 32768);
        let info = this.tree.occupancy().node_at_depth(key, 0)?;
        Some(PyColorNode::found(
            slf.clone().unbind(),
            &this.tree,
            info,
            key,
        ))
    }

    /// Set the colour of the node holding ``value``, replacing the old one. Returns the node,
    /// or None (and no change) in unknown space.
    #[pyo3(name = "setNodeColor")]
    fn set_node_color(
        slf: &Bound<'_, Self>,
        value: &Bound<'_, PyAny>,
        r: u8,
        g: u8,
        b: u8,
    ) -> PyResult<Option<PyColorNode>> {
        Self::color_op(slf, value, Color::new(r, g, b), ColorOcTree::set_node_color)
    }

    /// Average ``(r, g, b)`` into the node's colour (integer mean per channel; the colour
    /// itself when the node had none). Returns the node, or None in unknown space.
    #[pyo3(name = "averageNodeColor")]
    fn average_node_color(
        slf: &Bound<'_, Self>,
        value: &Bound<'_, PyAny>,
        r: u8,
        g: u8,
        b: u8,
    ) -> PyResult<Option<PyColorNode>> {
        Self::color_op(
            slf,
            value,
            Color::new(r, g, b),
            ColorOcTree::average_node_color,
        )
    }

    /// Integrate ``(r, g, b)`` weighted by the node's occupancy ``p``:
    /// ``old·p + new·(0.99 − p)`` per channel (the colour itself when the node had none).
    /// Returns the node, or None in unknown space.
    #[pyo3(name = "integrateNodeColor")]
    fn integrate_node_color(
        slf: &Bound<'_, Self>,
        value: &Bound<'_, PyAny>,
        r: u8,
        g: u8,
        b: u8,
    ) -> PyResult<Option<PyColorNode>> {
        Self::color_op(
            slf,
            value,
            Color::new(r, g, b),
            ColorOcTree::integrate_node_color,
        )
    }

    /// Whether a node is occupied under the current threshold.
    #[pyo3(name = "isNodeOccupied")]
    fn is_node_occupied(&self, node: &Bound<'_, PyAny>) -> PyResult<bool> {
        if let Ok(n) = node.cast::<PyColorNode>() {
            return Ok(self.tree.params().is_occupied(n.borrow().value));
        }
        Ok(self.tree.params().is_occupied(node_value(node)?))
    }

    /// Bring inner nodes up to date: occupancy to the max of the children, colour to the
    /// average of the children that have one.
    #[pyo3(name = "updateInnerOccupancy")]
    fn update_inner_occupancy(&mut self, py: Python<'_>) {
        let tree = &mut self.tree;
        py.detach(|| tree.update_inner_occupancy());
    }

    /// Set every node to the clamping bound on its side of the threshold (colours stay).
    #[pyo3(name = "toMaxLikelihood")]
    fn max_likelihood(&mut self, py: Python<'_>) {
        let tree = &mut self.tree;
        py.detach(|| tree.to_max_likelihood());
    }

    /// Merge eight equal-occupancy leaves into their parent (colours do not stop a merge; the
    /// parent takes child 0's colour, or the children's average when child 0 has one).
    fn prune(&mut self, py: Python<'_>) {
        let tree = &mut self.tree;
        py.detach(|| tree.prune());
    }

    /// Expand every pruned node down to voxels; children take the parent's colour.
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
    /// ``getColor()`` gives each node's colour.
    #[pyo3(signature = (maxDepth=0))]
    #[allow(non_snake_case)]
    fn begin_tree(&self, py: Python<'_>, maxDepth: i64) -> PyResult<Py<TreeIterator>> {
        let d = max_depth(convert::depth(maxDepth, "maxDepth")?);
        let items = iterator_items(py, self.tree.occupancy(), true, d);
        TreeIterator::create(py, self.colored(py, items, d))
    }

    /// Iterator over the leaves, treating nodes at ``maxDepth`` (0 = 16) as leaves.
    #[pyo3(signature = (maxDepth=0))]
    #[allow(non_snake_case)]
    fn begin_leafs(&self, py: Python<'_>, maxDepth: i64) -> PyResult<Py<LeafIterator>> {
        let d = max_depth(convert::depth(maxDepth, "maxDepth")?);
        let items = iterator_items(py, self.tree.occupancy(), false, d);
        LeafIterator::create(py, self.colored(py, items, d))
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
        LeafBbxIterator::create(py, self.colored(py, items, d))
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

    /// Delete the node at ``depth`` (0 = 16) holding ``value`` with its subtree
    /// (octomap-python's default depth is 1). Returns OctoMap's value: True only when the
    /// tree was empty or is left without children.
    #[pyo3(name = "deleteNode", signature = (value, depth=1))]
    fn delete_node(&mut self, value: &Bound<'_, PyAny>, depth: i64) -> PyResult<bool> {
        let d = convert::depth(depth, "depth")?;
        let Some(key) = self.key_of(value)? else {
            return Ok(false);
        };
        if self.tree.is_empty() {
            return Ok(true);
        }
        let deleted = self.tree.delete_node(key, d);
        Ok(deleted && self.tree.occupancy().nodes().nth(1).is_none())
    }
}

surgery_api!(PyColorOcTree);
occupancy_api!(PyColorOcTree, ColorOcTree);

impl PyColorOcTree {
    /// A Python node of `slf` for the node `info` at `key`.
    fn node_of(slf: &Bound<'_, Self>, info: NodeInfo, key: Key) -> PyColorNode {
        PyColorNode::found(slf.clone().unbind(), &slf.borrow().tree, info, key)
    }
}

/// octomap-python's `ColorOcTree` calls from `OccupancyOcTreeBase` and `OcTreeBaseImpl`:
/// scans, batches, node surgery and `.bt` files.
#[pymethods]
impl PyColorOcTree {
    /// Integrate a scan as OctoMap's ``insertPointCloud`` does on a ``ColorOcTree``:
    /// ``pointcloud`` (N, 3) end points and the sensor ``origin`` in the map frame; a miss on
    /// every free voxel, then a hit on every occupied one, each voxel once per scan, in the
    /// order of OctoMap's key sets (colours move with the tree's structure, so the order
    /// matters: a node pruned and expanded again hands its children the average colour). No
    /// colour is set. ``maxrange`` < 0: no limit; ``lazy_eval``: skip inner-node upkeep;
    /// ``discretize``: one ray per end-point voxel; with ``useBBXLimit(True)``, only the box's
    /// voxels. NaN/inf points are skipped. Releases the GIL.
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
        let (tree, bbx) = (&mut self.tree, self.bbx);
        py.detach(|| {
            if bbx.enabled {
                let (free, occupied) = bbx::key_sequences(
                    tree.converter(),
                    &bbx,
                    &points,
                    &origin,
                    maxrange,
                    discretize,
                );
                engine::update_color_key_sets(tree, &free, &occupied, lazy_eval);
            } else {
                let max_range = (maxrange >= 0.0).then_some(maxrange);
                engine::insert_color_point_cloud(
                    tree, &points, &origin, max_range, lazy_eval, discretize,
                );
            }
        });
        Ok(())
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
        let inner = InnerNodes::from_lazy(lazy_eval);
        py.detach(|| tree.update_keys(&keys, u, inner));
        Ok(())
    }

    /// Replace this tree by a ``.bt`` file (or ``.bt`` bytes): the occupancy and resolution of
    /// the file, every node white; the sensor model is kept. Returns True; raises OSError or
    /// ValueError instead of returning False.
    #[pyo3(name = "readBinary")]
    fn read_binary(&mut self, py: Python<'_>, filename: &Bound<'_, PyAny>) -> PyResult<bool> {
        let (data, name) = source(filename, "filename")?.bytes()?;
        let mut tree = py
            .detach(|| engine::read_bt(&data))
            .map_err(|e| convert::value_error(&name, &e))?;
        tree.set_params(*self.tree.params());
        *self.tree = ColorOcTree::from_occupancy(tree);
        Ok(true)
    }

    /// ``.bt`` bytes of the tree's occupancy (no colours), or write them to ``filename`` and
    /// return True. Like OctoMap, converts the tree to max-likelihood and prunes it first
    /// (with the colour rules).
    #[pyo3(name = "writeBinary", signature = (filename=None))]
    fn write_binary<'py>(
        &mut self,
        py: Python<'py>,
        filename: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let tree = &mut self.tree;
        let data = py
            .detach(|| engine::write_color_bt(tree))
            .map_err(|e| PyOSError::new_err(e.to_string()))?;
        bytes_or_true(py, data, filename)
    }

    /// Child ``idx`` (0..8) of a node with its colour, or None when it does not exist.
    #[pyo3(name = "getNodeChild")]
    fn get_node_child(
        slf: &Bound<'_, Self>,
        node: &Bound<'_, PyAny>,
        idx: i64,
    ) -> PyResult<Option<PyColorNode>> {
        let i = child_idx(idx)?;
        let (key, d) = live_node(&*slf.borrow().tree, node)?;
        let child = slf.borrow().tree.node_child(key, d, i);
        Ok(child
            .zip(OcTree::child_key(key, d, i))
            .map(|(c, k)| Self::node_of(slf, c.node, k)))
    }

    /// Create child ``idx`` (0..8) of a node with log-odds 0 and no colour, as OctoMap's
    /// ``createNodeChild``; returns it. ``ValueError`` when the child exists already or the
    /// node is a voxel.
    #[pyo3(name = "createNodeChild")]
    fn create_node_child(
        slf: &Bound<'_, Self>,
        node: &Bound<'_, PyAny>,
        idx: i64,
    ) -> PyResult<PyColorNode> {
        let i = child_idx(idx)?;
        let (key, d) = live_node(&*slf.borrow().tree, node)?;
        if d >= TREE_DEPTH {
            return Err(PyValueError::new_err(
                "createNodeChild: a voxel (depth 16) has no children",
            ));
        }
        let child = slf.borrow_mut().tree.create_node_child(key, d, i);
        let (c, k) = child.zip(OcTree::child_key(key, d, i)).ok_or_else(|| {
            PyValueError::new_err(format!("createNodeChild: child {i} exists already"))
        })?;
        Ok(Self::node_of(slf, c.node, k))
    }

    fn __copy__(&self) -> Self {
        PyColorOcTree {
            tree: self.tree.clone(),
            bbx: self.bbx,
        }
    }

    fn __deepcopy__(&self, _memo: &Bound<'_, pyo3::types::PyDict>) -> Self {
        self.__copy__()
    }

    /// Pickling: the ``.ot`` bytes (occupancy and colours) and the sensor model.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyTuple>> {
        let tree = &self.tree;
        let data = py
            .detach(|| engine::write_color_ot(tree))
            .map_err(|e| PyOSError::new_err(e.to_string()))?;
        let p = self.tree.params();
        let restore = py
            .import("octoquant._octoquant")?
            .getattr("_restore_color")?;
        let args = (
            PyBytes::new(py, &data),
            p.hit,
            p.miss,
            p.clamp_min,
            p.clamp_max,
            p.occupancy_threshold,
        );
        pyo3::types::PyTuple::new(py, [restore.into_any(), args.into_pyobject(py)?.into_any()])
    }
}

/// Unpickling a ``ColorOcTree``: the tree from its `.ot` bytes and its sensor model (log-odds).
#[pyfunction]
pub fn _restore_color(
    py: Python<'_>,
    data: &[u8],
    hit: f32,
    miss: f32,
    clamp_min: f32,
    clamp_max: f32,
    threshold: f32,
) -> PyResult<PyColorOcTree> {
    let mut tree = py
        .detach(|| engine::read_color_ot(data))
        .map_err(|e| convert::value_error("pickled ColorOcTree", &e))?;
    tree.set_params(OccupancyParams {
        hit,
        miss,
        clamp_min,
        clamp_max,
        occupancy_threshold: threshold,
    });
    Ok(PyColorOcTree::wrap(tree))
}
