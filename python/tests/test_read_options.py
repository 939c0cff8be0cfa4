"""octoquant.read_frames' reader options (those of ``octoquant map``) on the shared data: each
option checked against a relation it must satisfy, not a hard-coded answer."""

import subprocess

import numpy as np
import pytest

import octoquant
from conftest import tum_depth_stamps

OUSTER_TOPIC = "/os1_cloud_node/points"


def need(path):
    if not path.exists():
        pytest.skip(f"{path} is missing")
    return path


def test_mcap_topic_and_fixed_frame(data_dir):
    bag = need(data_dir / "mcap" / "pointcloudset_ouster_os1" / "test.mcap")
    default = octoquant.read_frames(bag)
    named = octoquant.read_frames(bag, topic=OUSTER_TOPIC)
    assert len(default) == len(named) == 2
    assert [len(p) for p, _ in named] == [45716, 45809]
    for (p, o), (q, r) in zip(default, named):
        np.testing.assert_array_equal(p, q)
        np.testing.assert_array_equal(o, r)
    with pytest.raises(ValueError, match="/nope"):
        octoquant.read_frames(bag, topic="/nope")
    # in the lidar's own frame: origin at 0, and the sensor frame is the lidar frame turned
    # 180 degrees about z and lifted
    own = octoquant.read_frames(bag, topic=OUSTER_TOPIC, fixed_frame="os1_lidar")
    (a, ao), (b, _) = own[0], default[0]
    assert ao.tolist() == [0, 0, 0]
    np.testing.assert_allclose(b[:, :2], -a[:, :2], atol=1e-5)
    dz = b[:, 2] - a[:, 2]
    np.testing.assert_allclose(dz, np.full_like(dz, dz[0]), atol=1e-5)
    with pytest.raises(ValueError, match="nope_frame"):
        octoquant.read_frames(bag, fixed_frame="nope_frame")


def test_tum_pixel_step_and_depth_scale(data_dir):
    assoc = need(data_dir / "rgbd" / "tum_fr2_pioneer_slam2_subset" / "my_association.txt")
    full = octoquant.read_frames(assoc, format="tum")
    step2 = octoquant.read_frames(assoc, pixel_step=2)
    assert len(full) == len(step2) > 0
    (p1, o1), (p2, o2) = full[0], step2[0]
    np.testing.assert_array_equal(o1, o2)
    # every other pixel in u and v: about a quarter, all of them among the full frame's points
    assert 0.2 * len(p1) < len(p2) < 0.3 * len(p1)
    assert {tuple(r) for r in p2.tolist()} <= {tuple(r) for r in p1.tolist()}
    # twice the depth units per metre: every point halfway to the camera
    half = octoquant.read_frames(assoc, depth_scale=10000.0)
    (ph, oh) = half[0]
    np.testing.assert_array_equal(oh, o1)
    np.testing.assert_allclose(ph - oh, 0.5 * (p1 - o1), atol=2e-5)
    # doubled focal lengths halve the lateral offsets in the camera frame; depth is unchanged,
    # so the distance to the origin shrinks for every point off the optical axis
    narrow = octoquant.read_frames(assoc, intrinsics=(1050.0, 1050.0, 319.5, 239.5))[0][0]
    assert narrow.shape == p1.shape
    assert np.all(np.linalg.norm(narrow - o1, axis=1) <= np.linalg.norm(p1 - o1, axis=1) + 1e-4)
    for bad in (dict(pixel_step=0), dict(depth_scale=-1.0), dict(intrinsics=(0, 1, 0, 0))):
        with pytest.raises(ValueError):
            octoquant.read_frames(assoc, **bad)


