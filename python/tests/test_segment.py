"""octoquant.dbscan1d against a brute-force O(n^2) DBSCAN (Ester et al. 1996) written from the
definition, and octoquant.segment_scan / read_laser_scans against total-least-squares fits and
the CARMEN log itself, on random values and the Intel lab log."""

import gzip
import math

import numpy as np
import pytest

import octoquant


def naive_dbscan(x, eps, min_points, period=None, border="first"):
    """The original DBSCAN visiting the values in index order (x sorted ascending): returns
    (labels, second) with -1 for none. ``second`` is the other cluster reaching a border point
    (for border="all")."""
    n = len(x)

    def dist(a, b):
        if period is None:
            return abs(x[a] - x[b])
        lo, hi = min(x[a], x[b]), max(x[a], x[b])
        return min(hi - lo, (lo + period) - hi)

    nbrs = [[j for j in range(n) if dist(i, j) <= eps] for i in range(n)]
    core = [len(nb) >= min_points for nb in nbrs]
    labels = [-1] * n
    visited = [False] * n
    c = 0
    for i in range(n):
        if visited[i] or not core[i]:
            continue
        # a new cluster from the first unvisited core point, expanded fully
        seeds = [i]
        visited[i] = True
        labels[i] = c
        while seeds:
            q = seeds.pop()
            for j in nbrs[q]:
                if labels[j] == -1:
                    labels[j] = c
                if core[j] and not visited[j]:
                    visited[j] = True
                    seeds.append(j)
        c += 1
    second = [-1] * n
    if border in ("noise", "all"):
        for i in range(n):
            if core[i]:
                continue
            reach = sorted({labels[j] for j in nbrs[i] if core[j]})
            if border == "noise":
                labels[i] = -1
            elif len(reach) == 2:
                second[i] = reach[1]
    return np.array(labels), np.array(second)


def cases(rng):
    """Sorted values with ties and exact-eps gaps: lattice steps and random reals."""
    for n in (0, 1, 2, 5, 40, 150):
        yield np.sort(rng.integers(0, 60, size=n).astype(np.float64) * 0.25), 0.5
        yield np.sort(rng.uniform(0, 10, size=n)), 0.3


@pytest.mark.parametrize("border", ["first", "noise", "all"])
@pytest.mark.parametrize("min_points", [1, 2, 3, 5])
def test_dbscan1d_matches_bruteforce(border, min_points):
    rng = np.random.default_rng(min_points)
    for x, eps in cases(rng):
        want, want2 = naive_dbscan(x, eps, min_points, border=border)
        got = octoquant.dbscan1d(x, eps, min_points, border=border)
        if border == "all":
            got, got2 = got
            np.testing.assert_array_equal(got2, want2)
        assert got.dtype == np.int64
        np.testing.assert_array_equal(got, want, err_msg=f"x={x.tolist()} eps={eps}")


@pytest.mark.parametrize("min_points", [1, 3, 4])
def test_dbscan1d_circular_matches_bruteforce(min_points):
    rng = np.random.default_rng(10 + min_points)
    period = 2 * math.pi
    for n in (1, 3, 30, 120):
        x = np.sort(rng.uniform(0, period, size=n))
        # values near both ends of the circle, so that clusters cross the seam
        x = np.sort(np.concatenate([x, [0.0, 0.01, period - 0.02, period - 0.005]]))
        for eps in (0.05, 0.2):
            want, _ = naive_dbscan(x, eps, min_points, period=period)
            got = octoquant.dbscan1d(x, eps, min_points, period=period)
            np.testing.assert_array_equal(got, want, err_msg=f"n={n} eps={eps}")


