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
