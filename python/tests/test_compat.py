"""Differential tests: the same calls on octomap-python's ``octomap.OcTree`` and on
``octoquant.OcTree`` give the same bytes, ray casts, search values, point clouds and leaves.
"""

import numpy as np
import pytest

import octoquant


def node_value(om, node):
    """A node's log-odds, or None where octomap-python returns a null node (unknown space)."""
    if node is None:
        return None
    try:
        return node.getValue()
    except om.NullPointerException:
        return None


def leaf_rows(it_source):
    return [
        (
            tuple(it.getCoordinate().tolist()),
            it.getSize(),
            it.getDepth(),
            it.getValue(),
            it.getOccupancy(),
            (it.getKey()[0], it.getKey()[1], it.getKey()[2]),
            (it.getIndexKey()[0], it.getIndexKey()[1], it.getIndexKey()[2]),
            (it.getX(), it.getY(), it.getZ()),
        )
        for it in it_source
    ]


def both(octomap, resolution):
    return octomap.OcTree(resolution), octoquant.OcTree(resolution)


def assert_same_tree(a, b):
    assert b.size() == a.size()
    assert b.getNumLeafNodes() == a.getNumLeafNodes()
    assert b.calcNumNodes() == a.calcNumNodes()
    assert b.write() == a.write()


@pytest.fixture(scope="module")
def scan_trees(octomap, scan_dat):
    """scan.dat inserted at 0.1 m by both."""
    a, b = both(octomap, 0.1)
    origin = np.zeros(3)
    a.insertPointCloud(scan_dat, origin)
    b.insertPointCloud(scan_dat, origin)
    return a, b


def test_scan_dat_bytes(scan_trees):
    a, b = scan_trees
    assert_same_tree(a, b)
    assert b.getMetricMin().tolist() == a.getMetricMin().tolist()
    assert b.getMetricMax().tolist() == a.getMetricMax().tolist()
    assert b.getMetricSize().tolist() == a.getMetricSize().tolist()
    assert b.volume() == a.volume()
    # writeBinary converts to max-likelihood and prunes: compare after, on copies
    a2 = octoquant.OcTree.read(a.write())
    assert a2.write() == a.write()


@pytest.mark.parametrize(
    "resolution,kwargs",
    [
        (0.2, {}),
        (0.2, {"maxrange": 4.0}),
        (0.2, {"discretize": True}),
        (0.25, {"lazy_eval": True}),
        (0.15, {"maxrange": 2.5, "discretize": True}),
    ],
)
def test_scan_dat_options(octomap, scan_dat, resolution, kwargs):
    a, b = both(octomap, resolution)
    origin = np.array([0.1, -0.2, 0.3])
    a.insertPointCloud(scan_dat, origin, **kwargs)
    b.insertPointCloud(scan_dat, origin, **kwargs)
    if kwargs.get("lazy_eval"):
        a.updateInnerOccupancy()
        b.updateInnerOccupancy()
    assert_same_tree(a, b)
    assert b.writeBinary() == a.writeBinary()
    assert_same_tree(a, b)


def test_float32_and_fortran_input_same_bytes(octomap, scan_dat):
    a, b = both(octomap, 0.2)
    pts = scan_dat[::3]
    a.insertPointCloud(pts, np.zeros(3))
    b.insertPointCloud(np.asfortranarray(pts.astype(np.float32)), [0, 0, 0])
    assert b.writeBinary() == a.writeBinary()


