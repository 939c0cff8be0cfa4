"""octoquant: OctoMap-compatible occupancy octrees from NumPy, fast.

``octoquant.OcTree`` is a drop-in for octomap-python's ``octomap.OcTree``: the same method
names, signatures and results (the ``.bt``/``.ot`` bytes are identical), built by octoquant's
Rust library, with the GIL released during heavy calls. See ``python/README.md`` for the
migration table.
"""

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

__all__ = [
    "ColorMapper",
    "ColorOcTree",
    "ColorOcTreeNode",
    "DensityReducer",
    "Mapper",
    "NullPointerException",
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
