"""The scripts in python/examples run and print what they promise."""

import subprocess
import sys
from pathlib import Path

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def run(script, *args):
    out = subprocess.run(
        [sys.executable, str(EXAMPLES / script), *args],
        capture_output=True,
        text=True,
        timeout=300,
        check=True,
    )
    return out.stdout


def test_octomap_port(tmp_path):
    out = run("octomap_port.py", str(tmp_path))
    assert "[3.01, 0.0, 0.0]: occupied" in out
    assert (tmp_path / "map.bt").stat().st_size > 0
    assert (tmp_path / "map.ot").stat().st_size > 0


def test_mapper_frames():
    out = run("mapper_frames.py")
    assert "frame 7:" in out and "occupied leaves" in out


def test_reduce_dbscan():
    out = run("reduce_dbscan.py")
    assert "reduce: 88000 points ->" in out
    surfaces = [line for line in out.splitlines() if line.startswith("surface ")]
    heights = sorted(float(line.split("z = ")[1].split(" m")[0]) for line in surfaces)
    assert len(heights) == 3 and abs(heights[0]) < 0.01
    assert abs(heights[1] - 0.75) < 0.01 and abs(heights[2] - 1.6) < 0.01
    assert out.count("line: normal") == 2
