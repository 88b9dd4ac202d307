"""Every closure about its own normal, against Cycles CPU in one bpy process
(docs/shading.md, "One normal per closure"): a Principled sphere with a Coat whose
Coat Normal (a strong tangent-space Normal Map) differs from its Normal (a weak one); a
Mix Shader of two Glossy BSDFs with different Normals (two Normal Maps); and a Diffuse
BSDF under a strong Normal Map, which Cycles shades about the normal as given (only
specular closures are bent by ensure_valid_specular_reflection) and dims towards the
smooth surface's horizon (bump_shadowing_term). Orthographic camera, sun, 64 spp; mean
CIEDE2000 on 4 × 4 blocks (bhelper's mean_de00) must stay within 1.5, with no warning.
The first two have a control that must be farther from Cycles (the test sees what it
tests): the coat about the Normal (farther overall, 1.5× as far on the rim, where the
coat's normal acts), both glossies about the first Normal (the old one normal per
material, twice as far); the diffuse's control (Normal unlinked) is only reported. Also
reported: the mean over the rim's blocks (centre beyond 0.8 of the sphere's radius),
where the specular correction acts."""

import pytest

from .bhelper import check, run_bpy

pytestmark = pytest.mark.blender


def test_per_closure_normals_match_cycles(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        """
    W = 48
    sc, ob = ortho_sphere_under_sun(W, math.radians(5.0))
    m = bpy.data.materials.new('Lobes'); m.use_nodes = True; nt = m.node_tree
    out = nt.nodes['Material Output']
    for n in list(nt.nodes):
        if n.type != 'OUTPUT_MATERIAL': nt.nodes.remove(n)
    ob.data.materials.append(m)

    def normal_map(scale, strength=1.0):
        noise = nt.nodes.new('ShaderNodeTexNoise'); noise.inputs['Scale'].default_value = scale
        uv = nt.nodes.new('ShaderNodeUVMap'); uv.uv_map = 'UVMap'
        mapping = nt.nodes.new('ShaderNodeMapping'); mapping.inputs['Scale'].default_value = (4.0, 2.0, 1.0)
        nt.links.new(uv.outputs['UV'], mapping.inputs['Vector']); nt.links.new(mapping.outputs['Vector'], noise.inputs['Vector'])
        mix = nt.nodes.new('ShaderNodeMix'); mix.data_type = 'RGBA'
        mix.inputs['Factor'].default_value = 0.6
        mix.inputs['A'].default_value = (0.5, 0.5, 1.0, 1.0)
        nt.links.new(noise.outputs['Color'], mix.inputs['B'])
        nm = nt.nodes.new('ShaderNodeNormalMap'); nm.space = 'TANGENT'; nm.uv_map = 'UVMap'
        nm.inputs['Strength'].default_value = strength
        nt.links.new(mix.outputs['Result'], nm.inputs['Color'])
        return nm

    c = sc.cycles; c.device = 'CPU'; c.samples = 64; c.use_denoising = False; c.use_adaptive_sampling = False
    c.filter_width = 0.01; c.max_bounces = 4
    c.sample_clamp_direct = 0.0; c.sample_clamp_indirect = 0.0
    sc.polychrome.samples = 64; sc.polychrome.max_bounces = 4
    sc.render.image_settings.file_format = 'OPEN_EXR'

    # Blocks whose centre lies beyond 0.8 of the sphere's radius (the rim).
    nb = W // 4
    centre = (np.arange(nb) + 0.5) * 4 / W * 2.3 - 1.15
    r = np.hypot(*np.meshgrid(centre, centre))
    rim = (r > 0.8) & (r < 1.0)

    def score(cycles, poly):
        d = block_de00(cycles, poly, 4)
        return float(d.mean()), float(d[rim].mean())

    def case(name, control_edit):
        cycles = render_rgb(sc, 'CYCLES', 'cycles')
        poly = render_rgb(sc, 'POLYCHROME', 'poly')
        err, warn = Engine.last_error, list(Engine.last_warnings or [])
        undo = control_edit()
        control = render_rgb(sc, 'POLYCHROME', 'control')
        undo()
        de, de_rim = score(cycles, poly)
        cde, cde_rim = score(cycles, control)
        emit(name=name, de=de, de_rim=de_rim, control=cde, control_rim=cde_rim, err=err, warn=warn,
             means=[float(cycles.mean()), float(poly.mean()), float(control.mean())])

    def unlink(socket_to):
        old = socket_to.links[0].from_socket
        nt.links.remove(socket_to.links[0])
        return lambda: nt.links.new(old, socket_to)

    def relink(socket_from, socket_to):
        old = socket_to.links[0].from_socket if socket_to.is_linked else None
        nt.links.new(socket_from, socket_to)
        def undo():
            if old is None:
                for l in list(socket_to.links): nt.links.remove(l)
            else:
                nt.links.new(old, socket_to)
        return undo

    # 1. A Principled with a coat whose normal is not the base's.
    p = nt.nodes.new('ShaderNodeBsdfPrincipled')
    p.inputs['Base Color'].default_value = (0.3, 0.4, 0.7, 1.0)
    p.inputs['Roughness'].default_value = 0.5
    p.inputs['Coat Weight'].default_value = 1.0
    p.inputs['Coat Roughness'].default_value = 0.05
    link = nt.links.new(p.outputs['BSDF'], out.inputs['Surface'])
    base_map = normal_map(3.0, strength=0.5)
    nt.links.new(base_map.outputs['Normal'], p.inputs['Normal'])
    coat_map = normal_map(4.0, strength=3.0)
    nt.links.new(coat_map.outputs['Normal'], p.inputs['Coat Normal'])
    case('coat normal', lambda: relink(base_map.outputs['Normal'], p.inputs['Coat Normal']))
    nt.links.remove(link)

    # 2. A Mix of two glossies with different normals.
    ga = nt.nodes.new('ShaderNodeBsdfAnisotropic'); ga.inputs['Roughness'].default_value = 0.45
    ga.inputs['Color'].default_value = (0.9, 0.5, 0.3, 1.0)
    gb = nt.nodes.new('ShaderNodeBsdfAnisotropic'); gb.inputs['Roughness'].default_value = 0.45
    gb.inputs['Color'].default_value = (0.3, 0.6, 0.9, 1.0)
    mixs = nt.nodes.new('ShaderNodeMixShader'); mixs.inputs['Fac'].default_value = 0.5
    nt.links.new(ga.outputs[0], mixs.inputs[1]); nt.links.new(gb.outputs[0], mixs.inputs[2])
    link = nt.links.new(mixs.outputs[0], out.inputs['Surface'])
    ma = normal_map(3.0); mb = normal_map(6.0, strength=1.5)
    nt.links.new(ma.outputs['Normal'], ga.inputs['Normal']); nt.links.new(mb.outputs['Normal'], gb.inputs['Normal'])
    case('mix of glossies', lambda: relink(ma.outputs['Normal'], gb.inputs['Normal']))
    nt.links.remove(link)

    # 3. A Diffuse BSDF under a strong Normal Map: Cycles keeps the normal as given.
    d = nt.nodes.new('ShaderNodeBsdfDiffuse'); d.inputs['Color'].default_value = (0.8, 0.6, 0.4, 1.0)
    link = nt.links.new(d.outputs[0], out.inputs['Surface'])
    md = normal_map(3.0, strength=2.5)
    nt.links.new(md.outputs['Normal'], d.inputs['Normal'])
    case('diffuse, strong normal map', lambda: unlink(d.inputs['Normal']))
    nt.links.remove(link)
    """,
        timeout=900,
    )
    results = check(proc, res, n=3)
    for r in results:
        print(
            f"{r['name']}: dE00 {r['de']:.3f} (rim {r['de_rim']:.3f}); control {r['control']:.3f} "
            f"(rim {r['control_rim']:.3f}); means {r['means']}"
        )
    for r in results:
        assert r["err"] is None, r
        assert not [w for w in r["warn"] if "Normal" in w or "not supported" in w], r["warn"]
        assert r["de"] <= 1.5, r
    coat, mix, _ = results
    # The coat's normal moves only its sharp highlights, most of all at the rim (where the
    # coat about the Normal is 1.11 from Cycles against 0.57): the control is farther
    # overall and 1.5× as far on the rim.
    assert coat["control"] > coat["de"], coat
    assert coat["control_rim"] > 1.5 * coat["de_rim"], coat
    assert mix["control"] > 1.5 and mix["control"] > 2.0 * mix["de"], mix
