"""Distance maps (``dynamicEDT_*``) against octomap-python's dynamicEDT3D: the same maps,
boxes and options give the same float distance and the same closest obstacle at every voxel
centre in and around the box, on OctoMap's real geb079 map, on a map built from the real
scan.dat, on sparse synthetic maps, and on one where dynamicEDT3D's brushfire is not exactly
Euclidean; after an incremental update too."""

import numpy as np
import pytest

import octoquant


def centres(res, lo, hi, margin=2):
    """Voxel centres of the key box between lo and hi, widened by `margin` voxels."""
    klo = np.floor(np.asarray(lo) / res).astype(int) - margin
    khi = np.floor(np.asarray(hi) / res).astype(int) + margin
    axes = [(np.arange(a, b + 1) + 0.5) * res for a, b in zip(klo, khi)]
    g = np.meshgrid(*axes, indexing="ij")
    return np.stack([a.ravel() for a in g], axis=1)


def both_maps(octomap, path_or_pair, maxdist, lo, hi, unknown):
    if isinstance(path_or_pair, tuple):
        a, b = path_or_pair
    else:
        a = octomap.OcTree(str(path_or_pair).encode())
        b = octoquant.OcTree(str(path_or_pair))
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    a.dynamicEDT_generate(maxdist, lo, hi, unknown)
    b.dynamicEDT_generate(maxdist, lo, hi, unknown)
    return a, b


def assert_same(a, b, points):
    """Identical distances and closest obstacles at every point; returns the distances."""
    got = b.distances(points)
    out = []
    for i, p in enumerate(points):
        da = a.dynamicEDT_getDistance(p)
        assert b.dynamicEDT_getDistance(p) == da, (i, p)
        assert got[i] == da, (i, p)
        (ea, oa), (eb, ob) = (
            a.dynamicEDT_getDistanceAndClosestObstacle(p),
            b.dynamicEDT_getDistanceAndClosestObstacle(p),
        )
        assert eb == ea == da, (i, p)
        if oa is None:
            assert ob is None, (i, p, ob)
        else:
            assert ob is not None and np.array_equal(ob, oa), (i, p, oa, ob)
        out.append(da)
    return np.array(out)


@pytest.mark.parametrize("unknown", [False, True])
def test_geb079_box(octomap, geb079, unknown):
    lo, hi = (0.3, -2.1, -0.2), (4.1, 1.9, 2.0)
    a, b = both_maps(octomap, geb079, 1.0, lo, hi, unknown)
    res = a.getResolution()
    pts = centres(res, lo, hi)
    # before the first update: only the settled obstacles read 0, the rest the maximum
    assert_same(a, b, pts[::7])
    a.dynamicEDT_update(True)
    b.dynamicEDT_update(True)
    assert b.dynamicEDT_getMaxDist() == a.dynamicEDT_getMaxDist()
    assert b.dynamicEDT_checkConsistency() is a.dynamicEDT_checkConsistency() is True
    d = assert_same(a, b, pts)
    # the comparison is not vacuous: outside, obstacles, distances between and the clamp
    assert (d == -1.0).any() and (d == 0.0).any()
    assert (d == a.dynamicEDT_getMaxDist()).any() or unknown
    assert ((d > 0) & (d < a.dynamicEDT_getMaxDist())).sum() > 1000


def test_geb079_whole_map_sampled(octomap, geb079):
    lo, hi = (-8.0, -7.5, -0.3), (30.9, 7.4, 2.7)
    a, b = both_maps(octomap, geb079, 0.6, lo, hi, False)
    a.dynamicEDT_update(True)
    b.dynamicEDT_update(True)
    rng = np.random.default_rng(79)
    pts = rng.uniform(np.array(lo) - 0.5, np.array(hi) + 0.5, size=(20000, 3))
    d = assert_same(a, b, pts)
    assert (d == -1.0).any() and ((d > 0) & (d < 0.6)).sum() > 1000


def test_scan_dat_map(octomap, scan_dat):
    a, b = octomap.OcTree(0.1), octoquant.OcTree(0.1)
    origin = np.zeros(3)
    a.insertPointCloud(scan_dat, origin, maxrange=8.0)
    b.insertPointCloud(scan_dat, origin, maxrange=8.0)
    lo, hi = (-3.0, -3.0, -1.0), (3.0, 3.0, 1.5)
    for unknown in (False, True):
        a2, b2 = both_maps(octomap, (a, b), 0.75, lo, hi, unknown)
        a2.dynamicEDT_update(True)
        b2.dynamicEDT_update(True)
        assert_same(a2, b2, centres(0.1, lo, hi, margin=1))


def sparse_pair(octomap, seed, n=30):
    """Sparse random obstacles in free space: long brushfire waves that meet."""
    a, b = octomap.OcTree(1.0), octoquant.OcTree(1.0)
    rng = np.random.default_rng(seed)
    occ = rng.random((n, n, n)) < 0.0003 * (1 + seed % 3)
    for x in range(n):
        for y in range(n):
            for z in range(n):
                p = np.array([x + 0.5, y + 0.5, z + 0.5])
                a.updateNode(p, bool(occ[x, y, z]))
                b.updateNode(p, bool(occ[x, y, z]))
    return a, b, occ


