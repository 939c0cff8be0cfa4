"""Per-node surgery (expandNode, pruneNode, isNodeCollapsible, createNodeChild, getNodeChild,
deleteNodeChild) on octomap-python's and octoquant's trees: the same calls on the same nodes
leave the same trees (``.ot`` and ``.bt`` bytes, sizes, node values)."""

import numpy as np
import pytest

import octoquant


def same_bytes(a, b):
    assert b.size() == a.size()
    assert b.write() == a.write()


def trees(octomap, res=0.1):
    a, b = octomap.OcTree(res), octoquant.OcTree(res)
    rng = np.random.default_rng(5)
    pts = np.round(rng.uniform(-1, 1, size=(300, 3)), 1) + 0.05
    for p in pts:
        hit = bool(rng.integers(0, 2))
        a.updateNode(p, hit)
        b.updateNode(p, hit)
    return a, b, pts


def test_child_calls_on_one_parent(octomap):
    a, b, pts = trees(octomap)
    same_bytes(a, b)
    p = pts[0]
    na, nb = a.search(p, 15), b.search(p, 15)
    assert nb.getDepth() == 15 and nb.getValue() == na.getValue()
    exists = [na.childExists(i) for i in range(8)]
    assert [b.nodeChildExists(nb, i) for i in range(8)] == exists
    assert b.nodeHasChildren(nb) == na.hasChildren() is True
    assert b.isNodeCollapsible(nb) == a.isNodeCollapsible(na)
    for i in range(8):
        if exists[i]:
            assert b.getNodeChild(nb, i).getValue() == a.getNodeChild(na, i).getValue()
            a.deleteNodeChild(na, i)
            b.deleteNodeChild(nb, i)
            assert not b.nodeChildExists(nb, i)
            same_bytes(a, b)
        else:
            assert b.getNodeChild(nb, i) is None
        ca, cb = a.createNodeChild(na, i), b.createNodeChild(nb, i)
        assert cb.getValue() == ca.getValue() == 0.0
        assert cb.getDepth() == 16
        assert b.search(b.keyToCoord(cb.getKey())).getValue() == 0.0
    same_bytes(a, b)
    # all eight children are now leaves with log-odds 0: the parent is collapsible
    assert a.isNodeCollapsible(na) and b.isNodeCollapsible(nb)
    assert b.pruneNode(nb) == a.pruneNode(na) is True
    same_bytes(a, b)
    assert not b.nodeHasChildren(nb)
    assert b.pruneNode(nb) == a.pruneNode(na) is False
    b.expandNode(nb)
    a.expandNode(na)
    same_bytes(a, b)
    for i in (3, 5):
        b.deleteNodeChild(nb, i)
        a.deleteNodeChild(na, i)
        same_bytes(a, b)
    assert [b.nodeChildExists(nb, i) for i in range(8)] == [na.childExists(i) for i in range(8)]
    assert b.writeBinary() == a.writeBinary()
    same_bytes(a, b)


def test_expand_and_prune_pruned_leaves_of_scan_dat(octomap, scan_trees_small):
    """Expand every pruned leaf of a real map one node at a time, then prune them back."""
    a, b = scan_trees_small
    same_bytes(a, b)
    pruned = [
        (np.array(it.getCoordinate()), it.getDepth())
        for it in b.begin_leafs()
        if it.getDepth() < 16
    ][:300]
    assert len(pruned) > 50
    for coord, depth in pruned:
        na, nb = a.search(coord, depth), b.search(coord, depth)
        assert nb.getDepth() == depth and nb.getValue() == na.getValue()
        assert not b.nodeHasChildren(nb) and not na.hasChildren()
        a.expandNode(na)
        b.expandNode(nb)
    same_bytes(a, b)
    for coord, depth in pruned[::3]:
        na, nb = a.search(coord, depth), b.search(coord, depth)
        assert b.isNodeCollapsible(nb) == a.isNodeCollapsible(na) is True
        assert b.pruneNode(nb) == a.pruneNode(na) is True
    same_bytes(a, b)
    for coord, depth in pruned[1::3]:
        na, nb = a.search(coord, depth), b.search(coord, depth)
        a.deleteNodeChild(na, 6)
        b.deleteNodeChild(nb, 6)
        assert b.isNodeCollapsible(nb) == a.isNodeCollapsible(na) is False
    same_bytes(a, b)
    assert b.writeBinary() == a.writeBinary()


@pytest.fixture
def scan_trees_small(octomap, scan_dat):
    a, b = octomap.OcTree(0.2), octoquant.OcTree(0.2)
    pts = scan_dat[::4]
    origin = np.zeros(3)
    a.insertPointCloud(pts, origin, 6.0)
    b.insertPointCloud(pts, origin, 6.0)
    return a, b


