"""octoquant.reduce and octoquant.segment_scan give what the CLI's ``octoquant reduce`` and
``octoquant segment`` give on the same real data, exactly.

The binary is OCTOQUANT_BIN, or the workspace's target/release or target/debug build (``cargo
test --workspace`` builds it, as .ci/run does before the Python tests); without one these tests
skip, except under CI=true (the ``cli`` fixture is in conftest.py).
"""

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest

import octoquant
from conftest import _missing


def read_binary_ply(path):
    """x, y, z float32 of a binary little-endian PLY with only those vertex properties."""
    data = Path(path).read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").splitlines()
    assert "format binary_little_endian 1.0" in header
    n = int(next(line for line in header if line.startswith("element vertex")).split()[2])
    props = [line.split()[1:] for line in header if line.startswith("property")]
    assert props == [["float", "x"], ["float", "y"], ["float", "z"]], props
    return np.frombuffer(data[end:], dtype="<f4", count=3 * n).reshape(n, 3)


@pytest.mark.parametrize("cell", ["0.2", "0.1,0.2,0.4"])
def test_reduce_matches_cli(cli, data_dir, tmp_path, cell):
    scan = data_dir / "lidar3d" / "octomap_scan_dat" / "scan.dat.bz2"
    out = tmp_path / "reduced.ply"
    res = subprocess.run(
        [cli, "reduce", str(scan), "--cell", cell, "-o", str(out), "--json"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert res.returncode == 0, res.stderr
    stats = json.loads(res.stdout)
    want = read_binary_ply(out)
    ((points, _),) = octoquant.read_frames(scan)
    sizes = [float(v) for v in cell.split(",")]
    got = octoquant.reduce(points, sizes[0] if len(sizes) == 1 else sizes)
    assert got.dtype == np.float32 and stats["reduced"] == len(got)
    np.testing.assert_array_equal(got, want)


def test_segment_matches_cli(cli, data_dir):
    log = data_dir / "laser2d" / "ple_corrected_carmen" / "intel-corrected.log.gz"
    if not log.is_file():
        _missing(str(log))
    scans = octoquant.read_laser_scans(log)
    for index in (0, 137, 512, 909):
        res = subprocess.run(
            [cli, "segment", str(log), "--scan", str(index), "--json"],
            capture_output=True,
            text=True,
            timeout=600,
        )
        assert res.returncode == 0, res.stderr
        want = json.loads(res.stdout)
        points, pose = scans[index]
        assert want["valid"] == len(points)
        assert want["laser_pose"] == pose.tolist()
        lines, labels = octoquant.segment_scan(points)
        assert want["on_lines"] == int((labels >= 0).sum())
        assert len(want["lines"]) == len(lines) > 0
        for w, g in zip(want["lines"], lines):
            assert w["normal_angle"] == g["normal_angle"]
            assert w["distance"] == g["distance"]
            assert w["start"] == [g["start_x"], g["start_y"]]
            assert w["end"] == [g["end_x"], g["end_y"]]
            assert w["points"] == g["n_points"]
            assert w["length"] == g["length"]
            assert w["rms_residual"] == g["rms_residual"]
            assert w["max_residual"] == g["max_residual"]


@pytest.mark.parametrize(
    "merge,max_range,band",
    [("average", None, None), ("integrate", None, None), ("average", 4.0, (0.0, 1.0))],
)
def test_color_mapper_matches_cli(cli, data_dir, tmp_path, merge, max_range, band):
    """octoquant.ColorMapper over read_frames(colors=True) writes the .ot that
    ``octoquant map --color`` writes from the same TUM RGB-D frames (the CLI's map is proven
    byte-identical with liboctomap's ColorOcTree inserting as octomap_server does), also with a
    maximum range and a z band filter."""
    assoc = data_dir / "rgbd" / "tum_fr2_pioneer_slam2_subset" / "my_association.txt"
    if not assoc.is_file():
        _missing(str(assoc))
    out = tmp_path / "cli.ot"
    args = [cli, "map", str(assoc), "--color", "--color-merge", merge, "--pixel-step", "4"]
    args += ["--res", "0.05", "-o", str(out), "-q"]
    if max_range is not None:
        args += ["--max-range", str(max_range)]
    zmin, zmax = band if band else (None, None)
    if band:
        args += ["--zmin", str(zmin), "--zmax", str(zmax)]
    res = subprocess.run(args, capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr
    frames = octoquant.read_frames(assoc, pixel_step=4, colors=True)
    assert len(frames) == 10
    mapper = octoquant.ColorMapper(0.05, merge=merge, max_range=max_range, zmin=zmin, zmax=zmax)
    dropped = 0
    for points, origin, colors in frames:
        assert colors.dtype == np.uint8 and colors.shape == points.shape
        st = mapper.insert(points, colors, origin)
        assert st["points"] == len(points)
        dropped += st["dropped"]["z_band"]
        if band:
            z = points[:, 2].astype(np.float64)
            assert st["dropped"]["z_band"] == int(np.sum((z < zmin) | (z > zmax)))
    assert (dropped > 10000) == bool(band), dropped
    assert mapper.frames == 10
    tree = mapper.tree
    assert tree.write() == out.read_bytes()
    coloured = sum(1 for leaf in tree.begin_leafs() if tree.search(leaf.getKey()).isColorSet())
    assert coloured > 1000, coloured


def test_color_mapper_refusals(data_dir):
    scan = data_dir / "lidar3d" / "octomap_scan_dat" / "scan.dat.bz2"
    with pytest.raises(ValueError, match="has no colours"):
        octoquant.read_frames(scan, colors=True)
    m = octoquant.ColorMapper(0.1)
    pts = np.array([[1.0, 0.0, 0.0], [2.0, 0.0, 0.0]], dtype=np.float32)
    with pytest.raises(ValueError, match="1 colours for 2 points"):
        m.insert(pts, np.zeros((1, 3), dtype=np.uint8))
    with pytest.raises(ValueError, match="uint8"):
        m.insert(pts, np.zeros((2, 3), dtype=np.float64))
    with pytest.raises(ValueError, match="merge"):
        octoquant.ColorMapper(0.1, merge="max")
    with pytest.raises(ValueError, match="max_range"):
        octoquant.ColorMapper(0.1, max_range=float("nan"))
    assert m.frames == 0 and m.tree.size() == 0
    # a voxel is coloured from its second sighting on (octomap_server's order)
    red = np.array([[200, 0, 0], [200, 0, 0]], dtype=np.uint8)
    m.insert(pts, red)
    m.insert(pts, red)
    node = m.tree.search(pts[0])
    assert node is not None and node.getColor() == (200, 0, 0)
