"""Differential tests of ``octoquant.ColorOcTree`` against octomap-python's ``ColorOcTree``:
the same calls give the same ``.ot`` bytes and the same node colours, on random sequences and
on real coloured points (PCL's table scene, a stereo frame with per-point RGB).
"""

import struct

import numpy as np
import pytest

import octoquant

PCD = "pcd/pcl_table_scene_mug_stereo_textured/table_scene_mug_stereo_textured.pcd"


def lzf_decompress(data, out_len):
    """LZF (liblzf's format, as PCD's binary_compressed uses), straight from its definition."""
    out = bytearray()
    i = 0
    while i < len(data):
        ctrl = data[i]
        i += 1
        if ctrl < 32:  # a literal run of ctrl + 1 bytes
            out += data[i : i + ctrl + 1]
            i += ctrl + 1
        else:  # a back reference
            length = ctrl >> 5
            if length == 7:
                length += data[i]
                i += 1
            ref = len(out) - ((ctrl & 0x1F) << 8) - data[i] - 1
            i += 1
            for _ in range(length + 2):
                out.append(out[ref])
                ref += 1
    assert len(out) == out_len
    return bytes(out)


def table_scene(data_dir):
    """(N, 3) float32 points and (N, 3) uint8 colours of the table scene, NaN pixels dropped."""
    raw = (data_dir / PCD).read_bytes()
    tag = b"DATA binary_compressed\n"
    at = raw.index(tag) + len(tag)
    header = raw[:at].decode()
    assert "FIELDS x y z rgba" in header
    packed, size = struct.unpack_from("<II", raw, at)
    body = lzf_decompress(raw[at + 8 : at + 8 + packed], size)
    n = size // 16
    xyz = np.frombuffer(body[: 12 * n], dtype="<f4").reshape(3, n).T
    rgba = np.frombuffer(body[12 * n :], dtype="<u4")
    keep = ~np.isnan(xyz).any(axis=1)
    xyz, rgba = xyz[keep], rgba[keep]
    # PCL packs rgba as 0xAARRGGBB
    rgb = np.stack([(rgba >> 16) & 255, (rgba >> 8) & 255, rgba & 255], axis=1).astype(np.uint8)
    return np.ascontiguousarray(xyz), rgb


def node_color(om, node):
    """A node's colour, or None for a null node (octomap-python) / None (octoquant)."""
    if node is None:
        return None
    try:
        return tuple(node.getColor())
    except om.NullPointerException:
        return None


@pytest.mark.parametrize("seed", range(6))
def test_random_color_sequences_match(octomap, seed):
    rng = np.random.default_rng(seed)
    a, b = octomap.ColorOcTree(0.1), octoquant.ColorOcTree(0.1)
    # points on a small grid, so octants fill, prune and share colours
    cells = (rng.integers(0, 6, size=(3000, 3)) * 0.1 + 0.05).astype(np.float64)
    palette = [(255, 255, 255), (0, 0, 0), (255, 255, 254)]
    inner_done = False
    for i, p in enumerate(cells):
        op = rng.integers(0, 10)
        if op < 5:
            hit = bool(rng.integers(0, 4))
            a.updateNode(p, hit)
            b.updateNode(p, hit)
        else:
            if rng.integers(0, 4) == 0:
                c = palette[rng.integers(0, len(palette))]
            else:
                c = tuple(int(v) for v in rng.integers(0, 256, size=3))
            name = ["setNodeColor", "averageNodeColor", "integrateNodeColor"][op % 3]
            na = getattr(a, name)(p, *c)
            nb = getattr(b, name)(p, *c)
            assert node_color(octomap, nb) == node_color(octomap, na), (i, name)
        if i % 500 == 499 and b.size() > 0:
            # (octomap's ColorOcTree.updateInnerOccupancy crashes on an empty tree)
            a.updateInnerOccupancy()
            b.updateInnerOccupancy()
            inner_done = True
    assert inner_done
    assert b.size() == a.size()
    assert b.write() == a.write()
    a.toMaxLikelihood()
    b.toMaxLikelihood()
    assert b.write() == a.write()


