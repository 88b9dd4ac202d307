#!/usr/bin/env python3
"""Generate the microfacet energy tables used by the Polychrome Rust core.

Run from the repository root with the project venv (numpy):

    .venv/bin/python tools/gen_energy_tables.py

Writes ``rust/core/src/material/energy_tables.rs`` (do not edit it by hand): the
directional albedo E(roughness, cos θ) of GGX lobes as Cycles tabulates them for its
multiple-scattering energy compensation (``intern/cycles/app/cycles_precompute.cpp`` in
Blender 4.5, read for its parametrisation only), computed here independently of the Rust
BSDF code so that the Rust white-furnace tests compare two implementations:

* ``GGX_E`` (32 roughness × 32 cos θ) and ``GGX_E_AVG`` (32): a GGX reflection lobe with
  Fresnel = 1, and its cosine-weighted average 2∫E(μ)μ dμ (Kulla & Conty 2017,
  "Revisiting Physically Based Shading at Imageworks");
* ``GLASS_E`` / ``GLASS_INV_E`` (16 index × 16 roughness × 16 cos θ) and their averages
  (16 × 16): a rough dielectric interface (reflection + refraction, exact dielectric
  Fresnel, energy not radiance: no 1/η² factor) seen from the side of relative index
  η > 1 (outside) and 1/η (inside);
* ``DIELECTRIC_E`` (16 × 16 × 16) and ``DIELECTRIC_E_AVG``: its reflection only (a
  coat, a Principled specular layer);
* ``FRESNEL_AVG`` / ``FRESNEL_INV_AVG`` (32 index): 2∫F(μ)μ dμ of the smooth interface.

Axes as in Cycles: roughness r = i/(n − 1) (Blender's roughness, alpha = r²), cos θ =
j/(n − 1), index through z = k/(n − 1) with F0 = z⁴, i.e. η = (1 + z²)/(1 − z²)
(z = √((η − 1)/(η + 1))), z clamped to [1e-4, 0.99]; the fastest axis is roughness.

Each entry integrates over the visible normals of GGX (Heitz 2018, "Sampling the GGX
Distribution of Visible Normals", JCGT 7(4)) on a STRATA × STRATA stratified grid; a
sampled normal contributes both its reflection F·G2/G1 and its refraction (1 − F)·G2/G1,
so the table has no lobe-selection noise. G2 is Smith's height-correlated masking-
shadowing. Cells are accurate to about 1e-3 (checked below against a finer grid and against
Cycles' own table at two points); averages use 24-point Gauss–Legendre quadrature in μ.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
OUT = REPO / "rust" / "core" / "src" / "material" / "energy_tables.rs"
STRATA = 128


def strata(n: int) -> tuple[np.ndarray, np.ndarray]:
    c = (np.arange(n) + 0.5) / n
    u1, u2 = np.meshgrid(c, c, indexing="ij")
    return u1.ravel(), u2.ravel()


U1, U2 = strata(STRATA)


def lam(alpha: float, w: np.ndarray) -> np.ndarray:
    """Smith's Λ for an isotropic GGX lobe; w is (..., 3)."""
    z2 = w[..., 2] ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        t = alpha * alpha * (w[..., 0] ** 2 + w[..., 1] ** 2) / z2
        out = 0.5 * (np.sqrt(1.0 + t) - 1.0)
    return np.where(z2 > 0, out, np.inf)


def sample_vndf(wo: np.ndarray, alpha: float) -> np.ndarray:
    """Visible normals of wo (a single direction, z > 0) at every stratum."""
    vh = np.array([alpha * wo[0], alpha * wo[1], wo[2]])
    vh /= np.linalg.norm(vh)
    lensq = vh[0] ** 2 + vh[1] ** 2
    if lensq > 1e-14:
        t1 = np.array([-vh[1], vh[0], 0.0]) / np.sqrt(lensq)
    else:
        t1 = np.array([1.0, 0.0, 0.0])
    t2 = np.cross(vh, t1)
    r = np.sqrt(U1)
    phi = 2.0 * np.pi * U2
    p1 = r * np.cos(phi)
    p2 = r * np.sin(phi)
    s = 0.5 * (1.0 + vh[2])
    p2 = (1.0 - s) * np.sqrt(np.maximum(0.0, 1.0 - p1 * p1)) + s * p2
    p3 = np.sqrt(np.maximum(0.0, 1.0 - p1 * p1 - p2 * p2))
    nh = p1[:, None] * t1 + p2[:, None] * t2 + p3[:, None] * vh
    ne = np.stack([alpha * nh[:, 0], alpha * nh[:, 1], np.maximum(nh[:, 2], 1e-9)], axis=1)
    return ne / np.linalg.norm(ne, axis=1, keepdims=True)


