"""octoquant's own behaviour: argument checking, errors, the vectorised extras, pickling and
the GIL. No octomap-python needed."""

import copy
import pickle
import threading
import time

import numpy as np
import pytest

import octoquant
from octoquant import NullPointerException, OcTree, OcTreeKey


def wall(n=40, x=2.0):
    """A square wall of n*n points at distance x, seen from the origin."""
    g = (np.arange(n) - n / 2) * 0.05
    yy, zz = np.meshgrid(g, g)
    return np.column_stack([np.full(n * n, x), yy.ravel(), zz.ravel()])


@pytest.fixture
def tree():
    t = OcTree(0.1)
    t.insertPointCloud(wall(), np.zeros(3))
    return t


def test_input_layouts_give_the_same_tree():
    pts = wall()
    ref = OcTree(0.1)
    ref.insertPointCloud(pts, np.zeros(3))
    big = np.zeros((pts.shape[0] * 2, 5))
    big[::2, 1:4] = pts
    for variant in [
        pts.astype(np.float32),
        np.asfortranarray(pts),
        np.asfortranarray(pts.astype(np.float32)),
        big[::2, 1:4],  # strided view
        pts[::-1][::-1],
        pts.tolist(),
    ]:
        t = OcTree(0.1)
        t.insertPointCloud(variant, (0.0, 0.0, 0.0))
        assert t.write() == ref.write()


@pytest.mark.parametrize(
    "bad,exc,msg",
    [
        (np.zeros((5, 4)), ValueError, r"shape \(N, 3\)"),
        (np.zeros(3), ValueError, r"shape \(N, 3\)"),
        (np.zeros((2, 3, 1)), ValueError, r"shape \(N, 3\)"),
        (np.zeros((5, 3), dtype=np.int64), TypeError, "float32 or float64"),
        (np.zeros((5, 3), dtype=np.complex128), TypeError, "float32 or float64"),
        ("points", TypeError, r"\(N, 3\) float array"),
        ([[1, 2], [3, 4]], ValueError, r"shape \(N, 3\)"),
        ([["a", "b", "c"]], TypeError, "float array"),
    ],
)
def test_bad_point_clouds(bad, exc, msg):
    t = OcTree(0.1)
    with pytest.raises(exc, match=msg):
        t.insertPointCloud(bad, np.zeros(3))
    with pytest.raises(exc, match=msg):
        t.getLabels(bad)


def test_bad_vectors_and_values():
    t = OcTree(0.1)
    with pytest.raises(ValueError, match="3 elements"):
        t.insertPointCloud(wall(), np.zeros(4))
    with pytest.raises(TypeError):
        t.insertPointCloud(wall(), "origin")
    with pytest.raises(ValueError, match="NaN"):
        t.insertPointCloud(wall(), np.zeros(3), float("nan"))
    with pytest.raises(ValueError, match="between 0 and 16"):
        t.search(np.zeros(3), 17)
    with pytest.raises(ValueError, match="between 0 and 16"):
        t.begin_leafs(-1)
    for bad in (0.0, -0.1, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="resolution"):
            OcTree(bad)
    for setter in ("setProbHit", "setProbMiss", "setOccupancyThres", "setClampingThresMin"):
        with pytest.raises(ValueError):
            getattr(t, setter)(1.0)
    with pytest.raises(ValueError, match=">= 0.5"):
        t.setProbHit(0.3)
    with pytest.raises(ValueError, match="<= 0.5"):
        t.setProbMiss(0.7)
    with pytest.raises(TypeError, match="update"):
        t.updateNode(np.zeros(3), "yes")
    with pytest.raises(OverflowError):
        OcTreeKey(70000, 0, 0)


def test_non_finite_points_are_skipped():
    pts = wall()
    ref = OcTree(0.1)
    ref.insertPointCloud(pts, np.zeros(3))
    dirty = np.concatenate([pts, [[np.nan, 0, 0], [np.inf, 1, 1], [0, -np.inf, 2]]])
    t = OcTree(0.1)
    t.insertPointCloud(dirty, np.zeros(3))
    assert t.write() == ref.write()
    labels = t.getLabels(np.array([[np.nan, 0, 0], [2.0, 0.0, 0.0], [1e9, 0, 0]]))
    assert labels.tolist() == [-1, 1, -1]


