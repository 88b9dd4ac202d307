"""Uniform refinement of subdivision-surface meshes (UsdGeom.Mesh ``subdivisionScheme``
catmullClark and bilinear), vectorised with numpy: every level is a handful of sorts and
``bincount`` sums over the corners, with no Python loop over vertices or faces.

The rules are OpenSubdiv's (Sdc) for the Catmark scheme, which USD, Hydra and Blender's
Subdivision Surface modifier all use:

* face point: the centroid of the face; edge point: (v0 + v1 + f0 + f1) / 4 for a smooth
  edge, the midpoint for a sharp one; vertex point: (Q + 2R + (n − 3)S) / n (Q the mean of
  the new face points around it, R the mean of its edges' midpoints, S the old point, n
  its valence) when smooth or a dart (at most one sharp edge), (a + 6S + b) / 8 on a crease
  (exactly two sharp edges, a and b their other ends), S at a corner (more than two sharp
  edges, a sharp vertex, or a non-manifold vertex).
* semi-sharp creases and corners use OpenSubdiv's default creasing method (Sdc
  ``CREASE_UNIFORM``, the "simple" rule; UsdGeom has no ``creaseMethod`` and PxOsd's
  default is uniform, not Chaikin): every level, each child edge and child vertex gets
  the parent's sharpness − 1 (not below 0; 10 and above is infinitely sharp and stays so).
  Where a rule changes between a parent and its child (a sharpness in (0, 1]), the two
  results are blended by that sharpness (for a vertex: the mean of its transitioning
  sharpnesses, at most 1) — Sdc's fractional weights.
* boundaries (``interpolateBoundary``): boundary and non-manifold edges are infinitely
  sharp; ``edgeAndCorner`` (USD's default) also makes a boundary vertex of a single face an
  infinitely sharp corner; ``edgeOnly`` does not; ``none`` keeps the positions of
  ``edgeOnly`` but, as OpenSubdiv, leaves out (as holes) the faces that touch the boundary.
* bilinear: every edge and vertex infinitely sharp (face centroids, edge midpoints, the
  old points).
* holes (``holeIndices``): refined with the rest (their neighbours see them) and left out.

Primvars: vertex data (``vertex``/``varying``) follows the vertex rules (as points);
face-varying data (``st``) per ``faceVaryingLinearInterpolation``: bilinear inside each
face for ``all``, else refined as a mesh of its own whose seams are boundaries
(:func:`_face_varying_mesh`).
"""

from __future__ import annotations

import numpy as np

#: OpenSubdiv's Sdc::Crease::SHARPNESS_INFINITE: this sharpness and above never decay.
INFINITE = 10.0
BOUNDARIES = ("edgeAndCorner", "edgeOnly", "none")
FACE_VARYING = ("none", "cornersOnly", "cornersPlus1", "cornersPlus2", "boundaries", "all")


def _child_sharpness(s: np.ndarray) -> np.ndarray:
    """CREASE_UNIFORM: s − 1 per level (not below 0); infinite stays infinite."""
    return np.where(s >= INFINITE, INFINITE, np.maximum(s - 1.0, 0.0))


def _sum_to(index: np.ndarray, values: np.ndarray, n: int) -> np.ndarray:
    """Rows of ``values`` summed into ``n`` rows by ``index`` (bincount per column)."""
    out = np.empty((n, values.shape[1]), np.float64)
    for k in range(values.shape[1]):
        out[:, k] = np.bincount(index, weights=values[:, k], minlength=n)
    return out


def _topology(counts: np.ndarray, idx: np.ndarray, n_points: int):
    """(face of each corner, the next corner in its face, the previous one, the edge of
    corner → next corner, the edges' two ends)."""
    n_faces, n_corners = len(counts), len(idx)
    first = np.cumsum(counts) - counts
    face_of_corner = np.repeat(np.arange(n_faces), counts)
    corner = np.arange(n_corners)
    pos = corner - first[face_of_corner]
    last = pos + 1 == counts[face_of_corner]
    nxt = np.where(last, first[face_of_corner], corner + 1)
    prev = np.where(pos == 0, first[face_of_corner] + counts[face_of_corner] - 1, corner - 1)
    a, b = idx, idx[nxt]
    keys = np.minimum(a, b) * n_points + np.maximum(a, b)
    unique, corner_edge = np.unique(keys, return_inverse=True)
    corner_edge = corner_edge.ravel()
    return face_of_corner, nxt, prev, corner_edge, unique // n_points, unique % n_points, unique


