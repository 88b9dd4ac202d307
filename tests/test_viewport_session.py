"""The add-on's ViewportSession without Blender: it restarts its background render when
the scene, view, size or settings change (and only then), refines progressively towards
the closed-form furnace value, and free() stops it promptly. Also view_camera against
hand-made OpenGL projection matrices (the viewport's window_matrix convention)."""

import math
import time

import numpy as np
import pytest

import polychrome as pc
from polychrome_blender import viewport
from conftest import luminance
from test_render_api import furnace_scene

EXPECTED = 0.25 / (1 - 0.5)


def furnace_desc():
    return furnace_scene(0.25, 0.5).description()


def until(cond, timeout=60.0):
    deadline = time.monotonic() + timeout
    while not cond():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.002)


def run_to_end(session, timeout=120.0):
    """Polls until the render ends and its final preview was taken; the previews seen."""
    seen = []
    deadline = time.monotonic() + timeout
    while True:
        p = session.poll()
        if p is not None:
            seen.append(p)
        if not session.refining:
            return seen
        assert time.monotonic() < deadline, "the viewport render did not finish"
        time.sleep(0.002)


def session_with(samples=64, size=(16, 12), camera=None):
    s = viewport.ViewportSession()
    s.set_scene(*furnace_desc())
    s.set_settings(pc.RenderSettings(samples=samples, max_bounces=100))
    s.set_view(camera or pc.Camera.looking_at((0, 0, 0), (1, 0, 0)), *size)
    return s


def test_nothing_starts_before_scene_view_and_settings_are_known():
    s = viewport.ViewportSession()
    assert not s.sync() and s.job is None and s.poll() is None and not s.refining
    s.set_scene(*furnace_desc())
    s.set_settings(pc.RenderSettings(samples=4))
    assert not s.sync()
    s.set_view(pc.Camera(), 8, 8)
    assert s.sync() and s.restarts == 1
    s.free()


def test_refines_progressively_and_converges_to_the_closed_form():
    s = session_with(samples=200)
    assert s.sync()
    seen = run_to_end(s)
    assert s.error is None
    assert seen[-1].last and seen[-1].samples == 200 and s.samples == 200
    assert any(not p.last for p in seen)
    assert all(a.samples <= b.samples for a, b in zip(seen, seen[1:]))
    assert seen[-1].rgba.shape == (12, 16, 4)
    for p in seen:
        y = luminance(p.rgba)
        se = y.std(ddof=1) / math.sqrt(y.size)
        assert abs(y.mean() - EXPECTED) < 5 * se + 2e-3, (p.samples, y.mean(), se)
    s.free()


def test_restarts_only_when_something_changed():
    s = session_with(samples=100_000)
    assert s.sync() and s.restarts == 1
    first = s.job
    # the same scene exported again, the same view and settings: no restart
    s.set_scene(*furnace_desc())
    s.set_view(pc.Camera.looking_at((0, 0, 0), (1, 0, 0)), 16, 12)
    s.set_settings(pc.RenderSettings(samples=100_000, max_bounces=100))
    assert not s.sync() and s.job is first and s.restarts == 1
    # each kind of change restarts, and the old job is cancelled
    changes = [
        lambda: s.set_scene(*furnace_scene(0.3, 0.5).description()),  # material edit
        lambda: s.set_view(pc.Camera.looking_at((0, 0, 0), (0, 1, 0)), 16, 12),  # view rotated
        lambda: s.set_view(pc.Camera.looking_at((0, 0, 0), (0, 1, 0)), 20, 12),  # region resized
        lambda: s.set_settings(pc.RenderSettings(samples=100_000, max_bounces=50)),  # settings
    ]
    for i, change in enumerate(changes):
        old = s.job
        change()
        assert s.sync(), i
        assert s.restarts == i + 2 and s.job is not old
        assert old.wait(timeout=30), "a replaced render kept running"
        assert old.result().stats["cancelled"]
    # a buffer change with an identical JSON description also restarts (vertex moved)
    desc, buffers = furnace_desc()
    buffers = [b.copy() for b in buffers]
    buffers[0][0] += 0.01
    s.set_scene(desc, buffers)
    assert s.sync()
    assert s.free(timeout=30)
    assert s.job is None and not s.refining