def test_sparse_maps(octomap):
    n = 30
    for seed in range(12):
        a, b, occ = sparse_pair(octomap, seed, n)
        a, b = both_maps(octomap, (a, b), 40.0, (0.5, 0.5, 0.5), (n - 0.5,) * 3, False)
        a.dynamicEDT_update(True)
        b.dynamicEDT_update(True)
        pts = centres(1.0, (0.5,) * 3, (n - 0.5,) * 3, margin=0)
        d = assert_same(a, b, pts)
        obst = np.argwhere(occ) + 0.5
        if len(obst):
            exact = np.sqrt(((pts[:, None, :] - obst[None]) ** 2).sum(-1)).min(1)
            exact = np.minimum(exact, a.dynamicEDT_getMaxDist())
            assert (d >= exact.astype(np.float32) - 1e-5).all()
            assert (d - exact < 1.0).all()


# A map where dynamicEDT3D's brushfire misses the nearest obstacle (found by the sparse-map
# property test of the distance crate): nine obstacles in a 36-voxel cube, everything else free.
NON_EUCLIDEAN = [
    (0, 33, 22), (4, 4, 7), (11, 3, 8), (14, 3, 8), (16, 30, 31),
    (18, 3, 11), (19, 5, 12), (26, 15, 23), (28, 3, 12),
]


def test_a_map_where_dynamicedt3d_is_not_euclidean(octomap):
    n = 36
    a, b = octomap.OcTree(1.0), octoquant.OcTree(1.0)
    obst = set(NON_EUCLIDEAN)
    for x in range(n):
        for y in range(n):
            for z in range(n):
                p = np.array([x + 0.5, y + 0.5, z + 0.5])
                a.updateNode(p, (x, y, z) in obst)
                b.updateNode(p, (x, y, z) in obst)
    a, b = both_maps(octomap, (a, b), 100.0, (0.5,) * 3, (n - 0.5,) * 3, False)
    a.dynamicEDT_update(True)
    b.dynamicEDT_update(True)
    pts = centres(1.0, (0.5,) * 3, (n - 0.5,) * 3, margin=0)
    d = assert_same(a, b, pts)
    o = np.array(sorted(obst)) + 0.5
    exact = np.sqrt(((pts[:, None, :] - o[None]) ** 2).sum(-1)).min(1).astype(np.float32)
    off = np.flatnonzero(d != exact)
    # octomap-python's own answer is not the exact distance here, and octoquant's is the same
    assert len(off) >= 1
    assert (d[off] > exact[off]).all() and (d[off] - exact[off] < 1.0).all()


def test_errors_and_missing_map():
    t = octoquant.OcTree(0.1)
    with pytest.raises(octoquant.NullPointerException):
        t.dynamicEDT_getDistance(np.zeros(3))
    with pytest.raises(octoquant.NullPointerException):
        t.dynamicEDT_update(True)
    lo, hi = np.zeros(3), np.ones(3)
    for bad in (float("nan"), -1.0, 1e9):
        with pytest.raises(ValueError):
            t.dynamicEDT_generate(bad, lo, hi)
    with pytest.raises(ValueError):
        t.dynamicEDT_generate(1.0, hi, lo)
    with pytest.raises(ValueError):
        t.dynamicEDT_generate(1.0, np.array([np.nan, 0, 0]), hi)
    with pytest.raises(ValueError):
        t.dynamicEDT_generate(1.0, -np.full(3, 1e4), np.full(3, 1e4))
    with pytest.raises(ValueError):
        t.dynamicEDT_generate(1.0, np.full(3, -3000.0), np.full(3, 3000.0))
    t.dynamicEDT_generate(1.0, lo, hi)
    with pytest.raises(ValueError):
        t.dynamicEDT_getDistance(np.array([np.nan, 0.0, 0.0]))
    with pytest.raises(ValueError, match="row 1"):
        t.distances(np.array([[0.0, 0, 0], [np.inf, 0, 0]]))
    t.dynamicEDT_update(True)
    # an empty tree with unknown space free: everything at the clamp
    assert t.dynamicEDT_getDistance(np.full(3, 0.55)) == t.dynamicEDT_getMaxDist()
    assert t.dynamicEDT_getDistance(np.full(3, 5.0)) == -1.0


def test_update_after_new_measurements(octomap, geb079):
    """dynamicEDT_update after updateNode calls: the same distances and the same closest
    obstacles everywhere. Where several obstacles are equally near, the one reported depends on
    the order the update takes the changed voxels in (OctoMap's hash map's), which octoquant
    reproduces."""
    lo, hi = (0.3, -2.1, -0.2), (4.1, 1.9, 2.0)
    a, b = both_maps(octomap, geb079, 1.0, lo, hi, False)
    a.dynamicEDT_update(True)
    b.dynamicEDT_update(True)
    rng = np.random.default_rng(3)
    for p in rng.uniform(lo, hi, size=(400, 3)):
        hit = bool(rng.integers(0, 2))
        for _ in range(3):
            a.updateNode(p, hit)
            b.updateNode(p, hit)
    assert b.dynamicEDT_checkConsistency() is a.dynamicEDT_checkConsistency() is False
    a.dynamicEDT_update(True)
    b.dynamicEDT_update(True)
    assert b.dynamicEDT_checkConsistency() is a.dynamicEDT_checkConsistency() is True
    pts = centres(a.getResolution(), lo, hi)
    assert np.array_equal(b.distances(pts), np.array([a.dynamicEDT_getDistance(p) for p in pts], dtype=np.float32))
    assert_same(a, b, pts)
    # a second round: the changed-voxel map has grown and been reset, and keeps its buckets
    for p in rng.uniform(lo, hi, size=(600, 3)):
        hit = bool(rng.integers(0, 3))
        for _ in range(2):
            a.updateNode(p, hit)
            b.updateNode(p, hit)
    a.dynamicEDT_update(True)
    b.dynamicEDT_update(True)
    assert_same(a, b, pts[::2])
