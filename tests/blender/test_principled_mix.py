"""Blender's Principled BSDF, Mix Shader and Add Shader through the add-on (bpy in
subprocesses): export mapping, a default Principled cube against Cycles CPU, and a Mix
of red and blue diffuse rendering as the mixed colour."""

import numpy as np
import pytest

from .bhelper import check, run_bpy

pytestmark = pytest.mark.blender


def test_principled_mix_add_map_to_polychrome(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        """
    import polychrome as pc
    from polychrome_blender.export import export_scene, materials
    materials.GRAPHS = False  # the fixed-pattern export (node graphs: test_node_graph.py, test_node_oracle.py)
    sc = empty_scene(8, 8)
    add_camera(sc, (0, -5, 0))
    def fresh(name):
        m = bpy.data.materials.new(name); m.use_nodes = True; nt = m.node_tree
        for n in list(nt.nodes):
            if n.type != 'OUTPUT_MATERIAL': nt.nodes.remove(n)
        return m, nt
    def out(nt, node):
        nt.links.new(node.outputs[0], nt.nodes['Material Output'].inputs['Surface'])
    mats = []
    m = bpy.data.materials.new('Default'); m.use_nodes = True; mats.append(m)      # Blender's default Principled
    m, nt = fresh('Film'); p = nt.nodes.new('ShaderNodeBsdfPrincipled')
    p.inputs['Metallic'].default_value = 0.25; p.inputs['Transmission Weight'].default_value = 0.5
    p.inputs['Roughness'].default_value = 0.2; p.inputs['IOR'].default_value = 1.45
    p.inputs['Thin Film Thickness'].default_value = 420.0; p.inputs['Thin Film IOR'].default_value = 1.38
    p.inputs['Specular Tint'].default_value = (1.0, 0.8, 0.6, 1.0); p.inputs['Specular IOR Level'].default_value = 0.25
    p.inputs['Emission Color'].default_value = (1.0, 0.5, 0.0, 1.0); p.inputs['Emission Strength'].default_value = 2.0
    out(nt, p); mats.append(m)
    m, nt = fresh('Mixed'); mix = nt.nodes.new('ShaderNodeMixShader'); mix.inputs[0].default_value = 0.3
    d = nt.nodes.new('ShaderNodeBsdfDiffuse'); d.inputs['Color'].default_value = (0.9, 0.1, 0.1, 1.0)
    add = nt.nodes.new('ShaderNodeAddShader')
    g = nt.nodes.new('ShaderNodeBsdfGlossy'); g.inputs['Roughness'].default_value = 0.1
    e = nt.nodes.new('ShaderNodeEmission'); e.inputs['Strength'].default_value = 3.0
    nt.links.new(d.outputs[0], mix.inputs[1]); nt.links.new(add.outputs[0], mix.inputs[2])
    nt.links.new(g.outputs[0], add.inputs[0]); nt.links.new(e.outputs[0], add.inputs[1])
    out(nt, mix); mats.append(m)
    m, nt = fresh('Half'); mix = nt.nodes.new('ShaderNodeMixShader')
    d = nt.nodes.new('ShaderNodeBsdfDiffuse'); nt.links.new(d.outputs[0], mix.inputs[2])   # first input empty
    out(nt, mix); mats.append(m)
    m, nt = fresh('Flint'); p = nt.nodes.new('ShaderNodeBsdfPrincipled')
    p.inputs['Transmission Weight'].default_value = 1.0
    dn = nt.nodes.new('PolychromeDispersionNode'); dn.model = 'NAMED'; dn.named = 'N_SF11'
    nt.links.new(dn.outputs[0], p.inputs['IOR'])
    out(nt, p); mats.append(m)
    for name, kind in (('Facing', 'ShaderNodeLayerWeight'), ('Fres', 'ShaderNodeFresnel')):
        m, nt = fresh(name); mix = nt.nodes.new('ShaderNodeMixShader')
        src = nt.nodes.new(kind)
        if kind == 'ShaderNodeLayerWeight':
            src.inputs['Blend'].default_value = 0.3; nt.links.new(src.outputs['Facing'], mix.inputs[0])
        else:
            src.inputs['IOR'].default_value = 1.6; nt.links.new(src.outputs[0], mix.inputs[0])
        nt.links.new(nt.nodes.new('ShaderNodeBsdfDiffuse').outputs[0], mix.inputs[1])
        nt.links.new(nt.nodes.new('ShaderNodeBsdfGlossy').outputs[0], mix.inputs[2])
        out(nt, mix); mats.append(m)
    m, nt = fresh('Coated'); p = nt.nodes.new('ShaderNodeBsdfPrincipled')
    p.inputs['Coat Weight'].default_value = 0.5; p.inputs['Alpha'].default_value = 0.5
    tex = nt.nodes.new('ShaderNodeTexNoise'); nt.links.new(tex.outputs[0], p.inputs['Roughness'])
    out(nt, p); mats.append(m)
    for i, mat in enumerate(mats):
        bpy.ops.mesh.primitive_cube_add(size=0.5, location=(i - 2, 0, 0))
        bpy.context.object.data.materials.append(mat)
    dg = bpy.context.evaluated_depsgraph_get()
    scene, warns = export_scene(dg)
    desc, _ = scene.description()
    emit(m={x['name']: x for x in desc['materials']}, warns=warns)
    """,
    )
    r = check(proc, res)[0]
    m = r["m"]
    # Only the unsupported Principled inputs of 'Coated' are reported, once each (its
    # coat is exported: weight 0.5 and Blender's defaults).
    assert len(r["warns"]) == 2 and all("'Coated'" in w for w in r["warns"]), r["warns"]
    assert any("Alpha" in w for w in r["warns"]) and any("driving 'Roughness'" in w for w in r["warns"])
    assert m["Coated"]["bsdf"]["type"] == "principled"
    coat = m["Coated"]["bsdf"]["coat"]
    assert coat["weight"] == pytest.approx(0.5) and coat["roughness"] == pytest.approx(0.03) and coat["ior"] == pytest.approx(1.5)
    assert "tint" not in coat and "sheen" not in m["Coated"]["bsdf"]
    d = m["Default"]["bsdf"]
    assert d["type"] == "principled"
    assert d["base_color"]["rgb"] == pytest.approx([0.8, 0.8, 0.8])
    assert d["roughness"] == pytest.approx(0.5) and d["metallic"] == 0.0 and d["transmission"] == 0.0
    assert d["ior"] == {"type": "constant", "ior": pytest.approx(1.5)}
    assert "emission" not in m["Default"]
    f = m["Film"]
    fb = f["bsdf"]
    assert fb["metallic"] == pytest.approx(0.25) and fb["transmission"] == pytest.approx(0.5)
    assert fb["roughness"] == pytest.approx(0.2) and fb["ior"]["ior"] == pytest.approx(1.45)
    assert fb["thin_film_thickness"] == pytest.approx(420.0) and fb["thin_film_ior"] == pytest.approx(1.38)
    assert fb["specular_tint"]["rgb"] == pytest.approx([1.0, 0.8, 0.6])
    assert fb["specular_ior_level"] == pytest.approx(0.25) and d["specular_ior_level"] == 0.5
    assert f["emission"]["rgb"] == pytest.approx([1.0, 0.5, 0.0]) and f["emission"]["scale"] == pytest.approx(2.0)
    mx = m["Mixed"]
    assert mx["bsdf"]["type"] == "mix" and mx["bsdf"]["factor"] == pytest.approx(0.3)
    assert mx["bsdf"]["a"]["type"] == "diffuse" and mx["bsdf"]["a"]["reflectance"]["rgb"] == pytest.approx([0.9, 0.1, 0.1])
    assert mx["bsdf"]["b"]["type"] == "add"
    assert mx["bsdf"]["b"]["a"]["type"] == "glossy" and mx["bsdf"]["b"]["b"] == {"type": "none"}
    # Emission of the nested Emission node (white × 3) weighted by the mix factor 0.3.
    em = mx["emission"]
    assert np.allclose(np.array(em["rgb"]) * em["scale"], 0.3 * 3.0)
    h = m["Half"]["bsdf"]
    assert h["type"] == "mix" and h["a"] == {"type": "none"} and h["b"]["type"] == "diffuse"
    assert m["Facing"]["bsdf"]["factor_from"] == {"type": "layer_weight_facing", "blend": pytest.approx(0.3)}
    assert m["Fres"]["bsdf"]["factor_from"] == {"type": "fresnel", "ior": pytest.approx(1.6)}
    assert m["Fres"]["bsdf"]["b"]["type"] == "glossy"
    fl = m["Flint"]["bsdf"]
    assert fl["type"] == "principled" and fl["transmission"] == 1.0 and fl["ior"] == {"type": "named", "name": "N-SF11"}


