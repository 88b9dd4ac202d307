"""Shared pieces of the paper's figure examples (docs/design.md#figures): meshes, spectra, the
left-RGB / right-spectral split image, and measurements on images.

The examples (``fig02_*.py`` ... ``fig13_*.py``) and ``tests/test_figures.py`` import
their scenes from here and from the example scripts, so the tests check the very scenes
the figures show.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

import polychrome as pc
from polychrome import _core, spectra

OUT = Path(__file__).resolve().parent / "out"
DOCS_IMAGES = Path(__file__).resolve().parents[1] / "docs" / "images"

# Linear Rec.709 (D65) <-> CIE XYZ.
XYZ_TO_RGB = np.array([[3.2404542, -1.5371385, -0.4985314], [-0.9692660, 1.8760108, 0.0415560], [0.0556434, -0.2040259, 1.0572252]])
RGB_TO_XYZ = np.linalg.inv(XYZ_TO_RGB)


# --------------------------------------------------------------------------- meshes


def quad(a, b, c, d):
    """Two triangles a-b-c, a-c-d (counter-clockwise seen from the front)."""
    return np.array([a, b, c, d], dtype=np.float32), np.array([[0, 1, 2], [0, 2, 3]])


def uv_sphere(center, radius, rings=32, segments=64):
    """A UV sphere with smooth normals: (vertices, triangles, normals)."""
    th = np.linspace(0, np.pi, rings + 1)[:, None]
    ph = np.linspace(0, 2 * np.pi, segments + 1)[None, :]
    n = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th) * np.ones_like(ph)], -1).reshape(-1, 3)
    row = segments + 1
    a = (np.arange(rings)[:, None] * row + np.arange(segments)[None, :]).ravel()
    t = np.concatenate([np.stack([a, a + row, a + 1], 1), np.stack([a + 1, a + row, a + row + 1], 1)])
    return (n * radius + np.asarray(center)).astype(np.float32), t, n.astype(np.float32)


def box(center, size, angle_deg=0.0):
    """An axis-aligned box standing on z = center[2], turned about +Z."""
    cx, cy, cz = center
    sx, sy, sz = (s / 2 for s in size)
    corners = np.array([[x, y, z] for z in (-sz, sz) for y in (-sy, sy) for x in (-sx, sx)], dtype=np.float64)
    a = np.radians(angle_deg)
    rot = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    v = corners @ rot.T + [cx, cy, cz + sz]
    faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    tris = [[f[0], f[1], f[2]] for f in faces] + [[f[0], f[2], f[3]] for f in faces]
    return v.astype(np.float32), np.array(tris)


def prism(corners_xy, z0, z1):
    """A closed triangular prism: the triangle ``corners_xy`` (3 × (x, y),
    counter-clockwise seen from +Z) extruded from z0 to z1; outward-facing triangles."""
    c = [tuple(p) for p in corners_xy]
    v = np.array([(x, y, z0) for x, y in c] + [(x, y, z1) for x, y in c], dtype=np.float32)
    t = [[0, 2, 1], [3, 4, 5]]  # bottom (facing −Z), top (facing +Z)
    for i in range(3):
        j = (i + 1) % 3
        t += [[i, j, j + 3], [i, j + 3, i + 3]]
    return v, np.array(t)


# --------------------------------------------------------------------------- spectra

LAM = np.arange(360.0, 831.0, 5.0)


def smooth_step(low, high, center, width, falling=False) -> spectra.Spectrum:
    s = 1.0 / (1.0 + np.exp(-(LAM - center) / width))
    return spectra.tabulated(LAM, low + (high - low) * ((1.0 - s) if falling else s))


def green_paint() -> spectra.Spectrum:
    """A smooth synthetic green reflectance (peak 0.53 at 530 nm, 0.08 in the red and
    blue): the sphere of figures 2-5. Its RGB under D65 is what RGB mode uses."""
    return spectra.tabulated(LAM, 0.08 + 0.45 * np.exp(-0.5 * ((LAM - 530.0) / 40.0) ** 2))


def settings_json(**kw) -> str:
    return json.dumps(kw)


def spectrum_xyz(spectrum: spectra.Spectrum, **grid) -> np.ndarray:
    """XYZ of a radiance spectrum as the film computes it (grid quadrature, Y of E = 1)."""
    return np.array(_core.spectrum_xyz(json.dumps(spectrum.to_dict()), settings_json(**grid)))


def spectrum_rgb(spectrum: spectra.Spectrum, **grid) -> np.ndarray:
    """Linear Rec.709 RGB of a radiance spectrum."""
    return XYZ_TO_RGB @ spectrum_xyz(spectrum, **grid)


def grid_values(spectrum: spectra.Spectrum, role="reflectance", **grid) -> tuple[np.ndarray, np.ndarray]:
    """(wavelengths, values) of a spectrum on a render grid."""
    s = settings_json(**grid)
    lam, _ = _core.wavelength_grid(s)
    return np.asarray(lam, np.float64), np.asarray(_core.spectrum_values(json.dumps(spectrum.to_dict()), s, role), np.float64)


def reflectance_rgb_under_d65(spectrum: spectra.Spectrum, **grid) -> np.ndarray:
    """Linear Rec.709 RGB of a reflectance seen under D65 (white reflector → (1, 1, 1)),
    as RGB mode converts it."""
    lam, refl = grid_values(spectrum, "reflectance", **grid)
    _, d65 = grid_values(spectra.d65(), "illuminant", **grid)
    return spectrum_rgb(spectra.tabulated(lam, refl * d65), **grid) / spectrum_rgb(spectra.tabulated(lam, d65), **grid)


def with_luminance(spectrum: spectra.Spectrum, y: float) -> spectra.Spectrum:
    """``spectrum`` scaled to luminance Y = y (film units: equal energy 1 has Y = 1)."""
    return spectrum * (y / spectrum_xyz(spectrum)[1])


def metameric_white(centers=(450.0, 540.0, 610.0), fwhm=12.0, y=1.0) -> spectra.Spectrum:
    """Three narrow bands mixed so that their RGB equals D65's (white, luminance ``y``):
    a "white" light of the same RGB as D65 but a spiky spectrum (figures 4, 5)."""
    bands = [spectra.narrow_band(c, fwhm) for c in centers]
    m = np.stack([spectrum_rgb(b) for b in bands], axis=1)  # columns: RGB of each band
    target = spectrum_rgb(spectra.d65())
    target = target / target[1] * 1.0  # D65's chromaticity; scaled below
    k = np.linalg.solve(m, target)
    if np.any(k <= 0):
        raise ValueError(f"bands {centers} cannot mix to D65 white with positive weights ({k})")
    lam = np.arange(360.0, 830.5, 0.5)
    values = sum(ki * np.exp(-4.0 * math.log(2.0) * ((lam - c) / fwhm) ** 2) for ki, c in zip(k, centers))
    return with_luminance(spectra.tabulated(lam, values), y)


# --------------------------------------------------------------------------- images


def split(left: np.ndarray, right: np.ndarray, line: bool = True) -> np.ndarray:
    """Left half of ``left`` beside the right half of ``right`` (the paper's layout),
    with a thin white dividing line."""
    w = left.shape[1]
    out = np.concatenate([left[:, : w // 2], right[:, w // 2 :]], axis=1).copy()
    if line:
        out[:, w // 2 - 1 : w // 2 + 1, :3] = 1.0
    return out


def side_by_side(left: np.ndarray, right: np.ndarray, gap: int = 2) -> np.ndarray:
    h = left.shape[0]
    sep = np.ones((h, gap, left.shape[2]), left.dtype)
    return np.concatenate([left, sep, right], axis=1)


def masked_mean(rgba: np.ndarray, mask: np.ndarray) -> np.ndarray:
    return rgba[..., :3][mask].reshape(-1, 3).mean(axis=0)


def delta_e(rgb_a, rgb_b, white_y: float = 1.0) -> float:
    """CIEDE2000 between two linear Rec.709 colours (polychrome.colordiff, verified
    against Sharma, Wu, Dalal 2005)."""
    from polychrome.colordiff import image_delta_e

    a = np.asarray(rgb_a, np.float64).reshape(1, 1, 3)
    b = np.asarray(rgb_b, np.float64).reshape(1, 1, 3)
    return float(image_delta_e(a, b, white_luminance=white_y).mean())


def save(rgba: np.ndarray, out: Path, docs_name: str | None = None, docs: bool = False) -> list[Path]:
    """Writes ``out``.png and ``out``.exr (and a copy of the PNG to docs/images/)."""
    from polychrome import imageio

    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    written = [out.with_suffix(".png"), out.with_suffix(".exr")]
    imageio.write_png(written[0], rgba)
    imageio.write_exr(written[1], rgba.astype(np.float32))
    if docs:
        DOCS_IMAGES.mkdir(parents=True, exist_ok=True)
        target = DOCS_IMAGES / f"{docs_name or out.name}.png"
        imageio.write_png(target, rgba)
        written.append(target)
    return written


def fixed() -> dict:
    """Settings that make a render use exactly the samples, grid and bounces it is given
    (no adaptive stop): ``quality="FINAL"`` where that setting exists."""
    import dataclasses

    names = {f.name for f in dataclasses.fields(pc.RenderSettings)}
    return {"quality": "FINAL"} if "quality" in names else {}
