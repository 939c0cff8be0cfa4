"""OcTree.merge against octomap-python: the same bytes as octomap's updateNode applied voxel by
voxel with each leaf of the other map's log-odds."""

import numpy as np
import pytest

import octoquant


def leaf_voxels(leaf):
    """The depth-16 keys a leaf covers (its key is the iterator's: min key + half its width)."""
    w = 1 << (16 - leaf.getDepth())
    k = leaf.getKey()
    lo = [k[i] - w // 2 if w > 1 else k[i] for i in range(3)]
    for x in range(lo[0], lo[0] + w):
        for y in range(lo[1], lo[1] + w):
            for z in range(lo[2], lo[2] + w):
                yield x, y, z


def test_merge_matches_octomap_update_node(octomap, scan_dat):
    # two parts of OctoMap's scan.dat mapped separately from two origins, 2 m range
    a = octoquant.OcTree(0.2)
    a.insertPointCloud(scan_dat[:44000:4], np.zeros(3), 2.0)
    b = octoquant.OcTree(0.2)
    b.insertPointCloud(scan_dat[44000::4], np.array([0.3, -0.2, 0.0]), 2.0)
    # and a block seen free twice, 8 voxels a side (aligned): pruned into one depth-13 leaf
    k0 = b.coordToKey(np.array([1.0, 1.0, 0.0]))
    base = [k0[i] & ~7 for i in range(3)]
    for _ in range(2):
        for dx in range(8):
            for dy in range(8):
                for dz in range(8):
                    b.updateNode(octoquant.OcTreeKey(base[0] + dx, base[1] + dy, base[2] + dz), False)
    assert any(leaf.getDepth() < 16 for leaf in b.begin_leafs()), "b has pruned leaves"

    ref = octomap.OcTree.read(a.write())
    voxels = 0
    for leaf in b.begin_leafs():
        v = leaf.getValue()
        for x, y, z in leaf_voxels(leaf):
            # by the voxel's centre (octomap-python's OcTreeKey(k0, k1, k2) ignores its arguments)
            centre = (np.array([x, y, z], dtype=np.float64) - 32768 + 0.5) * 0.2
            ref.updateNode(centre, float(v), False)
            voxels += 1

    stats = a.merge(b)
    assert stats["voxels"] == voxels
    assert stats["leaves"] == sum(1 for _ in b.begin_leafs())
    assert a.write() == ref.write()
    assert a.writeBinary() == ref.writeBinary()


def test_merge_refuses_a_resolution_mismatch_untouched():
    a = octoquant.OcTree(0.1)
    a.updateNode(np.array([0.5, 0.5, 0.5]), True)
    before = a.write()
    with pytest.raises(ValueError, match="resolution"):
        a.merge(octoquant.OcTree(0.2))
    assert a.write() == before


def test_merging_a_map_into_itself_doubles_its_evidence():
    a = octoquant.OcTree(0.1)
    p = np.array([0.5, 0.5, 0.5])
    a.updateNode(p, True)
    a.merge(a)
    assert a.search(p).getValue() == pytest.approx(2 * octoquant.OcTree(0.1).updateNode(p, True).getValue())
