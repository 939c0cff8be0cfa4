//! The calls octomap-python's trees share that read the occupancy, convert keys and points,
//! or set the sensor model, the query box and change detection, written once for `OcTree`,
//! `ColorOcTree` and `OcTreeStamped` (octomap-python's `ColorOcTree` has them all through
//! `OccupancyOcTreeBase`; OctoMap's C++ `OcTreeStamped` too).
//!
//! A class implements [`OccupancyHost`] and invokes [`occupancy_api!`], which adds the calls
//! as a further `#[pymethods]` block (pyo3's `multiple-pymethods`).

use crate::bbx::Bbx;
use crate::engine::{ColorOcTree, Key, OcTree, OccupancyParams, OctreeError, StampedOcTree};

/// The settings the shared calls change on a tree, which the Rust tree types have under the
/// same names.
pub(crate) trait TreeSettings {
    /// The occupancy tree.
    fn occupancy(&self) -> &OcTree;
    /// Replace the sensor model.
    fn set_params(&mut self, params: OccupancyParams);
    /// OctoMap's `enableChangeDetection`.
    fn enable_change_detection(&mut self, enable: bool);
    /// OctoMap's `resetChangeDetection`.
    fn reset_change_detection(&mut self);
    /// OctoMap's `setResolution`.
    fn set_resolution(&mut self, resolution: f64) -> Result<(), OctreeError>;
    /// Bytes the tree holds: its nodes and, for the payload trees, the payloads' side table.
    fn memory_usage(&self) -> usize;
}

impl TreeSettings for OcTree {
    fn occupancy(&self) -> &OcTree {
        self
    }
    fn set_params(&mut self, params: OccupancyParams) {
        OcTree::set_params(self, params);
    }
    fn enable_change_detection(&mut self, enable: bool) {
        OcTree::enable_change_detection(self, enable);
    }
    fn reset_change_detection(&mut self) {
        OcTree::reset_change_detection(self);
    }
    fn set_resolution(&mut self, resolution: f64) -> Result<(), OctreeError> {
        OcTree::set_resolution(self, resolution)
    }
    fn memory_usage(&self) -> usize {
        OcTree::memory_usage(self)
    }
}

/// [`TreeSettings`] for the trees with a payload per node, which pass them to their
/// occupancy tree.
macro_rules! payload_settings {
    ($($t:ident),*) => {$(
        impl TreeSettings for $t {
            fn occupancy(&self) -> &OcTree {
                $t::occupancy(self)
            }
            fn set_params(&mut self, params: OccupancyParams) {
                $t::set_params(self, params);
            }
            fn enable_change_detection(&mut self, enable: bool) {
                $t::enable_change_detection(self, enable);
            }
            fn reset_change_detection(&mut self) {
                $t::reset_change_detection(self);
            }
            fn set_resolution(&mut self, resolution: f64) -> Result<(), OctreeError> {
                $t::set_resolution(self, resolution)
            }
            fn memory_usage(&self) -> usize {
                $t::memory_usage(self)
            }
        }
    )*};
}
payload_settings!(ColorOcTree, StampedOcTree);

/// OctoMap's node surgery on a tree, by a node's key and depth, as the Rust tree types have it
/// (the colour tree with its colour rules).
pub(crate) trait NodeSurgery {
    /// Whether a node exists at exactly `depth` holding `key`, and whether it has children.
    fn node_state(&self, key: Key, depth: u8) -> Option<bool>;
    /// OctoMap's `expandNode`.
    fn expand_node(&mut self, key: Key, depth: u8) -> bool;
    /// OctoMap's `pruneNode`.
    fn prune_node(&mut self, key: Key, depth: u8) -> bool;
    /// OctoMap's `isNodeCollapsible`.
    fn is_node_collapsible(&self, key: Key, depth: u8) -> bool;
    /// OctoMap's `nodeChildExists`.
    fn node_child_exists(&self, key: Key, depth: u8, i: usize) -> bool;
    /// OctoMap's `deleteNodeChild`: the nodes removed.
    fn delete_node_child(&mut self, key: Key, depth: u8, i: usize) -> usize;
    /// The log-odds of the node at exactly `depth` holding `key`.
    fn node_value(&self, key: Key, depth: u8) -> Option<f32>;
    /// OctoMap's `setValue` on a node in hand (no clamping, no ancestor upkeep).
    fn set_node_raw_value(&mut self, key: Key, depth: u8, v: f32) -> Result<bool, OctreeError>;
}

