"""Evaluated meshes → arrays for ``polychrome.Scene.add_mesh``, with numpy ``foreach_get``
only (no per-triangle Python loops). The core takes per-vertex normals and uvs, so
vertices are split where their corners disagree (sharp edges, UV seams).

The default UV map is the one Blender renders with (``active_render``, as Cycles). What a
shading graph reads besides (docs/shading.md "Mesh data a graph reads": named UV maps,
colour attributes, generic attributes, MikkTSpace tangents) is exported only when a
material of the mesh asks for it (``needs``, from export/node_graph.py), per vertex like
the uvs, vertices being split where the corners of any of them differ."""

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
    data: dict | None = (
        None  # graph data: {"uv_maps": {name: (V,2)}, "colors": {name: (V,4)}, "attributes": {name: (V,k)}, "tangents": (V,4), "tangent_maps": {name: (V,4)}}
    )


def _key_words(cols):
    """The int32 columns of a row key as uint64 words whose lexicographic order is the
    byte order of the rows (what ``np.unique`` of the rows as void gives): each column
    byte-swapped, two to a word. 1-D words sort and gather far faster than 2-D rows."""
    be = [np.ascontiguousarray(c).byteswap().view(np.uint32).astype(np.uint64) for c in cols]
    if len(be) % 2:
        be.append(None)
    return [(hi << np.uint64(32)) | lo if lo is not None else hi << np.uint64(32) for hi, lo in zip(be[::2], be[1::2])]


def _unique_words(words):
    """``np.unique(rows, return_index=True, return_inverse=True)`` over rows given as
    :func:`_key_words`: (first index of each distinct row in sorted order, inverse).
    A stable sort on the first word (the vertex and one normal component: it ties on
    hardly any corners), then a lexicographic sort of the runs it ties."""
    n = len(words[0])
    perm = np.argsort(words[0], kind="stable")
    s0 = words[0][perm]
    new = np.empty(n, bool)
    new[:1] = True
    np.not_equal(s0[1:], s0[:-1], out=new[1:])
    tied = np.flatnonzero(~new[1:])  # sorted positions j, j + 1 with equal first words
    if len(words) > 1 and tied.size:
        pos = np.union1d(tied, tied + 1)
        idx = perm[pos]
        perm[pos] = idx[np.lexsort([w[idx] for w in words[:0:-1]] + [s0[pos]])]
        a, b = perm[tied], perm[tied + 1]
        differ = np.zeros(tied.size, bool)
        for w in words[1:]:
            differ |= w[a] != w[b]
        new[tied + 1] = differ
    inverse = np.empty(n, np.int64)
    inverse[perm] = np.cumsum(new) - 1
    return perm[new], inverse


def _int_columns(a, n):
    """The columns of a float32 corner array as int32 bit patterns (1-D views)."""
    a = np.ascontiguousarray(a, np.float32).reshape(n, -1).view(np.int32)
    return [a[:, j] for j in range(a.shape[1])]


def _corner_keys(cv, cn, uv, nv, extra=()):
    """Merges corners with equal (vertex, normal, uv and every ``extra`` corner array)
    into output vertices.

    Returns (first corner of each output vertex, output vertex of each corner). Fast path:
    a corner equal to its vertex's representative corner maps to that vertex; only the
    others (sharp edges, UV seams, flat faces) go through a sort, in the byte order of
    the rows (vertex, then the attribute bits), so the numbering is deterministic."""
    nl = len(cv)
    cols = [np.asarray(cv, np.int32)] + _int_columns(cn, nl)
    for a in (uv, *extra):
        if a is not None:
            cols += _int_columns(a, nl)
    words = _key_words(cols)  # the vertex is in the first word: equal words, equal vertex
    rep = np.full(nv, -1, np.int64)
    rep[cv] = np.arange(nl)  # one corner per used vertex (the last one written)
    rc = rep[cv]
    same = words[0] == words[0][rc]
    for w in words[1:]:
        same &= w == w[rc]
    used = rep >= 0
    base_id = np.cumsum(used) - 1
    n_base = int(np.count_nonzero(used))
    out = np.empty(nl, np.uint32)  # the triangles' dtype: Scene.add_mesh takes uint32
    out[same] = base_id[cv[same]]
    first = rep[used]
    diff = np.flatnonzero(~same)
    if diff.size:
        f, inv = _unique_words([w[diff] for w in words])
        out[diff] = n_base + inv
        first = np.concatenate([first, diff[f]])
    return first, out