def test_real_colored_points_match(octomap, data_dir):
    xyz, rgb = table_scene(data_dir)
    assert len(xyz) == 209_280
    a, b = octomap.ColorOcTree(0.01), octoquant.ColorOcTree(0.01)
    for p, c in zip(xyz[::3], rgb[::3].tolist()):
        a.updateNode(p, True)
        b.updateNode(p, True)
        a.integrateNodeColor(p, *c)
        b.integrateNodeColor(p, *c)
    a.updateInnerOccupancy()
    b.updateInnerOccupancy()
    ours = b.write()
    assert ours == a.write()
    assert len(ours) > 50_000  # about 12 000 nodes of 8 bytes
    # the bytes read back, by both
    again = octoquant.ColorOcTree.read(ours)
    assert again.write() == ours
    assert again.search(xyz[0]).getColor() == node_color(octomap, a.search(xyz[0]))


def test_file_round_trip_and_errors(tmp_path):
    t = octoquant.ColorOcTree(0.05)
    t.updateNode(np.array([1.0, 2.0, 3.0]), True)
    n = t.setNodeColor(np.array([1.0, 2.0, 3.0]), 1, 2, 3)
    assert n.getColor() == (1, 2, 3) and n.isColorSet()
    assert t.getTreeType() == b"ColorOcTree"
    assert t.setNodeColor(np.array([9.0, 9.0, 9.0]), 1, 2, 3) is None
    path = tmp_path / "c.ot"
    assert t.write(str(path)) is True
    assert octoquant.ColorOcTree(str(path)).write() == t.write()
    with pytest.raises(OverflowError):
        t.setNodeColor(np.array([1.0, 2.0, 3.0]), 256, 0, 0)
    plain = octoquant.OcTree(0.05)
    plain.updateNode(np.array([1.0, 2.0, 3.0]), True)
    with pytest.raises(ValueError, match="OcTree"):
        octoquant.ColorOcTree.read(plain.write())
    with pytest.raises(ValueError):
        octoquant.ColorOcTree.read(t.write()[:-3])


def om_node(om, node):
    """octomap-python's node, or None for its null node (it returns a node object that raises
    NullPointerException where octoquant returns None)."""
    try:
        node.getValue()
    except om.NullPointerException:
        return None
    return node


def nodes_of(it, color=True):
    """(depth, key, log-odds, colour) of every node an iterator walks, read while it stands on
    each (octomap-python's iterator objects all share one position)."""
    out = []
    for n in it:
        k = n.getKey()
        row = (n.getDepth(), (k[0], k[1], k[2]), n.getValue(), tuple(n.getCoordinate()))
        out.append(row + ((tuple(n.getColor()),) if color else ()))
    return out


@pytest.fixture(scope="module")
def colored_pair(octomap, data_dir):
    """octomap-python's ColorOcTree over the table scene (free space by ray insertion, end
    points' colours integrated, inner colours updated) and octoquant's read from its bytes."""
    xyz, rgb = table_scene(data_dir)
    a = octomap.ColorOcTree(0.02)
    a.insertPointCloud(xyz[::4].astype(np.float64), np.zeros(3))
    for p, c in zip(xyz[::9].astype(np.float64), rgb[::9].tolist()):
        a.integrateNodeColor(p, *c)
    a.updateInnerOccupancy()
    b = octoquant.ColorOcTree.read(a.write())
    assert b.size() == a.size() > 10_000
    return a, b, xyz


