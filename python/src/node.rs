//! `OcTreeKey` and `OcTreeNode`, octomap-python's key and node objects.

use crate::engine::{probability, Key, NodeInfo};
use pyo3::exceptions::{PyIndexError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyTuple;

/// A voxel address: three 16-bit indices counting cells from the map's corner (octomap's
/// `OcTreeKey`). Index it like a sequence: ``key[0]``, ``key[1] = 7``.
#[pyclass(module = "octoquant", name = "OcTreeKey")]
#[derive(Clone, Copy)]
pub struct PyKey {
    pub key: Key,
}

impl PyKey {
    /// Wrap a library key.
    pub fn new(key: Key) -> Self {
        PyKey { key }
    }
}

fn axis(i: isize) -> PyResult<usize> {
    match i {
        0..=2 => Ok(i as usize),
        -3..=-1 => Ok((i + 3) as usize),
        _ => Err(PyIndexError::new_err("OcTreeKey index out of range (0..3)")),
    }
}

#[pymethods]
impl PyKey {
    /// A key; all axes 0 unless given.
    #[new]
    #[pyo3(signature = (k0=0, k1=0, k2=0))]
    fn py_new(k0: u16, k1: u16, k2: u16) -> Self {
        PyKey::new(Key::new(k0, k1, k2))
    }

    fn __getitem__(&self, i: isize) -> PyResult<u16> {
        Ok(self.key[axis(i)?])
    }

    fn __setitem__(&mut self, i: isize, value: u16) -> PyResult<()> {
        self.key[axis(i)?] = value;
        Ok(())
    }

    fn __len__(&self) -> usize {
        3
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        (0..3).all(|i| {
            other
                .get_item(i)
                .and_then(|v| v.extract::<u16>())
                .is_ok_and(|v| v == self.key[i])
        })
    }

    fn __ne__(&self, other: &Bound<'_, PyAny>) -> bool {
        !self.__eq__(other)
    }

    fn __hash__(&self) -> u64 {
        self.key.morton()
    }

    fn __repr__(&self) -> String {
        format!(
            "OcTreeKey({}, {}, {})",
            self.key[0], self.key[1], self.key[2]
        )
    }

    fn __getnewargs__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        PyTuple::new(py, self.key.0)
    }
}

/// A key argument: an `OcTreeKey` or any sequence of three integers in 0..65535.
pub fn key_arg(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Key> {
    if let Ok(k) = obj.cast::<PyKey>() {
        return Ok(k.borrow().key);
    }
    let v: Vec<u16> = obj.extract().map_err(|_| {
        PyTypeError::new_err(format!(
            "{name} must be an OcTreeKey or 3 integers in 0..65535"
        ))
    })?;
    match v[..] {
        [a, b, c] => Ok(Key::new(a, b, c)),
        _ => Err(PyTypeError::new_err(format!(
            "{name} must have 3 elements, got {}",
            v.len()
        ))),
    }
}

/// A node of the tree as it was when it was looked up (octomap-python's `OcTreeNode` points
/// into the live tree instead; see the migration notes). Its setters (`setValue`,
/// `setLogOdds`, `addValue`) write through to the node of its tree by key and depth.
#[pyclass(module = "octoquant", name = "OcTreeNode")]
pub struct PyNode {
    /// The node's log-odds.
    pub value: f32,
    /// Whether it had children.
    pub has_children: bool,
    /// Its depth (0 root .. 16 voxel).
    pub depth: u8,
    /// Its key at that depth (the voxel key at depth 16).
    pub key: Key,
    /// The tree it came from, for the setters (any tree class with `_set_node_value`).
    pub tree: Option<Py<PyAny>>,
}

impl PyNode {
    /// A node from a search result and the key it was searched with, in `tree`.
    pub fn found(info: NodeInfo, key: Key, tree: Option<Py<PyAny>>) -> Self {
        PyNode {
            value: info.value,
            has_children: info.has_children,
            depth: info.depth,
            key: if info.depth < 16 {
                key.at_depth(info.depth)
            } else {
                key
            },
            tree,
        }
    }

    /// The tree the node came from.
    fn tree_of(slf: &Bound<'_, Self>) -> PyResult<Py<PyAny>> {
        slf.borrow()
            .tree
            .as_ref()
            .map(|t| t.clone_ref(slf.py()))
            .ok_or_else(|| PyValueError::new_err("the node belongs to no tree"))
    }

    /// Call the tree's `method` on this node with `arg`, then keep the log-odds it returns.
    fn write_through(slf: &Bound<'_, Self>, method: &str, arg: f32) -> PyResult<()> {
        let tree = Self::tree_of(slf)?;
        let v: f32 = tree
            .bind(slf.py())
            .call_method1(method, (slf, arg))?
            .extract()?;
        slf.borrow_mut().value = v;
        Ok(())
    }
}

#[pymethods]
impl PyNode {
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

    /// Set the node's log-odds in its tree as OctoMap's ``setValue`` does on the live node:
    /// as given, no clamping, no inner node refreshed (``updateInnerOccupancy`` does that).
    /// ``ValueError`` for NaN or a node no longer in its tree.
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
        let tree = Self::tree_of(slf)?;
        tree.bind(slf.py())
            .call_method1("nodeChildExists", (slf, i))?
            .extract()
    }

    fn __repr__(&self) -> String {
        format!(
            "OcTreeNode(log_odds={}, depth={}, has_children={})",
            self.value,
            self.depth,
            if self.has_children { "True" } else { "False" }
        )
    }
}

/// The key and depth of a node argument (an `OcTreeNode`), for the per-node calls; `None`
/// (unknown space) raises NullPointerException.
pub fn node_address(obj: &Bound<'_, PyAny>) -> PyResult<(Key, u8)> {
    if let Ok(n) = obj.cast::<PyNode>() {
        let n = n.borrow();
        return Ok((n.key, n.depth));
    }
    // the other trees' nodes (ColorOcTreeNode, OcTreeNodeStamped) by what they answer
    if let (Ok(k), Ok(d)) = (obj.call_method0("getKey"), obj.call_method0("getDepth")) {
        if let (Ok(key), Ok(depth)) = (key_arg(&k, "node key"), d.extract::<u8>()) {
            if depth <= 16 {
                return Ok((key, depth));
            }
        }
    }
    if obj.is_none() {
        return Err(crate::NullPointerException::new_err(
            "no node (search found unknown space)",
        ));
    }
    Err(PyTypeError::new_err(format!(
        "expected a tree node (OcTreeNode, ColorOcTreeNode or OcTreeNodeStamped), got {}",
        obj.get_type()
            .name()
            .map(|n| n.to_string())
            .unwrap_or_default()
    )))
}
