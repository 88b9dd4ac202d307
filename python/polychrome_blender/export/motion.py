"""Motion blur as Cycles sets it up (``blender/sync.cpp`` ``sync_motion``,
``blender/object.cpp`` ``object_motion_steps``; read to learn the model, the code is our
own): the shutter spans ``motion_blur_shutter`` frames placed by ``motion_blur_position``
(START: opens on the frame, CENTER: centred on it, END: closes on it); an object with
Motion Steps s has 2^s + 1 keys evenly spaced over it (Cycles' ``(2 << (s - 1)) + 1``),
the camera 3. The scene is evaluated at each key time (``RenderEngine.frame_set``) and
the transforms of every instance, the vertices of deforming meshes and the camera are
kept; the core interpolates between keys at each path's time (docs/camera.md).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: The camera's keys (Cycles' camera motion: shutter open, centre, close).
CAMERA_KEYS = 3


def object_keys(ob) -> int:
    """Motion keys of an object (0: its motion blur is off), Cycles' rule."""
    cycles = getattr(ob.original, "cycles", None)
    if cycles is not None and not getattr(cycles, "use_motion_blur", True):
        return 0
    steps = max(1, int(getattr(cycles, "motion_steps", 1))) if cycles is not None else 1
    return (2 << (steps - 1)) + 1


def deforms(ob) -> bool:
    """Whether the object's mesh may change over the shutter (deformation motion on,
    and modifiers or shape keys that can move its vertices)."""
    cycles = getattr(ob.original, "cycles", None)
    if cycles is not None and not getattr(cycles, "use_deform_motion", True):
        return False
    orig = ob.original
    if orig.type != "MESH":
        return False
    return len(orig.modifiers) > 0 or (orig.data is not None and orig.data.shape_keys is not None)


def instance_key(inst) -> tuple:
    """Identifies an object instance across frames."""
    pid = tuple(inst.persistent_id) if inst.is_instance else ()
    return (inst.object.original.name, pid)


def _vertex_positions(ob) -> np.ndarray | None:
    try:
        me = ob.to_mesh()
    except RuntimeError:
        return None
    try:
        co = np.empty(len(me.vertices) * 3, np.float32)
        me.attributes["position"].data.foreach_get("vector", co)
        return co.reshape(-1, 3)
    finally:
        ob.to_mesh_clear()


@dataclass
class Motion:
    """What moves over the shutter: per instance its transforms at each key, per
    deforming object its vertex positions (before export/meshes.py splits vertices)."""

    keys: int = 0  # the most keys any object has (every object's keys are a subset)
    transforms: dict = field(default_factory=dict)  # instance key -> [4×4] * keys
    vertices: dict = field(default_factory=dict)  # object name -> [(V, 3)] * keys
    camera: list = field(default_factory=list)  # camera matrix_world at each key

    def instance_motion(self, inst) -> list | None:
        """An instance's transform keys (its own count), or None when it stands still."""
        ms = self.transforms.get(instance_key(inst))
        if ms is None:
            return None
        n = object_keys(inst.object)
        if n == 0:
            return None
        keys = ms[:: (self.keys - 1) // (n - 1)] if n <= self.keys else ms
        if all(np.allclose(keys[0], k, rtol=0, atol=1e-7) for k in keys[1:]):
            return None
        return keys

    def vertex_motion(self, ob, source: np.ndarray | None) -> list | None:
        """A deforming object's positions at its keys, for the exported vertices
        (``source``: the mesh vertex of each); None when it does not deform."""
        ms = self.vertices.get(ob.original.name)
        if ms is None or source is None:
            return None
        n = object_keys(ob)
        if n == 0 or any(m is None or len(m) != len(ms[0]) for m in ms):
            return None
        keys = ms[:: (self.keys - 1) // (n - 1)] if n <= self.keys else ms
        if all(np.array_equal(keys[0], k) for k in keys[1:]):
            return None
        return [k[source] for k in keys]


def shutter_offsets(scene, keys: int) -> list[float]:
    """Frame offsets of the keys from the current frame."""
    r = scene.render
    shutter = float(r.motion_blur_shutter)
    centre = {"START": 0.5 * shutter, "CENTER": 0.0, "END": -0.5 * shutter}[r.motion_blur_position]
    return [centre + (-1.0 + 2.0 * k / (keys - 1)) * 0.5 * shutter for k in range(keys)]


def shutter_curve(scene, samples: int = 32) -> list[float] | None:
    """Blender's shutter curve at evenly spaced times (None: flat, fully open)."""
    try:
        mapping = scene.render.motion_blur_shutter_curve
        mapping.initialize()
        curve = mapping.curves[0]
        values = [float(mapping.evaluate(curve, i / (samples - 1))) for i in range(samples)]
    except (AttributeError, RuntimeError, IndexError):
        return None
    if all(abs(v - values[0]) < 1e-6 for v in values):
        return None
    return [max(v, 0.0) for v in values]


def sample_motion(depsgraph, frame_set) -> Motion:
    """Evaluates the scene at every key time with ``frame_set(frame, subframe)`` (the
    render engine's) and returns to the current frame."""
    scene = depsgraph.scene
    keys = max([object_keys(inst.object) for inst in depsgraph.object_instances] + [CAMERA_KEYS])
    frame, subframe = scene.frame_current, float(scene.frame_subframe)
    motion = Motion(keys=keys)
    cam_ob = scene.camera
    try:
        for k, offset in enumerate(shutter_offsets(scene, keys)):
            t = frame + subframe + offset
            f = int(np.floor(t))
            frame_set(f, t - f)
            for inst in depsgraph.object_instances:
                motion.transforms.setdefault(instance_key(inst), [None] * keys)[k] = np.array(inst.matrix_world, np.float64)
                ob = inst.object
                if not inst.is_instance and deforms(ob):
                    motion.vertices.setdefault(ob.original.name, [None] * keys)[k] = _vertex_positions(ob)
            if cam_ob is not None:
                motion.camera.append(np.array(cam_ob.evaluated_get(depsgraph).matrix_world, np.float64))
    finally:
        frame_set(frame, subframe)
    # Instances seen at only some key times (appearing, disappearing) do not move.
    motion.transforms = {k: v for k, v in motion.transforms.items() if all(m is not None for m in v)}
    if len(motion.camera) == keys:
        step = (keys - 1) // (CAMERA_KEYS - 1)
        motion.camera = motion.camera[::step]
    else:
        motion.camera = []
    return motion
