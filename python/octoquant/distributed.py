"""Exact tiled map building on Dask distributed: one map from many workers, with the bytes of a
single ``octoquant map`` run.

The map's key space is cut into tiles (the nodes at depth ``tile_depth`` of OctoMap's octree).
Tasks cast the rays of batches of frames and return, per tile, compact sorted update lists
(Morton codes, free or occupied, tagged with the frame index, as checked bytes); one task per
tile applies its lists in frame order to the tile's own tree (OctoMap's ``updateNode``:
clamping, pruning); the driver joins the tile trees and recomputes the levels above the tile
depth exactly as OctoMap keeps them. The Rust crate ``octoquant-tiles`` holds the pieces and
the argument for why the result is the sequential tree, node for node; this module only
orchestrates.

Runs on a ``LocalCluster`` by default, or on any ``distributed.Client`` (dask-jobqueue,
dask-kubernetes, cloud clusters). Command line::

    python -m octoquant.distributed INPUT... --res R [--max-range M] [--mode MODE]
        -o OUT.bt [--ot OUT.ot] [--workers N | --scheduler ADDR] [--tile-depth D]
        [--frames-per-task K] [--spill DIR] [--read-on auto|workers|driver] [--json]

Out of core: with ``spill_dir`` (``--spill DIR``) each tile task writes its tile tree into
that directory (one ``.ot`` per tile, on a file system the workers and the driver share)
instead of returning it, and the driver writes the directory's index at the end; the map is
then the directory, assembled by ``octoquant join DIR -o map.bt`` or :func:`join_tile_dir`,
byte-identical to the in-memory build.

Inputs: when every input announces its frame count (``.frames``, ``.graph``, TUM, VTK
sequences, single scans, MCAP with statistics) each ray task reads its own slice of frames
(the inputs must then be at the same path on the workers, as for ``spill_dir``); otherwise,
or with ``read_on="driver"``, the driver reads the inputs and ships the frames inside the
tasks. Either way every task can be rerun from what the scheduler holds, so a worker lost
mid-build costs time, not bytes: Dask reruns its tasks and the map is the same.
"""

import argparse
import json
import math
import os
import sys
import time

from octoquant._octoquant import (
    apply_tile,
    apply_tile_to_dir,
    cast_tiles,
    count_frames,
    default_tile_depth,
    join_tile_dir,
    join_tiles,
    read_frames,
    write_tile_index,
)

__all__ = [
    "apply_tile",
    "build_map",
    "build_map_with_summary",
    "cast_tiles",
    "default_tile_depth",
    "join_tile_dir",
    "join_tiles",
    "main",
]

MODES = ("exact", "discretize", "quantized", "quantized+bresenham")
READ_ON = ("auto", "workers", "driver")


def _cast_batch(frames, first, resolution, tile_depth, max_range, mode):
    """Task: cast a batch of frames; per-tile update lists as bytes, and the batch's counts."""
    return cast_tiles(frames, first, resolution, tile_depth, max_range=max_range, mode=mode)


def _cast_slice(path, start, count, first, reader_options, resolution, tile_depth, max_range, mode):
    """Task: read frames ``start .. start + count`` of ``path`` (run indices from ``first``)
    and cast them as :func:`_cast_batch` does."""
    frames = read_frames(path, first=start, count=count, **reader_options)
    return _cast_batch(frames, first, resolution, tile_depth, max_range, mode)


def _batch_summary(result):
    """Task: what the driver needs of a batch: its tiles with their list sizes, and counts."""
    lists, stats = result
    return {tile: len(b) for tile, b in lists.items()}, stats


def _pick(result, tile):
    """Task: one tile's lists of a batch (runs where the batch is, ships only this)."""
    return result[0][tile]


def _apply(tile_depth, tile, resolution, *buffers):
    """Task: a tile's lists applied in frame order; the tile tree as .ot bytes and counts."""
    return apply_tile(tile_depth, tile, list(buffers), resolution)