impl NodeSurgery for OcTree {
    fn node_state(&self, key: Key, depth: u8) -> Option<bool> {
        self.node_at_depth(key, depth).map(|n| n.has_children)
    }
    fn expand_node(&mut self, key: Key, depth: u8) -> bool {
        OcTree::expand_node(self, key, depth)
    }
    fn prune_node(&mut self, key: Key, depth: u8) -> bool {
        OcTree::prune_node(self, key, depth)
    }
    fn is_node_collapsible(&self, key: Key, depth: u8) -> bool {
        OcTree::is_node_collapsible(self, key, depth)
    }
    fn node_child_exists(&self, key: Key, depth: u8, i: usize) -> bool {
        OcTree::node_child_exists(self, key, depth, i) == Some(true)
    }
    fn delete_node_child(&mut self, key: Key, depth: u8, i: usize) -> usize {
        OcTree::delete_node_child(self, key, depth, i)
    }
    fn node_value(&self, key: Key, depth: u8) -> Option<f32> {
        self.node_at_depth(key, depth).map(|n| n.value)
    }
    fn set_node_raw_value(&mut self, key: Key, depth: u8, v: f32) -> Result<bool, OctreeError> {
        OcTree::set_node_raw_value(self, key, depth, v)
    }
}

/// [`NodeSurgery`] for the trees with a payload per node (their payload rules included).
macro_rules! payload_surgery {
    ($($t:ident),*) => {$(
        impl NodeSurgery for $t {
            fn node_state(&self, key: Key, depth: u8) -> Option<bool> {
                self.node_at_depth(key, depth).map(|n| n.node.has_children)
            }
            fn expand_node(&mut self, key: Key, depth: u8) -> bool {
                $t::expand_node(self, key, depth)
            }
            fn prune_node(&mut self, key: Key, depth: u8) -> bool {
                $t::prune_node(self, key, depth)
            }
            fn is_node_collapsible(&self, key: Key, depth: u8) -> bool {
                $t::is_node_collapsible(self, key, depth)
            }
            fn node_child_exists(&self, key: Key, depth: u8, i: usize) -> bool {
                self.node_child(key, depth, i).is_some()
            }
            fn delete_node_child(&mut self, key: Key, depth: u8, i: usize) -> usize {
                $t::delete_node_child(self, key, depth, i)
            }
            fn node_value(&self, key: Key, depth: u8) -> Option<f32> {
                self.node_at_depth(key, depth).map(|n| n.node.value)
            }
            fn set_node_raw_value(
                &mut self,
                key: Key,
                depth: u8,
                v: f32,
            ) -> Result<bool, OctreeError> {
                $t::set_node_raw_value(self, key, depth, v)
            }
        }
    )*};
}
payload_surgery!(ColorOcTree, StampedOcTree);

/// The key and depth of a node argument that still exists at its depth in `tree`.
pub(crate) fn live_node(
    tree: &impl NodeSurgery,
    node: &pyo3::Bound<'_, pyo3::PyAny>,
) -> pyo3::PyResult<(Key, u8)> {
    let (key, d) = crate::node::node_address(node)?;
    if tree.node_state(key, d).is_none() {
        return Err(crate::convert::not_in_tree(key, d));
    }
    Ok((key, d))
}

/// What the shared calls need of a tree class: its tree and its query box.
pub(crate) trait OccupancyHost {
    /// The Rust tree the class wraps.
    type Tree: TreeSettings;
    /// The tree.
    fn tree(&self) -> &Self::Tree;
    /// The tree, to change.
    fn tree_mut(&mut self) -> &mut Self::Tree;
    /// The query box.
    fn bbx(&self) -> &Bbx;
    /// The query box, to change.
    fn bbx_mut(&mut self) -> &mut Bbx;
    /// Called after `setResolution` changed the leaf size (what was derived at the old size
    /// goes).
    fn resolution_changed(&mut self) {}

