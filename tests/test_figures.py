"""The paper's figures as tests (docs/design.md#figures, issue 4), on tiny images.

- Figures 2-5: RGB mode and the spectral render of the green sphere differ by a large
  ΔE00 under a narrow-band red light and under a "white" light with D65's RGB but not
  its spectrum, and agree under D65.
- The spectral colour of a lit diffuse surface matches the closed form
  L(λ) = ρ(λ)/π · E(λ) integrated with colour-science's CIE 1931 CMFs (1 nm), both at
  1 nm (401 wavelengths) and on the default 41-sample grid.
- Figures 6-7: the spot of a cone light through an N-BK7 prism lands on the screen where
  Snell's law with the Sellmeier index puts it, at every grid wavelength (including the
  grid's ends), with the spread the closed form predicts; RGB mode gives three spots at
  620/540/460 nm.
"""

from __future__ import annotations

import math
from pathlib import Path
import sys

import numpy as np
import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
sys.path.insert(0, str(EXAMPLES))

import polychrome as pc  # noqa: E402
from polychrome import spectra  # noqa: E402

import figlib  # noqa: E402
import fig02_red_light_green_sphere as fig02  # noqa: E402
import fig04_non_d65_white as fig04  # noqa: E402
import fig06_prism as fig06  # noqa: E402

colour = pytest.importorskip("colour")

FIXED = figlib.fixed()

# --------------------------------------------------------------------------- figures 2-5

SPHERE = dict(width=48, height=36, samples=16, wavelength_count=41, max_bounces=3, seed=5, **FIXED)


def test_red_light_rgb_and_spectral_differ_by_a_large_delta_e():
    light = fig02.red_light()
    c = fig02.compare(*fig02.render_pair(fig02.build_scene(light), **SPHERE))
    assert c["pixels"] > 100
    # The paint reflects ~0.10 at 630 nm, but its RGB red under D65 is ~0.04: RGB mode
    # renders the sphere ~2.4x too dark (the paper's figure 2 vs 3).
    assert c["spectral"][0] > 1.8 * c["rgb"][0], c
    assert c["delta_e"] > 6.0, c


def test_metameric_white_has_d65_rgb_but_changes_the_sphere():
    light = fig04.white_light("triband")
    d65 = figlib.with_luminance(spectra.d65(), fig04.LUMINANCE)
    np.testing.assert_allclose(figlib.spectrum_rgb(light), figlib.spectrum_rgb(d65), rtol=2e-3)
    c = fig02.compare(*fig02.render_pair(fig02.build_scene(light), **SPHERE))
    assert c["delta_e"] > 2.5, c
    # Control: under D65 itself RGB mode and spectral agree (the same 16 spp noise).
    control = fig02.compare(*fig02.render_pair(fig02.build_scene(d65), **SPHERE))
    assert control["delta_e"] < 1.0, control


# --------------------------------------------------------------------------- closed-form colour

#: A tabulated green paint (10 nm) and a narrow-band sun on the slope of its reflectance.
PAINT_LAM = np.arange(370.0, 791.0, 10.0)
PAINT = 0.08 + 0.45 * np.exp(-0.5 * ((PAINT_LAM - 530.0) / 40.0) ** 2)
SUN_CENTER, SUN_FWHM, SUN_STRENGTH = 590.0, 30.0, 4.0


def sun_over_plane() -> pc.Scene:
    """A large diffuse plane z = 0 seen straight down by an orthographic camera, lit by a
    sun shining straight down: the radiance is ρ(λ)/π · E(λ) everywhere (cos = 1)."""
    scene = pc.Scene()
    paint = scene.add_material(pc.Diffuse(spectra.tabulated(PAINT_LAM, PAINT), name="green paint"))
    s = 50.0
    scene.add_mesh("plane", *figlib.quad((-s, -s, 0), (s, -s, 0), (s, s, 0), (-s, s, 0)), material=paint)
    scene.add_light(
        pc.SunLight(direction=(0.0, 0.0, -1.0), strength=SUN_STRENGTH, color=spectra.narrow_band(SUN_CENTER, SUN_FWHM), name="sun")
    )
    scene.camera = pc.Camera(
        to_world=pc.look_at((0.0, 0.0, 5.0), (0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0)), projection="ORTHOGRAPHIC", ortho_scale=2.0
    )
    return scene


