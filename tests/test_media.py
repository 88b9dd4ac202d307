"""Media through the Python API (docs/media.md): ``pc.Medium`` on a material, as a
volume-only ``pc.Volume`` and as the world's volume, checked against Beer–Lambert
computed here (also with the camera inside a medium), and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

import polychrome as pc

from test_materials import box, luminance, slab_scene


def test_grey_absorbing_volume_is_beer_lambert():
    """A volume-only slab of thickness 0.5 with σa = 0.8 × density 1.5 in front of a
    uniform emitter: every pixel is exp(−0.6) of the emitter, with no noise (pure
    absorption samples no distance)."""
    clear = pc.render(slab_scene(pc.Volume(pc.Medium())), width=8, height=8, samples=2, seed=1)
    medium = pc.Medium(absorption=0.8, density=1.5)
    out = pc.render(slab_scene(pc.Volume(medium, name="ink")), width=8, height=8, samples=2, seed=1)
    ratio = luminance(out.rgba) / luminance(clear.rgba)
    assert np.allclose(ratio, math.exp(-0.6), rtol=1e-4), ratio.mean()


def test_absorbing_glass_has_fresnel_and_beer_lambert():
    """Glass (n = 1.5) with σa = 1: T = (1 − R)²·τ/(1 − R²·τ²), τ = exp(−0.5)."""
    glass = pc.Dielectric(1.5, volume=pc.Medium(absorption=1.0))
    out = pc.render(slab_scene(glass), width=16, height=16, samples=64, max_bounces=64, seed=3)
    y = luminance(out.rgba)
    clear = luminance(pc.render(slab_scene(pc.Volume(pc.Medium())), width=4, height=4, samples=1).rgba).mean()
    r, tau = 0.04, math.exp(-0.5)
    expected = clear * (1 - r) ** 2 * tau / (1 - r * r * tau * tau)
    se = y.std(ddof=1) / math.sqrt(y.size)
    assert abs(y.mean() - expected) < 5 * se + 2e-3, (y.mean(), expected, se)


def test_medium_descriptions_and_bad_input():
    m = pc.Medium(absorption=(0.1, 0.5, 0.9), scattering=0.5, density=2.0, anisotropy=0.3, emission=(1.0, 0.5, 0.0))
    d = pc.Volume(m, name="smoke").to_dict()
    assert d["bsdf"] == {"type": "null"}
    v = d["volume"]
    assert v["absorption"] == {"type": "rgb", "rgb": [0.1, 0.5, 0.9], "scale": 2.0}
    assert v["scattering"] == {"type": "constant", "value": 0.5, "scale": 2.0} and v["anisotropy"] == 0.3
    assert "volume" in pc.Dielectric(1.33, volume=m).to_dict()
    with pytest.raises(ValueError, match="density"):
        pc.Medium(absorption=1.0, density=-1.0)
    with pytest.raises(ValueError, match="anisotropy"):
        pc.Medium(scattering=1.0, anisotropy=1.0)
    with pytest.raises(TypeError, match="'tea'"):
        pc.Dielectric(1.33, volume=0.5, name="tea")
    # A NaN density reaching the core is an error naming the material, not a NaN image.
    bad = pc.Medium(absorption=1.0)
    bad.density = float("nan")
    with pytest.raises(Exception, match="ink"):
        pc.render(slab_scene(pc.Volume(bad, name="ink")), width=4, height=4, samples=1)


def test_world_volume_and_a_camera_inside_a_box_are_beer_lambert():
    """The camera (z = 5, looking down at an emitter at z = −1 through a clear slab) inside
    an absorbing world σa = 0.1 (6 units: exp(−0.6)), inside a volume-only box z ∈ [4, 6]
    with σa = 0.5 (1 unit: exp(−0.5)), and inside both (they add)."""
    clear = luminance(pc.render(slab_scene(pc.Volume(pc.Medium())), width=4, height=4, samples=1).rgba)
    for world, box_medium, tau in [(0.1, None, 0.6), (None, 0.5, 0.5), (0.1, 0.5, 1.1)]:
        scene = slab_scene(pc.Volume(pc.Medium()))
        if world is not None:
            scene.world_volume = pc.Medium(absorption=world)
        if box_medium is not None:
            v, t = box((-3.0, -3.0, 4.0), (3.0, 3.0, 6.0))
            scene.add_mesh("tank", v, t, material=pc.Volume(pc.Medium(absorption=box_medium), name="tank"))
        out = pc.render(scene, width=4, height=4, samples=1)
        assert np.allclose(luminance(out.rgba) / clear, math.exp(-tau), rtol=1e-4), (world, box_medium)
    scene = slab_scene(pc.Volume(pc.Medium()))
    scene.world_volume = 0.5
    with pytest.raises(TypeError, match="World"):
        scene.description()
    bad = pc.Medium(absorption=1.0)
    bad.density = float("nan")
    scene.world_volume = bad
    with pytest.raises(Exception, match="world.volume"):
        pc.render(scene, width=4, height=4, samples=1)


def test_density_grid_ramp_is_beer_lambert_of_its_integral():
    """A volume-only slab (z in [0, 0.5]) whose density grid ramps along the view,
    ρ(z) = 4·z (voxel centres on the line, 8 layers): exp(−σa·∫ρ) = exp(−0.8·0.5) of
    the emitter, by ratio tracking (docs/media.md, "Grid media"); bad grids are errors."""
    nz = 8
    ramp = np.broadcast_to((4.0 * (np.arange(nz) + 0.5) * 0.5 / nz)[:, None, None], (nz, 2, 3))
    medium = pc.Medium(absorption=0.8, density_grid=ramp, grid_bounds=((-2, -2, 0), (2, 2, 0.5)))
    d = medium.to_dict()["density_grid"]
    assert d["dims"] == [3, 2, 8] and len(d["values"]) == 48 and d["bounds"] == [[-2, -2, 0], [2, 2, 0.5]]
    clear = pc.render(slab_scene(pc.Volume(pc.Medium())), width=4, height=4, samples=1)
    out = pc.render(slab_scene(pc.Volume(medium, name="smoke")), width=16, height=16, samples=64, seed=2)
    y = luminance(out.rgba) / luminance(clear.rgba).mean()
    se = y.std(ddof=1) / math.sqrt(y.size)
    assert abs(y.mean() - math.exp(-0.4)) < 5 * se + 2e-3, (y.mean(), math.exp(-0.4), se)
    with pytest.raises(ValueError, match="finite and non-negative"):
        pc.Medium(absorption=1.0, density_grid=-np.ones((2, 2, 2)), grid_bounds=((0, 0, 0), (1, 1, 1)))
    with pytest.raises(ValueError, match="grid_bounds"):
        pc.Medium(absorption=1.0, density_grid=np.ones((2, 2, 2)))
    with pytest.raises(ValueError, match="3-D"):
        pc.Medium(absorption=1.0, density_grid=np.ones((2, 2)), grid_bounds=((0, 0, 0), (1, 1, 1)))
