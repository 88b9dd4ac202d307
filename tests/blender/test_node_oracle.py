"""The emission oracle for the shading graph: node graphs on an Emission shader, rendered
by Cycles CPU and by Polychrome in one bpy process, compared pixel by pixel (linear
values, Standard view transform, no dithering). The scene and the cases are
oracle_scene.py and oracle_cases.py (they run inside the bpy subprocess).

An emitter cannot show a negative value, so where Cycles' pixel is negative Polychrome's
must be 0 (every result is also shown negated on a second tile, so both signs are
compared). Each case has its own tolerance (absolute, relative above 1)."""

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from .bhelper import check, run_bpy

pytestmark = pytest.mark.blender

HERE = Path(__file__).resolve().parent


def run_oracle(tmp_path, cases_name, samples=1, albedo=False, pixel_average=False):
    for name in ("oracle_scene.py", "oracle_cases.py"):
        shutil.copy(HERE / name, tmp_path / name)
    body = f"""
    from oracle_cases import {cases_name}
    from oracle_scene import run
    run({cases_name}, samples={samples}, albedo={albedo}, pixel_average={pixel_average})
    """
    proc, res = run_bpy(tmp_path, body, timeout=600)
    result = check(proc, res)[0]
    result["albedo"] = albedo
    out = os.environ.get("POLYCHROME_ORACLE_REPORT")  # a directory: one JSON of errors per case list
    if out:
        rows = errors(result, tile_means=cases_name != "CONSTANT_CASES")
        with open(Path(out) / f"{cases_name}.json", "w") as f:
            json.dump({"rows": rows, "error": result["error"], "warnings": result["warnings"], "seconds": result["seconds"]}, f, indent=1)
    return result


def errors(result, tile_means=False):
    """Per case: (family, label, worst error, tolerance, Cycles' value, Polychrome's value),
    per pixel or (``tile_means``) on the mean of each tile."""
    worst = {}
    for t in result["tiles"]:
        cyc, pc = np.array(t["cycles"]), np.array(t["polychrome"])
        if tile_means:
            cyc, pc = cyc.mean(0, keepdims=True), pc.mean(0, keepdims=True)
        want = np.clip(cyc, 0.0, 1.0) if result.get("albedo") else np.maximum(cyc, 0.0)  # negative radiance shows as 0
        err = np.abs(pc - want) / np.maximum(1.0, np.abs(want))
        k = int(np.argmax(err.max(-1)))
        key = (t["family"], t["label"])
        e = float(err.max())
        if key not in worst or e > worst[key][2]:
            worst[key] = (t["family"], t["label"], e, t["tol"], cyc[k].round(5).tolist(), pc[k].round(5).tolist())
    return list(worst.values())


@pytest.fixture(scope="module")
def constant(tmp_path_factory):
    return run_oracle(tmp_path_factory.mktemp("oracle_constant"), "CONSTANT_CASES")


FAMILIES = [
    "Math",
    "Vector Math",
    "Mix",
    "Map Range",
    "Clamp",
    "Color Ramp",
    "RGB Curves",
    "Float Curve",
    "Vector Curves",
    "Hue/Saturation/Value",
    "Invert",
    "Gamma",
    "Bright/Contrast",
    "RGB to BW",
    "Separate Color",
    "Combine Color",
    "Separate XYZ",
    "Combine XYZ",
    "Value",
    "RGB",
    "Blackbody",
    "Wavelength",
    "Group",
    "MixRGB (legacy)",
    "Separate RGB (legacy)",
    "Separate HSV (legacy)",
    "Combine RGB (legacy)",
    "Combine HSV (legacy)",
]


def test_constant_graphs_render(constant):
    assert constant["error"] is None, constant["error"]
    assert constant["cycles_finite"]
    assert not [w for w in constant["warnings"] if "not supported" in w], constant["warnings"]


@pytest.mark.parametrize("family", FAMILIES)
def test_constant_node_matches_cycles(constant, family):
    rows = [r for r in errors(constant) if r[0] == family]
    assert rows, family
    bad = [f"{f} {label}: error {e:.3g} > {tol:g} (Cycles {c}, Polychrome {p})" for f, label, e, tol, c, p in rows if not e <= tol]
    assert not bad, f"{len(bad)}/{len(rows)} cases off:\n" + "\n".join(bad)


HIT_FAMILIES = [
    "Texture Coordinate",
    "Mapping",
    "UV Map",
    "Geometry",
    "Color Attribute",
    "Attribute",
    "Object Info",
    "Fresnel",
    "Layer Weight",
    "Normal Map",
    "Bump",
    "Noise Texture",
    "Voronoi Texture",
    "Checker Texture",
    "Gradient Texture",
    "Wave Texture",
    "Magic Texture",
    "Brick Texture",
    "WhiteNoise Texture",
    "Image Texture",
]


@pytest.fixture(scope="module")
def per_hit(tmp_path_factory):
    """Per-hit cases on a Diffuse BSDF under a uniform white world (measured so before
    the core evaluated emission per hit; the per-pixel emission oracle of textured
    emission is below): each pixel is the albedo, clamped to [0, 1], with some
    sampling noise (Cycles 64 samples, Polychrome 256; tile means differ by < 1e-2)."""
    return run_oracle(tmp_path_factory.mktemp("oracle_hit"), "HIT_CASES", samples=256, albedo=True)