def sun_spectrum(lam):
    return SUN_STRENGTH * np.exp(-4.0 * math.log(2.0) * ((lam - SUN_CENTER) / SUN_FWHM) ** 2)


def lab(xyz, white_y):
    """L*a*b* with colour-science, D65 white point of luminance ``white_y``."""
    d65 = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]
    return colour.XYZ_to_Lab(np.asarray(xyz) / white_y, d65)


def rendered_xyz(rgba):
    m = colour.RGB_COLOURSPACES["ITU-R BT.709"].matrix_RGB_to_XYZ
    return m @ rgba[..., :3].reshape(-1, 3).mean(axis=0)


def closed_form_xyz_1nm():
    """∫ ρ(λ)/π · E(λ) · (x̄, ȳ, z̄) dλ / ∫ ȳ dλ over 380..780 nm at 1 nm, colour-science CMFs."""
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(colour.SpectralShape(380, 780, 1))
    lam = cmfs.wavelengths
    radiance = np.interp(lam, PAINT_LAM, PAINT) / math.pi * sun_spectrum(lam)
    return radiance @ cmfs.values / cmfs.values[:, 1].sum()


def closed_form_xyz_on_grid(lam_grid):
    """The same integral with the render grid's quadrature (eq. 6 weights): the sun and
    the paint averaged over each sample's cell (as the core resamples them), the CMFs of
    colour-science at the grid wavelengths."""
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    edges = np.concatenate([[lam_grid[0]], 0.5 * (lam_grid[1:] + lam_grid[:-1]), [lam_grid[-1]]])
    weights = np.diff(edges)
    fine = [np.linspace(a, b, 2001) for a, b in zip(edges[:-1], edges[1:])]
    sun = np.array([sun_spectrum(x).mean() for x in fine])
    paint = np.array([np.interp(x, PAINT_LAM, PAINT).mean() for x in fine])
    cmf = np.array([cmfs[float(x)] for x in lam_grid])
    radiance = paint / math.pi * sun
    return (radiance * weights) @ cmf / (cmf[:, 1] * weights).sum()


def white_y_1nm():
    """Luminance of a perfect white diffuser under the sun: the Lab white."""
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(colour.SpectralShape(380, 780, 1))
    return (sun_spectrum(cmfs.wavelengths) / math.pi) @ cmfs.values[:, 1] / cmfs.values[:, 1].sum()


@pytest.mark.parametrize("count", [401, 41])
def test_spectral_colour_of_a_lit_plane_matches_the_closed_form(count):
    result = pc.render(sun_over_plane(), width=4, height=4, samples=4, wavelength_count=count, max_bounces=1, **FIXED)
    assert result.stats["nonfinite_samples"] == 0
    xyz = rendered_xyz(result.rgba)
    white = white_y_1nm()
    exact = closed_form_xyz_1nm()
    de_exact = float(colour.delta_E(lab(xyz, white), lab(exact, white), method="CIE 2000"))
    if count == 401:
        # The grid is the 1 nm integration itself: only float32 and cell averages differ.
        assert de_exact < 0.3, (xyz, exact)
    else:
        # On the 10 nm grid, compare with the same integral on that grid...
        lam = np.asarray(result.wavelengths, np.float64)
        on_grid = closed_form_xyz_on_grid(lam)
        de_grid = float(colour.delta_E(lab(xyz, white), lab(on_grid, white), method="CIE 2000"))
        assert de_grid < 0.3, (xyz, on_grid)
        # ... and the quadrature error of a 30 nm band on a 10 nm grid stays small.
        assert de_exact < 1.0, (xyz, exact, de_exact)
    # And a wrong answer would be caught: the RGB-mode colour is far from it.
    rgb = pc.render(sun_over_plane(), width=4, height=4, samples=4, wavelength_count=count, max_bounces=1, method="RGB", **FIXED)
    assert float(colour.delta_E(lab(rendered_xyz(rgb.rgba), white), lab(exact, white), method="CIE 2000")) > 5.0


