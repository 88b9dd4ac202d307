"""The Principled BSDF's diffuse lobe about the Normal as given, against Cycles CPU in one
bpy process (docs/shading.md, "One normal per closure"): Cycles orients the Principled's
specular lobes about the valid Normal (`maybe_ensure_valid_specular_reflection`) but its
diffuse about the Normal as given, dimmed towards the smooth surface's horizon by
Blender 4.5's `bump_shadowing_term`. A plane with a strong tangent-space Normal Map (a
noise colour at Strength 3, so many normals tilt past 45° and get bent for the view
straight down) lit only by a sun 12° above the horizon (the grazing light where the two
normals and the shadowing term differ most), under a black world: no emission, no
ambient. Orthographic camera, 64 spp; mean CIEDE2000 on 4 × 4 blocks must stay within
1.5 for a rough dielectric Principled and for one with a rough Oren–Nayar base, with no
warning; the same plane with the Normal unlinked (control) must be farther from Cycles."""

import pytest

from .bhelper import check, run_bpy

pytestmark = pytest.mark.blender


def test_principled_diffuse_about_the_given_normal_matches_cycles(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        """
    W = 48
    sc = empty_scene(W, W)
    sc.world = bpy.data.worlds.new('W'); sc.world.use_nodes = True
    sc.world.node_tree.nodes['Background'].inputs['Color'].default_value = (0.0, 0.0, 0.0, 1.0)
    ld = bpy.data.lights.new('Sun', 'SUN'); ld.energy = 4.0; ld.angle = math.radians(1.0)
    sun = bpy.data.objects.new('Sun', ld); sc.collection.objects.link(sun)
    sun.rotation_euler = (math.radians(78.0), 0.0, math.radians(30.0))
    cd = bpy.data.cameras.new('C'); cd.type = 'ORTHO'; cd.ortho_scale = 2.0
    cam = bpy.data.objects.new('C', cd); sc.collection.objects.link(cam); sc.camera = cam; cam.location = (0, 0, 5)
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    ob = bpy.context.object

    m = bpy.data.materials.new('Bumpy'); m.use_nodes = True; nt = m.node_tree
    p = nt.nodes['Principled BSDF']
    p.inputs['Base Color'].default_value = (0.75, 0.5, 0.3, 1.0)
    p.inputs['Roughness'].default_value = 0.5
    ob.data.materials.append(m)
    noise = nt.nodes.new('ShaderNodeTexNoise'); noise.inputs['Scale'].default_value = 2.5
    noise.inputs['Detail'].default_value = 1.0
    uv = nt.nodes.new('ShaderNodeUVMap'); uv.uv_map = 'UVMap'
    nt.links.new(uv.outputs['UV'], noise.inputs['Vector'])
    mix = nt.nodes.new('ShaderNodeMix'); mix.data_type = 'RGBA'
    mix.inputs['Factor'].default_value = 0.8
    mix.inputs['A'].default_value = (0.5, 0.5, 1.0, 1.0)
    nt.links.new(noise.outputs['Color'], mix.inputs['B'])
    nm = nt.nodes.new('ShaderNodeNormalMap'); nm.space = 'TANGENT'; nm.uv_map = 'UVMap'
    nm.inputs['Strength'].default_value = 3.0
    nt.links.new(mix.outputs['Result'], nm.inputs['Color'])

    c = sc.cycles; c.device = 'CPU'; c.samples = 64; c.use_denoising = False; c.use_adaptive_sampling = False
    c.filter_width = 0.01; c.max_bounces = 4
    c.sample_clamp_direct = 0.0; c.sample_clamp_indirect = 0.0
    sc.polychrome.samples = 64; sc.polychrome.max_bounces = 4
    sc.render.image_settings.file_format = 'OPEN_EXR'
    for name, diffuse_roughness in (('lambertian base', 0.0), ('oren-nayar base', 0.8)):
        p.inputs['Diffuse Roughness'].default_value = diffuse_roughness
        link = nt.links.new(nm.outputs['Normal'], p.inputs['Normal'])
        cycles = render_rgb(sc, 'CYCLES', 'cycles')
        poly = render_rgb(sc, 'POLYCHROME', 'poly')
        err, warn = Engine.last_error, list(Engine.last_warnings or [])
        nt.links.remove(link)
        flat = render_rgb(sc, 'POLYCHROME', 'flat')
        emit(name=name, de=mean_de00(cycles, poly, 4), control=mean_de00(cycles, flat, 4), err=err, warn=warn,
             means=[float(cycles.mean()), float(poly.mean()), float(flat.mean())])
    """,
        timeout=600,
    )
    results = check(proc, res, n=2)
    for r in results:
        print(r["name"], "dE00", round(r["de"], 3), "unlinked control", round(r["control"], 3), r["means"])
    for r in results:
        assert r["err"] is None, r
        assert not [w for w in r["warn"] if "Normal" in w or "not supported" in w], r["warn"]
        assert r["de"] <= 1.5, r
        assert r["control"] > 2.0 * r["de"], r
