"""Curves (hair, fur, grass) and point clouds as triangle meshes, tessellated by the core
(``rust/core/src/geometry/curves.rs``; docs/camera.md, "Hair, curves and point clouds").

Curves are interpolated as Cycles interpolates Blender's curves (Catmull-Rom through the
keys, or straight segments) and become tubes of ``sides`` sides, ``subdivisions`` rings
per key segment, whose mean projected width is the curve's diameter; points become
icospheres whose mean projected area is the sphere's.
"""

from __future__ import annotations

import numpy as np

from . import _core

#: Cycles' default radius of Blender curves without a radius attribute, and of points.
CURVE_RADIUS_DEFAULT = 0.005
POINT_RADIUS_DEFAULT = 0.01


def _rows3(values, what: str) -> np.ndarray:
    a = np.ascontiguousarray(values, dtype=np.float32)
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"{what} must have shape (N, 3), got {a.shape}")
    return a


def curves_mesh(keys, radii, counts, *, subdivisions: int = 4, sides: int = 8, linear: bool = False, name: str = "curves"):
    """Curves → (vertices, normals, uvs, triangles, curve of each triangle). ``keys``
    (K, 3), ``radii`` (K,) or one radius, ``counts`` keys per curve (each ≥ 2);
    ``linear``: straight segments (Blender's POLY curves) instead of Catmull-Rom."""
    k = _rows3(keys, f"curves '{name}': keys")
    r = np.ascontiguousarray(np.broadcast_to(np.asarray(radii, dtype=np.float32), (len(k),)))
    c = np.asarray(counts)
    if c.ndim != 1 or (c.size and not np.issubdtype(c.dtype, np.integer)) or (c.size and c.min() < 0):
        raise ValueError(f"curves '{name}': counts must be a 1-D array of non-negative integers")
    c = np.ascontiguousarray(c, dtype=np.uint32)
    if not (int(subdivisions) >= 1 and int(sides) >= 3):
        raise ValueError(f"curves '{name}': subdivisions must be ≥ 1 and sides ≥ 3")
    t = _core.tessellate_curves(name, k, r, c, int(subdivisions), int(sides), bool(linear))
    return t["vertices"], t["normals"], t["uvs"], t["triangles"], t["owner"]


def points_mesh(positions, radii, *, level: int = 1, name: str = "points"):
    """Points → spheres: (vertices, normals, uvs, triangles, point of each triangle);
    icospheres of ``level`` (1: 80 triangles each)."""
    p = _rows3(positions, f"point cloud '{name}': positions")
    r = np.ascontiguousarray(np.broadcast_to(np.asarray(radii, dtype=np.float32), (len(p),)))
    if not 0 <= int(level) <= 5:
        raise ValueError(f"point cloud '{name}': level must be 0…5")
    t = _core.tessellate_points(name, p, r, int(level))
    return t["vertices"], t["normals"], t["uvs"], t["triangles"], t["owner"]