# --------------------------------------------------------------------------- prism (figures 6, 7)

#: N-BK7 Sellmeier coefficients (SCHOTT data sheet), λ in µm — typed here from the data
#: sheet, independently of the core's catalogue.
BK7_B = (1.03961212, 0.231792344, 1.01046945)
BK7_C = (0.00600069867, 0.0200179144, 103.560653)


def n_bk7(lam_nm):
    l2 = (np.asarray(lam_nm, np.float64) / 1000.0) ** 2
    return np.sqrt(1.0 + sum(b * l2 / (l2 - c) for b, c in zip(BK7_B, BK7_C)))


def refract(d, normal, eta):
    """Snell's law in vector form: direction ``d`` through a surface with unit ``normal``
    facing against ``d``, relative index ``eta`` = n_incident / n_transmitted; also
    returns the unpolarised Fresnel transmittance (NaN direction on TIR)."""
    cos_i = -np.sum(d * normal, axis=-1, keepdims=True)
    sin2_t = eta**2 * (1.0 - cos_i**2)
    cos_t = np.sqrt(np.clip(1.0 - sin2_t, 0.0, None))
    t = eta * d + (eta * cos_i - cos_t) * normal
    t[(sin2_t > 1.0)[..., 0]] = np.nan
    rs = ((eta * cos_i - cos_t) / (eta * cos_i + cos_t)) ** 2
    rp = ((eta * cos_t - cos_i) / (eta * cos_t + cos_i)) ** 2
    return t, 1.0 - 0.5 * (rs + rp)[..., 0]


def cone_directions(axis, half_angle, count, rng):
    """Directions uniformly distributed in solid angle within a cone."""
    cos_t = 1.0 - rng.random(count) * (1.0 - math.cos(half_angle))
    sin_t = np.sqrt(1.0 - cos_t**2)
    phi = rng.random(count) * 2 * math.pi
    w = axis / np.linalg.norm(axis)
    u = np.cross(w, [0.0, 0.0, 1.0])
    u /= np.linalg.norm(u)
    v = np.cross(w, u)
    return (sin_t * np.cos(phi))[:, None] * u + (sin_t * np.sin(phi))[:, None] * v + cos_t[:, None] * w


def hit_plane(o, d, p, n):
    t = np.sum((p - o) * n, axis=-1, keepdims=True) / np.sum(d * n, axis=-1, keepdims=True)
    return o + t * d


def snell_spots(g, lam_nm, spot_deg, count=20000, seed=7):
    """Closed form: for each wavelength, trace ``count`` rays of the cone through the
    prism's two faces with Snell's law (N-BK7 Sellmeier index) onto the screen plane.
    Returns (mean, std) of the screen coordinate along ``screen_axis`` per wavelength,
    weighted by the two faces' Fresnel transmittance."""
    rng = np.random.default_rng(seed)
    c = g["corners"]
    z = fig06.HEIGHT
    to3 = lambda p, zz=0.0: np.array([p[0], p[1], zz])
    outward = lambda a, b: np.array([b[1] - a[1], -(b[0] - a[0]), 0.0]) / np.linalg.norm(b - a)  # CCW polygon
    entry_p, entry_n = to3(c[2], z), outward(c[2], c[0])  # face apex → base-left
    exit_p, exit_n = to3(c[1], z), outward(c[1], c[2])  # face base-right → apex
    screen_p, screen_n = to3(g["screen_center"], z), to3(g["screen_normal"])
    axis = to3(g["screen_axis"])
    origin = to3(g["light"], z)
    d0 = cone_directions(to3(g["d_in"]), math.radians(spot_deg) / 2, count, rng)
    means, stds = [], []
    for lam in np.atleast_1d(lam_nm):
        n = float(n_bk7(lam))
        p1 = hit_plane(origin, d0, entry_p, entry_n)
        d1, t1 = refract(d0, entry_n, 1.0 / n)
        p2 = hit_plane(p1, d1, exit_p, -exit_n)
        d2, t2 = refract(d1, -exit_n, n)
        p3 = hit_plane(p2, d2, screen_p, screen_n)
        u = (p3 - screen_p) @ axis
        w = t1 * t2
        ok = np.isfinite(u) & np.isfinite(w)
        m = np.average(u[ok], weights=w[ok])
        means.append(m)
        stds.append(math.sqrt(np.average((u[ok] - m) ** 2, weights=w[ok])))
    return np.array(means), np.array(stds)