def _apply_to_dir(tile_depth, tile, resolution, spill_dir, *buffers):
    """Task: :func:`_apply` with the tile tree written into ``spill_dir``; its file name, size
    and counts."""
    return apply_tile_to_dir(tile_depth, tile, list(buffers), resolution, spill_dir)


def _prepare_spill_dir(spill_dir):
    """Create the spill directory, or check that an existing one is empty: tiles of two builds
    must not mix."""
    spill_dir = os.fspath(spill_dir)
    os.makedirs(spill_dir, exist_ok=True)
    if os.listdir(spill_dir):
        raise ValueError(f"spill_dir {spill_dir} is not empty (it may hold another build's tiles)")
    return spill_dir


def _peak_rss():
    """Peak resident memory of this (worker) process so far, in bytes (``ru_maxrss`` counts
    KiB on Linux, bytes on macOS); ``None`` where there is no ``resource`` module (Windows)."""
    try:
        import resource
    except ImportError:  # pragma: no cover - depends on the platform
        return None
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak if sys.platform == "darwin" else peak * 1024


def _plan_inputs(inputs, reader_options, read_on):
    """Per input: its frame count when the workers are to read it, else its frames (read
    here). ``read_on="workers"`` with an input that does not announce its count is an error."""
    plan = []
    for path in inputs:
        path = os.fspath(path)
        n = None if read_on == "driver" else count_frames(path, **reader_options)
        if n is None and read_on == "workers":
            raise ValueError(
                f"{path}: the input does not announce its frame count, so workers cannot read "
                'their own slices of it; use read_on="driver"'
            )
        if n is None:
            plan.append((path, None, read_frames(path, **reader_options)))
        else:
            plan.append((path, n, None))
    return plan