def test_default_principled_cube_matches_cycles(tmp_path):
    """A cube with Blender's default material (Principled BSDF: base 0.8, roughness 0.5,
    IOR 1.5) on a Principled floor, lit by an area and a point light, in Cycles CPU and in
    Polychrome: mean CIEDE2000 below 2."""
    proc, res = run_bpy(
        tmp_path,
        """
    sc = empty_scene(48, 36)
    sc.world = None
    def principled(name, rgb, roughness=0.5):
        m = bpy.data.materials.new(name); m.use_nodes = True
        p = m.node_tree.nodes['Principled BSDF']
        p.inputs['Base Color'].default_value = (*rgb, 1.0); p.inputs['Roughness'].default_value = roughness
        return m
    bpy.ops.mesh.primitive_plane_add(size=8)
    bpy.context.object.data.materials.append(principled('Floor', (0.6, 0.45, 0.3), 0.35))
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0, 0, 0.5))
    cube = bpy.data.materials.new('Cube'); cube.use_nodes = True     # untouched default Principled
    bpy.context.object.data.materials.append(cube)
    ld = bpy.data.lights.new('Area', 'AREA'); ld.energy = 300.0; ld.size = 1.5
    lo = bpy.data.objects.new('Area', ld); sc.collection.objects.link(lo); lo.location = (0.5, -0.5, 3.0)
    pd = bpy.data.lights.new('Point', 'POINT'); pd.energy = 150.0; pd.shadow_soft_size = 0.0; pd.color = (1.0, 0.9, 0.8)
    po = bpy.data.objects.new('Point', pd); sc.collection.objects.link(po); po.location = (-2.0, -1.0, 2.0)
    add_camera(sc, (4.0, -4.0, 3.0), (0, 0, 0.4), lens=35)
    A, B = cycles_and_polychrome(sc, 128)
    import polychrome.colordiff as cd
    white = float(np.percentile(A[..., 1], 99))
    de = cd.image_delta_e(A, B, white_luminance=white)
    emit(mean=float(de.mean()), err=Engine.last_error, warn=Engine.last_warnings,
         ma=A.mean(axis=(0, 1)).tolist(), mb=B.mean(axis=(0, 1)).tolist())
    """,
    )
    r = check(proc, res)[0]
    assert r["err"] is None and r["warn"] == []
    print("default Principled vs Cycles:", r)
    assert r["mean"] < 2.0, r
    for x, y in zip(r["ma"], r["mb"]):
        assert y == pytest.approx(x, rel=0.05), r