PRISM_W, PRISM_H = 96, 32
SPOT_DEG = 0.8


def pixel_u(g):
    """Screen coordinate (along screen_axis) of each pixel column's centre: the camera
    looks straight at the screen from ``camera_distance`` with a 50 mm lens on a 36 mm
    sensor spanning the image width."""
    half = 18.0 / 50.0 * g["camera_distance"]
    return ((np.arange(PRISM_W) + 0.5) / PRISM_W - 0.5) * 2 * half


@pytest.fixture(
    scope="module",
    params=[("FORWARD", "AUTO"), ("BIDIRECTIONAL", "AUTO"), ("FORWARD", "STRATIFIED"), ("BIDIRECTIONAL", "SPLIT"), ("FORWARD", "ENERGY")],
    ids=lambda p: "-".join(p),
)
def prism_render(request):
    """N-BK7 prism, D65 cone light, the camera facing the screen, traced FORWARD or
    BIDIRECTIONAL (whose light-tracing part takes this caustic of a delta light); light
    paths stop at the screen (max_bounces 3: entry, exit, screen) so no
    inter-reflection lands elsewhere. Each wavelength choice at the collapse (setting
    `collapse`, tests/test_collapse.py) must put the rainbow where Snell puts it."""
    direction, collapse = request.param
    scene, g = fig06.build_scene(spectra.d65(), glass="N-BK7", camera="screen", table=False, spot_deg=SPOT_DEG)
    result = pc.render(
        scene,
        width=PRISM_W,
        height=PRISM_H,
        samples=48,
        wavelength_count=41,
        direction=direction,
        collapse=collapse,
        max_bounces=3,
        spectral_output=True,
        seed=11,
        **FIXED,
    )
    assert result.stats["direction"] == direction
    return result, g


def column_moments(image, u):
    """(mean, std) of u weighted by an image's column sums (power along the screen)."""
    w = image.sum(axis=0)
    m = float((w * u).sum() / w.sum())
    return m, math.sqrt(float((w * (u - m) ** 2).sum() / w.sum()))


def test_prism_spot_follows_snell_at_every_wavelength(prism_render):
    result, g = prism_render
    assert result.stats["nonfinite_samples"] == 0
    lam = np.asarray(result.wavelengths, np.float64)
    u = pixel_u(g)
    pixel = u[1] - u[0]
    mean, std = snell_spots(g, lam, SPOT_DEG)
    # The rainbow spans many pixels: the blue end (380 nm) deviates more than the red end.
    assert abs(mean[0] - mean[-1]) > 10 * pixel
    for i in [0, 5, 10, 20, 30, 35, 40]:  # including both ends of the grid
        m, s = column_moments(result.spectral[..., i], u)
        # The centroid within a quarter pixel (thousands of paths per wavelength), the
        # beam's width within 10 %.
        assert abs(m - mean[i]) < 0.25 * pixel, (lam[i], m, mean[i], pixel)
        assert abs(s - std[i]) < 0.1 * std[i] + 0.3 * pixel, (lam[i], s, std[i])