def _lookup(keys: np.ndarray, table_keys: np.ndarray, table_values: np.ndarray) -> np.ndarray:
    """table_values at keys (0 where a key is not in the sorted table)."""
    if len(table_keys) == 0:
        return np.zeros(len(keys))
    pos = np.clip(np.searchsorted(table_keys, keys), 0, len(table_keys) - 1)
    return np.where(table_keys[pos] == keys, table_values[pos], 0.0)


def _step(points, counts, idx, crease_keys, crease_values, vertex_sharpness, boundary, bilinear, face_varying):
    """One level. Returns (points, counts, idx, parent face of each new face, crease table,
    vertex sharpness, face-varying arrays) of the refined mesh."""
    n_points, n_faces, n_corners = len(points), len(counts), len(idx)
    face_of_corner, nxt, prev, corner_edge, e0, e1, edge_keys = _topology(counts, idx, n_points)
    n_edges = len(e0)
    faces_of_edge = np.bincount(corner_edge, minlength=n_edges)
    faces_of_vertex = np.bincount(idx, minlength=n_points)
    valence = np.bincount(e0, minlength=n_points) + np.bincount(e1, minlength=n_points)

    es = _lookup(edge_keys, crease_keys, crease_values)
    es[faces_of_edge != 2] = INFINITE  # boundary and non-manifold edges
    vs = np.asarray(vertex_sharpness, np.float64).copy()
    on_boundary = np.zeros(n_points, bool)
    open_edges = faces_of_edge < 2
    on_boundary[e0[open_edges]] = on_boundary[e1[open_edges]] = True
    if boundary == "edgeAndCorner":
        vs[on_boundary & (faces_of_vertex == 1)] = INFINITE
    vs[(faces_of_vertex != valence) & ~on_boundary] = INFINITE  # non-manifold vertices (e.g. bow ties)
    vs[on_boundary & (faces_of_vertex + 1 != valence)] = INFINITE  # non-manifold boundary vertices
    if bilinear:
        es[:] = INFINITE
        vs[:] = INFINITE

    # Face points.
    face_points = _sum_to(face_of_corner, points[idx], n_faces) / counts[:, None]
    # Edge points: smooth, sharp (midpoint), blended by a sharpness below 1.
    mid = 0.5 * (points[e0] + points[e1])
    around = _sum_to(corner_edge, face_points[face_of_corner], n_edges)
    smooth_edge = (points[e0] + points[e1] + around) / np.maximum(2 + faces_of_edge, 1)[:, None]
    w_edge = np.clip(es, 0.0, 1.0)[:, None]
    edge_points = np.where(es[:, None] >= 1.0, mid, smooth_edge * (1 - w_edge) + mid * w_edge)

    # Vertex points.
    n = np.maximum(valence, 1)[:, None].astype(np.float64)
    neighbours = _sum_to(np.concatenate([e0, e1]), np.concatenate([points[e1], points[e0]]), n_points)
    face_sum = _sum_to(idx, face_points[face_of_corner], n_points)
    smooth = points * (n - 2) / n + (neighbours + face_sum) / (n * n)

    def crease_and_rule(edge_sharp, vertex_sharp):
        sharp = edge_sharp > 0
        ends = np.concatenate([e0[sharp], e1[sharp]])
        others = np.concatenate([points[e1[sharp]], points[e0[sharp]]])
        count = np.bincount(ends, minlength=n_points)
        crease = (6 * points + _sum_to(ends, others, n_points)) / 8
        rule = np.where((vertex_sharp > 0) | (count > 2), 2, np.where(count == 2, 1, 0))
        return crease, rule

    crease_p, rule_p = crease_and_rule(es, vs)
    es_c, vs_c = _child_sharpness(es), _child_sharpness(vs)
    semi_sharp = np.any((es > 0) & (es < INFINITE)) or np.any((vs > 0) & (vs < INFINITE))
    # Without semi-sharp features the children keep their parents' rules: no blending.
    crease_c, rule_c = crease_and_rule(es_c, vs_c) if semi_sharp else (crease_p, rule_p)

    def apply(rule, crease):
        return np.where((rule == 2)[:, None], points, np.where((rule == 1)[:, None], crease, smooth))

    vertex_points = apply(rule_p, crease_p)
    blend = (rule_p != rule_c) & (rule_p != 0)
    if semi_sharp and np.any(blend):
        # Sdc's fractional weight: the mean of the sharpnesses that reach 0 this level.
        vt = (vs > 0) & (vs_c <= 0)
        et = (es > 0) & (es_c <= 0)
        ends = np.concatenate([e0[et], e1[et]])
        t_sum = np.where(vt, vs, 0.0) + np.bincount(ends, weights=np.concatenate([es[et], es[et]]), minlength=n_points)
        t_count = vt.astype(np.int64) + np.bincount(ends, minlength=n_points)
        w = np.minimum(t_sum / np.maximum(t_count, 1), 1.0)[:, None]
        child = apply(rule_c, crease_c)
        vertex_points = np.where(blend[:, None], w * vertex_points + (1 - w) * child, vertex_points)

    new_points = np.concatenate([vertex_points, edge_points, face_points])
    # Child quads: (v_i, e(i, i+1), face, e(i−1, i)) keep each face's winding.
    new_idx = np.stack([idx, n_points + corner_edge, n_points + n_edges + face_of_corner, n_points + corner_edge[prev]], axis=1).ravel()
    new_counts = np.full(n_corners, 4, np.int64)

    # Creases of the children: both halves of an edge still sharp.
    keep = (es_c > 0) & (faces_of_edge == 2)
    ke = np.nonzero(keep)[0]
    ep = n_points + ke
    n_new = len(new_points)
    child_keys = np.concatenate(
        [np.minimum(e0[ke], ep) * n_new + np.maximum(e0[ke], ep), np.minimum(e1[ke], ep) * n_new + np.maximum(e1[ke], ep)]
    )
    child_values = np.concatenate([es_c[ke], es_c[ke]])
    order = np.argsort(child_keys)
    new_vs = np.zeros(n_new)
    new_vs[:n_points] = _child_sharpness(np.asarray(vertex_sharpness, np.float64))

    fv_out = []
    for fv in face_varying:
        centre = _sum_to(face_of_corner, fv, n_faces) / counts[:, None]
        fv_out.append(np.stack([fv, 0.5 * (fv + fv[nxt]), centre[face_of_corner], 0.5 * (fv + fv[prev])], axis=1).reshape(-1, fv.shape[1]))
    return new_points, new_counts, new_idx, face_of_corner, (child_keys[order], child_values[order]), new_vs, fv_out