def test_dbscan1d_unsorted_input_is_sorted_first():
    rng = np.random.default_rng(3)
    x = np.round(rng.uniform(0, 20, size=300), 1)
    order = np.argsort(x, kind="stable")
    want_sorted, _ = naive_dbscan(x[order], 0.25, 3)
    want = np.empty_like(want_sorted)
    want[order] = want_sorted
    np.testing.assert_array_equal(octoquant.dbscan1d(x, 0.25, 3), want)
    # float32, integers and lists are read as float64 values
    np.testing.assert_array_equal(octoquant.dbscan1d(x.astype(np.float32), 0.25, 3).shape, (300,))
    np.testing.assert_array_equal(
        octoquant.dbscan1d([0, 1, 2, 10, 11, 30], 1, 2), [0, 0, 0, 1, 1, -1]
    )


def test_dbscan1d_errors():
    with pytest.raises(ValueError, match="index 2"):
        octoquant.dbscan1d([0.0, 1.0, np.nan], 0.5, 2)
    with pytest.raises(ValueError, match="index 1 is outside"):
        octoquant.dbscan1d([0.0, 7.0], 0.5, 2, period=2 * math.pi)
    with pytest.raises(ValueError, match="eps"):
        octoquant.dbscan1d([0.0], -1.0, 2)
    with pytest.raises(ValueError, match="min_points"):
        octoquant.dbscan1d([0.0], 1.0, 0)
    with pytest.raises(ValueError, match="period"):
        octoquant.dbscan1d([0.0], 1.0, 1, period=0.0)
    with pytest.raises(ValueError, match="border"):
        octoquant.dbscan1d([0.0], 1.0, 1, border="some")
    with pytest.raises(ValueError, match=r"shape \(N,\)"):
        octoquant.dbscan1d(np.zeros((2, 2)), 1.0, 1)
    with pytest.raises(TypeError):
        octoquant.dbscan1d(["a", "b"], 1.0, 1)


@pytest.fixture(scope="module")
def intel_log(data_dir):
    path = data_dir / "laser2d" / "ple_corrected_carmen" / "intel-corrected.log.gz"
    if not path.is_file():
        pytest.skip(f"{path} is missing")
    return path


def flaser_ranges(path):
    """The readings of every FLASER line, straight from the text."""
    out = []
    with gzip.open(path, "rt") as f:
        for line in f:
            t = line.split()
            if t and t[0] == "FLASER":
                n = int(t[1])
                out.append(np.array([float(v) for v in t[2 : 2 + n]]))
    return out


def test_read_laser_scans_matches_the_log(intel_log):
    scans = octoquant.read_laser_scans(intel_log)
    ranges = flaser_ranges(intel_log)
    assert len(scans) == len(ranges) == 910
    for (pts, pose), r in zip(scans[::37], ranges[::37]):
        valid = r[(r > 0) & (r < 81.83 - 0.01)]
        assert pts.shape == (len(valid), 2) and pose.shape == (3,)
        np.testing.assert_allclose(np.hypot(pts[:, 0], pts[:, 1]), valid, rtol=1e-12)
    with pytest.raises(FileNotFoundError):
        octoquant.read_laser_scans(intel_log.parent / "nope.log")


def tls_fit(p):
    """The total-least-squares line through p, as the segment crate defines a Line."""
    c = p.mean(axis=0)
    d = p - c
    sxx, syy, sxy = (d[:, 0] ** 2).sum(), (d[:, 1] ** 2).sum(), (d[:, 0] * d[:, 1]).sum()
    phi = 0.5 * math.atan2(2 * sxy, sxx - syy) + math.pi / 2
    dist = c[0] * math.cos(phi) + c[1] * math.sin(phi)
    if dist < 0:
        phi += math.pi
        dist = -dist
    phi %= 2 * math.pi
    n = np.array([math.cos(phi), math.sin(phi)])
    r = p @ n - dist
    t = -p[:, 0] * n[1] + p[:, 1] * n[0]
    start = dist * n + t.min() * np.array([-n[1], n[0]])
    end = dist * n + t.max() * np.array([-n[1], n[0]])
    return phi, dist, start, end, math.sqrt((r**2).mean()), np.abs(r).max()


