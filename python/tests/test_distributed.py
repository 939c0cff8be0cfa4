"""octoquant.distributed builds, on Dask, the .bt and .ot bytes `octoquant map` writes for the
same real data, with 1 and 2 workers and several tile depths; its pieces (cast_tiles,
apply_tile, join_tiles) are checked on their own, bad buffers included.

Needs Dask distributed and the octoquant binary (OCTOQUANT_BIN, or target/release or
target/debug); without them these tests skip, except under CI=true.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import octoquant
from conftest import REPO, _missing

try:
    import distributed
except ImportError:  # pragma: no cover - depends on the environment
    distributed = None

from octoquant import distributed as od


@pytest.fixture(scope="module")
def dask():
    if distributed is None:
        _missing("Dask distributed (pip install 'dask[distributed]')")
    return distributed


@pytest.fixture(scope="module")
def cli():
    candidates = [os.environ.get("OCTOQUANT_BIN")] + [
        str(REPO / "target" / kind / "octoquant") for kind in ("release", "debug")
    ]
    for c in candidates:
        if c and Path(c).is_file() and os.access(c, os.X_OK):
            return c
    _missing("the octoquant binary (cargo build, or set OCTOQUANT_BIN)")


@pytest.fixture(scope="module")
def tum(data_dir):
    p = data_dir / "rgbd" / "tum_fr2_pioneer_slam2_subset" / "my_association.txt"
    if not p.is_file():
        _missing(str(p))
    return p


@pytest.fixture(scope="module")
def norlab(data_dir):
    p = data_dir / "lidar3d" / "norlab_icp_mapper_example"
    if not p.is_dir():
        _missing(str(p))
    return p


@pytest.fixture(scope="module")
def clients(dask):
    """Threaded LocalClusters of 1 and 2 workers (fast to start on a small machine)."""
    made = {}
    for n in (1, 2):
        cluster = dask.LocalCluster(
            n_workers=n, threads_per_worker=1, processes=False, dashboard_address=":0"
        )
        made[n] = (cluster, dask.Client(cluster))
    yield {n: c for n, (_, c) in made.items()}
    for cluster, client in made.values():
        client.close()
        cluster.close()


def cli_map(cli, inputs, tmp_path, *args):
    bt, ot = tmp_path / "cli.bt", tmp_path / "cli.ot"
    res = subprocess.run(
        [cli, "map", *map(str, inputs), *args, "-o", str(bt), "--ot", str(ot)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert res.returncode == 0, res.stderr
    return bt.read_bytes(), ot.read_bytes()


def tree_bytes(tree):
    ot = bytes(tree.write())
    bt = bytes(tree.writeBinary())
    return bt, ot


@pytest.mark.parametrize("workers", [1, 2])
@pytest.mark.parametrize("tile_depth", [3, 9])
def test_tum_matches_octoquant_map(cli, clients, tum, tmp_path, workers, tile_depth):
    want_bt, want_ot = cli_map(cli, [tum], tmp_path, "--res", "0.05", "--pixel-step", "8")
    tree, summary = od.build_map_with_summary(
        tum,
        resolution=0.05,
        client=clients[workers],
        tile_depth=tile_depth,
        frames_per_task=3,
        pixel_step=8,
    )
    bt, ot = tree_bytes(tree)
    assert ot == want_ot
    assert bt == want_bt
    assert summary["frames"] == 10 and summary["tasks"] == 4
    assert summary["workers"] == workers and summary["tile_depth"] == tile_depth
    assert summary["tiles"] >= 1 and summary["bytes_moved"]["update_lists"] > 0
    assert len(summary["peak_rss_bytes_per_worker"]) == workers
    assert all(v > 0 for v in summary["peak_rss_bytes_per_worker"].values())


@pytest.mark.parametrize("workers", [1, 2])
@pytest.mark.parametrize("tile_depth", [1, 6])
def test_norlab_matches_octoquant_map(cli, clients, norlab, tmp_path, workers, tile_depth):
    want_bt, want_ot = cli_map(cli, [norlab], tmp_path, "--res", "0.2", "--max-range", "10")
    tree = od.build_map(
        [norlab],
        resolution=0.2,
        max_range=10.0,
        client=clients[workers],
        tile_depth=tile_depth,
    )
    bt, ot = tree_bytes(tree)
    assert ot == want_ot
    assert bt == want_bt


def test_command_line_on_a_process_cluster(cli, dask, norlab, tmp_path):
    want_bt, want_ot = cli_map(cli, [norlab], tmp_path, "--res", "0.2", "--max-range", "8")
    out, ot = tmp_path / "d.bt", tmp_path / "d.ot"
    res = subprocess.run(
        [
            sys.executable, "-m", "octoquant.distributed", str(norlab), "--res", "0.2",
            "--max-range", "8", "-o", str(out), "--ot", str(ot), "--workers", "2",
            "--tile-depth", "4", "--frames-per-task", "5", "--json",
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert res.returncode == 0, res.stderr
    s = json.loads(res.stdout)
    assert out.read_bytes() == want_bt
    assert ot.read_bytes() == want_ot
    assert (s["frames"], s["points"], s["tasks"], s["workers"]) == (14, 579022, 3, 2)
    b = s["bytes_moved"]
    assert b["total"] == b["frames"] + b["update_lists"] + b["tile_trees"] > 0
    assert set(s["seconds"]) == {"read", "cast", "apply", "join", "total"}
    # one figure per worker process, in bytes: a Python process with Dask and NumPy loaded
    # holds tens of megabytes (a figure left in KiB would be a thousand times smaller)
    peak = s["peak_rss_bytes_per_worker"]
    assert len(peak) == 2 and all(v > 20e6 for v in peak.values()), peak
    bad = subprocess.run(
        [sys.executable, "-m", "octoquant.distributed", str(norlab), "-o", str(tmp_path / "x.txt")],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert bad.returncode != 0 and ".bt" in bad.stderr


def test_pieces_by_hand_match_the_mapper(tum):
    frames = octoquant.read_frames(tum, pixel_step=16)[:4]
    m = octoquant.Mapper(resolution=0.05)
    for pts, origin in frames:
        m.insert(pts, origin)
    want_bt, want_ot = tree_bytes(m.tree)
    for depth in (0, 2, 8, 16):
        a, sa = octoquant.distributed.cast_tiles(frames[:3], 0, 0.05, depth)
        b, sb = octoquant.distributed.cast_tiles(frames[3:], 3, 0.05, depth)
        assert sa["frames"] + sb["frames"] == 4
        trees = []
        for tile in sorted(set(a) | set(b), reverse=True):
            bufs = [x[tile] for x in (b, a) if tile in x]
            ot, st = octoquant.distributed.apply_tile(depth, tile, bufs, 0.05)
            assert st["frames"] >= 1
            trees.append(ot)
        tree = octoquant.distributed.join_tiles(depth, trees, 0.05)
        assert tree_bytes(tree) == (want_bt, want_ot), f"tile depth {depth}"


def test_bad_input_is_a_clear_error(tum):
    frames = octoquant.read_frames(tum, pixel_step=32)[:1]
    lists, _ = octoquant.distributed.cast_tiles(frames, 0, 0.1, 3)
    tile, buf = next(iter(lists.items()))
    with pytest.raises(ValueError, match="checksum"):
        octoquant.distributed.apply_tile(3, tile, [buf[:-1] + bytes([buf[-1] ^ 1])], 0.1)
    with pytest.raises(ValueError, match="buffer 0"):
        octoquant.distributed.apply_tile(3, tile, [b"junk"], 0.1)
    with pytest.raises(ValueError, match="given to"):
        octoquant.distributed.apply_tile(3, tile ^ 1, [buf], 0.1)
    with pytest.raises(ValueError, match="tile_depth"):
        octoquant.distributed.cast_tiles(frames, 0, 0.1, 17)
    with pytest.raises(ValueError, match="tile tree 0"):
        octoquant.distributed.join_tiles(3, [b"not a tree"], 0.1)
    with pytest.raises(ValueError, match="not supported"):
        od.build_map(tum, mode="quantized")
    with pytest.raises(ValueError, match="tile_depth"):
        od.build_map(tum, tile_depth=17)
    assert od.default_tile_depth(0.1) == 8


@pytest.mark.parametrize("workers", [1, 2])
def test_spilled_tiles_join_to_octoquant_map(cli, clients, norlab, tmp_path, workers):
    want_bt, want_ot = cli_map(cli, [norlab], tmp_path, "--res", "0.2", "--max-range", "10")
    spill = tmp_path / "tiles"
    tree, s = od.build_map_with_summary(
        [norlab],
        resolution=0.2,
        max_range=10.0,
        client=clients[workers],
        tile_depth=6,
        spill_dir=spill,
    )
    assert tree is None
    files = sorted(p.name for p in spill.iterdir())
    assert "tiles.index" in files and len(files) == s["tiles"] + 1
    assert s["bytes_moved"]["tile_trees"] == 0
    assert s["tile_file_bytes"] == sum(
        p.stat().st_size for p in spill.iterdir() if p.name != "tiles.index"
    )
    res = subprocess.run(
        [cli, "join", str(spill), "-o", str(tmp_path / "j.bt"), "-o", str(tmp_path / "j.ot")],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert res.returncode == 0, res.stderr
    assert (tmp_path / "j.bt").read_bytes() == want_bt
    assert (tmp_path / "j.ot").read_bytes() == want_ot
    assert tree_bytes(od.join_tile_dir(spill)) == (want_bt, want_ot)
    # a second build into the same directory is refused before any work
    with pytest.raises(ValueError, match="not empty"):
        od.build_map([norlab], resolution=0.2, client=clients[workers], spill_dir=spill)


def test_command_line_output_rules(norlab, tmp_path, capsys):
    # no -o is allowed only with --spill; --ot needs -o
    for argv in (
        [str(norlab)],
        [str(norlab), "--spill", str(tmp_path / "t"), "--ot", str(tmp_path / "x.ot")],
    ):
        with pytest.raises(SystemExit) as e:
            od.main(argv)
        assert e.value.code == 2
    err = capsys.readouterr().err
    assert "-o is required" in err and "--ot needs -o" in err
    assert not (tmp_path / "t").exists()
