"""Blender camera → polychrome.Camera: perspective, orthographic and panoramic
projections, lens, sensor and fit, shift, clip, pixel aspect and depth of field, each as
Cycles reads it (intern/cycles/blender/camera.cpp); docs/camera.md."""

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


def focus_distance(cam_ob, cam):
    """Cycles' ``blender_camera_focal_distance``: the focus object's (or its bone's)
    distance along the camera's view axis, else the camera's focus distance."""
    dof = cam.dof
    target = dof.focus_object
    if target is None:
        return float(dof.focus_distance)
    m = np.array(target.matrix_world, dtype=np.float64)
    if target.pose is not None and dof.focus_subtarget:
        bone = target.pose.bones.get(dof.focus_subtarget)
        if bone is not None:
            m = m @ np.array(bone.matrix, dtype=np.float64)
    c = camera_matrix(cam_ob.matrix_world)
    view_dir = c[:3, 2]  # unit local Z (the camera looks down −Z; the distance is |·|)
    return float(abs(np.dot(view_dir, c[:3, 3] - m[:3, 3])))


def export_camera(depsgraph, warnings):
    """The scene camera as a ``polychrome.Camera``."""
    scene = depsgraph.scene
    cam_ob = scene.camera
    if cam_ob is None:
        raise ValueError("scene has no active camera")
    ob = cam_ob.evaluated_get(depsgraph)
    cam = ob.data
    projection = {"PERSP": "PERSPECTIVE", "ORTHO": "ORTHOGRAPHIC", "PANO": "PANORAMIC"}.get(cam.type)
    if projection is None:
        warnings.add(
            ("camera", cam.type),
            f"camera '{cam_ob.name}': type {cam.type} (an OSL camera) is not supported, rendered as perspective",
        )
        projection = "PERSPECTIVE"
    if cam.stereo is not None and scene.render.use_multiview:
        warnings.add(("camera", "stereo"), f"camera '{cam_ob.name}': stereoscopy (multiview) is not supported; one view is rendered")
    r = scene.render
    if not (r.pixel_aspect_x > 0 and r.pixel_aspect_y > 0):
        raise ValueError(f"render settings: pixel aspect {r.pixel_aspect_x}:{r.pixel_aspect_y} must be positive")
    dof = {}
    if cam.dof.use_dof:
        # Cycles: the f-number sets the radius from the lens in metres (1/(2N) for
        # orthographic cameras), clamped like Cycles' max(fstop, 1e-5).
        fstop = max(float(cam.dof.aperture_fstop), 1e-5)
        radius = 1.0 / (2.0 * fstop) if projection == "ORTHOGRAPHIC" else float(cam.lens) * 1e-3 / (2.0 * fstop)
        dof = dict(
            aperture_radius=radius,
            focus_distance=max(focus_distance(ob, cam), 1e-5),
            aperture_blades=int(cam.dof.aperture_blades),
            aperture_rotation=float(cam.dof.aperture_rotation),
            aperture_ratio=float(cam.dof.aperture_ratio),
        )
    return pc.Camera(
        to_world=camera_matrix(ob.matrix_world),
        projection=projection,
        focal_length=float(cam.lens),
        sensor_width=float(cam.sensor_width),
        sensor_height=float(cam.sensor_height),
        sensor_fit=cam.sensor_fit,
        ortho_scale=float(cam.ortho_scale),
        shift_x=float(cam.shift_x),
        shift_y=float(cam.shift_y),
        clip_start=float(cam.clip_start),
        clip_end=float(cam.clip_end),
        pixel_aspect=float(r.pixel_aspect_x) / float(r.pixel_aspect_y),
        panorama_type=cam.panorama_type,
        fisheye_fov=float(cam.fisheye_fov),
        fisheye_lens=float(cam.fisheye_lens),
        latitude_min=float(cam.latitude_min),
        latitude_max=float(cam.latitude_max),
        longitude_min=float(cam.longitude_min),
        longitude_max=float(cam.longitude_max),
        fisheye_polynomial=tuple(float(getattr(cam, f"fisheye_polynomial_k{i}")) for i in range(5)),
        central_cylindrical_range_u_min=float(cam.central_cylindrical_range_u_min),
        central_cylindrical_range_u_max=float(cam.central_cylindrical_range_u_max),
        central_cylindrical_range_v_min=float(cam.central_cylindrical_range_v_min),
        central_cylindrical_range_v_max=float(cam.central_cylindrical_range_v_max),
        central_cylindrical_radius=float(cam.central_cylindrical_radius),
        name=cam_ob.name,
        **dof,
    )
