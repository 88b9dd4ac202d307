"""The whole export — camera, meshes with their materials, lights, world — from Blender's
evaluated depsgraph to a :class:`polychrome.Scene`, by an :class:`Exporter` that keeps
what it exported.

The expensive parts (reading a mesh, converting an image, exporting a material) are kept
between exports; :meth:`Exporter.update` forgets those that ``depsgraph.updates`` says
changed, so the viewport re-exports after an edit only what the edit touched. Instance
transforms, lights, the world and the camera are cheap and read on every export. A
change Blender does not tag in the depsgraph (image pixels set from Python without
``Image.update_tag()``) is not seen until the viewport render starts again.

The scene is built in the same order whether parts come from the cache or not, so a
cached export and a fresh one give the same description (and the same pixels).
"""

from dataclasses import dataclass, field

import numpy as np
import polychrome as pc

from .camera import camera_matrix, export_camera
from .lights import export_lights
from .materials import MaterialExport
from .curves import hair_systems, particle_hair_arrays
from .meshes import GEOMETRY_TYPES, MeshArrays, read_mesh
from . import motion as motion_blur
from .textures import TextureCache
from .visibility import object_visibility
from .warnings import Warnings
from .world import export_world


@dataclass
class _Cached:
    """An exported part and the warnings its export gave."""

    value: object
    warnings: list = field(default_factory=list)
    needs: dict = field(default_factory=dict)  # mesh data its graph reads (export/node_graph.py)


@dataclass
class _CachedMesh:
    arrays: MeshArrays | None  # None: the object has no triangles
    warnings: list
    owners: set  # names of the objects whose instances used it
    data_names: set  # names of their original geometry data blocks
    hair: bool = False  # particle hair (forgotten when any particle settings change)


def _material_key(mat):
    return None if mat is None else mat.original.name


