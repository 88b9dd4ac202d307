"""The vendored Khronos sample Box Textured (tests/data/gltf, CC-BY 4.0) imported by
Blender's own glTF importer, rendered by Cycles CPU and by Polychrome through the add-on in
the same bpy scene (bench/gltf_vs_cycles.py's floor, sun, world and camera): mean
CIEDE2000 over 4 × 4 blocks ≤ 1.5 (issue 12's acceptance; measured 0.83 at 64², 32 spp)
and no warning from the add-on."""

import pytest

from .bhelper import ROOT, check, run_bpy

pytestmark = pytest.mark.blender


def test_box_textured_matches_cycles(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        f"""
    sys.path.insert(0, {str(ROOT / "bench")!r})
    import gltf_vs_cycles as g
    r = g.compare(g.find_model('BoxTextured', g.DEFAULT_CACHE), size=48, samples=32, tmp='.')
    emit(**{{k: v for k, v in r.items() if k not in ('cycles', 'polychrome')}})  # not the images
    """,
        timeout=500,
    )
    r = check(proc, res)[0]
    print(r)
    assert r["error"] is None and r["warnings"] == [], r
    assert r["de"] <= 1.5, r
