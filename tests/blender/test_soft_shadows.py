"""Soft shadows against Cycles in the same bpy process: a ball over a grey floor, lit by
a sphere light (point and spot lights with a radius, Soft Falloff off) or by a sun with
an angular diameter, seen from above. The penumbra's mean CIEDE2000 on 4 × 4 pixel blocks
(colour-science) must stay within 1.5 of Cycles CPU; the same light rendered by
Polychrome as a point (radius 0, sharp shadow) must differ from Cycles by more than that tolerance."""

import pytest

from .bhelper import check, run_bpy

pytestmark = pytest.mark.blender

# name: (light type, settings, location, rotation (degrees), the setting that makes it sharp)
CASES = {
    "point r=0.6": (
        "POINT",
        {"energy": 400.0, "shadow_soft_size": 0.6, "use_soft_falloff": False},
        (0.5, 0.3, 2.6),
        (0, 0, 0),
        "shadow_soft_size",
    ),
    "spot r=0.5": (
        "SPOT",
        {"energy": 500.0, "shadow_soft_size": 0.5, "use_soft_falloff": False, "spot_size": 2.0, "spot_blend": 0.1},
        (-0.4, 0.2, 2.8),
        (0, 0, 0),
        "shadow_soft_size",
    ),
    "sun 40 degrees": ("SUN", {"energy": 3.0, "angle": 0.7}, (0, 0, 3), (35, 0, 20), "angle"),
}


def test_soft_shadows_match_cycles(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        f"""
    CASES = {CASES!r}
    sc = empty_scene(32, 32); sc.world = None
    bpy.ops.mesh.primitive_plane_add(size=20)
    bpy.context.object.data.materials.append(diffuse_material('Floor', (0.6, 0.6, 0.6)))
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.35, location=(0, 0, 0.9), segments=48, ring_count=24)
    bpy.ops.object.shade_smooth()
    bpy.context.object.data.materials.append(diffuse_material('Ball', (0.2, 0.4, 0.7)))
    cd = bpy.data.cameras.new('C'); cd.type = 'ORTHO'; cd.ortho_scale = 2.4
    cam = bpy.data.objects.new('C', cd); sc.collection.objects.link(cam); sc.camera = cam; cam.location = (0, 0, 5)
    sc.render.image_settings.file_format = 'OPEN_EXR'
    c = sc.cycles; c.device = 'CPU'; c.samples = 128; c.use_denoising = False; c.use_adaptive_sampling = False
    c.filter_width = 0.01; c.max_bounces = 4; c.diffuse_bounces = 4
    c.sample_clamp_direct = 0.0; c.sample_clamp_indirect = 0.0
    sc.polychrome.samples = 128; sc.polychrome.max_bounces = 4
    for name, (kind, settings, loc, rot, sharp) in CASES.items():
        ld = bpy.data.lights.new(name, kind)
        for k, v in settings.items():
            setattr(ld, k, v)
        ob = bpy.data.objects.new(name, ld); sc.collection.objects.link(ob)
        ob.location = loc; ob.rotation_euler = tuple(math.radians(x) for x in rot)
        cycles = render_rgb(sc, 'CYCLES', 'cycles')
        poly = render_rgb(sc, 'POLYCHROME', 'poly')
        err, warn = Engine.last_error, Engine.last_warnings
        setattr(ld, sharp, 0.0)
        point = render_rgb(sc, 'POLYCHROME', 'sharp')
        emit(name=name, de=mean_de00(cycles, poly, 4), control=mean_de00(cycles, point, 4), err=err, warn=warn,
             means=[float(cycles.mean()), float(poly.mean()), float(point.mean()), float(cycles.min()), float(point.min())])
        bpy.data.objects.remove(ob); bpy.data.lights.remove(ld)
    """,
        timeout=500,
    )
    results = check(proc, res, n=len(CASES))
    for r in results:
        print(r["name"], "dE00", round(r["de"], 3), "sharp control", round(r["control"], 3), r["means"])
    for r in results:
        assert r["err"] is None, r
        assert not any("angular" in w or "radius" in w for w in r["warn"]), r
        assert r["de"] <= 1.5, r
        assert r["control"] > 1.5 and r["control"] > 5.0 * r["de"], r
