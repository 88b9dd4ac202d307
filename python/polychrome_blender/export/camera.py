"""Blender camera → polychrome.Camera (perspective/orthographic, lens, sensor, shift, clip)."""

import numpy as np
import polychrome as pc


def render_size(scene):
    """Output size in pixels: resolution times percentage, as Blender computes it."""
    r = scene.render
    s = r.resolution_percentage / 100.0
    return max(1, int(r.resolution_x * s)), max(1, int(r.resolution_y * s))


def camera_matrix(matrix_world):
    """Camera → world without scale (Blender ignores camera object scale for rays)."""
    m = np.array(matrix_world, dtype=np.float64)
    for k in range(3):
        n = np.linalg.norm(m[:3, k])
        if not np.isfinite(n) or n == 0.0:
            raise ValueError("camera: its transform is degenerate or not finite")
        m[:3, k] /= n
    return m


def export_camera(depsgraph, warnings):
    """The scene camera as a ``polychrome.Camera``."""
    scene = depsgraph.scene
    cam_ob = scene.camera
    if cam_ob is None:
        raise ValueError("scene has no active camera")
    ob = cam_ob.evaluated_get(depsgraph)
    cam = ob.data
    if cam.type not in ("PERSP", "ORTHO"):
        warnings.add(("camera", cam.type), f"camera '{cam_ob.name}': type {cam.type} is not supported, rendered as perspective")
    if cam.dof.use_dof:
        warnings.add(("camera", "dof"), f"camera '{cam_ob.name}': depth of field is not supported yet and is ignored")
    if abs(scene.render.pixel_aspect_x - scene.render.pixel_aspect_y) > 1e-6:
        warnings.add(("camera", "aspect"), "non-square pixel aspect is not supported and is ignored")
    return pc.Camera(
        to_world=camera_matrix(ob.matrix_world),
        projection="ORTHOGRAPHIC" if cam.type == "ORTHO" else "PERSPECTIVE",
        focal_length=float(cam.lens),
        sensor_width=float(cam.sensor_width),
        sensor_height=float(cam.sensor_height),
        sensor_fit=cam.sensor_fit,
        ortho_scale=float(cam.ortho_scale),
        shift_x=float(cam.shift_x),
        shift_y=float(cam.shift_y),
        clip_start=float(cam.clip_start),
        clip_end=float(cam.clip_end),
        name=cam_ob.name,
    )
