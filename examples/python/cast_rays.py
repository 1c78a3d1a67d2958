#!/usr/bin/python3
"""splitray from Python: rays against a mesh (Open3D's conventions) and nearest neighbours
(scipy's), each checked against brute force. Run against the installed module or the build:

    PYTHONPATH=build/python /usr/bin/python3 examples/python/cast_rays.py data/horse/horse.obj.gz
"""

import sys

import numpy as np

import splitray


def main(path):
    vertices, triangles = splitray.load_mesh(path)
    scene = splitray.Scene(vertices, triangles, accel="bvh")
    lo, hi = vertices.min(0), vertices.max(0)
    x, y = np.meshgrid(np.linspace(lo[0], hi[0], 64), np.linspace(lo[1], hi[1], 64))
    rays = np.stack([x, y, np.full_like(x, hi[2] + 1), 0 * x, 0 * x, -np.ones_like(x)], -1)
    ans = scene.cast_rays(rays.astype(np.float32))  # (64, 64) answers
    brute = splitray.Scene(vertices, triangles, accel="brute").cast_rays(rays.astype(np.float32))
    hits = int(np.isfinite(ans["t_hit"]).sum())
    same = np.array_equal(ans["primitive_ids"], brute["primitive_ids"])
    print(f"{hits} of {ans['t_hit'].size} rays hit; same as brute force: {same}")

    tree = splitray.KDTree(vertices)
    d, i = tree.query(vertices[:100] + 1e-3, k=4, workers=-1)
    all_d = np.linalg.norm(vertices[None, :, :] - (vertices[:100] + 1e-3)[:, None, :], axis=-1)
    near = np.allclose(np.sort(all_d, axis=1)[:, :4], d, rtol=1e-5)
    print(f"4 nearest of 100 points: distances equal brute force: {near}")
    return 0 if same and near and hits > 0 else 1


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(f"usage: {sys.argv[0]} MESH")
    sys.exit(main(sys.argv[1]))
