"""Type stubs of octoquant.distributed: exact tiled map building on Dask distributed."""

import os
from collections.abc import Sequence
from typing import Any, Literal, Optional, Union

import numpy as np
from numpy.typing import NDArray

from octoquant import OcTree

StrOrBytesPath = Union[str, bytes, "os.PathLike[str]", "os.PathLike[bytes]"]
Mode = Literal["exact", "discretize", "quantized", "quantized+bresenham"]
ReadOn = Literal["auto", "workers", "driver"]
Frames = Sequence[tuple[NDArray[np.float32], NDArray[np.float32]]]

MODES: tuple[str, ...]
READ_ON: tuple[str, ...]

def build_map(
    inputs: Union[StrOrBytesPath, Sequence[StrOrBytesPath]],
    resolution: float = 0.1,
    max_range: Optional[float] = None,
    mode: Mode = "exact",
    client: Optional[Any] = None,
    n_workers: Optional[int] = None,
    tile_depth: Optional[int] = None,
    frames_per_task: Optional[int] = None,
    spill_dir: Optional[StrOrBytesPath] = None,
    read_on: ReadOn = "auto",
    **reader_options: Any,
) -> Optional[OcTree]:
    """The map ``octoquant map`` builds from ``inputs`` with these options, node for node,
    built on a Dask ``client`` (a ``LocalCluster`` of ``n_workers`` when none is given);
    ``None`` with ``spill_dir`` (the map is then the directory of tiles)."""

def build_map_with_summary(
    inputs: Union[StrOrBytesPath, Sequence[StrOrBytesPath]],
    resolution: float = 0.1,
    max_range: Optional[float] = None,
    mode: Mode = "exact",
    client: Optional[Any] = None,
    n_workers: Optional[int] = None,
    tile_depth: Optional[int] = None,
    frames_per_task: Optional[int] = None,
    spill_dir: Optional[StrOrBytesPath] = None,
    read_on: ReadOn = "auto",
    **reader_options: Any,
) -> tuple[Optional[OcTree], dict[str, Any]]:
    """:func:`build_map` and its summary: frames, points, rays, tiles, workers, tasks, mode,
    frames read by the workers, bytes moved, seconds per stage and each worker's peak
    resident memory (``peak_rss_bytes_per_worker``)."""

def cast_tiles(
    frames: Frames,
    first: int,
    resolution: float,
    tile_depth: int,
    max_range: Optional[float] = None,
    mode: Mode = "exact",
) -> tuple[dict[int, bytes], dict[str, Any]]:
    """Cast frames (run indices from ``first``) and split their voxel sets by tile: each
    touched tile's update lists as bytes, and the totals."""

def apply_tile(
    tile_depth: int, tile_index: int, buffers: Sequence[bytes], resolution: float
) -> tuple[bytes, dict[str, Any]]:
    """A tile's update lists applied in frame order to a new tree: its ``.ot`` bytes and
    counts."""

def apply_tile_to_dir(
    tile_depth: int,
    tile_index: int,
    buffers: Sequence[bytes],
    resolution: float,
    spill_dir: StrOrBytesPath,
) -> tuple[Optional[str], int, dict[str, Any]]:
    """:func:`apply_tile` with the tile tree written into ``spill_dir``: the file name (None
    for an empty tile), its size in bytes and the counts."""

def join_tiles(tile_depth: int, trees: Sequence[bytes], resolution: float) -> OcTree:
    """Tile trees (``.ot`` bytes) joined into one tree, upper levels as OctoMap keeps them."""

def write_tile_index(
    spill_dir: StrOrBytesPath, resolution: float, tile_depth: int, tiles: Sequence[tuple[int, str]]
) -> None:
    """Write the index of a directory of tile files."""

def join_tile_dir(spill_dir: StrOrBytesPath) -> OcTree:
    """The map of a directory of tiles and its index (``octoquant join``)."""

def default_tile_depth(resolution: float) -> int:
    """Tiles of about 25.6 m a side at this resolution, depth 1..=14."""

def main(argv: Optional[Sequence[str]] = None) -> int:
    """The command line, ``python -m octoquant.distributed``."""
