"""Blender volumes through the add-on (bpy in subprocesses): the Volume output's export
against Cycles' closure definitions (docs/media.md), warnings for what is not rendered,
and a glass of coloured liquid and a scattering cube against Cycles CPU."""

import numpy as np
import polychrome as pc
import pytest

from .bhelper import check, run_bpy

pytestmark = pytest.mark.blender


def test_volume_nodes_export_as_cycles_defines_them(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        """
    from polychrome_blender.export import export_scene
    sc = empty_scene(8, 8)
    add_camera(sc, (0, -5, 0))
    def fresh(name, surface=None):
        m = bpy.data.materials.new(name); m.use_nodes = True; nt = m.node_tree
        for n in list(nt.nodes):
            if n.type != 'OUTPUT_MATERIAL': nt.nodes.remove(n)
        if surface:
            s = nt.nodes.new(surface); nt.links.new(s.outputs[0], nt.nodes['Material Output'].inputs['Surface'])
        return m, nt
    def vol(nt, node):
        nt.links.new(node.outputs[0], nt.nodes['Material Output'].inputs['Volume'])
    mats = []
    m, nt = fresh('Tea', 'ShaderNodeBsdfGlass'); a = nt.nodes.new('ShaderNodeVolumeAbsorption')
    a.inputs['Color'].default_value = (0.9, 0.4, 0.1, 1); a.inputs['Density'].default_value = 2.0
    vol(nt, a); mats.append(m)
    m, nt = fresh('Fog'); s = nt.nodes.new('ShaderNodeVolumeScatter')
    s.inputs['Color'].default_value = (0.5, 0.6, 0.7, 1); s.inputs['Density'].default_value = 3.0
    s.inputs['Anisotropy'].default_value = 0.4
    vol(nt, s); mats.append(m)
    m, nt = fresh('Smoke'); p = nt.nodes.new('ShaderNodeVolumePrincipled')
    p.inputs['Color'].default_value = (0.8, 0.5, 0.2, 1); p.inputs['Density'].default_value = 0.5
    p.inputs['Absorption Color'].default_value = (0.25, 0.64, 1.0, 1); p.inputs['Anisotropy'].default_value = -0.2
    p.inputs['Emission Strength'].default_value = 2.0; p.inputs['Emission Color'].default_value = (1, 0.5, 0, 1)
    p.inputs['Blackbody Intensity'].default_value = 1.0
    vol(nt, p); mats.append(m)
    m, nt = fresh('Cloud'); s = nt.nodes.new('ShaderNodeVolumeScatter')
    s.phase = 'FOURNIER_FORAND'
    tex = nt.nodes.new('ShaderNodeTexNoise'); nt.links.new(tex.outputs[0], s.inputs['Density'])
    vol(nt, s); mats.append(m)
    for i, mat in enumerate(mats):
        bpy.ops.mesh.primitive_cube_add(size=0.5, location=(i - 2, 0, 0))
        bpy.context.object.data.materials.append(mat)
    w = bpy.data.worlds.new('W'); w.use_nodes = True; sc.world = w
    fog = w.node_tree.nodes.new('ShaderNodeVolumeScatter')
    w.node_tree.links.new(fog.outputs[0], w.node_tree.nodes['World Output'].inputs['Volume'])
    dg = bpy.context.evaluated_depsgraph_get()
    scene, warns = export_scene(dg)
    desc, _ = scene.description()
    emit(m={x['name']: x for x in desc['materials']}, world=desc['world'], warns=warns)
    """,
    )
    r = check(proc, res)[0]
    m, warns = r["m"], r["warns"]

    def coeff(d):
        return np.array(d["rgb"]) * d["scale"]

    tea = m["Tea"]
    assert ("nodes" in tea or tea["bsdf"]["type"] == "dielectric") and "scattering" not in tea["volume"]
    assert np.allclose(coeff(tea["volume"]["absorption"]), 2.0 * (1 - np.array([0.9, 0.4, 0.1])))
    fog = m["Fog"]
    assert fog["bsdf"] == {"type": "null"} and "absorption" not in fog["volume"]
    assert np.allclose(coeff(fog["volume"]["scattering"]), 3.0 * np.array([0.5, 0.6, 0.7]))
    assert fog["volume"]["anisotropy"] == pytest.approx(0.4)
    smoke = m["Smoke"]["volume"]
    c, a = np.array([0.8, 0.5, 0.2]), np.array([0.25, 0.64, 1.0])
    assert np.allclose(coeff(smoke["scattering"]), 0.5 * c)
    # svm_node_principled_volume: σt = (c + max(1 − c, 0)·max(1 − √a, 0))·ρ.
    assert np.allclose(coeff(smoke["absorption"]), 0.5 * (1 - c) * (1 - np.sqrt(a)), atol=1e-6)
    # Emission Strength × Color plus the blackbody (intensity 1 at the default 1000 K):
    # σ_SB·10⁻⁶/π·T⁴ × the blackbody's luminance-1 colour (svm_node_principled_volume).
    from polychrome_blender.export.lights import blackbody_white

    bb = 5.670373e-8 * 1e-6 / np.pi * 1000.0**4 * np.array(pc.spectra.rec709(blackbody_white(1000.0)))
    assert np.allclose(coeff(smoke["emission"]), 2.0 * np.array([1.0, 0.5, 0.0]) + bb, rtol=1e-5)
    assert smoke["anisotropy"] == pytest.approx(-0.2)
    # The world's Volume Scatter (defaults: colour 0.8, density 1) fills all space.
    world = r["world"]["volume"]
    assert np.allclose(coeff(world["scattering"]), [0.8, 0.8, 0.8]) and "absorption" not in world
    # One warning per unsupported feature, naming the material and the node.
    expected = [("'Cloud'", "FOURNIER_FORAND"), ("'Cloud'", "Density")]
    for who, what in expected:
        assert any(who in w and what in w for w in warns), (who, what, warns)
    assert len(warns) == len(expected), warns