def fresnel(cos_i: np.ndarray, eta: float) -> tuple[np.ndarray, np.ndarray]:
    """Dielectric Fresnel reflectance for light arriving at cos_i > 0 on the side of
    relative index eta (far side over near side), and cos θt (0 under TIR)."""
    sin2_t = (1.0 - cos_i * cos_i) / (eta * eta)
    tir = sin2_t >= 1.0
    cos_t = np.sqrt(np.maximum(0.0, 1.0 - sin2_t))
    rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    f = np.where(tir, 1.0, 0.5 * (rs * rs + rp * rp))
    return np.clip(f, 0.0, 1.0), np.where(tir, 0.0, cos_t)


def albedo(rough: float, mu: float, eta: float | None, transmit: bool) -> float:
    """Directional albedo of a GGX lobe seen from cos θ = mu. eta None: Fresnel = 1."""
    alpha = max(rough * rough, 1e-4)
    wo = np.array([np.sqrt(max(0.0, 1.0 - mu * mu)), 0.0, mu])
    m = sample_vndf(wo, alpha)
    c = np.clip(m @ wo, 0.0, 1.0)
    lo = lam(alpha, wo[None, :])[0]
    g1 = 1.0 / (1.0 + lo)
    wr = 2.0 * c[:, None] * m - wo
    ok_r = wr[:, 2] > 0
    g2r = 1.0 / (1.0 + lo + lam(alpha, wr))
    if eta is None:
        f = np.ones_like(c)
        cos_t = np.zeros_like(c)
    else:
        f, cos_t = fresnel(c, eta)
    total = np.where(ok_r, f * g2r / g1, 0.0)
    if transmit:
        wt = -wo / eta + (c / eta - cos_t)[:, None] * m
        ok_t = (wt[:, 2] < 0) & (f < 1.0)
        g2t = 1.0 / (1.0 + lo + lam(alpha, np.where(ok_t[:, None], wt, -wo)))
        total = total + np.where(ok_t, (1.0 - f) * g2t / g1, 0.0)
    return float(np.mean(total))


def axis(n: int, lo: float = 1e-4, hi: float = 1.0) -> np.ndarray:
    return np.clip(np.arange(n) / (n - 1), lo, hi)


def ior_of_z(z: float) -> float:
    return (1.0 + z * z) / (1.0 - z * z)


def average(table_mu: np.ndarray, mus: np.ndarray) -> float:
    """2∫E(μ)μ dμ by the trapezoidal rule on a fine μ grid."""
    y = 2.0 * table_mu * mus
    return float(np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(mus)))


# Gauss–Legendre nodes and weights on [0, 1] for the cosine-weighted averages.
_X, _W = np.polynomial.legendre.leggauss(24)
AVG_MU = 0.5 * (_X + 1.0)
AVG_W = 0.5 * _W


def gauss_average(values: np.ndarray) -> float:
    """2∫E(μ)μ dμ from E at AVG_MU."""
    return float(np.sum(2.0 * values * AVG_MU * AVG_W))


def table_2d(n_r: int, n_mu: int, eta: float | None, transmit: bool) -> tuple[np.ndarray, np.ndarray]:
    rs = axis(n_r)
    mus = axis(n_mu)
    e = np.array([[albedo(r, mu, eta, transmit) for r in rs] for mu in mus])
    avg = np.array([gauss_average(np.array([albedo(r, mu, eta, transmit) for mu in AVG_MU])) for r in rs])
    return e, avg


def table_3d(n: int, inverse: bool, transmit: bool) -> tuple[np.ndarray, np.ndarray]:
    es, avgs = [], []
    for z in axis(n, 1e-4, 0.99):
        eta = ior_of_z(z)
        if inverse:
            eta = 1.0 / eta
        e, avg = table_2d(n, n, eta, transmit)
        es.append(e)
        avgs.append(avg)
        print(f"  z {z:.3f} η {eta:.4f}: E(r=0.5, μ=0.5) {e[n // 2, n // 2]:.4f}", file=sys.stderr)
    return np.array(es), np.array(avgs)


def fresnel_average(n: int, inverse: bool) -> np.ndarray:
    mus = np.linspace(0.0, 1.0, 20001)
    out = []
    for z in axis(n, 1e-4, 0.99):
        eta = ior_of_z(z)
        if inverse:
            eta = 1.0 / eta
        f, _ = fresnel(np.maximum(mus, 1e-12), eta)
        out.append(average(f, mus))
    return np.array(out)


