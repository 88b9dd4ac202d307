"""Principled, Mix and Add through the Python API, against closed forms computed here:
Fresnel at normal incidence, thin-film interference per wavelength (transfer-matrix
formula written independently of the core's Airy sum), a white Principled base in a
white world, and the mix of two diffuse colours."""

from __future__ import annotations

import math

import numpy as np
import pytest

import polychrome as pc

from meshes import pole_sphere


def luminance(rgba: np.ndarray) -> np.ndarray:
    return 0.2126 * rgba[..., 0] + 0.7152 * rgba[..., 1] + 0.0722 * rgba[..., 2]


def plane_scene(material: pc.Material) -> pc.Scene:
    """A large plane at z = 0 seen straight down by an orthographic camera (normal
    incidence everywhere), under a world of radiance 1 at every wavelength."""
    scene = pc.Scene()
    m = np.eye(4)
    m[2, 3] = 5.0
    scene.camera = pc.Camera(to_world=m, projection="ORTHOGRAPHIC", ortho_scale=1.0)
    v = np.array([[-4, -4, 0], [4, -4, 0], [4, 4, 0], [-4, 4, 0]], dtype=np.float32)
    scene.add_mesh("plane", v, np.array([[0, 1, 2], [0, 2, 3]]), material=material)
    scene.set_world(pc.spectra.constant(1.0))
    return scene


@pytest.mark.parametrize("n,level", [(1.33, 0.5), (1.5, 0.5), (2.4, 0.5), (1.5, 0.0), (1.5, 0.8)])
def test_black_base_reflects_normal_incidence_fresnel(n, level):
    """((n − 1)/(n + 1))², scaled by 2·level (Blender's Specular IOR Level)."""
    scene = plane_scene(pc.Principled((0.0, 0.0, 0.0), roughness=0.0, ior=n, specular_ior_level=level))
    out = pc.render(scene, width=4, height=4, samples=2, max_bounces=4)
    expected = ((n - 1) / (n + 1)) ** 2 * 2 * level
    assert np.allclose(luminance(out.rgba), expected, rtol=2e-3, atol=1e-6), (luminance(out.rgba).mean(), expected)


def film_reflectance(lam: np.ndarray, d: float, n1: float, n2: float) -> np.ndarray:
    """Normal-incidence reflectance of one film (n1, d) on a substrate n2 from air, by
    the characteristic matrix [[cos δ, i sin δ/n1], [i n1 sin δ, cos δ]] (Macleod)."""
    delta = 2 * np.pi * n1 * d / lam
    b = np.cos(delta) + 1j * np.sin(delta) * n2 / n1
    c = 1j * n1 * np.sin(delta) + n2 * np.cos(delta)
    r = (b - c) / (b + c)
    return np.abs(r) ** 2


def test_thin_film_interference_is_spectral():
    """A quarter-wave film (n = √1.5, d = 550/(4n) nm) on a smooth black-base Principled:
    the spectral pass holds the textbook film reflectance at every grid wavelength
    (zero at 550 nm), which no RGB product can reproduce."""
    n_sub = 1.5
    n_film = math.sqrt(n_sub)
    d = 550.0 / (4 * n_film)
    mat = pc.Principled(0.0, roughness=0.0, ior=n_sub, thin_film_thickness=d, thin_film_ior=n_film)
    out = pc.render(plane_scene(mat), width=2, height=2, samples=1, max_bounces=4, wavelength_count=41, spectral_output=True)
    spectrum = out.spectral.reshape(-1, out.spectral.shape[-1]).mean(axis=0)
    expected = film_reflectance(np.asarray(out.wavelengths, dtype=np.float64), d, n_film, n_sub)
    assert np.allclose(spectrum, expected, atol=2e-5), np.c_[out.wavelengths, spectrum, expected]
    i550 = int(np.argmin(np.abs(out.wavelengths - 550.0)))
    assert spectrum[i550] < 1e-5
    # Without the film: the flat 4 % of bare glass.
    bare = pc.render(
        plane_scene(pc.Principled(0.0, roughness=0.0, ior=n_sub)),
        width=2,
        height=2,
        samples=1,
        max_bounces=4,
        wavelength_count=41,
        spectral_output=True,
    )
    assert np.allclose(bare.spectral, 0.04, atol=1e-5)


