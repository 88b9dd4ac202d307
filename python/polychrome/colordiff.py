"""Perceptual colour difference (CIEDE2000) between scene-linear renders, numpy-vectorised.

Pipeline: scene-linear Rec.709/sRGB RGB -> CIE XYZ (IEC 61966-2-1 matrix, D65)
-> CIE 1976 L*a*b* relative to a D65 white -> CIEDE2000 (Sharma, Wu & Dalal 2005).
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "MATRIX_LINEAR_SRGB_TO_XYZ",
    "D65_WHITE_XYZ",
    "linear_rgb_to_xyz",
    "xyz_to_lab",
    "delta_e_2000",
    "image_delta_e",
    "delta_e_stats",
    "write_heatmap_png",
    "diff_files",
]

# IEC 61966-2-1:1999 eq. (F.7): linear sRGB (Rec.709 primaries, D65) to CIE XYZ.
MATRIX_LINEAR_SRGB_TO_XYZ = np.array(
    [
        [0.4124, 0.3576, 0.1805],
        [0.2126, 0.7152, 0.0722],
        [0.0193, 0.1192, 0.9505],
    ]
)
# The standard's D65 reference white (0.9505, 1.0000, 1.0890): RGB (1, 1, 1) maps onto it,
# so neutral greys get a* = b* = 0 exactly.
D65_WHITE_XYZ = MATRIX_LINEAR_SRGB_TO_XYZ.sum(axis=1)

_LAB_EPSILON = (6.0 / 29.0) ** 3  # 216 / 24389
_25_POW_7 = 25.0**7


def linear_rgb_to_xyz(rgb):
    """Scene-linear sRGB/Rec.709 (..., 3) to CIE XYZ (..., 3), no clamping (negatives pass through)."""
    rgb = np.asarray(rgb, dtype=np.float64)
    if rgb.shape[-1:] != (3,):
        raise ValueError(f"rgb must have shape (..., 3), got {rgb.shape}")
    return rgb @ MATRIX_LINEAR_SRGB_TO_XYZ.T


def xyz_to_lab(xyz, white_xyz=D65_WHITE_XYZ):
    """CIE 1976 L*a*b* of XYZ (..., 3) relative to the reference white `white_xyz` (CIE 15:2004 eq. 8.1)."""
    xyz = np.asarray(xyz, dtype=np.float64)
    if xyz.shape[-1:] != (3,):
        raise ValueError(f"xyz must have shape (..., 3), got {xyz.shape}")
    t = xyz / np.asarray(white_xyz, dtype=np.float64)
    f = np.where(t > _LAB_EPSILON, np.cbrt(t), t / (3.0 * (6.0 / 29.0) ** 2) + 4.0 / 29.0)
    fx, fy, fz = f[..., 0], f[..., 1], f[..., 2]
    return np.stack([116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)], axis=-1)


# --------------------------------------------------------------------------- CIEDE2000


def _hue_angle(a_prime, b):
    """Sharma eq. (4): h' in degrees [0, 360), defined as 0 when a' = b = 0 (atan2(0, -0) would give 180)."""
    h = np.degrees(np.arctan2(b, a_prime))
    h = np.where(h < 0.0, h + 360.0, h)
    return np.where((a_prime == 0.0) & (b == 0.0), 0.0, h)


def _raw_hue_difference(h1, h2, a1p, b1, a2p, b2):
    """h2' - h1', snapped to exactly +-180 when the two (a', b) vectors are exactly opposite.

    Sharma's branches (eqs. 10 and 14) switch at |h2' - h1'| = 180; two separate atan2 calls
    can land a hair either side of it (e.g. test pair 14), so the tie is detected exactly
    with the cross and dot products instead.
    """
    d = h2 - h1
    opposite = (a1p * b2 - b1 * a2p == 0.0) & (a1p * a2p + b1 * b2 < 0.0)
    return np.where(opposite, np.where(d > 0.0, 180.0, -180.0), d)


def _hue_difference(d, zero_chroma):
    """Sharma eq. (10): delta h' wrapped into [-180, 180], 0 if either chroma is 0."""
    wrapped = np.where(d > 180.0, d - 360.0, np.where(d < -180.0, d + 360.0, d))
    return np.where(zero_chroma, 0.0, wrapped)


def _mean_hue(h1, h2, d, zero_chroma):
    """Sharma eq. (14): mean hue h-bar', taking the short way round; h1' + h2' if either chroma is 0."""
    s = h1 + h2
    wrapped = np.where(s < 360.0, (s + 360.0) / 2.0, (s - 360.0) / 2.0)
    return np.where(zero_chroma, s, np.where(np.abs(d) <= 180.0, s / 2.0, wrapped))


def delta_e_2000(lab1, lab2, kL=1.0, kC=1.0, kH=1.0):
    """CIEDE2000 colour difference of L*a*b* arrays (..., 3), broadcast, per Sharma, Wu & Dalal 2005 eqs. (1)-(22)."""
    lab1, lab2 = np.asarray(lab1, dtype=np.float64), np.asarray(lab2, dtype=np.float64)
    if lab1.shape[-1:] != (3,) or lab2.shape[-1:] != (3,):
        raise ValueError(f"Lab arrays must have shape (..., 3), got {lab1.shape} and {lab2.shape}")
    L1, a1, b1 = np.moveaxis(lab1, -1, 0)
    L2, a2, b2 = np.moveaxis(lab2, -1, 0)

    # Step 1: a', C', h' (eqs. 2-7).
    c_bar_7 = ((np.hypot(a1, b1) + np.hypot(a2, b2)) / 2.0) ** 7
    g = 0.5 * (1.0 - np.sqrt(c_bar_7 / (c_bar_7 + _25_POW_7)))
    a1p, a2p = (1.0 + g) * a1, (1.0 + g) * a2
    c1p, c2p = np.hypot(a1p, b1), np.hypot(a2p, b2)
    h1p, h2p = _hue_angle(a1p, b1), _hue_angle(a2p, b2)
    zero_chroma = c1p * c2p == 0.0

    # Step 2: delta L', delta C', delta H' (eqs. 8-11).
    d_raw = _raw_hue_difference(h1p, h2p, a1p, b1, a2p, b2)
    dLp, dCp = L2 - L1, c2p - c1p
    dHp = 2.0 * np.sqrt(c1p * c2p) * np.sin(np.radians(_hue_difference(d_raw, zero_chroma) / 2.0))

    # Step 3: weighting functions and rotation term (eqs. 12-22).
    L_bar, c_bar_p = (L1 + L2) / 2.0, (c1p + c2p) / 2.0
    h_bar = np.radians(_mean_hue(h1p, h2p, d_raw, zero_chroma))
    t = (
        1.0
        - 0.17 * np.cos(h_bar - np.radians(30.0))
        + 0.24 * np.cos(2.0 * h_bar)
        + 0.32 * np.cos(3.0 * h_bar + np.radians(6.0))
        - 0.20 * np.cos(4.0 * h_bar - np.radians(63.0))
    )
    d_theta = 30.0 * np.exp(-(((np.degrees(h_bar) - 275.0) / 25.0) ** 2))
    r_c = 2.0 * np.sqrt(c_bar_p**7 / (c_bar_p**7 + _25_POW_7))
    s_l = 1.0 + 0.015 * (L_bar - 50.0) ** 2 / np.sqrt(20.0 + (L_bar - 50.0) ** 2)
    s_c = 1.0 + 0.045 * c_bar_p
    s_h = 1.0 + 0.015 * c_bar_p * t
    r_t = -np.sin(np.radians(2.0 * d_theta)) * r_c

    l_term, c_term, h_term = dLp / (kL * s_l), dCp / (kC * s_c), dHp / (kH * s_h)
    return np.sqrt(l_term**2 + c_term**2 + h_term**2 + r_t * c_term * h_term)


# --------------------------------------------------------------------------- images


def _image_rgb(image, name: str) -> np.ndarray:
    """The RGB part (alpha dropped) of an (H, W, 3|4) image as float64."""
    arr = np.asarray(image, dtype=np.float64)
    if arr.ndim != 3 or arr.shape[2] not in (3, 4):
        raise ValueError(f"image {name} must have shape (H, W, 3) or (H, W, 4), got {arr.shape}")
    return arr[:, :, :3]


def image_delta_e(a, b, white_luminance=1.0):
    """Per-pixel CIEDE2000 (H, W) between two scene-linear RGB(A) images; alpha is ignored.

    L*a*b* is taken relative to a D65 white of luminance `white_luminance`. Scene-linear
    renders carry absolute-ish radiometric scale rather than display code values: a perfect
    white diffuser lit by the scene's reference light renders at Y ~= 1, so the default
    white Y = 1 puts it at L* = 100. Pass a different value when the exposure differs
    (e.g. the luminance of the reference white in that render); values above the white
    just give L* > 100, nothing is clipped.
    """
    rgb_a, rgb_b = _image_rgb(a, "a"), _image_rgb(b, "b")
    if rgb_a.shape != rgb_b.shape:
        raise ValueError(f"image shapes differ: {np.shape(a)} vs {np.shape(b)}")
    if not (np.isfinite(white_luminance) and white_luminance > 0):
        raise ValueError(f"white_luminance must be finite and > 0, got {white_luminance}")
    bad = int(np.count_nonzero(~np.all(np.isfinite(rgb_a) & np.isfinite(rgb_b), axis=-1)))
    if bad:
        raise ValueError(f"{bad} pixel(s) have non-finite (NaN or inf) RGB values")
    white = D65_WHITE_XYZ * float(white_luminance)
    lab_a = xyz_to_lab(linear_rgb_to_xyz(rgb_a), white)
    lab_b = xyz_to_lab(linear_rgb_to_xyz(rgb_b), white)
    return delta_e_2000(lab_a, lab_b)


def delta_e_stats(de) -> dict:
    """Summary of a delta-E array: mean, median, p95, max (floats) and pixels (count)."""
    values = np.asarray(de, dtype=np.float64).reshape(-1)
    if values.size == 0:
        raise ValueError("delta_e_stats needs at least one value")
    return {
        "mean": float(np.mean(values)),
        "median": float(np.median(values)),
        "p95": float(np.percentile(values, 95)),
        "max": float(np.max(values)),
        "pixels": int(values.size),
    }


def _ramp_colormap(x):
    """Built-in fallback heat ramp black -> red -> yellow -> white, x in [0, 1] -> RGB in [0, 1]."""
    stops = np.array([0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0])
    colours = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [1, 1, 1]], dtype=np.float64)
    return np.stack([np.interp(x, stops, colours[:, c]) for c in range(3)], axis=-1)