def test_iterators_walk_the_same_nodes_and_colours(octomap, colored_pair):
    a, b, _ = colored_pair
    tree_a, tree_b = nodes_of(a.begin_tree()), nodes_of(b.begin_tree())
    assert len(tree_b) == a.size()
    assert tree_b == tree_a
    # inner nodes carry the average colours, and some leaves are coloured, some white
    colours = {row[4] for row in tree_b}
    assert len(colours) > 100 and (255, 255, 255) in colours
    assert any(row[0] < 16 and row[4] != (255, 255, 255) for row in tree_b)
    assert nodes_of(b.begin_leafs()) == nodes_of(a.begin_leafs())
    assert nodes_of(b.begin_leafs(13)) == nodes_of(a.begin_leafs(13))
    assert nodes_of(b.begin_tree(11)) == nodes_of(a.begin_tree(11))
    lo, hi = np.array([-0.2, -0.1, 0.6]), np.array([0.1, 0.2, 1.0])
    box_b = nodes_of(b.begin_leafs_bbx(lo, hi))
    assert len(box_b) > 100
    assert box_b == nodes_of(a.begin_leafs_bbx(lo, hi))
    # isLeaf on the tree iterator, occupancy through an iterator
    leaf_a = [n.isLeaf() for n in a.begin_tree(12)]
    assert [n.isLeaf() for n in b.begin_tree(12)] == leaf_a
    occ_a = [a.isNodeOccupied(n) for n in a.begin_leafs()]
    assert [b.isNodeOccupied(n) for n in b.begin_leafs()] == occ_a


def test_iterator_ends_and_plain_tree_colour(octomap, colored_pair):
    a, b, _ = colored_pair
    for t, npe in ((a, octomap.NullPointerException), (b, octoquant.NullPointerException)):
        with pytest.raises(npe):
            t.end_leafs().getColor()
        it = t.begin_leafs()
        assert it.getColor() == tuple(it.getColor())
    plain = octoquant.OcTree(0.1)
    plain.updateNode(np.zeros(3), True)
    with pytest.raises(TypeError, match="ColorOcTree"):
        next(iter(plain.begin_leafs())).getColor()


def test_node_colour_accessors_match(octomap, colored_pair):
    a, b, xyz = colored_pair
    rng = np.random.default_rng(5)
    seen_inner = 0
    for p in xyz[rng.choice(len(xyz), 400, replace=False)].astype(np.float64):
        for depth in (0, 16, 14, 12):
            na, nb = om_node(octomap, a.search(p, depth)), b.search(p, depth)
            assert (nb is None) == (na is None)
            if nb is None:
                continue
            seen_inner += nb.hasChildren()
            assert (nb.getValue(), nb.hasChildren()) == (na.getValue(), na.hasChildren())
            assert nb.getColor() == tuple(na.getColor())
            assert nb.isColorSet() == na.isColorSet()
            assert nb.getAverageChildColor() == tuple(na.getAverageChildColor())
    assert seen_inner > 100
    ra, rb = a.getRoot(), b.getRoot()
    assert rb.getColor() == tuple(ra.getColor())
    assert rb.getAverageChildColor() == tuple(ra.getAverageChildColor())


def test_set_color_on_nodes_in_hand_matches(octomap, colored_pair):
    a0, _, xyz = colored_pair
    a = octomap.ColorOcTree.read(a0.write())
    b = octoquant.ColorOcTree.read(a0.write())
    for i, p in enumerate(xyz[::5000].astype(np.float64)):
        depth = (0, 16, 15, 13, 10)[i % 5]
        na, nb = om_node(octomap, a.search(p, depth)), b.search(p, depth)
        assert (nb is None) == (na is None)
        if nb is None:
            continue
        c = (i * 7 % 256, 255 - i % 256, 3)
        na.setColor(*c)
        nb.setColor(*c)
        assert nb.getColor() == c == tuple(na.getColor())
        assert b.search(p, depth).getColor() == c
    assert b.write() == a.write()
    # a node gone from its tree cannot be coloured
    p = xyz[0].astype(np.float64)
    n = b.search(p)
    b.clear()
    with pytest.raises(ValueError, match="no longer"):
        n.setColor(1, 2, 3)


