"""``octoquant.OcTreeStamped`` and ``octoquant.StampedMapper`` (OctoMap's ``OcTreeStamped``).

octomap-python has no ``OcTreeStamped``, so the reference is the CLI: ``octoquant map
--stamped`` writes the ``.ot`` that liboctomap's ``OcTreeStamped`` writes with its clock set to
each frame's second (tests/stamped_diff.rs proves that against the C++ library). The clock is
controlled through the frames' own time stamps: the TUM RGB-D association's depth images are
named by their time, the CLI stamps each frame with its whole second, and the Python side is
given the same times as ``insert(..., stamp=...)``. The binary is found as in
test_cli_agreement.py (the ``cli`` fixture in conftest.py).
"""

import math
import subprocess

import numpy as np
import pytest

import octoquant
from conftest import _missing, tum_depth_stamps

TUM = "rgbd/tum_fr2_pioneer_slam2_subset/my_association.txt"


@pytest.fixture(scope="module")
def tum(data_dir):
    """The TUM RGB-D association, its frames (every 4th pixel) and each frame's time stamp."""
    assoc = data_dir / TUM
    if not assoc.is_file():
        _missing(str(assoc))
    read = octoquant.read_frames(assoc, pixel_step=4, stamps=True)
    frames = [(points, origin) for points, origin, _ in read]
    stamps = [stamp for _, _, stamp in read]
    assert stamps == tum_depth_stamps(assoc)
    assert len(frames) == 10
    return assoc, frames, stamps


