"""The five methods and three directions (docs/design.md#methods) through the Python API: every
spectral method and direction converges to the same image as a high-sample
POLYCHROMATIC BACKWARD reference (mean CIEDE2000 < 0.5), and RGB mode differs from the
spectral render by a large ΔE00 under a narrow-band light (the paper's figure 2/3)."""

from __future__ import annotations

import numpy as np
import pytest

import polychrome as pc
from polychrome import spectra
from polychrome.colordiff import delta_e_stats, image_delta_e

from meshes import quad, uv_sphere


def closed_box() -> pc.Scene:
    """A closed room of spectral diffuse walls, an area light, the camera inside."""
    scene = pc.Scene()
    white = scene.add_material(pc.Diffuse(0.7, name="white"))
    red = scene.add_material(pc.Diffuse(spectra.tabulated([380, 570, 610, 780], [0.05, 0.06, 0.8, 0.85]), name="red"))
    green = scene.add_material(pc.Diffuse(spectra.narrow_band(530.0, 90.0, 0.75), name="green"))
    lamp = scene.add_material(pc.Emitter(spectra.blackbody(4500.0), strength=1.5, name="lamp"))
    s = 1.0
    scene.add_mesh("floor", *quad((-s, -s, -s), (s, -s, -s), (s, s, -s), (-s, s, -s)), material=white)
    scene.add_mesh("ceiling", *quad((-s, -s, s), (-s, s, s), (s, s, s), (s, -s, s)), material=white)
    scene.add_mesh("left", *quad((-s, -s, -s), (-s, s, -s), (-s, s, s), (-s, -s, s)), material=red)
    scene.add_mesh("right", *quad((s, -s, -s), (s, -s, s), (s, s, s), (s, s, -s)), material=green)
    scene.add_mesh("back", *quad((-s, s, -s), (s, s, -s), (s, s, s), (-s, s, s)), material=white)
    scene.add_mesh("front", *quad((-s, -s, -s), (-s, -s, s), (s, -s, s), (s, -s, -s)), material=white)
    l = 0.9  # a large emitter: low variance, so tiny renders converge in seconds
    scene.add_mesh("lamp", *quad((-l, -l, 0.98), (l, -l, 0.98), (l, l, 0.98), (-l, l, 0.98)), material=lamp)
    scene.camera = pc.Camera.looking_at((0.0, -0.95, 0.0), (0.0, 1.0, 0.0), focal_length=16.0)
    return scene


SIZE = 24
BASE = dict(width=SIZE, height=SIZE, wavelength_count=21, max_bounces=5, seed=3)


def blocks(rgba, k=4):
    """Averages k×k pixel blocks: compares images at a coarser scale, where a few
    seconds of samples bring the Monte Carlo noise well under the ΔE threshold."""
    h, w = rgba.shape[:2]
    return rgba.reshape(h // k, k, w // k, k, -1).mean(axis=(1, 3))


@pytest.fixture(scope="module")
def box_reference():
    return blocks(pc.render(closed_box(), samples=2048, **BASE).rgba)


@pytest.mark.parametrize(
    "method,direction,samples",
    [
        ("MONOCHROMATIC_RAYS", "BACKWARD", 1024),
        ("MONOCHROMATIC_SCENES", "BACKWARD", 64),
        ("POLYCHROMATIC", "FORWARD", 512),
        ("POLYCHROMATIC", "BIDIRECTIONAL", 512),
        ("HERO", "BACKWARD", 1024),
        ("HERO", "FORWARD", 1024),
    ],
)
def test_methods_converge_to_the_polychromatic_image(box_reference, method, direction, samples):
    result = pc.render(closed_box(), samples=samples, method=method, direction=direction, **BASE)
    assert result.stats["nonfinite_samples"] == 0
    assert result.stats["method"] == method and result.stats["direction"] == direction
    stats = delta_e_stats(image_delta_e(blocks(result.rgba), box_reference))
    assert stats["mean"] < 0.5, (method, direction, stats)


def test_a_wrong_exposure_would_fail_the_same_check(box_reference):
    # Guards the threshold: a 5 % brighter image is already far outside it.
    stats = delta_e_stats(image_delta_e(box_reference * np.array([1.05, 1.05, 1.05, 1.0]), box_reference))
    assert stats["mean"] > 0.5


def green_sphere_under(light: spectra.Spectrum) -> pc.Scene:
    scene = pc.Scene()
    green = scene.add_material(pc.Diffuse(spectra.rgb(0.1, 0.7, 0.1), name="green"))
    scene.add_mesh("ball", *uv_sphere((0.0, 0.0, -4.0), 3.0), material=green)
    scene.set_world(light)
    return scene


def test_rgb_mode_is_far_from_spectral_under_a_narrow_band_red_light():
    scene = green_sphere_under(spectra.narrow_band(600.0, 20.0, 3.0))
    kw = dict(width=8, height=8, samples=32, max_bounces=1)
    spectral = pc.render(scene, **kw)
    rgb = pc.render(scene, method="RGB", **kw)
    centre = (slice(2, 6), slice(2, 6))
    de = image_delta_e(rgb.rgba[centre], spectral.rgba[centre])
    assert float(np.mean(de)) > 10.0, float(np.mean(de))
    # ... while under D65 white both agree closely (the uplift reproduces the RGB).
    scene = green_sphere_under(spectra.d65(1.0))
    de = image_delta_e(pc.render(scene, method="RGB", **kw).rgba[centre], pc.render(scene, **kw).rgba[centre])
    assert float(np.mean(de)) < 1.0, float(np.mean(de))


def test_unknown_direction_and_method_are_reported():
    with pytest.raises(ValueError, match="direction"):
        pc.render(closed_box(), width=4, height=4, samples=1, direction="SIDEWAYS")
    with pytest.raises(ValueError, match="method"):
        pc.render(closed_box(), width=4, height=4, samples=1, method="HYPERSPECTRAL")
    with pytest.raises(ValueError, match="dispersion_splitting"):
        pc.render(closed_box(), width=4, height=4, samples=1, method="RGB", dispersion_splitting=True)