def default_uv_layer(me):
    """The UV map Blender renders with (its ``active_render`` flag, as Cycles), else the active one."""
    return next((layer for layer in me.uv_layers if layer.active_render), None) or me.uv_layers.active


def _uv_corners(me, layer):
    uv = np.empty(len(me.loops) * 2, np.float32)
    layer.uv.foreach_get("vector", uv)
    uv = uv.reshape(-1, 2)
    uv[~np.isfinite(uv)] = 0.0
    return uv


#: Generic attribute types: (foreach_get field, components, numpy dtype of the buffer).
_ATTRIBUTE_FIELDS = {
    "FLOAT": ("value", 1, np.float32),
    "INT": ("value", 1, np.int32),
    "INT8": ("value", 1, np.int32),
    "BOOLEAN": ("value", 1, bool),
    "FLOAT2": ("vector", 2, np.float32),
    "INT32_2D": ("value", 2, np.int32),
    "FLOAT_VECTOR": ("vector", 3, np.float32),
    "FLOAT_COLOR": ("color", 4, np.float32),
    "BYTE_COLOR": ("color", 4, np.float32),  # 'color' is scene linear for bytes too
    "QUATERNION": ("value", 4, np.float32),
}


def _attribute_corners(me, attr, cv, corner_face):
    """A generic attribute as (corners, k) float32, or None for a domain/type the graph cannot read."""
    spec = _ATTRIBUTE_FIELDS.get(attr.data_type)
    if spec is None or attr.domain not in ("POINT", "CORNER", "FACE"):
        return None
    field, k, dtype = spec
    buf = np.empty(len(attr.data) * k, dtype)
    attr.data.foreach_get(field, buf)
    buf = buf.reshape(-1, k).astype(np.float32, copy=False)
    if attr.domain == "POINT":
        buf = np.take(buf, cv, axis=0)
    elif attr.domain == "FACE":
        buf = np.take(buf, corner_face, axis=0)
    buf[~np.isfinite(buf)] = 0.0
    return buf


def graph_corners(me, cv, needs, name, warnings):
    """The corner arrays of what ``needs`` asks for: {"uv_maps": {name: (L,2)}, "colors":
    {name: (L,4)}, "attributes": {name: (L,k)}, "tangents": (L,4) or None (the default UV
    map's), "tangent_maps": {UV map name: (L,4)}}. ``needs`` maps
    (kind, name) to who asks ("material 'M' node 'N'"); a missing name reads zero in
    Blender and gets one warning here."""
    out = {"uv_maps": {}, "colors": {}, "attributes": {}, "tangents": None, "tangent_maps": {}}
    nl = len(cv)
    corner_face = None
    if any(kind == "attribute" for kind, _ in needs):
        starts = np.empty(len(me.polygons), np.int32)
        me.polygons.foreach_get("loop_start", starts)
        sizes = np.empty(len(me.polygons), np.int32)
        me.polygons.foreach_get("loop_total", sizes)
        corner_face = np.repeat(np.arange(len(starts)), sizes)

    def missing(kind, what, key):
        warnings.add(
            ("missing", name, kind, key), f"object '{name}': {needs[(kind, key)]} reads {what} '{key}', which the mesh lacks (zero)"
        )

    for kind, key in sorted(needs):
        if kind == "uv" and key:
            layer = me.uv_layers.get(key)
            if layer is None:
                missing(kind, "UV map", key)
            else:
                out["uv_maps"][key] = _uv_corners(me, layer)
        elif kind == "color":
            ca = me.color_attributes
            cname = key or ca.default_color_name or ca.active_color_name
            attr = ca.get(cname) if cname else None
            if attr is None:
                if key:
                    missing(kind, "colour attribute", key)
                continue
            buf = np.empty(len(attr.data) * 4, np.float32)
            attr.data.foreach_get("color", buf)
            buf = buf.reshape(-1, 4)
            out["colors"][key] = np.take(buf, cv, axis=0) if attr.domain == "POINT" else buf
        elif kind == "attribute" and key:
            layer = me.uv_layers.get(key)
            if layer is not None:  # a UV map read by name: (u, v, 0), as Cycles
                uv = _uv_corners(me, layer)
                out["attributes"][key] = np.concatenate([uv, np.zeros((nl, 1), np.float32)], axis=1)
                continue
            attr = me.attributes.get(key)
            got = None if attr is None or key.startswith(".") else _attribute_corners(me, attr, cv, corner_face)
            if got is None:
                missing(kind, "attribute", key)
            else:
                out["attributes"][key] = (
                    got if got.shape[1] in (1, 3, 4) else np.concatenate([got, np.zeros((nl, 3 - got.shape[1]), np.float32)], axis=1)
                )
    # One tangent set per UV map a Normal Map or Tangent node names ("" = the default map).
    for uvname in sorted(key for kind, key in needs if kind == "tangent"):
        layer = me.uv_layers.get(uvname) if uvname else default_uv_layer(me)
        if layer is None:
            if uvname:
                missing("tangent", "UV map", uvname)
            continue
        try:
            me.calc_tangents(uvmap=layer.name)
        except RuntimeError as e:  # e.g. n-gons: MikkTSpace needs triangles and quads
            warnings.add(("tangents", name), f"object '{name}': no tangents for normal mapping ({e})")
            break
        t = np.empty(nl * 3, np.float32)
        me.loops.foreach_get("tangent", t)
        sign = np.empty(nl, np.float32)
        me.loops.foreach_get("bitangent_sign", sign)
        tan = np.concatenate([t.reshape(-1, 3), sign[:, None]], axis=1)
        tan[~np.isfinite(tan)] = 0.0
        if uvname:
            out["tangent_maps"][uvname] = tan
        else:
            out["tangents"] = tan
    return out