SCENE = """
    sc = empty_scene(40, 30)
    w = bpy.data.worlds.new('W'); w.use_nodes = True; sc.world = w
    bg = w.node_tree.nodes['Background']; bg.inputs['Color'].default_value = (0.6, 0.7, 0.9, 1); bg.inputs['Strength'].default_value = 0.5
    bpy.ops.mesh.primitive_plane_add(size=10)
    bpy.context.object.data.materials.append(diffuse_material('Floor', (0.8, 0.8, 0.75)))
    ld = bpy.data.lights.new('Area', 'AREA'); ld.energy = 400.0; ld.size = 2.0
    lo = bpy.data.objects.new('Area', ld); sc.collection.objects.link(lo); lo.location = (1.0, -1.0, 4.0)
    def fresh(name, surface=None):
        m = bpy.data.materials.new(name); m.use_nodes = True; nt = m.node_tree
        for n in list(nt.nodes):
            if n.type != 'OUTPUT_MATERIAL': nt.nodes.remove(n)
        s = None
        if surface:
            s = nt.nodes.new(surface); nt.links.new(s.outputs[0], nt.nodes['Material Output'].inputs['Surface'])
        return m, nt, s
    {objects}
    add_camera(sc, (0.0, -2.4, 1.0), (0, 0, 0.55), lens=40)
    sc.render.image_settings.file_format = 'OPEN_EXR'
    sc.render.engine = 'CYCLES'
    c = sc.cycles; c.device = 'CPU'; c.samples = {spp}; c.use_denoising = False; c.use_adaptive_sampling = False
    c.filter_width = 0.01; c.max_bounces = 16; c.diffuse_bounces = 16; c.glossy_bounces = 16
    c.transmission_bounces = 16; c.volume_bounces = 16; c.transparent_max_bounces = 16
    c.sample_clamp_indirect = 0.0; c.sample_clamp_direct = 0.0; c.caustics_reflective = True; c.caustics_refractive = True
    sc.render.filepath = os.path.abspath('cycles.exr'); bpy.ops.render.render(write_still=True)
    sc.render.engine = 'POLYCHROME'
    sc.polychrome.samples = {spp}; sc.polychrome.max_bounces = 16
    sc.render.filepath = os.path.abspath('poly.exr'); bpy.ops.render.render(write_still=True)
    a, b = exr_channels('cycles.exr'), exr_channels('poly.exr')
    import polychrome.colordiff as cd
    A = np.stack([a['R'], a['G'], a['B']], -1); B = np.stack([b['R'], b['G'], b['B']], -1)
    h, wd = A.shape[0] // 5 * 5, A.shape[1] // 5 * 5
    blocks = lambda X: X[:h, :wd].reshape(h // 5, 5, wd // 5, 5, 3).mean(axis=(1, 3))
    white = float(np.percentile(A[..., 1], 99))
    de = cd.image_delta_e(blocks(A), blocks(B), white_luminance=white)
    err, warn = Engine.last_error, Engine.last_warnings
    # The same render with every Volume output unlinked: how far off ignoring the media is.
    for mat in bpy.data.materials:
        if mat.node_tree is not None:
            for link in list(mat.node_tree.links):
                if link.to_socket.name == 'Volume':
                    mat.node_tree.links.remove(link)
    sc.render.filepath = os.path.abspath('novolume.exr'); bpy.ops.render.render(write_still=True)
    n = exr_channels('novolume.exr'); N = np.stack([n['R'], n['G'], n['B']], -1)
    de_none = cd.image_delta_e(blocks(A), blocks(N), white_luminance=white)
    emit(mean=float(de.mean()), p90=float(np.percentile(de, 90)), without_volume=float(de_none.mean()),
         err=err, warn=warn, ma=A.mean(axis=(0, 1)).tolist(), mb=B.mean(axis=(0, 1)).tolist())
"""


