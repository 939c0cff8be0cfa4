"""Thin a dense cloud with octoquant.reduce, then find its horizontal surfaces with
octoquant.dbscan1d on the heights, and the walls of a 2D scan with octoquant.segment_scan.

A synthetic room: a floor at z = 0, a table top at z = 0.75 and a shelf at z = 1.6, sampled
far more densely near the sensor than far away (as a real scanner does).
"""

import numpy as np

import octoquant


def room(rng):
    parts = []
    for z, half, n in ((0.0, 3.0, 60000), (0.75, 0.6, 20000), (1.6, 0.4, 8000)):
        r = half * np.sqrt(rng.uniform(0, 1, n)) ** 2  # dense near the middle
        a = rng.uniform(0, 2 * np.pi, n)
        noise = rng.normal(0, 0.005, n)
        parts.append(np.column_stack([r * np.cos(a), r * np.sin(a), z + noise]))
    return np.vstack(parts)


def main():
    rng = np.random.default_rng(7)
    cloud = room(rng)
    kept, index = octoquant.reduce(cloud, 0.05, return_index=True)
    print(f"reduce: {len(cloud)} points -> {len(kept)} (cell 0.05 m)")
    assert np.array_equal(cloud[index], kept)

    # The same reduction online: insert in batches, take some points away, read a cycle.
    reducer = octoquant.DensityReducer((0.05, 0.05, 0.05))
    for batch in np.array_split(cloud, 4):
        reducer.insert(batch)
    reducer.remove(cloud[:1000])
    print(f"online reducer: {len(reducer)} cells, {len(reducer.output())} points after removing 1000")

    # Horizontal surfaces: clusters of the reduced points' heights.
    labels = octoquant.dbscan1d(kept[:, 2], eps=0.02, min_points=20)
    for c in range(labels.max() + 1):
        z = kept[labels == c, 2]
        print(f"surface {c}: z = {z.mean():.3f} m, {len(z)} points")
    print(f"noise: {(labels == -1).sum()} points")

    # Walls of a 2D scan of the room's corner, as octoquant segment finds them.
    wall_x = np.column_stack([np.full(40, 3.0), np.linspace(-1.0, 2.9, 40)])
    wall_y = np.column_stack([np.linspace(2.9, -1.0, 40), np.full(40, 2.0)])
    lines, on_line = octoquant.segment_scan(np.vstack([wall_x, wall_y]) + rng.normal(0, 0.003, (80, 2)))
    for line in lines:
        print(
            f"line: normal {np.degrees(line['normal_angle']):.1f} deg, distance {line['distance']:.2f} m, "
            f"{line['n_points']} points, length {line['length']:.2f} m"
        )


if __name__ == "__main__":
    main()
