"""Sensor poses and batches on ``ColorMapper`` and ``StampedMapper``: ``insert(..., pose=...)``
and ``insert_frames``, on real frames.

A pose insertion must put exactly the world points ``Mapper.insert(points, pose=...)`` puts:
each sensor-frame point widened to float64, turned and moved by the pose, narrowed once to
float32, the sensor at the pose's translation. The reference here is NumPy's own float64
``R @ p + t`` narrowed to float32, inserted with ``origin=t`` (the rotation matrix built from
the quaternion in this file, not by octoquant). With ``crop_sensor`` the box is taken in the
pose's axes: the occupancy then equals the plain ``Mapper``'s with the same pose and box, and
the points dropped are those NumPy finds inside the box in the sensor frame.

Data: the TUM RGB-D frames (colours, time stamps), turned into a sensor frame of our own (a
rotation of about 100 degrees about a skewed axis), and the norlab LiDAR scans, which are
stored in the scanner's frame with their real 6-DoF poses in trajectory.csv.
"""

import csv
import math
import time

import numpy as np
import pytest

import octoquant
from conftest import _missing, tum_depth_stamps

TUM = "rgbd/tum_fr2_pioneer_slam2_subset/my_association.txt"
NORLAB = "lidar3d/norlab_icp_mapper_example"

# a sensor orientation far from the identity, (x, y, z, w), not normalised on purpose
Q = (0.3, -0.5, 0.4, 0.7)


def rotation(q):
    """The rotation matrix of quaternion (x, y, z, w), normalised first, in float64."""
    x, y, z, w = np.asarray(q, dtype=np.float64) / np.linalg.norm(np.asarray(q, dtype=np.float64))
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def matrix(t, q):
    """The 4x4 homogeneous matrix of translation t and quaternion q."""
    m = np.eye(4)
    m[:3, :3] = rotation(q)
    m[:3, 3] = t
    return m


def to_world(points, t, q):
    """Sensor-frame float32 points in the world: float64 ``R p + t``, narrowed once."""
    p = np.asarray(points, dtype=np.float32).astype(np.float64)
    return (p @ rotation(q).T + np.asarray(t, dtype=np.float64)).astype(np.float32)


def in_box(points, box):
    """Rows of float32 points inside the box (xmin, ymin, zmin, xmax, ymax, zmax), bounds
    included, compared in float64."""
    p = np.asarray(points, dtype=np.float32).astype(np.float64)
    box = np.asarray(box, dtype=np.float64)
    return ((p >= box[:3]) & (p <= box[3:])).all(axis=1)


def same_occupancy(a, b):
    """Asserts that trees a and b (any of OcTree, ColorOcTree, OcTreeStamped) store the same
    log-odds for every voxel, however differently pruned: each leaf of either has the value of
    the deepest node holding its key in the other, and no leaf of either lies in the other's
    unknown space. Returns the two leaf counts."""
    counts = []
    for x, y in ((a, b), (b, a)):
        n = 0
        for it in x.begin_leafs():
            node = y.search(it.getKey())
            assert node is not None, (tuple(it.getKey()), it.getDepth())
            assert node.getValue() == it.getValue(), (tuple(it.getKey()), it.getDepth())
            n += 1
        counts.append(n)
    return counts


def untimed(stats):
    """Statistics without the wall times."""
    return {k: v for k, v in stats.items() if "seconds" not in k}


@pytest.fixture(scope="module")
def tum(data_dir):
    """The TUM RGB-D frames (every 4th pixel): [(points, origin, colors, stamp), ...]."""
    assoc = data_dir / TUM
    if not assoc.is_file():
        _missing(str(assoc))
    frames = octoquant.read_frames(assoc, pixel_step=4, colors=True, stamps=True)
    assert len(frames) == 10
    assert [f[3] for f in frames] == tum_depth_stamps(assoc)
    return frames


