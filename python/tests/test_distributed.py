"""octoquant.distributed builds, on Dask, the .bt and .ot bytes `octoquant map` writes for the
same real data, with 1 and 2 workers and several tile depths; its pieces (cast_tiles,
apply_tile, join_tiles) are checked on their own, bad buffers included.

Needs Dask distributed and the octoquant binary (OCTOQUANT_BIN, or target/release or
target/debug); without them these tests skip, except under CI=true.
"""

import json
import os
import signal
import subprocess
import sys

import numpy as np
import pytest

import octoquant
from conftest import _missing

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
        od.build_map(tum, mode="simple")
    with pytest.raises(ValueError, match="read_on"):
        od.build_map(tum, read_on="somewhere")
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


@pytest.mark.parametrize("mode", ["discretize", "quantized", "quantized+bresenham"])
def test_every_frame_set_mode_matches_octoquant_map(cli, clients, norlab, tmp_path, mode):
    want_bt, want_ot = cli_map(
        cli, [norlab], tmp_path, "--res", "0.2", "--max-range", "10", "--mode", mode
    )
    for workers, read_on in ((1, "driver"), (2, "workers")):
        tree, s = od.build_map_with_summary(
            [norlab],
            resolution=0.2,
            max_range=10.0,
            mode=mode,
            client=clients[workers],
            tile_depth=5,
            frames_per_task=4,
            read_on=read_on,
        )
        assert tree_bytes(tree) == (want_bt, want_ot), (workers, read_on)
        assert s["mode"] == mode and s["tasks"] == 4
        # who read the frames: the driver ships them, or each task reads its own slice
        if read_on == "driver":
            assert s["frames_read_by_workers"] == 0 and s["bytes_moved"]["frames"] > 0
        else:
            assert s["frames_read_by_workers"] == 14 and s["bytes_moved"]["frames"] == 0


def test_frame_slices_are_the_whole_read_in_pieces(tum, norlab):
    for path, opts in ((tum, {"pixel_step": 16}), (norlab, {})):
        whole = octoquant.read_frames(path, **opts)
        assert octoquant.count_frames(path, **opts) == len(whole) > 3
        pieces = []
        for first in range(0, len(whole), 3):
            pieces += octoquant.read_frames(path, first=first, count=3 if first + 3 <= len(whole)
                                            else len(whole) - first, **opts)
        assert len(pieces) == len(whole)
        for (p, o), (q, r) in zip(pieces, whole):
            assert np.array_equal(p, q) and np.array_equal(o, r)
        tail = octoquant.read_frames(path, first=len(whole) - 1, **opts)
        assert len(tail) == 1 and np.array_equal(tail[0][0], whole[-1][0])
        assert octoquant.read_frames(path, first=2, count=0, **opts) == []
        with pytest.raises(ValueError, match=f"has only {len(whole)}"):
            octoquant.read_frames(path, first=len(whole) - 1, count=2, **opts)
        with pytest.raises(ValueError, match=f"has only {len(whole)}"):
            octoquant.read_frames(path, first=len(whole) + 1, **opts)
        with pytest.raises(ValueError, match="first"):
            octoquant.read_frames(path, first=-1, **opts)


def test_text_input_without_a_count_is_read_by_the_driver(clients, tmp_path):
    # a text scan log announces no frame count: auto has the driver read it, workers refuses
    log = tmp_path / "scan.log"
    log.write_text(
        "NODE 0 0 0 0 0 0\n1 0 0\n1 1 0\n0 1 0.5\nNODE 0.1 0 0 0 0 0\n2 0 0\n0 2 0\n"
    )
    assert octoquant.count_frames(log) is None
    m = octoquant.Mapper(resolution=0.1)
    for pts, origin in octoquant.read_frames(log):
        m.insert(pts, origin)
    tree, s = od.build_map_with_summary(log, resolution=0.1, client=clients[1], tile_depth=12)
    assert tree_bytes(tree) == tree_bytes(m.tree)
    assert s["frames"] == 2 and s["frames_read_by_workers"] == 0
    with pytest.raises(ValueError, match="frame count"):
        od.build_map(log, resolution=0.1, client=clients[1], read_on="workers")


@pytest.mark.parametrize("read_on", ["workers", "driver"])
def test_a_worker_killed_mid_build_changes_nothing(cli, dask, norlab, tmp_path, read_on):
    """A worker process is killed (SIGKILL, no goodbye) when it starts the first tile task of
    the build, after the ray tasks ran: Dask loses the update lists it held and the tile task,
    reruns what is lost on the surviving or restarted worker, and the map is the same."""
    want_bt, want_ot = cli_map(cli, [norlab], tmp_path, "--res", "0.2", "--max-range", "10")
    marker = tmp_path / "killed"

    class KillOnce(dask.WorkerPlugin):
        """Kills its worker the first time, cluster-wide, a tile task starts on it."""

        def __init__(self, marker):
            self.marker = str(marker)

        def transition(self, key, start, finish, **kwargs):
            if finish != "executing" or "_apply" not in str(key):
                return
            try:
                fd = os.open(self.marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
            except FileExistsError:
                return
            os.write(fd, str(os.getpid()).encode())
            os.close(fd)
            os.kill(os.getpid(), signal.SIGKILL)

    cluster = dask.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
    )
    client = dask.Client(cluster)
    try:
        pids = set(client.run(os.getpid).values())
        client.register_plugin(KillOnce(marker))
        tree, s = od.build_map_with_summary(
            [norlab],
            resolution=0.2,
            max_range=10.0,
            client=client,
            tile_depth=6,
            frames_per_task=2,
            read_on=read_on,
        )
    finally:
        client.close()
        cluster.close()
    killed = int(marker.read_text())
    assert killed in pids, "the plugin killed a worker of this cluster"
    assert tree_bytes(tree) == (want_bt, want_ot)
    assert s["frames"] == 14 and s["tasks"] == 7