def _colormap(x):
    """Map x in [0, 1] to display RGB with matplotlib's perceptually uniform 'inferno', if available."""
    try:
        from matplotlib import colormaps
    except ImportError:
        return _ramp_colormap(x)
    return colormaps["inferno"](x)[..., :3]


def write_heatmap_png(de, path, vmax=None) -> float:
    """Write delta-E (H, W) as a colour-mapped PNG, 0 -> dark, >= vmax -> bright; returns the vmax used.

    vmax defaults to max(99th percentile, 1) so that a few outliers do not wash out the map
    and an almost identical pair is not blown up into noise.
    """
    from PIL import Image

    values = np.asarray(de, dtype=np.float64)
    if values.ndim != 2 or values.size == 0:
        raise ValueError(f"heat map needs a non-empty (H, W) array, got {values.shape}")
    values = np.nan_to_num(values, nan=0.0)
    if vmax is None:
        vmax = max(float(np.percentile(values, 99)), 1.0)
    if not (np.isfinite(vmax) and vmax > 0):
        raise ValueError(f"vmax must be finite and > 0, got {vmax}")
    rgb = _colormap(np.clip(values / vmax, 0.0, 1.0))
    Image.fromarray(np.rint(rgb * 255.0).astype(np.uint8), "RGB").save(str(path), format="PNG")
    return float(vmax)


def diff_files(path_a, path_b, heatmap=None, white_luminance=1.0) -> dict:
    """delta_e_stats of the per-pixel CIEDE2000 between two image files (.exr or .png), optional heat map."""
    from . import imageio

    a, b = imageio.read_image(path_a), imageio.read_image(path_b)
    if a.shape != b.shape:
        raise ValueError(f"image sizes differ: {path_a} is {a.shape[:2]}, {path_b} is {b.shape[:2]} (H, W)")
    try:
        de = image_delta_e(a, b, white_luminance)
    except ValueError as exc:
        raise ValueError(f"{path_a} vs {path_b}: {exc}") from exc
    if heatmap is not None:
        write_heatmap_png(de, heatmap)
    return delta_e_stats(de)