def convex_scene(material: pc.Material) -> pc.Scene:
    """A sphere filling the view under a uniform white (D65-shaped, luminance 1) world:
    a convex object sees only the world, so its radiance is (directional albedo) × world."""
    scene = pc.Scene()
    scene.camera = pc.Camera.looking_at((0, -6, 0), (0, 0, 0), focal_length=200.0)  # the sphere fills the frame
    v, t = pole_sphere(rings=24, segments=48)
    scene.add_mesh("ball", v, t, material=material)
    scene.set_world((1.0, 1.0, 1.0))
    return scene


def on_sphere(out) -> np.ndarray:
    """RGB of the pixels that see the sphere (non-zero normal pass), every pixel."""
    hit = np.linalg.norm(out.normal, axis=-1) > 0.5
    assert hit.all(), hit.mean()
    return out.rgba[..., :3][hit]


def test_white_principled_base_is_invisible_in_a_white_world():
    """Energy conservation: a white base under the specular layer returns all the light
    at every angle, so in a uniform world the sphere has the world's colour (1, 1, 1)."""
    for roughness in (0.0, 0.5, 1.0):
        out = pc.render(convex_scene(pc.Principled((1.0, 1.0, 1.0), roughness=roughness)), width=16, height=16, samples=32, max_bounces=4)
        rgb = on_sphere(out)
        assert np.allclose(rgb.mean(axis=0), 1.0, atol=0.01), (roughness, rgb.mean(axis=0))
        assert out.stats["nonfinite_samples"] == 0


def test_white_coat_and_sheen_over_a_white_base_are_invisible_in_a_white_world():
    """White furnace through the layers: a coat of weight 1 and white tint (smooth or
    rough), and a white sheen over it, take from the layers below exactly what they
    reflect (Cycles' closure_layering_weight), so the sphere keeps the world's colour."""
    for kw in (
        dict(coat_weight=1.0, coat_roughness=0.0),
        dict(coat_weight=1.0, coat_roughness=0.4, coat_ior=1.8),
        dict(coat_weight=1.0, coat_roughness=0.2, sheen_weight=1.0, sheen_roughness=0.3),
    ):
        mat = pc.Principled((1.0, 1.0, 1.0), roughness=0.5, **kw)
        out = pc.render(convex_scene(mat), width=12, height=12, samples=32, max_bounces=6)
        rgb = on_sphere(out).mean(axis=0)
        assert np.allclose(rgb, 1.0, atol=0.015), (kw, rgb)
        assert out.stats["nonfinite_samples"] == 0


def test_coat_tint_and_specular_tint_closed_forms_at_normal_incidence():
    """Seen straight down, a smooth coat of tint t over a white diffuse base in a white
    world returns F_c + (1 − F_c)·t (Beer's law through the coat at normal incidence:
    t¹, Cycles' coat_tint^(1/cos θt)); a smooth dielectric with Specular Tint s over a
    black base reflects F0·s ((n − 1)/(n + 1))² per channel."""
    t = 0.5
    fc = ((1.5 - 1) / (1.5 + 1)) ** 2
    mat = pc.Principled(1.0, roughness=0.3, coat_weight=1.0, coat_roughness=0.0, coat_tint=t)
    out = pc.render(plane_scene(mat), width=4, height=4, samples=256, max_bounces=8)
    got = luminance(out.rgba).mean()
    assert got == pytest.approx(fc + (1 - fc) * t, rel=0.01), got
    d = pc.Principled(coat_weight=1.0, coat_tint=(0.5, 0.5, 0.5), sheen_weight=0.3).bsdf_dict()
    assert d["coat"]["tint"]["rgb"] == [0.5, 0.5, 0.5] and d["sheen"] == {"weight": 0.3, "roughness": 0.5}
    for s in (1.0, 0.5, 0.1):
        out = pc.render(
            plane_scene(pc.Principled(0.0, roughness=0.0, ior=1.5, specular_tint=s)), width=4, height=4, samples=2, max_bounces=4
        )
        assert np.allclose(luminance(out.rgba), fc * s, rtol=3e-3), (s, luminance(out.rgba).mean())


