"""octoquant: OctoMap-compatible occupancy octrees from NumPy, fast.

``octoquant.OcTree`` is a drop-in for octomap-python's ``octomap.OcTree``: the same method
names, signatures and results (the ``.bt``/``.ot`` bytes are identical), built by octoquant's
Rust library, with the GIL released during heavy calls. See ``python/README.md`` for the
migration table.
"""

import abc

from octoquant._octoquant import (
    ColorMapper,
    ColorOcTree,
    ColorOcTreeNode,
    DensityReducer,
    Mapper,
    NullPointerException,
    OcTree,
    OcTreeKey,
    OcTreeNode,
    OcTreeNodeStamped,
    OcTreeStamped,
    OutputCycle,
    StampedMapper,
    count_frames,
    dbscan1d,
    iterator_base,
    leaf_bbx_iterator,
    leaf_iterator,
    read_frames,
    read_laser_scans,
    reduce,
    segment_scan,
    tree_iterator,
    write_frames,
)



class OccupancyOcTreeBase(abc.ABC):
    """The occupancy trees' common base, as octomap-python's ``OccupancyOcTreeBase``:
    ``isinstance(t, OccupancyOcTreeBase)`` holds for every ``OcTree``, ``ColorOcTree`` and
    ``OcTreeStamped``, so that code checking for octomap-python's base runs unchanged. It is
    not a tree: constructing it raises TypeError (octomap-python's gives an object whose calls
    have no tree behind them)."""

    def __new__(cls, *args, **kwargs):
        raise TypeError(
            "OccupancyOcTreeBase is the trees' common base; construct OcTree, ColorOcTree or "
            "OcTreeStamped"
        )


for _tree in (OcTree, ColorOcTree, OcTreeStamped):
    OccupancyOcTreeBase.register(_tree)
del _tree

__all__ = [
    "ColorMapper",
    "ColorOcTree",
    "ColorOcTreeNode",
    "DensityReducer",
    "Mapper",
    "NullPointerException",
    "OccupancyOcTreeBase",
    "OcTree",
    "OcTreeKey",
    "OcTreeNode",
    "OcTreeNodeStamped",
    "OcTreeStamped",
    "OutputCycle",
    "StampedMapper",
    "count_frames",
    "dbscan1d",
    "iterator_base",
    "leaf_bbx_iterator",
    "leaf_iterator",
    "read_frames",
    "read_laser_scans",
    "reduce",
    "segment_scan",
    "tree_iterator",
    "write_frames",
]
