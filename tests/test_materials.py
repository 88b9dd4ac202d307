"""Glass, metals, spot and sun lights through the Python API, checked against closed
forms (Fresnel, inverse-square law) computed here."""

from __future__ import annotations

import math

import numpy as np
import pytest

import polychrome as pc
from polychrome import ior
from meshes import box, square


def luminance(rgba: np.ndarray) -> np.ndarray:
    return 0.2126 * rgba[..., 0] + 0.7152 * rgba[..., 1] + 0.0722 * rgba[..., 2]


def top_camera(width: float) -> pc.Camera:
    m = np.eye(4)
    m[2, 3] = 5.0
    return pc.Camera(to_world=m, projection="ORTHOGRAPHIC", ortho_scale=width)


def slab_scene(glass: pc.Material) -> pc.Scene:
    scene = pc.Scene()
    scene.camera = top_camera(1.0)
    v, t = box((-2.0, -2.0, 0.0), (2.0, 2.0, 0.5))
    scene.add_mesh("slab", v, t, material=glass)
    v, t = square(4.0, -1.0)
    scene.add_mesh("lamp", v, t, material=pc.Emitter(pc.spectra.constant(1.0)))
    return scene


@pytest.mark.parametrize("n", [1.0001, 1.5, 4.0])
def test_glass_slab_transmits_fresnel(n):
    """Looking through a slab at normal incidence: T = (1 − R)/(1 + R) with
    R = ((n − 1)/(n + 1))² (all internal reflections summed)."""
    out = pc.render(slab_scene(pc.Dielectric(n)), width=16, height=16, samples=32, max_bounces=64, seed=1)
    y = luminance(out.rgba)
    r = ((n - 1) / (n + 1)) ** 2
    expected = (1 - r) / (1 + r)
    se = y.std(ddof=1) / math.sqrt(y.size) + 1e-9
    assert abs(y.mean() - expected) < 5 * se + 2e-3, (y.mean(), expected, se)
    assert out.stats["nonfinite_samples"] == 0


def test_dispersive_slab_transmits_like_its_d_line_index():
    """N-BK7 at normal incidence: dispersion moves no ray, and T(λ) varies by < 0.2 %
    over the visible, so the luminance is T at nd = 1.5168."""
    out = pc.render(slab_scene(pc.Dielectric(ior.named("N-BK7"))), width=16, height=16, samples=64, max_bounces=64, seed=2)
    y = luminance(out.rgba)
    r = ((1.5168 - 1) / (1.5168 + 1)) ** 2
    expected = (1 - r) / (1 + r)
    se = y.std(ddof=1) / math.sqrt(y.size)
    assert abs(y.mean() - expected) < 5 * se + 4e-3, (y.mean(), expected, se)


def test_metal_mirror_reflects_conductor_fresnel():
    """A smooth conductor facing the camera under a white world: L = R(0) =
    ((n − 1)² + k²)/((n + 1)² + k²)."""
    n, k = 0.2, 3.0
    scene = pc.Scene()
    scene.camera = top_camera(1.0)
    v, t = square(2.0, 0.0)
    scene.add_mesh("mirror", v, t, material=pc.Conductor(eta=n, k=k))
    scene.set_world(pc.spectra.constant(1.0))
    out = pc.render(scene, width=4, height=4, samples=2, max_bounces=4)
    expected = ((n - 1) ** 2 + k**2) / ((n + 1) ** 2 + k**2)
    assert np.allclose(luminance(out.rgba), expected, rtol=2e-3)


def test_gold_is_yellow_and_glossy_white_is_a_mirror():
    scene = pc.Scene()
    scene.camera = top_camera(1.0)
    v, t = square(2.0, 0.0)
    scene.add_mesh("gold", v, t, material=pc.Conductor("gold"))
    scene.set_world(pc.spectra.constant(1.0))
    out = pc.render(scene, width=4, height=4, samples=1, max_bounces=4)
    r, g, b = out.rgba[..., 0].mean(), out.rgba[..., 1].mean(), out.rgba[..., 2].mean()
    assert r > g > b and r > 1.5 * b
    scene.materials[0] = pc.Glossy(1.0, roughness=0.0)
    white = pc.render(scene, width=4, height=4, samples=1, max_bounces=4)
    assert np.allclose(luminance(white.rgba), 1.0, rtol=2e-3)


