"""One-sided area lights against Cycles in the same bpy process: a square light under a
ceiling shining down on a floor and a cube, and a tilted disk light shining at the cube
from the side. Cycles' area lights emit from their −Z face only (their back lights
nothing: the ceiling above the square light is lit only indirectly), cast no shadow, are
not seen by the camera and let rays through (a transparent bounce: the floor under the
square light sees the ceiling through it). Polychrome and Cycles CPU render the same
scene with 12 bounces (the floor–ceiling interreflection converged); the mean CIEDE2000
(colour-science) over 4 × 4 blocks must stay below 1.5 (measured 1.16; 0.53 without the
ceiling)."""

import pytest

from .bhelper import check, run_bpy

pytestmark = pytest.mark.blender


def test_one_sided_area_lights_match_cycles(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        """
    from mathutils import Vector
    W, H = 48, 32
    sc = empty_scene(W, H); sc.world = None
    bpy.ops.mesh.primitive_plane_add(size=12)
    bpy.context.object.data.materials.append(diffuse_material('Floor', (0.7, 0.6, 0.5)))
    bpy.ops.mesh.primitive_plane_add(size=12, location=(0, 0, 3.0))
    bpy.context.object.data.materials.append(diffuse_material('Ceiling', (0.8, 0.8, 0.8)))
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0.3, 0.2, 0.5))
    bpy.context.object.data.materials.append(diffuse_material('Cube', (0.2, 0.5, 0.7)))
    sq = bpy.data.lights.new('Square', 'AREA'); sq.energy = 150.0; sq.size = 1.5
    so = bpy.data.objects.new('Square', sq); sc.collection.objects.link(so); so.location = (0, 0, 2.2)
    dk = bpy.data.lights.new('Disk', 'AREA'); dk.energy = 80.0; dk.shape = 'DISK'; dk.size = 0.8
    dk.color = (1.0, 0.7, 0.4)
    do = bpy.data.objects.new('Disk', dk); sc.collection.objects.link(do); do.location = (-2.0, 1.0, 1.2)
    do.rotation_euler = (Vector((0.3, 0.2, 0.5)) - do.location).to_track_quat('-Z', 'Y').to_euler()
    add_camera(sc, (5.0, -5.0, 2.6), (0, 0, 1.0), lens=24)
    sc.render.image_settings.file_format = 'OPEN_EXR'
    c = sc.cycles; c.device = 'CPU'; c.samples = 128; c.use_denoising = False; c.use_adaptive_sampling = False
    c.filter_width = 0.01; c.max_bounces = 12; c.diffuse_bounces = 12
    c.sample_clamp_indirect = 0.0; c.sample_clamp_direct = 0.0
    sc.polychrome.samples = 128; sc.polychrome.max_bounces = 12
    cycles = render_rgb(sc, 'CYCLES', 'cycles')
    poly = render_rgb(sc, 'POLYCHROME', 'poly')
    d = block_de00(cycles, poly, 4)
    mean, p95 = float(np.mean(d)), float(np.percentile(d, 95))
    emit(de=mean, p95=p95, err=Engine.last_error, warn=Engine.last_warnings,
         ceiling_ratio=float(poly[:H // 4].mean() / max(cycles[:H // 4].mean(), 1e-9)))
    """,
        timeout=500,
    )
    r = check(proc, res)[0]
    print(r)
    assert r["err"] is None and r["warn"] == [], r
    assert r["de"] < 1.5, r