def test_mix_of_red_and_blue_diffuse_renders_the_mixed_colour(tmp_path):
    """A Mix Shader (factor 0.5) of red and blue Diffuse BSDFs on a plane under a uniform
    white world, seen straight down: each pixel is the mixed reflectance × the world
    (the plane's upper hemisphere is all world), i.e. 0.5·(red + blue)."""
    proc, res = run_bpy(
        tmp_path,
        """
    sc = empty_scene(8, 8)
    w = bpy.data.worlds.new('W'); w.use_nodes = True; sc.world = w
    bg = w.node_tree.nodes['Background']; bg.inputs['Color'].default_value = (1, 1, 1, 1); bg.inputs['Strength'].default_value = 1.0
    m = bpy.data.materials.new('Mix'); m.use_nodes = True; nt = m.node_tree
    for n in list(nt.nodes):
        if n.type != 'OUTPUT_MATERIAL': nt.nodes.remove(n)
    mix = nt.nodes.new('ShaderNodeMixShader'); mix.inputs[0].default_value = 0.5
    red = nt.nodes.new('ShaderNodeBsdfDiffuse'); red.inputs['Color'].default_value = (0.8, 0.05, 0.05, 1)
    blue = nt.nodes.new('ShaderNodeBsdfDiffuse'); blue.inputs['Color'].default_value = (0.05, 0.05, 0.8, 1)
    nt.links.new(red.outputs[0], mix.inputs[1]); nt.links.new(blue.outputs[0], mix.inputs[2])
    nt.links.new(mix.outputs[0], nt.nodes['Material Output'].inputs['Surface'])
    bpy.ops.mesh.primitive_plane_add(size=20)
    bpy.context.object.data.materials.append(m)
    cd = bpy.data.cameras.new('Camera'); cd.type = 'ORTHO'; cd.ortho_scale = 2.0
    co = bpy.data.objects.new('Camera', cd); sc.collection.objects.link(co); sc.camera = co
    co.location = (0, 0, 5)
    sc.render.engine = 'POLYCHROME'
    sc.polychrome.samples = 64; sc.polychrome.max_bounces = 4
    sc.render.image_settings.file_format = 'OPEN_EXR'
    sc.render.filepath = os.path.abspath('mix.exr'); bpy.ops.render.render(write_still=True)
    ch = exr_channels('mix.exr')
    emit(rgb=[float(ch[k].mean()) for k in ('R', 'G', 'B')], err=Engine.last_error, warn=Engine.last_warnings)
    """,
    )
    r = check(proc, res)[0]
    assert r["err"] is None and r["warn"] == []
    expected = 0.5 * (np.array([0.8, 0.05, 0.05]) + np.array([0.05, 0.05, 0.8]))
    assert np.allclose(r["rgb"], expected, atol=0.01), (r["rgb"], expected)


