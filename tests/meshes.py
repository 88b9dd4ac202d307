"""Small meshes shared by the Python tests (vertices float32, triangles int)."""

from __future__ import annotations

import math

import numpy as np


def quad(a, b, c, d):
    """Two triangles over the corners a, b, c, d (in order)."""
    return np.array([a, b, c, d], dtype=np.float32), np.array([[0, 1, 2], [0, 2, 3]])


def square(half: float, z: float = 0.0):
    """A horizontal square of side 2·half at height z, facing +z."""
    return quad((-half, -half, z), (half, -half, z), (half, half, z), (-half, half, z))


def box(lo, hi):
    """An axis-aligned box between the corners lo and hi, wound outwards."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    v = np.array([[x, y, z] for z in (z0, z1) for y in (y0, y1) for x in (x0, x1)], dtype=np.float32)
    # Vertex index: x + 2y + 4z (0/1 each).
    faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    return v, np.array([t for a, b, c, d in faces for t in ([a, b, c], [a, c, d])])


def uv_sphere(center=(0.0, 0.0, 0.0), radius=1.0, rings=16, segments=32):
    """A latitude–longitude sphere with a seam column of duplicated vertices."""
    th = np.linspace(0, np.pi, rings + 1)[:, None]
    ph = np.linspace(0, 2 * np.pi, segments + 1)[None, :]
    v = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th) + 0 * ph], -1).reshape(-1, 3)
    v = v * radius + np.asarray(center)
    row = segments + 1
    a = (np.arange(rings)[:, None] * row + np.arange(segments)[None, :]).ravel()
    # Per quad, its two triangles in turn (the order the tests' seeds were drawn with).
    t = np.stack([np.stack([a, a + row, a + 1], 1), np.stack([a + 1, a + row, a + row + 1], 1)], 1)
    return v.astype(np.float32), t.reshape(-1, 3)


def pole_sphere(radius: float = 1.0, rings: int = 16, segments: int = 32) -> tuple[np.ndarray, np.ndarray]:
    """A sphere about the origin with one vertex at each pole (closed, no seam)."""
    v = [[0.0, 0.0, radius]]
    for i in range(1, rings):
        th = math.pi * i / rings
        for j in range(segments):
            ph = 2 * math.pi * j / segments
            v.append([radius * math.sin(th) * math.cos(ph), radius * math.sin(th) * math.sin(ph), radius * math.cos(th)])
    v.append([0.0, 0.0, -radius])
    t = [[0, 1 + j, 1 + (j + 1) % segments] for j in range(segments)]
    for i in range(rings - 2):
        for j in range(segments):
            a, b = 1 + i * segments + j, 1 + i * segments + (j + 1) % segments
            t += [[a, a + segments, b + segments], [a, b + segments, b]]
    last = len(v) - 1
    for j in range(segments):
        a, b = 1 + (rings - 2) * segments + j, 1 + (rings - 2) * segments + (j + 1) % segments
        t.append([a, last, b])
    return np.array(v, dtype=np.float32), np.array(t)
