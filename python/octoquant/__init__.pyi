"""Type stubs for octoquant (the extension module octoquant._octoquant)."""

import abc
import os
from collections.abc import Iterable, Iterator, Sequence
from typing import Any, Literal, Optional, Union, overload

import numpy as np
from numpy.typing import NDArray

StrOrBytesPath = Union[str, bytes, "os.PathLike[str]", "os.PathLike[bytes]"]
Vec3 = Union[NDArray[np.floating[Any]], NDArray[np.integer[Any]], Sequence[float]]
Points = Union[NDArray[np.float32], NDArray[np.float64], Sequence[Sequence[float]]]
KeyLike = Union["OcTreeKey", Sequence[int]]
# a sensor pose (sensor to world): a 4x4 homogeneous matrix, or (translation, quaternion (x, y, z, w))
Pose = Union[NDArray[np.floating[Any]], Sequence[Sequence[float]], tuple[Vec3, Sequence[float]]]

class NullPointerException(Exception):
    """A node or iterator that stands for nothing (unknown space, or past the end)."""

class OcTreeKey:
    """A voxel address: three 16-bit cell indices (octomap's ``OcTreeKey``)."""

    def __init__(self, k0: int = 0, k1: int = 0, k2: int = 0) -> None: ...
    def __getitem__(self, i: int) -> int: ...
    def __setitem__(self, i: int, value: int) -> None: ...
    def __len__(self) -> int: ...
    def __iter__(self) -> Iterator[int]: ...
    def __eq__(self, other: object) -> bool: ...
    def __ne__(self, other: object) -> bool: ...
    def __hash__(self) -> int: ...

class OcTreeNode:
    """A node as it was when it was looked up (a snapshot, not a live pointer)."""

    def getValue(self) -> float:
        """The node's log-odds."""
    def getLogOdds(self) -> float:
        """The node's log-odds."""
    def getOccupancy(self) -> float:
        """The occupancy probability ``1 - 1/(1 + exp(log_odds))``."""
    def hasChildren(self) -> bool:
        """Whether the node had children."""
    def getDepth(self) -> int:
        """The node's depth (16 = voxel)."""
    def getKey(self) -> OcTreeKey:
        """The node's key at its depth."""
    def setValue(self, v: float) -> None:
        """Set the node's log-odds in its tree (no clamping, no inner upkeep)."""
    def setLogOdds(self, v: float) -> None: ...
    def addValue(self, p: float) -> None: ...
    def childExists(self, i: int) -> bool: ...


class iterator_base:
    """A position in a tree traversal; the accessors describe the current node."""

    def getCoordinate(self) -> NDArray[np.float64]:
        """Centre of the node (float32 precision, like OctoMap's ``point3d``)."""
    def getDepth(self) -> int: ...
    def getKey(self) -> OcTreeKey: ...
    def getIndexKey(self) -> OcTreeKey:
        """Smallest voxel key inside the node."""
    def getSize(self) -> float:
        """Edge length of the node in metres."""
    def getX(self) -> float: ...
    def getY(self) -> float: ...
    def getZ(self) -> float: ...
    def getOccupancy(self) -> float: ...
    def getValue(self) -> float: ...
    def getLogOdds(self) -> float: ...
    def isLeaf(self) -> bool:
        """No children, or at the iterator's depth limit."""
    def getColor(self) -> tuple[int, int, int]:
        """The node's colour (a ColorOcTree's iterators; TypeError on an OcTree's)."""
    def getTimestamp(self) -> int:
        """The node's time stamp in seconds (an OcTreeStamped's iterators; TypeError on the
        others')."""
    def __len__(self) -> int:
        """Nodes left, the current one included."""

class tree_iterator(iterator_base):
    def next(self) -> tree_iterator:
        """Move on one node and return self (StopIteration at the end)."""
    def __iter__(self) -> Iterator[tree_iterator]: ...
    def __next__(self) -> tree_iterator: ...

class leaf_iterator(iterator_base):
    def next(self) -> leaf_iterator:
        """Move on one leaf and return self (StopIteration at the end)."""
    def __iter__(self) -> Iterator[leaf_iterator]: ...
    def __next__(self) -> leaf_iterator: ...

class leaf_bbx_iterator(iterator_base):
    def next(self) -> leaf_bbx_iterator:
        """Move on one leaf and return self (StopIteration at the end)."""
    def __iter__(self) -> Iterator[leaf_bbx_iterator]: ...
    def __next__(self) -> leaf_bbx_iterator: ...

class OccupancyOcTreeBase(abc.ABC):
    """The calls every tree class shares (octomap-python's ``OccupancyOcTreeBase``): keys and
    points, metrics, the sensor model, the query box of ``insertPointCloud`` and change
    detection. At run time an abstract base that ``OcTree``, ``ColorOcTree`` and
    ``OcTreeStamped`` are registered with (``isinstance`` holds), each class having the calls
    itself; constructing it raises TypeError."""

    def isNodeAtThreshold(
        self, node: Union[OcTreeNode, ColorOcTreeNode, OcTreeNodeStamped, iterator_base, None]
    ) -> bool: ...
    def setResolution(self, resolution: float) -> None:
        """Change the leaf size; nodes keep their keys and values (the map scales)."""
    def calcNumNodes(self) -> int: ...
    def getTreeDepth(self) -> int: ...
    def getMetricMin(self) -> NDArray[np.float64]: ...
    def getMetricMax(self) -> NDArray[np.float64]: ...
    def getMetricSize(self) -> NDArray[np.float64]: ...
    def volume(self) -> float: ...
    def memoryUsage(self) -> int: ...
    def memoryUsageNode(self) -> int: ...
    def memoryFullGrid(self) -> int: ...
    def coordToKey(self, coord: Vec3, depth: Optional[int] = None) -> OcTreeKey: ...
    def coordToKeyChecked(
        self, coord: Vec3, depth: Optional[int] = None
    ) -> tuple[bool, Optional[OcTreeKey]]: ...
    def keyToCoord(self, key: KeyLike, depth: Optional[int] = None) -> NDArray[np.float64]: ...
    def adjustKeyAtDepth(self, key: KeyLike, depth: int) -> OcTreeKey: ...
    def getProbHit(self) -> float: ...
    def getProbHitLog(self) -> float: ...
    def getProbMiss(self) -> float: ...
    def getProbMissLog(self) -> float: ...
    def getClampingThresMin(self) -> float: ...
    def getClampingThresMinLog(self) -> float: ...
    def getClampingThresMax(self) -> float: ...
    def getClampingThresMaxLog(self) -> float: ...
    def getOccupancyThres(self) -> float: ...
    def getOccupancyThresLog(self) -> float: ...
    def setProbHit(self, prob: float) -> None: ...
    def setProbMiss(self, prob: float) -> None: ...
    def setClampingThresMin(self, thresProb: float) -> None: ...
    def setClampingThresMax(self, thresProb: float) -> None: ...
    def setOccupancyThres(self, prob: float) -> None: ...
    def useBBXLimit(self, enable: bool) -> None: ...
    def bbxSet(self) -> bool: ...
    def setBBXMin(self, min: Vec3) -> None: ...
    def setBBXMax(self, max: Vec3) -> None: ...
    def getBBXMin(self) -> NDArray[np.float64]: ...
    def getBBXMax(self) -> NDArray[np.float64]: ...
    def getBBXBounds(self) -> NDArray[np.float64]: ...
    def getBBXCenter(self) -> NDArray[np.float64]: ...
    def inBBX(self, p: Vec3) -> bool: ...
    def enableChangeDetection(self, enable: bool) -> None: ...
    def isChangeDetectionEnabled(self) -> bool: ...
    def resetChangeDetection(self) -> None: ...
    def numChangesDetected(self) -> int: ...
    def changedKeys(self) -> list[tuple[OcTreeKey, bool]]: ...

