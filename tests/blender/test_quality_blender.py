"""Issue 9 in Blender: scene.polychrome.quality reaches the core; settings changed in the
panel win over the preset, settings never touched are left to it."""

import pytest

from .bhelper import check, run_bpy

pytestmark = pytest.mark.blender


def test_quality_preset_fills_untouched_settings_and_explicit_ones_win(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        """
    bpy.ops.wm.read_factory_settings()
    sc = bpy.context.scene; p = sc.polychrome
    sc.render.engine = 'POLYCHROME'
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = 8, 6, 100
    p.samples = 2; p.threads = 1
    sc.render.image_settings.file_format = 'OPEN_EXR'
    stats = {}
    for q in ('AUTO', 'PREVIEW', 'REFERENCE'):
        p.quality = q
        sc.render.filepath = os.path.abspath(f'{q}.exr'); bpy.ops.render.render(write_still=True)
        stats[q] = Engine.last_stats
    p.quality = 'REFERENCE'; p.wavelength_count = 12; p.max_bounces = 3; p.noise_threshold = 5.0
    sc.render.filepath = os.path.abspath('explicit.exr'); bpy.ops.render.render(write_still=True)
    stats['explicit'] = Engine.last_stats
    emit(stats=stats, items=[i.identifier for i in p.bl_rna.properties['quality'].enum_items])
    """,
    )
    r = check(proc, res)[0]
    s = r["stats"]
    assert r["items"] == ["AUTO", "PREVIEW", "FINAL", "REFERENCE"]
    assert s["AUTO"]["quality"] == "AUTO" and any(x.startswith("grid:") for x in s["AUTO"]["auto_reason"])
    assert s["AUTO"]["samples_per_pixel"] == 2 and s["AUTO"]["noise_threshold"] == 0
    assert (s["PREVIEW"]["wavelengths"], s["PREVIEW"]["max_bounces"]) == (16, 4)
    assert (s["REFERENCE"]["wavelengths"], s["REFERENCE"]["max_bounces"], s["REFERENCE"]["samples_per_pixel"]) == (81, 16, 2)
    e = s["explicit"]
    assert (e["wavelengths"], e["max_bounces"], e["noise_threshold"]) == (12, 3, 5.0)
