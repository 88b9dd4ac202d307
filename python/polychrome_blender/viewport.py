"""Interactive viewport rendering: the 3D view's camera as a ``polychrome.Camera``, and
:class:`ViewportSession`, which keeps one background ``polychrome.RenderJob`` in step with
the scene, the view and the settings (restarting it when any of them changes) and hands
out its progressive previews.

Nothing here needs ``bpy`` or a GPU: the engine's ``view_update`` / ``view_draw`` feed the
session and draw what it returns, and tests drive the session directly.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json

import numpy as np
import polychrome as pc

#: Samples per pixel of material previews (Blender's preview scene, small images).
MATERIAL_PREVIEW_SAMPLES = 16
#: Material previews stop refining after this many seconds.
MATERIAL_PREVIEW_TIME_LIMIT = 10.0

_live_sessions = []  # every session not yet freed, so unregister() / exit can stop them


def view_camera(view_matrix, window_matrix, width, height, name="Viewport"):
    """The ``polychrome.Camera`` that sees what a 3D view of ``width`` × ``height`` pixels
    shows: ``view_matrix`` (world → view) and ``window_matrix`` (the OpenGL-style
    projection) of ``region_data``. This covers perspective and orthographic user views
    and the camera view (whose window matrix already holds the camera's lens, sensor,
    shift, zoom and offset in the region)."""
    V = np.array(view_matrix, dtype=np.float64).reshape(4, 4)
    P = np.array(window_matrix, dtype=np.float64).reshape(4, 4)
    if not (np.isfinite(V).all() and np.isfinite(P).all()):
        raise ValueError("viewport: the view or projection matrix is not finite")
    to_world = np.linalg.inv(V)
    for k in range(3):
        n = np.linalg.norm(to_world[:3, k])
        if n == 0.0:
            raise ValueError("viewport: the view matrix is degenerate")
        to_world[:3, k] /= n
    if P[0, 0] == 0.0 or P[1, 1] == 0.0:
        raise ValueError("viewport: the projection matrix is degenerate")
    perspective = abs(P[3, 3]) < 0.5  # 0 for a perspective projection, 1 for orthographic
    # Half extents of the image plane (at distance 1, or in world units) and its centre.
    half_w, half_h = 1.0 / abs(P[0, 0]), 1.0 / abs(P[1, 1])
    if perspective:
        cx, cy = P[0, 2] / P[0, 0], P[1, 2] / P[1, 1]
        near, far = P[2, 3] / (P[2, 2] - 1.0), P[2, 3] / (P[2, 2] + 1.0)
    else:
        cx, cy = -P[0, 3] / P[0, 0], -P[1, 3] / P[1, 1]
        near, far = (P[2, 3] + 1.0) / P[2, 2], (P[2, 3] - 1.0) / P[2, 2]
    # The core's lens shift is in units of the fitted image side: with a horizontal fit,
    # the width (the core takes the image height from the aspect ratio).
    fitted = 2.0 * half_w
    common = dict(sensor_fit="HORIZONTAL", shift_x=float(cx / fitted), shift_y=float(cy / fitted), name=name)
    if perspective:
        near = max(float(near), 1e-6)
        far = max(float(far), near * 2.0)
        # sensor / focal = full width at distance 1
        return pc.Camera(
            to_world=to_world,
            projection="PERSPECTIVE",
            focal_length=50.0,
            sensor_width=float(100.0 * half_w),
            sensor_height=float(100.0 * half_h),
            clip_start=near,
            clip_end=far,
            **common,
        )
    # Orthographic user views clip on both sides of the view origin: move the origin
    # back along the view axis (which changes nothing else) so the near plane is ahead.
    near, far = float(near), float(far)
    if near < 1e-4:
        back = 1e-4 - near
        to_world[:3, 3] += to_world[:3, 2] * back
        near, far = near + back, far + back
    return pc.Camera(
        to_world=to_world,
        projection="ORTHOGRAPHIC",
        ortho_scale=float(2.0 * half_w),
        clip_start=near,
        clip_end=max(far, near * 2.0),
        **common,
    )


def viewport_size(region_width, region_height, pixel_size=1):
    """Render size for a region drawn with ``pixel_size`` screen pixels per render pixel."""
    s = max(1, int(pixel_size))
    return max(1, int(region_width) // s), max(1, int(region_height) // s)


def description_digest(desc, buffers):
    """A digest of a scene description and its buffers (the camera excluded)."""
    h = hashlib.blake2b(digest_size=20)
    d = {k: v for k, v in desc.items() if k != "camera"}
    h.update(json.dumps(d, sort_keys=True, default=str).encode())
    for b in buffers:
        a = np.ascontiguousarray(b)
        h.update(f"{a.dtype.str}{a.shape}".encode())
        h.update(a.view(np.uint8).reshape(-1).data)
    return h.hexdigest()


class ViewportSession:
    """One background render kept in step with (scene, view camera, size, settings).

    ``set_scene(desc, buffers)``, ``set_view(camera, width, height)`` and
    ``set_settings(settings)`` record the newest state; ``sync()`` restarts the render
    when any of them changed since the running job started (and not otherwise), so
    calling them on every depsgraph update or redraw is cheap. ``poll()`` returns a new
    preview when there is one. Old jobs are cancelled at once and forgotten when they end;
    ``free()`` cancels everything and waits (bounded) for the threads to stop.
    """

    def __init__(self):
        self.job = None
        self.restarts = 0
        self.error = None
        self.latest = None  # the newest polychrome.Preview taken from the job
        self._desc = None
        self._buffers = None
        self._scene_digest = None
        self._camera = None
        self._size = None
        self._settings = None
        self._running_key = None
        self._retired = []
        _live_sessions.append(self)

    # -- state -------------------------------------------------------------------
    def set_scene(self, desc, buffers):
        """The exported scene (``Scene.description()``); its camera is replaced by the view's."""
        self._desc, self._buffers = desc, list(buffers)
        self._scene_digest = description_digest(desc, self._buffers)

    def set_view(self, camera, width, height):
        """The view camera (a ``polychrome.Camera`` or its dict) and the render size."""
        self._camera = camera.to_dict() if isinstance(camera, pc.Camera) else dict(camera)
        self._size = (max(1, int(width)), max(1, int(height)))

    def set_settings(self, settings):
        """``polychrome.RenderSettings``; its width and height are replaced by the view's."""
        self._settings = settings

    @property
    def ready(self):
        return self._desc is not None and self._camera is not None and self._settings is not None

    def key(self):
        """What the running render depends on; a change means a restart."""
        if not self.ready:
            return None
        settings = dataclasses.replace(self._settings, width=self._size[0], height=self._size[1])
        return (self._scene_digest, json.dumps(self._camera, sort_keys=True), settings.to_json())

    # -- control -----------------------------------------------------------------
    def sync(self):
        """Restarts the render if the scene, view, size or settings changed; returns
        whether it did."""
        key = self.key()
        if key is None or key == self._running_key:
            return False
        self.restart()
        return True

    def restart(self):
        """Cancels the current render and starts one for the current state."""
        self._retire_current()
        self._running_key = self.key()
        self.latest = None
        self.error = None
        self.restarts += 1
        settings = dataclasses.replace(self._settings, width=self._size[0], height=self._size[1])
        desc = dict(self._desc)
        desc["camera"] = self._camera
        try:
            self.job = pc.RenderJob.from_description(desc, self._buffers, settings).start()
        except Exception as e:  # noqa: BLE001 - reported by the engine, never raised into Blender
            self.job = None
            self.error = str(e) or type(e).__name__

    def _retire_current(self):
        if self.job is not None:
            self.job.cancel()
            self._retired.append(self.job)
            self.job = None
        self._retired = [j for j in self._retired if not j.done()]

    def poll(self):
        """The newest preview if it is newer than the last one returned, else None. When
        the render has failed, ``error`` holds its message."""
        self._retired = [j for j in self._retired if not j.done()]
        job = self.job
        if job is None:
            return None
        if self.error is None and job.done():
            try:
                job.result()
            except Exception as e:  # noqa: BLE001
                self.error = str(e) or type(e).__name__
        serial = job.preview_serial()
        if serial == 0 or (self.latest is not None and self.latest.serial == serial):
            return None
        p = job.preview()
        if p is None:
            return None
        self.latest = p
        return p

    @property
    def refining(self):
        """True while the current render still adds samples (or a newer preview waits)."""
        job = self.job
        if job is None:
            return False
        if not job.done():
            return True
        return self.latest is None or self.latest.serial != job.preview_serial()

    @property
    def samples(self):
        return 0 if self.latest is None else self.latest.samples

    def progress(self):
        return (0, 0) if self.job is None else self.job.progress()

    def free(self, timeout=5.0):
        """Cancels every render of this session and waits up to ``timeout`` seconds in all
        for their threads to end; returns whether they all did."""
        self._retire_current()
        ok = True
        for j in self._retired:
            j.cancel()
        for j in self._retired:
            ok = j.wait(timeout) and ok
        self._retired = [j for j in self._retired if not j.done()]
        if self in _live_sessions:
            _live_sessions.remove(self)
        self._running_key = None
        return ok


def free_all(timeout=5.0):
    """Stops every live session (add-on unregister, interpreter exit)."""
    for s in list(_live_sessions):
        try:
            s.free(timeout)
        except Exception as e:  # noqa: BLE001
            print(f"Polychrome: stopping a viewport render failed: {e}")