def test_bad_files(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.bt"):
        OcTree(str(tmp_path / "nope.bt"))
    with pytest.raises(FileNotFoundError):
        OcTree.read(tmp_path / "nope.ot")
    garbage = tmp_path / "garbage.bt"
    garbage.write_bytes(b"not an octree\n" * 10)
    with pytest.raises(ValueError, match="garbage.bt"):
        OcTree(str(garbage))
    truncated = tmp_path / "cut.bt"
    t = OcTree(0.1)
    t.insertPointCloud(wall(), np.zeros(3))
    truncated.write_bytes(t.writeBinary()[:-7])
    with pytest.raises(ValueError, match="cut.bt"):
        OcTree.read(truncated)
    with pytest.raises(ValueError):
        OcTree.read(b"# Octomap OcTree file\nid OcTree\nsize 3\nres 0.1\ndata\n\x01")
    ot = tmp_path / "x.ot"
    t.write(ot)
    with pytest.raises(ValueError, match="binary"):
        OcTree(0.1).readBinary(str(ot))
    with pytest.raises(OSError):
        t.writeBinary(str(tmp_path / "missing_dir" / "x.bt"))
    with pytest.raises(TypeError):
        OcTree.read(12.5j)


def test_search_and_nodes(tree):
    n = tree.search(np.array([2.0, 0.0, 0.0]))
    assert tree.isNodeOccupied(n)
    assert n.getOccupancy() == pytest.approx(0.7)
    assert n.getLogOdds() == n.getValue()
    assert not n.hasChildren()
    assert tree.search(np.array([5.0, 5.0, 5.0])) is None
    assert tree.search([50000.0, 0.0, 0.0]) is None
    with pytest.raises(NullPointerException):
        tree.isNodeOccupied(tree.search(np.array([5.0, 5.0, 5.0])))
    free = tree.search(np.array([1.0, 0.0, 0.0]))
    assert not tree.isNodeOccupied(free)
    k = tree.coordToKey(np.array([2.0, 0.0, 0.0]))
    assert tree.search(k).getValue() == n.getValue()
    assert tree.search((k[0], k[1], k[2])) is not None or True
    node = tree.updateNode(k, True)
    assert node.getValue() == pytest.approx(2 * 0.8472978)
    assert tree.updateNode([1e9, 0, 0], True) is None
    assert tree.getRoot().hasChildren()
    assert OcTree(0.1).getRoot() is None


def test_keys():
    k = OcTreeKey(1, 2, 3)
    assert list(k) == [1, 2, 3] and len(k) == 3
    k[1] = 9
    assert k == OcTreeKey(1, 9, 3) and k == (1, 9, 3) and k != (1, 2, 3)
    assert k[-1] == 3
    with pytest.raises(IndexError):
        k[3]
    assert pickle.loads(pickle.dumps(k)) == k
    assert repr(k) == "OcTreeKey(1, 9, 3)"


def test_iterators(tree):
    it = tree.begin_leafs()
    first = it.getCoordinate()
    assert it.next() is it
    assert it.getCoordinate().tolist() != first.tolist() or it.getDepth() >= 0
    leaves = list(tree.begin_leafs())
    assert len(leaves) == tree.getNumLeafNodes()
    assert all(isinstance(x, octoquant.leaf_iterator) for x in leaves)
    assert len({tuple(x.getCoordinate()) for x in leaves}) == len(leaves)
    end = tree.end_leafs()
    with pytest.raises(NullPointerException):
        end.getCoordinate()
    with pytest.raises(StopIteration):
        end.next()
    nodes = list(tree.begin_tree())
    assert len(nodes) == tree.size()
    assert sum(n.isLeaf() for n in nodes) == tree.getNumLeafNodes()
    # a box corner outside the map gives no leaves, as in OctoMap
    assert list(tree.begin_leafs_bbx(np.array([-1e9, 0, 0]), np.zeros(3))) == []


def test_extras_agree_with_the_compatible_api(tree):
    occ_c, occ_s = tree.occupied_voxels()
    free_c, free_s = tree.free_voxels()
    assert len(occ_c) + len(free_c) == tree.getNumLeafNodes()
    assert np.all(occ_s > 0) and occ_c.shape[1] == 3
    labels = tree.getLabels(occ_c)
    assert np.all(labels == 1)
    assert np.all(tree.getLabels(free_c) == 0)
    p = tree.occupancy(np.concatenate([occ_c, [[9.0, 9.0, 9.0]]]))
    assert np.all(p[:-1] > 0.5) and np.isnan(p[-1])
    lv = tree.leaves()
    assert lv.dtype.names == ("x", "y", "z", "size", "depth", "log_odds")
    assert len(lv) == tree.getNumLeafNodes()
    ref = [(it.getX(), it.getSize(), it.getDepth(), it.getValue()) for it in tree.begin_leafs()]
    assert [(r["x"], r["size"], r["depth"], r["log_odds"]) for r in lv] == [
        (x, s, d, np.float32(v)) for x, s, d, v in ref
    ]
    box = tree.leaves(bbx=(np.array([1.5, -1, -1]), np.array([2.5, 1, 1])), max_depth=14)
    assert 0 < len(box) < len(lv)
    hits, ends = tree.cast_rays(np.zeros(3), np.array([[1.0, 0, 0], [-1.0, 0, 0], [0, 0, 0]]))
    assert hits.tolist() == [True, False, False]
    assert np.isnan(ends[2]).all()
    assert ends[0].tolist() == pytest.approx([2.05, 0.05, 0.05])


def test_serialization_round_trips(tree):
    bt = tree.to_bytes("bt")
    ot = tree.to_bytes("ot")
    assert OcTree.from_bytes(ot).write() == ot
    assert OcTree.from_bytes(bt).writeBinary() == bt
    with pytest.raises(ValueError):
        tree.to_bytes("xml")
    tree.setProbHit(0.9)
    back = pickle.loads(pickle.dumps(tree))
    assert back.write() == tree.write()
    assert back.getProbHit() == tree.getProbHit()
    c = copy.deepcopy(tree)
    c.clear()
    assert tree.size() > 0


def test_change_detection():
    t = OcTree(0.1)
    t.enableChangeDetection(True)
    assert t.isChangeDetectionEnabled()
    t.updateNode(np.array([0.05, 0.05, 0.05]), True)
    changes = t.changedKeys()
    assert t.numChangesDetected() == len(changes) == 1
    key, new = changes[0]
    assert new and key == t.coordToKey(np.array([0.05, 0.05, 0.05]))
    t.resetChangeDetection()
    assert t.numChangesDetected() == 0


def test_cast_ray_end_argument(tree):
    end = np.zeros(3, dtype=np.float32)
    assert tree.castRay([0, 0, 0], [1, 0, 0], end)
    assert end.tolist() == pytest.approx([2.05, 0.05, 0.05])
    with pytest.raises(TypeError, match="end"):
        tree.castRay([0, 0, 0], [1, 0, 0], [0.0, 0.0, 0.0])
    ro = np.zeros(3)
    ro.flags.writeable = False
    with pytest.raises(ValueError):
        tree.castRay([0, 0, 0], [1, 0, 0], ro)
    untouched = np.full(3, 4.0)
    assert not tree.castRay([0, 0, 0], [0, 0, 0], untouched)
    assert untouched.tolist() == [4.0, 4.0, 4.0]


def test_insert_releases_the_gil():
    rng = np.random.default_rng(1)
    pts = rng.normal(0, 20, (300_000, 3))
    t = OcTree(0.05)
    done = threading.Event()
    ticks = 0

    def work():
        t.insertPointCloud(pts, np.zeros(3))
        done.set()

    th = threading.Thread(target=work)
    start = time.perf_counter()
    th.start()
    while not done.is_set():
        ticks += 1
        time.sleep(0.001)
    th.join()
    elapsed = time.perf_counter() - start
    # the main thread kept running while the insertion did
    assert elapsed < 0.05 or ticks > 5


def test_read_frames_errors(tmp_path):
    with pytest.raises(FileNotFoundError):
        octoquant.read_frames(tmp_path / "nope.pcd")
    bad = tmp_path / "bad.pcd"
    bad.write_text("this is not a pcd file\n")
    with pytest.raises(ValueError, match="bad.pcd"):
        octoquant.read_frames(bad)
    txt = tmp_path / "pts.txt"
    txt.write_text("1 2 3\n4 5 6\n")
    ((pts, origin),) = octoquant.read_frames(txt)
    assert pts.tolist() == [[1, 2, 3], [4, 5, 6]] and origin.tolist() == [0, 0, 0]
    with pytest.raises(ValueError, match="unknown format"):
        octoquant.read_frames(txt, format="xml")