def refine(
    points,
    counts,
    indices,
    level: int,
    *,
    scheme: str = "catmullClark",
    boundary: str = "edgeAndCorner",
    crease_indices=None,
    crease_lengths=None,
    crease_sharpnesses=None,
    corner_indices=None,
    corner_sharpnesses=None,
    face_varying=(),
    face_varying_interpolation: str = "all",
) -> dict:
    """Refines a polygon mesh ``level`` times.

    ``points`` (V, k): the positions, optionally with vertex primvars as further columns
    (refined by the same rules); ``counts``/``indices``: faceVertexCounts/Indices (faces of
    fewer than 3 vertices must be removed first); ``face_varying``: arrays of one row per
    face-vertex, refined per ``face_varying_interpolation`` (USD's
    faceVaryingLinearInterpolation: "all" bilinear, else smooth, see
    :func:`_face_varying_mesh`). Returns ``points`` (V', k), ``counts`` (all 4),
    ``indices``, ``face`` (the control face each refined face comes from) and
    ``face_varying`` (one row per refined face-vertex; ``face_varying_mesh`` the same as
    (distinct values, value of each face-vertex) pairs). ValueError for malformed crease or
    corner data."""
    if scheme not in ("catmullClark", "bilinear"):
        raise ValueError(f"subdivision scheme '{scheme}' is not supported (catmullClark, bilinear)")
    if boundary not in BOUNDARIES:
        raise ValueError(f"interpolateBoundary '{boundary}' is not one of {', '.join(BOUNDARIES)}")
    if face_varying_interpolation not in FACE_VARYING:
        raise ValueError(f"faceVaryingLinearInterpolation '{face_varying_interpolation}' is not one of {', '.join(FACE_VARYING)}")
    pts = np.asarray(points, np.float64)
    pts = pts.reshape(len(pts), -1)
    counts = np.asarray(counts, np.int64)
    idx = np.asarray(indices, np.int64)
    n_points = len(pts)
    face = np.arange(len(counts))
    fv = [np.asarray(a, np.float64).reshape(len(idx), -1) for a in face_varying]

    # Creases: a run of L vertices is L − 1 edges; one sharpness per run or per edge.
    keys = np.zeros(0, np.int64)
    values = np.zeros(0)
    if crease_indices is not None and crease_lengths is not None and len(crease_lengths):
        ci = np.asarray(crease_indices, np.int64)
        cl = np.asarray(crease_lengths, np.int64)
        cs = np.asarray(crease_sharpnesses if crease_sharpnesses is not None else [], np.float64)
        if np.any(cl < 2) or int(cl.sum()) != len(ci):
            raise ValueError(f"creaseLengths (each at least 2) must add up to the {len(ci)} creaseIndices")
        if len(ci) and (ci.min() < 0 or ci.max() >= n_points):
            raise ValueError("creaseIndices out of range")
        n_edges = int((cl - 1).sum())
        if len(cs) == len(cl):
            cs = np.repeat(cs, cl - 1)
        elif len(cs) != n_edges:
            raise ValueError(f"creaseSharpnesses has {len(cs)} values; expected {len(cl)} (per crease) or {n_edges} (per edge)")
        start = np.cumsum(cl) - cl
        is_last = np.zeros(len(ci), bool)
        is_last[start + cl - 1] = True
        a = ci[:-1][~is_last[:-1]]
        b = ci[1:][~is_last[:-1]]
        k = np.minimum(a, b) * n_points + np.maximum(a, b)
        order = np.lexsort((-cs, k))  # the sharpest of repeated edges
        k, s = k[order], cs[order]
        first = np.concatenate([[True], k[1:] != k[:-1]]) if len(k) else np.zeros(0, bool)
        keys, values = k[first], np.maximum(s[first], 0.0)
    vs = np.zeros(n_points)
    if corner_indices is not None and len(corner_indices):
        ki = np.asarray(corner_indices, np.int64)
        ks = np.asarray(corner_sharpnesses if corner_sharpnesses is not None else [], np.float64)
        if len(ks) != len(ki):
            raise ValueError(f"cornerSharpnesses has {len(ks)} values for {len(ki)} cornerIndices")
        if ki.min() < 0 or ki.max() >= n_points:
            raise ValueError("cornerIndices out of range")
        np.maximum.at(vs, ki, np.maximum(ks, 0.0))

    bilinear = scheme == "bilinear"
    holes = np.zeros(len(counts), bool)
    if boundary == "none" and not bilinear and level > 0:
        _, _, _, corner_edge, e0, e1, _ = _topology(counts, idx, n_points)
        open_edges = np.bincount(corner_edge, minlength=len(e0)) < 2
        on_boundary = np.zeros(n_points, bool)
        on_boundary[e0[open_edges]] = on_boundary[e1[open_edges]] = True
        holes = np.bincount(np.repeat(np.arange(len(counts)), counts), weights=on_boundary[idx], minlength=len(counts)) > 0
    # Face-varying data: each array refined as a mesh of its own (its values welded per
    # vertex), so the refined corners come with their face-varying vertex.
    fv_mesh = []
    if level > 0:
        mode = "all" if bilinear else face_varying_interpolation
        fv_mesh = [_face_varying_mesh(a, counts, idx, keys, values, vs, boundary, mode, level) for a in fv]
    for _ in range(int(level)):
        pts, counts, idx, parent, (keys, values), vs, _ = _step(pts, counts, idx, keys, values, vs, boundary, bilinear, [])
        face = face[parent]
    if fv_mesh:
        fv = [v[i] for v, i in fv_mesh]
    return {
        "points": pts,
        "counts": counts,
        "indices": idx,
        "face": face,
        "face_varying": fv,
        "face_varying_mesh": fv_mesh,
        "boundary_holes": holes,
    }