@pytest.fixture(scope="module")
def tum_sensor(tum):
    """The TUM frames as a sensor turned by ``Q`` at each frame's origin sees them:
    [(sensor points float32, translation float64, colors), ...], the points
    ``R^T (p - o)`` in float64, stored float32."""
    r = rotation(Q)
    out = []
    for points, origin, colors, _ in tum:
        o = origin.astype(np.float64)
        local = ((points.astype(np.float64) - o) @ r).astype(np.float32)
        out.append((local, o, colors))
    return out


@pytest.fixture(scope="module")
def norlab(data_dir):
    """The first 4 norlab LiDAR scans by time, in the scanner's frame (``read_frames`` of each
    VTK file: origin 0), each with its pose T_map<-base_link from trajectory.csv (matched by
    the stamp in the file name, read as numbers: the nanoseconds are not zero-padded):
    [(points, translation, quaternion (x, y, z, w), stamp), ...]."""
    d = data_dir / NORLAB
    traj = d / "trajectory.csv"
    if not traj.is_file():
        _missing(str(traj))
    poses = {}
    with traj.open(newline="") as f:
        for row in csv.DictReader(f):
            key = (int(row["header.stamp.sec"]), int(row["header.stamp.nanosec"]))
            t = tuple(float(row[f"pose.pose.position.{a}"]) for a in "xyz")
            q = tuple(float(row[f"pose.pose.orientation.{a}"]) for a in "xyzw")
            poses[key] = (t, q)
    scans = []
    for path in (d / "scans").glob("*.vtk"):
        _, sec, nsec = path.stem.split("_")
        scans.append(((int(sec), int(nsec)), path))
    scans.sort()
    assert len(scans) == 14 and all(k in poses for k, _ in scans)
    out = []
    for (sec, nsec), path in scans[:4]:
        [(points, origin)] = octoquant.read_frames(path)
        assert not origin.any() and len(points) > 40000
        t, q = poses[(sec, nsec)]
        out.append((points, t, q, sec + nsec * 1e-9))
    # a real, non-trivial orientation: about -11 degrees of yaw and 2 of pitch
    assert abs(rotation(out[0][2])[0, 1]) > 0.15
    return out


# --- ColorMapper -------------------------------------------------------------------------------


def test_color_pose_equals_numpy_world_points(tum_sensor):
    """ColorMapper.insert(sensor points, colors, pose=(t, q)) and pose=4x4 write the .ot bytes
    of inserting NumPy's world points with origin=t, frame after frame; and the sensor frame
    is really turned (the points inserted as they are, from t, give another map)."""
    res = 0.05
    by_tq = octoquant.ColorMapper(res)
    by_matrix = octoquant.ColorMapper(res)
    world = octoquant.ColorMapper(res)
    unturned = octoquant.ColorMapper(res)
    for local, t, colors in tum_sensor:
        st = by_tq.insert(local, colors, pose=(t, Q))
        st_m = by_matrix.insert(local, colors, pose=matrix(t, Q))
        st_w = world.insert(to_world(local, t, Q), colors, origin=t)
        unturned.insert(local + t.astype(np.float32), colors, origin=t)
        assert untimed(st) == untimed(st_m) == untimed(st_w)
        assert st["points"] == len(local)
    want = world.tree.write()
    assert by_tq.tree.write() == want
    assert by_matrix.tree.write() == want
    assert unturned.tree.write() != want
    tree = by_tq.tree
    coloured = sum(1 for leaf in tree.begin_leafs() if tree.search(leaf.getKey()).isColorSet())
    assert by_tq.frames == 10 and coloured > 1000, coloured