def check_lines(pts, lines, labels, min_line_points=5):
    assert labels.shape == (len(pts),) and labels.dtype == np.int64
    assert set(np.unique(labels)) <= set(range(-1, len(lines)))
    for k, line in enumerate(lines):
        members = pts[labels == k]
        assert line["n_points"] == len(members) >= max(min_line_points, 2)
        phi, dist, start, end, rms, mx = tls_fit(members)
        ang = math.remainder(line["normal_angle"] - phi, 2 * math.pi)
        assert abs(ang) < 1e-7 and 0 <= line["normal_angle"] < 2 * math.pi
        assert math.isclose(line["distance"], dist, rel_tol=1e-7, abs_tol=1e-7)
        np.testing.assert_allclose([line["start_x"], line["start_y"]], start, atol=1e-6)
        np.testing.assert_allclose([line["end_x"], line["end_y"]], end, atol=1e-6)
        assert math.isclose(line["length"], np.linalg.norm(end - start), abs_tol=1e-6)
        assert math.isclose(line["rms_residual"], rms, rel_tol=1e-6, abs_tol=1e-12)
        assert math.isclose(line["max_residual"], mx, rel_tol=1e-6, abs_tol=1e-12)


def test_segment_scan_corner():
    wall_x = np.column_stack([np.full(30, 3.0), -1.0 + 0.1 * np.arange(30)])
    wall_y = np.column_stack([2.9 - 0.1 * np.arange(30), np.full(30, 2.0)])
    pts = np.vstack([wall_x, wall_y])
    lines, labels = octoquant.segment_scan(pts)
    assert len(lines) == 2
    feet = sorted(
        (round(d * math.cos(a), 9) + 0.0, round(d * math.sin(a), 9) + 0.0)
        for a, d in zip(lines["normal_angle"], lines["distance"])
    )
    assert feet == [(0.0, 2.0), (3.0, 0.0)]
    check_lines(pts, lines, labels)
    # too few points give no lines, and a stricter minimum drops both walls
    assert len(octoquant.segment_scan(pts[:2])[0]) == 0
    assert len(octoquant.segment_scan(pts, min_line_points=40)[0]) == 0


def test_segment_scan_real_log(intel_log):
    scans = octoquant.read_laser_scans(intel_log)
    total = 0
    for pts, _ in scans[::15]:
        lines, labels = octoquant.segment_scan(pts)
        check_lines(pts, lines, labels)
        total += len(lines)
        tight, _ = octoquant.segment_scan(
            pts,
            eps_theta=math.radians(1.0),
            eps_dist=0.03,
            min_points_theta=4,
            min_points_dist=4,
            min_line_points=8,
            border="noise",
        )
        assert (tight["n_points"] >= 8).all()
    assert total > 100


def test_segment_scan_errors():
    with pytest.raises(ValueError, match="not finite"):
        octoquant.segment_scan(np.array([[0.0, 1.0], [np.nan, 1.0], [1.0, 1.0]]))
    with pytest.raises(ValueError, match=r"shape \(N, 2\)"):
        octoquant.segment_scan(np.zeros((5, 3)))
    with pytest.raises(ValueError, match="eps_dist"):
        octoquant.segment_scan(np.zeros((5, 2)), eps_dist=-1.0)
    with pytest.raises(ValueError, match="min_points_theta"):
        octoquant.segment_scan(np.zeros((5, 2)), min_points_theta=0)


def raycast(walls, degrees, sigma=0.0, seed=0):
    """Points of beams from the origin at ``degrees`` hitting the nearest wall segment
    ((x0, y0), (x1, y1)), with Gaussian range noise; beams hitting nothing give no point."""
    rng = np.random.default_rng(seed)
    pts = []
    for a in np.radians(degrees):
        d = np.array([math.cos(a), math.sin(a)])
        best = math.inf
        for p0, p1 in walls:
            p0, e = np.asarray(p0, float), np.asarray(p1, float) - np.asarray(p0, float)
            den = d[0] * e[1] - d[1] * e[0]
            if abs(den) < 1e-12:
                continue
            r = (p0[0] * e[1] - p0[1] * e[0]) / den
            s = (p0[0] * d[1] - p0[1] * d[0]) / den
            if r > 0 and 0 <= s <= 1:
                best = min(best, r)
        if best < math.inf:
            pts.append((best + sigma * rng.standard_normal()) * d)
    return np.array(pts)