def test_random_sequences(octomap):
    rng = np.random.default_rng(23)
    for trial in range(6):
        res = float(rng.choice([0.05, 0.1, 0.3]))
        a, b = both(octomap, res)
        for step in range(12):
            op = rng.integers(0, 5)
            lazy = bool(rng.integers(0, 2))
            if op == 0:
                n = int(rng.integers(1, 400))
                pts = rng.normal(0, 2.0, (n, 3))
                origin = rng.normal(0, 0.5, 3)
                maxrange = float(rng.choice([-1.0, 1.5, 3.0]))
                disc = bool(rng.integers(0, 2))
                a.insertPointCloud(pts, origin, maxrange, lazy, disc)
                b.insertPointCloud(pts, origin, maxrange, lazy, disc)
            elif op == 1:
                p = rng.normal(0, 1.0, 3)
                hit = bool(rng.integers(0, 2))
                na = a.updateNode(p, hit, lazy)
                nb = b.updateNode(p, hit, lazy)
                assert nb.getValue() == na.getValue()
            elif op == 2:
                p = rng.normal(0, 1.0, 3)
                delta = float(rng.normal(0, 1.5))
                na = a.updateNode(p, delta, lazy)
                nb = b.updateNode(p, delta, lazy)
                assert nb.getValue() == na.getValue()
            elif op == 3:
                keys_a = []
                keys_b = []
                for p in rng.normal(0, 1.0, (20, 3)):
                    keys_a.append(a.coordToKey(p))
                    keys_b.append(b.coordToKey(p))
                hit = bool(rng.integers(0, 2))
                a.updateNodes(keys_a, hit, lazy)
                b.updateNodes(keys_b, hit, lazy)
            else:
                a.updateInnerOccupancy()
                b.updateInnerOccupancy()
            if step % 4 == 3:
                a.updateInnerOccupancy()
                b.updateInnerOccupancy()
                assert b.write() == a.write(), (trial, step)
        a.updateInnerOccupancy()
        b.updateInnerOccupancy()
        assert_same_tree(a, b)
        if trial % 2:
            a.toMaxLikelihood()
            b.toMaxLikelihood()
            assert b.write() == a.write()
        assert b.writeBinary() == a.writeBinary()


def test_cast_ray(scan_trees):
    a, b = scan_trees
    rng = np.random.default_rng(5)
    origins = rng.normal(0, 1.0, (400, 3))
    dirs = rng.normal(0, 1.0, (400, 3))
    for i, (o, d) in enumerate(zip(origins, dirs)):
        for ignore, max_range in [(False, -1.0), (True, -1.0), (True, 3.0), (False, 0.5)]:
            ea = np.full(3, 7.0)
            eb = np.full(3, 7.0)
            ha = a.castRay(o, d, ea, ignore, max_range)
            hb = b.castRay(o, d, eb, ignoreUnknownCells=ignore, maxRange=max_range)
            assert hb == ha, (i, ignore, max_range)
            assert eb.tolist() == ea.tolist(), (i, ignore, max_range)
    # the vectorised form agrees with the loop
    hits, ends = b.cast_rays(origins, dirs, ignore_unknown=True)
    for o, d, h, e in zip(origins, dirs, hits, ends):
        ea = np.zeros(3)
        assert a.castRay(o, d, ea, True) == h
        assert ea.tolist() == e.tolist()


def test_search_and_labels(octomap, scan_trees):
    a, b = scan_trees
    rng = np.random.default_rng(9)
    pts = np.concatenate([rng.uniform(-6, 6, (3000, 3)), a.extractPointCloud()[0][:500]])
    for p in pts[:1500]:
        for depth in (0, 16, 14, 9):
            va = node_value(octomap, a.search(p, depth))
            vb = node_value(octomap, b.search(p, depth))
            assert vb == va, (p, depth)
        key_a = a.coordToKey(p)
        key_b = b.coordToKey(p)
        assert list(key_b) == [key_a[0], key_a[1], key_a[2]]
        assert node_value(octomap, b.search(key_b)) == node_value(octomap, a.search(key_a))
    assert b.getLabels(pts).tolist() == a.getLabels(pts).tolist()


def occupancy_of(octomap, node):
    """octomap-python's getOccupancy of a node, or None for a null node (unknown space)."""
    if node is None:
        return None
    try:
        return node.getOccupancy()
    except octomap.NullPointerException:
        return None


