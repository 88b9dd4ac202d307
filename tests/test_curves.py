"""Curves and point clouds in the Python API (Scene.add_curves / add_points, tessellated by
the core): their coverage against closed forms, and bad input named. Cycles comparisons
are in tests/blender/test_hair.py."""

from __future__ import annotations

import numpy as np
import pytest

import polychrome as pc
from polychrome import curves

VIEW = 4.0  # the orthographic view is VIEW × VIEW scene units


def coverage(scene: pc.Scene, size=96, samples=64) -> float:
    """Fraction of the orthographic view covered by the (emissive, radiance 1) geometry."""
    glow = scene.materials[0]
    assert isinstance(glow, pc.Emitter)
    scene.camera = pc.Camera.looking_at((0, -10, 0), (0, 0, 0), projection="ORTHOGRAPHIC", ortho_scale=VIEW)
    rgba = pc.render(scene, width=size, height=size, samples=samples, seed=4, wavelength_count=4, max_bounces=0).rgba
    white = pc.render(emissive_wall(), width=4, height=4, samples=1, wavelength_count=4, max_bounces=0).rgba[..., 1].mean()
    return float(rgba[..., 1].mean() / white)


def emissive_wall() -> pc.Scene:
    s = pc.Scene()
    m = s.add_material(pc.Emitter(pc.spectra.constant(1.0), name="glow"))
    s.add_mesh("wall", np.array([[-9, 0, -9], [9, 0, -9], [9, 0, 9], [-9, 0, 9]], np.float32), np.array([[0, 1, 2], [0, 2, 3]]), material=m)
    s.camera = pc.Camera.looking_at((0, -10, 0), (0, 0, 0), projection="ORTHOGRAPHIC", ortho_scale=VIEW)
    return s


def test_thin_straight_curves_cover_twice_their_radius_times_their_projected_length():
    """Short straight strands in random directions, apart from each other: together they
    cover Σ 2r·L⊥ (the tube's mean width is the diameter), plus the ends' π r² each."""
    rng = np.random.default_rng(1)
    n, r, length = 64, 0.012, 0.35
    centres = np.stack(np.meshgrid(np.linspace(-1.6, 1.6, 8), [0.0], np.linspace(-1.6, 1.6, 8)), -1).reshape(-1, 3)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    keys = np.stack([centres - d * length / 2, centres + d * length / 2], 1).reshape(-1, 3)
    scene = pc.Scene()
    glow = scene.add_material(pc.Emitter(pc.spectra.constant(1.0), name="glow"))
    scene.add_curves("strands", keys, np.full(n, 2), radius=r, material=glow, linear=True)
    projected = length * np.linalg.norm(d[:, [0, 2]], axis=1)  # the view looks along y
    expect = (2 * r * projected.sum() + n * np.pi * r * r) / VIEW**2
    got = coverage(scene, size=160, samples=64)
    assert got == pytest.approx(expect, rel=0.05), (got, expect)


def test_points_cover_pi_r_squared_each():
    rng = np.random.default_rng(2)
    n, r = 50, 0.08
    grid = np.stack(np.meshgrid(np.linspace(-1.5, 1.5, 10), [0.0], np.linspace(-1.2, 1.2, 5)), -1).reshape(-1, 3)
    positions = grid + rng.uniform(-0.05, 0.05, grid.shape)
    scene = pc.Scene()
    glow = scene.add_material(pc.Emitter(pc.spectra.constant(1.0), name="glow"))
    scene.add_points("dots", positions, radius=r, material=glow)
    got = coverage(scene)
    assert got == pytest.approx(n * np.pi * r * r / VIEW**2, rel=0.03)


def test_catmull_rom_curve_passes_through_its_keys_and_per_curve_materials_apply():
    keys = np.array([[0, 0, 0], [0.5, 0, 0.5], [0, 0, 1.0], [1, 0, 0], [1, 0, 1]], float)
    v, n, uv, t, owner = curves.curves_mesh(keys, 0.05, [3, 2], sides=8)
    assert set(owner.tolist()) == {0, 1}
    # Each key is the centre of one ring of 8 vertices.
    centres = v.reshape(-1, 8, 3).mean(axis=1)
    for k in keys:
        assert np.min(np.linalg.norm(centres - k, axis=1)) < 1e-5
    scene = pc.Scene()
    a = scene.add_material(pc.Diffuse((0.5, 0.5, 0.5), name="a"))
    b = scene.add_material(pc.Diffuse((0.2, 0.2, 0.2), name="b"))
    m = scene.add_curves("two", keys, [3, 2], radius=0.05, material_ids=[a, b])
    ids = scene.description()[1][scene.description()[0]["meshes"][m]["material_ids"]]
    assert sorted(set(ids.tolist())) == [a, b]


def test_bad_curves_and_points_name_the_object():
    scene = pc.Scene()
    with pytest.raises(ValueError, match="curves 'Fur'.*counts add up"):
        scene.add_curves("Fur", np.zeros((5, 3)), [2, 2])
    with pytest.raises(ValueError, match="curves 'Fur'.*at least 2"):
        scene.add_curves("Fur", np.zeros((3, 3)), [1, 2])
    with pytest.raises(ValueError, match="curves 'Fur'.*radius"):
        scene.add_curves("Fur", np.zeros((2, 3)), [2], radius=-1.0)
    with pytest.raises(ValueError, match="point cloud 'Dust'.*not finite"):
        scene.add_points("Dust", [[0.0, np.nan, 0.0]])
    with pytest.raises(ValueError, match="one entry per curve"):
        scene.add_curves("Fur", np.zeros((4, 3)), [2, 2], material_ids=[0])