def test_mix_of_red_and_blue_diffuse_is_the_mixed_colour():
    """Mix(a, b, t) of two diffuse colours = diffuse (1 − t)·a + t·b: in a white world a
    convex diffuse object shows its reflectance's colour (the uplift round-trips RGB
    under the D65 white)."""
    red, blue = (0.8, 0.1, 0.1), (0.1, 0.1, 0.8)
    for t in (0.0, 0.5, 0.8):
        mat = pc.Mix(pc.Diffuse(red), pc.Diffuse(blue), t)
        out = pc.render(convex_scene(mat), width=12, height=12, samples=16, max_bounces=2)
        got = on_sphere(out).mean(axis=0)
        expected = (1 - t) * np.array(red) + t * np.array(blue)
        assert np.allclose(got, expected, atol=0.01), (t, got, expected)


def test_add_and_mix_emission_and_description():
    a = pc.Diffuse(0.5, emission=(1.0, 0.0, 0.0))
    b = pc.Principled(
        (0.2, 0.3, 0.4), metallic=0.3, transmission=0.2, ior=pc.ior.named("N-BK7"), specular_tint=(1.0, 0.9, 0.8), thin_film_thickness=300.0
    )
    m = pc.Mix(a, b, 0.25)

    def rgb(e):
        return [c * e.scale for c in e.params["rgb"]]

    assert m.emission.kind == "rgb" and rgb(m.emission) == pytest.approx([0.75, 0.0, 0.0])
    d = m.bsdf_dict()
    assert d["type"] == "mix" and d["factor"] == 0.25 and d["a"]["type"] == "diffuse"
    assert d["b"]["type"] == "principled" and d["b"]["thin_film_thickness"] == 300.0 and d["b"]["ior"]["type"] == "named"
    add = pc.Add(pc.Mix(a, b), pc.Emitter((0.0, 1.0, 0.0)))
    assert rgb(add.emission) == pytest.approx([0.5, 1.0, 0.0])
    assert add.bsdf_dict()["b"] == {"type": "none"}
    # Renders (nested mix, dispersive glass lobe) with finite values.
    out = pc.render(convex_scene(add), width=6, height=6, samples=4, max_bounces=6)
    assert np.all(np.isfinite(out.rgba)) and out.stats["nonfinite_samples"] == 0


def test_bad_parameters_are_value_errors_naming_the_material():
    with pytest.raises(ValueError, match="material 'P'"):
        pc.Principled(metallic=1.2, name="P")
    with pytest.raises(ValueError, match="thin_film_ior"):
        pc.Principled(thin_film_thickness=100.0, thin_film_ior=0.5, name="P")
    with pytest.raises(ValueError, match="coat_ior"):
        pc.Principled(coat_weight=1.0, coat_ior=0.5, name="P")
    with pytest.raises(ValueError, match="sheen_weight"):
        pc.Principled(sheen_weight=float("nan"), name="P")
    with pytest.raises(ValueError, match="material 'M'"):
        pc.Mix(pc.Diffuse(), pc.Diffuse(), 1.5, name="M")
    with pytest.raises(TypeError):
        pc.Mix(pc.Diffuse(), 0.5)
    # The core rejects a base colour above 1 (energy) naming the material.
    scene = plane_scene(pc.Principled(2.0, name="Bright"))
    with pytest.raises(ValueError, match="material 'Bright'"):
        pc.render(scene, width=2, height=2, samples=1)