def test_cast_ray_matches(octomap, colored_pair):
    a, b, xyz = colored_pair
    rng = np.random.default_rng(11)
    targets = xyz[rng.choice(len(xyz), 1500, replace=False)].astype(np.float64)
    dirs = targets + rng.normal(scale=0.05, size=targets.shape)
    origin = np.zeros(3)
    hits = 0
    cases = [dict(), dict(ignoreUnknownCells=True), dict(ignoreUnknownCells=True, maxRange=0.8)]
    for d in dirs:
        for kw in cases:
            ea, eb = np.zeros(3), np.zeros(3)
            ha = a.castRay(origin, d, ea, **kw)
            hb = b.castRay(origin, d, eb, **kw)
            assert (hb, eb.tolist()) == (ha, ea.tolist()), (d, kw)
            hits += hb
    assert 500 < hits < 3 * len(dirs)
    # the vectorised form agrees with the single casts
    h, ends = b.cast_rays(origin, dirs[:50], ignore_unknown=True)
    for d, hv, e in zip(dirs[:50], h, ends):
        ea = np.zeros(3)
        assert bool(hv) == a.castRay(origin, d, ea, ignoreUnknownCells=True)
        assert e.tolist() == ea.tolist()


@pytest.fixture(scope="module")
def colored_base(octomap, data_dir):
    """The `.ot` bytes of octomap-python's ColorOcTree at 0.02 m over the table scene (the scan
    inserted once, then every leaf given a colour of its own) and the scene's points: leaves
    of unequal log-odds with colours, so that a later scan's eager updates prune nodes and
    expand some again, which moves colours in an order-dependent way (with the free keys in
    Morton order instead of OctoMap's, the first insertion test below fails)."""
    xyz, _ = table_scene(data_dir)
    a = octomap.ColorOcTree(0.02)
    pts = xyz[::4].astype(np.float64)
    a.insertPointCloud(pts, np.zeros(3))
    for i, it in enumerate(a.begin_leafs()):
        a.setNodeColor(it.getCoordinate(), i % 251, (7 * i) % 253, (13 * i) % 255)
    return a.write(), xyz


def pair_from(octomap, data):
    """octomap-python's and octoquant's ColorOcTree read from the same `.ot` bytes."""
    a = octomap.ColorOcTree(0.1)
    assert a.readBinary is not None
    return octomap.ColorOcTree.read(data), octoquant.ColorOcTree.read(data)


@pytest.mark.parametrize(
    "maxrange, lazy, discretize",
    [(-1.0, False, False), (0.9, False, False), (-1.0, True, False), (-1.0, False, True)],
)
def test_insert_point_cloud_into_a_coloured_tree_matches(
    octomap, colored_base, maxrange, lazy, discretize
):
    data, xyz = colored_base
    a, b = pair_from(octomap, data)
    assert b.write() == data
    colored = sum(n.getColor() != (255, 255, 255) for n in b.begin_tree())
    assert colored > 1_000
    # a shifted copy of the scene: other rays through the same space, a different origin
    pts = (xyz[1::3] + np.float32(0.013)).astype(np.float64)
    origin = np.array([0.01, -0.02, 0.005])
    a.insertPointCloud(pts, origin, maxrange, lazy, discretize)
    b.insertPointCloud(pts, origin, maxrange, lazy, discretize)
    ours = b.write()
    assert ours != data
    assert ours == a.write()
    if lazy:
        a.updateInnerOccupancy()
        b.updateInnerOccupancy()
        assert b.write() == a.write()