def test_metal_and_thin_film_principled_match_cycles(tmp_path):
    """Principled spheres in Cycles CPU and Polychrome: a gold-coloured metal (F82-tint
    Fresnel), a half-metallic paint, a dark dielectric with a 500 nm thin film (spectral
    interference in Polychrome, Cycles' own thin-film model) and a white metal under a
    300 nm film, on a Principled floor, area light and a blue world, with Blender's default
    Multiscatter GGX (Polychrome compensates the metal's multiple scattering, Kulla & Conty)
    and Cycles' glossy filter off: mean CIEDE2000 below 2 on 2×2 blocks."""
    proc, res = run_bpy(
        tmp_path,
        """
    sc = empty_scene(64, 36)
    w = bpy.data.worlds.new('W'); w.use_nodes = True; sc.world = w
    bg = w.node_tree.nodes['Background']; bg.inputs['Color'].default_value = (0.6, 0.7, 0.9, 1); bg.inputs['Strength'].default_value = 0.5
    def principled(name, rgb, **kw):
        m = bpy.data.materials.new(name); m.use_nodes = True
        p = m.node_tree.nodes['Principled BSDF']   # Blender's default distribution: Multiscatter GGX
        p.inputs['Base Color'].default_value = (*rgb, 1.0)
        for k, v in kw.items(): p.inputs[k].default_value = v
        return m
    bpy.ops.mesh.primitive_plane_add(size=10)
    bpy.context.object.data.materials.append(principled('Floor', (0.5, 0.5, 0.5), Roughness=0.6))
    specs = [('Gold', (1.0, 0.78, 0.34), dict(Metallic=1.0, Roughness=0.3)),
             ('Half', (0.2, 0.5, 0.3), dict(Metallic=0.5, Roughness=0.4)),
             ('Film', (0.05, 0.05, 0.05), {'Roughness': 0.15, 'Thin Film Thickness': 500.0, 'Thin Film IOR': 1.33}),
             ('FilmMetal', (0.9, 0.9, 0.9), {'Metallic': 1.0, 'Roughness': 0.2, 'Thin Film Thickness': 300.0, 'Thin Film IOR': 1.5})]
    for i, (n, rgb, kw) in enumerate(specs):
        bpy.ops.mesh.primitive_uv_sphere_add(radius=0.6, location=(1.4 * i - 2.1, 0, 0.6), segments=48, ring_count=24)
        bpy.ops.object.shade_smooth()
        bpy.context.object.data.materials.append(principled(n, rgb, **kw))
    ld = bpy.data.lights.new('Area', 'AREA'); ld.energy = 400.0; ld.size = 2.0
    lo = bpy.data.objects.new('Area', ld); sc.collection.objects.link(lo); lo.location = (0.5, -2.0, 4.0)
    add_camera(sc, (0.0, -6.0, 2.0), (0, 0, 0.5), lens=35)
    A, B = cycles_and_polychrome(sc, 256)
    import polychrome.colordiff as cd
    # 2×2 pixel blocks: the comparison is about the materials, not the caustic noise on the floor
    A, B = block_means(A), block_means(B)
    white = float(np.percentile(A[..., 1], 99))
    de = cd.image_delta_e(A, B, white_luminance=white)
    emit(mean=float(de.mean()), err=Engine.last_error, warn=Engine.last_warnings,
         ma=A.reshape(-1, 3).mean(axis=0).tolist(), mb=B.reshape(-1, 3).mean(axis=0).tolist())
    """,
        timeout=300,
    )
    r = check(proc, res)[0]
    print("metal/thin film Principled vs Cycles:", r)
    assert r["err"] is None and r["warn"] == []
    assert r["mean"] < 2.0, r
    for x, y in zip(r["ma"], r["mb"]):
        assert y == pytest.approx(x, rel=0.05), r


