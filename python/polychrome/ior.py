"""Indices of refraction for :class:`polychrome.Dielectric` (docs/materials.md).

Each helper returns an :class:`Ior`, a small description the core evaluates on the
render's wavelength grid. An index that is not finite, below 1 or near a Sellmeier
pole at any grid wavelength is an error when the scene loads (naming the material
and the wavelength). A glass disperses (and splits white light) only if its index
varies over the grid; :func:`constant` never does.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import json
import math
from typing import Any
from collections.abc import Sequence

from . import _core

#: Fraunhofer lines of the Abbe number (nm): helium d, hydrogen F and C, as SCHOTT and
#: ISO 7944 give them; defined once, in the core (material/dispersion.rs).
LAMBDA_D: float = _core.LAMBDA_D
LAMBDA_F: float = _core.LAMBDA_F
LAMBDA_C: float = _core.LAMBDA_C
#: The named glasses of the core's catalogue (material/catalogue.rs): name → dict of
#: aliases, Sellmeier ``b`` and ``c`` (µm²), published ``nd`` and ``vd``, ``source``.
GLASSES: dict[str, dict[str, Any]] = {g["name"]: g for g in _core.glass_catalogue()}


@dataclass(frozen=True)
class Ior:
    """An index-of-refraction model: ``kind`` and its parameters."""

    kind: str
    params: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {"type": self.kind, **self.params}

    def index_at(self, wavelength_nm: float) -> float:
        """The index at ``wavelength_nm`` as the core evaluates it (NaN where the model is
        undefined, e.g. at a Sellmeier pole)."""
        return _core.ior_index(json.dumps(self.to_dict()), [float(wavelength_nm)])[0]


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
    """Index ``nd`` at the d line (:data:`LAMBDA_D`) and Abbe number ``vd`` = (nd − 1)/(nF − nC), as Blender
    gives them; mapped to the two-term Cauchy fit that reproduces both."""
    vd = _finite(vd, "Abbe number")
    if vd <= 0:
        raise ValueError(f"abbe: Abbe number {vd} must be positive (use constant() for no dispersion)")
    return Ior("abbe", {"nd": _finite(nd, "nd"), "vd": vd})


def named(name: str) -> Ior:
    """A catalogue glass with published Sellmeier coefficients (:data:`GLASSES`: "N-BK7",
    "Fused Silica", "N-SF11", "Water", "Diamond", ...; case, '-', '_' and spaces are ignored)."""
    return Ior("named", {"name": str(name)})


def abbe_to_cauchy(nd: float, vd: float) -> tuple[float, float]:
    """(A, B in µm²) of the two-term Cauchy fit used for :func:`abbe` (λ in µm): the core's."""
    return _core.abbe_to_cauchy(float(nd), float(vd))


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