def build_map_with_summary(
    inputs,
    resolution=0.1,
    max_range=None,
    mode="exact",
    client=None,
    n_workers=None,
    tile_depth=None,
    frames_per_task=None,
    spill_dir=None,
    read_on="auto",
    **reader_options,
):
    """:func:`build_map`, also returning a summary dict: frames, points, rays, tiles, workers,
    bytes moved (frames shipped by the driver, update lists, tile trees), which frames the
    workers read themselves, and seconds per stage (read, cast, apply, join). With
    ``spill_dir`` the tree is ``None`` (the map is the directory), tile trees are not moved (``bytes_moved["tile_trees"]`` is 0), ``tile_file_bytes`` says how
    much the tiles take on disk, and ``join`` is the time to write the index.
    ``peak_rss_bytes_per_worker`` maps each worker's address to the peak resident memory of
    its process, read after the apply stage (since the process started: a long-lived
    worker's earlier work counts; threaded workers share one process)."""
    if read_on not in READ_ON:
        raise ValueError(f"read_on must be one of {READ_ON}, got {read_on!r}")
    if mode not in MODES:
        raise ValueError(
            f"mode {mode!r} is not supported by the distributed build yet; expected one of {MODES}"
        )
    if not (isinstance(resolution, (int, float)) and math.isfinite(resolution) and resolution > 0):
        raise ValueError(f"resolution must be finite and > 0, got {resolution!r}")
    if max_range is not None and math.isnan(max_range):
        raise ValueError("max_range must not be NaN")
    if isinstance(inputs, (str, bytes, os.PathLike)):
        inputs = [inputs]
    inputs = list(inputs)
    if not inputs:
        raise ValueError("no inputs")
    if tile_depth is None:
        tile_depth = default_tile_depth(resolution)
    if not (isinstance(tile_depth, int) and 0 <= tile_depth <= 16):
        raise ValueError(f"tile_depth must be an integer 0..=16, got {tile_depth!r}")
    if frames_per_task is not None and not (isinstance(frames_per_task, int) and frames_per_task >= 1):
        raise ValueError(f"frames_per_task must be a positive integer, got {frames_per_task!r}")
    if n_workers is not None and not (isinstance(n_workers, int) and n_workers >= 1):
        raise ValueError(f"n_workers must be a positive integer, got {n_workers!r}")
    try:
        import distributed
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError(
            "octoquant.distributed needs Dask distributed: pip install 'dask[distributed]'"
        ) from e

    if spill_dir is not None:
        spill_dir = _prepare_spill_dir(spill_dir)

    seconds = {}
    t0 = time.perf_counter()
    plan = _plan_inputs(inputs, reader_options, read_on)
    seconds["read"] = time.perf_counter() - t0
    total_frames = sum(n if frames is None else len(frames) for _, n, frames in plan)

    own_cluster = None
    if client is None:
        own_cluster = distributed.LocalCluster(
            n_workers=n_workers if n_workers is not None else 2,
            threads_per_worker=1,
            dashboard_address=":0",
        )
        client = distributed.Client(own_cluster)
    try:
        workers = len(client.scheduler_info()["workers"]) or 1
        per_task = frames_per_task or max(1, math.ceil(total_frames / (2 * workers)))

        t = time.perf_counter()
        batches = []
        frame_bytes = 0
        worker_read = 0
        first = 0
        # the frames travel inside the tasks (never scattered): a lost worker's tasks can be
        # rerun from what the scheduler holds
        for path, n, frames in plan:
            size = n if frames is None else len(frames)
            for start in range(0, size, per_task):
                count = min(per_task, size - start)
                if frames is None:
                    worker_read += count
                    task = (_cast_slice, path, start, count, first, reader_options)
                else:
                    chunk = frames[start : start + count]
                    frame_bytes += sum(p.nbytes + o.nbytes for p, o in chunk)
                    task = (_cast_batch, chunk, first)
                batches.append(
                    client.submit(
                        *task, resolution, tile_depth, max_range, mode, pure=False
                    )
                )
                first += count
        summaries = client.gather(client.map(_batch_summary, batches, pure=False))
        seconds["cast"] = time.perf_counter() - t

        t = time.perf_counter()
        tiles = {}
        list_bytes = 0
        for batch, (sizes, _) in zip(batches, summaries):
            for tile, n in sizes.items():
                list_bytes += n
                tiles.setdefault(tile, []).append(
                    client.submit(_pick, batch, tile, pure=False)
                )
        if spill_dir is None:
            tile_futures = [
                client.submit(_apply, tile_depth, tile, resolution, *parts, pure=False)
                for tile, parts in sorted(tiles.items())
            ]
        else:
            tile_futures = [
                client.submit(
                    _apply_to_dir, tile_depth, tile, resolution, spill_dir, *parts, pure=False
                )
                for tile, parts in sorted(tiles.items())
            ]
        results = client.gather(tile_futures)
        seconds["apply"] = time.perf_counter() - t
        peak_rss = client.run(_peak_rss)
        tiles_seen = sorted(tiles)
        del batches, tiles, tile_futures
    finally:
        if own_cluster is not None:
            client.close()
            own_cluster.close()

    t = time.perf_counter()
    file_bytes = None
    if spill_dir is None:
        trees = [ot for ot, _ in results]
        tree_bytes = sum(len(ot) for ot in trees)
        tree = join_tiles(tile_depth, trees, resolution)
    else:
        tree, tree_bytes = None, 0
        written = [
            (tile, name) for tile, (name, _, _) in zip(tiles_seen, results) if name
        ]
        file_bytes = sum(n for _, n, _ in results)
        write_tile_index(spill_dir, resolution, tile_depth, written)
    seconds["join"] = time.perf_counter() - t
    seconds["total"] = time.perf_counter() - t0

    totals = {"frames": 0, "points": 0, "rays": 0, "free": 0, "occupied": 0}
    for _, stats in summaries:
        for k in totals:
            totals[k] += stats[k]
    summary = dict(totals)
    summary.update(
        {
            "tiles": len(results),
            "tile_depth": tile_depth,
            "workers": workers,
            "tasks": len(summaries),
            "frames_per_task": per_task,
            "mode": mode,
            "frames_read_by_workers": worker_read,
            "bytes_moved": {
                "frames": frame_bytes,
                "update_lists": list_bytes,
                "tile_trees": tree_bytes,
                "total": frame_bytes + list_bytes + tree_bytes,
            },
            "seconds": seconds,
            "peak_rss_bytes_per_worker": peak_rss,
        }
    )
    if spill_dir is not None:
        summary["spill_dir"] = spill_dir
        summary["tile_file_bytes"] = file_bytes
    return tree, summary


