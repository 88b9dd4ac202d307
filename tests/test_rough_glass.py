"""Rough glass keeps its energy (issue 14): a white rough glass sphere in a uniform white
world vanishes. A closed dielectric object in a uniform world of radiance L returns L
along every ray that leaves it (the 1/η² of the way in is undone on the way out), so the
pixel mean is the world's, 1, within noise, whatever the roughness and index: the
closed-form reference. Without multiple-scattering compensation (single-scattering GGX,
as before) the same sphere is visibly darker, most at high roughness; Cycles' Multiscatter
GGX glass (microfacet_ggx_preserve_energy, intern/cycles/kernel/closure/bsdf_microfacet.h)
is what the core now does, per wavelength at a dispersive glass's own index."""

from __future__ import annotations

import math

import numpy as np
import pytest

import polychrome as pc

from meshes import pole_sphere


def furnace(material: pc.Material, **kw) -> tuple[np.ndarray, np.ndarray, dict]:
    """Mean RGB and its standard error over the pixels that see the sphere (it fills the
    frame), and the render's stats."""
    scene = pc.Scene()
    scene.camera = pc.Camera.looking_at((0, -6, 0), (0, 0, 0), focal_length=200.0)
    v, t = pole_sphere(rings=16, segments=32)
    scene.add_mesh("ball", v, t, material=material)
    scene.set_world((1.0, 1.0, 1.0))
    out = pc.render(scene, width=12, height=12, max_bounces=64, **kw)
    hit = np.linalg.norm(out.normal, axis=-1) > 0.5
    assert hit.all(), hit.mean()
    px = out.rgba[..., :3][hit].astype(np.float64)
    return px.mean(axis=0), px.std(axis=0, ddof=1) / math.sqrt(len(px)), out.stats


@pytest.mark.parametrize("roughness,ior", [(0.3, 1.5), (0.6, 1.1), (1.0, 1.5), (1.0, 2.0)])
def test_white_rough_glass_sphere_vanishes_in_a_white_world(roughness, ior):
    mean, se, stats = furnace(pc.Dielectric(ior, roughness=roughness), samples=32)
    assert stats["nonfinite_samples"] == 0
    assert np.all(np.abs(mean - 1.0) < 4 * se + 0.01), (roughness, ior, mean, se)


def test_dispersive_rough_glass_sphere_vanishes_in_a_white_world():
    """N-SF11 (n 1.76..1.81 over the grid): each wavelength compensated at its own index,
    so the sphere is white, not tinted, after the paths collapse to one wavelength."""
    mean, se, stats = furnace(pc.Dielectric(pc.ior.named("N-SF11"), roughness=0.8), samples=48)
    assert stats["nonfinite_samples"] == 0
    assert np.all(np.abs(mean - 1.0) < 4 * se + 0.015), (mean, se)


def test_white_rough_principled_glass_vanishes_in_a_white_world():
    """The Principled's glass lobe (transmission 1, white base: F_ss = √1 = 1)."""
    mean, se, _ = furnace(pc.Principled((1.0, 1.0, 1.0), roughness=0.7, transmission=1.0), samples=32)
    assert np.all(np.abs(mean - 1.0) < 4 * se + 0.01), (mean, se)
