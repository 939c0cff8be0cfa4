"""octoquant.reduce and octoquant.DensityReducer against a naive Python reducer written from the
density crate's definitions, and against the reducer's documented guarantees, on scan.dat and
random clouds."""

import math

import numpy as np
import pytest

import octoquant


def naive_reduce(points, cell, offset=(0.0, 0.0, 0.0), distance="euclidean"):
    """The online grid density reducer, one read cycle, closest-to-centre rule, from the
    definitions: cell = floor((p - offset) / size); each cell keeps the member closest to its
    centre (Euclidean distance in the points' units, the paper's Eq. 3, or with
    ``distance="cell_units"`` each axis divided by its size; ties by coordinates); cells are read in ascending distance
    (ties by cell index); a cell whose point lies closer than half a cell on every axis to an
    emitted point of a neighbouring cell is eliminated."""
    p = np.asarray(points, dtype=np.float64)
    p = p[np.isfinite(p).all(axis=1)]
    size = np.asarray(cell, dtype=np.float64)
    off = np.asarray(offset, dtype=np.float64)
    idx = np.floor((p - off) / size).astype(np.int64)
    centre = off + (idx + 0.5) * size
    t = p - centre if distance == "euclidean" else (p - centre) / size
    dist = t[:, 0] * t[:, 0] + t[:, 1] * t[:, 1] + t[:, 2] * t[:, 2]
    best = {}
    for i in range(len(p)):
        k = tuple(idx[i])
        cand = (dist[i], tuple(p[i]))
        if k not in best or cand < best[k]:
            best[k] = cand
    order = sorted(best, key=lambda k: (best[k][0], k))
    decided = set()
    out = []
    half = 0.5 * size
    for k in order:
        if k in decided:
            continue
        decided.add(k)
        q = np.array(best[k][1])
        out.append(best[k][1])
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                for dz in (-1, 0, 1):
                    n = (k[0] + dx, k[1] + dy, k[2] + dz)
                    if n == k or n in decided or n not in best:
                        continue
                    if np.all(np.abs(np.array(best[n][1]) - q) < half):
                        decided.add(n)
    return np.array(out, dtype=np.float64).reshape(-1, 3)


def assert_well_separated(out, cell):
    """No two output points closer than half a cell on every axis."""
    half = 0.5 * np.asarray(cell, dtype=np.float64)
    buckets = {}
    keys = np.floor(out / half).astype(np.int64)
    for i, k in enumerate(map(tuple, keys)):
        buckets.setdefault(k, []).append(i)
    for i, k in enumerate(map(tuple, keys)):
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                for dz in (-1, 0, 1):
                    for j in buckets.get((k[0] + dx, k[1] + dy, k[2] + dz), ()):
                        if j != i:
                            assert not np.all(np.abs(out[i] - out[j]) < half), (out[i], out[j])


@pytest.fixture(scope="module")
def rng():
    return np.random.default_rng(2311)


def lattice(rng, n, spread=4.0, step=1 / 16):
    """Points on a fine lattice: many ties in distance and exact half-cell distances."""
    return np.round(rng.uniform(-spread, spread, size=(n, 3)) / step) * step + 0.0


@pytest.mark.parametrize(
    "cell, offset",
    [(0.5, None), ((0.25, 0.5, 1.0), None), (0.5, (0.1, -0.2, 0.3))],
)
def test_reduce_matches_naive_reducer(rng, cell, offset):
    pts = lattice(rng, 3000)
    out = octoquant.reduce(pts, cell, offset=offset)
    size = np.broadcast_to(np.asarray(cell, dtype=np.float64), (3,))
    off = (0.0, 0.0, 0.0) if offset is None else offset
    want = naive_reduce(pts, size, off)
    assert out.dtype == np.float64
    np.testing.assert_array_equal(out, want)


