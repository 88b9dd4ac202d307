"""Spectra a scene can use: named illuminants, blackbodies, narrow bands, measured
tables and RGB (converted by the render's RGB → spectrum map, eq. 10).

Each function returns a :class:`Spectrum`, a small description that the core
evaluates on the render's wavelength grid; nothing here depends on the grid.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any
from collections.abc import Sequence

import numpy as np


@dataclass(frozen=True)
class Spectrum:
    """A spectrum description: a ``kind`` with its parameters and an overall ``scale``."""

    kind: str
    params: dict[str, Any] = field(default_factory=dict)
    scale: float = 1.0

    def __mul__(self, factor: float) -> Spectrum:
        return Spectrum(self.kind, self.params, self.scale * float(factor))

    __rmul__ = __mul__

    def to_dict(self) -> dict[str, Any]:
        return {"type": self.kind, **self.params, "scale": self.scale}


def constant(value: float) -> Spectrum:
    """The same value at every wavelength."""
    return Spectrum("constant", {"value": float(value)})


def blackbody(temperature: float, scale: float = 1.0) -> Spectrum:
    """Planck's law at ``temperature`` kelvin, normalised to 1 at its peak."""
    return Spectrum("blackbody", {"temperature": float(temperature)}, float(scale))


def d65(scale: float = 1.0) -> Spectrum:
    """CIE standard illuminant D65, 1 at 560 nm."""
    return Spectrum("d65", {}, float(scale))


def illuminant_a(scale: float = 1.0) -> Spectrum:
    """CIE standard illuminant A (incandescent, 2856 K), 1 at 560 nm."""
    return Spectrum("a", {}, float(scale))


def equal_energy(scale: float = 1.0) -> Spectrum:
    """CIE illuminant E: flat."""
    return Spectrum("e", {}, float(scale))


def fluorescent(index: int, scale: float = 1.0) -> Spectrum:
    """CIE fluorescent illuminant F2, F7 or F11, 1 at 560 nm."""
    return Spectrum("fluorescent", {"index": int(index)}, float(scale))


def narrow_band(center: float, width: float, scale: float = 1.0) -> Spectrum:
    """A Gaussian band of peak 1 around ``center`` nm, full width at half maximum ``width`` nm.

    Its energy is integrated over each grid cell, so it survives even between samples.
    """
    return Spectrum("narrow_band", {"center": float(center), "width": float(width)}, float(scale))


def tabulated(wavelengths: Sequence[float], values: Sequence[float], scale: float = 1.0) -> Spectrum:
    """Measured (wavelength nm, value) pairs, ascending; averaged over each grid cell."""
    w = np.asarray(wavelengths, dtype=np.float64).ravel()
    v = np.asarray(values, dtype=np.float64).ravel()
    return Spectrum("tabulated", {"wavelengths": w.tolist(), "values": v.tolist()}, float(scale))


def rgb(r: float, g: float, b: float, scale: float = 1.0) -> Spectrum:
    """Scene-linear Rec.709 RGB, turned into a spectrum by the render's uplift."""
    return Spectrum("rgb", {"rgb": [float(r), float(g), float(b)]}, float(scale))


def as_spectrum(value: Any) -> Spectrum:
    """Accepts a Spectrum, a number (constant) or an (r, g, b) triple."""
    if isinstance(value, Spectrum):
        return value
    if isinstance(value, (int, float, np.floating, np.integer)):
        return constant(float(value))
    seq = list(value) if not isinstance(value, str) else None
    if seq is not None and len(seq) == 3 and all(isinstance(c, (int, float, np.floating, np.integer)) for c in seq):
        return rgb(*seq)
    raise TypeError(f"cannot use {value!r} as a spectrum: give a number, an (r, g, b) triple or a polychrome.spectra function's result")


#: The grid the colour of a spectrum is measured on (5 nm over the visible range).
_TINT_SETTINGS = '{"wavelength_count": 81}'
#: CIE XYZ → linear Rec.709 (the inverse of IEC 61966-2-1's matrix, as polychrome.colordiff).
_XYZ_TO_REC709 = np.linalg.inv(np.array([[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722], [0.0193, 0.1192, 0.9505]], dtype=np.float64))


def tinted(spectrum: Spectrum, r: float, g: float, b: float) -> Spectrum:
    """A light of ``spectrum`` whose colour is multiplied by the RGB tint (r, g, b), as
    Cycles (``intern/cycles/blender/light.cpp``: colour × temperature colour) and UsdLux
    (``color`` × ``colorTemperature``) define it: the product is taken in linear Rec.709
    (the spectrum's colour through the CIE 1931 observer, RGB white ↔ D65) and becomes an
    RGB colour uplifted as an illuminant. A white tint returns ``spectrum`` unchanged."""
    if (r, g, b) == (1.0, 1.0, 1.0):
        return spectrum
    if not all(np.isfinite(c) and c >= 0.0 for c in (r, g, b)):
        raise ValueError(f"tint {(r, g, b)} must be finite and non-negative")
    own = rec709(spectrum)
    return rgb(float(r * own[0]), float(g * own[1]), float(b * own[2]))


def rec709(spectrum: Spectrum) -> tuple[float, float, float]:
    """The linear Rec.709 colour of an emitted ``spectrum`` (CIE 1931 observer, RGB white
    ↔ D65), as :func:`tinted` measures it."""
    import json

    from . import _core

    xyz = np.array(_core.spectrum_xyz(json.dumps(spectrum.to_dict()), _TINT_SETTINGS), dtype=np.float64)
    own = _XYZ_TO_REC709 @ xyz
    return float(own[0]), float(own[1]), float(own[2])