def test_insert_point_cloud_in_a_box_matches(octomap, colored_base):
    data, xyz = colored_base
    a, b = pair_from(octomap, data)
    lo, hi = np.array([-0.3, -0.2, 0.5]), np.array([0.2, 0.25, 1.1])
    for t in (a, b):
        t.setBBXMin(lo)
        t.setBBXMax(hi)
        t.useBBXLimit(True)
    assert b.bbxSet() and a.bbxSet()
    assert b.getBBXMin().tolist() == list(a.getBBXMin())
    assert b.getBBXCenter().tolist() == pytest.approx(list(a.getBBXCenter()))
    assert b.inBBX(np.array([0.0, 0.0, 0.8])) and not b.inBBX(np.array([0.0, 0.0, 2.0]))
    pts = (xyz[2::3] - np.float32(0.011)).astype(np.float64)
    a.insertPointCloud(pts, np.zeros(3), 1.0)
    b.insertPointCloud(pts, np.zeros(3), 1.0)
    assert b.write() != data
    assert b.write() == a.write()


def test_update_nodes_and_binary_files_match(octomap, colored_base, tmp_path):
    data, xyz = colored_base
    a, b = pair_from(octomap, data)
    pts = xyz[5::11].astype(np.float64)
    for update in (False, True, False):
        a.updateNodes(pts, update)
        b.updateNodes(pts, update)
    assert b.write() == a.write()
    # writeBinary: max-likelihood and pruned by the colour rules first, like OctoMap's
    bt = b.writeBinary()
    assert bt == a.writeBinary()
    assert b"id ColorOcTree" in bt.split(b"\ndata\n")[0]
    assert b.write() == a.write()
    path = tmp_path / "t.bt"
    path.write_bytes(bt)
    ra, rb = octomap.ColorOcTree(0.1), octoquant.ColorOcTree(0.1)
    assert ra.readBinary(str(path).encode()) and rb.readBinary(str(path))
    assert rb.getResolution() == 0.02
    assert rb.write() == ra.write()
    assert all(n.getColor() == (255, 255, 255) for n in rb.begin_tree())


def test_node_surgery_matches(octomap, colored_base):
    data, xyz = colored_base
    a, b = pair_from(octomap, data)
    rng = np.random.default_rng(3)
    done = {"expand": 0, "prune": 0, "create": 0, "delete": 0}
    for i, p in enumerate(xyz[rng.choice(len(xyz), 1500, replace=False)].astype(np.float64)):
        depth = int(rng.integers(11, 17))
        nb = b.search(p, depth)
        na = om_node(octomap, a.search(p, depth))
        assert (nb is None) == (na is None)
        if nb is None:
            continue
        assert b.isNodeCollapsible(nb) == a.isNodeCollapsible(na)
        kind = i % 4
        if kind == 0 and not nb.hasChildren() and nb.getDepth() < 16:
            a.expandNode(na)
            b.expandNode(nb)
            done["expand"] += 1
        elif kind == 1 and nb.hasChildren():
            assert b.pruneNode(nb) == a.pruneNode(na)
            done["prune"] += 1
        elif kind == 2 and nb.getDepth() < 16:
            j = int(rng.integers(0, 8))
            if b.nodeChildExists(nb, j):
                cb, ca = b.getNodeChild(nb, j), a.getNodeChild(na, j)
                assert (cb.getValue(), cb.getColor()) == (ca.getValue(), tuple(ca.getColor()))
                b.deleteNodeChild(nb, j)
                a.deleteNodeChild(na, j)
                done["delete"] += 1
            elif nb.hasChildren():
                cb, ca = b.createNodeChild(nb, j), a.createNodeChild(na, j)
                assert (cb.getValue(), cb.getColor()) == (ca.getValue(), tuple(ca.getColor()))
                done["create"] += 1
    assert min(done.values()) > 20, done
    # (OctoMap's deleteNodeChild takes one node off size(), whatever the subtree, and the
    # header of write() gives that size)
    assert b.calcNumNodes() == a.calcNumNodes()
    body = b.write().split(b"\ndata\n", 1)[1]
    assert len(body) > 50_000
    assert body == a.write().split(b"\ndata\n", 1)[1]