@pytest.mark.parametrize("distance", ["euclidean", "cell_units"])
def test_reduce_centre_distance_on_unequal_cells(rng, distance):
    """Both centre distances against the naive reducer on cells of unequal sizes, where they
    pick different points; the reducer reports the one it was given."""
    pts = lattice(rng, 3000)
    cell = (0.25, 0.5, 1.0)
    out = octoquant.reduce(pts, cell, distance=distance)
    np.testing.assert_array_equal(out, naive_reduce(pts, cell, distance=distance))
    other = "cell_units" if distance == "euclidean" else "euclidean"
    assert not np.array_equal(out, naive_reduce(pts, cell, distance=other))
    r = octoquant.DensityReducer(cell, distance=distance)
    assert r.distance == distance
    r.insert(pts)
    np.testing.assert_array_equal(r.output(), out)
    with pytest.raises(ValueError, match="distance"):
        octoquant.reduce(pts, cell, distance="manhattan")


def test_reduce_scan_dat(scan_dat):
    """Real data: the exact naive result, a subset of the input, well separated, independent
    of the input order and of float32 vs float64 when the values are the same."""
    cell = (0.2, 0.2, 0.4)
    out, index = octoquant.reduce(scan_dat, cell, return_index=True)
    assert 1000 < len(out) < len(scan_dat)
    np.testing.assert_array_equal(scan_dat[index], out)
    np.testing.assert_array_equal(out, naive_reduce(scan_dat, cell))
    assert_well_separated(out, cell)
    perm = np.random.default_rng(1).permutation(len(scan_dat))
    np.testing.assert_array_equal(octoquant.reduce(scan_dat[perm], cell), out)
    f32 = scan_dat.astype(np.float32)
    out32 = octoquant.reduce(f32, cell)
    assert out32.dtype == np.float32
    np.testing.assert_array_equal(out32, octoquant.reduce(f32.astype(np.float64), cell))
    # Fortran order and strided views read the same rows
    np.testing.assert_array_equal(octoquant.reduce(np.asfortranarray(scan_dat), cell), out)
    doubled = np.zeros((len(scan_dat), 6))
    doubled[:, ::2] = scan_dat
    np.testing.assert_array_equal(octoquant.reduce(doubled[:, ::2], cell), out)


def test_reduce_mean_selection(rng):
    """The mean rule keeps, per cell, the member closest to the cell's mean; the output is
    still a well-separated subset."""
    pts = rng.normal(size=(2000, 3))
    out, index = octoquant.reduce(pts, 0.5, selection="mean", return_index=True)
    np.testing.assert_array_equal(pts[index], out)
    assert_well_separated(out, (0.5, 0.5, 0.5))
    r = octoquant.DensityReducer(0.5, selection="mean")
    r.insert(pts)
    kept = r.selected_points()
    cells = np.floor(pts / 0.5).astype(np.int64)
    for q in kept[:200]:
        k = np.floor(q / 0.5).astype(np.int64)
        members = pts[np.all(cells == k, axis=1)]
        d = (((members - members.mean(axis=0)) / 0.5) ** 2).sum(axis=1)
        assert math.isclose(
            (((q - members.mean(axis=0)) / 0.5) ** 2).sum(), d.min(), rel_tol=1e-12, abs_tol=1e-15
        )


def test_reduce_skips_non_finite(rng):
    pts = lattice(rng, 500)
    bad = np.array([[np.nan, 0, 0], [0, np.inf, 0], [0, 0, -np.inf]])
    mixed = np.vstack([bad[:1], pts[:250], bad[1:], pts[250:]])
    out, index = octoquant.reduce(mixed, 1.0, return_index=True)
    np.testing.assert_array_equal(out, octoquant.reduce(pts, 1.0))
    assert np.isfinite(mixed[index]).all()
    r = octoquant.DensityReducer(1.0)
    assert r.insert(mixed) == 3
    assert r.counts() == {"inserted": 500, "rejected": 3, "removed": 0}


