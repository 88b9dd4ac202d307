"""Evaluated meshes → arrays for ``polychrome.Scene.add_mesh``, with numpy ``foreach_get``
only (no per-triangle Python loops). The core takes per-vertex normals and uvs, so
vertices are split where their corners disagree (sharp edges, UV seams)."""

from typing import NamedTuple

import numpy as np

#: Object types whose evaluated geometry is exported as a triangle mesh (hair curves as
#: tubes and point clouds as spheres: export/curves.py).
GEOMETRY_TYPES = ("MESH", "CURVE", "SURFACE", "META", "FONT", "CURVES", "POINTCLOUD")


class MeshArrays(NamedTuple):
    vertices: np.ndarray  # (V, 3) float32
    triangles: np.ndarray  # (T, 3) uint32
    normals: np.ndarray  # (V, 3) float32
    uvs: np.ndarray | None  # (V, 2) float32, from the active UV map
    tri_slot: np.ndarray  # (T,) material slot of each triangle
    source: np.ndarray | None = None  # (V,) the Blender vertex of each vertex (motion blur)


def _unique_rows(keys):
    """np.unique over the rows of a 2-D int32 array: (first index of each row, inverse)."""
    keys = np.ascontiguousarray(keys)
    row = keys.view(np.dtype((np.void, keys.dtype.itemsize * keys.shape[1]))).ravel()
    _, first, inverse = np.unique(row, return_index=True, return_inverse=True)
    return first, inverse.ravel()


def _corner_keys(cv, cn, uv, nv):
    """Merges corners with equal (vertex, normal, uv) into output vertices.

    Returns (first corner of each output vertex, output vertex of each corner). Fast path:
    a corner equal to its vertex's representative corner maps to that vertex; only the
    others (sharp edges, UV seams, flat faces) go through a sort."""
    cols = [np.ascontiguousarray(cn, np.float32).view(np.int32)]
    if uv is not None:
        cols.append(np.ascontiguousarray(uv, np.float32).view(np.int32))
    attrs = np.concatenate(cols, axis=1)
    nl = len(cv)
    rep = np.full(nv, -1, np.int64)
    rep[cv] = np.arange(nl)  # one corner per used vertex (the last one written)
    same = np.all(attrs == attrs[rep[cv]], axis=1)
    used = rep >= 0
    base_id = np.cumsum(used) - 1
    n_base = int(used.sum())
    out = np.empty(nl, np.int64)
    out[same] = base_id[cv[same]]
    first = rep[used]
    diff = np.nonzero(~same)[0]
    if diff.size:
        keys = np.concatenate([cv[diff].astype(np.int32)[:, None], attrs[diff]], axis=1)
        f, inv = _unique_rows(keys)
        out[diff] = n_base + inv
        first = np.concatenate([first, diff[f]])
    return first, out


def mesh_arrays(ob, name):
    """The :class:`MeshArrays` of an evaluated object, or None if it has no triangles."""
    me = ob.to_mesh()
    try:
        me.calc_loop_triangles()
        nv, nt, nl = len(me.vertices), len(me.loop_triangles), len(me.loops)
        if nt == 0:
            return None
        co = np.empty(nv * 3, np.float32)
        me.attributes["position"].data.foreach_get("vector", co)
        co = co.reshape(-1, 3)
        if not np.all(np.isfinite(co)):
            bad = int(np.argwhere(~np.isfinite(co).all(axis=1))[0][0])
            raise ValueError(f"object '{name}': vertex {bad} has a non-finite position")
        cv = np.empty(nl, np.int32)
        me.attributes[".corner_vert"].data.foreach_get("value", cv)
        tl = np.empty(nt * 3, np.int32)
        me.loop_triangles.foreach_get("loops", tl)
        tp = np.empty(nt, np.int32)
        me.loop_triangle_polygons.foreach_get("value", tp)
        pm = np.zeros(len(me.polygons), np.int32)
        if "material_index" in me.attributes:
            me.attributes["material_index"].data.foreach_get("value", pm)
        tri_slot = pm[tp]
        cn = np.empty(nl * 3, np.float32)
        me.corner_normals.foreach_get("vector", cn)
        cn = cn.reshape(-1, 3)
        cn[~np.isfinite(cn)] = 0.0
        uv = None
        if me.uv_layers.active is not None:
            uv = np.empty(nl * 2, np.float32)
            me.uv_layers.active.uv.foreach_get("vector", uv)
            uv = uv.reshape(-1, 2)
            uv[~np.isfinite(uv)] = 0.0
        first, inverse = _corner_keys(cv, cn, uv, nv)
        vertices = co[cv[first]]
        normals = cn[first]
        uvs = None if uv is None else uv[first]
        triangles = inverse[tl].reshape(-1, 3).astype(np.uint32)
        return MeshArrays(vertices, triangles, normals, uvs, tri_slot, cv[first])
    finally:
        ob.to_mesh_clear()


def read_mesh(ob, name, warnings):
    """:func:`mesh_arrays`, where an object that has no mesh to give (e.g. a curve without
    geometry) is skipped with a warning; a mesh object that cannot be read is an error."""
    from . import curves

    if ob.type == "CURVES":
        return curves.curves_arrays(ob, name, warnings)
    if ob.type == "POINTCLOUD":
        return curves.pointcloud_arrays(ob, name)
    try:
        return mesh_arrays(ob, name)
    except RuntimeError as e:
        if ob.type == "MESH":
            raise ValueError(f"object '{name}': cannot read its mesh ({e})") from e
        warnings.add(("mesh", name), f"object '{name}': skipped, its {ob.type.lower()} has no mesh ({e})")
        return None