def test_color_pose_crops_in_the_sensor_axes(tum_sensor):
    """With ``crop_sensor`` and a pose, ColorMapper drops the points NumPy finds inside the box
    in the sensor frame (not the box in the world's axes around the origin, which holds other
    points), and its occupancy is the plain Mapper's with the same pose and box, voxel for
    voxel."""
    res = 0.1
    box = (-1.5, -1.0, 0.5, -0.5, 1.0, 2.5)
    colored = octoquant.ColorMapper(res, crop_sensor=box)
    plain = octoquant.Mapper(res, crop_sensor=box)
    dropped = world_axes = 0
    for local, t, colors in tum_sensor:
        st = colored.insert(local, colors, pose=(t, Q))
        plain_st = plain.insert(local, pose=(t, Q))
        want = int(in_box(local, box).sum())
        assert st["dropped"]["crop_sensor"] == plain_st["dropped"]["crop_sensor"] == want
        dropped += want
        world_axes += int(in_box(to_world(local, t, Q) - t.astype(np.float32), box).sum())
    assert dropped > 10000 and world_axes < dropped / 2, (dropped, world_axes)
    leaves = same_occupancy(colored.tree, plain.tree)
    assert min(leaves) > 10000, leaves


def test_color_insert_frames_equals_insert_per_frame(tum):
    """ColorMapper.insert_frames over the TUM frames writes the .ot bytes of one insert per
    frame, with the same statistics; origin None is the world's origin, as in insert."""
    frames = [(points, colors, origin) for points, origin, colors, _ in tum]
    frames[3] = (frames[3][0], frames[3][1], None)
    one = octoquant.ColorMapper(0.05, merge="integrate")
    each = [untimed(one.insert(p, c, o)) for p, c, o in frames]
    batch = octoquant.ColorMapper(0.05, merge="integrate")
    stats = batch.insert_frames(frames)
    assert [untimed(s) for s in stats] == each
    assert batch.frames == one.frames == 10
    assert batch.tree.write() == one.tree.write()
    assert one.tree.size() > 10000


def test_color_insert_frames_refuses_a_bad_frame_and_changes_nothing(tum):
    """A bad frame in the middle of a batch raises, naming it, before any frame is inserted."""
    (p0, o0, c0, _), (p1, o1, c1, _), (p2, o2, c2, _) = tum[:3]
    m = octoquant.ColorMapper(0.1)
    m.insert(p0, c0, o0)
    before = m.tree.write()
    bad_batches = [
        (ValueError, r"^frames\[1\]: \d+ colours for \d+ points", (p1, c1[:-1], o1)),
        (ValueError, r"frames\[1\]: .*shape \(N, 3\)", (p1[:, :2], c1, o1)),
        (ValueError, r"frames\[1\]: .*uint8", (p1, c1.astype(np.float64), o1)),
        (ValueError, r"frames\[1\]: .*3 elements", (p1, c1, np.zeros(4))),
        (ValueError, r"frames\[1\]", (p1, c1)),
        (TypeError, r"frames\[1\]: .*float32 or float64", (p1.astype(np.int64), c1, o1)),
    ]
    for exc, msg, bad in bad_batches:
        with pytest.raises(exc, match=msg):
            m.insert_frames([(p2, c2, o2), bad, (p0, c0, o0)])
        assert m.frames == 1
        assert m.tree.write() == before


# --- StampedMapper -----------------------------------------------------------------------------


def test_stamped_pose_equals_numpy_world_points(norlab):
    """StampedMapper.insert(scan, pose=(t, q), stamp=s) and pose=4x4 on the norlab scans in
    their own frame, with their real poses, write the .ot bytes of inserting NumPy's world
    points with origin=t at the same times; the statistics tell the same second."""
    kw = dict(resolution=0.2, max_range=30.0)
    by_tq = octoquant.StampedMapper(**kw)
    by_matrix = octoquant.StampedMapper(**kw)
    world = octoquant.StampedMapper(**kw)
    unturned = octoquant.StampedMapper(**kw)
    for points, t, q, stamp in norlab:
        st = by_tq.insert(points, pose=(t, q), stamp=stamp)
        st_m = by_matrix.insert(points, stamp=stamp, pose=matrix(t, q))
        st_w = world.insert(to_world(points, t, q), t, stamp)
        unturned.insert(points + np.asarray(t, dtype=np.float32), t, stamp)
        assert untimed(st) == untimed(st_m) == untimed(st_w)
        assert st["stamp"] == math.floor(stamp)
    want = world.tree.write()
    assert by_tq.tree.write() == want
    assert by_matrix.tree.write() == want
    assert unturned.tree.write() != want
    assert by_tq.tree.getLastUpdateTime() == math.floor(norlab[-1][3])
    assert by_tq.tree.size() > 10000