def test_reduce_bad_arguments():
    pts = np.zeros((4, 3))
    with pytest.raises(ValueError, match="cell size"):
        octoquant.reduce(pts, 0.0)
    with pytest.raises(ValueError, match="cell size"):
        octoquant.reduce(pts, (1.0, np.nan, 1.0))
    with pytest.raises(ValueError, match="3 numbers"):
        octoquant.reduce(pts, (1.0, 2.0))
    with pytest.raises(ValueError, match="offset"):
        octoquant.reduce(pts, 1.0, offset=np.inf)
    with pytest.raises(ValueError, match="selection"):
        octoquant.reduce(pts, 1.0, selection="median")
    with pytest.raises(ValueError, match=r"shape \(N, 3\)"):
        octoquant.reduce(np.zeros((4, 2)), 1.0)
    with pytest.raises(TypeError, match="float32 or float64"):
        octoquant.reduce(np.zeros((4, 3), dtype=np.int32), 1.0)
    with pytest.raises(ValueError, match="cell size"):
        octoquant.DensityReducer(-1.0)
    r = octoquant.DensityReducer([0.5, 1, 2], offset=0.25, selection="mean")
    assert (r.cell, r.offset, r.selection, len(r)) == ((0.5, 1.0, 2.0), (0.25,) * 3, "mean", 0)
    assert r.output().shape == (0, 3)
    assert octoquant.reduce(np.zeros((0, 3)), 1.0).shape == (0, 3)


def test_reducer_online_equals_batch(rng):
    pts = lattice(rng, 4000)
    r = octoquant.DensityReducer((0.5, 0.5, 0.25))
    for chunk in np.array_split(pts, 7):
        assert r.insert(chunk.astype(np.float32) if len(chunk) % 2 else chunk) == 0
    assert r.point_count == 4000
    assert len(r) == len(np.unique(np.floor(pts / (0.5, 0.5, 0.25)), axis=0))
    assert r.cell == (0.5, 0.5, 0.25) and r.offset == (0.0, 0.0, 0.0)
    assert r.selection == "centre"
    np.testing.assert_array_equal(r.output(), octoquant.reduce(pts, (0.5, 0.5, 0.25)))
    # a second cycle over an unchanged grid gives the same output
    np.testing.assert_array_equal(r.output(), octoquant.reduce(pts, (0.5, 0.5, 0.25)))
    r.validate()


def test_reducer_remove(rng):
    a = lattice(rng, 2000)
    b = lattice(rng, 1500) + 0.03125
    r = octoquant.DensityReducer(0.5)
    r.insert(a)
    before = r.selected_points()
    r.insert(b)
    found = r.remove(b)
    assert found.dtype == np.bool_ and found.all()
    assert not r.remove(np.array([[100.0, 100.0, 100.0]]))[0]
    np.testing.assert_array_equal(r.selected_points(), before)
    np.testing.assert_array_equal(r.output(), octoquant.reduce(a, 0.5))
    assert r.counts() == {"inserted": 3500, "rejected": 0, "removed": 1500}
    assert r.point_count == 2000
    r.validate()


def test_reducer_cycles_in_steps(rng):
    pts = lattice(rng, 3000)
    r = octoquant.DensityReducer(0.5)
    r.insert(pts)
    cycle = r.begin_cycle()
    assert cycle.id == 1 and not cycle.finished
    parts = []
    while True:
        out, finished = cycle.step(50)
        parts.append(out)
        if finished:
            break
    assert cycle.finished and len(parts) > 2
    full = np.vstack(parts)
    np.testing.assert_array_equal(full, octoquant.reduce(pts, 0.5))
    c = cycle.counts()
    assert c["emitted"] == len(full) and c["deferred"] == 0
    assert c["emitted"] + c["eliminated"] == len(r)


def test_reducer_insert_during_a_cycle(rng):
    first = lattice(rng, 2000)
    second = lattice(rng, 2000) + 10.0
    r = octoquant.DensityReducer(0.5)
    r.insert(first)
    cycle = r.begin_cycle()
    out, finished = cycle.step(20)
    assert not finished
    r.insert(second)
    rest, finished = cycle.step()
    assert finished
    emitted = np.vstack([out, rest])
    # the cells created meanwhile are left to the next cycle
    assert cycle.counts()["deferred"] > 0
    assert {tuple(p) for p in emitted} <= {tuple(p) for p in first}
    np.testing.assert_array_equal(r.output(), octoquant.reduce(np.vstack([first, second]), 0.5))


def test_stale_cycle_raises(rng):
    r = octoquant.DensityReducer(1.0)
    r.insert(lattice(rng, 100))
    old = r.begin_cycle()
    new = r.begin_cycle()
    with pytest.raises(RuntimeError, match="stale"):
        old.step()
    assert new.step()[1]
