"""The Mapper's point filters (keyword arguments) against naive NumPy definitions."""

import subprocess

import numpy as np
import pytest

import octoquant


def cloud(origin, n=3000, seed=5):
    rng = np.random.default_rng(seed)
    pts = (origin + rng.uniform(-6, 6, size=(n, 3))).astype(np.float32)
    pts[::50] = np.asarray(origin, dtype=np.float32)  # driver "no return" points
    pts[1::97] = np.nan
    return pts


def bt(mapper):
    return mapper.tree.to_bytes("bt")


def naive_keep(pts, origin, min_range, sbox, wbox, zmin, zmax):
    o = np.asarray(origin, dtype=np.float32).astype(np.float64)
    p = pts.astype(np.float64)
    finite = np.isfinite(p).all(axis=1)
    zero = finite & (pts == np.asarray(origin, dtype=np.float32)).all(axis=1)
    rel = p - o
    keep = finite & ~zero
    reasons = {"zero": int(zero.sum())}
    drop = keep & (np.linalg.norm(rel, axis=1) < min_range)
    reasons["min_range"] = int(drop.sum())
    keep &= ~drop
    drop = keep & ((rel >= sbox[:3]) & (rel <= sbox[3:])).all(axis=1)
    reasons["crop_sensor"] = int(drop.sum())
    keep &= ~drop
    drop = keep & ~((p >= wbox[:3]) & (p <= wbox[3:])).all(axis=1)
    reasons["crop_world"] = int(drop.sum())
    keep &= ~drop
    drop = keep & ((p[:, 2] < zmin) | (p[:, 2] > zmax))
    reasons["z_band"] = int(drop.sum())
    keep &= ~drop
    reasons["ground"] = 0
    return keep, reasons, int(zero.sum()), int((~finite).sum())


def test_filters_match_naive_definition():
    origin = (0.5, -0.25, 0.3)
    sbox = np.array([-1.0, -1.0, -0.5, 1.0, 1.0, 0.5])
    wbox = np.array([-4.0, -5.0, -2.0, 4.0, 3.0, 3.0])
    args = dict(min_range=0.8, crop_sensor=sbox, crop_world=wbox, zmin=-1.0, zmax=2.0)
    m = octoquant.Mapper(0.2, drop_zero=True, **{k: (list(v) if isinstance(v, np.ndarray) else v) for k, v in args.items()})
    pts = cloud(origin)
    st = m.insert(pts, origin=origin)
    keep, reasons, zeros, non_finite = naive_keep(pts, origin, 0.8, sbox, wbox, -1.0, 2.0)
    assert st["dropped"] == reasons
    assert st["zero"] == zeros and st["non_finite"] == non_finite
    assert all(v > 0 for k, v in reasons.items() if k != "ground")
    plain = octoquant.Mapper(0.2)
    plain.insert(pts[keep], origin=origin)
    assert bt(m) == bt(plain)
    assert m.stats()["dropped"] == reasons


def test_no_filters_keep_zero_points_and_count_them():
    origin = (0.0, 0.0, 0.0)
    pts = cloud(origin)
    st = octoquant.Mapper(0.2).insert(pts, origin=origin)
    zeros = int((pts == np.float32(0)).all(axis=1).sum())
    assert zeros >= 50
    assert st["zero"] == zeros
    assert sum(st["dropped"].values()) == 0


def test_ground_filter_removes_a_known_plane():
    rng = np.random.default_rng(1)
    xy = rng.uniform(-8, 8, size=(5000, 2))
    ground = np.column_stack([xy, np.full(5000, -1.5) + rng.uniform(-0.01, 0.01, 5000)])
    wall = np.column_stack([np.full(2000, 6.0), rng.uniform(-8, 8, 2000), rng.uniform(-1.3, 2, 2000)])
    pts = np.vstack([ground, wall]).astype(np.float32)
    runs = []
    for threads in (1, 2):
        m = octoquant.Mapper(0.2, threads=threads, ground=0.05, ground_seed=3)
        st = m.insert(pts, origin=(0, 0, 0))
        assert st["dropped"]["ground"] == 5000
        runs.append(bt(m))
    assert runs[0] == runs[1]


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(crop_world=[1, 0, 0, 0, 1, 1]),
        dict(crop_sensor=[0, 0, float("nan"), 1, 1, 1]),
        dict(crop_sensor=[0, 0, 1]),
        dict(min_range=-1.0),
        dict(zmin=2.0, zmax=1.0),
        dict(ground=0.0),
    ],
)
def test_invalid_filters_are_errors_naming_the_option(kwargs):
    with pytest.raises(ValueError) as e:
        octoquant.Mapper(0.1, **kwargs)
    name = next(iter(kwargs)).replace("zmin", "z_min")
    assert name in str(e.value)


def test_ground_clears_inserts_the_ground_as_free_space(cli, tmp_path):
    """``ground_clears=True``: the ground points' rays clear, their end voxels are not marked
    occupied (octomap_server's insertion); the same bytes as ``octoquant map --ground-clears``
    on the same points, and dropping them instead leaves their voxels unknown."""
    rng = np.random.default_rng(1)
    xy = rng.uniform(-8, 8, size=(5000, 2))
    ground = np.column_stack([xy, np.full(5000, -1.5) + rng.uniform(-0.01, 0.01, 5000)])
    wall = np.column_stack([np.full(2000, 6.0), rng.uniform(-8, 8, 2000), rng.uniform(-1.3, 2, 2000)])
    pts = np.vstack([ground, wall]).astype(np.float32)
    maps = {}
    for clears in (False, True):
        m = octoquant.Mapper(0.2, ground=0.05, ground_seed=3, ground_clears=clears)
        st = m.insert(pts, origin=(0, 0, 0))
        assert st["dropped"]["ground"] == (0 if clears else 5000)
        assert st["ground_clearing"] == (5000 if clears else 0)
        maps[clears] = m.tree
    # the ground's end voxels: never occupied, and mostly free when cleared (rays of other
    # ground points cross them); mostly unknown when dropped (no other ray reaches them)
    cleared = [maps[True].search(p) for p in ground[:500]]
    assert not any(n is not None and maps[True].isNodeOccupied(n) for n in cleared)
    assert sum(n is not None for n in cleared) > 400
    assert sum(maps[False].search(p) is None for p in ground[:500]) > 400
    assert maps[True].getNumLeafNodes() > maps[False].getNumLeafNodes()
    # the CLI on the same float32 points (a text list, sensor at 0)
    path = tmp_path / "pts.txt"
    np.savetxt(path, pts, fmt="%.9g")
    out = tmp_path / "cli.bt"
    args = ["map", str(path), "--res", "0.2", "--ground", "0.05", "--ground-seed", "3"]
    subprocess.run([cli, *args, "--ground-clears", "-q", "-o", str(out)], check=True, capture_output=True)
    assert out.read_bytes() == maps[True].to_bytes("bt")
