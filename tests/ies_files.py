"""IES LM-63 files written for the tests (no vendored data): a type C profile over one
quadrant (0°–90° horizontally, mirrored by readers to the full circle), 0°–180°
vertically, candela c(h, v) = base · (1 + cos v)² · (1 + 0.5 cos 2h) so it is bright
downwards, dark upwards and varies around the axis."""

from __future__ import annotations

import numpy as np

V_ANGLES = np.arange(0.0, 180.01, 5.0)
H_QUADRANT = np.arange(0.0, 90.01, 15.0)


def candela(h_deg, v_deg, base=100.0):
    h, v = np.radians(h_deg), np.radians(v_deg)
    return base * (1 + np.cos(v)) ** 2 * (1 + 0.5 * np.cos(2 * h))


def quadrant_file(multiplier=1.0, base=100.0) -> str:
    """The file's text (TILT=NONE, one lamp, absolute photometry)."""
    rows = [[candela(h, v, base) for v in V_ANGLES] for h in H_QUADRANT]
    lines = [
        "IESNA:LM-63-2002",
        "[TEST] Polychrome quadrant profile",
        "TILT=NONE",
        f"1 -1 {multiplier} {len(V_ANGLES)} {len(H_QUADRANT)} 1 2 0.1 0.1 0.0",
        "1.0 1.0 100",
        " ".join(f"{a:g}" for a in V_ANGLES),
        " ".join(f"{a:g}" for a in H_QUADRANT),
    ]
    lines += [" ".join(f"{c:.6g}" for c in row) for row in rows]
    return "\n".join(lines) + "\n"
