"""IES light profiles (IESNA LM-63 photometric files) for point and spot lights.

``read(path)`` / ``parse(text)`` give an :class:`IESProfile`: the file's candela table
processed as Cycles processes it (``intern/cycles/util/ies.cpp``: types A, B and C
turned into type C's angles, symmetric files mirrored to the full circle, angles in
radians) and scaled as Cycles scales it, candela × multiplier × ballast factors × 4π/177.83
(177.83 lm/W: D65's luminous efficacy; 4π: Cycles' light strength is a power), so that a
light of power 1 W with this profile has the file's absolute intensity in Cycles' units.
Pass it as ``profile=`` to :class:`polychrome.PointLight` or :class:`polychrome.SpotLight`;
the light's ``orientation`` turns it (by default the light shines down −Z, the profile's
0° vertical angle). Tilt data (``TILT=INCLUDE``) is read past and ignored, as in Cycles.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

#: Candela → Cycles' light-strength units (4π / 177.83), as util/ies.cpp.
CANDELA_TO_STRENGTH = 0.0706650768394


@dataclass
class IESProfile:
    """A processed IES table: ``h_angles`` ∈ [0, 2π] and ``v_angles`` ∈ [0, π]
    (radians, increasing; v = 0 straight down the light's −Z), ``values[i, j]`` at
    (h_angles[i], v_angles[j])."""

    h_angles: np.ndarray
    v_angles: np.ndarray
    values: np.ndarray
    name: str = "IES"

    def sphere_mean(self) -> float:
        """The mean of the profile over all directions (∫ I dω / 4π), by the midpoint rule
        uniform in cos v and h with linear interpolation of the table."""
        n = 256
        cos_v = 1.0 - 2.0 * (np.arange(n) + 0.5) / n
        v = np.arccos(cos_v)
        h = (np.arange(n) + 0.5) / n * 2.0 * np.pi
        inside_v = (v >= self.v_angles[0]) & (v < self.v_angles[-1])
        inside_h = (h >= self.h_angles[0]) & (h < self.h_angles[-1])
        # Along v per table row, then along h.
        rows = np.stack([np.interp(v, self.v_angles, row) for row in np.asarray(self.values)])  # (H, n)
        grid = np.stack([np.interp(h, self.h_angles, rows[:, j]) for j in range(n)], 1)  # (n_h, n_v)
        return float((grid * inside_h[:, None] * inside_v[None, :]).mean())

    def to_dict(self, orientation=None) -> dict:
        """The scene description's ``profile`` for a light of ``orientation`` (3 × 3, its
        local axes as columns in world space; None: shining down world −Z)."""
        r = np.eye(3) if orientation is None else np.asarray(orientation, np.float64)
        if r.shape != (3, 3) or not np.all(np.isfinite(r)):
            raise ValueError(f"IES profile '{self.name}': orientation must be a finite 3 × 3 rotation")
        u, _, vt = np.linalg.svd(r)  # the nearest rotation: a light's scale does not turn its profile
        r = u @ vt
        return {
            "h_angles": [float(x) for x in self.h_angles],
            "v_angles": [float(x) for x in self.v_angles],
            "values": [float(x) for x in np.asarray(self.values).ravel()],
            "to_local": r.T.tolist(),  # rows of world → light
        }


def angle_scaled(profile: IESProfile, angle_scale: float) -> IESProfile:
    """The profile with its vertical angles rescaled as UsdLux's ``shaping:ies:angleScale``
    s defines it (OpenUSD's ShapingAPI user documentation, usdLux/userDoc): a direction
    at vertical angle θ from the light's axis reads the table at θ_ies = θ / s for s > 0
    (scaled about straight down: s < 1 narrows a downlight's beam, s > 1 widens it),
    θ_ies = (θ − π) / −s + π for s < 0 (scaled about straight up), θ for s = 0; θ_ies
    clamped to [0, π]. A table vertical angle a therefore moves to a·s (s > 0) or
    π + |s|·(a − π) (s < 0), which keeps the interpolation between table entries exact;
    where the clamp holds the profile at a pole the table reaches, the pole's value is
    added at 0 or π, and a table stretched past a pole is cut there with the value at the
    pole interpolated linearly. The values (and any normalisation already applied) stay."""
    s = float(angle_scale)
    if not np.isfinite(s):
        raise ValueError(f"IES profile '{profile.name}': angleScale {s} is not finite")
    v = np.asarray(profile.v_angles, np.float64)
    vals = np.asarray(profile.values, np.float64)
    if s == 0.0:
        return IESProfile(profile.h_angles.copy(), v.copy(), vals.copy(), profile.name)
    new = v * s if s > 0 else np.pi + (-s) * (v - np.pi)
    eps = 1e-6

    def at(theta_ies):  # each row of the table at one vertical angle (linear)
        return np.array([np.interp(theta_ies, v, row) for row in vals])[:, None]

    if new[-1] > np.pi + eps:  # stretched past straight up: cut at π
        keep = new < np.pi - eps
        new, vals = np.append(new[keep], np.pi), np.concatenate([vals[:, keep], at(np.pi / s)], 1)
    if new[0] < -eps:  # stretched past straight down (s < −1): cut at 0
        keep = new > eps
        new, vals = np.insert(new[keep], 0, 0.0), np.concatenate([at(np.pi - np.pi / -s), vals[:, keep]], 1)
    if v[-1] >= np.pi - eps and new[-1] < np.pi - eps:  # θ_ies clamped to π: the top's value above
        new, vals = np.append(new, np.pi), np.concatenate([vals, vals[:, -1:]], 1)
    if v[0] <= eps and new[0] > eps:  # θ_ies clamped to 0: the bottom's value below
        new, vals = np.insert(new, 0, 0.0), np.concatenate([vals[:, :1], vals], 1)
    if len(new) < 2 or np.any(np.diff(new) <= 0):
        raise ValueError(f"IES profile '{profile.name}': angleScale {s} leaves fewer than 2 vertical angles")
    return IESProfile(profile.h_angles.copy(), new, vals, profile.name)


def read(path) -> IESProfile:
    """The profile in the IES file at ``path``; ``ValueError`` naming the file if it cannot be read."""
    try:
        with open(path, encoding="latin-1") as f:
            text = f.read()
    except OSError as e:
        raise ValueError(f"IES file '{path}': {e.strerror or e}") from None
    return parse(text, name=os.path.basename(str(path)))


def _numbers(text: str, name: str):
    for tok in text.replace(",", " ").split():
        try:
            yield float(tok)
        except ValueError:
            raise ValueError(f"IES file '{name}': '{tok}' is not a number") from None


def parse(text: str, name: str = "IES") -> IESProfile:
    """The profile of IES file contents ``text`` (``name`` for messages)."""
    lines = text.splitlines()
    tilt = next((i for i, line in enumerate(lines) if line.strip().upper().startswith("TILT")), None)
    if tilt is None:
        raise ValueError(f"IES file '{name}': no TILT line (not an IES LM-63 file?)")
    rest = "\n".join(lines[tilt + 1 :])
    nums = list(_numbers(rest, name))
    k = 0
    if lines[tilt].strip().upper().startswith("TILT=INCLUDE"):
        # Lamp-to-luminaire geometry, then the tilt angles and factors: skipped.
        count = int(nums[1]) if len(nums) > 1 else 0
        k = 2 + 2 * count
    head = nums[k : k + 13]
    if len(head) < 13:
        raise ValueError(f"IES file '{name}': the photometric header is cut short")
    factor = head[2] * head[10] * head[11] * CANDELA_TO_STRENGTH
    nv, nh, kind = int(head[3]), int(head[4]), int(head[5])
    if kind not in (1, 2, 3):
        raise ValueError(f"IES file '{name}': photometric type {kind} is not 1 (C), 2 (B) or 3 (A)")
    if nv < 1 or nh < 1:
        raise ValueError(f"IES file '{name}': {nv} vertical and {nh} horizontal angles")
    k += 13
    body = nums[k : k + nv + nh + nv * nh]
    if len(body) < nv + nh + nv * nh:
        raise ValueError(f"IES file '{name}': {len(body)} numbers where the header promises {nv + nh + nv * nh}")
    v = list(body[:nv])
    h = list(body[nv : nv + nh])
    cd = np.array(body[nv + nh :], np.float64).reshape(nh, nv) * factor
    intensity = [list(row) for row in cd]
    h, v, intensity = {1: _type_c, 2: _type_b, 3: _type_a}[kind](h, v, intensity)
    ha, va = np.radians(np.array(h, np.float64)), np.radians(np.array(v, np.float64))
    values = np.array(intensity, np.float64)
    if len(ha) < 2 or len(va) < 2 or np.any(np.diff(ha) <= 0) or np.any(np.diff(va) <= 0):
        raise ValueError(f"IES file '{name}': its angles do not increase (or fewer than 2 of a kind)")
    if not np.all(np.isfinite(values)) or np.any(values < 0):
        raise ValueError(f"IES file '{name}': candela values must be finite and non-negative")
    return IESProfile(ha, va, values, name)


def _close(a: float, b: float) -> bool:
    return abs(a - b) < 1e-4


def _type_c(h, v, intensity):
    """Type C as Cycles' ``process_type_c``: rotate 90°–270° files, mirror quadrants
    and halves to the full circle, close it with the 360° entry."""
    if _close(h[0], 90.0):
        h = [a - 90.0 for a in h]
    if len(h) == 1:
        h = [0.0, 360.0]
        intensity = [intensity[0], intensity[0]]
    if _close(h[-1], 90.0):
        n = len(h)
        for i in range(n - 2, -1, -1):
            h.append(180.0 - h[i])
            intensity.append(intensity[i])
    if _close(h[-1], 180.0):
        n = len(h)
        for i in range(n - 2, -1, -1):
            h.append(360.0 - h[i])
            intensity.append(intensity[i])
    if _close(h[0], 0.0) and not _close(h[-1], 360.0) and len(h) > 1:
        last, first, gap = h[-1] - h[-2], h[1] - h[0], 360.0 - h[-1]
        if _close(last, gap) or _close(first, gap):
            h.append(360.0)
            intensity.append(intensity[0])
    return h, v, intensity


def _type_a(h, v, intensity):
    """Type A as Cycles' ``process_type_a``: vertical angles shifted by 90°, −90°..90°
    horizontally mapped to 270°..90°, mirrored when the file starts at 0°."""
    v = [a + 90.0 for a in v]
    new_h = [180.0 - h[i] for i in range(len(h) - 1, -1, -1)]
    new_i = [intensity[i] for i in range(len(h) - 1, -1, -1)]
    if _close(h[0], 0.0):
        for i in range(1, len(h)):
            new_h.append(180.0 + h[i])
            new_i.append(intensity[i])
    return new_h, v, new_i


def _type_b(h, v, intensity):
    """Type B as Cycles' ``process_type_b``: the axes transposed (the polar axis made
    vertical), then each mirrored or shifted to 0°..180°."""
    intensity = [[intensity[j][i] for j in range(len(h))] for i in range(len(v))]
    h, v = v, h
    if _close(h[0], 0.0):
        n = len(h)
        new_h = [90.0 - h[i] for i in range(n - 1, 0, -1)] + [90.0 + a for a in h]
        new_i = [intensity[i] for i in range(n - 1, 0, -1)] + list(intensity)
        h, intensity = new_h, new_i
    else:
        h = [a + 90.0 for a in h]
    if _close(v[0], 0.0):
        n = len(v)
        v = [90.0 - v[i] for i in range(n - 1, 0, -1)] + [90.0 + a for a in v]
        intensity = [[row[j] for j in range(n - 1, 0, -1)] + list(row) for row in intensity]
    else:
        v = [a + 90.0 for a in v]
    return h, v, intensity