class OcTree(OccupancyOcTreeBase):
    """OctoMap's probabilistic occupancy octree, built by octoquant.

    ``OcTree(resolution)`` is an empty tree; ``OcTree(filename)`` reads a ``.bt``/``.ot`` file
    (or serialized bytes). Names, signatures and results follow octomap-python.
    """

    def __init__(self, arg: Union[float, StrOrBytesPath]) -> None: ...
    @staticmethod
    def read(filename: Union[StrOrBytesPath, bytes]) -> OcTree:
        """A tree from a ``.ot``/``.bt`` file or bytes (OSError, ValueError on failure)."""
    @staticmethod
    def from_bytes(data: bytes) -> OcTree:
        """A tree from ``.bt`` or ``.ot`` bytes."""
    def readBinary(self, filename: Union[StrOrBytesPath, bytes]) -> bool:
        """Replace this tree by a ``.bt`` file or bytes; raises instead of returning False."""
    @overload
    def writeBinary(self) -> bytes: ...
    @overload
    def writeBinary(self, filename: StrOrBytesPath) -> bool: ...
    @overload
    def write(self) -> bytes: ...
    @overload
    def write(self, filename: StrOrBytesPath) -> bool: ...
    def to_bytes(self, kind: Literal["bt", "ot"] = "bt") -> bytes: ...
    def insertPointCloud(
        self,
        pointcloud: Points,
        origin: Vec3,
        maxrange: float = -1.0,
        lazy_eval: bool = False,
        discretize: bool = False,
    ) -> None:
        """Integrate a scan (N, 3) seen from ``origin``; releases the GIL."""
    def castRay(
        self,
        origin: Vec3,
        direction: Vec3,
        end: NDArray[np.floating[Any]],
        ignoreUnknownCells: bool = False,
        maxRange: float = -1.0,
    ) -> bool:
        """True when an occupied voxel is hit; ``end`` receives where the ray stopped."""
    def cast_rays(
        self,
        origins: Union[Vec3, Points],
        directions: Points,
        ignore_unknown: bool = False,
        max_range: Optional[float] = None,
    ) -> tuple[NDArray[np.bool_], NDArray[np.float64]]:
        """Many casts: (hit (N,), ends (N, 3), NaN where no cast was possible)."""
    def search(self, value: Union[OcTreeKey, Vec3], depth: int = 0) -> Optional[OcTreeNode]:
        """The node holding a key or point, or None in unknown space."""
    def isNodeOccupied(self, node: Union[OcTreeNode, iterator_base, None]) -> bool: ...
    def updateNode(
        self, value: Union[OcTreeKey, Vec3], update: Union[bool, float], lazy_eval: bool = False
    ) -> Optional[OcTreeNode]:
        """Hit (True), miss (False) or add a log-odds delta (float) to one voxel."""
    def updateNodes(
        self,
        values: Union[Sequence[Union[OcTreeKey, Vec3]], Points],
        update: Union[bool, float],
        lazy_eval: bool = False,
    ) -> None: ...
    def updateInnerOccupancy(self) -> None: ...
    def toMaxLikelihood(self) -> None: ...
    def prune(self) -> None: ...
    def expand(self, max_nodes: Optional[int] = None) -> None:
        """Expand every pruned node down to voxels (OctoMap's ``expand``); ``MemoryError``,
        nothing expanded, when it would add more than ``max_nodes`` nodes (default: more than
        the machine's physical memory could hold)."""
    def merge(self, other: OcTree) -> dict[str, int]:
        """Fuse ``other`` into this tree: each leaf of ``other`` applied to the voxels it covers
        as OctoMap's ``updateNode(voxel, leaf_log_odds)``, with this tree's clamping (pruned
        leaves applied whole). ``ValueError`` on a resolution mismatch or a non-finite leaf.
        Returns ``{"leaves", "pruned_leaves", "voxels"}``."""
    def clear(self) -> None: ...
    def deleteNode(self, value: Union[OcTreeKey, Vec3], depth: int = 1) -> bool: ...
    def expandNode(self, node: OcTreeNode) -> None:
        """Give a childless node eight children with its value (``ValueError`` for a node with
        children, a voxel, or a node no longer in the tree)."""
    def pruneNode(self, node: OcTreeNode) -> bool:
        """Collapse a node whose eight children are equal leaves; whether it did."""
    def isNodeCollapsible(self, node: OcTreeNode) -> bool:
        """All eight children exist, are leaves and have equal log-odds."""
    def nodeHasChildren(self, node: OcTreeNode) -> bool:
        """Whether the node has children now (``node.hasChildren()``: when looked up)."""
    def nodeChildExists(self, node: OcTreeNode, idx: int) -> bool:
        """Whether child ``idx`` (0..8; bit 0 x, bit 1 y, bit 2 z) exists."""
    def getNodeChild(self, node: OcTreeNode, idx: int) -> Optional[OcTreeNode]:
        """Child ``idx`` of the node, or None when it does not exist."""
    def createNodeChild(self, node: OcTreeNode, idx: int) -> OcTreeNode:
        """Create child ``idx`` with log-odds 0 and return it (``ValueError`` if it exists)."""
    def deleteNodeChild(self, node: OcTreeNode, idx: int) -> None:
        """Delete child ``idx`` and its subtree (``ValueError`` if it does not exist)."""
    def extractPointCloud(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(occupied, empty) voxel centres, (N, 3) float64 each."""
    def getLabels(self, points: Points) -> NDArray[np.int32]:
        """1 occupied, 0 free, -1 unknown per point."""
    def dynamicEDT_generate(
        self,
        maxdist: float,
        bbx_min: Vec3,
        bbx_max: Vec3,
        treatUnknownAsOccupied: bool = False,
    ) -> None:
        """A distance map over the box (dynamicEDT3D); distances appear with dynamicEDT_update.
        ValueError for a bad maxdist, a corner outside the map, an empty or too large box."""
    def dynamicEDT_update(self, updateRealDist: bool) -> None:
        """Take in the tree's changes since the last update and recompute the distances."""
    def dynamicEDT_getMaxDist(self) -> float:
        """The distance clamp in metres (at least the maxdist asked for)."""
    def dynamicEDT_checkConsistency(self) -> bool:
        """Whether the map's obstacles are the tree's occupied voxels in the box."""
    def dynamicEDT_getDistance(self, p: Union[OcTreeKey, Vec3]) -> float:
        """Distance to the nearest obstacle in metres; -1.0 outside the box."""
    def dynamicEDT_getDistanceAndClosestObstacle(
        self, p: Vec3
    ) -> tuple[float, Optional[NDArray[np.float64]]]:
        """(distance, obstacle voxel centre); the obstacle is None outside the box or when no
        obstacle lies within the maximum distance."""
    def distances(self, points: Points) -> NDArray[np.float32]:
        """dynamicEDT_getDistance of every row of an (N, 3) array."""
    def probability_at(self, point: Vec3) -> Optional[float]:
        """Occupancy probability at one point; None in unknown space or outside the map."""
    def occupancy(self, points: Points) -> NDArray[np.float64]:
        """Occupancy probability per point, NaN in unknown space."""
    def grid(
        self,
        zmin: Optional[float] = None,
        zmax: Optional[float] = None,
        depth: int = 16,
        unknown: str = "unknown",
    ) -> tuple[NDArray[np.int8], tuple[float, float], float]: ...
    def write_grid(
        self,
        yaml: Union[str, os.PathLike[str]],
        zmin: Optional[float] = None,
        zmax: Optional[float] = None,
        depth: int = 16,
        unknown: str = "unknown",
    ) -> str: ...
    def occupied_voxels(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]: ...
    def free_voxels(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]: ...
    def leaves(
        self, bbx: Optional[tuple[Vec3, Vec3]] = None, max_depth: int = 0
    ) -> NDArray[np.void]:
        """Structured array: x, y, z, size, depth, log_odds per leaf."""
    def getResolution(self) -> float: ...
    def getTreeType(self) -> bytes: ...
    def size(self) -> int: ...
    def getNumLeafNodes(self) -> int: ...
    def getRoot(self) -> Optional[OcTreeNode]: ...
    def begin_tree(self, maxDepth: int = 0) -> tree_iterator: ...
    def begin_leafs(self, maxDepth: int = 0) -> leaf_iterator: ...
    def begin_leafs_bbx(self, bbx_min: Vec3, bbx_max: Vec3, maxDepth: int = 0) -> leaf_bbx_iterator: ...
    def end_tree(self) -> tree_iterator: ...
    def end_leafs(self) -> leaf_iterator: ...
    def end_leafs_bbx(self) -> leaf_bbx_iterator: ...
    def __copy__(self) -> OcTree: ...
    def __deepcopy__(self, memo: dict[int, Any]) -> OcTree: ...

class ColorOcTreeNode:
    """A node of a ColorOcTree as it was when it was looked up (a snapshot)."""

    def getValue(self) -> float:
        """The node's log-odds."""
    def getLogOdds(self) -> float:
        """The node's log-odds."""
    def getOccupancy(self) -> float:
        """The occupancy probability ``1 - 1/(1 + exp(log_odds))``."""
    def hasChildren(self) -> bool:
        """Whether the node had children."""
    def getDepth(self) -> int:
        """The node's depth (16 = voxel)."""
    def getKey(self) -> OcTreeKey:
        """The node's key at its depth."""
    def getColor(self) -> tuple[int, int, int]:
        """The colour ``(r, g, b)``; white when none was set."""
    def isColorSet(self) -> bool:
        """Whether a colour was set (anything but white)."""
    def getAverageChildColor(self) -> tuple[int, int, int]:
        """Mean colour of the children that have one; white when none has."""
    def setColor(self, r: int, g: int, b: int) -> None:
        """Set the node's colour in its tree (ValueError when the node is gone from it)."""
    def setValue(self, v: float) -> None:
        """Set the node's log-odds in its tree (no clamping, no inner upkeep)."""
    def setLogOdds(self, v: float) -> None: ...
    def addValue(self, p: float) -> None: ...
    def childExists(self, i: int) -> bool: ...


class ColorOcTree(OccupancyOcTreeBase):
    """OctoMap's ColorOcTree: occupancy plus an RGB colour per node, built by octoquant.

    ``ColorOcTree(resolution)`` is an empty tree; ``ColorOcTree(filename)`` reads a ``.ot``
    file of type ColorOcTree (or the bytes ``write()`` returned). ``write()`` bytes equal
    octomap-python's for the same calls.
    """

    def __init__(self, arg: Union[float, StrOrBytesPath]) -> None: ...
    @staticmethod
    def read(filename: Union[StrOrBytesPath, bytes]) -> ColorOcTree:
        """A tree from a ColorOcTree ``.ot`` file or bytes (OSError, ValueError on failure)."""
    @overload
    def write(self) -> bytes: ...
    @overload
    def write(self, filename: StrOrBytesPath) -> bool: ...
    def getTreeType(self) -> bytes: ...
    def getResolution(self) -> float: ...
    def size(self) -> int: ...
    def getNumLeafNodes(self) -> int: ...
    def clear(self) -> None: ...
    def updateNode(
        self, value: Union[OcTreeKey, NDArray[Any]], update: Union[bool, float], lazy_eval: bool = ...
    ) -> Optional[ColorOcTreeNode]: ...
    def search(
        self, value: Union[OcTreeKey, NDArray[Any]], depth: int = ...
    ) -> Optional[ColorOcTreeNode]: ...
    def setNodeColor(
        self, value: Union[OcTreeKey, NDArray[Any]], r: int, g: int, b: int
    ) -> Optional[ColorOcTreeNode]: ...
    def averageNodeColor(
        self, value: Union[OcTreeKey, NDArray[Any]], r: int, g: int, b: int
    ) -> Optional[ColorOcTreeNode]: ...
    def integrateNodeColor(
        self, value: Union[OcTreeKey, NDArray[Any]], r: int, g: int, b: int
    ) -> Optional[ColorOcTreeNode]: ...
    def isNodeOccupied(self, node: Union[ColorOcTreeNode, OcTreeNode, iterator_base]) -> bool: ...
    def updateInnerOccupancy(self) -> None: ...
    def toMaxLikelihood(self) -> None: ...
    def prune(self) -> None: ...
    def expand(self, max_nodes: Optional[int] = None) -> None:
        """Expand every pruned node down to voxels (OctoMap's ``expand``); ``MemoryError``,
        nothing expanded, when it would add more than ``max_nodes`` nodes (default: more than
        the machine's physical memory could hold)."""
    def deleteNode(self, value: Union[OcTreeKey, NDArray[Any]], depth: int = ...) -> bool: ...
    def getRoot(self) -> Optional[ColorOcTreeNode]: ...
    def castRay(
        self,
        origin: Vec3,
        direction: Vec3,
        end: NDArray[np.floating[Any]],
        ignoreUnknownCells: bool = False,
        maxRange: float = -1.0,
    ) -> bool:
        """True when an occupied voxel is hit; ``end`` receives where the ray stopped."""
    def cast_rays(
        self,
        origins: Union[Vec3, Points],
        directions: Points,
        ignore_unknown: bool = False,
        max_range: Optional[float] = None,
    ) -> tuple[NDArray[np.bool_], NDArray[np.float64]]:
        """Many casts: (hit (N,), ends (N, 3), NaN where no cast was possible)."""
    def begin_tree(self, maxDepth: int = 0) -> tree_iterator:
        """Every node, inner ones too; ``getColor()`` gives each one's colour."""
    def begin_leafs(self, maxDepth: int = 0) -> leaf_iterator: ...
    def begin_leafs_bbx(self, bbx_min: Vec3, bbx_max: Vec3, maxDepth: int = 0) -> leaf_bbx_iterator: ...
    def end_tree(self) -> tree_iterator: ...
    def end_leafs(self) -> leaf_iterator: ...
    def end_leafs_bbx(self) -> leaf_bbx_iterator: ...
    def insertPointCloud(
        self,
        pointcloud: Points,
        origin: Vec3,
        maxrange: float = -1.0,
        lazy_eval: bool = False,
        discretize: bool = False,
    ) -> None:
        """Integrate a scan (N, 3) seen from ``origin`` as OctoMap does, in its key sets'
        order (colours move with the structure only); releases the GIL."""
    def updateNodes(
        self,
        values: Union[Sequence[Union[OcTreeKey, Vec3]], Points],
        update: Union[bool, float],
        lazy_eval: bool = False,
    ) -> None: ...
    def readBinary(self, filename: Union[StrOrBytesPath, bytes]) -> bool:
        """Replace this tree by a ``.bt`` file or bytes (every node white)."""
    @overload
    def writeBinary(self) -> bytes: ...
    @overload
    def writeBinary(self, filename: StrOrBytesPath) -> bool: ...
    def expandNode(self, node: ColorOcTreeNode) -> None:
        """Give a childless node eight children with its value and colour."""
    def pruneNode(self, node: ColorOcTreeNode) -> bool:
        """Collapse children of equal log-odds (child 0's colour, or their average when child
        0 has one); whether it did."""
    def isNodeCollapsible(self, node: ColorOcTreeNode) -> bool:
        """All eight children exist, are leaves and have equal log-odds (colours aside)."""
    def nodeHasChildren(self, node: ColorOcTreeNode) -> bool: ...
    def nodeChildExists(self, node: ColorOcTreeNode, idx: int) -> bool: ...
    def getNodeChild(self, node: ColorOcTreeNode, idx: int) -> Optional[ColorOcTreeNode]: ...
    def createNodeChild(self, node: ColorOcTreeNode, idx: int) -> ColorOcTreeNode:
        """Create child ``idx`` with log-odds 0 and no colour (``ValueError`` if it exists)."""
    def deleteNodeChild(self, node: ColorOcTreeNode, idx: int) -> None:
        """Delete child ``idx``, its subtree and their colours."""
    def __copy__(self) -> ColorOcTree: ...
    def __deepcopy__(self, memo: dict[int, Any]) -> ColorOcTree: ...


class ColorMapper:
    """Coloured scans into a ``ColorOcTree`` as octomap_server's colour server inserts them:
    each end point's colour merges into its voxel's node before the scan's occupancy updates
    (a voxel is coloured from its second sighting on), then the scan, then ``prune()``. The
    same bytes as ``octoquant map --color``. ``merge``: ``"average"`` (octomap_server's
    ``averageNodeColor``) or ``"integrate"`` (``integrateNodeColor``); ``max_range``:
    octomap_server's ``sensor_model/max_range`` (a farther point only clears its ray, cut
    there, and the voxel where it is cut). The point filters of ``Mapper`` (keyword-only) drop
    points with their colours first."""

    def __init__(
        self,
        resolution: float = 0.1,
        merge: Literal["average", "integrate"] = "average",
        max_range: Optional[float] = None,
        prob_hit: float = 0.7,
        prob_miss: float = 0.4,
        clamping_min: float = 0.1192,
        clamping_max: float = 0.971,
        occupancy_threshold: float = 0.5,
        *,
        drop_zero: bool = False,
        min_range: Optional[float] = None,
        crop_sensor: Optional[Sequence[float]] = None,
        crop_world: Optional[Sequence[float]] = None,
        zmin: Optional[float] = None,
        zmax: Optional[float] = None,
        ground: Optional[float] = None,
        ground_angle: float = 0.15,
        ground_iterations: int = 200,
        ground_seed: int = 0,
        ground_clears: bool = False,
    ) -> None: ...
    def insert(
        self,
        points: Points,
        colors: NDArray[np.uint8],
        origin: Optional[Vec3] = None,
        pose: Optional[Pose] = None,
    ) -> dict[str, Any]:
        """Insert one scan: points (N, 3), uint8 RGB colours (N, 3), and either the sensor
        ``origin`` (world points) or its ``pose`` (sensor-frame points, moved as
        ``Mapper.insert`` moves them; ``crop_sensor`` in the pose's axes); not both
        (ValueError)."""
    def insert_frames(
        self, frames: Sequence[tuple[Points, NDArray[np.uint8], Optional[Vec3]]]
    ) -> list[dict[str, Any]]:
        """Insert scans ``(points, colors, origin)`` in order, the same map as one ``insert``
        each; the statistics of each. All are checked first: a bad one raises (naming
        ``frames[i]``) and nothing is inserted."""
    @property
    def tree(self) -> ColorOcTree:
        """A copy of the map so far."""
    @property
    def frames(self) -> int:
        """Scans inserted so far."""

class OcTreeNodeStamped:
    """A node of an OcTreeStamped as it was when it was looked up (a snapshot)."""

    def getValue(self) -> float:
        """The node's log-odds."""
    def getLogOdds(self) -> float:
        """The node's log-odds."""
    def getOccupancy(self) -> float:
        """The occupancy probability ``1 - 1/(1 + exp(log_odds))``."""
    def hasChildren(self) -> bool:
        """Whether the node had children."""
    def getDepth(self) -> int:
        """The node's depth (16 = voxel)."""
    def getKey(self) -> OcTreeKey:
        """The node's key at its depth."""
    def getTimestamp(self) -> int:
        """Whole seconds of the node's last update (OctoMap's ``getTimestamp``); 0 if never
        stamped, e.g. in a tree read from a file."""

class OcTreeStamped(OccupancyOcTreeBase):
    """OctoMap's OcTreeStamped: occupancy plus the time (whole seconds) of each node's last
    update, built by octoquant.

    ``OcTreeStamped(resolution)`` is an empty tree; ``OcTreeStamped(filename)`` reads a ``.ot``
    file of type OcTreeStamped (or the bytes ``write()`` returned). OctoMap reads the clock
    inside each stamping call; here each also takes ``now=`` (seconds) to stamp with a given
    time. ``.ot`` files hold no stamps (as OctoMap's): a tree read back has every stamp 0.
    """

    def __init__(self, arg: Union[float, StrOrBytesPath]) -> None: ...
    @staticmethod
    def read(filename: Union[StrOrBytesPath, bytes]) -> OcTreeStamped:
        """A tree from an OcTreeStamped ``.ot`` file or bytes (OSError, ValueError on failure,
        also for another tree type or a ``.bt``)."""
    @overload
    def write(self) -> bytes: ...
    @overload
    def write(self, filename: StrOrBytesPath) -> bool: ...
    def getTreeType(self) -> bytes: ...
    def getResolution(self) -> float: ...
    def size(self) -> int: ...
    def getNumLeafNodes(self) -> int: ...
    def clear(self) -> None: ...
    def getLastUpdateTime(self) -> int:
        """The root's stamp: the time of the last eager update anywhere; 0 when empty."""
    def updateNode(
        self,
        value: Union[OcTreeKey, NDArray[Any]],
        update: Union[bool, float],
        lazy_eval: bool = ...,
        *,
        now: Optional[int] = None,
    ) -> Optional[OcTreeNodeStamped]:
        """One observation at ``now`` (default the system clock): stamps the voxel, and the
        inner nodes on its way unless lazy; None outside the map."""
    def insertPointCloud(
        self,
        pointcloud: Points,
        origin: Vec3,
        maxrange: float = -1.0,
        lazy_eval: bool = False,
        discretize: bool = False,
        *,
        now: Optional[int] = None,
    ) -> None:
        """Integrate a scan (N, 3) seen from ``origin`` at ``now`` (default the system
        clock), every update stamped; releases the GIL."""
    def search(
        self, value: Union[OcTreeKey, NDArray[Any]], depth: int = ...
    ) -> Optional[OcTreeNodeStamped]: ...
    def getRoot(self) -> Optional[OcTreeNodeStamped]: ...
    def degradeOutdatedNodes(self, time_thres: int, *, now: Optional[int] = None) -> None:
        """One miss for every occupied leaf stamped more than ``time_thres`` s before ``now``
        (default the system clock); stamps and inner nodes stay."""
    def isNodeOccupied(self, node: Union[OcTreeNodeStamped, OcTreeNode, iterator_base]) -> bool: ...
    def updateInnerOccupancy(self, *, now: Optional[int] = None) -> None:
        """Inner nodes to the max of their children, stamped ``now``."""
    def toMaxLikelihood(self) -> None: ...
    def prune(self) -> None:
        """Collapse eight leaves with equal log-odds and equal stamps."""
    def expand(self, max_nodes: Optional[int] = None) -> None:
        """Expand every pruned node down to voxels (OctoMap's ``expand``); ``MemoryError``,
        nothing expanded, when it would add more than ``max_nodes`` nodes (default: more than
        the machine's physical memory could hold)."""
    def deleteNode(
        self, value: Union[OcTreeKey, NDArray[Any]], depth: int = ..., *, now: Optional[int] = None
    ) -> bool: ...
    def castRay(
        self,
        origin: Vec3,
        direction: Vec3,
        end: NDArray[np.floating[Any]],
        ignoreUnknownCells: bool = False,
        maxRange: float = -1.0,
    ) -> bool:
        """True when an occupied voxel is hit; ``end`` receives where the ray stopped."""
    def cast_rays(
        self,
        origins: Union[Vec3, Points],
        directions: Points,
        ignore_unknown: bool = False,
        max_range: Optional[float] = None,
    ) -> tuple[NDArray[np.bool_], NDArray[np.float64]]:
        """Many casts: (hit (N,), ends (N, 3), NaN where no cast was possible)."""
    def begin_tree(self, maxDepth: int = 0) -> tree_iterator:
        """Every node, inner ones too; ``getTimestamp()`` gives each one's stamp."""
    def begin_leafs(self, maxDepth: int = 0) -> leaf_iterator: ...
    def begin_leafs_bbx(self, bbx_min: Vec3, bbx_max: Vec3, maxDepth: int = 0) -> leaf_bbx_iterator: ...
    def end_tree(self) -> tree_iterator: ...
    def end_leafs(self) -> leaf_iterator: ...
    def end_leafs_bbx(self) -> leaf_bbx_iterator: ...
    def expandNode(self, node: OcTreeNodeStamped) -> None:
        """Give a childless node eight children with its value and stamp."""
    def pruneNode(self, node: OcTreeNodeStamped) -> bool:
        """Collapse children of equal log-odds and stamps (child 0's stamp); whether it did."""
    def isNodeCollapsible(self, node: OcTreeNodeStamped) -> bool: ...
    def nodeHasChildren(self, node: OcTreeNodeStamped) -> bool: ...
    def nodeChildExists(self, node: OcTreeNodeStamped, idx: int) -> bool: ...
    def getNodeChild(self, node: OcTreeNodeStamped, idx: int) -> Optional[OcTreeNodeStamped]: ...
    def createNodeChild(self, node: OcTreeNodeStamped, idx: int) -> OcTreeNodeStamped:
        """Create child ``idx`` with log-odds 0 and stamp 0 (``ValueError`` if it exists)."""
    def deleteNodeChild(self, node: OcTreeNodeStamped, idx: int) -> None: ...
    def updateNodeLogOdds(
        self, node: OcTreeNodeStamped, update: float, *, now: Optional[int] = None
    ) -> float:
        """Add and clamp the node's log-odds (no early exit, no ancestor refreshed) and stamp
        it ``now``; the new log-odds (``ValueError`` for a NaN sum)."""
    def integrateHit(self, node: OcTreeNodeStamped, *, now: Optional[int] = None) -> float: ...
    def integrateMiss(self, node: OcTreeNodeStamped, *, now: Optional[int] = None) -> float: ...
    def integrateMissNoTime(self, node: OcTreeNodeStamped) -> float:
        """One miss, clamped, the stamp kept."""
    def nodeToMaxLikelihood(self, node: OcTreeNodeStamped) -> float:
        """The node to the clamp on its side of the threshold, the stamp kept."""
    def setNodeTimestamp(self, node: OcTreeNodeStamped, timestamp: int) -> int:
        """OctoMap's ``node->setTimestamp(t)``."""
    def updateNodeTimestamp(self, node: OcTreeNodeStamped, *, now: Optional[int] = None) -> int:
        """OctoMap's ``node->updateTimestamp()``: the stamp ``now`` (default the system clock)."""
    def __copy__(self) -> OcTreeStamped: ...
    def __deepcopy__(self, memo: dict[int, Any]) -> OcTreeStamped: ...


class StampedMapper:
    """Scans into an ``OcTreeStamped`` as OctoMap's ``insertPointCloud`` puts them into one,
    every voxel and inner node an update reaches stamped with the scan's whole second: the same
    bytes as ``octoquant map --stamped``. ``degrade_older_than``: after each scan, one miss for
    every occupied leaf not updated for more than that many seconds (``degradeOutdatedNodes``,
    the CLI's ``--degrade-older-than``). ``mode``: as ``Mapper``'s but ``"simple"``; ``lazy``
    is refused (ValueError). The point filters of ``Mapper`` (keyword-only) drop points
    first."""

    def __init__(
        self,
        resolution: float = 0.1,
        degrade_older_than: Optional[int] = None,
        mode: Literal["exact", "discretize", "quantized", "quantized+bresenham"] = "exact",
        max_range: Optional[float] = None,
        lazy: bool = False,
        prob_hit: float = 0.7,
        prob_miss: float = 0.4,
        clamping_min: float = 0.1192,
        clamping_max: float = 0.971,
        occupancy_threshold: float = 0.5,
        *,
        drop_zero: bool = False,
        min_range: Optional[float] = None,
        crop_sensor: Optional[Sequence[float]] = None,
        crop_world: Optional[Sequence[float]] = None,
        zmin: Optional[float] = None,
        zmax: Optional[float] = None,
        ground: Optional[float] = None,
        ground_angle: float = 0.15,
        ground_iterations: int = 200,
        ground_seed: int = 0,
        ground_clears: bool = False,
    ) -> None: ...
    def insert(
        self,
        points: Points,
        origin: Optional[Vec3] = None,
        stamp: Optional[float] = None,
        pose: Optional[Pose] = None,
    ) -> dict[str, Any]:
        """Insert one scan (world points (N, 3) and sensor ``origin``, or sensor-frame points
        and the sensor ``pose``, moved as ``Mapper.insert`` moves them; not both) at time
        ``stamp`` (seconds, floored; default the system clock). Its statistics, with
        ``"stamp"`` the second used; ValueError for a time outside 0 ..= 2**32 - 1 s."""
    def insert_frames(
        self, frames: Sequence[tuple[Points, Optional[Vec3], Optional[float]]]
    ) -> list[dict[str, Any]]:
        """Insert scans ``(points, origin, stamp)`` in order (stamp None: the clock), the same
        map as one ``insert`` each; the statistics of each, with ``"stamp"``. All are checked
        first: a bad one raises (naming ``frames[i]``) and nothing is inserted."""
    @property
    def tree(self) -> OcTreeStamped:
        """A copy of the map so far, stamps included."""
    @property
    def frames(self) -> int:
        """Scans inserted so far."""
    @property
    def resolution(self) -> float: ...
    @property
    def degrade_older_than(self) -> Optional[int]: ...

class Mapper:
    """Builds a map from frames with octoquant's pipeline (see the module README)."""

    def __init__(
        self,
        resolution: float = 0.1,
        mode: Literal["exact", "discretize", "quantized", "quantized+bresenham", "simple"] = "exact",
        max_range: Optional[float] = None,
        threads: Optional[int] = None,
        lazy: bool = False,
        reduce: Union[None, float, Vec3] = None,
        prob_hit: float = 0.7,
        prob_miss: float = 0.4,
        clamping_min: float = 0.1192,
        clamping_max: float = 0.971,
        occupancy_threshold: float = 0.5,
        *,
        drop_zero: bool = False,
        min_range: Optional[float] = None,
        crop_sensor: Optional[Sequence[float]] = None,
        crop_world: Optional[Sequence[float]] = None,
        zmin: Optional[float] = None,
        zmax: Optional[float] = None,
        ground: Optional[float] = None,
        ground_angle: float = 0.15,
        ground_iterations: int = 200,
        ground_seed: int = 0,
        ground_clears: bool = False,
    ) -> None:
        """Point filters are keyword-only and off by default (the map is then OctoMap's):
        ``drop_zero`` points exactly at the sensor origin, ``min_range`` metres,
        ``crop_sensor``/``crop_world`` boxes ``(xmin, ymin, zmin, xmax, ymax, zmax)`` (drop
        inside the sensor-centred box / keep inside the world box), ``zmin``/``zmax`` world
        heights, ``ground`` RANSAC ground-plane distance. Statistics count ``zero`` points and
        the points each filter ``dropped`` (a dict by reason)."""
    def insert(
        self,
        points: Points,
        origin: Optional[Vec3] = None,
        pose: Optional[Pose] = None,
    ) -> dict[str, Any]:
        """Insert one frame (world points + origin, or sensor points + pose); its statistics."""
    def insert_frames(self, frames: Sequence[tuple[Points, Vec3]]) -> list[dict[str, Any]]:
        """Insert frames in order, pipelined; the statistics of each. All are read first: a
        bad one raises (naming ``frames[i]``) and nothing is inserted."""
    @property
    def tree(self) -> OcTree:
        """A copy of the map so far."""
    @property
    def mode(self) -> str: ...
    @property
    def resolution(self) -> float: ...
    def stats(self) -> dict[str, Any]:
        """Totals over every frame inserted so far."""

@overload
def read_frames(
    path: StrOrBytesPath,
    format: Optional[
        Literal["graph", "frames", "text", "vtk", "vtk-seq", "pcd", "tum-png", "tum", "mcap", "ply"]
    ] = None,
    *,
    points_global: bool = False,
    topic: Optional[str] = None,
    fixed_frame: Optional[str] = None,
    pixel_step: int = 1,
    trajectory: Optional[StrOrBytesPath] = None,
    depth_scale: Optional[float] = None,
    intrinsics: Optional[tuple[float, float, float, float]] = None,
    viewpoint: Optional[Literal["origin", "apply", "ignore"]] = None,
    first: int = 0,
    count: Optional[int] = None,
    colors: Literal[True],
    stamps: Literal[False] = False,
) -> list[tuple[NDArray[np.float32], NDArray[np.float32], NDArray[np.uint8]]]: ...
@overload
def read_frames(
    path: StrOrBytesPath,
    format: Optional[
        Literal["graph", "frames", "text", "vtk", "vtk-seq", "pcd", "tum-png", "tum", "mcap", "ply"]
    ] = None,
    *,
    points_global: bool = False,
    topic: Optional[str] = None,
    fixed_frame: Optional[str] = None,
    pixel_step: int = 1,
    trajectory: Optional[StrOrBytesPath] = None,
    depth_scale: Optional[float] = None,
    intrinsics: Optional[tuple[float, float, float, float]] = None,
    viewpoint: Optional[Literal["origin", "apply", "ignore"]] = None,
    first: int = 0,
    count: Optional[int] = None,
    colors: Literal[False] = False,
    stamps: Literal[True],
) -> list[tuple[NDArray[np.float32], NDArray[np.float32], Optional[float]]]: ...
@overload
def read_frames(
    path: StrOrBytesPath,
    format: Optional[
        Literal["graph", "frames", "text", "vtk", "vtk-seq", "pcd", "tum-png", "tum", "mcap", "ply"]
    ] = None,
    *,
    points_global: bool = False,
    topic: Optional[str] = None,
    fixed_frame: Optional[str] = None,
    pixel_step: int = 1,
    trajectory: Optional[StrOrBytesPath] = None,
    depth_scale: Optional[float] = None,
    intrinsics: Optional[tuple[float, float, float, float]] = None,
    viewpoint: Optional[Literal["origin", "apply", "ignore"]] = None,
    first: int = 0,
    count: Optional[int] = None,
    colors: Literal[True],
    stamps: Literal[True],
) -> list[tuple[NDArray[np.float32], NDArray[np.float32], NDArray[np.uint8], Optional[float]]]: ...
@overload
def read_frames(
    path: StrOrBytesPath,
    format: Optional[
        Literal["graph", "frames", "text", "vtk", "vtk-seq", "pcd", "tum-png", "tum", "mcap", "ply"]
    ] = None,
    *,
    points_global: bool = False,
    topic: Optional[str] = None,
    fixed_frame: Optional[str] = None,
    pixel_step: int = 1,
    trajectory: Optional[StrOrBytesPath] = None,
    depth_scale: Optional[float] = None,
    intrinsics: Optional[tuple[float, float, float, float]] = None,
    viewpoint: Optional[Literal["origin", "apply", "ignore"]] = None,
    first: int = 0,
    count: Optional[int] = None,
    colors: Literal[False] = False,
    stamps: Literal[False] = False,
) -> list[tuple[NDArray[np.float32], NDArray[np.float32]]]:
    """Frames ``[(points (N, 3) float32, origin (3,) float32), ...]`` from any input the CLI
    reads, with the reader options of ``octoquant map`` as keywords: ``format`` (``--format``),
    ``points_global`` (``--global``: .graph points already in world coordinates), ``topic`` and
    ``fixed_frame`` (MCAP), ``pixel_step`` (TUM depth); beyond the CLI ``trajectory`` (VTK
    sequence CSV), ``depth_scale`` (TUM raw units per metre, default 5000), ``intrinsics``
    ``(fx, fy, cx, cy)`` (TUM, default 525, 525, 319.5, 239.5) and ``viewpoint`` (PCD
    ``VIEWPOINT``: ``"origin"`` as PCL, the default, ``"apply"`` or ``"ignore"``). ``first`` and
    ``count``: only frames ``first .. first + count`` (all from ``first`` without a count),
    read no further than needed; an input with fewer frames raises ``ValueError``. ``colors``:
    also each frame's (N, 3) uint8 RGB colours, ``[(points, origin, colors), ...]`` (PCD, PLY,
    TUM with RGB images, PointCloud2, ``.frames`` files that store them; a frame without
    colours raises ``ValueError``). ``stamps``: also each frame's time in seconds (``None``
    where the input has none) as the last element (a TUM depth image's name, an MCAP cloud's
    header stamp, a VTK sequence scan's time, a ``.frames`` file's stored time: what ``map --stamped`` and :class:`StampedMapper` stamp a frame with). Bad
    options and files raise ``ValueError`` naming the file; a missing path
    ``FileNotFoundError``."""

def count_frames(
    path: StrOrBytesPath,
    format: Optional[
        Literal["graph", "frames", "text", "vtk", "vtk-seq", "pcd", "tum-png", "tum", "mcap", "ply"]
    ] = None,
    *,
    points_global: bool = False,
    topic: Optional[str] = None,
    fixed_frame: Optional[str] = None,
    pixel_step: int = 1,
    trajectory: Optional[StrOrBytesPath] = None,
    depth_scale: Optional[float] = None,
    intrinsics: Optional[tuple[float, float, float, float]] = None,
    viewpoint: Optional[Literal["origin", "apply", "ignore"]] = None,
) -> Optional[int]:
    """How many frames :func:`read_frames` gives for ``path``, known without reading points
    (file headers, association rows, MCAP statistics); ``None`` when the input does not say."""

def write_frames(
    path: StrOrBytesPath,
    frames: Iterable[tuple[Any, ...]],
    *,
    colors: bool = False,
    stamps: bool = False,
) -> None:
    """Write frames as a ``.frames`` file (what ``octoquant map``, ``bench``, the distributed
    build and :func:`read_frames` read back bit for bit). Each frame is a tuple laid out as
    :func:`read_frames` returns it with the same flags: ``(points (N, 3), origin (3,))``, then
    (N, 3) uint8 colours with ``colors=True``, then the time in seconds or ``None`` with
    ``stamps=True``. Points are stored as float32 (NaN kept); origins and stamps must be
    finite. Every frame is checked before anything is written (``TypeError``/``ValueError``
    naming ``frames[i]``); the file is replaced atomically, so a failed write (``OSError``)
    leaves no partial file."""

CellSize = Union[float, Sequence[float], NDArray[np.floating[Any]]]
Selection = Literal["centre", "center", "mean"]
CentreDistance = Literal["euclidean", "cell_units"]

@overload
def reduce(
    points: NDArray[np.float32],
    cell: CellSize,
    *,
    offset: Optional[CellSize] = None,
    selection: Selection = "centre",
    distance: CentreDistance = "euclidean",
    return_index: Literal[False] = False,
) -> NDArray[np.float32]: ...
@overload
def reduce(
    points: Union[NDArray[np.float64], Sequence[Sequence[float]]],
    cell: CellSize,
    *,
    offset: Optional[CellSize] = None,
    selection: Selection = "centre",
    distance: CentreDistance = "euclidean",
    return_index: Literal[False] = False,
) -> NDArray[np.float64]: ...
@overload
def reduce(
    points: Points,
    cell: CellSize,
    *,
    offset: Optional[CellSize] = None,
    selection: Selection = "centre",
    distance: CentreDistance = "euclidean",
    return_index: Literal[True],
) -> tuple[NDArray[np.floating[Any]], NDArray[np.int64]]: ...
def reduce(
    points: Points,
    cell: CellSize,
    *,
    offset: Optional[CellSize] = None,
    selection: Selection = "centre",
    distance: CentreDistance = "euclidean",
    return_index: bool = False,
) -> Any:
    """Reduce a cloud with the online grid density reducer (one read cycle).

    Each point goes to cell ``floor((p - offset) / cell)`` (``cell`` and ``offset``: one number
    or three); each cell keeps the point closest to its centre (``selection="centre"``) or to
    the mean of its points (``"mean"``); cells are read in ascending distance of that point to
    the centre and a point closer than half a cell on every axis to an emitted one is dropped.
    ``distance``: to the centre in the points' units (``"euclidean"``, the paper's criterion) or
    per axis in cell units (``"cell_units"``); they differ only when the cell sizes differ.
    Returns the kept points (a subset of the input, in output order, the input's dtype) and,
    with ``return_index``, their rows in ``points`` (int64). NaN/inf points are skipped. The
    result does not depend on the input order. Releases the GIL."""

class OutputCycle:
    """One read cycle of a DensityReducer, stepped with ``step`` (from ``begin_cycle()``)."""

    @property
    def id(self) -> int:
        """1 for the reducer's first cycle."""
    @property
    def finished(self) -> bool: ...
    def step(self, max_cells: Optional[int] = None) -> tuple[NDArray[np.float64], bool]:
        """Visit up to ``max_cells`` more cells (all when None): ``(emitted points, finished)``.
        ``RuntimeError`` when a newer cycle has begun."""
    def counts(self) -> dict[str, int]:
        """``emitted``, ``eliminated``, ``deferred`` so far."""

class DensityReducer:
    """The online grid density reducer: ``insert``/``remove`` points at any time, read the
    reduced cloud with ``output()`` or in steps with ``begin_cycle()``. ``len()`` is the number of
    non-empty cells. Points are stored as float64. Calls release the GIL but hold the reducer:
    a call from another thread meanwhile raises ``RuntimeError``; interleave input and output
    with ``begin_cycle()`` and ``OutputCycle.step``."""

    def __init__(
        self,
        cell: CellSize,
        *,
        offset: Optional[CellSize] = None,
        selection: Selection = "centre",
        distance: CentreDistance = "euclidean",
    ) -> None: ...
    def insert(self, points: Points) -> int:
        """Add an (N, 3) batch; returns how many points were rejected (NaN/inf/out of range)."""
    def remove(self, points: Points) -> NDArray[np.bool_]:
        """Delete one stored copy of each row (bit-equal as float64); whether each was found."""
    def output(self) -> NDArray[np.float64]:
        """One complete read cycle: the reduced points in output order."""
    def begin_cycle(self) -> OutputCycle:
        """Begin a read cycle to step through; older cycles become stale."""
    def selected_points(self) -> NDArray[np.float64]:
        """The point each cell keeps, in cell index order."""
    @property
    def point_count(self) -> int:
        """Points stored (all members of all cells)."""
    def counts(self) -> dict[str, int]:
        """``inserted``, ``rejected``, ``removed`` so far."""
    @property
    def cell(self) -> tuple[float, float, float]: ...
    @property
    def offset(self) -> tuple[float, float, float]: ...
    @property
    def selection(self) -> Literal["centre", "mean"]: ...
    @property
    def distance(self) -> CentreDistance: ...
    def validate(self) -> None:
        """Check the store's invariants (``RuntimeError`` if broken: a bug)."""
    def __len__(self) -> int: ...

@overload
def dbscan1d(
    x: Union[NDArray[Any], Sequence[float]],
    eps: float,
    min_points: int,
    period: Optional[float] = None,
    *,
    border: Literal["first", "noise"] = "first",
) -> NDArray[np.int64]: ...
@overload
def dbscan1d(
    x: Union[NDArray[Any], Sequence[float]],
    eps: float,
    min_points: int,
    period: Optional[float] = None,
    *,
    border: Literal["all"],
) -> tuple[NDArray[np.int64], NDArray[np.int64]]: ...
def dbscan1d(
    x: Union[NDArray[Any], Sequence[float]],
    eps: float,
    min_points: int,
    period: Optional[float] = None,
    *,
    border: Literal["first", "noise", "all"] = "first",
) -> Any:
    """DBSCAN on 1-D values in O(N) after sorting: int64 labels, -1 for noise. Neighbours are
    within ``eps`` (inclusive); core points have at least ``min_points`` neighbours, themselves
    included. With ``period``, values lie on a circle and must be in ``[0, period)``. Clusters
    are numbered in the order the original DBSCAN finds them visiting the values in ascending
    order; unsorted input is sorted first (stably) and the labels returned in input order.
    ``border``: border points join the first cluster reaching them, are noise (``"noise"``), or
    (``"all"``) the result is ``(labels, second_labels)``. NaN/inf or out-of-period values
    raise ``ValueError`` naming the index."""

def segment_scan(
    points: Union[NDArray[Any], Sequence[Sequence[float]]],
    *,
    eps_theta: Optional[float] = None,
    eps_dist: Optional[float] = None,
    min_points_theta: Optional[int] = None,
    min_points_dist: Optional[int] = None,
    min_line_points: Optional[int] = None,
    border: Literal["first", "noise", "all"] = "first",
    split_eps: Optional[float] = None,
    split_min_points: Optional[int] = None,
    split_spacing_factor: Optional[float] = None,
    resegment_rms: Optional[float] = None,
    resegment_eps: Optional[float] = None,
    resegment_min_points: Optional[int] = None,
) -> tuple[NDArray[np.void], NDArray[np.int64]]:
    """Line segments of one 2D laser scan: ``points`` (N, 2) valid returns in beam order, laser
    at the origin. Defaults are the library's: ``eps_theta`` 2 degrees (in radians), ``eps_dist``
    0.05 m, 5 points for each minimum; collinear lines separation ``split_eps`` 0.5 m (``inf``:
    off), ``split_min_points`` 2, ``split_spacing_factor`` 3 (median point spacings; 0: fixed
    epsilon); re-segmentation off unless ``resegment_rms`` is given
    (``resegment_eps`` 0.01 m, ``resegment_min_points`` 5). Returns ``(lines, labels)``: a structured array with
    fields normal_angle, distance (``x cos(a) + y sin(a) = distance``), start_x, start_y, end_x,
    end_y, length, n_points, rms_residual, max_residual, and the int64 line of each point (-1
    for none)."""

def read_laser_scans(
    path: StrOrBytesPath,
) -> list[tuple[NDArray[np.float64], NDArray[np.float64]]]:
    """The laser scans of a CARMEN log (FLASER/ROBOTLASER1, .gz/.bz2 allowed):
    ``[(points (N, 2) in the laser frame, laser pose (x, y, theta)), ...]``, the input of
    ``segment_scan``."""
