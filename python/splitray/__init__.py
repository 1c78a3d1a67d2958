"""splitray: kd-trees, bounding interval hierarchies, BVHs and nearest-neighbour search.

Ray casting with the names and conventions of Open3D's ``RaycastingScene``::

    import numpy as np, splitray
    vertices, triangles = splitray.load_mesh("bunny.ply")
    scene = splitray.Scene(vertices, triangles, accel="bvh")
    ans = scene.cast_rays(rays)          # rays: (..., 6) float32 origins + directions
    ans["t_hit"], ans["primitive_ids"], ans["primitive_normals"]

Nearest neighbours with the names and conventions of scipy's ``cKDTree``::

    tree = splitray.KDTree(points)
    distances, indices = tree.query(queries, k=8, workers=-1)
"""

import errno as _errno
import os as _os

from . import _core
from ._core import Scene, accel_names, builder_names, neighbor_index_names
from ._kdtree import KDTree

__version__ = _core.__version__
__all__ = ["Scene", "KDTree", "load_mesh", "load_points", "accel_names", "builder_names",
           "neighbor_index_names", "__version__"]


def _existing_file(path, what):
    path = _os.fspath(path)
    if not isinstance(path, str):
        raise TypeError(f"{what}: expected a path (str or os.PathLike), got {type(path).__name__}")
    if not _os.path.exists(path):
        raise FileNotFoundError(_errno.ENOENT, f"{what}: no such file", path)
    if not _os.path.isfile(path):
        raise IsADirectoryError(_errno.EISDIR, f"{what}: not a regular file", path)
    return path


def load_mesh(path):
    """Loads a triangle mesh (OBJ, PLY, STL, OFF, glTF/GLB, COLLADA, MD2, ..., also .gz).

    Returns ``(vertices, triangles)``: a (V, 3) float32 array of positions and an (M, 3)
    uint32 array of vertex indices (polygons triangulated, node transforms applied), ready
    for :class:`Scene`. A malformed file raises ValueError naming the file and the problem.
    """
    return _core.load_mesh(_existing_file(path, "load_mesh"))


def load_points(path):
    """Loads a point set (PLY without faces, or XYZ text) as an (N, 3) float32 array."""
    return _core.load_points(_existing_file(path, "load_points"))
