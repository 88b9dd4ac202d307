"""Indices of refraction for :class:`polychrome.Dielectric` (SPEC §5).

Each helper returns an :class:`Ior`, a small description the core evaluates on the
render's wavelength grid. An index that is not finite, below 1 or near a Sellmeier
pole at any grid wavelength is an error when the scene loads (naming the material
and the wavelength). A glass disperses (and splits white light) only if its index
varies over the grid; :func:`constant` never does.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import math
from typing import Any
from collections.abc import Sequence

#: Fraunhofer lines of the Abbe number (nm): helium d, hydrogen F and C.
LAMBDA_D = 587.56
LAMBDA_F = 486.13
LAMBDA_C = 656.27


@dataclass(frozen=True)
class Ior:
    """An index-of-refraction model: ``kind`` and its parameters."""

    kind: str
    params: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {"type": self.kind, **self.params}


def _finite(value: Any, what: str) -> float:
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{what} = {value} is not finite")
    return v


def constant(ior: float) -> Ior:
    """The same index at every wavelength (no dispersion)."""
    return Ior("constant", {"ior": _finite(ior, "ior")})


def cauchy(a: float, b: float, c: float = 0.0) -> Ior:
    """Cauchy's formula n(λ) = A + B/λ² + C/λ⁴ with λ in µm (B in µm², C in µm⁴)."""
    return Ior("cauchy", {"a": _finite(a, "A"), "b": _finite(b, "B"), "c": _finite(c, "C")})


def sellmeier(b: Sequence[float], c: Sequence[float]) -> Ior:
    """Sellmeier's formula n² = 1 + Σ Bk λ²/(λ² − Ck), λ in µm, Ck in µm², up to 3 terms."""
    bs, cs = [float(x) for x in b], [float(x) for x in c]
    if len(bs) != len(cs) or not 1 <= len(bs) <= 3:
        raise ValueError(f"sellmeier: need 1 to 3 (B, C) pairs, got {len(bs)} B and {len(cs)} C")
    bs += [0.0] * (3 - len(bs))
    cs += [0.0] * (3 - len(cs))
    for i, (x, y) in enumerate(zip(bs, cs)):
        _finite(x, f"B{i + 1}")
        _finite(y, f"C{i + 1}")
    return Ior("sellmeier", {"b": bs, "c": cs})


def abbe(nd: float, vd: float) -> Ior:
    """Index ``nd`` at 587.56 nm and Abbe number ``vd`` = (nd − 1)/(nF − nC), as Blender
    gives them; mapped to the two-term Cauchy fit that reproduces both."""
    vd = _finite(vd, "Abbe number")
    if vd <= 0:
        raise ValueError(f"abbe: Abbe number {vd} must be positive (use constant() for no dispersion)")
    return Ior("abbe", {"nd": _finite(nd, "nd"), "vd": vd})


def named(name: str) -> Ior:
    """A catalogue glass with published Sellmeier coefficients: "N-BK7", "Fused Silica",
    "N-SF11", "Water", "Diamond" (case, '-', '_' and spaces are ignored)."""
    return Ior("named", {"name": str(name)})


def abbe_to_cauchy(nd: float, vd: float) -> tuple[float, float]:
    """(A, B) of the two-term Cauchy fit used for :func:`abbe` (λ in µm)."""
    inv2 = lambda nm: 1.0 / (nm * 1e-3) ** 2  # noqa: E731
    b = (nd - 1.0) / (vd * (inv2(LAMBDA_F) - inv2(LAMBDA_C)))
    return nd - b * inv2(LAMBDA_D), b


def as_ior(value: Any) -> Ior:
    """An :class:`Ior` from an Ior or a plain number (a constant index)."""
    if isinstance(value, Ior):
        return value
    if isinstance(value, (int, float)):
        return constant(value)
    if isinstance(value, str):
        return named(value)
    raise TypeError(f"ior: expected a number, a glass name or a polychrome.ior model, got {type(value).__name__}")


__all__ = ["Ior", "constant", "cauchy", "sellmeier", "abbe", "named", "abbe_to_cauchy", "as_ior"]