def _against_cycles(tmp_path, objects, spp=256):
    proc, res = run_bpy(tmp_path, SCENE.replace("{objects}", objects).replace("{spp}", str(spp)), timeout=600)
    r = check(proc, res)[0]
    assert r["err"] is None and r["warn"] == [], r
    return r


def test_glass_of_coloured_liquid_matches_cycles(tmp_path):
    """A sphere of tea (Glass BSDF at IOR 1.33 + Volume Absorption) on a floor: the
    colour through the liquid is Beer–Lambert per wavelength in Polychrome, per RGB
    channel in Cycles; mean CIEDE2000 over 5×5-pixel blocks ≤ 1.5."""
    r = _against_cycles(
        tmp_path,
        """
    m, nt, g = fresh('Tea', 'ShaderNodeBsdfGlass'); g.inputs['IOR'].default_value = 1.33
    a = nt.nodes.new('ShaderNodeVolumeAbsorption')
    a.inputs['Color'].default_value = (0.9, 0.55, 0.25, 1); a.inputs['Density'].default_value = 2.0
    nt.links.new(a.outputs[0], nt.nodes['Material Output'].inputs['Volume'])
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.55, location=(0, 0, 0.55), segments=48, ring_count=24)
    bpy.ops.object.shade_smooth()
    bpy.context.object.data.materials.append(m)
    """,
    )
    print("tea vs Cycles:", r)
    assert r["mean"] <= 1.5 and r["without_volume"] > 3.0 * max(r["mean"], 1.0), r


def test_scattering_cube_matches_cycles(tmp_path):
    """A cube of Volume Scatter (no surface, multiple scattering up to 16 bounces in
    both) on a floor under an area light: mean CIEDE2000 over 5×5-pixel blocks ≤ 1.5."""
    r = _against_cycles(
        tmp_path,
        """
    m, nt, _ = fresh('Fog')
    s = nt.nodes.new('ShaderNodeVolumeScatter')
    s.inputs['Color'].default_value = (0.9, 0.8, 0.6, 1); s.inputs['Density'].default_value = 2.0
    s.inputs['Anisotropy'].default_value = 0.3
    nt.links.new(s.outputs[0], nt.nodes['Material Output'].inputs['Volume'])
    bpy.ops.mesh.primitive_cube_add(size=1.1, location=(0, 0, 0.56))
    bpy.context.object.data.materials.append(m)
    """,
    )
    print("fog cube vs Cycles:", r)
    assert r["mean"] <= 1.5 and r["without_volume"] > 3.0 * max(r["mean"], 1.0), r