def test_shared_calls_match(octomap, colored_base):
    data, xyz = colored_base
    a, b = pair_from(octomap, data)
    for name in ("getMetricMin", "getMetricMax", "getMetricSize"):
        assert getattr(b, name)().tolist() == pytest.approx(list(getattr(a, name)()))
    assert b.volume() == pytest.approx(a.volume())
    assert b.getTreeDepth() == a.getTreeDepth() == 16
    assert b.calcNumNodes() == a.calcNumNodes() == b.size()
    assert b.memoryFullGrid() == a.memoryFullGrid()
    for p in xyz[::20000].astype(np.float64):
        ka, kb = a.coordToKey(p), b.coordToKey(p)
        assert list(kb) == [ka[0], ka[1], ka[2]]
        assert b.keyToCoord(kb).tolist() == list(a.keyToCoord(ka))
        na, nb = a.search(p), b.search(p)
        assert b.isNodeAtThreshold(nb) == a.isNodeAtThreshold(na)
    for t in (a, b):
        t.setProbHit(0.8)
        t.setProbMiss(0.45)
        t.setClampingThresMin(0.2)
        t.setClampingThresMax(0.9)
        t.setOccupancyThres(0.6)
    for name in ("getProbHit", "getProbMiss", "getClampingThresMin", "getClampingThresMax",
                 "getOccupancyThres", "getProbHitLog", "getClampingThresMaxLog"):
        assert getattr(b, name)() == pytest.approx(getattr(a, name)(), rel=1e-6)
    pts = xyz[3::5].astype(np.float64)
    for _ in range(2):
        a.insertPointCloud(pts, np.zeros(3))
        b.insertPointCloud(pts, np.zeros(3))
    assert b.write() == a.write()
    at = [b.isNodeAtThreshold(n) for n in b.begin_leafs()]
    assert any(at) and not all(at)
    assert at == [a.isNodeAtThreshold(n) for n in a.begin_leafs()]
    with pytest.raises(ValueError):
        b.setProbHit(0.3)


def test_set_resolution_matches(octomap, colored_base):
    """``setResolution`` keeps every node's key and value: the map scales about the centre of
    the key range, on the plain tree and the colour tree alike."""
    data, xyz = colored_base
    a, b = pair_from(octomap, data)
    pa, pb = octomap.OcTree(0.02), octoquant.OcTree(0.02)
    pts = xyz[::9].astype(np.float64)
    pa.insertPointCloud(pts, np.zeros(3))
    pb.insertPointCloud(pts, np.zeros(3))
    for ta, tb in ((a, b), (pa, pb)):
        ta.setResolution(0.05)
        tb.setResolution(0.05)
        assert tb.getResolution() == ta.getResolution() == 0.05
        assert tb.write() == ta.write()
        assert tb.getMetricMax().tolist() == pytest.approx(list(ta.getMetricMax()))
        # a leaf's centre, scaled with the map (a point of the scan now lies elsewhere)
        p = np.array(next(iter(tb.begin_leafs())).getCoordinate(), dtype=np.float64)
        ka = ta.coordToKey(p)  # (octomap-python's key has no end for list())
        assert list(tb.coordToKey(p)) == [ka[0], ka[1], ka[2]]
        assert tb.search(p).getValue() == ta.search(p).getValue()
        with pytest.raises(ValueError, match="setResolution"):
            tb.setResolution(0.0)
        assert tb.getResolution() == 0.05


def test_copies_and_pickles_keep_colours_and_the_sensor_model(colored_base):
    import copy
    import pickle

    data, xyz = colored_base
    b = octoquant.ColorOcTree.read(data)
    b.setProbHit(0.8)
    b.setClampingThresMin(0.2)
    for c in (pickle.loads(pickle.dumps(b)), copy.copy(b), copy.deepcopy(b)):
        assert c.write() == data
        assert (c.getProbHit(), c.getClampingThresMin()) == (b.getProbHit(), b.getClampingThresMin())
        p = xyz[0].astype(np.float64)
        c.setNodeColor(p, 1, 2, 3)
        assert b.search(p).getColor() != (1, 2, 3), "a copy is independent"
