"""Motion blur and the render region through the Python API (docs/camera.md).

Motion blur against a closed form: an emissive square of width w whose centre moves
uniformly over a distance D during the shutter smears into a trapezoid — at x it is seen
for |[x − w/2, x + w/2] ∩ path| / D of the shutter — so its row's total light is the
static square's and its extent w + D. The render region against the whole render: the
region's pixels are the same samples (per-pixel random streams), the rest is empty.
The Cycles comparisons are in tests/blender/test_motion.py."""

from __future__ import annotations

import math

import numpy as np
import pytest

import polychrome as pc

W, H, VIEW = 64, 4, 8.0  # 1/8 unit per pixel


def translation(x: float, z: float = -5.0) -> np.ndarray:
    m = np.eye(4)
    m[0, 3], m[2, 3] = x, z
    return m


def square_scene(motion=None, motion_vertices=None, camera_motion=None) -> pc.Scene:
    scene = pc.Scene()
    glow = scene.add_material(pc.Emitter(pc.spectra.constant(1.0), name="glow"))
    v = np.array([[-0.5, -2, 0], [0.5, -2, 0], [0.5, 2, 0], [-0.5, 2, 0]], np.float32)
    scene.add_mesh(
        "square",
        v,
        np.array([[0, 1, 2], [0, 2, 3]]),
        material=glow,
        transform=translation(0.0),
        motion=motion,
        motion_vertices=motion_vertices,
    )
    scene.camera = pc.Camera(projection="ORTHOGRAPHIC", ortho_scale=VIEW, motion=camera_motion)
    return scene


def columns(scene: pc.Scene, samples: int, **kw) -> np.ndarray:
    out = pc.render(scene, width=W, height=H, samples=samples, wavelength_count=8, max_bounces=0, seed=3, **kw)
    y = out.rgba[..., :3] @ np.array([0.2126, 0.7152, 0.0722])
    return y.mean(axis=0)


def trapezoid(a: float, b: float) -> np.ndarray:
    x = (np.arange(W) + 0.5) * VIEW / W - VIEW / 2
    lo, hi = min(a, b), max(a, b)
    return np.clip(np.minimum(x + 0.5, hi) - np.maximum(x - 0.5, lo), 0, None) / (hi - lo)