MEDIA = """
    sc = empty_scene(40, 30)
    w = bpy.data.worlds.new('W'); w.use_nodes = True; sc.world = w
    bg = w.node_tree.nodes['Background']; bg.inputs['Color'].default_value = (0.6, 0.7, 0.9, 1); bg.inputs['Strength'].default_value = 0.5
    bpy.ops.mesh.primitive_plane_add(size=10)
    bpy.context.object.data.materials.append(diffuse_material('Floor', (0.8, 0.8, 0.75)))
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.4, location=(0.5, 0.4, 0.4))
    bpy.context.object.data.materials.append(diffuse_material('Ball', (0.2, 0.5, 0.8)))
    ld = bpy.data.lights.new('Area', 'AREA'); ld.energy = 400.0; ld.size = 2.0
    lo = bpy.data.objects.new('Area', ld); sc.collection.objects.link(lo); lo.location = (1.0, -1.0, 3.5)
    def fresh(name):
        m = bpy.data.materials.new(name); m.use_nodes = True; nt = m.node_tree
        for n in list(nt.nodes):
            if n.type != 'OUTPUT_MATERIAL': nt.nodes.remove(n)
        return m, nt
    def volume(tree, node, output):
        tree.links.new(node.outputs[0], tree.nodes[output].inputs['Volume'])
    {objects}
    add_camera(sc, (0.0, -2.4, 1.0), (0, 0, 0.55), lens=40)
    sc.render.image_settings.file_format = 'OPEN_EXR'
    c = sc.cycles; c.device = 'CPU'; c.samples = {spp}; c.use_denoising = False; c.use_adaptive_sampling = False
    c.filter_width = 0.01; c.max_bounces = 16; c.diffuse_bounces = 16; c.glossy_bounces = 16
    c.transmission_bounces = 16; c.volume_bounces = 16; c.transparent_max_bounces = 16
    c.sample_clamp_indirect = 0.0; c.sample_clamp_direct = 0.0
    sc.polychrome.samples = {spp}; sc.polychrome.max_bounces = 16
    A = render_rgb(sc, 'CYCLES', 'cycles')
    B = render_rgb(sc, 'POLYCHROME', 'poly')
    err, warn = Engine.last_error, Engine.last_warnings
    # Every Volume output (materials and world) unlinked: how far off ignoring them is.
    for tree in [m.node_tree for m in bpy.data.materials] + [x.node_tree for x in bpy.data.worlds]:
        if tree is not None:
            for link in list(tree.links):
                if link.to_socket.name == 'Volume':
                    tree.links.remove(link)
    N = render_rgb(sc, 'POLYCHROME', 'novolume')
    emit(mean=mean_de00(A, B, 5), p90=float(np.percentile(block_de00(A, B, 5), 90)), without_volume=mean_de00(A, N, 5),
         err=err, warn=warn, ma=A.mean(axis=(0, 1)).tolist(), mb=B.mean(axis=(0, 1)).tolist())
"""


def _media_vs_cycles(tmp_path, objects, spp=256):
    proc, res = run_bpy(tmp_path, MEDIA.replace("{objects}", objects).replace("{spp}", str(spp)), timeout=600)
    r = check(proc, res)[0]
    assert r["err"] is None and r["warn"] == [], r
    return r