def build_map(
    inputs,
    resolution=0.1,
    max_range=None,
    mode="exact",
    client=None,
    n_workers=None,
    tile_depth=None,
    frames_per_task=None,
    spill_dir=None,
    read_on="auto",
    **reader_options,
):
    """Build one map from sensor files on Dask: the ``OcTree`` ``octoquant map`` builds from
    the same inputs and options, node for node (so the same ``.bt`` and ``.ot`` bytes), for any
    worker count, tile depth and task size.

    ``inputs``: a path or a list of paths (files or scan directories), read in order as
    ``octoquant map`` reads them; ``reader_options`` are :func:`octoquant.read_frames`'s
    keywords. ``resolution``, ``max_range``, ``mode`` (``"exact"``, ``"discretize"``,
    ``"quantized"``, ``"quantized+bresenham"``): as ``octoquant map``. ``client``: a ``distributed.Client`` to run on; without one a
    ``LocalCluster`` of ``n_workers`` processes (default 2) is started and closed.
    ``tile_depth``: depth of the tiles in the key space (0..=16; default: tiles of about
    25.6 m); ``frames_per_task``: frames per ray task (default: two tasks per worker).
    ``spill_dir``: out of core; each tile tree is written there (one ``.ot`` per tile, then
    the index) by the worker that built it, nothing is joined in memory and ``None`` is
    returned; ``octoquant join DIR -o map.bt`` or :func:`join_tile_dir` assembles the map
    (same bytes). The directory is created, or must be empty, and must be on a file system
    the workers share. ``read_on``: ``"auto"`` (default) lets each ray task read its own slice
    of an input that announces its frame count and has the driver read the others;
    ``"workers"`` insists on the former (ValueError for an input without a count), and
    ``"driver"`` ships every frame from the driver (for workers that cannot see the inputs).

    A script that lets this start a ``LocalCluster`` must call it under
    ``if __name__ == "__main__":``, as for any Dask cluster of processes (the workers are
    spawned and import the script's main module).
    """
    tree, _ = build_map_with_summary(
        inputs,
        resolution=resolution,
        max_range=max_range,
        mode=mode,
        client=client,
        n_workers=n_workers,
        tile_depth=tile_depth,
        frames_per_task=frames_per_task,
        spill_dir=spill_dir,
        read_on=read_on,
        **reader_options,
    )
    return tree


def _text_summary(s, out, ot):
    b = s["bytes_moved"]
    sec = s["seconds"]
    lines = [
        f"frames {s['frames']}, points {s['points']}, rays {s['rays']}",
        f"tiles {s['tiles']} at depth {s['tile_depth']}, {s['tasks']} ray tasks of "
        f"{s['frames_per_task']} frames on {s['workers']} workers, mode {s['mode']}, "
        f"{s['frames_read_by_workers']} frames read by the workers",
        f"bytes moved {b['total']} (frames {b['frames']}, update lists {b['update_lists']}, "
        f"tile trees {b['tile_trees']})",
        "seconds: "
        + ", ".join(f"{k} {sec[k]:.3f}" for k in ("read", "cast", "apply", "join", "total")),
        "peak memory per worker (MB): "
        + ", ".join(
            "?" if v is None else f"{v / 1e6:.0f}"
            for _, v in sorted(s["peak_rss_bytes_per_worker"].items())
        ),
    ]
    if s.get("spill_dir"):
        lines.append(f"tiles in {s['spill_dir']} ({s['tile_file_bytes']} bytes)")
    if out:
        lines.append(f"wrote {out}" + (f" and {ot}" if ot else ""))
    return "\n".join(lines)


