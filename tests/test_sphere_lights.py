"""Sphere lights and sun disks against closed forms, in every light-transport direction:
a diffuse floor of albedo ρ under a sphere light of intensity I and radius r at height d
(straight above the camera's view) has radiance ρ/π · I/d² (π L (r/d)² with L = I/(πr²));
under a sun of irradiance E and any angular diameter, ρ/π · E. A ball over the floor casts
a penumbra: the partly shadowed ring is neither dark nor lit, unlike a point light's."""

import math

import numpy as np
import pytest

import polychrome as pc
from conftest import luminance

RHO = 0.5


def floor(light, half=1.0):
    """A floor of half-width ``half`` seen straight down from 0.5 through a pinhole (light
    tracing connects to it) whose view is 0.36 wide."""
    scene = pc.Scene()
    grey = scene.add_material(pc.Diffuse(RHO, name="grey"))
    v = np.array([[-half, -half, 0], [half, -half, 0], [half, half, 0], [-half, half, 0]], np.float32)
    scene.add_mesh("floor", v, np.array([[0, 1, 2], [0, 2, 3]], np.uint32), material=grey)
    scene.add_light(light)
    scene.camera = pc.Camera.looking_at((0, 0, 0.5), (0, 0, 0), focal_length=50.0, sensor_width=36.0, name="lens")
    return scene


N = 6
CENTRES = ((np.arange(N) + 0.5) / N * 2 - 1) * 0.18  # the floor under the pixel centres
X, Y = np.meshgrid(CENTRES, CENTRES)


def above(intensity, d):
    """Mean irradiance from a point (or fully visible sphere) of intensity I at height d."""
    return float(np.mean(intensity * d / (d * d + X * X + Y * Y) ** 1.5))


SAMPLES = {"BACKWARD": 64, "FORWARD": 32768, "BIDIRECTIONAL": 128}  # light tracing is noisy here


@pytest.mark.parametrize("direction", ["BACKWARD", "FORWARD", "BIDIRECTIONAL"])
@pytest.mark.parametrize(
    "light, irradiance",
    [
        (pc.PointLight((0, 0, 2.0), power=4 * math.pi * 8.0, radius=0.6, name="sphere"), above(8.0, 2.0)),
        (pc.SpotLight((0, 0, 2.0), (0, 0, -1), power=4 * math.pi * 8.0, spot_size=2.0, radius=0.4, name="spot"), above(8.0, 2.0)),
        (pc.SunLight((0.2, 0, -1), strength=3.0, angle=0.8, name="sun"), 3.0 / math.hypot(0.2, 1.0)),
    ],
    ids=["sphere", "spot", "sun"],
)
def test_floor_radiance_is_the_closed_form(light, irradiance, direction):
    scene = floor(light)
    result = pc.render(scene, width=N, height=N, samples=SAMPLES[direction], max_bounces=1, seed=2, direction=direction)
    got = float(luminance(result.rgba[..., :3]).mean())
    assert got == pytest.approx(RHO / math.pi * irradiance, rel=0.04), direction


def test_a_ball_casts_a_penumbra():
    def ring(radius):
        scene = floor(pc.PointLight((0, 0, 3.0), power=400.0, radius=radius, name="bulb"), half=10.0)
        black = scene.add_material(pc.Diffuse(0.0, name="black"))
        # a small black square card at height 1 (its shadow: a square of half-width 0.45)
        v = np.array([[-0.3, -0.3, 1], [0.3, -0.3, 1], [0.3, 0.3, 1], [-0.3, 0.3, 1]], np.float32)
        scene.add_mesh("card", v, np.array([[0, 1, 2], [0, 2, 3]], np.uint32), material=black)
        scene.camera = pc.Camera.looking_at((0, 0, 0.5), (0, 0, 0), projection="ORTHOGRAPHIC", ortho_scale=2.0, name="low")
        img = luminance(pc.render(scene, width=40, height=40, samples=32, max_bounces=1, seed=1).rgba[..., :3])
        return img[20, 27], img[20, 39]  # just inside the sharp shadow's edge (x ≈ 0.39 < 0.45), far out

    sharp_edge, lit = ring(0.0)
    soft_edge, lit_soft = ring(0.8)
    assert sharp_edge < 0.02 * lit
    assert 0.15 * lit_soft < soft_edge < 0.85 * lit_soft


@pytest.mark.parametrize("camera", [False, True])
def test_a_mirror_shows_the_sphere_and_the_camera_only_when_visible(camera):
    """A sphere light of intensity I and radius r has radiance I/(πr²): seen straight on,
    the pixels inside its disk read it only with ``visibility={"camera": True}`` (off by
    default, as Cycles' ``visible_camera``); in a white mirror (Glossy, roughness 0) below
    the camera, its reflection reads it whatever the camera visibility (BSDF rays hit
    the sphere)."""
    intensity, r = 5.0, 0.3
    scene = pc.Scene()
    mirror = scene.add_material(pc.Glossy(1.0, roughness=0.0, name="mirror"))
    v = np.array([[-9, -9, 0], [9, -9, 0], [9, 9, 0], [-9, 9, 0]], np.float32)
    scene.add_mesh("mirror", v, np.array([[0, 1, 2], [0, 2, 3]], np.uint32), material=mirror)
    vis = {"camera": True} if camera else None
    scene.add_light(pc.PointLight((0, 0, 2.0), power=4 * math.pi * intensity, radius=r, name="sphere", visibility=vis))
    radiance = intensity / (math.pi * r * r)
    # Looking up at the sphere from below its centre (the mirror is behind the camera) ...
    scene.camera = pc.Camera.looking_at((0, 0, 1.0), (0, 0, 2.0), up=(0, 1, 0), focal_length=50.0, name="up")
    up = luminance(pc.render(scene, width=16, height=16, samples=4, max_bounces=2, seed=1).rgba[..., :3])
    assert up[6:10, 6:10].mean() == pytest.approx(radiance if camera else 0.0, rel=0.01, abs=1e-6)
    assert up[0, 0] == 0.0
    # ... and down at its reflection (the sphere is behind the camera: at 2 above, seen at 1 + 2 = 3 away).
    scene.camera = pc.Camera.looking_at((0, 0, 1.0), (0, 0, 0.0), up=(0, 1, 0), focal_length=50.0, name="down")
    down = luminance(pc.render(scene, width=16, height=16, samples=4, max_bounces=2, seed=1).rgba[..., :3])
    assert down[7:9, 7:9].mean() == pytest.approx(radiance, rel=0.01)
    assert down[0, 0] == 0.0
