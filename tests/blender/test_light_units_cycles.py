"""Light units against Cycles in the same bpy process: a grey diffuse plane seen from
above by an orthographic camera, lit by one light at a time (no world, so only direct
light), rendered by Cycles CPU and by Polychrome. Each case is one of Cycles' unit
conversions (intern/cycles/scene/light.cpp, intern/cycles/blender/light.cpp): Normalize
off for sun, point and spot lights, area lights on scaled objects, colour × temperature."""

import pytest

from .bhelper import check, run_bpy

pytestmark = pytest.mark.blender

# name: (light type, settings, object location, object scale)
CASES = {
    "sun normalize off": ("SUN", {"energy": 20.0, "angle": 0.35, "normalize": False}, (0, 0, 1), (1, 1, 1)),
    "sun normalize on": ("SUN", {"energy": 2.0, "angle": 0.35}, (0, 0, 1), (1, 1, 1)),
    "point normalize off r=0": ("POINT", {"energy": 30.0, "shadow_soft_size": 0.0, "normalize": False}, (0.8, 0, 1.5), (1, 1, 1)),
    "point normalize off r=0.3": (
        "POINT",
        {"energy": 100.0, "shadow_soft_size": 0.3, "use_soft_falloff": False, "normalize": False},
        (0.8, 0, 1.5),
        (1, 1, 1),
    ),
    "spot normalize off r=0": (
        "SPOT",
        {"energy": 30.0, "shadow_soft_size": 0.0, "spot_size": 1.8, "spot_blend": 0.0, "normalize": False},
        (0.3, 0, 1.5),
        (1, 1, 1),
    ),
    "area square scale 2": ("AREA", {"energy": 60.0, "shape": "SQUARE", "size": 0.5}, (0.8, 0, 1.5), (2, 2, 1)),
    "area square scale 0.01": ("AREA", {"energy": 60.0, "shape": "SQUARE", "size": 40.0}, (0.8, 0, 1.5), (0.01, 0.01, 1)),
    "area disk scale 0.5x2": ("AREA", {"energy": 60.0, "shape": "DISK", "size": 1.0}, (0.8, 0, 1.5), (0.5, 2, 1)),
    "area square normalize off scale 2": (
        "AREA",
        {"energy": 8.0, "shape": "SQUARE", "size": 0.5, "normalize": False},
        (0.8, 0, 1.5),
        (2, 2, 1),
    ),
    "point temperature 4000 K tinted": (
        "POINT",
        {"energy": 40.0, "shadow_soft_size": 0.0, "use_temperature": True, "temperature": 4000.0, "color": (1.0, 0.6, 0.3)},
        (0.8, 0, 1.5),
        (1, 1, 1),
    ),
    "sun temperature 2700 K white": (
        "SUN",
        {"energy": 2.0, "angle": 0.0, "use_temperature": True, "temperature": 2700.0},
        (0, 0, 1),
        (1, 1, 1),
    ),
}


def test_light_units_match_cycles(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        f"""
    CASES = {CASES!r}
    sc = empty_scene(8, 8); sc.world = None
    bpy.ops.mesh.primitive_plane_add(size=40)
    bpy.context.object.data.materials.append(diffuse_material('Grey', (0.5, 0.5, 0.5)))
    cd = bpy.data.cameras.new('C'); cd.type = 'ORTHO'; cd.ortho_scale = 0.2
    cam = bpy.data.objects.new('C', cd); sc.collection.objects.link(cam); sc.camera = cam; cam.location = (0, 0, 3)
    sc.render.image_settings.file_format = 'OPEN_EXR'
    c = sc.cycles; c.device = 'CPU'; c.samples = 256; c.use_denoising = False; c.use_adaptive_sampling = False
    c.filter_width = 0.01; c.sample_clamp_direct = 0.0; c.sample_clamp_indirect = 0.0
    sc.polychrome.samples = 256
    for name, (kind, settings, loc, scale) in CASES.items():
        ld = bpy.data.lights.new(name, kind)
        for k, v in settings.items():
            setattr(ld, k, v)
        ob = bpy.data.objects.new(name, ld); sc.collection.objects.link(ob)
        ob.location = loc; ob.scale = scale
        if kind == 'SUN':
            ob.rotation_euler = (math.radians(30), 0, 0)   # 30° from the zenith
        means = {{}}
        for engine in ('CYCLES', 'POLYCHROME'):
            sc.render.engine = engine
            sc.render.filepath = os.path.abspath(f'{{engine}}.exr'); bpy.ops.render.render(write_still=True)
            ch = exr_channels(f'{{engine}}.exr')
            means[engine] = [float(ch[k].mean()) for k in 'RGB']
        emit(name=name, cycles=means['CYCLES'], poly=means['POLYCHROME'], err=Engine.last_error, warn=Engine.last_warnings)
        bpy.data.objects.remove(ob); bpy.data.lights.remove(ld)
    """,
        timeout=400,
    )
    results = check(proc, res, n=len(CASES))
    colour = pytest.importorskip("colour")
    import numpy as np

    rec709 = colour.RGB_COLOURSPACES["ITU-R BT.709"]
    failures = []
    for r in results:
        assert r["err"] is None, r
        assert all("temperature" not in w and "tint" not in w for w in r["warn"]), r
        a, b = np.array(r["cycles"]), np.array(r["poly"])
        ya, yb = (colour.RGB_to_XYZ(x, rec709, apply_cctf_decoding=False)[1] for x in (a, b))
        # Lab of both mean colours relative to a white twice Cycles' luminance (L* ≈ 76)
        white = colour.xy_to_XYZ(rec709.whitepoint) * 2.0 * ya
        lab = [colour.XYZ_to_Lab(colour.RGB_to_XYZ(x, rec709, apply_cctf_decoding=False) / white[1], rec709.whitepoint) for x in (a, b)]
        de = float(colour.delta_E(lab[0], lab[1], method="CIE 2000"))
        # Delta lights and a flat plane: no noise beyond the pixel filter; the area lights'
        # mean over 64 pixels × 256 samples has a standard error well under 1 %.
        if not (abs(yb / ya - 1.0) < 0.03 and de < 1.0):
            failures.append((r["name"], round(yb / ya, 4), round(de, 3), a.tolist(), b.tolist()))
    assert not failures, failures
