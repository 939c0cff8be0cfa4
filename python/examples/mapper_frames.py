"""octoquant's own API: a Mapper fed with posed frames, then vectorised queries.

A sensor turns on the spot in a 6 x 4 x 2.5 m room; each frame's points are in the sensor
frame and its pose is (translation, quaternion x, y, z, w).
"""

import numpy as np

import octoquant


def frame_in_sensor(n, seed):
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d[:, 0] = np.abs(d[:, 0])  # a forward-looking sensor
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return d * 2.5


def main():
    mapper = octoquant.Mapper(resolution=0.05, mode="quantized", max_range=4.0)
    for i in range(8):
        yaw = i * np.pi / 4
        q = (0.0, 0.0, np.sin(yaw / 2), np.cos(yaw / 2))
        st = mapper.insert(frame_in_sensor(5000, i), pose=((0.0, 0.0, 0.0), q))
        print(f"frame {i}: {st['rays']} rays, {st['occupied']} occupied voxels, {st['seconds'] * 1e3:.1f} ms")
    tree = mapper.tree
    centres, sizes = tree.occupied_voxels()
    print(f"{len(centres)} occupied leaves, {sizes.sum():.1f} m of edges")
    probs = tree.occupancy(np.array([[0.0, 0.0, 0.0], centres[0], [9.0, 0.0, 0.0]]))
    print("occupancy at the origin, at an occupied voxel, far away:", probs)
    dirs = np.column_stack([np.cos(np.linspace(0, 2 * np.pi, 16)), np.sin(np.linspace(0, 2 * np.pi, 16)), np.zeros(16)])
    hits, ends = tree.cast_rays(np.zeros(3), dirs, ignore_unknown=True)
    print(f"{hits.sum()} of 16 horizontal rays hit; mean range {np.linalg.norm(ends[hits], axis=1).mean():.2f} m")
    leaves = tree.leaves(max_depth=14)
    print("leaves at depth <= 14:", len(leaves), "fields", leaves.dtype.names)


if __name__ == "__main__":
    main()