def test_probability_at_is_octomaps_get_occupancy(octomap, scan_trees):
    a, b = scan_trees
    rng = np.random.default_rng(11)
    pts = np.concatenate(
        [rng.uniform(-6, 6, (2000, 3)), a.extractPointCloud()[0][:300], [[1e7, 0.0, 0.0]]]
    )
    known = 0
    for p in pts:
        want = occupancy_of(octomap, a.search(p))
        got = b.probability_at(p)
        assert got == want, p
        known += want is not None
    # both kinds of answer occur: known space and unknown space
    assert 0 < known < len(pts)
    vec = b.occupancy(pts)
    assert [None if np.isnan(v) else v for v in vec] == [b.probability_at(p) for p in pts]


def test_extract_point_cloud(octomap, scan_dat):
    a, b = both(octomap, 0.2)
    a.insertPointCloud(scan_dat, np.zeros(3))
    b.insertPointCloud(scan_dat, np.zeros(3))
    # prune to big leaves first: each covers many voxel centres
    a.writeBinary()
    b.writeBinary()
    occ_a, free_a = a.extractPointCloud()
    occ_b, free_b = b.extractPointCloud()
    assert occ_b.dtype == occ_a.dtype and free_b.dtype == free_a.dtype
    assert occ_b.shape == occ_a.shape and free_b.shape == free_a.shape
    assert occ_b.tobytes() == occ_a.tobytes()
    assert free_b.tobytes() == free_a.tobytes()


def test_leaf_iteration(scan_trees):
    a, b = scan_trees
    assert leaf_rows(b.begin_leafs()) == leaf_rows(a.begin_leafs())
    for depth in (12, 15):
        assert leaf_rows(b.begin_leafs(depth)) == leaf_rows(a.begin_leafs(depth))
    lo, hi = np.array([-1.0, -2.0, -0.5]), np.array([1.5, 0.3, 0.8])
    assert leaf_rows(b.begin_leafs_bbx(lo, hi)) == leaf_rows(a.begin_leafs_bbx(lo, hi))
    assert leaf_rows(b.begin_leafs_bbx(hi, lo, 13)) == leaf_rows(a.begin_leafs_bbx(hi, lo, 13))
    rows_a = [(r, it.isLeaf()) for r, it in zip(leaf_rows(a.begin_tree(14)), a.begin_tree(14))]
    rows_b = [(r, it.isLeaf()) for r, it in zip(leaf_rows(b.begin_tree(14)), b.begin_tree(14))]
    assert rows_b == rows_a


def test_is_node_occupied_on_iterators(scan_trees):
    a, b = scan_trees
    occ_a = [a.isNodeOccupied(it) for it in a.begin_leafs(14)]
    occ_b = [b.isNodeOccupied(it) for it in b.begin_leafs(14)]
    assert occ_b == occ_a
    thr_a = [a.isNodeAtThreshold(it) for it in a.begin_leafs()]
    thr_b = [b.isNodeAtThreshold(it) for it in b.begin_leafs()]
    assert thr_b == thr_a


def test_sensor_model(octomap, scan_dat):
    a, b = both(octomap, 0.2)
    for t in (a, b):
        t.setProbHit(0.8)
        t.setProbMiss(0.35)
        t.setClampingThresMin(0.2)
        t.setClampingThresMax(0.9)
        t.setOccupancyThres(0.6)
    for name in [
        "getProbHit",
        "getProbHitLog",
        "getProbMiss",
        "getProbMissLog",
        "getClampingThresMin",
        "getClampingThresMinLog",
        "getClampingThresMax",
        "getClampingThresMaxLog",
        "getOccupancyThres",
        "getOccupancyThresLog",
    ]:
        assert getattr(b, name)() == getattr(a, name)(), name
    a.insertPointCloud(scan_dat, np.zeros(3))
    b.insertPointCloud(scan_dat, np.zeros(3))
    assert_same_tree(a, b)
    assert b.writeBinary() == a.writeBinary()


