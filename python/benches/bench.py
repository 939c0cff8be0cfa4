"""Time octomap-python against octoquant on the same NumPy frames.

    python python/benches/bench.py [--data DIR] [--res 0.1] [--repeat 3]

(after ``pip install ./python``; it lives outside ``python/`` itself so that the installed
package, not its uncompiled source folder, is imported).

Inserts OctoMap's scan.dat (88206 points of a 3D laser scan, one frame) with
octomap-python's ``insertPointCloud`` and with octoquant (``OcTree.insertPointCloud`` on all
cores, ``Mapper`` in exact mode with one thread, and quantized mode against octomap-python's
``discretize=True``), and into a ``ColorOcTree`` with both (OctoMap's updates in its key sets'
order), into an empty one and, from another origin, into one whose leaves all have colours
of their own (where the order shows), checks that the ``.bt`` (colour tree: ``.ot``) bytes are identical, and prints the
median times and the ratios of one run.
"""

import argparse
import bz2
import os
import statistics
import time
from pathlib import Path

import numpy as np

import octoquant


def load_scan(data_dir):
    path = Path(data_dir) / "lidar3d" / "octomap_scan_dat" / "scan.dat.bz2"
    with bz2.open(path, "rt") as f:
        return np.loadtxt(f, dtype=np.float64)


def median_time(make, insert, repeat):
    times = []
    tree = None
    for _ in range(repeat):
        tree = make()
        start = time.perf_counter()
        insert(tree)
        times.append(time.perf_counter() - start)
    return statistics.median(times), tree


def main():
    here = Path(__file__).resolve().parent
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=os.environ.get("OCTOQUANT_DATA", here.parents[2] / "shared" / "data"))
    ap.add_argument("--res", type=float, default=0.1)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()

    import octomap

    pts = load_scan(args.data)
    origin = np.zeros(3)
    res = args.res
    print(f"scan.dat: {len(pts)} points, resolution {res} m, median of {args.repeat}, {os.cpu_count()} CPUs")

    rows = []

    def run(name, make, insert, reference=None):
        t, tree = median_time(make, insert, args.repeat)
        tree = tree.tree if isinstance(tree, octoquant.Mapper) else tree
        data = tree.write() if "ColorOcTree" in name else tree.writeBinary()
        kind = ".ot" if "ColorOcTree" in name else ".bt"
        same = "" if reference is None else (f"identical {kind}" if data == reference else f"DIFFERENT {kind}")
        rows.append((name, t, same))
        return t, data

    t_om, bt_om = run(
        "octomap-python insertPointCloud",
        lambda: octomap.OcTree(res),
        lambda t: t.insertPointCloud(pts, origin),
    )
    run(
        "octoquant OcTree.insertPointCloud (all cores)",
        lambda: octoquant.OcTree(res),
        lambda t: t.insertPointCloud(pts, origin),
        bt_om,
    )
    run(
        "octoquant Mapper exact, 1 thread",
        lambda: octoquant.Mapper(res, "exact", threads=1),
        lambda m: m.insert(pts, origin),
        bt_om,
    )
    t_omd, bt_omd = run(
        "octomap-python insertPointCloud(discretize=True)",
        lambda: octomap.OcTree(res),
        lambda t: t.insertPointCloud(pts, origin, discretize=True),
    )
    run(
        "octoquant Mapper quantized, 1 thread",
        lambda: octoquant.Mapper(res, "quantized", threads=1),
        lambda m: m.insert(pts, origin),
        bt_omd,
    )
    run(
        "octoquant Mapper quantized+bresenham, 1 thread",
        lambda: octoquant.Mapper(res, "quantized+bresenham", threads=1),
        lambda m: m.insert(pts, origin),
    )

    t_omc, ot_omc = run(
        "octomap-python ColorOcTree.insertPointCloud",
        lambda: octomap.ColorOcTree(res),
        lambda t: t.insertPointCloud(pts, origin),
    )
    run(
        "octoquant ColorOcTree.insertPointCloud (all cores)",
        lambda: octoquant.ColorOcTree(res),
        lambda t: t.insertPointCloud(pts, origin),
        ot_omc,
    )

    # a second scan, from another origin, into a tree whose leaves all have colours of their
    # own: prunes and re-expansions move colours, so OctoMap's order is followed where it shows
    base = octomap.ColorOcTree(res)
    base.insertPointCloud(pts, origin)
    for i, it in enumerate(base.begin_leafs()):
        base.setNodeColor(it.getCoordinate(), i % 251, (7 * i) % 253, (13 * i) % 255)
    colored = base.write()
    second = np.array([0.3, 0.2, 0.1])
    t_oms, ot_oms = run(
        "octomap-python ColorOcTree, 2nd scan, coloured tree",
        lambda: octomap.ColorOcTree.read(colored),
        lambda t: t.insertPointCloud(pts, second),
    )
    run(
        "octoquant ColorOcTree, 2nd scan, coloured tree",
        lambda: octoquant.ColorOcTree.read(colored),
        lambda t: t.insertPointCloud(pts, second),
        ot_oms,
    )

    width = max(len(r[0]) for r in rows)
    for name, t, same in rows:
        if "2nd scan" in name:
            base = t_oms
        elif "ColorOcTree" in name:
            base = t_omc
        elif "discretize" in name or "quantized" in name:
            base = t_omd
        else:
            base = t_om
        print(f"{name:<{width}}  {t * 1000:9.1f} ms  {base / t:6.1f}x  {same}")


if __name__ == "__main__":
    main()
