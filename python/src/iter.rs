//! octomap-python's tree, leaf and bounding-box iterators.
//!
//! The nodes are collected when the iterator is created (without the GIL), so the tree may
//! change while Python iterates. Like octomap-python, an iterator object is positioned on a
//! node and answers `getCoordinate()` etc. for it, and `next()` moves it on; `for it in
//! tree.begin_leafs()` yields one object per node.

use crate::convert;
use crate::engine::{probability, Color, KeyConverter, NodeItem, TREE_DEPTH};
use crate::node::{PyKey, PyNode};
use crate::NullPointerException;
use numpy::PyArray1;
use pyo3::exceptions::{PyStopIteration, PyTypeError};
use pyo3::prelude::*;
use pyo3::PyClassInitializer;
use std::sync::Arc;

/// What the three iterator classes share: the nodes, the position and the accessors.
#[pyclass(module = "octoquant", name = "iterator_base", subclass)]
pub struct IteratorBase {
    items: Arc<Vec<NodeItem>>,
    /// The nodes' colours, parallel to `items`, for a ColorOcTree's iterators; `None` for a
    /// plain OcTree's (whose `getColor` is a TypeError, as in octomap-python).
    colors: Option<Arc<Vec<Color>>>,
    /// The nodes' time stamps, parallel to `items`, for an OcTreeStamped's iterators; `None`
    /// for the other trees' (whose `getTimestamp` is a TypeError).
    stamps: Option<Arc<Vec<u32>>>,
    pos: usize,
    conv: Arc<KeyConverter>,
    max_depth: u8,
}

impl IteratorBase {
    /// An iterator over `items`, positioned on the first.
    pub fn new(items: Vec<NodeItem>, conv: KeyConverter, max_depth: u8) -> Self {
        IteratorBase {
            items: Arc::new(items),
            colors: None,
            stamps: None,
            pos: 0,
            conv: Arc::new(conv),
            max_depth,
        }
    }

    /// An iterator over a ColorOcTree's `items` with their `colors` (same length, same order).
    pub fn with_colors(
        items: Vec<NodeItem>,
        colors: Vec<Color>,
        conv: KeyConverter,
        max_depth: u8,
    ) -> Self {
        debug_assert_eq!(items.len(), colors.len());
        IteratorBase {
            colors: Some(Arc::new(colors)),
            ..Self::new(items, conv, max_depth)
        }
    }

    /// An iterator over an OcTreeStamped's `items` with their time `stamps` (same length,
    /// same order).
    pub fn with_stamps(
        items: Vec<NodeItem>,
        stamps: Vec<u32>,
        conv: KeyConverter,
        max_depth: u8,
    ) -> Self {
        debug_assert_eq!(items.len(), stamps.len());
        IteratorBase {
            stamps: Some(Arc::new(stamps)),
            ..Self::new(items, conv, max_depth)
        }
    }

    /// A copy positioned on the same node.
    fn at_current(&self) -> Self {
        IteratorBase {
            items: self.items.clone(),
            colors: self.colors.clone(),
            stamps: self.stamps.clone(),
            pos: self.pos,
            conv: self.conv.clone(),
            max_depth: self.max_depth,
        }
    }

    /// The node the iterator stands on; `NullPointerException` past the end.
    pub fn current(&self) -> PyResult<&NodeItem> {
        self.items
            .get(self.pos)
            .ok_or_else(|| NullPointerException::new_err("the iterator is past the last node"))
    }

    /// Move on one node; `StopIteration` when already past the end.
    fn advance(&mut self) -> PyResult<()> {
        if self.pos >= self.items.len() {
            return Err(PyStopIteration::new_err(()));
        }
        self.pos += 1;
        Ok(())
    }

    /// A copy of the current position to hand out, then move on (the `__next__` protocol).
    fn take(&mut self) -> PyResult<Self> {
        if self.pos >= self.items.len() {
            return Err(PyStopIteration::new_err(()));
        }
        let out = self.at_current();
        self.pos += 1;
        Ok(out)
    }

    fn coord(&self, axis: usize) -> PyResult<f64> {
        let n = self.current()?;
        Ok(self.conv.key_to_coord_at_depth(n.key[axis], n.depth))
    }
}

