"""A normal-mapped and a bumped sphere under a sun against Cycles CPU in one bpy process
(docs/shading.md, "Normal Map and Bump"): a Principled sphere whose Normal comes from a
tangent-space Normal Map of a procedural colour (MikkTSpace tangents from Blender), and
one whose Normal comes from a Bump of a Noise height, seen by an orthographic camera.
Mean CIEDE2000 on 4 × 4 blocks (bhelper's mean_de00) must stay within 1.5; the same
spheres with the Normal unlinked must be further from Cycles than that (the test sees
the normal), and no warning may name the normal nodes."""

import pytest

from .bhelper import check, run_bpy

pytestmark = pytest.mark.blender


def test_normal_mapped_and_bumped_spheres_match_cycles(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        """
    sc, ob = ortho_sphere_under_sun(48)
    m = bpy.data.materials.new('Bumpy'); m.use_nodes = True; nt = m.node_tree
    p = nt.nodes['Principled BSDF']
    p.inputs['Base Color'].default_value = (0.7, 0.45, 0.25, 1.0)
    p.inputs['Roughness'].default_value = 0.45
    ob.data.materials.append(m)

    def normal_map():
        noise = nt.nodes.new('ShaderNodeTexNoise'); noise.inputs['Scale'].default_value = 3.0
        uv = nt.nodes.new('ShaderNodeUVMap'); uv.uv_map = 'UVMap'
        mapping = nt.nodes.new('ShaderNodeMapping'); mapping.inputs['Scale'].default_value = (4.0, 2.0, 1.0)
        nt.links.new(uv.outputs['UV'], mapping.inputs['Vector']); nt.links.new(mapping.outputs['Vector'], noise.inputs['Vector'])
        mix = nt.nodes.new('ShaderNodeMix'); mix.data_type = 'RGBA'
        mix.inputs['Factor'].default_value = 0.6
        mix.inputs['A'].default_value = (0.5, 0.5, 1.0, 1.0)
        nt.links.new(noise.outputs['Color'], mix.inputs['B'])
        nm = nt.nodes.new('ShaderNodeNormalMap'); nm.space = 'TANGENT'; nm.uv_map = 'UVMap'
        nm.inputs['Strength'].default_value = 1.0
        nt.links.new(mix.outputs['Result'], nm.inputs['Color'])
        return nm.outputs['Normal']

    def bump():
        noise = nt.nodes.new('ShaderNodeTexNoise'); noise.inputs['Scale'].default_value = 3.0
        b = nt.nodes.new('ShaderNodeBump'); b.inputs['Distance'].default_value = 0.5
        nt.links.new(noise.outputs['Fac'], b.inputs['Height'])
        return b.outputs['Normal']

    c = sc.cycles; c.device = 'CPU'; c.samples = 64; c.use_denoising = False; c.use_adaptive_sampling = False
    c.filter_width = 0.01; c.max_bounces = 4
    c.sample_clamp_direct = 0.0; c.sample_clamp_indirect = 0.0
    sc.polychrome.samples = 64; sc.polychrome.max_bounces = 4
    sc.render.image_settings.file_format = 'OPEN_EXR'
    for name, make in (('normal map', normal_map), ('bump', bump)):
        link = nt.links.new(make(), p.inputs['Normal'])
        cycles = render_rgb(sc, 'CYCLES', 'cycles')
        poly = render_rgb(sc, 'POLYCHROME', 'poly')
        err, warn = Engine.last_error, list(Engine.last_warnings or [])
        nt.links.remove(link)
        flat = render_rgb(sc, 'POLYCHROME', 'flat')
        emit(name=name, de=mean_de00(cycles, poly, 4), control=mean_de00(cycles, flat, 4), err=err, warn=warn,
             means=[float(cycles.mean()), float(poly.mean()), float(flat.mean())])
    """,
        timeout=500,
    )
    results = check(proc, res, n=2)
    for r in results:
        print(r["name"], "dE00", round(r["de"], 3), "unlinked control", round(r["control"], 3), r["means"])
    for r in results:
        assert r["err"] is None, r
        assert not [w for w in r["warn"] if "Normal" in w or "Bump" in w or "not supported" in w], r["warn"]
        assert r["de"] <= 1.5, r
        assert r["control"] > 1.5 and r["control"] > 2.0 * r["de"], r
