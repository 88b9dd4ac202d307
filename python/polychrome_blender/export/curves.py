"""Blender hair curves, particle hair and point clouds → triangle meshes (tubes and
spheres, ``polychrome.curves``), read as Cycles reads them (intern/cycles/blender/
curves.cpp and pointcloud.cpp): Catmull-Rom through the keys (straight segments for POLY
curves), radius 0.005 where a Curves object has no radius attribute and 0.01 for points,
the first material for all curves and points, particle hair from its render path cache
with Cycles' root/tip radius shape. docs/camera.md, "Hair, curves and point clouds"."""

import numpy as np
from polychrome import curves as pc_curves

from .meshes import MeshArrays

#: Tessellation: rings per key segment and sides per ring (docs/camera.md gives the
#: agreement with Cycles at these values).
SUBDIVISIONS = 4
SIDES = 8
SPHERE_LEVEL = 1

#: Blender's curve type codes (the ``curve_type`` attribute).
CURVE_TYPE_POLY = 1


def _attribute(data, name, domain, dtype, width, default=None):
    """The values of attribute ``name`` on ``domain`` as an (n, width) or (n,) array."""
    attr = data.attributes.get(name)
    if attr is None or attr.domain != domain:
        return default
    n = len(attr.data)
    key = "vector" if width == 3 else "value"
    buf = np.empty(n * width, dtype)
    attr.data.foreach_get(key, buf)
    return buf.reshape(n, width) if width > 1 else buf


def _arrays(t, slot):
    vertices, normals, uvs, triangles, _owner = t
    return MeshArrays(vertices, triangles, normals, uvs, np.full(len(triangles), slot, np.int32))


def _check_finite(name, what, values):
    if values is not None and not np.all(np.isfinite(values)):
        raise ValueError(f"object '{name}': a {what} is not finite")


def curves_arrays(ob, name, warnings):
    """A Curves (hair) object → :class:`MeshArrays` of tubes, or None without curves."""
    data = ob.data
    n_curves, n_points = len(data.curves), len(data.points)
    if n_curves == 0 or n_points == 0:
        return None
    positions = _attribute(data, "position", "POINT", np.float32, 3)
    _check_finite(name, "curve point", positions)
    radius = _attribute(data, "radius", "POINT", np.float32, 1, default=np.full(n_points, pc_curves.CURVE_RADIUS_DEFAULT, np.float32))
    _check_finite(name, "curve radius", radius)
    offsets = np.empty(n_curves + 1, np.int32)
    data.curve_offset_data.foreach_get("value", offsets)
    counts = np.diff(offsets)
    types = _attribute(data, "curve_type", "CURVE", np.int32, 1)
    linear = types is not None and len(types) > 0 and int(types[0]) == CURVE_TYPE_POLY  # Cycles: the first curve decides
    materials = _attribute(data, "material_index", "CURVE", np.int32, 1)
    if materials is not None and np.any(materials != 0):
        warnings.add(
            ("curves-materials", name), f"object '{name}': per-curve materials are not used (as in Cycles): every curve gets the first"
        )
    keep = counts >= 2
    if not np.all(keep):
        warnings.add(("curves-short", name), f"object '{name}': {int((~keep).sum())} curves with fewer than 2 points are skipped")
        mask = np.repeat(keep, counts)
        positions, radius, counts = positions[mask], radius[mask], counts[keep]
        if len(counts) == 0:
            return None
    t = pc_curves.curves_mesh(positions, np.maximum(radius, 0.0), counts, subdivisions=SUBDIVISIONS, sides=SIDES, linear=linear, name=name)
    return _arrays(t, 0)


def pointcloud_arrays(ob, name):
    """A point cloud object → :class:`MeshArrays` of spheres, or None without points."""
    data = ob.data
    n = len(data.points)
    if n == 0:
        return None
    positions = _attribute(data, "position", "POINT", np.float32, 3)
    _check_finite(name, "point", positions)
    radius = _attribute(data, "radius", "POINT", np.float32, 1, default=np.full(n, pc_curves.POINT_RADIUS_DEFAULT, np.float32))
    _check_finite(name, "point radius", radius)
    t = pc_curves.points_mesh(positions, np.maximum(radius, 0.0), level=SPHERE_LEVEL, name=name)
    return _arrays(t, 0)


def _shape_radius(shape, root, tip, time):
    """Cycles' ``shaperadius``: radius along a particle hair (time 0 at the root)."""
    r = 1.0 - time
    if shape < 0.0:
        r = r ** (1.0 + shape)
    elif shape > 0.0:
        r = r ** (1.0 / (1.0 - shape))
    return r * (root - tip) + tip


def hair_systems(ob):
    """The particle systems of ``ob`` that render as hair strands."""
    return [ps for ps in getattr(ob, "particle_systems", ()) if ps.settings.type == "HAIR" and ps.settings.render_type == "PATH"]


def particle_hair_arrays(ob, ps, name, render, warnings):
    """One hair particle system of evaluated object ``ob`` → :class:`MeshArrays` in
    object space, or None without strands. ``render``: the depsgraph is a final render
    one (render steps and every child; the viewport uses display steps and the display
    percentage of children, as Cycles)."""
    s = ps.settings
    steps = (1 << (s.render_step if render else s.display_step)) + 1
    if s.kink == "SPIRAL":
        steps += s.kink_extra_steps
    parents = len(ps.particles)
    children = len(ps.child_particles)
    if not render:
        children = int(children * s.display_percentage / 100.0)
    if s.child_type != "NONE" and children > 0:
        indices = range(parents, parents + children)
    else:
        indices = range(parents)
    n = len(indices)
    if n == 0:
        return None
    world = np.empty((n * steps, 3), np.float64)
    k = 0
    for i in indices:
        for step in range(steps):
            world[k] = ps.co_hair(ob, particle_no=i, step=step)
            k += 1
    _check_finite(name, f"hair key of '{ps.name}'", world)
    # co_hair gives world space; the mesh is placed with the object's transform.
    to_object = np.linalg.inv(np.array(ob.matrix_world, np.float64))
    keys = world @ to_object[:3, :3].T + to_object[:3, 3]
    keys = keys.reshape(n, steps, 3)
    seg = np.linalg.norm(np.diff(keys, axis=1), axis=2)
    along = np.concatenate([np.zeros((n, 1)), np.cumsum(seg, axis=1)], axis=1)
    length = along[:, -1:]
    time = np.divide(along, length, out=np.zeros_like(along), where=length > 0)
    half = s.radius_scale * 0.5
    radius = _shape_radius(s.shape, half * s.root_radius, half * s.tip_radius, time)
    if s.use_close_tip:
        radius[:, -1] = 0.0
    slots = max(len(ob.material_slots), 1)
    slot = min(max(s.material - 1, 0), slots - 1)
    t = pc_curves.curves_mesh(
        keys.reshape(-1, 3), radius.ravel(), np.full(n, steps), subdivisions=SUBDIVISIONS, sides=SIDES, name=f"{name}/{ps.name}"
    )
    return _arrays(t, slot)