def test_spot_light_matches_blender_power_convention():
    """Blender: a spot of P watts has intensity P/4π on its axis; under it a diffuse
    plane of albedo ρ shows ρ/π · I/h² at the centre and nothing outside the cone."""
    rho, power, h = 0.6, 50.0, 2.0
    scene = pc.Scene()
    scene.camera = top_camera(4.0)
    v, t = square(4.0, 0.0)
    scene.add_mesh("floor", v, t, material=pc.Diffuse(pc.spectra.constant(rho)))
    scene.add_light(
        pc.SpotLight((0, 0, h), (0, 0, -1), power=power, color=pc.spectra.constant(1.0), spot_size=math.radians(40), spot_blend=0.0)
    )
    out = pc.render(scene, width=21, height=21, samples=8, max_bounces=1)
    y = luminance(out.rgba)
    expected = rho / math.pi * power / (4 * math.pi) / h**2
    assert abs(y[10, 10] - expected) < 5e-3 * expected
    assert y[0, 0] == 0.0 and y[10, 0] == 0.0


def test_sun_irradiance():
    rho, e, theta = 0.5, 3.0, 0.4
    scene = pc.Scene()
    scene.camera = top_camera(1.0)
    v, t = square(2.0, 0.0)
    scene.add_mesh("floor", v, t, material=pc.Diffuse(pc.spectra.constant(rho)))
    scene.add_light(pc.SunLight((math.sin(theta), 0.0, -math.cos(theta)), strength=e, color=pc.spectra.constant(1.0)))
    out = pc.render(scene, width=4, height=4, samples=1, max_bounces=1)
    assert np.allclose(luminance(out.rgba), rho / math.pi * e * math.cos(theta), rtol=2e-3)


def test_fraunhofer_lines_and_catalogue_come_from_the_core():
    # SCHOTT TIE-29 / ISO 7944: He d 587.5618 nm, H F 486.1327 nm, H C 656.2725 nm (one definition, in the core)
    assert (ior.LAMBDA_D, ior.LAMBDA_F, ior.LAMBDA_C) == (587.5618, 486.1327, 656.2725)
    bk7 = ior.named("N-BK7")
    nd, nf, nc = (bk7.index_at(lam) for lam in (ior.LAMBDA_D, ior.LAMBDA_F, ior.LAMBDA_C))
    # SCHOTT's N-BK7 data sheet: nd 1.51680, nF 1.52238, nC 1.51432, Vd 64.17
    assert nd == pytest.approx(1.51680, abs=2e-5) and nf == pytest.approx(1.52238, abs=2e-5)
    assert nc == pytest.approx(1.51432, abs=2e-5) and (nd - 1) / (nf - nc) == pytest.approx(64.17, abs=0.05)
    assert set(ior.GLASSES) >= {"N-BK7", "Fused Silica", "N-SF11", "Water", "Diamond"}
    assert ior.GLASSES["N-BK7"]["nd"] == 1.5168
    # a Sellmeier pole is NaN in the readout, not an exception
    assert math.isnan(ior.sellmeier([1.0], [0.25]).index_at(500.0))


def test_ior_helpers_and_errors():
    a, b = ior.abbe_to_cauchy(1.5168, 64.17)
    n = lambda nm: a + b / (nm * 1e-3) ** 2  # noqa: E731
    assert abs(n(ior.LAMBDA_D) - 1.5168) < 1e-12
    assert abs((n(ior.LAMBDA_D) - 1) / (n(ior.LAMBDA_F) - n(ior.LAMBDA_C)) - 64.17) < 1e-9
    assert pc.Dielectric("N-BK7").bsdf_dict()["ior"] == {"type": "named", "name": "N-BK7"}
    assert ior.sellmeier([1.0], [0.01]).to_dict()["b"] == [1.0, 0.0, 0.0]
    with pytest.raises(ValueError, match="roughness"):
        pc.Dielectric(1.5, roughness=2.0)
    with pytest.raises(ValueError, match="Abbe"):
        ior.abbe(1.5, 0.0)
    with pytest.raises(ValueError):
        pc.Conductor()
    scene = slab_scene(pc.Dielectric(ior.named("N-ZZ99"), name="Mystery"))
    with pytest.raises(Exception, match="Mystery.*N-ZZ99"):
        pc.render(scene, width=2, height=2, samples=1)
    pole = ior.sellmeier([1.0, 0, 0], [0.5**2, 0, 0])
    with pytest.raises(Exception, match="pole"):
        pc.render(slab_scene(pc.Dielectric(pole, name="Pole")), width=2, height=2, samples=1)