def test_world_fog_matches_cycles(tmp_path):
    """World > Volume: a Volume Scatter fog (with some absorption) filling all space,
    the camera inside it, the floor and a ball under an area light; the background is lost
    in the fog in both. Mean CIEDE2000 over 5×5-pixel blocks ≤ 1.5."""
    r = _media_vs_cycles(
        tmp_path,
        """
    s = w.node_tree.nodes.new('ShaderNodeVolumeScatter')
    s.inputs['Color'].default_value = (0.9, 0.8, 0.7, 1); s.inputs['Density'].default_value = 0.25
    s.inputs['Anisotropy'].default_value = 0.2
    a = w.node_tree.nodes.new('ShaderNodeVolumeAbsorption')
    a.inputs['Color'].default_value = (0.7, 0.8, 0.9, 1); a.inputs['Density'].default_value = 0.1
    add = w.node_tree.nodes.new('ShaderNodeAddShader')
    w.node_tree.links.new(s.outputs[0], add.inputs[0]); w.node_tree.links.new(a.outputs[0], add.inputs[1])
    volume(w.node_tree, add, 'World Output')
    """,
    )
    print("world fog vs Cycles:", r)
    assert r["mean"] <= 1.5 and r["without_volume"] > 3.0 * max(r["mean"], 1.0), r


def test_camera_inside_an_absorbing_box_matches_cycles(tmp_path):
    """The camera, the light and the ball inside a box of Volume Absorption (no surface)
    that the floor crosses: Cycles starts camera paths inside it
    (integrator_volume_stack_init), so must Polychrome. Mean CIEDE2000 ≤ 1.5."""
    r = _media_vs_cycles(
        tmp_path,
        """
    m, nt = fresh('Water')
    a = nt.nodes.new('ShaderNodeVolumeAbsorption')
    a.inputs['Color'].default_value = (0.5, 0.75, 0.9, 1); a.inputs['Density'].default_value = 0.5
    volume(nt, a, 'Material Output')
    bpy.ops.mesh.primitive_cube_add(size=7.0, location=(0, 0, 1.0))
    bpy.context.object.data.materials.append(m)
    """,
    )
    print("camera in absorbing box vs Cycles:", r)
    assert r["mean"] <= 1.5 and r["without_volume"] > 3.0 * max(r["mean"], 1.0), r


def test_volume_emission_matches_cycles(tmp_path):
    """Volume emission: a cube of Principled Volume (black colour: absorption only,
    blackbody at 2500 K, intensity 1) and a sphere whose Volume is an Emission node
    beside Volume Absorption, glowing onto the floor. Mean CIEDE2000 ≤ 1.5."""
    r = _media_vs_cycles(
        tmp_path,
        """
    ld.energy = 40.0
    m, nt = fresh('Flame')
    p = nt.nodes.new('ShaderNodeVolumePrincipled')
    p.inputs['Color'].default_value = (0, 0, 0, 1); p.inputs['Density'].default_value = 1.5
    p.inputs['Blackbody Intensity'].default_value = 1.0; p.inputs['Temperature'].default_value = 2500.0
    volume(nt, p, 'Material Output')
    bpy.ops.mesh.primitive_cube_add(size=0.7, location=(-0.5, 0.2, 0.36))
    bpy.context.object.data.materials.append(m)
    m, nt = fresh('Glow')
    e = nt.nodes.new('ShaderNodeEmission')
    e.inputs['Color'].default_value = (0.2, 0.9, 0.4, 1); e.inputs['Strength'].default_value = 1.5
    a = nt.nodes.new('ShaderNodeVolumeAbsorption')
    a.inputs['Color'].default_value = (0.5, 0.5, 0.5, 1); a.inputs['Density'].default_value = 2.0
    add = nt.nodes.new('ShaderNodeAddShader')
    nt.links.new(e.outputs[0], add.inputs[0]); nt.links.new(a.outputs[0], add.inputs[1])
    volume(nt, add, 'Material Output')
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.3, location=(0.0, -0.6, 0.9), segments=32, ring_count=16)
    bpy.context.object.data.materials.append(m)
    """,
    )
    print("volume emission vs Cycles:", r)
    assert r["mean"] <= 1.5 and r["without_volume"] > 3.0 * max(r["mean"], 1.0), r