def test_frame_stamps(data_dir):
    """``stamps=True`` appends each frame's time: a TUM depth image's name, a VTK sequence
    scan's time (its file name, cloud_<seconds>_<nanoseconds>.vtk, as the trajectory rows),
    an MCAP cloud's header stamp; None for a single PCD cloud. The points are those read
    without stamps."""
    assoc = need(data_dir / "rgbd" / "tum_fr2_pioneer_slam2_subset" / "my_association.txt")
    plain = octoquant.read_frames(assoc, pixel_step=8)
    stamped = octoquant.read_frames(assoc, pixel_step=8, stamps=True)
    names = tum_depth_stamps(assoc)
    assert [t for _, _, t in stamped] == names
    for (p, o), (q, r, _) in zip(plain, stamped):
        np.testing.assert_array_equal(p, q)
        np.testing.assert_array_equal(o, r)
    # with colours too: the colours third, the stamp last
    both = octoquant.read_frames(assoc, pixel_step=8, colors=True, stamps=True, count=2)
    assert [len(f) for f in both] == [4, 4]
    assert both[0][2].dtype == np.uint8 and both[0][2].shape == both[0][0].shape
    assert [f[3] for f in both] == names[:2]
    # a slice has its own frames' stamps
    part = octoquant.read_frames(assoc, pixel_step=8, first=3, count=2, stamps=True)
    assert [t for *_, t in part] == names[3:5]

    norlab = need(data_dir / "lidar3d" / "norlab_icp_mapper_example")
    scans = sorted((norlab / "scans").glob("*.vtk"))[:3]
    want = [int(f.stem.split("_")[1]) + int(f.stem.split("_")[2]) * 1e-9 for f in scans]
    got = [t for *_, t in octoquant.read_frames(norlab, count=3, stamps=True)]
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-6)

    bag = need(data_dir / "mcap" / "pointcloudset_ouster_os1" / "test.mcap")
    clouds = octoquant.read_frames(bag, stamps=True)
    times = [t for *_, t in clouds]
    # two clouds of a 10 Hz lidar, stamped in 2020 or later
    assert all(isinstance(t, float) and t > 1.5e9 for t in times), times
    assert 0.05 < times[1] - times[0] < 0.5, times

    table = "pcl_table_scene_mug_stereo_textured"
    pcd = need(data_dir / "pcd" / table / "table_scene_mug_stereo_textured.pcd")
    ((_, _, t),) = octoquant.read_frames(pcd, stamps=True)
    assert t is None


def test_saved_frames_keep_their_stamps(cli, tmp_path):
    """A ``.frames`` file keeps each frame's time: the simulated city LiDAR (10 Hz) stamps
    frame ``i`` at ``i / 10`` s, and reading the file back gives those times, after the same
    points as a read without stamps."""
    path = tmp_path / "city.frames"
    args = ["simulate", "--scene", "city", "--frames", "3", "--columns", "64", "-o", str(path)]
    subprocess.run([cli, *args], check=True, capture_output=True)
    stamped = octoquant.read_frames(path, stamps=True)
    assert [t for *_, t in stamped] == [i / 10.0 for i in range(3)]
    for (p, o), (q, r, _) in zip(octoquant.read_frames(path), stamped):
        np.testing.assert_array_equal(p, q)
        np.testing.assert_array_equal(o, r)
    # a slice has its own frames' stamps
    assert [t for *_, t in octoquant.read_frames(path, first=1, stamps=True)] == [0.1, 0.2]


def test_graph_points_global(data_dir):
    graph = need(data_dir / "octomap_reference" / "spherical_scan.graph")
    local = octoquant.read_frames(graph)
    glob = octoquant.read_frames(graph, points_global=True)
    assert len(local) == len(glob)
    for (pl, ol), (pg, og) in zip(local, glob):
        np.testing.assert_array_equal(ol, og)
        # the non-global points are the stored ones moved by a rigid pose: fit it (Kabsch)
        a = pg.astype(np.float64)
        b = pl.astype(np.float64)
        ca, cb = a.mean(axis=0), b.mean(axis=0)
        u, _, vt = np.linalg.svd((a - ca).T @ (b - cb))
        r = (u @ vt).T
        if np.linalg.det(r) < 0:
            vt[-1] *= -1
            r = (u @ vt).T
        np.testing.assert_allclose(a @ r.T + (cb - ca @ r.T), b, atol=1e-3)


def test_pcd_viewpoint(data_dir):
    pcd = need(
        data_dir / "pcd" / "pcl_table_scene_mug_stereo_textured" / "table_scene_mug_stereo_textured.pcd"
    )
    ((p, o),) = octoquant.read_frames(pcd)
    ((q, z),) = octoquant.read_frames(pcd, viewpoint="ignore")
    ((r, _),) = octoquant.read_frames(pcd, viewpoint="apply")
    assert z.tolist() == [0, 0, 0]
    # the default leaves the points as stored, like "ignore"; this file's VIEWPOINT is
    # 0 0 0 0 1 0 0 (translation 0, quaternion w x y z = 0 1 0 0: half a turn about x), so
    # applying it negates y and z
    np.testing.assert_array_equal(p, q)
    np.testing.assert_array_equal(r, p * np.array([1, -1, -1], dtype=np.float32))
    with pytest.raises(ValueError, match="viewpoint"):
        octoquant.read_frames(pcd, viewpoint="sideways")


def test_option_errors(tmp_path):
    txt = tmp_path / "pts.txt"
    txt.write_text("1 2 3\n")
    with pytest.raises(ValueError, match="pixel_step"):
        octoquant.read_frames(txt, pixel_step=0)
    with pytest.raises(TypeError):
        octoquant.read_frames(txt, "text", True)  # options are keyword-only
    ((p, _),) = octoquant.read_frames(txt, "text", topic="/ignored", points_global=True)
    assert p.tolist() == [[1, 2, 3]]