def test_stamped_pose_crops_in_the_sensor_axes(norlab):
    """With ``crop_sensor`` (upstream's robot-body box, in the robot's frame) and the scans'
    poses, StampedMapper drops the points NumPy finds inside the box in the scanner's frame,
    not those inside the box in the world's axes, and its occupancy is the plain Mapper's with
    the same poses and box, voxel for voxel."""
    box = (-1.5, -1.0, -1.0, 0.5, 1.0, 0.5)
    kw = dict(max_range=30.0, crop_sensor=box)
    stamped = octoquant.StampedMapper(0.2, **kw)
    plain = octoquant.Mapper(0.2, **kw)
    # a box the yaw turns points into and out of: a 4 m strip ahead of the robot
    strip = (2.0, -0.3, -2.0, 6.0, 0.3, 2.0)
    strip_stamped = octoquant.StampedMapper(0.2, max_range=30.0, crop_sensor=strip)
    for points, t, q, stamp in norlab:
        st = stamped.insert(points, pose=(t, q), stamp=stamp)
        plain_st = plain.insert(points, pose=(t, q))
        want = int(in_box(points, box).sum())
        assert st["dropped"]["crop_sensor"] == plain_st["dropped"]["crop_sensor"] == want > 100
        st = strip_stamped.insert(points, pose=matrix(t, q), stamp=stamp)
        want = int(in_box(points, strip).sum())
        world_axes = int(in_box(to_world(points, t, q) - np.asarray(t, np.float32), strip).sum())
        assert st["dropped"]["crop_sensor"] == want > 100
        assert want != world_axes
    leaves = same_occupancy(stamped.tree, plain.tree)
    assert min(leaves) > 10000, leaves


def test_stamped_insert_frames_equals_insert_per_frame(tum):
    """StampedMapper.insert_frames over the TUM frames with their times writes the .ot bytes of
    one insert per frame, with the same statistics and stamps, also degrading (1 s threshold,
    the frames being 1-2 s apart)."""
    frames = [(points, origin, stamp) for points, origin, _, stamp in tum]
    for kw in ({}, {"degrade_older_than": 1}):
        one = octoquant.StampedMapper(0.1, **kw)
        each = [untimed(one.insert(p, o, s)) for p, o, s in frames]
        batch = octoquant.StampedMapper(0.1, **kw)
        stats = batch.insert_frames(frames)
        assert [untimed(s) for s in stats] == each
        assert [s["stamp"] for s in stats] == [math.floor(s) for _, _, s in frames]
        assert batch.frames == one.frames == 10
        assert batch.tree.write() == one.tree.write()
        assert batch.tree.getLastUpdateTime() == math.floor(frames[-1][2])
        assert one.tree.size() > 10000


def test_stamped_insert_frames_reads_the_clock_for_missing_stamps(tum):
    """A frame without a stamp (None) is stamped with the system clock when it goes in, and
    its statistics tell that second; a None origin is the world's origin."""
    (p0, o0, _, s0), (p1, _, _, _) = tum[:2]
    m = octoquant.StampedMapper(0.1)
    before = math.floor(time.time())
    stats = m.insert_frames([(p0, o0, s0), (p1, None, None)])
    after = math.floor(time.time())
    assert stats[0]["stamp"] == math.floor(s0)
    assert before <= stats[1]["stamp"] <= after
    assert m.tree.getLastUpdateTime() == stats[1]["stamp"]
    ref = octoquant.StampedMapper(0.1)
    ref.insert(p0, o0, s0)
    ref.insert(p1, np.zeros(3), stats[1]["stamp"])
    assert m.tree.write() == ref.tree.write()