def test_keys_and_coordinates(octomap):
    a, b = both(octomap, 0.07)
    rng = np.random.default_rng(2)
    for p in np.concatenate([rng.normal(0, 50, (300, 3)), [[3000.0, 0, 0], [-2293.76, 0, 1]]]):
        ka, kb = a.coordToKey(p), b.coordToKey(p)
        assert list(kb) == [ka[i] for i in range(3)]
        for d in (16, 12, 3, 1):
            ka_d, kb_d = a.coordToKey(p, d), b.coordToKey(p, d)
            assert list(kb_d) == [ka_d[i] for i in range(3)]
            assert b.keyToCoord(kb_d, d).tolist() == a.keyToCoord(ka_d, d).tolist()
            ja, jb = a.adjustKeyAtDepth(ka, d), b.adjustKeyAtDepth(kb, d)
            assert list(jb) == [ja[i] for i in range(3)]
        assert b.keyToCoord(kb).tolist() == a.keyToCoord(ka).tolist()
        ca, cb = a.coordToKeyChecked(p), b.coordToKeyChecked(p)
        assert cb[0] == ca[0]
        if ca[0]:
            assert list(cb[1]) == [ca[1][i] for i in range(3)]
        else:
            assert cb[1] is None


def test_read_reference_file(octomap, geb079):
    a = octomap.OcTree(str(geb079))
    b = octoquant.OcTree(str(geb079))
    assert b.getResolution() == a.getResolution()
    assert_same_tree(a, b)
    assert b.writeBinary() == a.writeBinary() == geb079.read_bytes()
    assert leaf_rows(b.begin_leafs()) == leaf_rows(a.begin_leafs())
    # bytes path, readBinary from a path and from bytes, read() of .ot bytes
    c = octoquant.OcTree(bytes(geb079))
    assert c.writeBinary() == a.writeBinary()
    d = octoquant.OcTree(0.5)
    assert d.readBinary(geb079.read_bytes()) is True
    assert d.write() == a.write()
    e = octoquant.OcTree.read(a.write())
    assert e.write() == a.write()


def test_write_files(octomap, scan_dat, tmp_path):
    a, b = both(octomap, 0.3)
    a.insertPointCloud(scan_dat[::5], np.zeros(3))
    b.insertPointCloud(scan_dat[::5], np.zeros(3))
    ot = a.write()
    assert a.write(str(tmp_path / "a.ot")) is True
    assert b.write(tmp_path / "b.ot") is True
    assert (tmp_path / "b.ot").read_bytes() == (tmp_path / "a.ot").read_bytes()
    assert a.writeBinary(str(tmp_path / "a.bt")) is True
    assert b.writeBinary(str(tmp_path / "b.bt").encode()) is True
    assert (tmp_path / "b.bt").read_bytes() == (tmp_path / "a.bt").read_bytes()
    # each reads the other's files
    assert octoquant.OcTree.read(str(tmp_path / "a.ot")).write() == ot
    assert octomap.OcTree.read(str(tmp_path / "b.ot")).write() == ot


def test_bbx_limited_insertion(octomap, scan_dat):
    for disc, maxrange in [(False, -1.0), (True, -1.0), (False, 3.0)]:
        a, b = both(octomap, 0.2)
        lo, hi = np.array([-2.0, -4.0, -0.5]), np.array([3.0, 1.0, 1.5])
        for t in (a, b):
            t.setBBXMin(lo)
            t.setBBXMax(hi)
            t.useBBXLimit(True)
        assert b.bbxSet() == a.bbxSet()
        for name in ("getBBXMin", "getBBXMax", "getBBXBounds", "getBBXCenter"):
            assert getattr(b, name)().tolist() == getattr(a, name)().tolist(), name
        for p in (np.array([0.0, 0.0, 0.0]), np.array([3.0, 1.0, 1.6]), hi, lo):
            assert b.inBBX(p) == a.inBBX(p)
        a.insertPointCloud(scan_dat, np.array([0.5, -1.0, 0.2]), maxrange, False, disc)
        b.insertPointCloud(scan_dat, np.array([0.5, -1.0, 0.2]), maxrange, False, disc)
        assert_same_tree(a, b)