class Exporter:
    """Depsgraph → ``polychrome.Scene``, keeping the exported meshes (by evaluated
    geometry and material slots), materials (by material) and textures (by image).

    ``export(depsgraph)`` returns ``(scene, warning messages)``; every problem with user
    data raises ``ValueError`` naming the object. ``update(depsgraph)``, called where
    ``depsgraph.updates`` is valid (``RenderEngine.view_update``, depsgraph handlers),
    forgets what changed. ``counts`` says what the last export read afresh.
    """

    def __init__(self):
        self.textures = TextureCache()
        self._motion = None  # export/motion.py's Motion while exporting with motion blur
        self._meshes = {}  # (evaluated data pointer, material slot names) -> _CachedMesh
        self._materials = {}  # material name (None: no material) -> _Cached
        self.counts = {"meshes": 0, "materials": 0, "images": 0}

    # -- invalidation --------------------------------------------------------------
    def update(self, depsgraph):
        """Forgets the parts that ``depsgraph.updates`` reports changed."""
        for u in depsgraph.updates:
            kind, name = u.id.id_type, u.id.original.name
            if kind == "OBJECT" and u.is_updated_geometry:
                self._forget_meshes(lambda m, name=name: name in m.owners)
            elif kind in ("MESH", "CURVE", "CURVES", "POINTCLOUD", "META", "FONT") and u.is_updated_geometry:
                self._forget_meshes(lambda m, name=name: name in m.data_names)
            elif kind == "PARTICLE":
                self._forget_meshes(lambda m: m.hair)
            elif kind == "MATERIAL":
                self._materials.pop(name, None)
                self.textures.forget_used_by(("MATERIAL", name))  # it may be a reload of its image
            elif kind == "WORLD":
                self.textures.forget_used_by(("WORLD", name))
            elif kind == "IMAGE":
                for user_kind, user in self.textures.users_of(name):
                    if user_kind == "MATERIAL":
                        self._materials.pop(user, None)  # it holds the image's old texture
                self.textures.forget(name)
            elif kind == "NODETREE" and not u.id.is_embedded_data:
                self._materials.clear()  # a node group: any material may use it

    def _forget_meshes(self, matches):
        for key in [k for k, m in self._meshes.items() if matches(m)]:
            del self._meshes[key]

    def clear(self):
        self._meshes.clear()
        self._materials.clear()
        self.textures.clear()

    # -- export ------------------------------------------------------------------
    def export(self, depsgraph, camera=None, frame_set=None):
        """Returns ``(polychrome.Scene, [warning messages])``. ``camera`` (a
        ``polychrome.Camera``, e.g. the viewport's) replaces the scene camera.
        ``frame_set(frame, subframe)`` (``RenderEngine.frame_set``) lets the export
        evaluate the scene over the shutter for motion blur (export/motion.py)."""
        self.counts = {"meshes": 0, "materials": 0, "images": 0}
        self.textures.converted = 0
        warnings = Warnings()
        scene = pc.Scene()
        self._motion = None
        if depsgraph.scene.render.use_motion_blur:
            if frame_set is None:
                warnings.add(("motion blur",), "motion blur is rendered in final renders only: the viewport shows the current frame")
            else:
                self._motion = motion_blur.sample_motion(depsgraph, frame_set)
        scene.camera = export_camera(depsgraph, warnings) if camera is None else camera
        if self._motion is not None and camera is None:
            self._camera_motion(depsgraph, scene.camera)
        self._export_meshes(depsgraph, scene, warnings)
        export_lights(depsgraph, scene, warnings, self._motion)
        export_world(depsgraph, scene, warnings, self.textures)
        # Film > Transparent: the background leaves Combined's alpha 0 (holdouts always do).
        scene.film_transparent = bool(depsgraph.scene.render.film_transparent)
        self.counts["images"] = self.textures.converted
        return scene, warnings.messages

    def _camera_motion(self, depsgraph, cam):
        """The camera's keys and the shutter's shape (Cycles' shutter curve, rolling shutter)."""
        m = self._motion
        cam_ob = depsgraph.scene.camera
        if m.camera and motion_blur.object_keys(cam_ob) > 0:
            keys = [camera_matrix(k) for k in m.camera]
            if not all(np.allclose(keys[0], k, rtol=0, atol=1e-7) for k in keys[1:]):
                cam.motion = keys
        cam.shutter_curve = motion_blur.shutter_curve(depsgraph.scene)
        cycles = getattr(depsgraph.scene, "cycles", None)
        if cycles is not None and getattr(cycles, "rolling_shutter_type", "NONE") == "TOP":
            cam.rolling_shutter = True
            cam.rolling_shutter_duration = float(cycles.rolling_shutter_duration)

    def _cached_material(self, mat):
        key = _material_key(mat)
        cached = self._materials.get(key)
        if cached is None:
            own = Warnings()
            export = MaterialExport(mat, own, self.textures)
            cached = self._materials[key] = _Cached(export.material(), own.items, export.needs)
            self.counts["materials"] += 1
        return cached

    def _slot_material(self, ob, slot):
        if slot is not None and slot < len(ob.material_slots):
            return ob.material_slots[slot].material
        return None

    def _needs(self, ob):
        """What the graphs of ``ob``'s materials read from its mesh (export/node_graph.py)."""
        needs = {}
        for slot in range(len(ob.material_slots)):
            for k, who in self._cached_material(self._slot_material(ob, slot)).needs.items():
                needs.setdefault(k, who)
        return needs

    def _material(self, ob, slot, scene, indices, warnings):
        """Scene index of the material in ``ob``'s ``slot`` (None: no slot), exported
        once per Blender material."""
        mat = self._slot_material(ob, slot)
        key = _material_key(mat)
        if key not in indices:
            cached = self._cached_material(mat)
            warnings.extend(cached.warnings)
            indices[key] = scene.add_material(cached.value)
        return indices[key]

    def _mesh(self, ob, key, name, warnings, needs):
        """The cached mesh of ``key`` if ``ob`` used it in an earlier export, else read."""
        data_name = ob.original.data.name if ob.original.data is not None else None
        cached = self._meshes.get(key)
        if cached is None or name not in cached.owners:
            own = Warnings()
            cached = self._meshes[key] = _CachedMesh(read_mesh(ob, name, own, needs), own.items, {name}, {data_name})
            self.counts["meshes"] += 1
        warnings.extend(cached.warnings)
        return cached

    def _export_meshes(self, depsgraph, scene, warnings):
        """Adds every visible geometry object to ``scene``; instances of one evaluated
        geometry share one mesh."""
        placed = {}  # key -> mesh index in this scene (None: no triangles)
        materials = {}  # material key -> index in this scene
        used = set()
        for inst in depsgraph.object_instances:
            ob = inst.object
            if ob.type not in GEOMETRY_TYPES:
                continue
            name = ob.original.name
            if inst.show_particles and ob.type == "MESH":
                self._export_hair(depsgraph, inst, ob, name, scene, placed, materials, used, warnings)
            if not inst.show_self:  # an emitter whose particle settings hide it
                continue
            # Geometry-node instances of different meshes share the instancer's name, so
            # the evaluated data block is the key (with the materials it is shown with).
            needs = self._needs(ob) if ob.type == "MESH" else {}
            key = (
                ob.data.as_pointer(),
                tuple(s.material.original.name if s.material else "" for s in ob.material_slots),
                tuple(sorted(needs)),
            )
            if key not in placed:
                cached = self._mesh(ob, key, name, warnings, needs)
                used.add(key)
                placed[key] = None
                if cached.arrays is not None:
                    a = cached.arrays
                    slots = [self._material(ob, s, scene, materials, warnings) for s in range(len(ob.material_slots))]
                    slot_map = np.asarray(slots or [self._material(ob, None, scene, materials, warnings)], dtype=np.int64)
                    ids = slot_map[np.clip(a.tri_slot, 0, len(slot_map) - 1)]
                    deform = None
                    if self._motion is not None and not inst.is_instance:
                        deform = self._motion.vertex_motion(ob, a.source)
                    placed[key] = scene.add_mesh(
                        name,
                        a.vertices,
                        a.triangles,
                        normals=a.normals,
                        uvs=a.uvs,
                        material_ids=ids,
                        place=False,
                        motion_vertices=deform,
                        **graph_mesh_data(a.data),
                    )
            else:
                cached = self._meshes[key]
                cached.owners.add(name)  # another object showing the same evaluated geometry
                if ob.original.data is not None:
                    cached.data_names.add(ob.original.data.name)
            mesh = placed[key]
            if mesh is None:
                continue
            m = np.array(inst.matrix_world, dtype=np.float64)
            if not np.all(np.isfinite(m)):
                raise ValueError(f"object '{name}': its transform is not finite")
            moves = None if self._motion is None else self._motion.instance_motion(inst)
            # Object Info › Random: a Blender instance's random_id, as Cycles (an object's own
            # is the core's hash of its name, Cycles' for non-instances).
            rnd = (inst.random_id & 0xFFFFFFFF) / 0xFFFFFFFF if inst.is_instance else None
            vis = object_visibility(ob, name, warnings)
            scene.add_instance(mesh, m, name, motion=moves, visibility=vis, random=rnd, holdout=is_holdout(inst, depsgraph))
        # what no object shows any more (deleted, hidden, re-evaluated) is dropped
        self._meshes = {k: v for k, v in self._meshes.items() if k in used}
        self._materials = {k: v for k, v in self._materials.items() if k in materials}

    def _export_hair(self, depsgraph, inst, ob, name, scene, placed, materials, used, warnings):
        """The hair particle systems of a mesh object: one mesh of tubes each (in object
        space, shared by the object's instances), placed with the instance's transform."""
        for ps in hair_systems(ob):
            key = ("hair", name, ps.name)
            if key not in placed:
                cached = self._meshes.get(key)
                if cached is None:
                    own = Warnings()
                    arrays = particle_hair_arrays(ob, ps, name, depsgraph.mode == "RENDER", own)
                    cached = self._meshes[key] = _CachedMesh(arrays, own.items, {name}, set(), hair=True)
                    self.counts["meshes"] += 1
                warnings.extend(cached.warnings)
                used.add(key)
                placed[key] = None
                a = cached.arrays
                if a is not None:
                    slot = int(a.tri_slot[0]) if ob.material_slots and len(a.tri_slot) else None
                    ids = np.full(len(a.triangles), self._material(ob, slot, scene, materials, warnings), np.int64)
                    placed[key] = scene.add_mesh(
                        f"{name}/{ps.name}", a.vertices, a.triangles, normals=a.normals, uvs=a.uvs, material_ids=ids, place=False
                    )
            if placed[key] is not None:
                vis = object_visibility(ob, name, warnings)
                m = np.array(inst.matrix_world, dtype=np.float64)
                scene.add_instance(placed[key], m, f"{name}/{ps.name}", visibility=vis, holdout=is_holdout(inst, depsgraph))


def is_holdout(inst, depsgraph):
    """Cycles' object holdout (intern/cycles/blender/object.cpp: ``b_parent.holdout_get``
    in the view layer, the instancer for an instance): Object › Visibility › Holdout or a
    holdout collection of the view layer."""
    parent = inst.parent if inst.is_instance and inst.parent is not None else inst.object
    try:
        return bool(parent.original.holdout_get(view_layer=depsgraph.view_layer))
    except (AttributeError, TypeError, RuntimeError):
        return bool(getattr(parent.original, "is_holdout", False))


def graph_mesh_data(data):
    """``Scene.add_mesh`` keyword arguments for the graph data of :class:`MeshArrays`."""
    if not data:
        return {}
    kw = {k: data[k] for k in ("uv_maps", "colors", "attributes") if data[k]}
    if data.get("tangents") is not None:
        kw["tangents"] = data["tangents"]
    if data.get("tangent_maps"):
        kw["tangent_maps"] = data["tangent_maps"]
    return kw


def export_scene(depsgraph, camera=None, frame_set=None):
    """A one-off export (final renders, scripts): ``Exporter().export(depsgraph, camera, frame_set)``."""
    return Exporter().export(depsgraph, camera, frame_set)
