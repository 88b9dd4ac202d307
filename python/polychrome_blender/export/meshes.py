"""Evaluated meshes → polychrome meshes, with numpy ``foreach_get`` only (no per-triangle
Python loops). The core takes per-vertex normals and uvs, so vertices are split where
their corners disagree (sharp edges, UV seams)."""

import numpy as np


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
    """Arrays of an evaluated mesh object: vertices, triangles, normals, uvs, slot per triangle."""
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
        return vertices, triangles, normals, uvs, tri_slot
    finally:
        ob.to_mesh_clear()


def export_meshes(pc, depsgraph, scene, material_for_slot, warnings):
    """Adds every visible mesh object (instances share one mesh) to ``scene``."""
    placed = {}
    count = 0
    for inst in depsgraph.object_instances:
        ob = inst.object
        if ob.type not in ("MESH", "CURVE", "SURFACE", "META", "FONT"):
            continue
        name = ob.original.name
        # Instances of one geometry share the evaluated data block; geometry-node instances
        # of different meshes share the instancer's name, so the data pointer is the key.
        data = getattr(ob, "data", None)
        key = (
            data.as_pointer() if data is not None else name,
            tuple(s.material.original.name if s.material else "" for s in ob.material_slots),
        )
        if key not in placed:
            try:
                arrays = mesh_arrays(ob, name)
            except RuntimeError as e:  # e.g. a curve with no geometry
                if ob.type == "MESH":
                    raise ValueError(f"object '{name}': cannot read its mesh ({e})") from e
                warnings.add(("mesh", name), f"object '{name}': skipped, its {ob.type.lower()} has no mesh ({e})")
                arrays = None
            if arrays is None:
                placed[key] = None
                continue
            vertices, triangles, normals, uvs, tri_slot = arrays
            slots = [material_for_slot(ob, s) for s in range(len(ob.material_slots))] or [material_for_slot(ob, None)]
            slot_map = np.asarray(slots, dtype=np.int64)
            ids = slot_map[np.clip(tri_slot, 0, len(slot_map) - 1)]
            placed[key] = scene.add_mesh(name, vertices, triangles, normals=normals, uvs=uvs, material_ids=ids, place=False)
        mesh = placed[key]
        if mesh is None:
            continue
        m = np.array(inst.matrix_world, dtype=np.float64)
        if not np.all(np.isfinite(m)):
            raise ValueError(f"object '{name}': its transform is not finite")
        scene.add_instance(mesh, m, name)
        count += 1
    return count
