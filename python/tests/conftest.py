"""Shared fixtures: octomap-python for the differential tests, and the shared data.

A missing prerequisite (octomap-python, the data directory) skips the tests that need it,
except under ``CI=true``, where it fails them: CI must run every comparison.
"""

import bz2
import os
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]


def _missing(what):
    if os.environ.get("CI", "").lower() == "true":
        pytest.fail(f"{what} is missing (required under CI=true)")
    pytest.skip(f"{what} is missing")


@pytest.fixture(scope="session")
def octomap():
    """octomap-python's module (PyPI octomap-python)."""
    try:
        import octomap as mod
    except ImportError:
        _missing("octomap-python (pip install octomap-python)")
    return mod


@pytest.fixture(scope="session")
def data_dir():
    """The shared data: OCTOQUANT_DATA, default ../shared/data beside the repository."""
    d = Path(os.environ.get("OCTOQUANT_DATA", REPO.parent / "shared" / "data"))
    if not d.is_dir():
        _missing(f"the shared data directory {d} (set OCTOQUANT_DATA)")
    return d


@pytest.fixture(scope="session")
def scan_dat(data_dir):
    """OctoMap's scan.dat: 88206 points of a 3D laser scan, origin (0, 0, 0), float64."""
    path = data_dir / "lidar3d" / "octomap_scan_dat" / "scan.dat.bz2"
    if not path.is_file():
        _missing(str(path))
    with bz2.open(path, "rt") as f:
        pts = np.loadtxt(f, dtype=np.float64)
    assert pts.shape == (88206, 3)
    return pts


@pytest.fixture(scope="session")
def geb079(data_dir):
    """OctoMap's geb079.bt reference map."""
    path = data_dir / "octomap_reference" / "geb079.bt"
    if not path.is_file():
        _missing(str(path))
    return path


@pytest.fixture(scope="session")
def cli():
    """The octoquant CLI binary: OCTOQUANT_BIN, or the workspace's target/release or
    target/debug build (``cargo test --workspace`` builds it, as .ci/run does before the
    Python tests)."""
    candidates = [os.environ.get("OCTOQUANT_BIN")] + [
        str(REPO / "target" / kind / "octoquant") for kind in ("release", "debug")
    ]
    for c in candidates:
        if c and Path(c).is_file() and os.access(c, os.X_OK):
            return c
    _missing("the octoquant binary (cargo build, or set OCTOQUANT_BIN)")


def tum_depth_stamps(assoc):
    """Each frame's time in a TUM association, read independently of octoquant: the rows
    whose depth image (second column) exists, each stamped with that image's name,
    <seconds>.png."""
    stamps = []
    for line in assoc.read_text().splitlines():
        if line.strip() and not line.startswith("#"):
            depth = assoc.parent / line.split()[1]
            if depth.is_file():
                stamps.append(float(depth.stem))
    return stamps
