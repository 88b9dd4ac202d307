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
* ``GLASS_E`` / ``GLASS_INV_E`` (32 index × 32 cos θ × 16 roughness) and their averages
  (16 × 16): a rough dielectric interface (reflection + refraction, exact dielectric
  Fresnel, energy not radiance: no 1/η² factor) seen from the side of relative index
  η > 1 (outside) and 1/η (inside). Finer than Cycles' 16³ ``ggx_glass_E``, on a √μ axis,
  and conservative (see ``conservative``): near grazing view and η ≈ 1 the albedo changes
  within a fraction of one of Cycles' cells (from inside, the critical angle sweeps
  μ = 0..0.13 between its first two index slabs), and a lookup below the true albedo E
  makes the compensated lobe 1/E_table · E return more energy than it receives (Cycles'
  table gave 2.58 at η 1.01 from inside, roughness 0.95, μ 0.01);
* ``DIELECTRIC_E`` (16 × 16 × 16) and ``DIELECTRIC_E_AVG``: its reflection only (a
  coat, a Principled specular layer);
* ``FRESNEL_AVG`` / ``FRESNEL_INV_AVG`` (32 index): 2∫F(μ)μ dμ of the smooth interface.

Axes as in Cycles: roughness r = i/(n − 1) (Blender's roughness, alpha = r²), cos θ =
j/(n − 1), index through z = k/(n − 1) with F0 = z⁴, i.e. η = (1 + z²)/(1 − z²)
(z = √((η − 1)/(η + 1))), z clamped to [1e-4, 0.99]; the fastest axis is roughness. The
glass E tables differ in their cos θ axis only: √μ = j/(n − 1) (μ clamped to ≥ 1e-4).

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


# The glass E tables: GLASS_NZ index slabs of GLASS_NMU rows (√μ = j/(n − 1)) of GLASS_NR
# roughness; the Rust lookup (material/energy.rs, glass_e) reads them on these axes.
GLASS_NR, GLASS_NMU, GLASS_NZ = 16, 32, 32
# A lookup may fall below the true albedo by this fraction at most (at the check points).
GLASS_SLACK = 0.002


def glass_mu(y: float) -> float:
    return max(y * y, 1e-4)


def glass_eta(z: float, inverse: bool) -> float:
    eta = ior_of_z(z)
    return 1.0 / eta if inverse else eta


def glass_cell(x: float, n: int) -> tuple[int, int, float]:
    """As energy.rs' cell(): (i0, i1, weight of i1) of x in [0, 1] on n samples."""
    x = min(max(x, 0.0), 1.0) * (n - 1)
    i = min(int(x), n - 1)
    return i, min(i + 1, n - 1), x - i


def glass_weights(r: float, y: float, z: float) -> list[tuple[tuple[int, int, int], float]]:
    """The (k, j, i) nodes and trilinear weights a lookup at (r, √μ, z) reads."""
    i0, i1, tx = glass_cell(r, GLASS_NR)
    j0, j1, ty = glass_cell(y, GLASS_NMU)
    k0, k1, tz = glass_cell(z, GLASS_NZ)
    out = []
    for k, wz in ((k0, 1 - tz), (k1, tz)):
        for j, wy in ((j0, 1 - ty), (j1, ty)):
            for i, wx in ((i0, 1 - tx), (i1, tx)):
                w = wz * wy * wx
                if w > 0:
                    out.append(((k, j, i), w))
    return out


def conservative(table: np.ndarray, inverse: bool) -> tuple[np.ndarray, float, float]:
    """Raise nodes until no lookup at the check points falls below the true albedo by more
    than GLASS_SLACK: the compensation 1/E_table then never returns more energy than the
    lobe receives (beyond the slack), at the cost of a little loss where a raised node is
    read away from its steep neighbourhood. Check points: every cell's centre; in the
    grazing / η ≈ 1 corner (the first 6 √μ or index cells) four more per cell; in the
    first two √μ cells (μ < 0.0042, where E changes fastest) twelve more, and the rows
    μ = 1e-5 and 1e-4. Returns the table and the worst true/lookup ratio before and after."""
    points = []
    for k in range(GLASS_NZ - 1):
        for j in range(GLASS_NMU - 1):
            fracs = [(0.5, 0.5, 0.5)]
            if j < 6 or k < 6:
                fracs += [(0.5, fy, fz) for fy in (0.25, 0.75) for fz in (0.25, 0.75)]
            if j < 2:
                fracs += [(fr, fy, fz) for fr in (0.25, 0.75) for fy in (0.2, 0.5, 0.8) for fz in (0.25, 0.75)]
            for fr, fy, fz in fracs:
                y, z = (j + fy) / (GLASS_NMU - 1), (k + fz) / (GLASS_NZ - 1)
                for i in range(GLASS_NR - 1):
                    points.append(((i + fr) / (GLASS_NR - 1), y, z))
        for mu in (1e-5, 1e-4):
            for fz in (0.25, 0.75):
                for i in range(GLASS_NR - 1):
                    points.append(((i + 0.5) / (GLASS_NR - 1), np.sqrt(mu), (k + fz) / (GLASS_NZ - 1)))
    truth = np.array([albedo(r, max(y * y, 1e-6), glass_eta(max(z, 1e-4), inverse), True) for r, y, z in points])
    weights = [glass_weights(r, y, z) for r, y, z in points]
    out = table.copy()

    def worst() -> float:
        return max(e / max(sum(w * out[n] for n, w in ws), 1e-9) for e, ws in zip(truth, weights))

    before = worst()
    for _ in range(50):
        raised = False
        for e, ws in zip(truth, weights):
            look = sum(w * out[n] for n, w in ws)
            if look * (1.0 + GLASS_SLACK) < e:
                s = e / ((1.0 + GLASS_SLACK) * max(look, 1e-9))
                for n, _ in ws:
                    out[n] = min(1.0, out[n] * s)
                raised = True
        if not raised:
            break
    return out, before, worst()


def table_avg(n: int, inverse: bool) -> np.ndarray:
    """2∫E(μ)μ dμ of the glass per (z, r), n × n on Cycles' axes."""
    return np.array(
        [
            [gauss_average(np.array([albedo(r, mu, glass_eta(z, inverse), True) for mu in AVG_MU])) for r in axis(n)]
            for z in axis(n, 1e-4, 0.99)
        ]
    )


def table_glass(inverse: bool) -> np.ndarray:
    """E on the glass axes (index slabs of √μ rows of roughness), made conservative."""
    rs = axis(GLASS_NR)
    e = np.array(
        [
            [[albedo(r, glass_mu(j / (GLASS_NMU - 1)), glass_eta(z, inverse), True) for r in rs] for j in range(GLASS_NMU)]
            for z in axis(GLASS_NZ, 1e-4, 0.99)
        ]
    )
    e, before, after = conservative(e, inverse)
    side = "inside" if inverse else "outside"
    print(f"  {side}: worst true/lookup at the check points {before:.3f} -> {after:.4f}", file=sys.stderr)
    return e


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
    glass_avg = table_avg(16, False)
    glass_e = table_glass(False)
    print("glass E, η < 1", file=sys.stderr)
    glass_inv_avg = table_avg(16, True)
    glass_inv_e = table_glass(True)
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
        rust_array(
            "GLASS_E",
            "E(r, μ, z) of a rough dielectric (η > 1): 32 z slabs of 32 √μ rows of 16 r, conservative.",
            glass_e,
        ),
        "",
        rust_array("GLASS_E_AVG", "2∫E μ dμ of the glass (η > 1): 16 z rows of 16 r.", glass_avg),
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