    /// The occupancy tree.
    fn occ(&self) -> &OcTree {
        self.tree().occupancy()
    }
    /// Change the sensor model in place.
    fn update_params(&mut self, f: impl FnOnce(&mut OccupancyParams)) {
        let mut p = *self.occ().params();
        f(&mut p);
        self.tree_mut().set_params(p);
    }
    /// OctoMap's `enableChangeDetection`.
    fn enable_changes(&mut self, enable: bool) {
        self.tree_mut().enable_change_detection(enable);
    }
    /// OctoMap's `resetChangeDetection`.
    fn reset_changes(&mut self) {
        self.tree_mut().reset_change_detection();
    }
    /// OctoMap's `setResolution`.
    fn set_leaf_size(&mut self, resolution: f64) -> Result<(), OctreeError> {
        self.tree_mut().set_resolution(resolution)?;
        self.resolution_changed();
        Ok(())
    }
}

/// The shared calls as a `#[pymethods]` block for the class `$ty` (an [`OccupancyHost`]);
/// with `$tree`, also the class's [`OccupancyHost`] impl over its `tree` and `bbx` fields.
macro_rules! occupancy_api {
    // a class with fields `tree: Box<$tree>` and `bbx: Bbx`: the host too
    ($ty:ty, $tree:ty) => {
        impl $crate::occupancy_api::OccupancyHost for $ty {
            type Tree = $tree;
            fn tree(&self) -> &$tree {
                &self.tree
            }
            fn tree_mut(&mut self) -> &mut $tree {
                &mut self.tree
            }
            fn bbx(&self) -> &$crate::bbx::Bbx {
                &self.bbx
            }
            fn bbx_mut(&mut self) -> &mut $crate::bbx::Bbx {
                &mut self.bbx
            }
        }
        $crate::occupancy_api::occupancy_api!($ty);
    };
    ($ty:ty) => {
        #[pyo3::pymethods]
        impl $ty {
            /// Number of nodes, counted by walking the tree.
            #[pyo3(name = "calcNumNodes")]
            fn calc_num_nodes(&self, py: ::pyo3::Python<'_>) -> usize {
                let tree = self.occ();
                py.detach(|| tree.counts().nodes)
            }

            /// Change the leaf size (OctoMap's ``setResolution``): every node keeps its key
            /// and value, so the map scales about the centre of the key range. ``ValueError``
            /// unless ``resolution`` is finite and positive.
            #[pyo3(name = "setResolution")]
            fn set_resolution(&mut self, resolution: f64) -> ::pyo3::PyResult<()> {
                self.set_leaf_size(resolution)
                    .map_err(|e| $crate::convert::value_error("setResolution", &e))
            }

            /// 16.
            #[pyo3(name = "getTreeDepth")]
            fn get_tree_depth(&self) -> u8 {
                $crate::engine::TREE_DEPTH
            }

            /// Lower corner of the bounding box of all leaves (zeros for an empty tree).
            #[pyo3(name = "getMetricMin")]
            fn get_metric_min<'py>(
                &self,
                py: ::pyo3::Python<'py>,
            ) -> ::pyo3::Bound<'py, ::numpy::PyArray1<f64>> {
                let b = self
                    .occ()
                    .metric_bounds()
                    .map_or([0.0; 3], |(lo, _)| lo.into());
                $crate::convert::array3(py, b)
            }

            /// Upper corner of the bounding box of all leaves (zeros for an empty tree).
            #[pyo3(name = "getMetricMax")]
            fn get_metric_max<'py>(
                &self,
                py: ::pyo3::Python<'py>,
            ) -> ::pyo3::Bound<'py, ::numpy::PyArray1<f64>> {
                let b = self
                    .occ()
                    .metric_bounds()
                    .map_or([0.0; 3], |(_, hi)| hi.into());
                $crate::convert::array3(py, b)
            }

            /// Edge lengths of the bounding box of all leaves.
            #[pyo3(name = "getMetricSize")]
            fn get_metric_size<'py>(
                &self,
                py: ::pyo3::Python<'py>,
            ) -> ::pyo3::Bound<'py, ::numpy::PyArray1<f64>> {
                $crate::convert::array3(py, self.occ().metric_size())
            }

            /// Volume of the bounding box of all leaves.
            fn volume(&self) -> f64 {
                self.occ().volume()
            }

            /// Bytes this tree's storage holds, colours and time stamps included (octoquant's,
            /// not OctoMap's formula).
            #[pyo3(name = "memoryUsage")]
            fn memory_usage(&self) -> usize {
                $crate::occupancy_api::TreeSettings::memory_usage(
                    $crate::occupancy_api::OccupancyHost::tree(self),
                )
            }

            /// Bytes per node in OctoMap (16 on 64-bit machines), for formulas written against it.
            #[pyo3(name = "memoryUsageNode")]
            fn memory_usage_node(&self) -> usize {
                16
            }

            /// Bytes a dense float grid over the map's bounding box would take, by OctoMap's
            /// formula: the three sizes in voxels multiplied in `f64` (no rounding up), times
            /// 4, truncated.
            #[pyo3(name = "memoryFullGrid")]
            fn memory_full_grid(&self) -> usize {
                if self.occ().is_empty() {
                    return 0;
                }
                let r = self.occ().resolution();
                let s = self.occ().metric_size();
                ((s[0] / r) * (s[1] / r) * (s[2] / r) * 4.0) as usize
            }

            /// Key of a point (taken as float32), unchecked like OctoMap: outside the map it wraps.
            /// With ``depth``, the key of the coarser node at that depth.
            #[pyo3(name = "coordToKey", signature = (coord, depth=None))]
            fn coord_to_key(
                &self,
                coord: &::pyo3::Bound<'_, ::pyo3::PyAny>,
                depth: Option<i64>,
            ) -> ::pyo3::PyResult<$crate::node::PyKey> {
                let p = $crate::convert::vec3_f32(coord, "coord")?.cast::<f64>();
                let conv = self.occ().converter();
                let key = match depth {
                    None => conv.point_to_key_unchecked(&p),
                    Some(d) => {
                        let d = $crate::convert::depth(d, "depth")?;
                        $crate::engine::Key::new(
                            conv.coord_to_key_at_depth(p.x, d),
                            conv.coord_to_key_at_depth(p.y, d),
                            conv.coord_to_key_at_depth(p.z, d),
                        )
                    }
                };
                Ok($crate::node::PyKey::new(key))
            }

            /// ``(True, key)`` for a point inside the map, ``(False, None)`` outside.
            #[pyo3(name = "coordToKeyChecked", signature = (coord, depth=None))]
            fn coord_to_key_checked(
                &self,
                coord: &::pyo3::Bound<'_, ::pyo3::PyAny>,
                depth: Option<i64>,
            ) -> ::pyo3::PyResult<(bool, Option<$crate::node::PyKey>)> {
                let p = $crate::convert::vec3_f32(coord, "coord")?.cast::<f64>();
                let d = depth
                    .map(|d| $crate::convert::depth(d, "depth"))
                    .transpose()?;
                Ok(match self.occ().converter().point_to_key(&p) {
                    Some(k) => (
                        true,
                        Some($crate::node::PyKey::new(d.map_or(k, |d| k.at_depth(d)))),
                    ),
                    None => (false, None),
                })
            }

            /// Centre of the voxel (or of the node at ``depth``) with this key, float32 precision.
            #[pyo3(name = "keyToCoord", signature = (key, depth=None))]
            fn key_to_coord<'py>(
                &self,
                py: ::pyo3::Python<'py>,
                key: &::pyo3::Bound<'py, ::pyo3::PyAny>,
                depth: Option<i64>,
            ) -> ::pyo3::PyResult<::pyo3::Bound<'py, ::numpy::PyArray1<f64>>> {
                let k = $crate::node::key_arg(key, "key")?;
                let d = depth
                    .map(|d| $crate::convert::depth(d, "depth"))
                    .transpose()?;
                let conv = self.occ().converter();
                let d = d.unwrap_or($crate::engine::TREE_DEPTH);
                let c = [0, 1, 2].map(|a| conv.key_to_coord_at_depth(k[a], d) as f32 as f64);
                Ok($crate::convert::array3(py, c))
            }

            /// The key of the node at ``depth`` that contains ``key``.
            #[pyo3(name = "adjustKeyAtDepth")]
            fn adjust_key_at_depth(
                &self,
                key: &::pyo3::Bound<'_, ::pyo3::PyAny>,
                depth: i64,
            ) -> ::pyo3::PyResult<$crate::node::PyKey> {
                let k = $crate::node::key_arg(key, "key")?;
                Ok($crate::node::PyKey::new(
                    k.at_depth($crate::convert::depth(depth, "depth")?),
                ))
            }

            /// Probability added by a hit.
            #[pyo3(name = "getProbHit")]
            fn get_prob_hit(&self) -> f64 {
                $crate::engine::probability(self.occ().params().hit as f64)
            }

            /// Log-odds added by a hit.
            #[pyo3(name = "getProbHitLog")]
            fn get_prob_hit_log(&self) -> f32 {
                self.occ().params().hit
            }

            /// Probability of a miss.
            #[pyo3(name = "getProbMiss")]
            fn get_prob_miss(&self) -> f64 {
                $crate::engine::probability(self.occ().params().miss as f64)
            }

            /// Log-odds added by a miss.
            #[pyo3(name = "getProbMissLog")]
            fn get_prob_miss_log(&self) -> f32 {
                self.occ().params().miss
            }

            /// Lower clamping bound (probability).
            #[pyo3(name = "getClampingThresMin")]
            fn get_clamping_thres_min(&self) -> f64 {
                $crate::engine::probability(self.occ().params().clamp_min as f64)
            }

            /// Lower clamping bound (log-odds).
            #[pyo3(name = "getClampingThresMinLog")]
            fn get_clamping_thres_min_log(&self) -> f32 {
                self.occ().params().clamp_min
            }

            /// Upper clamping bound (probability).
            #[pyo3(name = "getClampingThresMax")]
            fn get_clamping_thres_max(&self) -> f64 {
                $crate::engine::probability(self.occ().params().clamp_max as f64)
            }

            /// Upper clamping bound (log-odds).
            #[pyo3(name = "getClampingThresMaxLog")]
            fn get_clamping_thres_max_log(&self) -> f32 {
                self.occ().params().clamp_max
            }

            /// Occupancy threshold (probability).
            #[pyo3(name = "getOccupancyThres")]
            fn get_occupancy_thres(&self) -> f64 {
                $crate::engine::probability(self.occ().params().occupancy_threshold as f64)
            }

            /// Occupancy threshold (log-odds).
            #[pyo3(name = "getOccupancyThresLog")]
            fn get_occupancy_thres_log(&self) -> f32 {
                self.occ().params().occupancy_threshold
            }

            /// Set the hit probability (0.5 <= p < 1).
            #[pyo3(name = "setProbHit")]
            fn set_prob_hit(&mut self, prob_: f64) -> ::pyo3::PyResult<()> {
                let l = $crate::convert::prob(prob_, "prob")?;
                if l < 0.0 {
                    return Err(::pyo3::exceptions::PyValueError::new_err(format!(
                        "a hit must not lower occupancy: prob must be >= 0.5, got {prob_}"
                    )));
                }
                self.update_params(|p| p.hit = l);
                Ok(())
            }

            /// Set the miss probability (0 < p <= 0.5).
            #[pyo3(name = "setProbMiss")]
            fn set_prob_miss(&mut self, prob_: f64) -> ::pyo3::PyResult<()> {
                let l = $crate::convert::prob(prob_, "prob")?;
                if l > 0.0 {
                    return Err(::pyo3::exceptions::PyValueError::new_err(format!(
                        "a miss must not raise occupancy: prob must be <= 0.5, got {prob_}"
                    )));
                }
                self.update_params(|p| p.miss = l);
                Ok(())
            }

            /// Set the lower clamping bound (a probability, at most the upper bound).
            #[pyo3(name = "setClampingThresMin")]
            #[allow(non_snake_case)]
            fn set_clamping_thres_min(&mut self, thresProb: f64) -> ::pyo3::PyResult<()> {
                let l = $crate::convert::prob(thresProb, "thresProb")?;
                if l > self.occ().params().clamp_max {
                    return Err(::pyo3::exceptions::PyValueError::new_err(format!(
                        "the lower clamping bound {thresProb} exceeds the upper one {}",
                        $crate::engine::probability(self.occ().params().clamp_max as f64)
                    )));
                }
                self.update_params(|p| p.clamp_min = l);
                Ok(())
            }

            /// Set the upper clamping bound (a probability, at least the lower bound).
            #[pyo3(name = "setClampingThresMax")]
            #[allow(non_snake_case)]
            fn set_clamping_thres_max(&mut self, thresProb: f64) -> ::pyo3::PyResult<()> {
                let l = $crate::convert::prob(thresProb, "thresProb")?;
                if l < self.occ().params().clamp_min {
                    return Err(::pyo3::exceptions::PyValueError::new_err(format!(
                        "the upper clamping bound {thresProb} is below the lower one {}",
                        $crate::engine::probability(self.occ().params().clamp_min as f64)
                    )));
                }
                self.update_params(|p| p.clamp_max = l);
                Ok(())
            }

            /// Set the occupancy threshold (a probability).
            #[pyo3(name = "setOccupancyThres")]
            fn set_occupancy_thres(&mut self, prob_: f64) -> ::pyo3::PyResult<()> {
                let l = $crate::convert::prob(prob_, "prob")?;
                self.update_params(|p| p.occupancy_threshold = l);
                Ok(())
            }

            /// Whether a node's log-odds sits at either clamping bound.
            #[pyo3(name = "isNodeAtThreshold")]
            fn is_node_at_threshold(
                &self,
                node: &::pyo3::Bound<'_, ::pyo3::PyAny>,
            ) -> ::pyo3::PyResult<bool> {
                Ok(self
                    .occ()
                    .params()
                    .is_at_threshold($crate::iter::node_value(node)?))
            }

            /// Limit ``insertPointCloud`` to the box set with ``setBBXMin``/``setBBXMax``.
            #[pyo3(name = "useBBXLimit")]
            fn use_bbx_limit(&mut self, enable: bool) {
                self.bbx_mut().enabled = enable;
            }

            /// Whether the box limit is on.
            #[pyo3(name = "bbxSet")]
            fn bbx_set(&self) -> bool {
                self.bbx().enabled
            }

            /// Set the lower corner of the box (ValueError outside the map).
            #[pyo3(name = "setBBXMin")]
            fn set_bbx_min(
                &mut self,
                min: &::pyo3::Bound<'_, ::pyo3::PyAny>,
            ) -> ::pyo3::PyResult<()> {
                let p = $crate::convert::vec3_f32(min, "min")?;
                let conv = self.occ().converter().clone();
                if !self.bbx_mut().set_min(&conv, p) {
                    return Err(::pyo3::exceptions::PyValueError::new_err(format!(
                        "box corner {p:?} is outside the map"
                    )));
                }
                Ok(())
            }

            /// Set the upper corner of the box (ValueError outside the map).
            #[pyo3(name = "setBBXMax")]
            fn set_bbx_max(
                &mut self,
                max: &::pyo3::Bound<'_, ::pyo3::PyAny>,
            ) -> ::pyo3::PyResult<()> {
                let p = $crate::convert::vec3_f32(max, "max")?;
                let conv = self.occ().converter().clone();
                if !self.bbx_mut().set_max(&conv, p) {
                    return Err(::pyo3::exceptions::PyValueError::new_err(format!(
                        "box corner {p:?} is outside the map"
                    )));
                }
                Ok(())
            }

            /// Lower corner of the box.
            #[pyo3(name = "getBBXMin")]
            fn get_bbx_min<'py>(
                &self,
                py: ::pyo3::Python<'py>,
            ) -> ::pyo3::Bound<'py, ::numpy::PyArray1<f64>> {
                $crate::convert::array3(py, self.bbx().min.cast::<f64>().into())
            }

            /// Upper corner of the box.
            #[pyo3(name = "getBBXMax")]
            fn get_bbx_max<'py>(
                &self,
                py: ::pyo3::Python<'py>,
            ) -> ::pyo3::Bound<'py, ::numpy::PyArray1<f64>> {
                $crate::convert::array3(py, self.bbx().max.cast::<f64>().into())
            }

            /// Half the box's edge lengths.
            #[pyo3(name = "getBBXBounds")]
            fn get_bbx_bounds<'py>(
                &self,
                py: ::pyo3::Python<'py>,
            ) -> ::pyo3::Bound<'py, ::numpy::PyArray1<f64>> {
                let b = (self.bbx().max - self.bbx().min) / 2.0;
                $crate::convert::array3(py, [b.x as f64, b.y as f64, b.z as f64])
            }

            /// Centre of the box.
            #[pyo3(name = "getBBXCenter")]
            fn get_bbx_center<'py>(
                &self,
                py: ::pyo3::Python<'py>,
            ) -> ::pyo3::Bound<'py, ::numpy::PyArray1<f64>> {
                let c = self.bbx().min + (self.bbx().max - self.bbx().min) / 2.0;
                $crate::convert::array3(py, [c.x as f64, c.y as f64, c.z as f64])
            }

            /// Whether a point lies inside the box (borders included).
            #[pyo3(name = "inBBX")]
            fn in_bbx(&self, p: &::pyo3::Bound<'_, ::pyo3::PyAny>) -> ::pyo3::PyResult<bool> {
                Ok(self.bbx().contains(&$crate::convert::vec3_f32(p, "p")?))
            }

            /// Record every voxel that is created or whose occupancy flips from now on.
            #[pyo3(name = "enableChangeDetection")]
            fn enable_change_detection(&mut self, enable: bool) {
                self.enable_changes(enable);
            }

            /// Whether change detection is on.
            #[pyo3(name = "isChangeDetectionEnabled")]
            fn is_change_detection_enabled(&self) -> bool {
                self.occ().is_change_detection_enabled()
            }

            /// Forget the changes recorded so far.
            #[pyo3(name = "resetChangeDetection")]
            fn reset_change_detection(&mut self) {
                self.reset_changes();
            }

            /// Number of changed voxels recorded.
            #[pyo3(name = "numChangesDetected")]
            fn num_changes_detected(&self) -> usize {
                self.occ().num_changes_detected()
            }

            /// The changed voxels in key order: ``[(OcTreeKey, is_new), ...]``; ``is_new`` is True
            /// for a voxel that did not exist before, False for one whose occupancy flipped.
            #[pyo3(name = "changedKeys")]
            fn changed_keys(&self) -> Vec<($crate::node::PyKey, bool)> {
                self.occ()
                    .changed_keys()
                    .map(|(k, new)| ($crate::node::PyKey::new(k), new))
                    .collect()
            }
        }
    };
}
pub(crate) use occupancy_api;

