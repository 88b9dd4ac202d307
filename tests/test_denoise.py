"""Denoising with Open Image Denoise (the `denoise` setting: polychrome.denoise, pc.render, RenderJob, the CLI).

The reference is the same scene rendered converged (2048 spp); ΔE00 comes from
colour-science, not from polychrome.colordiff. OIDN is a trained network, so the factor
by which it helps is measured (docs/denoise.md) and asserted with a margin."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
import pytest

import polychrome as pc
from polychrome import denoise

pytest.importorskip("pyoidn")
colour = pytest.importorskip("colour")

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples"))


def mean_de00(a, b) -> float:
    """Mean CIEDE2000 between two linear-sRGB images (white Y = 1), by colour-science."""
    cs = colour.RGB_COLOURSPACES["sRGB"]
    lab = [
        colour.XYZ_to_Lab(colour.RGB_to_XYZ(np.asarray(x, np.float64)[..., :3], cs, apply_cctf_decoding=False), cs.whitepoint)
        for x in (a, b)
    ]
    return float(np.mean(colour.delta_E(lab[0], lab[1], method="CIE 2000")))


def cornell():
    from cornell_box import build_scene

    return build_scene()


SIZE = 48
COMMON = dict(width=SIZE, height=SIZE, wavelength_count=41, max_bounces=8, noise_threshold=0.0)


@pytest.fixture(scope="module")
def reference():
    return pc.render(cornell(), samples=2048, seed=99, **COMMON)


def test_denoised_cornell_box_is_closer_to_the_converged_reference(reference):
    r = pc.render(cornell(), samples=16, seed=1, denoise=True, **COMMON)
    noisy, denoised = mean_de00(r.noisy, reference.rgba), mean_de00(r.rgba, reference.rgba)
    print(f"16 spp: noisy {noisy:.3f}, denoised {denoised:.3f} (x{noisy / denoised:.2f})")
    # Measured 2.17 -> 1.09 (x2.0); the reference's own noise (~0.2) is part of both.
    assert denoised * 1.7 < noisy
    assert np.isfinite(r.rgba).all() and r.rgba.shape == (SIZE, SIZE, 4)
    np.testing.assert_array_equal(r.rgba[..., 3], r.noisy[..., 3])
    assert r.stats["denoiser"].startswith("Open Image Denoise 2.5")
    # Prefiltering the aux images (the default) beats handing OIDN the noisy ones.
    raw_aux = mean_de00(denoise.denoise(r.noisy, r.albedo, r.normal, prefilter=False), reference.rgba)
    assert denoised < raw_aux, (denoised, raw_aux)


def test_flat_regions_stay_flat():
    rng = np.random.default_rng(7)
    h, w = 64, 64
    clean = np.empty((h, w, 4), np.float32)
    clean[..., :3] = (0.6, 0.4, 0.2)
    clean[..., 3] = 1
    noisy = clean.copy()
    noisy[..., :3] *= rng.gamma(4.0, 0.25, (h, w, 1)).astype(np.float32)  # mean 1, 50% noise
    albedo = np.full((h, w, 3), 0.5, np.float32)
    normal = np.zeros((h, w, 3), np.float32)
    normal[..., 2] = 1
    out = denoise.denoise(noisy, albedo, normal)
    inner = out[8:-8, 8:-8, :3]
    # Flat in, flat out: no invented structure, and the level kept.
    assert inner.std(axis=(0, 1)).max() < 0.1 * noisy[..., :3].std(axis=(0, 1)).max()
    np.testing.assert_allclose(inner.mean(axis=(0, 1)), clean[0, 0, :3], rtol=0.05)
    # A noise-free flat image stays what it is away from the image border (OIDN pads the
    # border; measured: up to 24% off in the outermost pixels of a constant image).
    still = denoise.denoise(clean, albedo, normal)[..., :3]
    np.testing.assert_allclose(still[4:-4, 4:-4], clean[4:-4, 4:-4, :3], rtol=0.02)


def test_non_finite_and_negative_input_never_reaches_the_output():
    rng = np.random.default_rng(3)
    img = rng.uniform(0, 1, (32, 32, 4)).astype(np.float32)
    img[3, 4, 0], img[10, 10, 1], img[20, 5, 2], img[7, 7, 0] = np.nan, np.inf, -np.inf, -5.0
    albedo = rng.uniform(0, 1, (32, 32, 3)).astype(np.float32)
    albedo[1, 1] = np.nan
    out = denoise.denoise(img, albedo, None)
    assert np.isfinite(out).all() and (out[..., :3] >= 0).all()


def test_shapes_and_options_are_checked():
    img = np.zeros((8, 8, 4), np.float32)
    with pytest.raises(ValueError, match="albedo"):
        denoise.denoise(img, None, np.zeros((8, 8, 3), np.float32))
    with pytest.raises(ValueError, match="shape"):
        denoise.denoise(img, np.zeros((4, 8, 3), np.float32))
    with pytest.raises(ValueError, match="quality"):
        denoise.denoise(img, quality="best")


def test_missing_package_is_named_before_the_render(monkeypatch):
    monkeypatch.setitem(sys.modules, "pyoidn", None)  # import pyoidn now raises ImportError
    assert not denoise.available()
    with pytest.raises(ImportError, match=r"'pyoidn'.*polychrome\[denoise\]"):
        pc.render(cornell(), width=4, height=4, samples=1, denoise=True)
    with pytest.raises(ImportError, match="pyoidn"):
        pc.RenderJob(cornell(), width=4, height=4, samples=1, denoise_previews=True)
    pc.render(cornell(), width=4, height=4, samples=1)  # without denoise nothing needs it


def test_too_large_for_memory_is_refused_with_the_size(monkeypatch):
    monkeypatch.setattr(denoise, "_free_memory_bytes", lambda: 10 * 2**20)
    with pytest.raises(MemoryError, match=r"a 4000x3000 image needs about .* GiB"):
        denoise.denoise(np.zeros((3000, 4000, 3), np.float32))


def test_exr_passes_keep_the_noisy_image_and_the_denoising_data(tmp_path):
    from polychrome import imageio

    r = pc.render(cornell(), width=16, height=12, samples=4, denoise=True)
    path = r.save(tmp_path / "d.exr", passes=True)
    ch = imageio._read_exr_channels(path)
    for name in ["Combined.R", "Noisy Image.R", "Noisy Image.A", "Denoising Albedo.G", "Denoising Normal.X", "Denoising Normal.Z"]:
        assert name in ch, sorted(ch)
    np.testing.assert_allclose(ch["Noisy Image.G"], r.noisy[..., 1], rtol=1e-3, atol=1e-6)
    np.testing.assert_allclose(ch["Combined.G"], r.rgba[..., 1], rtol=1e-3, atol=1e-6)
    assert not np.allclose(ch["Combined.G"], ch["Noisy Image.G"])


def test_render_job_denoises_result_and_previews():
    job = pc.RenderJob(cornell(), width=16, height=12, samples=8, seed=2, denoise=True, denoise_previews=True).start()
    result = job.result()
    plain = pc.render(cornell(), width=16, height=12, samples=8, seed=2)
    np.testing.assert_array_equal(result.noisy, plain.rgba)  # the same samples, denoised after
    np.testing.assert_allclose(result.rgba, denoise.denoise(plain.rgba, plain.albedo, plain.normal), atol=1e-5)
    last = job.preview()
    assert last.last and np.array_equal(last.rgba, result.rgba)


def test_cli_denoise_flag_writes_the_denoised_image_and_passes(tmp_path):
    pytest.importorskip("pxr")
    from polychrome import cli, imageio, usd

    stage = usd.write_stage(cornell(), tmp_path / "box.usda", pc.RenderSettings(width=16, height=12, samples=4, seed=1))
    out = tmp_path / "box.exr"
    assert cli.main(["render", str(stage), "-o", str(out), "--quiet", "--denoise", "--passes"]) == 0
    ch = imageio._read_exr_channels(out)
    assert {"Noisy Image.R", "Denoising Albedo.R", "Denoising Normal.X"} <= set(ch)
    assert np.isfinite(ch["Combined.R"]).all() and not np.allclose(ch["Combined.R"], ch["Noisy Image.R"])


def through_specular_scene(front: str, ior=1.5, wall_reflectance=None) -> pc.Scene:
    """An orthographic camera at the origin looking along +y at a wall (y = 2) of one
    colour; in the middle third of the view a perfect mirror (y = 1, facing the camera)
    or a glass slab (y = 1 to 1.1). With the mirror, behind the camera (y = −1) a wall of
    the same colour, which the mirror shows; with the glass nothing there, so light the
    slab reflects leaves the scene. Every ray meets the surfaces at normal incidence."""
    scene = pc.Scene()
    wall = scene.add_material(pc.Diffuse(wall_reflectance or pc.spectra.rgb(0.7, 0.3, 0.1), name="wall"))

    def quad(name, y, x0, x1, z0, z1, m, facing):  # facing: -1 towards the camera (−y)
        p = np.array([[x0, y, z0], [x1, y, z0], [x1, y, z1], [x0, y, z1]], np.float32)
        tris = np.array([[0, 1, 2], [0, 2, 3]]) if facing < 0 else np.array([[0, 2, 1], [0, 3, 2]])
        scene.add_mesh(name, p, tris, material=m)

    quad("front wall", 2.0, -2, 2, -2, 2, wall, -1)
    if front == "mirror":
        quad("back wall", -1.0, -2, 2, -2, 2, wall, +1)
        mirror = scene.add_material(pc.Conductor(eta=0.2, k=3.0, name="mirror"))
        quad("mirror", 1.0, -0.15, 0.15, -1, 1, mirror, -1)
    else:
        glass = scene.add_material(pc.Dielectric(ior, name="glass"))
        x0, x1, y0, y1, z0, z1 = -0.15, 0.15, 1.0, 1.1, -1.0, 1.0
        v = np.array([[x, y, z] for z in (z0, z1) for y in (y0, y1) for x in (x0, x1)], np.float32)
        # A closed box, outward faces (vertex k: x bit 0, y bit 1, z bit 2).
        faces = [[0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5], [0, 2, 3, 1], [4, 5, 7, 6]]
        tris = np.array([t for a, b, c, d in faces for t in ([a, b, c], [a, c, d])])
        scene.add_mesh("slab", v, tris, material=glass)
    scene.camera = pc.Camera.looking_at((0, 0, 0), (0, 1, 0), up=(0, 0, 1), projection="ORTHOGRAPHIC", ortho_scale=0.9)
    return scene


@pytest.mark.parametrize("front", ["mirror", "glass"])
def test_aux_passes_see_through_mirrors_and_glass(front):
    """The albedo pass behind a perfect mirror / a glass slab is the wall's albedo times
    the mirror's normal-incidence reflectance R0 = ((n−1)² + k²)/((n+1)² + k²), or the
    slab's transmittance with its internal reflections, (1 − F0)/(1 + F0) with
    F0 = ((n−1)/(n+1))²; the normal pass is the wall's there (through the mirror the
    wall behind the camera, facing +y), as OIDN expects."""
    samples = 8 if front == "mirror" else 256
    r = pc.render(
        through_specular_scene(front), width=30, height=30, samples=samples, quality="FINAL", max_bounces=16, seed=2, wavelength_count=16
    )
    wall = r.albedo[:, 2:8].reshape(-1, 3)  # seen directly at the sides
    behind = r.albedo[:, 13:17].reshape(-1, 3)  # the middle: through the mirror or the slab
    assert np.allclose(wall, wall[0], rtol=1e-4) and wall[0, 0] > 2 * wall[0, 2] > 0, wall[0]
    if front == "mirror":
        n, k = 0.2, 3.0
        expected = ((n - 1) ** 2 + k**2) / ((n + 1) ** 2 + k**2)
        ratio = behind.mean(axis=0) / wall[0]
        np.testing.assert_allclose(ratio, expected, rtol=2e-3)
        # The wall behind the camera faces +y; the mirror and the front wall face −y.
        assert r.normal[15, 15, 1] > 0.99 and r.normal[15, 4, 1] < -0.99, (r.normal[15, 15], r.normal[15, 4])
    else:
        f0 = ((1.5 - 1) / (1.5 + 1)) ** 2
        expected = (1 - f0) / (1 + f0)
        ratio = behind.mean(axis=0) / wall[0]
        # 256 spp × 120 pixels of a Bernoulli (reflected paths escape, adding 0): σ ≈ 0.1 %.
        np.testing.assert_allclose(ratio, expected, rtol=4e-3)
        # Grey glass keeps the wall's colour: a chain that Russian roulette ends inside the
        # slab adds nothing (keeping the glass' white albedo there made B 1 % high).
        np.testing.assert_allclose(ratio, ratio.mean(), rtol=1e-4)
        assert abs(r.normal[15, 15, 1]) > 0.95


# A strongly dispersive Cauchy glass: n = 2.13 at 380 nm, 1.50 at 780 nm.
CAUCHY_A, CAUCHY_B = 1.3, 0.12


@pytest.mark.parametrize(
    "dispersive, how",
    [
        (False, {}),
        (True, {}),
        (True, {"dispersion_splitting": True}),
        (True, {"method": "HERO"}),
        (True, {"method": "MONOCHROMATIC_RAYS"}),
    ],
    ids=["constant n=1.5", "Cauchy, collapse", "Cauchy, splitting", "Cauchy, hero", "Cauchy, monochromatic rays"],
)
def test_albedo_through_a_dispersive_slab_matches_the_closed_form(dispersive, how):
    """Behind a glass slab at normal incidence a wall of constant reflectance ρ has
    albedo ρ·T(λ), T = (1 − F)/(1 + F) with F = ((n(λ) − 1)/(n(λ) + 1))² (both faces and
    the internal reflections), at each wavelength's own index even though the path
    carries one wavelength past a dispersive glass (eq. 9). The pass integrates
    ρ·T(λ)·D65(λ) against the CIE 1931 observer with the grid's quadrature, normalised
    to Y(D65) = 1, to linear sRGB: computed here with colour-science's tables. A
    dispersive glass makes T fall towards the blue, so the pass is tinted; the constant
    glass (n = 1.5) gives a grey one. Past the dispersive glass the path collapses to
    one wavelength (eq. 9), splits into one per wavelength, goes on with its hero
    wavelength, or carries one from the camera on: the pass is the same."""
    rho = 0.5
    ior = pc.ior.cauchy(CAUCHY_A, CAUCHY_B) if dispersive else 1.5
    scene = through_specular_scene("glass", ior=ior, wall_reflectance=pc.spectra.constant(rho))
    r = pc.render(scene, width=30, height=30, samples=256, quality="FINAL", max_bounces=16, seed=3, wavelength_count=41, **how)
    behind = r.albedo[:, 13:17].reshape(-1, 3).mean(axis=0)
    direct = r.albedo[:, 2:8].reshape(-1, 3).mean(axis=0)

    lam = np.linspace(380.0, 780.0, 41)
    w = np.full(41, 10.0)
    w[[0, -1]] = 5.0  # the grid's quadrature weights (eq. 6)
    n = CAUCHY_A + CAUCHY_B / (lam / 1000.0) ** 2 if dispersive else np.full(41, 1.5)
    f = ((n - 1) / (n + 1)) ** 2
    t = (1 - f) / (1 + f)
    shape = colour.SpectralShape(380, 780, 10)
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(shape).values
    d65 = colour.SDS_ILLUMINANTS["D65"].copy().align(shape).values
    cs = colour.RGB_COLOURSPACES["sRGB"]

    def albedo_rgb(reflectance):
        xyz = (cmfs * (d65 * reflectance * w)[:, None]).sum(axis=0) / (cmfs[:, 1] * d65 * w).sum()
        return colour.XYZ_to_RGB(xyz, cs, apply_cctf_encoding=False)

    np.testing.assert_allclose(direct, albedo_rgb(np.full(41, rho)), rtol=2e-3)
    expected = albedo_rgb(rho * t)
    print(f"through the slab: {behind} expected {expected}")
    # 256 spp × 120 pixels; the paths the slab reflects back add 0: σ ≈ 0.1 %.
    np.testing.assert_allclose(behind, expected, rtol=0.01)
    if dispersive:
        assert expected[2] < 0.95 * expected[0] and behind[2] < 0.95 * behind[0], (behind, expected)
    assert abs(r.normal[15, 15, 1]) > 0.95  # the wall's normal, not the glass'


def test_viewport_session_denoises_its_previews_with_denoise_previews():
    """The Blender viewport (the add-on's ViewportSession, which runs a RenderJob with the
    scene's settings, scene.polychrome.denoise_previews included) shows OIDN-denoised
    previews: each one equals the same pass of a session without it, denoised colour-only
    with OIDN's fast quality; the final one stays the noisy image without `denoise`."""
    from polychrome_blender import viewport

    def previews(**flags):
        s = viewport.ViewportSession()
        s.set_scene(*cornell().description())
        s.set_settings(pc.RenderSettings(samples=24, seed=4, max_bounces=4, wavelength_count=16, **flags))
        s.set_view(pc.Camera.looking_at((0.0, -3.5, 1.0), (0.0, 0.0, 1.0)), 24, 16)
        assert s.sync()
        seen, deadline = {}, time.monotonic() + 120
        while s.refining or not seen:
            p = s.poll()
            if p is not None:
                seen[(p.samples, p.last)] = p.rgba.copy()
            assert time.monotonic() < deadline, "the viewport render did not finish"
            time.sleep(0.002)
        s.free()
        return seen

    plain, denoised = previews(), previews(denoise_previews=True)
    common = [k for k in denoised if k in plain and not k[1]]
    assert common, (sorted(plain), sorted(denoised))
    for k in common:
        np.testing.assert_allclose(denoised[k], denoise.denoise(plain[k], quality="fast"), atol=1e-5)
        assert not np.allclose(denoised[k], plain[k])
    last = [k for k in denoised if k[1]]
    assert last and np.array_equal(denoised[last[0]], plain[last[0]])
