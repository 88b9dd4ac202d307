"""Polychrome's custom shader nodes: survive save/reload, export to the right spectra."""

import pytest

from .bhelper import check, run_bpy

pytestmark = pytest.mark.blender


def test_custom_nodes_survive_save_and_reload_and_render(tmp_path):
    blend = tmp_path / "nodes.blend"
    proc, res = run_bpy(
        tmp_path,
        f"""
    sc = empty_scene(24, 16)
    def node_material(name, idname):
        m = bpy.data.materials.new(name); m.use_nodes = True
        nt = m.node_tree
        for n in list(nt.nodes):
            if n.type != 'OUTPUT_MATERIAL': nt.nodes.remove(n)
        n = nt.nodes.new(idname); n.name = name + 'Node'
        nt.links.new(n.outputs[0], nt.nodes['Material Output'].inputs['Surface'])
        return m, n
    m1, n1 = node_material('Curve', 'PolychromeSpectralReflectanceNode')
    n1.curve = [0.5] * 32
    n1.curve[3] = 0.5                      # explicit values (defaults are not stored)
    m2, n2 = node_material('Checker', 'PolychromeSpectralReflectanceNode')
    n2.mode = 'COLORCHECKER'; n2.patch = 'P15'
    m3, n3 = node_material('Glass', 'PolychromeDispersionNode')
    n3.model = 'ABBE'; n3.abbe_nd = 1.6; n3.abbe_vd = 40.0
    m4, n4 = node_material('Lamp', 'PolychromeSpectralEmissionNode')
    n4.kind = 'NARROW_BAND'; n4.center = 600.0; n4.width = 20.0; n4.strength = 3.0
    m1.use_fake_user = m2.use_fake_user = m3.use_fake_user = m4.use_fake_user = True
    bpy.ops.wm.save_as_mainfile(filepath={str(blend)!r})
    emit(saved=True)
    """,
    )
    check(proc, res)
    proc, res = run_bpy(
        tmp_path,
        f"""
    bpy.ops.wm.open_mainfile(filepath={str(blend)!r})
    mats = bpy.data.materials
    n1 = mats['Curve'].node_tree.nodes['CurveNode']; n2 = mats['Checker'].node_tree.nodes['CheckerNode']
    n3 = mats['Glass'].node_tree.nodes['GlassNode']; n4 = mats['Lamp'].node_tree.nodes['LampNode']
    out = dict(types=[n.bl_idname for n in (n1, n2, n3, n4)], curve=list(n1.curve), mode=n2.mode, patch=n2.patch,
               model=n3.model, nd=n3.abbe_nd, vd=n3.abbe_vd, kind=n4.kind, center=n4.center, width=n4.width,
               strength=n4.strength)
    # IOR readouts: Abbe mode and the catalogue's N-BK7 (SCHOTT: nd 1.51680, Vd 64.17)
    from polychrome_blender.nodes import LINE_C, LINE_D, LINE_F
    out['abbe'] = [n3.ior(LINE_F), n3.ior(LINE_D), n3.ior(LINE_C)]
    n3.model = 'NAMED'; n3.named = 'N_BK7'
    out['bk7'] = [n3.ior(LINE_F), n3.ior(LINE_D), n3.ior(LINE_C)]
    n3.model = 'ABBE'
    # render: a plane with the flat 0.5 spectral curve vs the same plane in RGB grey 0.5
    sc = bpy.context.scene
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = 24, 16, 100
    sc.view_settings.view_transform = 'Standard'
    bpy.ops.mesh.primitive_plane_add(size=20)
    plane = bpy.context.object
    add_camera(sc, (0, 0, 5), (0, 0, 0))
    ld = bpy.data.lights.new('P', 'POINT'); ld.energy = 500.0; ld.shadow_soft_size = 0.0
    lo = bpy.data.objects.new('P', ld); sc.collection.objects.link(lo); lo.location = (0, 0, 3)
    sc.world = None
    sc.render.engine = 'POLYCHROME'; sc.polychrome.samples = 16
    sc.render.image_settings.file_format = 'OPEN_EXR'
    means = {{}}
    for name, mat in (('curve', mats['Curve']), ('rgb', diffuse_material('Grey', (0.5, 0.5, 0.5))), ('checker', mats['Checker'])):
        plane.data.materials.clear(); plane.data.materials.append(mat)
        sc.render.filepath = os.path.abspath(name + '.exr'); bpy.ops.render.render(write_still=True)
        ch = exr_channels(name + '.exr')
        means[name] = [float(ch[c].mean()) for c in 'RGB']
        out['err_' + name] = Engine.last_error
    out['means'] = means
    emit(**out)
    """,
    )
    r = check(proc, res)[0]
    assert r["types"] == ["PolychromeSpectralReflectanceNode"] * 2 + ["PolychromeDispersionNode", "PolychromeSpectralEmissionNode"]
    assert r["curve"] == pytest.approx([0.5] * 32)
    assert (r["mode"], r["patch"], r["model"], r["kind"]) == ("COLORCHECKER", "P15", "ABBE", "NARROW_BAND")
    assert (r["nd"], r["vd"], r["center"], r["width"], r["strength"]) == pytest.approx((1.6, 40.0, 600.0, 20.0, 3.0))
    nf, nd, nc = r["abbe"]
    assert nd == pytest.approx(1.6, abs=1e-6) and (nd - 1) / (nf - nc) == pytest.approx(40.0, rel=1e-5)
    nf, nd, nc = r["bk7"]
    assert nd == pytest.approx(1.51680, abs=2e-5) and (nd - 1) / (nf - nc) == pytest.approx(64.17, abs=0.05)
    assert r["err_curve"] is None and r["err_rgb"] is None and r["err_checker"] is None
    # a flat 0.5 reflectance and RGB grey 0.5 (flat by the uplift's bounds) give the same image;
    # both are rendered with the same seed, so only the uplift's rounding differs
    for a, b in zip(r["means"]["curve"], r["means"]["rgb"]):
        assert a == pytest.approx(b, rel=0.02)
    # ColorChecker patch 15 is "red": R well above G and B
    red = r["means"]["checker"]
    assert red[0] > 2.5 * red[1] and red[0] > 2.5 * red[2]