def test_fresnel_and_layer_weight_mixes_match_cycles(tmp_path):
    """Mix Shaders of a red diffuse and a blue glossy driven by a Fresnel node (IOR 1.45)
    and Layer Weight nodes (Fresnel output, blend 0.3; Facing output, blend 0.6) on three
    spheres, Cycles CPU vs Polychrome: mean CIEDE2000 below 2 on 2×2 blocks (≈ 0.7)."""
    proc, res = run_bpy(
        tmp_path,
        """
    sc = empty_scene(64, 36)
    w = bpy.data.worlds.new('W'); w.use_nodes = True; sc.world = w
    bg = w.node_tree.nodes['Background']; bg.inputs['Color'].default_value = (0.6, 0.7, 0.9, 1); bg.inputs['Strength'].default_value = 0.5
    bpy.ops.mesh.primitive_plane_add(size=10)
    bpy.context.object.data.materials.append(diffuse_material('Floor', (0.5, 0.5, 0.5)))
    for i, (kind, out, val) in enumerate([('ShaderNodeFresnel', 0, 1.45), ('ShaderNodeLayerWeight', 'Fresnel', 0.3), ('ShaderNodeLayerWeight', 'Facing', 0.6)]):
        m = bpy.data.materials.new(f'M{i}'); m.use_nodes = True; nt = m.node_tree
        for n in list(nt.nodes):
            if n.type != 'OUTPUT_MATERIAL': nt.nodes.remove(n)
        mix = nt.nodes.new('ShaderNodeMixShader'); src = nt.nodes.new(kind)
        if kind == 'ShaderNodeFresnel': src.inputs['IOR'].default_value = val
        else: src.inputs['Blend'].default_value = val
        nt.links.new(src.outputs[out], mix.inputs[0])
        d = nt.nodes.new('ShaderNodeBsdfDiffuse'); d.inputs['Color'].default_value = (0.7, 0.1, 0.1, 1)
        g = nt.nodes.new('ShaderNodeBsdfGlossy'); g.inputs['Roughness'].default_value = 0.25; g.inputs['Color'].default_value = (0.2, 0.4, 0.9, 1)
        nt.links.new(d.outputs[0], mix.inputs[1]); nt.links.new(g.outputs[0], mix.inputs[2])
        nt.links.new(mix.outputs[0], nt.nodes['Material Output'].inputs['Surface'])
        bpy.ops.mesh.primitive_uv_sphere_add(radius=0.7, location=(1.6 * i - 1.6, 0, 0.7), segments=48, ring_count=24)
        bpy.ops.object.shade_smooth()
        bpy.context.object.data.materials.append(m)
    ld = bpy.data.lights.new('Area', 'AREA'); ld.energy = 400.0; ld.size = 2.0
    lo = bpy.data.objects.new('Area', ld); sc.collection.objects.link(lo); lo.location = (0.5, -2.0, 4.0)
    add_camera(sc, (0.0, -6.0, 2.0), (0, 0, 0.5), lens=35)
    A, B = cycles_and_polychrome(sc, 256)
    import polychrome.colordiff as cd
    A, B = block_means(A), block_means(B)
    white = float(np.percentile(A[..., 1], 99))
    de = cd.image_delta_e(A, B, white_luminance=white)
    emit(mean=float(de.mean()), err=Engine.last_error, warn=Engine.last_warnings,
         ma=A.reshape(-1, 3).mean(axis=0).tolist(), mb=B.reshape(-1, 3).mean(axis=0).tolist())
""",
        timeout=300,
    )
    r = check(proc, res)[0]
    print("Fresnel/Layer Weight mixes vs Cycles:", r)
    assert r["err"] is None and r["warn"] == []
    assert r["mean"] < 2.0, r
    for x, y in zip(r["ma"], r["mb"]):
        assert y == pytest.approx(x, rel=0.05), r