def test_fresnel_mix_factor_is_view_dependent():
    """Mix(red, blue, Fresnel(1.5)) seen at normal incidence: (1 − F0)·red + F0·blue with
    F0 = 4 %; with LayerWeight(0.5, "FACING") the factor is 1 − cos θ = 0: pure red."""
    red, blue = np.array([0.8, 0.1, 0.1]), np.array([0.1, 0.1, 0.8])
    world = (1.0, 1.0, 1.0)
    for factor, t in ((pc.Fresnel(1.5), 0.04), (pc.LayerWeight(0.5, "FACING"), 0.0), (pc.LayerWeight(0.5), 1.0 / 9.0)):
        scene = plane_scene(pc.Mix(pc.Diffuse(tuple(red)), pc.Diffuse(tuple(blue)), factor))
        scene.set_world(world)
        out = pc.render(scene, width=4, height=4, samples=16, max_bounces=2)
        got = out.rgba[..., :3].reshape(-1, 3).mean(axis=0)
        expected = (1 - t) * red + t * blue
        assert np.allclose(got, expected, atol=0.01), (factor, got, expected)
    d = pc.Mix(pc.Diffuse(), pc.Diffuse(), pc.LayerWeight(0.3, "facing")).bsdf_dict()
    assert d["factor_from"] == {"type": "layer_weight_facing", "blend": 0.3}
    with pytest.raises(ValueError, match="blend"):
        pc.Mix(pc.Diffuse(), pc.Diffuse(), pc.LayerWeight(1.5))


def test_textured_base_colour_of_principled_and_inside_mix():
    """A Principled base colour and a Diffuse inside a Mix may be image textures
    (converted per hit): a white texture under the layer is invisible in a white world
    (energy conservation), and a Mix of a red-textured and a blue diffuse at 0.5 is the
    mixed colour."""
    white = pc.Texture.from_array(np.ones((4, 4, 3), np.float32), name="white")
    out = pc.render(convex_scene(pc.Principled(white, roughness=0.4)), width=12, height=12, samples=32, max_bounces=4)
    assert np.allclose(on_sphere(out).mean(axis=0), 1.0, atol=0.01)
    red = pc.Texture.from_array(np.tile(np.array([0.8, 0.1, 0.1], np.float32), (4, 4, 1)), name="red")
    out = pc.render(convex_scene(pc.Mix(pc.Diffuse(red), pc.Diffuse((0.1, 0.1, 0.8)), 0.5)), width=12, height=12, samples=16, max_bounces=2)
    assert np.allclose(on_sphere(out).mean(axis=0), [0.45, 0.1, 0.45], atol=0.01)


def test_subsurface_white_sphere_is_invisible_under_a_coat_in_a_white_world():
    """The subsurface random walk through the Python API (Blender's inputs): a white
    sphere whose base all walks (albedo 1, a chromatic radius of its own size) under the
    specular layer and a coat returns every bit of light that entered, so it keeps the
    world's colour; and it does not warn on the default BACKWARD direction."""
    mat = pc.Principled(
        (1.0, 1.0, 1.0),
        subsurface_weight=1.0,
        subsurface_radius=(1.0, 0.5, 0.25),
        subsurface_scale=8.0,
        subsurface_anisotropy=0.3,
        coat_weight=1.0,
        coat_roughness=0.2,
    )
    assert mat.bsdf_dict()["subsurface"]["radius"] == [1.0, 0.5, 0.25]
    out = pc.render(convex_scene(mat), width=12, height=12, samples=128, max_bounces=16)
    rgb = on_sphere(out).mean(axis=0)
    assert np.allclose(rgb, 1.0, atol=0.015), rgb
    assert out.stats["nonfinite_samples"] == 0
    assert not [w for w in out.stats.get("warnings", []) if "subsurface" in w]


@pytest.mark.parametrize(
    "kw", [dict(subsurface_radius=(1.0, float("nan"), 0.1)), dict(subsurface_radius=(-1.0, 0.2, 0.1)), dict(subsurface_scale=-0.1)]
)
def test_subsurface_bad_radius_is_rejected_naming_the_material(kw):
    with pytest.raises(ValueError, match="'wax'.*subsurface"):
        pc.Principled(0.8, subsurface_weight=1.0, name="wax", **kw)