def _corner_arrays(corners):
    """The corner arrays of :func:`graph_corners` in a fixed order (for the split)."""
    arrays = [
        *corners["uv_maps"].values(),
        *corners["colors"].values(),
        *corners["attributes"].values(),
        *corners["tangent_maps"].values(),
    ]
    if corners["tangents"] is not None:
        arrays.append(corners["tangents"])
    return arrays


def mesh_arrays(ob, name, needs=None, warnings=None):
    """The :class:`MeshArrays` of an evaluated object, or None if it has no triangles.
    ``needs`` (see :func:`graph_corners`) adds the data shading graphs read."""
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
        default_uv = default_uv_layer(me)
        if default_uv is not None:
            uv = _uv_corners(me, default_uv)
        corners = graph_corners(me, cv, needs, name, warnings) if needs else None
        first, inverse = _corner_keys(cv, cn, uv, nv, _corner_arrays(corners) if corners else ())
        # np.take: row gathers of (n, k) arrays run several times faster than a[idx]
        source = cv[first]
        vertices = np.take(co, source, axis=0)
        normals = np.take(cn, first, axis=0)
        uvs = None if uv is None else np.take(uv, first, axis=0)
        triangles = inverse[tl].reshape(-1, 3)
        data = None
        if corners is not None:
            data = {
                k: {n: np.take(a, first, axis=0) for n, a in corners[k].items()}
                for k in ("uv_maps", "colors", "attributes", "tangent_maps")
            }
            data["tangents"] = None if corners["tangents"] is None else np.take(corners["tangents"], first, axis=0)
        return MeshArrays(vertices, triangles, normals, uvs, tri_slot, source, data)
    finally:
        ob.to_mesh_clear()


def read_mesh(ob, name, warnings, needs=None):
    """:func:`mesh_arrays`, where an object that has no mesh to give (e.g. a curve without
    geometry) is skipped with a warning; a mesh object that cannot be read is an error."""
    from . import curves

    if ob.type == "CURVES":
        return curves.curves_arrays(ob, name, warnings)
    if ob.type == "POINTCLOUD":
        return curves.pointcloud_arrays(ob, name)
    try:
        return mesh_arrays(ob, name, needs, warnings)
    except RuntimeError as e:
        if ob.type == "MESH":
            raise ValueError(f"object '{name}': cannot read its mesh ({e})") from e
        warnings.add(("mesh", name), f"object '{name}': skipped, its {ob.type.lower()} has no mesh ({e})")
        return None