def _face_varying_mesh(values, counts, idx, keys, sharpness, vs, boundary, mode, level):
    """Smooth refinement of face-varying data, OpenSubdiv's way: corners of a vertex with
    equal values are one face-varying vertex; where they differ (a seam) the values are on
    a face-varying boundary, whose edges are infinitely sharp. The data is then refined as
    a mesh of its own (faces = the mesh's faces, vertices = the distinct values) with the
    vertex rules, the mesh's creases and corners, and values pinned per ``mode``:
    ``none`` none (but the mesh's own pinned corners), ``cornersOnly`` a value of a single
    face, ``cornersPlus1`` also every value of a vertex where three or more regions meet,
    ``cornersPlus2`` also both values of a vertex of two whose one is a corner (the other a
    concave corner) and darts (a seam ending inside the mesh), ``boundaries`` every value
    on a face-varying boundary. Returns one row per refined
    face-vertex."""
    n_points = len(vs)
    rows = np.ascontiguousarray(
        np.concatenate(
            [idx.astype(np.int64)[:, None].view(np.int32).reshape(len(idx), 2), np.ascontiguousarray(values, np.float64).view(np.int32)],
            axis=1,
        )
    )
    first, fi = weld(rows)
    n_values = len(first)
    vertex_of = idx[first]
    face_of_corner, nxt, _, corner_edge, e0, e1, _ = _topology(counts, fi, n_values)
    # The mesh's creases on the face-varying edges.
    s_corner = _lookup(np.minimum(idx, idx[nxt]) * n_points + np.maximum(idx, idx[nxt]), keys, sharpness)
    sharp = np.nonzero(s_corner > 0)[0]
    f_vs = np.asarray(vs, np.float64)[vertex_of].copy()
    # Pins: the mesh's own corners (edgeAndCorner: a boundary vertex of a single face) and the mode's.
    faces_of_edge = np.bincount(corner_edge, minlength=len(e0))
    open_edges = faces_of_edge < 2
    on_fv_boundary = np.zeros(n_values, bool)
    on_fv_boundary[e0[open_edges]] = on_fv_boundary[e1[open_edges]] = True
    faces_of_value = np.bincount(fi, minlength=n_values)
    faces_of_vertex = np.bincount(idx, minlength=n_points)
    siblings = np.bincount(vertex_of, minlength=n_points)
    pin = np.zeros(n_values, bool)
    if boundary == "edgeAndCorner":
        pin |= faces_of_vertex[vertex_of] == 1
    if mode in ("cornersOnly", "cornersPlus1", "cornersPlus2"):
        pin |= on_fv_boundary & (faces_of_value == 1)
    if mode in ("cornersPlus1", "cornersPlus2"):
        pin |= siblings[vertex_of] >= 3
    if mode == "cornersPlus2":
        # A vertex of two values one of which is a corner (the other then a concave corner): both.
        corner = on_fv_boundary & (faces_of_value == 1)
        with_corner = np.bincount(vertex_of, weights=corner, minlength=n_points) > 0
        pin |= (siblings[vertex_of] == 2) & with_corner[vertex_of]
        # Darts: a seam ending inside the mesh (one value, on a face-varying boundary).
        _, _, _, m_edge, m0, m1, _ = _topology(counts, idx, n_points)
        m_open = np.bincount(m_edge, minlength=len(m0)) < 2
        on_mesh_boundary = np.zeros(n_points, bool)
        on_mesh_boundary[m0[m_open]] = on_mesh_boundary[m1[m_open]] = True
        pin |= on_fv_boundary & (siblings[vertex_of] == 1) & ~on_mesh_boundary[vertex_of]
    if mode == "boundaries":
        pin |= on_fv_boundary
    f_vs[pin] = INFINITE
    if mode == "all":  # bilinear inside each face: the bilinear scheme on the face-varying mesh
        r = refine(np.asarray(values, np.float64)[first], counts, fi, level, scheme="bilinear")
        return r["points"], r["indices"]
    r = refine(
        np.asarray(values, np.float64)[first],
        counts,
        fi,
        level,
        boundary="edgeOnly",
        crease_indices=np.stack([fi[sharp], fi[nxt[sharp]]], 1).ravel(),
        crease_lengths=np.full(len(sharp), 2),
        crease_sharpnesses=s_corner[sharp],
        corner_indices=np.arange(n_values)[f_vs > 0],
        corner_sharpnesses=f_vs[f_vs > 0],
    )
    return r["points"], r["indices"]


