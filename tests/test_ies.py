"""IES profiles (polychrome.ies): the LM-63 reader against the file's own numbers and
Cycles' processing rules, and a point light with a profile over a plane against the
closed form L = ρ/π · P/(4π) · c(h, v) · 4π/177.83 · cos θ / d²."""

from __future__ import annotations

import math

import numpy as np
import pytest

import polychrome as pc
from polychrome import ies
from ies_files import H_QUADRANT, V_ANGLES, candela, quadrant_file
from meshes import square


def test_a_quadrant_file_is_mirrored_to_the_full_circle_and_scaled_as_cycles():
    p = ies.parse(quadrant_file(multiplier=2.0), "q.ies")
    # 0..90 -> 0..180 -> 0..360: 7 + 6 + 12 entries, 360 included.
    np.testing.assert_allclose(np.degrees(p.h_angles), np.arange(0.0, 360.01, 15.0), atol=1e-9)
    np.testing.assert_allclose(np.degrees(p.v_angles), V_ANGLES)
    factor = 2.0 * 4 * math.pi / 177.83  # multiplier × ballast (1 × 1) × 4π / D65's 177.83 lm/W
    for i, h in enumerate(np.degrees(p.h_angles)):
        np.testing.assert_allclose(p.values[i], factor * candela(h, V_ANGLES), rtol=2e-5)
    assert len(H_QUADRANT) == 7


def test_bad_files_are_errors_naming_the_file(tmp_path):
    with pytest.raises(ValueError, match="missing.ies"):
        ies.read(tmp_path / "missing.ies")
    with pytest.raises(ValueError, match="'x.ies'.*TILT"):
        ies.parse("IESNA:LM-63\n1 2 3\n", "x.ies")
    text = quadrant_file()
    with pytest.raises(ValueError, match="'cut.ies'"):
        ies.parse(text[: len(text) // 2], "cut.ies")


def test_a_profiled_point_light_lights_a_plane_as_the_closed_form(tmp_path):
    path = tmp_path / "q.ies"
    path.write_text(quadrant_file())
    rho, power, height, n = 0.6, 3.0, 1.2, 24
    scene = pc.Scene()
    floor = scene.add_material(pc.Diffuse(rho, name="floor"))
    v, t = square(3.0)
    scene.add_mesh("floor", v, t, material=floor)
    scene.add_light(pc.PointLight((0.0, 0.0, height), power, 1.0, name="lamp", profile=path))
    scene.camera = pc.Camera.looking_at((0, 0, 5), (0, 0, 0), up=(0, 1, 0), projection="ORTHOGRAPHIC", ortho_scale=4.0)
    out = pc.render(scene, width=n, height=n, samples=16, max_bounces=1, seed=1)
    y = 0.2126 * out.rgba[..., 0] + 0.7152 * out.rgba[..., 1] + 0.0722 * out.rgba[..., 2]
    for px, py in [(12, 12), (16, 12), (20, 5), (5, 14), (9, 20)]:
        x, yy = (px + 0.5) / n * 4 - 2, 2 - (py + 0.5) / n * 4
        d = np.array([x, yy, -height])
        dist = np.linalg.norm(d)
        w = d / dist
        v_deg = math.degrees(math.acos(-w[2]))
        h_deg = math.degrees(math.atan2(w[0], w[1]) + math.pi)
        c = candela(h_deg, v_deg) * 4 * math.pi / 177.83
        expected = rho / math.pi * power / (4 * math.pi) * c * (height / dist) / dist**2
        assert abs(y[py, px] - expected) < 0.03 * expected, (px, py, y[py, px], expected)
