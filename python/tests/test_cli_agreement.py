"""octoquant.reduce and octoquant.segment_scan give what the CLI's ``octoquant reduce`` and
``octoquant segment`` give on the same real data, exactly.

The binary is OCTOQUANT_BIN, or the workspace's target/release or target/debug build (``cargo
test --workspace`` builds it, as .ci/run does before the Python tests); without one these tests
skip, except under CI=true.
"""

import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

import octoquant
from conftest import REPO, _missing


@pytest.fixture(scope="module")
def cli():
    candidates = [os.environ.get("OCTOQUANT_BIN")] + [
        str(REPO / "target" / kind / "octoquant") for kind in ("release", "debug")
    ]
    for c in candidates:
        if c and Path(c).is_file() and os.access(c, os.X_OK):
            return c
    _missing("the octoquant binary (cargo build, or set OCTOQUANT_BIN)")


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