def cli_map(cli, assoc, out, *extra):
    args = [cli, "map", str(assoc), "--pixel-step", "4", "--res", "0.1", "--stamped"]
    args += [*extra, "-q", "-o", str(out)]
    res = subprocess.run(args, capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr
    return out.read_bytes()


def stamped_map(frames, stamps, **kwargs):
    mapper = octoquant.StampedMapper(0.1, **kwargs)
    for (points, origin), stamp in zip(frames, stamps):
        st = mapper.insert(points, origin, stamp=stamp)
        assert st["stamp"] == math.floor(stamp)
        assert st["points"] == len(points)
    assert mapper.frames == len(frames)
    return mapper


def leaves(tree):
    """Every leaf as (key, depth, log-odds, stamp), in iteration order."""
    return [
        (tuple(it.getKey()), it.getDepth(), it.getValue(), it.getTimestamp())
        for it in tree.begin_leafs()
    ]


def test_stamped_mapper_matches_cli(cli, tum, tmp_path):
    """StampedMapper over read_frames with the frames' own times writes the .ot that ``octoquant
    map --stamped`` writes from the same TUM frames, without and with ``--degrade-older-than``
    (the frames are 1-2 s apart, so a 1 s threshold degrades after most frames); and the stamps
    shape the map: a plain Mapper prunes more, and degrading changes the bytes."""
    assoc, frames, stamps = tum
    kept = cli_map(cli, assoc, tmp_path / "kept.ot")
    degraded = cli_map(cli, assoc, tmp_path / "degraded.ot", "--degrade-older-than", "1")
    assert kept != degraded

    mapper = stamped_map(frames, stamps)
    tree = mapper.tree
    assert tree.write() == kept
    assert tree.getTreeType() == b"OcTreeStamped"
    assert tree.getLastUpdateTime() == math.floor(stamps[-1]) == 1311877824
    assert mapper.degrade_older_than is None
    # several seconds in the map, and equal leaves kept apart by their stamps
    assert len({s for *_, s in leaves(tree)}) >= 5
    plain = octoquant.Mapper(0.1)
    for points, origin in frames:
        plain.insert(points, origin)
    assert plain.tree.getNumLeafNodes() < tree.getNumLeafNodes()

    mapper = stamped_map(frames, stamps, degrade_older_than=1)
    assert mapper.degrade_older_than == 1
    assert mapper.tree.write() == degraded


@pytest.mark.parametrize(
    "extra, kwargs",
    [((), {}), (("--max-range", "4"), {"maxrange": 4.0}), (("--discretize",), {"discretize": True})],
)
def test_insert_point_cloud_matches_cli(cli, tum, tmp_path, extra, kwargs):
    """``OcTreeStamped.insertPointCloud`` with each frame's whole second as ``now`` writes the
    .ot of ``octoquant map --stamped`` on the same TUM frames (OctoMap's ``insertPointCloud``
    into an ``OcTreeStamped`` with its clock set to each frame's second), with a maximum range
    and with ``discretize`` as the CLI's options; and a clock a second later for every other
    frame gives another map."""
    assoc, frames, stamps = tum
    want = cli_map(cli, assoc, tmp_path / "want.ot", *extra)
    tree = octoquant.OcTreeStamped(0.1)
    for (points, origin), stamp in zip(frames, stamps):
        tree.insertPointCloud(points, origin, now=math.floor(stamp), **kwargs)
    assert tree.write() == want
    assert tree.getLastUpdateTime() == math.floor(stamps[-1])
    shifted = octoquant.OcTreeStamped(0.1)
    for i, ((points, origin), stamp) in enumerate(zip(frames, stamps)):
        shifted.insertPointCloud(points, origin, now=math.floor(stamp) + i % 2, **kwargs)
    assert shifted.write() != want


def test_insert_point_cloud_refusals(tum):
    """A NaN maximum range, a negative time and points of the wrong shape raise ValueError
    and leave the tree as it was."""
    _, frames, _ = tum
    points, origin = frames[0]
    tree = octoquant.OcTreeStamped(0.1)
    for kwargs in [{"maxrange": float("nan")}, {"now": -1}]:
        with pytest.raises(ValueError):
            tree.insertPointCloud(points, origin, **kwargs)
    with pytest.raises(ValueError):
        tree.insertPointCloud(points[:, :2], origin, now=5)
    assert tree.size() == 0


def test_stamped_mapper_filters_and_range_match_cli(cli, tum, tmp_path):
    """The sensor model, maximum range and point filters reach the stamped map as the CLI's
    options do: same .ot bytes with --max-range, a z band and --degrade-older-than 2."""
    assoc, frames, stamps = tum
    want = cli_map(
        cli,
        assoc,
        tmp_path / "banded.ot",
        *("--max-range", "4", "--zmin", "0", "--zmax", "1", "--degrade-older-than", "2"),
    )
    mapper = octoquant.StampedMapper(0.1, degrade_older_than=2, max_range=4.0, zmin=0.0, zmax=1.0)
    dropped = 0
    for (points, origin), stamp in zip(frames, stamps):
        st = mapper.insert(points, origin, stamp)
        z = points[:, 2].astype(np.float64)
        assert st["dropped"]["z_band"] == int(np.sum((z < 0.0) | (z > 1.0)))
        dropped += st["dropped"]["z_band"]
    assert dropped > 10000, dropped
    assert mapper.tree.write() == want


def test_degrade_outdated_nodes_matches_cli(cli, tum, tmp_path):
    """``OcTreeStamped.degradeOutdatedNodes`` against the CLI's ``--degrade-older-than``, with
    the clock set by the frames' times: the frames' whole seconds run from 1311877813 to
    1311877824, so with a 10 s threshold the CLI's degrade after each frame finds a stale leaf
    only after the last one (824 - 813 > 10; 823 - 813 is not). The map of every frame without
    degrading, then ``degradeOutdatedNodes(10, now=1311877824)``, is then the CLI's map byte for
    byte, and differs from the map without degrading."""
    assoc, frames, stamps = tum
    seconds = [math.floor(s) for s in stamps]
    assert seconds[0] == 1311877813 and seconds[-1] == 1311877824
    assert seconds[-2] - seconds[0] <= 10 < seconds[-1] - seconds[0]
    want = cli_map(cli, assoc, tmp_path / "degraded.ot", "--degrade-older-than", "10")
    tree = stamped_map(frames, stamps).tree
    assert tree.write() != want
    tree.degradeOutdatedNodes(10, now=seconds[-1])
    assert tree.write() == want


def test_degrade_outdated_nodes_matches_naive_expectation(tum):
    """``degradeOutdatedNodes(thres, now=...)`` on the map of the TUM frames: every occupied leaf
    whose stamp is more than ``thres`` seconds before ``now`` gets exactly one miss (clamped at
    the lower bound), computed here in float32 from the leaves' stamps; every other leaf, every
    inner node and every stamp stays as it was."""
    _, frames, stamps = tum
    tree = stamped_map(frames, stamps).tree
    model = octoquant.OcTree(0.1)  # the same default sensor model, for its log-odds
    miss = np.float32(model.getProbMissLog())
    clamp_min = np.float32(model.getClampingThresMinLog())
    threshold = np.float32(model.getOccupancyThresLog())
    now = math.floor(stamps[-1])
    thres = 3
    before = leaves(tree)
    inner_before = [(tuple(n.getKey()), n.getDepth(), n.getValue()) for n in tree.begin_tree()
                    if not n.isLeaf()]
    expected = []
    for key, depth, value, stamp in before:
        v = np.float32(value)
        if v >= threshold and now - stamp > thres:
            v = max(np.float32(v + miss), clamp_min)
        expected.append((key, depth, float(v), stamp))
    stale = sum(1 for b, e in zip(before, expected) if b != e)
    fresh_occupied = sum(
        1 for _, _, v, s in before if np.float32(v) >= threshold and now - s <= thres
    )
    assert stale > 100 and fresh_occupied > 100, (stale, fresh_occupied)

    tree.degradeOutdatedNodes(thres, now=now)
    assert leaves(tree) == expected
    inner_after = [(tuple(n.getKey()), n.getDepth(), n.getValue()) for n in tree.begin_tree()
                   if not n.isLeaf()]
    assert inner_after == inner_before
    assert tree.getLastUpdateTime() == now


def test_written_tree_reads_back(tum, tmp_path):
    """write() to a file and to bytes, read back through ``OcTreeStamped.read``, the
    constructor and bytes: the same .ot bytes, nodes and log-odds, every stamp 0 (the format
    holds none, as in OctoMap), and less memory (no stamps to hold)."""
    _, frames, stamps = tum
    tree = stamped_map(frames[:4], stamps[:4]).tree
    data = tree.write()
    path = tmp_path / "stamped.ot"
    assert tree.write(str(path)) is True
    assert path.read_bytes() == data
    for back in (
        octoquant.OcTreeStamped.read(path),
        octoquant.OcTreeStamped.read(str(path)),
        octoquant.OcTreeStamped(str(path)),
        octoquant.OcTreeStamped.read(data),
    ):
        assert back.write() == data
        assert back.size() == tree.size() > 1000
        assert back.getResolution() == tree.getResolution()
        assert back.getLastUpdateTime() == 0
        got = leaves(back)
        assert [g[:3] for g in got] == [w[:3] for w in leaves(tree)]
        assert {g[3] for g in got} == {0}
        assert all(n.getTimestamp() == 0 for n in back.begin_tree())
        # memoryUsage counts the stamps: four bytes at least for each stamped node, which
        # the tree read back (the same nodes, no stamps) does not hold
        assert tree.memoryUsage() >= back.memoryUsage() + 4 * tree.size()


def test_node_stamps_follow_octomap_rules(tum):
    """On the map of the TUM frames: an eager update stamps the voxel and the root, a lazy one
    only the voxel; ``search`` and the iterators give the same stamps; eight equal leaves with
    different stamps are not pruned, with equal stamps they are; ``updateInnerOccupancy`` stamps
    the inner nodes."""
    _, frames, stamps = tum
    tree = stamped_map(frames[:3], stamps[:3]).tree
    last = math.floor(stamps[2])
    assert tree.getLastUpdateTime() == last
    assert tree.getRoot().getTimestamp() == last
    occupied = [it for it in tree.begin_leafs() if tree.isNodeOccupied(it) and it.getDepth() == 16]
    assert len(occupied) > 100
    for it in occupied[:50]:
        assert tree.search(it.getKey()).getTimestamp() == it.getTimestamp() > 0

    key = occupied[0].getKey()
    node = tree.updateNode(key, False, now=last + 100)
    assert node.getTimestamp() == last + 100 == tree.search(key).getTimestamp()
    assert tree.getLastUpdateTime() == last + 100
    other = occupied[1].getKey()
    tree.updateNode(other, False, True, now=last + 200)  # lazy: the voxel only
    assert tree.search(other).getTimestamp() == last + 200
    assert tree.getLastUpdateTime() == last + 100

    # eight voxels of one fresh depth-15 node, far from the scans
    base = octoquant.OcTreeKey(1000, 1000, 1000)
    octant = [octoquant.OcTreeKey(base[0] + (i & 1), base[1] + (i >> 1 & 1), base[2] + (i >> 2 & 1))
              for i in range(8)]
    for i, k in enumerate(octant):
        for _ in range(6):  # reach the upper clamp
            tree.updateNode(k, True, now=last + 300 + (i == 7))
    assert tree.search(octant[0]).getDepth() == 16  # kept apart by the last stamp
    size = tree.size()
    for _ in range(6):
        tree.updateNode(octant[7], True, now=last + 300)  # at the clamp: no change, no stamp
    assert tree.search(octant[7]).getTimestamp() == last + 301
    tree.updateNode(octant[7], False, now=last + 300)
    for _ in range(6):
        tree.updateNode(octant[7], True, now=last + 300)
    pruned = tree.search(octant[0])
    assert pruned.getDepth() == 15 and pruned.getTimestamp() == last + 300
    assert tree.size() == size - 8

    tree.updateInnerOccupancy(now=last + 400)
    assert tree.getLastUpdateTime() == last + 400
    assert all(n.getTimestamp() == last + 400 for n in tree.begin_tree() if not n.isLeaf())


def test_non_finite_points_are_skipped(tum):
    """NaN and inf rows are counted and skipped: the map is the one without them."""
    _, frames, stamps = tum
    points, origin = frames[0]
    dirty = np.concatenate([points, [[np.nan, 0, 0], [np.inf, 1, 1], [0, -np.inf, 2]]])
    clean = octoquant.StampedMapper(0.1)
    clean.insert(points, origin, stamps[0])
    m = octoquant.StampedMapper(0.1)
    st = m.insert(dirty.astype(np.float64), origin, stamps[0])
    assert st["non_finite"] == 3 and st["points"] == len(points) + 3
    assert m.tree.write() == clean.tree.write()


@pytest.mark.parametrize(
    "bad,exc,msg",
    [
        (np.zeros((5, 4)), ValueError, r"shape \(N, 3\)"),
        (np.zeros(3), ValueError, r"shape \(N, 3\)"),
        (np.zeros((5, 3), dtype=np.int64), TypeError, "float32 or float64"),
        ("points", TypeError, r"\(N, 3\) float array"),
    ],
)
def test_bad_points_are_refused(bad, exc, msg):
    m = octoquant.StampedMapper(0.1)
    with pytest.raises(exc, match=msg):
        m.insert(bad, np.zeros(3), 100.0)
    assert m.frames == 0


def test_refusals(data_dir, geb079, tmp_path):
    """Bad arguments and files raise Python exceptions, never crash, and change nothing."""
    for bad in (float("nan"), 0.0, -0.1, float("inf")):
        with pytest.raises(ValueError, match="resolution"):
            octoquant.OcTreeStamped(bad)
        with pytest.raises(ValueError, match="resolution"):
            octoquant.StampedMapper(bad)
    with pytest.raises(ValueError, match="eager"):
        octoquant.StampedMapper(0.1, lazy=True)
    with pytest.raises(ValueError, match="per-frame voxel sets"):
        octoquant.StampedMapper(0.1, mode="simple")
    with pytest.raises(ValueError, match="unknown mode"):
        octoquant.StampedMapper(0.1, mode="fast")
    with pytest.raises(ValueError, match="degrade_older_than"):
        octoquant.StampedMapper(0.1, degrade_older_than=-1)
    with pytest.raises(ValueError, match="max_range"):
        octoquant.StampedMapper(0.1, max_range=float("nan"))
    with pytest.raises(ValueError, match="hit probability 1.5"):
        octoquant.StampedMapper(0.1, prob_hit=1.5)
    with pytest.raises(ValueError, match="crop_sensor"):
        octoquant.StampedMapper(0.1, crop_sensor=[1.0, 2.0])

    m = octoquant.StampedMapper(0.1)
    pts = np.array([[1.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    with pytest.raises(ValueError, match="3 elements"):
        m.insert(pts, np.zeros(4), 100.0)
    for stamp in (-1.0, float("nan"), float("inf"), 2.0**32):
        with pytest.raises(ValueError, match="time stamp"):
            m.insert(pts, np.zeros(3), stamp)
    with pytest.raises(TypeError):
        m.insert(pts, np.zeros(3), "noon")
    assert m.frames == 0 and m.tree.size() == 0
    m.insert(pts, np.zeros(3), 2.0**32 - 0.5)  # the last second OctoMap can store
    assert m.tree.getLastUpdateTime() == 2**32 - 1

    t = m.tree
    with pytest.raises(ValueError, match="time_thres"):
        t.degradeOutdatedNodes(-1)
    with pytest.raises(ValueError, match="now"):
        t.degradeOutdatedNodes(1, now=2**32)
    with pytest.raises(ValueError, match="now"):
        t.updateNode(np.array([1.0, 0.0, 0.0]), True, now=-5)
    with pytest.raises(ValueError, match="between 0 and 16"):
        t.search(np.zeros(3), 17)
    with pytest.raises(TypeError, match="update"):
        t.updateNode(np.zeros(3), "yes")
    assert t.updateNode(np.array([1e9, 0.0, 0.0]), True, now=1) is None  # outside the map
    assert t.getLastUpdateTime() == 2**32 - 1
    with pytest.raises(TypeError, match="OcTreeStamped"):
        next(iter(octoquant.OcTree(geb079).begin_leafs())).getTimestamp()

    # files of other tree types, a .bt, garbage, a missing file
    plain = tmp_path / "plain.ot"
    octoquant.OcTree(geb079).write(str(plain))
    color = octoquant.ColorOcTree(0.1)
    color.updateNode(np.array([1.0, 0.0, 0.0]), True)
    colored = tmp_path / "color.ot"
    color.write(str(colored))
    garbage = tmp_path / "garbage.ot"
    garbage.write_bytes(b"# Octomap OcTree file\nid OcTreeStamped\nsize 12\nres 0.1\ndata\nxx")
    for path, msg in (
        (plain, 'plain.ot: the file holds a tree of type "OcTree", not the OcTreeStamped'),
        (colored, 'type "ColorOcTree"'),
        (geb079, "geb079.bt: invalid .ot data"),
        (garbage, "garbage.ot"),
    ):
        with pytest.raises(ValueError, match=msg):
            octoquant.OcTreeStamped.read(path)
        with pytest.raises(ValueError, match=msg):
            octoquant.OcTreeStamped(str(path))
    with pytest.raises(ValueError, match='type "OcTree"'):
        octoquant.OcTreeStamped.read(plain.read_bytes())
    with pytest.raises(FileNotFoundError, match="nope.ot"):
        octoquant.OcTreeStamped.read(tmp_path / "nope.ot")


def test_occupancy_calls_and_the_box_as_on_an_octree(scan_dat):
    """OcTreeStamped shares OcTree's occupancy calls (keys, metrics, sensor model, query box,
    change detection): with the same calls, the same occupancy as an OcTree, whose box-limited
    insertion is checked against octomap-python in test_compat; every voxel updated stamped."""
    s, o = octoquant.OcTreeStamped(0.1), octoquant.OcTree(0.1)
    lo, hi = np.array([-4.0, -3.0, -1.0]), np.array([3.0, 4.0, 1.5])
    for t in (s, o):
        t.setProbHit(0.8)
        t.setClampingThresMax(0.95)
        t.setBBXMin(lo)
        t.setBBXMax(hi)
        t.useBBXLimit(True)
        t.enableChangeDetection(True)
    pts = scan_dat[::3]
    s.insertPointCloud(pts, np.zeros(3), 6.0, now=1234)
    o.insertPointCloud(pts, np.zeros(3), 6.0)
    assert s.getProbHit() == o.getProbHit() == pytest.approx(0.8)
    assert s.calcNumNodes() == o.calcNumNodes() > 5_000
    assert s.write().split(b"\ndata\n", 1)[1] == o.write().split(b"\ndata\n", 1)[1]
    assert s.getMetricMin().tolist() == o.getMetricMin().tolist()
    assert (s.getMetricMin() >= lo - 0.2).all() and (s.getMetricMax() <= hi + 0.2).all()
    assert s.numChangesDetected() == o.numChangesDetected() > 1000
    assert s.changedKeys()[:50] == o.changedKeys()[:50]
    s.resetChangeDetection()
    assert s.numChangesDetected() == 0
    for p in pts[::500]:
        assert list(s.coordToKey(p)) == list(o.coordToKey(p))
        ns, no = s.search(p), o.search(p)
        assert (ns is None) == (no is None)
        if ns is not None:
            assert s.isNodeAtThreshold(ns) == o.isNodeAtThreshold(no)
            assert ns.getTimestamp() == 1234
    assert s.getLastUpdateTime() == 1234


def test_copies_keep_the_stamps(scan_dat):
    import copy
    import pickle

    s = octoquant.OcTreeStamped(0.2)
    s.insertPointCloud(scan_dat[::50], np.zeros(3), now=77)
    for c in (copy.copy(s), copy.deepcopy(s)):
        assert c.write() == s.write() and c.getLastUpdateTime() == 77
        c.insertPointCloud(scan_dat[1::50], np.zeros(3), now=99)
        assert c.getLastUpdateTime() == 99 and s.getLastUpdateTime() == 77
    with pytest.raises(TypeError):
        pickle.dumps(s)


def test_node_surgery_follows_the_stamp_rules():
    """OctoMap's node surgery on an OcTreeStamped (checked against liboctomap by the Rust
    tests' reference scripts): an expansion copies the node's stamp to its children, a prune
    needs equal stamps and keeps child 0's, a created child has stamp 0; no clock is read."""
    t = octoquant.OcTreeStamped(0.1)
    base = np.array([0.05, 0.05, 0.05])
    # the eight voxels of one depth-15 node, all at the clamp at the same time: pruned
    for i in range(8):
        p = base + 0.1 * np.array([i & 1, i >> 1 & 1, i >> 2 & 1])
        for _ in range(5):
            t.updateNode(p, True, now=50)
    parent = t.search(base, 15)
    assert parent.getDepth() == 15 and not t.nodeHasChildren(parent)
    assert parent.getTimestamp() == 50
    t.expandNode(parent)
    kids = [t.getNodeChild(parent, i) for i in range(8)]
    assert [k.getTimestamp() for k in kids] == [50] * 8
    assert t.isNodeCollapsible(parent)
    # another stamp on one child stops the collapse; deleting it and creating it anew gives
    # a child of log-odds 0 and stamp 0
    t.updateNode(kids[3].getKey(), False, now=60)
    assert t.search(base, 16).getTimestamp() == 50
    assert t.getNodeChild(parent, 3).getTimestamp() == 60
    assert not t.isNodeCollapsible(parent) and not t.pruneNode(parent)
    t.deleteNodeChild(parent, 3)
    assert not t.nodeChildExists(parent, 3)
    c = t.createNodeChild(parent, 3)
    assert (c.getValue(), c.getTimestamp()) == (0.0, 0)
    with pytest.raises(ValueError, match="exists already"):
        t.createNodeChild(parent, 3)
    t.deleteNodeChild(parent, 3)
    t.createNodeChild(parent, 3)
    t.updateNode(t.getNodeChild(parent, 3).getKey(), float(kids[0].getValue()), True, now=50)
    # (the lazy update set log-odds and stamp 50 like its siblings, and pruned nothing:
    # collapsible again)
    assert t.getNodeChild(parent, 3).getTimestamp() == 50
    assert t.isNodeCollapsible(parent) and t.pruneNode(parent)
    assert t.search(base, 16).getDepth() == 15
    assert t.search(base, 16).getTimestamp() == 50


def test_node_in_hand_calls_follow_octomap():
    """OctoMap's calls on a node in hand (checked against liboctomap by the Rust tests'
    reference scripts): ``updateNodeLogOdds``, ``integrateHit`` and ``integrateMiss`` add and
    clamp without an early exit and stamp the node alone; ``integrateMissNoTime`` and
    ``nodeToMaxLikelihood`` keep its stamp; ``setNodeTimestamp``/``updateNodeTimestamp`` set
    it; none of them refreshes the ancestors."""
    t = octoquant.OcTreeStamped(0.1)
    p = np.array([0.05, 0.05, 0.05])
    t.updateNode(p, True, now=10)
    # OctoMap's default sensor model, as log-odds
    hit, miss, lo, hi = (math.log(q / (1 - q)) for q in (0.7, 0.4, 0.1192, 0.971))
    voxel = t.search(p)
    assert t.integrateHit(voxel, now=20) == pytest.approx(2 * hit, abs=1e-5)
    assert (t.search(p).getTimestamp(), t.getLastUpdateTime()) == (20, 10)
    assert t.integrateMiss(voxel, now=30) == pytest.approx(2 * hit + miss, abs=1e-5)
    # no early exit at a clamp: the sum is clamped
    assert t.updateNodeLogOdds(voxel, 100.0, now=40) == pytest.approx(hi, abs=1e-5)
    assert t.updateNodeLogOdds(voxel, -100.0, now=41) == pytest.approx(lo, abs=1e-5)
    assert t.search(p).getTimestamp() == 41
    assert t.integrateMissNoTime(voxel) == pytest.approx(lo, abs=1e-5)
    assert t.search(p).getTimestamp() == 41
    t.updateNodeLogOdds(voxel, 3.0, now=42)  # from the lower clamp to occupied
    assert t.nodeToMaxLikelihood(voxel) == pytest.approx(hi, abs=1e-5)
    assert t.search(p).getTimestamp() == 42
    # the root was not refreshed by any of them
    root = t.getRoot()
    assert (root.getTimestamp(), root.getValue()) == (10, pytest.approx(hit, abs=1e-5))
    assert t.setNodeTimestamp(root, 7) == 7 and t.getLastUpdateTime() == 7
    assert t.updateNodeTimestamp(root, now=99) == 99 and t.getLastUpdateTime() == 99
    assert t.updateNodeTimestamp(root) >= 1_700_000_000  # the system clock
    with pytest.raises(ValueError, match="NaN"):
        t.updateNodeLogOdds(voxel, float("nan"), now=50)
    with pytest.raises(ValueError, match="whole seconds"):
        t.setNodeTimestamp(root, -1)
    t.deleteNode(p, 0, now=60)
    with pytest.raises(ValueError, match="not in this tree"):
        t.integrateHit(voxel, now=60)
