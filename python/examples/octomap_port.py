"""An octomap-python script ported to octoquant by changing the import.

Builds a map of a simulated room scan, casts a ray, queries a few points, walks the leaves
and writes map.bt / map.ot (in the current directory, or the one given as argument).
"""

import sys
from pathlib import Path

import numpy as np

import octoquant as octomap  # was: import octomap


def room_scan(n=20000, seed=0):
    """End points on the walls of a 6 x 4 x 2.5 m room, seen from its centre."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    half = np.array([3.0, 2.0, 1.25])
    t = np.min(half / np.abs(d), axis=1)
    return d * t[:, None]


def main(out_dir):
    tree = octomap.OcTree(0.05)
    tree.insertPointCloud(room_scan(), np.array([0.0, 0.0, 0.0]), maxrange=-1.0)

    end = np.zeros(3)
    hit = tree.castRay(np.zeros(3), np.array([1.0, 0.0, 0.0]), end, ignoreUnknownCells=True)
    print("ray along +x:", "hit" if hit else "no hit", "at", end)

    for p in ([0.0, 0.0, 0.0], [3.01, 0.0, 0.0], [5.0, 0.0, 0.0]):
        node = tree.search(np.array(p))
        state = "unknown" if node is None else ("occupied" if tree.isNodeOccupied(node) else "free")
        print(f"{p}: {state}")

    occupied = sum(tree.isNodeOccupied(it) for it in tree.begin_leafs())
    print(f"{tree.getNumLeafNodes()} leaves, {occupied} occupied, {tree.size()} nodes")
    print("labels:", tree.getLabels(np.array([[0.0, 0.0, 0.0], [3.01, 0.0, 0.0], [9.0, 9, 9]])))

    out = Path(out_dir)
    tree.write(str(out / "map.ot"))
    tree.writeBinary(str(out / "map.bt"))
    print("wrote", out / "map.bt", "and", out / "map.ot")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else ".")