@pytest.mark.parametrize("how", ["instance", "vertices", "camera"])
def test_a_moving_square_smears_into_the_closed_form_trapezoid(how):
    plateau = columns(square_scene(), 8)[W // 2]
    assert plateau > 0.1
    if how == "instance":  # three keys, Cycles' default motion steps
        scene = square_scene(motion=[translation(-1.5), translation(-0.25), translation(1.0)])
        a, b = -1.5, 1.0
    elif how == "vertices":
        v = np.array([[-0.5, -2, 0], [0.5, -2, 0], [0.5, 2, 0], [-0.5, 2, 0]], np.float32)
        scene = square_scene(motion_vertices=[v + [-1.5, 0, 0], v + [1.0, 0, 0]])
        a, b = -1.5, 1.0
    else:  # the camera moves right to left: the square crosses its view left to right
        scene = square_scene(camera_motion=[translation(1.5, 0.0), translation(-1.0, 0.0)])
        a, b = -1.5, 1.0
    col = columns(scene, 256) / plateau
    want = trapezoid(a, b)
    assert np.abs(col - want).max() < 0.08, np.round(col, 2)
    # Motion spreads the light and keeps its amount: the square is 8 columns wide.
    assert col.sum() == pytest.approx(W / VIEW, rel=0.01)
    assert np.abs(col - trapezoid(a / 2, b / 2)).max() > 0.25  # half the travel: told apart


def test_motion_keys_are_checked_with_the_objects_name():
    v = np.zeros((4, 3), np.float32)
    with pytest.raises(ValueError, match="instance 'square'.*K ≥ 2"):
        square_scene(motion=[translation(0.0)])
    with pytest.raises(ValueError, match="mesh 'square': motion_vertices"):
        square_scene(motion_vertices=[v[:3], v[:3]])
    with pytest.raises(ValueError, match="camera 'Camera'.*K ≥ 2"):
        pc.render(square_scene(camera_motion=np.eye(4)[None]), width=4, height=4, samples=1)
    cam = pc.Camera(shutter_curve=[0.0, 0.0], name="Shut")
    scene = square_scene()
    scene.camera = cam
    with pytest.raises(ValueError, match="camera 'Shut'.*closed"):
        pc.render(scene, width=4, height=4, samples=1)


def test_a_shutter_curve_weights_the_times():
    # A shutter that opens linearly (curve 0 → 1): the square moving from −1.5 to +1 is
    # seen ∝ t, so the smear's light leans to the end of its travel (mean position at
    # t = 2/3 instead of 1/2).
    plateau = columns(square_scene(), 8)[W // 2]
    scene = square_scene(motion=[translation(-1.5), translation(1.0)])
    scene.camera.shutter_curve = [0.0, 1.0]
    col = columns(scene, 512) / plateau
    x = (np.arange(W) + 0.5) * VIEW / W - VIEW / 2
    mean = (col * x).sum() / col.sum()
    assert mean == pytest.approx(-1.5 + 2.5 * 2 / 3, abs=0.03)
    scene.camera.shutter_curve = None
    col = columns(scene, 128) / plateau
    assert (col * x).sum() / col.sum() == pytest.approx(-1.5 + 2.5 / 2, abs=0.03)


@pytest.mark.parametrize("direction", ["BACKWARD", "FORWARD"])
def test_a_region_renders_the_same_pixels_and_nothing_else(direction):
    scene = pc.Scene()
    grey = scene.add_material(pc.Diffuse(0.6))
    v = np.array([[-2, -2, -5], [2, -2, -5], [2, 2, -5], [-2, 2, -5]], np.float32)
    scene.add_mesh("wall", v, np.array([[0, 1, 2], [0, 2, 3]]), material=grey)
    scene.add_light(pc.PointLight((0.3, 0.2, -2.0), power=200.0))
    scene.camera = pc.Camera(focal_length=30.0)
    kw = dict(width=24, height=16, samples=4, wavelength_count=8, seed=5, direction=direction, max_bounces=2, noise_threshold=0.0)
    full = pc.render(scene, **kw)
    part = pc.render(scene, region=(5, 3, 17, 11), **kw)
    inside = (slice(3, 11), slice(5, 17))
    assert np.array_equal(part.rgba[inside], full.rgba[inside])
    outside = np.ones((16, 24), bool)
    outside[inside] = False
    assert np.all(part.rgba[outside] == 0.0) and full.rgba[inside][..., :3].mean() > 0.01
    if direction == "BACKWARD":  # camera samples only where asked
        assert part.stats["total_samples"] == 12 * 8 * 4
    with pytest.raises(ValueError, match="region"):
        pc.render(scene, region=(5, 3, 25, 11), **kw)


@pytest.mark.parametrize("keys", [2, 3])
def test_a_moving_point_light_lights_the_time_average_of_the_inverse_square_law(keys):
    """A point light at height h over a diffuse floor (ρ = 0.6) sweeps x from −1.5 to 1.5
    over the shutter: the floor's radiance at (x, y) is ρ/π · I · ⟨h / r(t)³⟩ over the
    shutter, the time average integrated numerically here (pixel footprints included)."""
    h, power, rho = 1.0, 40.0, 0.6
    scene = pc.Scene()
    floor = scene.add_material(pc.Diffuse(rho))
    v = np.array([[-6, -3, -5], [6, -3, -5], [6, 3, -5], [-6, 3, -5]], np.float32)
    scene.add_mesh("floor", v, np.array([[0, 1, 2], [0, 2, 3]]), material=floor)
    xs = np.linspace(-1.5, 1.5, keys)
    motion = [translation(x, -5.0 + h) for x in xs]
    scene.add_light(pc.PointLight((xs[keys // 2], 0.0, -5.0 + h), power=power, motion=motion))
    scene.camera = pc.Camera(projection="ORTHOGRAPHIC", ortho_scale=VIEW)
    out = pc.render(scene, width=W, height=H, samples=64, wavelength_count=32, max_bounces=1, seed=5)
    got = (out.rgba[..., :3] @ np.array([0.2126, 0.7152, 0.0722])).mean(axis=0)
    # Closed form: 4 × 4 points per pixel, 2001 times over the shutter.
    px = VIEW / W
    sub = (np.arange(4) + 0.5) / 4
    x = ((np.arange(W)[:, None] + sub[None, :]) * px - VIEW / 2).ravel()
    y = ((np.arange(H)[:, None] + sub[None, :]) * px - H * px / 2).ravel()
    t = np.linspace(-1.5, 1.5, 2001)
    r2 = (x[:, None, None] - t[None, None, :]) ** 2 + y[None, :, None] ** 2 + h * h
    e = (h / r2**1.5).mean(axis=(1, 2)).reshape(W, 4).mean(axis=1)
    want = rho / np.pi * power / (4 * np.pi) * e
    lit = want > 0.1 * want.max()
    rel = np.abs(got[lit] / want[lit] - 1)
    print(f"moving point light, {keys} keys: max relative error {rel.max():.4f}, mean {(got[lit] / want[lit] - 1).mean():+.4f}")
    assert rel.max() < 0.02, (rel.max(), got[lit][:8], want[lit][:8])
    # Control: the light standing at the frame is clearly another picture.
    still = (
        rho
        / np.pi
        * power
        / (4 * np.pi)
        * ((h / ((x[:, None] - xs[keys // 2]) ** 2 + y[None, :] ** 2 + h * h) ** 1.5).mean(axis=1).reshape(W, 4).mean(axis=1))
    )
    assert np.abs(still[lit] / want[lit] - 1).max() > 0.3


def test_a_turning_sun_lights_the_time_average_of_its_cosine():
    """``SunLight(motion=…)``: a sun turning uniformly by θ from −0.2 to 1.4 rad from the
    vertical over the shutter lights a diffuse floor with ⟨cos θ⟩ = (sin 1.4 + sin 0.2) / 1.6
    of the overhead sun's radiance."""

    def key(theta):
        s, c = math.sin(theta), math.cos(theta)
        return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1]], float)

    def mean(sun):
        scene = pc.Scene()
        floor = scene.add_material(pc.Diffuse(0.5))
        v = np.array([[-3, -3, 0], [3, -3, 0], [3, 3, 0], [-3, 3, 0]], np.float32)
        scene.add_mesh("floor", v, np.array([[0, 1, 2], [0, 2, 3]]), material=floor)
        scene.add_light(sun)
        scene.camera = pc.Camera(projection="ORTHOGRAPHIC", ortho_scale=4.0, to_world=translation(0.0, 5.0))
        out = pc.render(scene, width=8, height=8, samples=64, wavelength_count=8, max_bounces=1)
        return float((out.rgba[..., :3] @ np.array([0.2126, 0.7152, 0.0722])).mean())

    overhead = mean(pc.SunLight((0, 0, -1), strength=3.0))
    frame_dir = (0.0, math.sin(0.6), -math.cos(0.6))
    turning = mean(pc.SunLight(frame_dir, strength=3.0, motion=[key(-0.2), key(1.4)]))
    want = (math.sin(1.4) + math.sin(0.2)) / 1.6
    assert abs(turning / overhead - want) < 0.01 * want, (turning / overhead, want)
    at_frame = mean(pc.SunLight(frame_dir, strength=3.0)) / overhead
    assert abs(at_frame - want) > 0.08 * want