def smooth_normals(points: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """Unit vertex normals of a quad mesh (F, 4): the sum of its faces' area vectors."""
    p = np.asarray(points, np.float64)
    q = np.asarray(quads, np.int64).reshape(-1, 4)
    area = np.cross(p[q[:, 2]] - p[q[:, 0]], p[q[:, 3]] - p[q[:, 1]])
    n = sum(_sum_to(q[:, k], area, len(p)) for k in range(4))
    length = np.linalg.norm(n, axis=1, keepdims=True)
    return np.where(length > 0, n / np.maximum(length, 1e-300), np.array([0.0, 0.0, 1.0]))


def weld(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Groups equal rows of an int32 array (C, m): (first row of each group, in order of
    first appearance, and the group of every row). Rows are hashed to 64 bits and the
    groups checked row by row (an exact np.unique of the rows if a hash ever collides)."""
    rows = np.ascontiguousarray(rows, np.int32)
    h = np.full(len(rows), 0xCBF29CE484222325, np.uint64)
    with np.errstate(over="ignore"):
        for j in range(rows.shape[1]):
            h = (h ^ rows[:, j].astype(np.uint32).astype(np.uint64)) * np.uint64(0x100000001B3)
            h ^= h >> np.uint64(29)
    _, first, inverse = np.unique(h, return_index=True, return_inverse=True)
    inverse = inverse.ravel()
    if not np.array_equal(rows[first[inverse]], rows):
        row = rows.view(np.dtype((np.void, 4 * rows.shape[1]))).ravel()
        _, first, inverse = np.unique(row, return_index=True, return_inverse=True)
        inverse = inverse.ravel()
    order = np.argsort(first)  # groups in order of first appearance
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return first[order], rank[inverse]