def test_delete_node(octomap, scan_dat):
    a, b = both(octomap, 0.2)
    a.insertPointCloud(scan_dat[::4], np.zeros(3))
    b.insertPointCloud(scan_dat[::4], np.zeros(3))
    rng = np.random.default_rng(4)
    for p in scan_dat[rng.choice(len(scan_dat), 40)]:
        d = int(rng.choice([0, 16, 14, 12]))
        assert b.deleteNode(p, d) == a.deleteNode(p, d)
    # OctoMap's size() goes stale in deleteNode (one node per deleted subtree), and .ot
    # headers carry it: compare the node data and the leaves
    body = lambda t: t.write().split(b"\ndata\n", 1)[1]  # noqa: E731
    assert body(b) == body(a)
    assert b.calcNumNodes() == a.calcNumNodes()
    assert leaf_rows(b.begin_leafs()) == leaf_rows(a.begin_leafs())


def test_clear_and_prune_expand(octomap, scan_dat):
    a, b = both(octomap, 0.2)
    a.insertPointCloud(scan_dat[::4], np.zeros(3))
    b.insertPointCloud(scan_dat[::4], np.zeros(3))
    a.toMaxLikelihood()
    b.toMaxLikelihood()
    b.prune()
    b.expand()
    b.prune()
    assert b.writeBinary() == a.writeBinary()
    a.clear()
    b.clear()
    assert_same_tree(a, b)
    assert b.getTreeDepth() == a.getTreeDepth()
    assert b.getTreeType() == a.getTreeType()


def test_frames_read_by_the_rust_readers(octomap, data_dir, scan_dat):
    """Frames from octoquant.read_frames (the CLI's readers) inserted into both trees."""
    scan = octoquant.read_frames(data_dir / "lidar3d" / "octomap_scan_dat" / "scan.dat.bz2")
    assert len(scan) == 1
    pts, origin = scan[0]
    assert pts.dtype == np.float32 and pts.shape == scan_dat.shape
    np.testing.assert_allclose(pts, scan_dat, rtol=1e-6)
    graph = octoquant.read_frames(data_dir / "octomap_reference" / "spherical_scan.graph")
    assert len(graph) == 1 and graph[0][0].shape == (10201, 3)
    a, b = both(octomap, 0.2)
    for pts, origin in graph + scan:
        a.insertPointCloud(pts.astype(np.float64), origin.astype(np.float64), 8.0)
        b.insertPointCloud(pts, origin, 8.0)
    assert_same_tree(a, b)
    assert b.writeBinary() == a.writeBinary()


def test_the_common_base_is_octomap_pythons(octomap):
    """``OccupancyOcTreeBase`` relates to the tree classes as octomap-python's does, and is no
    tree of its own."""
    pairs = [(octomap.OcTree, octoquant.OcTree), (octomap.ColorOcTree, octoquant.ColorOcTree)]
    for theirs, ours in pairs:
        assert isinstance(theirs(0.1), octomap.OccupancyOcTreeBase)
        assert isinstance(ours(0.1), octoquant.OccupancyOcTreeBase)
        assert issubclass(ours, octoquant.OccupancyOcTreeBase)
    # OctoMap's OcTreeStamped derives from OccupancyOcTreeBase too
    assert isinstance(octoquant.OcTreeStamped(0.1), octoquant.OccupancyOcTreeBase)
    for other in (octoquant.OcTreeNode, octoquant.Mapper, octoquant.OcTreeKey):
        assert not issubclass(other, octoquant.OccupancyOcTreeBase)
    with pytest.raises(TypeError, match="common base"):
        octoquant.OccupancyOcTreeBase()
