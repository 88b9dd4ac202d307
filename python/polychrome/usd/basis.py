"""UsdGeom.BasisCurves evaluated into polylines (what ``Scene.add_curves(linear=True)``
tessellates). The cubic bases, their vertex steps and the ``nonperiodic`` / ``periodic``
/ ``pinned`` wraps follow the UsdGeomBasisCurves documentation ("Segment Indexing",
"Cubic Vertex Interpolation", "Pinned Curves"): a segment t ∈ [0, 1] is
[t³ t² t 1] · M · [P0 P1 P2 P3]ᵀ with the matrices below (the standard Bézier,
uniform B-spline and Catmull-Rom basis matrices)."""

from __future__ import annotations

import numpy as np

#: Samples per cubic segment of the polyline a cubic curve becomes.
SAMPLES_PER_SEGMENT = 8

#: basis → (M, vstep).
CUBIC_BASES = {
    "bezier": (np.array([[-1, 3, -3, 1], [3, -6, 3, 0], [-3, 3, 0, 0], [1, 0, 0, 0]], np.float64), 3),
    "bspline": (np.array([[-1, 3, -3, 1], [3, -6, 3, 0], [-3, 0, 3, 0], [1, 4, 1, 0]], np.float64) / 6.0, 1),
    "catmullRom": (np.array([[-1, 3, -3, 1], [2, -5, 4, -1], [-1, 0, 1, 0], [0, 2, 0, 0]], np.float64) / 2.0, 1),
}


def segment_count(n: int, ctype: str, basis: str, wrap: str) -> int:
    """Segments of one curve of ``n`` vertices (0: too few vertices)."""
    if ctype == "linear":
        return n if wrap == "periodic" and n >= 2 else max(n - 1, 0)
    vstep = CUBIC_BASES[basis][1]
    if wrap == "periodic":
        return n // vstep if n >= 4 - (vstep == 1) else 0
    if wrap == "pinned" and basis != "bezier":
        n += 2  # the phantom points
    return (n - 4) // vstep + 1 if n >= 4 else 0


def evaluate_curve(p: np.ndarray, w: np.ndarray, w_varying: bool, ctype: str, basis: str, wrap: str):
    """One curve's vertices ``p`` (n, 3) and widths ``w`` (per vertex, or per segment end
    when ``w_varying``) → (polyline (m, 3), widths (m,)); None when it has too few vertices."""
    out = evaluate_curves(p[None], w[None], w_varying, ctype, basis, wrap)
    return None if out is None else (out[0][0], out[1][0])


def evaluate_curves(p: np.ndarray, w: np.ndarray, w_varying: bool, ctype: str, basis: str, wrap: str):
    """A batch of curves with the same vertex count: ``p`` (c, n, 3), ``w`` (c, n) or
    (c, ends) → (polylines (c, m, 3), widths (c, m)); None when n is too few."""
    n = p.shape[1]
    nseg = segment_count(n, ctype, basis, wrap)
    if nseg == 0:
        return None
    if ctype == "linear":
        if wrap == "periodic":
            return np.concatenate([p, p[:, :1]], 1), np.concatenate([w, w[:, :1]], 1)
        return p, w
    m, vstep = CUBIC_BASES[basis]
    if wrap == "pinned" and basis != "bezier":  # phantom points 2·P0 − P1 and 2·Pn−1 − Pn−2
        p = np.concatenate([2 * p[:, :1] - p[:, 1:2], p, 2 * p[:, -1:] - p[:, -2:-1]], 1)
        if not w_varying:
            w = np.concatenate([2 * w[:, :1] - w[:, 1:2], w, 2 * w[:, -1:] - w[:, -2:-1]], 1)
    idx = (np.arange(nseg)[:, None] * vstep + np.arange(4)[None, :]) % p.shape[1]
    t = np.linspace(0.0, 1.0, SAMPLES_PER_SEGMENT + 1)
    weights = np.stack([t**3, t**2, t, np.ones_like(t)], 1) @ m  # (S+1, 4)
    pts = np.einsum("sk,cnkd->cnsd", weights, p[:, idx])
    if w_varying:  # one width per segment end, linear along the segment
        ends = w if w.shape[1] == nseg + 1 else np.concatenate([w, w[:, :1]], 1)  # periodic: closes onto the first
        ws = ends[:, :-1, None] * (1 - t)[None, None] + ends[:, 1:, None] * t[None, None]
    else:
        ws = np.einsum("sk,cnk->cns", weights, w[:, idx])
    keep = np.ones((nseg, SAMPLES_PER_SEGMENT + 1), bool)
    keep[:-1, -1] = False  # segment ends are the next segment's starts
    c = len(p)
    return pts[:, keep].reshape(c, -1, 3), np.maximum(ws[:, keep].reshape(c, -1), 0.0)


def varying_count(n: int, ctype: str, basis: str, wrap: str) -> int:
    """Values of a varying primvar on one curve: one per segment end."""
    nseg = segment_count(n, ctype, basis, wrap)
    if ctype == "linear":
        return n
    return nseg if wrap == "periodic" else nseg + 1
