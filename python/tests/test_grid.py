"""2D occupancy grids: ``OcTree.grid`` against octomap_server's projection written here in
Python over octomap-python's leaf iterator, and ``write_grid`` read back as Nav2 reads it."""

import numpy as np
import pytest

import octoquant


def octomap_server_projection(tree, zmin, zmax, depth=16):
    """octomap_server's projected map, written from its rule: every leaf whose z extent
    overlaps the band (``z + size/2 > zmin and z - size/2 < zmax``) marks the cells under it,
    occupied over free over unknown; cells of ``res * 2**(16 - depth)`` in OctoMap's key grid.
    Returns {(cell x, cell y): 100 or 0} and the cell size."""
    res = tree.getResolution()
    cell = res * 2 ** (16 - depth)
    marks = {}
    for leaf in tree.begin_leafs():
        x, y, z = leaf.getCoordinate()
        half = leaf.getSize() / 2
        if not (z + half > zmin and z - half < zmax):
            continue
        value = 100 if tree.isNodeOccupied(leaf) else 0
        # the leaf's first and last cell in each axis (key-grid aligned, so exact up to
        # floating point: take cell centres)
        first = [int(np.floor((c - half + res / 2) / cell)) for c in (x, y)]
        last = [int(np.floor((c + half - res / 2) / cell)) for c in (x, y)]
        for cx in range(first[0], last[0] + 1):
            for cy in range(first[1], last[1] + 1):
                marks[(cx, cy)] = max(marks.get((cx, cy), -1), value)
    return marks, cell


@pytest.mark.parametrize("depth", [16, 14])
def test_grid_matches_octomap_server(octomap, geb079, depth):
    ref = octomap.OcTree(str(geb079))
    tree = octoquant.OcTree(str(geb079))
    zmin, zmax = 0.2, 1.2
    cells, origin, resolution = tree.grid(zmin=zmin, zmax=zmax, depth=depth)
    marks, cell = octomap_server_projection(ref, zmin, zmax, depth)
    assert resolution == pytest.approx(cell)
    assert cells.dtype == np.int8 and cells.ndim == 2
    x0 = min(k[0] for k in marks)
    y0 = min(k[1] for k in marks)
    w = max(k[0] for k in marks) - x0 + 1
    h = max(k[1] for k in marks) - y0 + 1
    assert cells.shape == (h, w)
    assert origin == pytest.approx((x0 * cell, y0 * cell))
    want = np.full((h, w), -1, dtype=np.int8)
    for (cx, cy), v in marks.items():
        want[cy - y0, cx - x0] = v
    assert np.array_equal(cells, want)
    assert {-1, 0, 100} == set(np.unique(cells).tolist())
    # unknown="free" only turns unknown cells free
    free_cells, _, _ = tree.grid(zmin=zmin, zmax=zmax, depth=depth, unknown="free")
    assert np.array_equal(free_cells, np.where(want == -1, 0, want))


def test_write_grid_reads_back_as_nav2(geb079, tmp_path):
    tree = octoquant.OcTree(str(geb079))
    cells, origin, resolution = tree.grid(zmin=0.2, zmax=1.5)
    image = tree.write_grid(tmp_path / "floor.yaml", zmin=0.2, zmax=1.5)
    assert image == str(tmp_path / "floor.pgm")
    fields = dict(
        line.split(": ", 1) for line in (tmp_path / "floor.yaml").read_text().splitlines()
    )
    assert fields["image"] == "floor.pgm" and fields["mode"] == "trinary"
    assert float(fields["resolution"]) == resolution
    ox, oy, yaw = (float(v) for v in fields["origin"].strip("[]").split(","))
    assert (ox, oy, yaw) == (origin[0], origin[1], 0.0)
    data = (tmp_path / "floor.pgm").read_bytes()
    head = data.split(b"\n", 3)
    assert head[0] == b"P5" and head[2] == b"255"
    w, h = (int(v) for v in head[1].split())
    pixels = np.frombuffer(head[3], dtype=np.uint8).reshape(h, w)[::-1]
    occ = (255.0 - pixels) / 255.0
    nav2 = np.where(
        occ > float(fields["occupied_thresh"]),
        100,
        np.where(occ < float(fields["free_thresh"]), 0, -1),
    )
    assert np.array_equal(nav2, cells)


def test_grid_errors(geb079, tmp_path):
    tree = octoquant.OcTree(str(geb079))
    with pytest.raises(ValueError, match="depth"):
        tree.grid(depth=0)
    with pytest.raises(ValueError, match="unknown"):
        tree.grid(unknown="maybe")
    with pytest.raises(ValueError, match="no known voxel"):
        tree.grid(zmin=500.0)
    with pytest.raises(ValueError, match="empty"):
        tree.grid(zmin=1.0, zmax=0.5)
    with pytest.raises(ValueError, match=".yaml"):
        tree.write_grid(tmp_path / "floor.png")
    with pytest.raises(ValueError, match="no such directory"):
        tree.write_grid(tmp_path / "missing" / "floor.yaml")
