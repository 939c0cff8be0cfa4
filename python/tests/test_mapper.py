"""octoquant.Mapper: the pipeline's modes against octomap-python and against OcTree."""

import numpy as np
import pytest

import octoquant


def frames(n=4, seed=3):
    rng = np.random.default_rng(seed)
    out = []
    for i in range(n):
        origin = rng.normal(0, 0.3, 3)
        pts = origin + rng.normal(0, 2.0, (3000, 3))
        out.append((pts, origin))
    return out


def test_modes_match_octomap(octomap, scan_dat):
    origin = np.zeros(3)
    ref = octomap.OcTree(0.2)
    ref.insertPointCloud(scan_dat, origin, 6.0)
    ref_disc = octomap.OcTree(0.2)
    ref_disc.insertPointCloud(scan_dat, origin, 6.0, False, True)
    for mode, expected in [("exact", ref), ("discretize", ref_disc), ("quantized", ref_disc)]:
        for threads in (None, 1, 2):
            m = octoquant.Mapper(0.2, mode, max_range=6.0, threads=threads)
            st = m.insert(scan_dat, origin)
            assert st["points"] == len(scan_dat)
            assert m.tree.write() == expected.write(), (mode, threads)


def test_simple_mode_matches_update_node_loop():
    rng = np.random.default_rng(1)
    pts = rng.normal(0, 1.0, (200, 3))
    m = octoquant.Mapper(0.1, "simple")
    m.insert(pts)
    assert m.tree.size() > 0
    assert m.mode == "simple"


def test_insert_frames_equals_insert_per_frame():
    fr = frames()
    a = octoquant.Mapper(0.1, "exact", threads=2, lazy=True)
    a.insert_frames(fr)
    b = octoquant.OcTree(0.1)
    for pts, origin in fr:
        b.insertPointCloud(pts, origin, lazy_eval=True)
    b.updateInnerOccupancy()
    assert a.tree.write() == b.write()
    c = octoquant.Mapper(0.1, "exact", threads=1)
    c.insert_frames(fr)
    d = octoquant.OcTree(0.1)
    for pts, origin in fr:
        d.insertPointCloud(pts, origin)
    assert c.tree.write() == d.write()
    assert a.stats()["frames"] == len(fr)


def test_pose_forms_agree():
    rng = np.random.default_rng(7)
    pts = rng.normal(0, 1.5, (2000, 3))
    yaw = 0.7
    q = (0.0, 0.0, np.sin(yaw / 2), np.cos(yaw / 2))
    t = (1.0, -2.0, 0.5)
    mat = np.eye(4)
    mat[:3, :3] = [[np.cos(yaw), -np.sin(yaw), 0], [np.sin(yaw), np.cos(yaw), 0], [0, 0, 1]]
    mat[:3, 3] = t
    a = octoquant.Mapper(0.1)
    a.insert(pts, pose=(t, q))
    b = octoquant.Mapper(0.1)
    b.insert(pts, pose=mat)
    ta, tb = a.tree, b.tree
    # the two rotations may differ in the last bit; the maps agree almost everywhere
    occ_a = {tuple(c) for c in ta.occupied_voxels()[0].round(6)}
    occ_b = {tuple(c) for c in tb.occupied_voxels()[0].round(6)}
    assert len(occ_a ^ occ_b) <= 0.01 * len(occ_a)
    world = pts @ mat[:3, :3].T + mat[:3, 3]
    c = octoquant.OcTree(0.1)
    c.insertPointCloud(world, t)
    assert len({tuple(x) for x in c.occupied_voxels()[0].round(6)} ^ occ_b) <= 0.01 * len(occ_b)


def test_mapper_arguments():
    with pytest.raises(ValueError, match="unknown mode"):
        octoquant.Mapper(0.1, "fast")
    with pytest.raises(ValueError):
        octoquant.Mapper(-1.0)
    with pytest.raises(ValueError):
        octoquant.Mapper(0.1, threads=0)
    with pytest.raises(ValueError):
        octoquant.Mapper(0.1, prob_hit=0.2)
    with pytest.raises(ValueError):
        octoquant.Mapper(0.1, reduce=-1.0)
    m = octoquant.Mapper(0.1, reduce=0.2)
    st = m.insert(np.random.default_rng(0).normal(0, 1, (1000, 3)))
    assert st["reduced"] < 1000
    with pytest.raises(ValueError, match="origin or pose"):
        m.insert(np.zeros((1, 3)), origin=np.zeros(3), pose=np.eye(4))
    with pytest.raises(ValueError, match="4x4"):
        m.insert(np.zeros((1, 3)), pose=np.eye(3))
    with pytest.raises(ValueError, match="quaternion"):
        m.insert(np.zeros((1, 3)), pose=((0, 0, 0), (0, 0, 0, 0)))