def rust_array(name: str, doc: str, values: np.ndarray, per_line: int = 16) -> str:
    flat = values.ravel()
    lines = [f"/// {doc}", "#[rustfmt::skip]", f"pub static {name}: [f32; {flat.size}] = ["]
    for i in range(0, flat.size, per_line):
        lines.append("    " + " ".join(f"{v:.6f}," for v in flat[i : i + per_line]))
    lines.append("];")
    return "\n".join(lines)


def self_check() -> None:
    """Closed forms and a finer grid: smooth limits, the quadrature's accuracy."""
    # A nearly smooth glass conserves energy; a nearly smooth reflection reflects F(μ).
    for eta in (1.5, 1 / 1.5):
        assert abs(albedo(0.0, 0.7, eta, True) - 1.0) < 1e-3
        f, _ = fresnel(np.array([0.7]), eta)
        assert abs(albedo(0.0, 0.7, eta, False) - f[0]) < 1e-3
    # F = 1: Cycles' own tabulation (intern/cycles/scene/shader.tables, table_ggx_E,
    # Blender 4.5) at roughness 12/31 and 28/31, normal incidence: 0.971982, 0.415925.
    for r, ref in ((12 / 31, 0.971982), (28 / 31, 0.415925)):
        e = albedo(r, 1.0, None, False)
        assert abs(e - ref) < 2e-3, (r, e, ref)
    global U1, U2
    coarse = albedo(0.6, 0.3, 1.5, True)
    U1, U2 = strata(2 * STRATA)
    fine = albedo(0.6, 0.3, 1.5, True)
    U1, U2 = strata(STRATA)
    assert abs(coarse - fine) < 1e-3, (coarse, fine)
    # The average of Fresnel at η = 1.5 (closed form of Stern 1964: 0.0918).
    fa = fresnel_average(32, False)
    z15 = np.sqrt(0.5 / 2.5)
    i = z15 * 31
    k = int(i)
    v = fa[k] * (1 - (i - k)) + fa[k + 1] * (i - k)
    assert abs(v - 0.0918) < 3e-3, v


def main() -> None:
    self_check()
    print("GGX E (F = 1)", file=sys.stderr)
    ggx_e, ggx_avg = table_2d(32, 32, None, False)
    print("glass E, η > 1", file=sys.stderr)
    glass_e, glass_avg = table_3d(16, False, True)
    print("glass E, η < 1", file=sys.stderr)
    glass_inv_e, glass_inv_avg = table_3d(16, True, True)
    print("dielectric reflection E", file=sys.stderr)
    diel_e, diel_avg = table_3d(16, False, False)
    fa = fresnel_average(32, False)
    fia = fresnel_average(32, True)
    parts = [
        "//! Generated by tools/gen_energy_tables.py: do not edit by hand.",
        "//!",
        "//! Directional albedos of GGX lobes for multiple-scattering energy compensation; see",
        "//! that script for what each table holds and [`super::energy`] for the lookups.",
        "#![allow(clippy::approx_constant)] // computed data that happens to be near π etc.",
        "",
        rust_array("GGX_E", "E(r, μ) of GGX reflection with F = 1: 32 μ rows of 32 roughness.", ggx_e),
        "",
        rust_array("GGX_E_AVG", "2∫E(μ)μ dμ of [`GGX_E`] per roughness.", ggx_avg),
        "",
        rust_array("GLASS_E", "E(r, μ, z) of a rough dielectric (η > 1): 16 z slabs of 16 μ rows of 16 r.", glass_e),
        "",
        rust_array("GLASS_E_AVG", "2∫E μ dμ of [`GLASS_E`]: 16 z rows of 16 r.", glass_avg),
        "",
        rust_array("GLASS_INV_E", "As [`GLASS_E`] seen from inside (relative index 1/η).", glass_inv_e),
        "",
        rust_array("GLASS_INV_E_AVG", "2∫E μ dμ of [`GLASS_INV_E`].", glass_inv_avg),
        "",
        rust_array("DIELECTRIC_E", "E(r, μ, z) of the reflection of a rough dielectric (η > 1).", diel_e),
        "",
        rust_array("DIELECTRIC_E_AVG", "2∫E μ dμ of [`DIELECTRIC_E`].", diel_avg),
        "",
        rust_array("FRESNEL_AVG", "2∫F(μ)μ dμ of a smooth dielectric per z (η > 1).", fa),
        "",
        rust_array("FRESNEL_INV_AVG", "As [`FRESNEL_AVG`] seen from inside (1/η).", fia),
        "",
    ]
    OUT.write_text("\n".join(parts))
    print(f"wrote {OUT.relative_to(REPO)}", file=sys.stderr)


if __name__ == "__main__":
    main()