def test_per_hit_graphs_render(per_hit):
    assert per_hit["error"] is None, per_hit["error"]
    assert not [w for w in per_hit["warnings"] if "not supported" in w], per_hit["warnings"]


@pytest.mark.parametrize("family", HIT_FAMILIES)
def test_per_hit_node_matches_cycles(per_hit, family):
    rows = [r for r in errors(per_hit, tile_means=True) if r[0] == family]
    assert rows, family
    bad = [f"{f} {label}: error {e:.3g} > {tol:g} (Cycles {c}, Polychrome {p})" for f, label, e, tol, c, p in rows if not e <= tol]
    assert not bad, f"{len(bad)}/{len(rows)} cases off:\n" + "\n".join(bad)


def test_environment_texture_in_a_material_matches_cycles(tmp_path):
    """Kept apart from HIT_CASES: a render error would take every case with it."""
    r = run_oracle(tmp_path, "ENVIRONMENT_CASES", samples=256, albedo=True)
    assert r["error"] is None, r["error"]
    rows = errors(r, tile_means=True)
    bad = [f"{f} {label}: error {e:.3g} > {tol:g} (Cycles {c}, Polychrome {p})" for f, label, e, tol, c, p in rows if not e <= tol]
    assert not bad, "\n".join(bad)


def test_image_texture_alpha_matches_cycles(tmp_path):
    """Image Texture's Alpha output, and its Color output when Alpha is read (Cycles
    un-associates), for 8-bit sRGB, float, Non-Color, Channel Packed and None alpha
    modes (Premultiplied on an 8-bit image is warned: Cycles' colour differs by 0.23), Closest and CLIP (ALPHA_CASES). Kept apart from HIT_CASES so it
    runs on its own in a few seconds."""
    r = run_oracle(tmp_path, "ALPHA_CASES", samples=256, albedo=True)
    assert r["error"] is None, r["error"]
    assert not [w for w in r["warnings"] if "not supported" in w], r["warnings"]
    rows = errors(r, tile_means=True)
    assert len(rows) == 9, rows
    bad = [f"{f} {label}: error {e:.3g} > {tol:g} (Cycles {c}, Polychrome {p})" for f, label, e, tol, c, p in rows if not e <= tol]
    assert not bad, "\n".join(bad)


def test_textured_emission_matches_cycles_per_pixel(tmp_path):
    """Per-hit emission (an Image Texture, any colour space, Linear and Closest, every
    extension, into an Emission shader) through the emission oracle itself: every pixel
    compared, no lighting noise. The texture changes within a pixel (16 texels over 6
    pixels), so both renderers estimate the pixel's box average (Cycles' Box filter one
    pixel wide), 128 samples each."""
    r = run_oracle(tmp_path, "EMISSION_HIT_CASES", samples=512, pixel_average=True)
    assert r["error"] is None, r["error"]
    assert not [w for w in r["warnings"] if "not supported" in w or "emission" in w], r["warnings"]
    rows = errors(r)
    bad = [f"{f} {label}: error {e:.3g} > {tol:g} (Cycles {c}, Polychrome {p})" for f, label, e, tol, c, p in rows if not e <= tol]
    assert not bad, "\n".join(bad)


def test_normal_map_and_bump_match_cycles_per_pixel(tmp_path):
    """Normal Map (tangent, object, world and Blender's spaces, Strength, a second UV
    map) and Bump (heights linear in the position and in a UV map, Strength, Distance,
    Invert, over a Normal Map) into an Emission colour: each pixel is the normal, compared
    with Cycles' to TOL (NORMAL_CASES)."""
    r = run_oracle(tmp_path, "NORMAL_CASES")
    assert r["error"] is None, r["error"]
    bad_warnings = [w for w in r["warnings"] if "not supported" in w or "(ShaderNodeBump)" in w or "(ShaderNodeNormalMap)" in w]
    assert not bad_warnings, bad_warnings
    rows = errors(r)
    for f, label, e, _tol, c, p in rows:
        print(f"{f} {label}: error {e:.3g} (Cycles {c}, Polychrome {p})")
    bad = [f"{f} {label}: error {e:.3g} > {tol:g} (Cycles {c}, Polychrome {p})" for f, label, e, tol, c, p in rows if not e <= tol]
    assert not bad, "\n".join(bad)


def test_tangents_of_each_uv_map_match_cycles_per_pixel(tmp_path):
    """The Tangent node (radial, and the UV map's for the default map and two named ones)
    and tangent-space Normal Maps into an Emission colour, with materials reading both UV
    maps' tangents at once (each node its own map's set: TANGENT_CASES), compared with
    Cycles per pixel to TOL, with no warning about tangents."""
    r = run_oracle(tmp_path, "TANGENT_CASES")
    assert r["error"] is None, r["error"]
    bad_warnings = [w for w in r["warnings"] if "not supported" in w or "tangent" in w.lower()]
    assert not bad_warnings, bad_warnings
    rows = errors(r)
    for f, label, e, _tol, c, p in rows:
        print(f"{f} {label}: error {e:.3g} (Cycles {c}, Polychrome {p})")
    bad = [f"{f} {label}: error {e:.3g} > {tol:g} (Cycles {c}, Polychrome {p})" for f, label, e, tol, c, p in rows if not e <= tol]
    assert not bad, "\n".join(bad)