/// OctoMap's node surgery calls that return no node, as a `#[pymethods]` block for the class
/// `$ty` (an [`OccupancyHost`] whose tree has [`NodeSurgery`]).
macro_rules! surgery_api {
    ($ty:ty) => {
        #[pyo3::pymethods]
        impl $ty {
            /// Give a childless node (from ``search``, ``getRoot``, ``getNodeChild``, ...) eight
            /// children with its value (and colour; OctoMap's ``expandNode``; inner nodes above
            /// are not refreshed). ``ValueError`` when the node is no longer in the tree at its
            /// depth, already has children, or is a voxel (depth 16).
            #[pyo3(name = "expandNode")]
            fn expand_node(
                &mut self,
                node: &::pyo3::Bound<'_, ::pyo3::PyAny>,
            ) -> ::pyo3::PyResult<()> {
                let (key, d) = $crate::occupancy_api::live_node(self.tree(), node)?;
                if d >= $crate::engine::TREE_DEPTH {
                    return Err(::pyo3::exceptions::PyValueError::new_err(
                        "expandNode: a voxel (depth 16) has no children",
                    ));
                }
                if !$crate::occupancy_api::NodeSurgery::expand_node(self.tree_mut(), key, d) {
                    return Err(::pyo3::exceptions::PyValueError::new_err(
                        "expandNode: the node already has children",
                    ));
                }
                Ok(())
            }

            /// Collapse a node whose eight children are leaves of equal log-odds into one leaf
            /// (OctoMap's ``pruneNode``; a colour tree's node takes child 0's colour, or the
            /// children's average colour when child 0 has one). Returns whether it did.
            #[pyo3(name = "pruneNode")]
            fn prune_node(
                &mut self,
                node: &::pyo3::Bound<'_, ::pyo3::PyAny>,
            ) -> ::pyo3::PyResult<bool> {
                let (key, d) = $crate::occupancy_api::live_node(self.tree(), node)?;
                Ok($crate::occupancy_api::NodeSurgery::prune_node(
                    self.tree_mut(),
                    key,
                    d,
                ))
            }

            /// Whether a node has all eight children, none with children, all with equal
            /// log-odds (OctoMap's ``isNodeCollapsible``; colours are not compared).
            #[pyo3(name = "isNodeCollapsible")]
            fn is_node_collapsible(
                &self,
                node: &::pyo3::Bound<'_, ::pyo3::PyAny>,
            ) -> ::pyo3::PyResult<bool> {
                let (key, d) = $crate::occupancy_api::live_node(self.tree(), node)?;
                Ok($crate::occupancy_api::NodeSurgery::is_node_collapsible(
                    self.tree(),
                    key,
                    d,
                ))
            }

            /// Whether a node has children now (OctoMap's ``nodeHasChildren``; the node
            /// object's ``hasChildren()`` tells how it was when it was looked up).
            #[pyo3(name = "nodeHasChildren")]
            fn node_has_children(
                &self,
                node: &::pyo3::Bound<'_, ::pyo3::PyAny>,
            ) -> ::pyo3::PyResult<bool> {
                let (key, d) = $crate::occupancy_api::live_node(self.tree(), node)?;
                Ok(
                    $crate::occupancy_api::NodeSurgery::node_state(self.tree(), key, d)
                        == Some(true),
                )
            }

            /// Whether child ``idx`` (0..8: bit 0 x, bit 1 y, bit 2 z) of a node exists
            /// (OctoMap's ``nodeChildExists``).
            #[pyo3(name = "nodeChildExists")]
            fn node_child_exists(
                &self,
                node: &::pyo3::Bound<'_, ::pyo3::PyAny>,
                idx: i64,
            ) -> ::pyo3::PyResult<bool> {
                let (key, d) = $crate::occupancy_api::live_node(self.tree(), node)?;
                let i = $crate::convert::child_idx(idx)?;
                Ok($crate::occupancy_api::NodeSurgery::node_child_exists(
                    self.tree(),
                    key,
                    d,
                    i,
                ))
            }

            /// OctoMap's ``node.setValue(value)`` on a node in hand (what the node objects'
            /// ``setValue`` and ``setLogOdds`` call): the node's log-odds set as given, no
            /// clamping, no ancestor refreshed. Returns the value. ``ValueError`` for NaN and
            /// for a node no longer in the tree.
            #[pyo3(name = "_set_node_value")]
            fn set_node_value_in_hand(
                &mut self,
                node: &::pyo3::Bound<'_, ::pyo3::PyAny>,
                value: f32,
            ) -> ::pyo3::PyResult<f32> {
                let (key, d) = $crate::occupancy_api::live_node(self.tree(), node)?;
                $crate::occupancy_api::NodeSurgery::set_node_raw_value(
                    self.tree_mut(),
                    key,
                    d,
                    value,
                )
                .map_err(|e| $crate::convert::value_error("setValue", &e))?;
                Ok(value)
            }

            /// OctoMap's ``node.addValue(delta)`` on a node in hand: its log-odds now plus
            /// ``delta``, set as ``_set_node_value`` sets it. Returns the new value.
            #[pyo3(name = "_add_node_value")]
            fn add_node_value_in_hand(
                &mut self,
                node: &::pyo3::Bound<'_, ::pyo3::PyAny>,
                delta: f32,
            ) -> ::pyo3::PyResult<f32> {
                let (key, d) = $crate::occupancy_api::live_node(self.tree(), node)?;
                let now = $crate::occupancy_api::NodeSurgery::node_value(self.tree(), key, d)
                    .unwrap_or(0.0);
                let value = now + delta;
                $crate::occupancy_api::NodeSurgery::set_node_raw_value(
                    self.tree_mut(),
                    key,
                    d,
                    value,
                )
                .map_err(|e| $crate::convert::value_error("addValue", &e))?;
                Ok(value)
            }

            /// Delete child ``idx`` (0..8) of a node with its subtree (and their colours;
            /// OctoMap's ``deleteNodeChild``; ``size()`` drops by the whole subtree).
            /// ``ValueError`` when the child does not exist.
            #[pyo3(name = "deleteNodeChild")]
            fn delete_node_child(
                &mut self,
                node: &::pyo3::Bound<'_, ::pyo3::PyAny>,
                idx: i64,
            ) -> ::pyo3::PyResult<()> {
                let (key, d) = $crate::occupancy_api::live_node(self.tree(), node)?;
                let i = $crate::convert::child_idx(idx)?;
                if $crate::occupancy_api::NodeSurgery::delete_node_child(self.tree_mut(), key, d, i)
                    == 0
                {
                    return Err(::pyo3::exceptions::PyValueError::new_err(format!(
                        "deleteNodeChild: child {i} does not exist"
                    )));
                }
                Ok(())
            }
        }
    };
}
pub(crate) use surgery_api;