def test_free_cancels_promptly_and_free_all_stops_every_session():
    a, b = session_with(samples=1_000_000), session_with(samples=1_000_000, size=(24, 24))
    a.sync(), b.sync()
    until(lambda: a.job.preview_serial() > 0 and b.job.preview_serial() > 0)
    ja, jb = a.job, b.job
    viewport.free_all(timeout=30)
    assert ja.done() and jb.done()
    assert ja.result().stats["cancelled"] and jb.result().stats["cancelled"]
    assert a not in viewport._live_sessions and b not in viewport._live_sessions


def test_render_errors_are_kept_not_raised():
    s = viewport.ViewportSession()
    desc, buffers = furnace_desc()
    s.set_scene(desc, buffers)
    s.set_settings(pc.RenderSettings(samples=4, method="RGB", direction="FORWARD"))
    cam = pc.Camera(projection="ORTHOGRAPHIC")
    s.set_view(cam, 8, 8)
    s.sync()
    until(lambda: s.poll() is None and s.error is not None)
    assert "FORWARD" in s.error
    s.free()


def gl_perspective(l, r, b, t, n, f):
    return np.array(
        [
            [2 * n / (r - l), 0, (r + l) / (r - l), 0],
            [0, 2 * n / (t - b), (t + b) / (t - b), 0],
            [0, 0, -(f + n) / (f - n), -2 * f * n / (f - n)],
            [0, 0, -1, 0],
        ]
    )


def gl_ortho(l, r, b, t, n, f):
    return np.array(
        [
            [2 / (r - l), 0, 0, -(r + l) / (r - l)],
            [0, 2 / (t - b), 0, -(t + b) / (t - b)],
            [0, 0, -2 / (f - n), -(f + n) / (f - n)],
            [0, 0, 0, 1],
        ]
    )


@pytest.mark.parametrize("width,height", [(40, 30), (30, 40)])
def test_view_camera_reproduces_a_projection_pixel_for_pixel(width, height):
    """A plane z = 0 seen from above through an off-centre frustum: the depth pass's hit
    pixels must be those whose frustum ray hits the plane's square (computed here)."""
    aspect = height / width
    l, r = -0.3, 0.5  # off-centre (lens shift) at the near plane n = 0.5
    b, t = -0.4 * aspect, 0.4 * aspect
    b, t = b + 0.05, t + 0.05
    n, f = 0.5, 100.0
    eye = np.array([0.2, -0.1, 5.0])
    view = np.eye(4)
    view[:3, 3] = -eye  # camera axes = world axes, looking down -Z
    scene = pc.Scene()
    scene.add_material(pc.Diffuse(0.5))
    scene.add_mesh("square", np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], float), np.array([[0, 1, 2], [0, 2, 3]]))
    for P, persp in ((gl_perspective(l, r, b, t, n, f), True), (gl_ortho(l * 4, r * 4, b * 4, t * 4, -10, 10), False)):
        scene.camera = viewport.view_camera(view, P, width, height)
        res = pc.render(scene, width=width, height=height, samples=1, max_bounces=0)
        hit = res.depth > 0
        ys, xs = np.mgrid[0:height, 0:width] + 0.5
        ndc_x, ndc_y = 2 * xs / width - 1, 1 - 2 * ys / height
        inv = np.linalg.inv(P)
        if persp:
            # direction through the pixel centre (at distance 1), then to the plane z = 0
            u = (ndc_x + P[0, 2]) / P[0, 0]
            v = (ndc_y + P[1, 2]) / P[1, 1]
            px, py = eye[0] + u * eye[2], eye[1] + v * eye[2]
        else:
            px = eye[0] + (ndc_x - P[0, 3]) / P[0, 0]
            py = eye[1] + (ndc_y - P[1, 3]) / P[1, 1]
        assert inv.shape == (4, 4)
        inside = (np.abs(px) < 1) & (np.abs(py) < 1)
        # pixels whose whole footprint (the sample is jittered inside it) is on one side
        foot = (2 / P[0, 0]) * (eye[2] if persp else 1.0) / width
        margin = (np.abs(np.abs(px) - 1) > 0.6 * foot) & (np.abs(np.abs(py) - 1) > 0.6 * foot)
        assert inside[margin].sum() > 20 and (~inside[margin]).sum() > 20, "the test scene must show the square's edge"
        np.testing.assert_array_equal(hit[margin], inside[margin])
        # depth along the view axis is the eye height wherever the plane is seen (an
        # orthographic view's origin moves back behind its near plane z = +10)
        np.testing.assert_allclose(res.depth[hit & margin], eye[2] + (0.0 if persp else 10.0), rtol=1e-4)
