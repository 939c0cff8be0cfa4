"""``write_frames``: frames from Python saved as ``.frames``, the CLI's lossless frame store.

Checked against the documented byte layout (built here with ``struct``, not by octoquant),
against ``read_frames`` on real TUM and norlab frames, and against ``octoquant map`` of the
original inputs.
"""

import math
import struct
import subprocess

import numpy as np
import pytest

import octoquant


def _layout(frames, version):
    """The .frames bytes of ``frames`` [(points, origin, colors or None, stamp or None)] as
    formats/src/frames.rs documents them: magic, u32 version, u32 count, then per frame f32
    origin, u32 n, (version 2: u32 flags, f64 stamp), n x f32 xyz, (n x u8 rgb)."""
    out = [b"OCTFRAME", struct.pack("<II", version, len(frames))]
    for points, origin, colors, stamp in frames:
        out.append(struct.pack("<fffI", *origin, len(points)))
        if version == 2:
            flags = (1 if stamp is not None else 0) | (2 if colors is not None else 0)
            out.append(struct.pack("<I", flags))
            if stamp is not None:
                out.append(struct.pack("<d", stamp))
        out.append(np.asarray(points, dtype="<f4").tobytes())
        if colors is not None:
            out.append(np.asarray(colors, dtype=np.uint8).tobytes())
    return b"".join(out)


def test_bytes_follow_the_documented_layout(tmp_path):
    pts = np.array([[1.5, -2.25, 3.0], [np.nan, 0.0, -0.0]], dtype=np.float32)
    plain = [(pts, np.array([0.1, 0.2, 0.3])), (pts[:0], (0, 0, 0))]
    path = tmp_path / "plain.frames"
    octoquant.write_frames(path, plain)
    want = _layout([(p, np.float32(o), None, None) for p, o in plain], 1)
    assert path.read_bytes() == want

    rgb = np.array([[255, 0, 7], [1, 2, 3]], dtype=np.uint8)
    extra = [(pts, (1.0, 2.0, 3.0), rgb, 12.5), (pts, (0.0, 0.0, 0.0), rgb, None)]
    path = tmp_path / "extra.frames"
    octoquant.write_frames(path, extra, colors=True, stamps=True)
    want = _layout([(p, o, c, t) for p, o, c, t in extra], 2)
    assert path.read_bytes() == want


def _same_frames(a, b):
    assert len(a) == len(b)
    for fa, fb in zip(a, b):
        assert len(fa) == len(fb)
        assert fa[0].dtype == fb[0].dtype == np.float32
        assert fa[0].tobytes() == fb[0].tobytes()
        assert fa[1].tobytes() == fb[1].tobytes()
        for xa, xb in zip(fa[2:], fb[2:]):
            if isinstance(xa, np.ndarray):
                assert xa.tobytes() == xb.tobytes()
            else:
                assert xa == xb


def test_real_frames_come_back_bit_for_bit(data_dir, tmp_path):
    tum = data_dir / "rgbd" / "tum_fr2_pioneer_slam2_subset" / "my_association.txt"
    frames = octoquant.read_frames(tum, count=3, colors=True, stamps=True)
    assert all(f[3] is not None for f in frames)
    path = tmp_path / "tum.frames"
    octoquant.write_frames(path, frames, colors=True, stamps=True)
    _same_frames(octoquant.read_frames(path, colors=True, stamps=True), frames)
    # the same frames without their extras, and the extras dropped on reading
    octoquant.write_frames(path, [f[:2] for f in frames])
    _same_frames(octoquant.read_frames(path), [f[:2] for f in frames])
    assert path.read_bytes()[8:12] == struct.pack("<I", 1)

    scans = data_dir / "lidar3d" / "norlab_icp_mapper_example"
    lidar = octoquant.read_frames(scans, count=2, stamps=True)
    path = tmp_path / "norlab.frames"
    octoquant.write_frames(path, lidar, stamps=True)
    _same_frames(octoquant.read_frames(path, stamps=True), lidar)


def test_float64_points_are_rounded_as_mapper_rounds_them(data_dir, tmp_path):
    scans = data_dir / "lidar3d" / "norlab_icp_mapper_example"
    (pts, origin), = octoquant.read_frames(scans, count=1)
    wide = pts.astype(np.float64) + 1e-9  # not exactly representable: rounding matters
    path = tmp_path / "wide.frames"
    octoquant.write_frames(path, [(wide, origin.astype(np.float64))])
    (back, back_origin), = octoquant.read_frames(path)
    assert back.tobytes() == wide.astype(np.float32).tobytes()
    assert back_origin.tobytes() == origin.tobytes()
    a = octoquant.Mapper(resolution=0.2)
    a.insert(wide, origin.astype(np.float64))
    b = octoquant.Mapper(resolution=0.2)
    b.insert_frames([(back, back_origin)])
    assert a.tree.to_bytes() == b.tree.to_bytes()


def test_the_cli_maps_written_frames_as_the_original_input(cli, data_dir, tmp_path):
    tum = data_dir / "rgbd" / "tum_fr2_pioneer_slam2_subset" / "my_association.txt"
    path = tmp_path / "tum.frames"
    octoquant.write_frames(path, octoquant.read_frames(tum))
    outs = []
    for src in (tum, path):
        out = tmp_path / f"{len(outs)}.bt"
        subprocess.run(
            [cli, "map", str(src), "--res", "0.05", "--mode", "quantized", "-o", str(out)],
            check=True,
            capture_output=True,
        )
        outs.append(out.read_bytes())
    assert outs[0] == outs[1]


@pytest.mark.parametrize(
    "frame, flags, message",
    [
        ((np.zeros((2, 3)),), {}, "frames[1]: a frame must have 2 items"),
        ((np.zeros((2, 3)), (0.0, math.nan, 0.0)), {}, "frames[1]: origin must be finite"),
        ((np.zeros((2, 2)), (0, 0, 0)), {}, "frames[1]: points must have shape (N, 3)"),
        (
            (np.zeros((2, 3)), (0, 0, 0), np.zeros((3, 3), np.uint8)),
            {"colors": True},
            "frames[1]: 3 colours for 2 points",
        ),
        (
            (np.zeros((2, 3)), (0, 0, 0), np.zeros((2, 3), np.float32)),
            {"colors": True},
            "frames[1]: colors must be an (N, 3) uint8 array",
        ),
        ((np.zeros((2, 3)), (0, 0, 0), math.inf), {"stamps": True}, "frames[1]: stamp must be finite"),
    ],
)
def test_a_bad_frame_writes_nothing(tmp_path, frame, flags, message):
    good = [np.ones((2, 3)), (0, 0, 0)]
    if flags.get("colors"):
        good.append(np.zeros((2, 3), np.uint8))
    if flags.get("stamps"):
        good.append(1.0)
    path = tmp_path / "bad.frames"
    with pytest.raises((ValueError, TypeError)) as err:
        octoquant.write_frames(path, [tuple(good), frame], **flags)
    assert message in str(err.value)
    assert not path.exists()
    assert list(tmp_path.iterdir()) == []


def test_io_errors_name_the_file(tmp_path):
    missing = tmp_path / "no" / "such" / "dir" / "x.frames"
    with pytest.raises(OSError) as err:
        octoquant.write_frames(missing, [(np.zeros((1, 3)), (0, 0, 0))])
    assert "x.frames" in str(err.value)
    # an existing file is replaced whole
    path = tmp_path / "x.frames"
    path.write_bytes(b"old")
    octoquant.write_frames(path, [])
    assert path.read_bytes() == b"OCTFRAME" + struct.pack("<II", 1, 0)