def test_stamped_insert_frames_refuses_a_bad_frame_and_changes_nothing(tum):
    """A bad frame in the middle of a batch (a time OctoMap cannot store, bad points or
    origin) raises, naming it, before any frame is inserted."""
    (p0, o0, _, s0), (p1, o1, _, s1), (p2, o2, _, s2) = tum[:3]
    m = octoquant.StampedMapper(0.1)
    m.insert(p0, o0, s0)
    before = m.tree.write()
    bad_batches = [
        # named once, by its place in the list (the library's "frame N" becomes "frames[1]")
        (ValueError, r"^frames\[1\]: time stamp -1 s is not a time", (p1, o1, -1.0)),
        (ValueError, r"frames\[1\]: .*time stamp", (p1, o1, 2.0**32)),
        (ValueError, r"frames\[1\]: .*time stamp", (p1, o1, float("nan"))),
        (ValueError, r"frames\[1\]: .*shape \(N, 3\)", (p1[:, :2], o1, s1)),
        (ValueError, r"frames\[1\]: .*3 elements", (p1, np.zeros(2), s1)),
        (ValueError, r"frames\[1\]", (p1, o1)),
        (TypeError, r"frames\[1\]", (p1, o1, "noon")),
    ]
    for exc, msg, bad in bad_batches:
        with pytest.raises(exc, match=msg):
            m.insert_frames([(p2, o2, s2), bad, (p0, o0, None)])
        assert m.frames == 1
        assert m.tree.write() == before
        assert m.tree.getLastUpdateTime() == math.floor(s0)


# --- both --------------------------------------------------------------------------------------


def test_origin_and_pose_together_and_bad_poses_are_refused():
    """origin and pose together, or a pose that is not one, raise ValueError (Mapper's texts)
    and insert nothing."""
    pts = np.array([[1.0, 0.0, 0.0], [2.0, 0.5, 0.0]], dtype=np.float32)
    rgb = np.full((2, 3), 200, dtype=np.uint8)
    color = octoquant.ColorMapper(0.1)
    stamped = octoquant.StampedMapper(0.1)
    inserts = [
        lambda **kw: color.insert(pts, rgb, **kw),
        lambda **kw: stamped.insert(pts, stamp=100.0, **kw),
    ]
    for insert in inserts:
        with pytest.raises(ValueError, match="^give origin or pose, not both$"):
            insert(origin=np.zeros(3), pose=np.eye(4))
        with pytest.raises(ValueError, match="^give origin or pose, not both$"):
            insert(origin=(1.0, 2.0, 3.0), pose=((0, 0, 0), (0, 0, 0, 1)))
        with pytest.raises(ValueError, match="4x4"):
            insert(pose=np.eye(3))
        with pytest.raises(ValueError, match="4x4"):
            insert(pose=np.full((4, 4), np.nan))
        with pytest.raises(ValueError, match="quaternion"):
            insert(pose=((0, 0, 0), (0, 0, 0, 0)))
        with pytest.raises(ValueError, match="quaternion"):
            insert(pose=((0, 0, 0), (0, 0, 1)))
        with pytest.raises(ValueError, match="translation"):
            insert(pose=((0, 0), (0, 0, 0, 1)))
    with pytest.raises(ValueError, match="time stamp"):
        stamped.insert(pts, stamp=-5.0, pose=np.eye(4))
    with pytest.raises(ValueError, match="1 colours for 2 points"):
        color.insert(pts, rgb[:1], pose=np.eye(4))
    assert color.frames == 0 and color.tree.size() == 0
    assert stamped.frames == 0 and stamped.tree.size() == 0
    # the identity pose is the origin 0
    color.insert(pts, rgb, pose=np.eye(4))
    stamped.insert(pts, stamp=100.0, pose=((0, 0, 0), (0, 0, 0, 1)))
    ref_color = octoquant.ColorMapper(0.1)
    ref_color.insert(pts, rgb)
    ref_stamped = octoquant.StampedMapper(0.1)
    ref_stamped.insert(pts, stamp=100.0)
    assert color.tree.write() == ref_color.tree.write()
    assert stamped.tree.write() == ref_stamped.tree.write()