def test_segment_scan_doorway_splits_the_wall():
    # a wall 2 m ahead with a 1 m doorway at x in [0.5, 1.5]
    walls = [((-4.0, 2.0), (0.5, 2.0)), ((1.5, 2.0), (4.0, 2.0))]
    pts = raycast(walls, np.arange(0.0, 181.0))
    lines, labels = octoquant.segment_scan(pts)
    check_lines(pts, lines, labels)
    assert len(lines) == 2
    # the ends next to the doorway are within a beam spacing (3.7 cm) of the jambs
    inner = sorted(
        min((l["start_x"], l["end_x"]), key=lambda x: abs(x - 1.0)) for l in lines
    )
    assert abs(inner[0] - 0.5) < 0.04 and abs(inner[1] - 1.5) < 0.04
    whole, labels = octoquant.segment_scan(pts, split_eps=math.inf)
    check_lines(pts, whole, labels)
    assert len(whole) == 1 and whole["n_points"][0] == lines["n_points"].sum()
    assert len(octoquant.segment_scan(pts, split_eps=1.2)[0]) == 1
    assert len(octoquant.segment_scan(pts, split_min_points=50)[0]) == 0
    # 40 median spacings (3.5 cm near the doorway) span it: one line again
    assert len(octoquant.segment_scan(pts, split_spacing_factor=40.0)[0]) == 1


def test_segment_scan_resegments_close_parallel_walls():
    # two parallel walls 5 cm apart, side by side, 3 mm range noise
    walls = [((-3.0, 2.0), (0.0, 2.0)), ((0.0, 1.95), (3.0, 1.95))]
    for seed in range(10):
        pts = raycast(walls, np.arange(0.0, 181.0), sigma=0.003, seed=seed)
        merged, _ = octoquant.segment_scan(pts)
        assert len(merged) == 1 and merged["rms_residual"][0] > 0.01
        lines, labels = octoquant.segment_scan(pts, resegment_rms=0.01)
        check_lines(pts, lines, labels)
        assert len(lines) == 2
        np.testing.assert_allclose(np.sort(lines["distance"]), [1.95, 2.0], atol=0.005)
        # a re-segmentation epsilon above the separation changes nothing
        same, _ = octoquant.segment_scan(pts, resegment_rms=0.01, resegment_eps=0.1)
        assert len(same) == 1


def test_segment_scan_split_errors():
    pts = np.zeros((5, 2))
    with pytest.raises(ValueError, match="split_eps"):
        octoquant.segment_scan(pts, split_eps=-1.0)
    with pytest.raises(ValueError, match="split_min_points"):
        octoquant.segment_scan(pts, split_min_points=0)
    with pytest.raises(ValueError, match="split_spacing_factor"):
        octoquant.segment_scan(pts, split_spacing_factor=-1.0)
    with pytest.raises(ValueError, match="resegment.max_rms"):
        octoquant.segment_scan(pts, resegment_rms=math.nan)
    with pytest.raises(ValueError, match="resegment_min_points"):
        octoquant.segment_scan(pts, resegment_rms=0.01, resegment_min_points=0)
    with pytest.raises(ValueError, match="need resegment_rms"):
        octoquant.segment_scan(pts, resegment_eps=0.01)


def test_segment_scan_real_log_split_only_cuts(intel_log):
    scans = octoquant.read_laser_scans(intel_log)
    with_split = without = 0
    for pts, _ in scans[::15]:
        lines, labels = octoquant.segment_scan(pts)
        whole, whole_labels = octoquant.segment_scan(pts, split_eps=math.inf)
        with_split += len(lines)
        without += len(whole)
        # every line of the default lies inside one line of the unsplit segmentation
        for k in range(len(lines)):
            parents = set(whole_labels[labels == k].tolist())
            assert len(parents) == 1 and -1 not in parents
    assert with_split >= without