def test_prism_rainbow_spread_matches_snell(prism_render):
    """The whole rainbow: the power-weighted spread over every wavelength (D65 × grid
    weights × Fresnel) against the closed-form mixture."""
    result, g = prism_render
    lam = np.asarray(result.wavelengths, np.float64)
    _, d65 = figlib.grid_values(spectra.d65(), "illuminant", wavelength_count=41)
    weights = np.asarray(pc._core.wavelength_grid(figlib.settings_json(wavelength_count=41))[1], np.float64)
    u = pixel_u(g)
    power = (result.spectral * weights).sum(axis=2)
    m, s = column_moments(power, u)
    mean, std = snell_spots(g, lam, SPOT_DEG, count=4000)
    p = d65 * weights
    p = p / p.sum()
    mix_mean = float(p @ mean)
    mix_std = math.sqrt(float(p @ (std**2 + mean**2)) - mix_mean**2)
    assert abs(m - mix_mean) < 0.25 * (u[1] - u[0])
    assert abs(s - mix_std) < 0.05 * mix_std, (s, mix_std)
    # Without dispersion the spread would be only the beam's width.
    assert mix_std > 2.0 * std[20]


@pytest.mark.parametrize("center", [400.0, 700.0])
def test_prism_narrow_band_light_lands_where_snell_puts_it(center):
    """A red and a blue narrow-band cone light (2 nm wide: all its energy in one 10 nm
    grid cell) each light one spot; its centroid in the RGB image (luminance-free: the
    sum of |R|, |G|, |B|) is where Snell's law puts that wavelength."""
    scene, g = fig06.build_scene(spectra.narrow_band(center, 2.0), glass="N-BK7", camera="screen", table=False, spot_deg=SPOT_DEG)
    result = pc.render(
        scene, width=PRISM_W, height=PRISM_H, samples=16, wavelength_count=41, direction="FORWARD", max_bounces=3, seed=3, **FIXED
    )
    u = pixel_u(g)
    m, _ = column_moments(np.abs(result.rgba[..., :3]).sum(axis=-1), u)
    mean, _ = snell_spots(g, [center], SPOT_DEG)
    assert abs(m - mean[0]) < 0.25 * (u[1] - u[0]), (center, m, mean[0])
    # The other end of the spectrum is far away: this is not a loose tolerance.
    other, _ = snell_spots(g, [1100.0 - center], SPOT_DEG)
    assert abs(m - other[0]) > 10 * (u[1] - u[0])


def test_prism_in_rgb_mode_gives_three_spots_at_620_540_460():
    scene, g = fig06.build_scene(spectra.d65(), glass="N-BK7", camera="screen", table=False, spot_deg=SPOT_DEG)
    result = pc.render(scene, width=PRISM_W, height=PRISM_H, samples=32, method="RGB", direction="FORWARD", max_bounces=3, seed=11, **FIXED)
    u = pixel_u(g)
    mean, _ = snell_spots(g, [620.0, 540.0, 460.0], SPOT_DEG)
    for channel in range(3):
        m, _ = column_moments(result.rgba[..., channel], u)
        assert abs(m - mean[channel]) < 0.25 * (u[1] - u[0]), (channel, m, mean[channel])
    # Three spots in the order of their indices, each more than two pixels apart.
    assert mean[0] < mean[1] < mean[2] or mean[0] > mean[1] > mean[2]
    assert min(abs(mean[1] - mean[0]), abs(mean[2] - mean[1])) > 2 * (u[1] - u[0])


# --------------------------------------------------------------------------- the scripts themselves


@pytest.mark.parametrize("name", ["fig02_red_light_green_sphere", "fig04_non_d65_white", "fig06_prism", "fig12_room", "fig13_room_glass"])
def test_example_scripts_run_and_write_png_and_exr(name, tmp_path, capsys):
    import importlib

    module = importlib.import_module(name)
    out = tmp_path / name
    args = ["--samples", "1", "--width", "16", "--height", "12", "--wavelengths", "16", "--out", str(out)]
    assert module.main(args) == 0
    assert out.with_suffix(".png").is_file() and out.with_suffix(".exr").is_file()
    image = pc.imageio.read_image(out.with_suffix(".exr"))
    assert np.all(np.isfinite(image)) and image[..., :3].max() > 0
    printed = capsys.readouterr().out
    assert "wrote" in printed