def main(argv=None):
    """The command line (``python -m octoquant.distributed --help``)."""
    p = argparse.ArgumentParser(
        prog="python -m octoquant.distributed",
        description="Build one OctoMap map on Dask distributed, byte-identical to `octoquant map`.",
    )
    p.add_argument("inputs", nargs="+", metavar="INPUT", help="sensor files or scan directories")
    p.add_argument("--res", type=float, default=0.1, help="leaf size in metres (default 0.1)")
    p.add_argument("--max-range", type=float, default=None, help="readings beyond only clear space")
    p.add_argument("--mode", choices=MODES, default="exact", help="insertion mode (as `octoquant map`)")
    p.add_argument(
        "-o", "--output", default=None, help="the .bt to write (optional with --spill)"
    )
    p.add_argument("--ot", default=None, help="also write the full tree as .ot")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, default=None, help="LocalCluster workers (default 2)")
    where.add_argument("--scheduler", default=None, help="a running scheduler, tcp://HOST:PORT")
    p.add_argument("--tile-depth", type=int, default=None, help="tile depth 0..16")
    p.add_argument("--frames-per-task", type=int, default=None, help="frames per ray task")
    p.add_argument(
        "--spill",
        default=None,
        metavar="DIR",
        help="write the tiles into DIR (one .ot per tile plus tiles.index; "
        "`octoquant join DIR -o map.bt` assembles them); -o then joins them too",
    )
    p.add_argument(
        "--read-on",
        choices=READ_ON,
        default="auto",
        help="who reads the inputs: each task its own slice (workers; the inputs must be at "
        "the same path there), the driver, or auto (workers when the input announces its "
        "frame count)",
    )
    p.add_argument("--format", default=None, help="input format (as `octoquant map --format`)")
    p.add_argument("--pixel-step", type=int, default=1, help="TUM depth images: every N-th pixel")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    a = p.parse_args(argv)
    if a.output is None and a.spill is None:
        p.error("-o is required (unless --spill keeps the map as tiles)")
    if a.ot is not None and a.output is None:
        p.error("--ot needs -o")
    if a.output is not None and not a.output.lower().endswith(".bt"):
        p.error(f"-o must name a .bt file, got {a.output}")
    if a.ot is not None and not a.ot.lower().endswith(".ot"):
        p.error(f"--ot must name a .ot file, got {a.ot}")
    reader = {"pixel_step": a.pixel_step}
    if a.format is not None:
        reader["format"] = a.format
    client = None
    try:
        if a.scheduler is not None:
            import distributed

            client = distributed.Client(a.scheduler)
        tree, summary = build_map_with_summary(
            a.inputs,
            resolution=a.res,
            max_range=a.max_range,
            mode=a.mode,
            client=client,
            n_workers=a.workers,
            tile_depth=a.tile_depth,
            frames_per_task=a.frames_per_task,
            spill_dir=a.spill,
            read_on=a.read_on,
            **reader,
        )
        if tree is None and a.output is not None:
            tree = join_tile_dir(a.spill)
    except (ValueError, OSError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    finally:
        if client is not None:
            client.close()
    # the .ot first: the .bt's max-likelihood conversion changes the tree
    if tree is not None:
        if a.ot is not None:
            tree.write(a.ot)
        tree.writeBinary(a.output)
    summary["output"] = a.output
    summary["ot"] = a.ot
    if a.json:
        print(json.dumps(summary))
    else:
        print(_text_summary(summary, a.output, a.ot))
    return 0


if __name__ == "__main__":
    from octoquant.distributed import main as _main

    sys.exit(_main())