def test_surgery_errors():
    t = octoquant.OcTree(0.1)
    with pytest.raises(octoquant.NullPointerException):
        t.expandNode(t.search([0, 0, 0]))
    t.updateNode([0.05, 0.05, 0.05], True)
    voxel = t.search([0.05, 0.05, 0.05])
    with pytest.raises(ValueError, match="voxel"):
        t.expandNode(voxel)
    with pytest.raises(ValueError, match="voxel"):
        t.createNodeChild(voxel, 0)
    assert t.getNodeChild(voxel, 0) is None
    parent = t.search([0.05, 0.05, 0.05], 15)
    with pytest.raises(ValueError, match="has children"):
        t.expandNode(parent)
    with pytest.raises(IndexError):
        t.getNodeChild(parent, 8)
    with pytest.raises(TypeError, match="OcTreeNode"):
        t.pruneNode([0, 0, 0])
    missing = [i for i in range(8) if not t.nodeChildExists(parent, i)][0]
    with pytest.raises(ValueError, match="does not exist"):
        t.deleteNodeChild(parent, missing)
    with pytest.raises(ValueError, match="exists already"):
        t.createNodeChild(parent, [i for i in range(8) if t.nodeChildExists(parent, i)][0])
    t.deleteNode([0.05, 0.05, 0.05], 0)
    with pytest.raises(ValueError, match="not in this tree"):
        t.pruneNode(voxel)
    root = t.getRoot()
    assert root is not None and root.getDepth() == 0
    assert not t.isNodeCollapsible(root)


def naive_expansion(tree):
    """The nodes OctoMap's expand() adds: a leaf at depth d becomes a full subtree down to
    depth 16, 8 + 8^2 + ... + 8^(16-d) = (8^(17-d) - 8) / 7 nodes."""
    return sum((8 ** (17 - it.getDepth()) - 8) // 7 for it in tree.begin_leafs())


def test_expand_spreads_leaves_and_refuses_past_its_limit(scan_trees_small):
    """expand() on a real map (octomap-python has no expand to compare with): every leaf
    becomes its voxels, each with the leaf's value, and the size grows by OctoMap's count;
    with a limit below that count it raises MemoryError and changes nothing."""
    _, b = scan_trees_small
    before, want = b.size(), naive_expansion(b)
    assert want > 0
    original = b.write()
    leaves = [(it.getDepth(), it.getValue()) for it in b.begin_leafs()]
    with pytest.raises(MemoryError, match=f"would add {want} nodes"):
        b.expand(max_nodes=want - 1)
    assert b.size() == before and b.write() == original
    b.expand(max_nodes=want)
    assert b.size() == before + want
    voxels = [(it.getDepth(), it.getValue()) for it in b.begin_leafs()]
    # pre-order: each old leaf's voxels come in its place, 8^(16-d) of them
    spread = [(16, v) for d, v in leaves for _ in range(8 ** (16 - d))]
    assert voxels == spread


@pytest.mark.parametrize("cls", ["OcTree", "ColorOcTree", "OcTreeStamped"])
def test_expand_of_a_childless_root_is_refused(cls):
    """A root left childless by a delete would expand into 8^16 voxels: MemoryError naming
    the count, before anything is allocated, whatever the tree type."""
    t = getattr(octoquant, cls)(0.1)
    t.updateNode([0.05, 0.05, 0.05], True)
    assert t.deleteNode([0.05, 0.05, 0.05], 1)
    assert t.size() == 1
    with pytest.raises(MemoryError, match=f"would add {(8**17 - 8) // 7} nodes"):
        t.expand()
    # a limit beyond what a tree can address (2^32 blocks of 8 nodes) is that bound
    with pytest.raises(MemoryError, match=f"limit of {2**35} nodes"):
        t.expand(max_nodes=10**15)
    assert t.size() == 1


@pytest.mark.parametrize("kind", ["OcTree", "ColorOcTree"])
def test_node_setters_write_through(octomap, kind):
    """``setValue``, ``setLogOdds`` and ``addValue`` on nodes in hand change the node in the
    tree as octomap-python's live nodes do (no clamping, no inner upkeep), at any depth;
    ``childExists`` answers for the tree as it is now."""
    a, b = getattr(octomap, kind)(0.1), getattr(octoquant, kind)(0.1)
    rng = np.random.default_rng(9)
    pts = np.round(rng.uniform(-1, 1, size=(400, 3)), 1) + 0.05
    for p in pts:
        hit = bool(rng.integers(0, 2))
        a.updateNode(p, hit)
        b.updateNode(p, hit)
    assert b.write() == a.write()
    changed = 0
    for i, p in enumerate(pts[::3]):
        depth = (16, 15, 14, 12, 0)[i % 5]
        na, nb = a.search(p, depth), b.search(p, depth)
        assert nb.getValue() == na.getValue()
        assert [nb.childExists(j) for j in range(8)] == [na.childExists(j) for j in range(8)]
        v = float(np.float32(rng.uniform(-6, 6)))  # beyond the clamps too
        op = i % 3
        if op == 0:
            na.setValue(v)
            nb.setValue(v)
        elif op == 1:
            na.setLogOdds(v)
            nb.setLogOdds(v)
        else:
            na.addValue(v)
            nb.addValue(v)
        assert nb.getValue() == pytest.approx(na.getValue(), abs=0)
        assert b.search(p, depth).getValue() == nb.getValue()
        changed += 1
    assert changed > 100
    assert b.write() == a.write()
    a.updateInnerOccupancy()
    b.updateInnerOccupancy()
    assert b.write() == a.write()
    n = b.search(pts[0])
    with pytest.raises(ValueError, match="setValue"):
        n.setValue(float("nan"))
    b.clear()
    with pytest.raises(ValueError, match="not in this tree"):
        n.setValue(1.0)