#[pymethods]
impl IteratorBase {
    /// Centre of the current node (float32 precision, as OctoMap's `point3d`).
    #[pyo3(name = "getCoordinate")]
    fn get_coordinate<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let mut c = [0.0; 3];
        for (a, v) in c.iter_mut().enumerate() {
            *v = self.coord(a)? as f32 as f64;
        }
        Ok(convert::array3(py, c))
    }

    /// Depth of the current node (16 = voxel).
    #[pyo3(name = "getDepth")]
    fn get_depth(&self) -> PyResult<u8> {
        Ok(self.current()?.depth)
    }

    /// Key of the current node (the centre key at its depth).
    #[pyo3(name = "getKey")]
    fn get_key(&self) -> PyResult<PyKey> {
        Ok(PyKey::new(self.current()?.key))
    }

    /// Smallest voxel key inside the current node.
    #[pyo3(name = "getIndexKey")]
    fn get_index_key(&self) -> PyResult<PyKey> {
        Ok(PyKey::new(self.current()?.min_key()))
    }

    /// Edge length of the current node in metres.
    #[pyo3(name = "getSize")]
    fn get_size(&self) -> PyResult<f64> {
        Ok(self.conv.node_size(self.current()?.depth))
    }

    /// x of the current node's centre (double precision).
    #[pyo3(name = "getX")]
    fn get_x(&self) -> PyResult<f64> {
        self.coord(0)
    }

    /// y of the current node's centre (double precision).
    #[pyo3(name = "getY")]
    fn get_y(&self) -> PyResult<f64> {
        self.coord(1)
    }

    /// z of the current node's centre (double precision).
    #[pyo3(name = "getZ")]
    fn get_z(&self) -> PyResult<f64> {
        self.coord(2)
    }

    /// Occupancy probability of the current node.
    #[pyo3(name = "getOccupancy")]
    fn get_occupancy(&self) -> PyResult<f64> {
        Ok(probability(self.current()?.value as f64))
    }

    /// Log-odds of the current node.
    #[pyo3(name = "getValue")]
    fn get_value(&self) -> PyResult<f32> {
        Ok(self.current()?.value)
    }

    /// Log-odds of the current node (same as `getValue`).
    #[pyo3(name = "getLogOdds")]
    fn get_log_odds(&self) -> PyResult<f32> {
        Ok(self.current()?.value)
    }

    /// Colour ``(r, g, b)`` of the current node (white when none was set). A plain OcTree's
    /// iterators raise TypeError, as octomap-python's do.
    #[pyo3(name = "getColor")]
    fn get_color(&self) -> PyResult<(u8, u8, u8)> {
        let Some(colors) = &self.colors else {
            return Err(PyTypeError::new_err(
                "getColor() is only available on ColorOcTree iterators",
            ));
        };
        self.current()?;
        let c = colors[self.pos];
        Ok((c.r, c.g, c.b))
    }

    /// Time stamp of the current node (OctoMap's ``OcTreeNodeStamped::getTimestamp``: whole
    /// seconds of its last update, 0 if never stamped). Only an OcTreeStamped's iterators have
    /// stamps; the other trees' raise TypeError.
    #[pyo3(name = "getTimestamp")]
    fn get_timestamp(&self) -> PyResult<u32> {
        let Some(stamps) = &self.stamps else {
            return Err(PyTypeError::new_err(
                "getTimestamp() is only available on OcTreeStamped iterators",
            ));
        };
        self.current()?;
        stamps
            .get(self.pos)
            .copied()
            .ok_or_else(|| NullPointerException::new_err("the iterator is past the last node"))
    }

    /// Whether the current node is a leaf (no children, or at the iterator's depth limit).
    #[pyo3(name = "isLeaf")]
    fn is_leaf(&self) -> PyResult<bool> {
        let n = self.current()?;
        Ok(!n.has_children || n.depth == self.max_depth)
    }

    /// Nodes left, the current one included.
    fn __len__(&self) -> usize {
        self.items.len().saturating_sub(self.pos)
    }
}

/// One iterator class: `next()` moves this object on; iterating yields one object per node.
macro_rules! iterator_class {
    ($rust:ident, $py:literal, $doc:literal) => {
        #[doc = $doc]
        #[pyclass(module = "octoquant", name = $py, extends = IteratorBase)]
        pub struct $rust;

        impl $rust {
            /// A Python object of this class over `base`.
            pub fn create(py: Python<'_>, base: IteratorBase) -> PyResult<Py<$rust>> {
                Py::new(py, PyClassInitializer::from(base).add_subclass($rust))
            }
        }

        #[pymethods]
        impl $rust {
            /// Move to the next node and return this iterator (`StopIteration` at the end).
            fn next(mut slf: PyRefMut<'_, Self>) -> PyResult<PyRefMut<'_, Self>> {
                slf.as_super().advance()?;
                Ok(slf)
            }

            fn __iter__(slf: PyRefMut<'_, Self>) -> PyRefMut<'_, Self> {
                slf
            }

            fn __next__(mut slf: PyRefMut<'_, Self>) -> PyResult<Py<$rust>> {
                let item = slf.as_super().take()?;
                $rust::create(slf.py(), item)
            }
        }
    };
}

iterator_class!(
    LeafIterator,
    "leaf_iterator",
    "Iterator over the leaves (`OcTree.begin_leafs`)."
);
iterator_class!(
    LeafBbxIterator,
    "leaf_bbx_iterator",
    "Iterator over the leaves that overlap a box (`OcTree.begin_leafs_bbx`)."
);
iterator_class!(
    TreeIterator,
    "tree_iterator",
    "Iterator over every node, inner ones too (`OcTree.begin_tree`)."
);

/// The depth limit of an iterator: OctoMap's `maxDepth = 0` means the whole tree.
pub fn max_depth(d: u8) -> u8 {
    if d == 0 {
        TREE_DEPTH
    } else {
        d
    }
}

/// Used by `isNodeOccupied` and friends: the log-odds of a node or iterator argument. It is
/// here, with the iterators, because an iterator stands for the node it is on; `node.rs`
/// knows nothing of iterators.
pub fn node_value(obj: &Bound<'_, PyAny>) -> PyResult<f32> {
    if let Ok(n) = obj.cast::<PyNode>() {
        return Ok(n.borrow().value);
    }
    if let Ok(it) = obj.cast::<IteratorBase>() {
        return it.borrow().current().map(|n| n.value);
    }
    // the other trees' nodes (ColorOcTreeNode, OcTreeNodeStamped) by what they answer
    if !obj.is_none() {
        if let Ok(v) = obj
            .call_method0("getValue")
            .and_then(|v| v.extract::<f32>())
        {
            return Ok(v);
        }
    }
    if obj.is_none() {
        return Err(crate::NullPointerException::new_err(
            "no node (search found unknown space)",
        ));
    }
    Err(PyTypeError::new_err(format!(
        "expected a tree node (OcTreeNode, ColorOcTreeNode or OcTreeNodeStamped) or an iterator, got {}",
        obj.get_type()
            .name()
            .map(|n| n.to_string())
            .unwrap_or_default()
    )))
}
