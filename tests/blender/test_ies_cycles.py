"""IES Texture on a light's Emission Strength (Cycles' light shader), against Cycles CPU
in one bpy process: a point light over a grey plane seen from above by an orthographic
camera, with a written type C quadrant profile (tests/ies_files.py) from a file
(External) and from a text block (Internal), the light turned 40° about X and 25° about
Z so that the profile's orientation shows, its Emission Color a Blackbody; and a spot
light with the profile inside its cone. Mean CIEDE2000 on 2 × 2 blocks ≤ 1.5, no
warning; control: the same lights without the profile are far off."""

import pytest

from .bhelper import ROOT, check, run_bpy

pytestmark = pytest.mark.blender


def test_ies_lights_match_cycles(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        f"""
    sys.path.insert(0, {str(ROOT / "tests")!r})
    from ies_files import quadrant_file
    open('q.ies', 'w').write(quadrant_file())
    W = 40
    sc = empty_scene(W, W)
    sc.world = None
    cd = bpy.data.cameras.new('C'); cd.type = 'ORTHO'; cd.ortho_scale = 6.0
    cam = bpy.data.objects.new('C', cd); sc.collection.objects.link(cam); sc.camera = cam; cam.location = (0, 0, 6)
    bpy.ops.mesh.primitive_plane_add(size=12)
    m = bpy.data.materials.new('grey'); m.use_nodes = True
    m.node_tree.nodes['Principled BSDF'].inputs['Base Color'].default_value = (0.5, 0.5, 0.5, 1)
    m.node_tree.nodes['Principled BSDF'].inputs['Roughness'].default_value = 1.0
    m.node_tree.nodes['Principled BSDF'].inputs['Specular IOR Level'].default_value = 0.0
    bpy.context.object.data.materials.append(m)

    def lamp(kind, mode, blackbody=False, profile=True):
        for o in [o for o in sc.collection.objects if o.type == 'LIGHT']:
            bpy.data.objects.remove(o)
        ld = bpy.data.lights.new('L', kind); ld.energy = 40.0; ld.shadow_soft_size = 0.0
        if kind == 'SPOT':
            ld.spot_size = 1.6; ld.spot_blend = 0.3
        ob = bpy.data.objects.new('L', ld); sc.collection.objects.link(ob)
        ob.location = (0.3, -0.2, 1.5); ob.rotation_euler = (0.7, 0.0, 0.44)
        ld.use_nodes = True
        nt = ld.node_tree; em = nt.nodes['Emission']
        if profile:
            t = nt.nodes.new('ShaderNodeTexIES')
            if mode == 'EXTERNAL':
                t.mode = 'EXTERNAL'; t.filepath = os.path.abspath('q.ies')
            else:
                t.mode = 'INTERNAL'; txt = bpy.data.texts.new('q.ies'); txt.from_string(quadrant_file()); t.ies = txt
            t.inputs['Strength'].default_value = 0.8
            nt.links.new(t.outputs['Fac'], em.inputs['Strength'])
        if blackbody:
            b = nt.nodes.new('ShaderNodeBlackbody'); b.inputs['Temperature'].default_value = 3500.0
            nt.links.new(b.outputs['Color'], em.inputs['Color'])

    out = {{}}
    for tag, kind, mode, bb in [('point-file', 'POINT', 'EXTERNAL', False), ('point-text-bb', 'POINT', 'INTERNAL', True),
                                ('spot', 'SPOT', 'EXTERNAL', False)]:
        lamp(kind, mode, bb)
        ref, test = cycles_and_polychrome(sc, 64, 1)
        warn = list(Engine.last_warnings); err = Engine.last_error
        lamp(kind, mode, bb, profile=False)
        sc.render.filepath = os.path.abspath('plain.exr'); bpy.ops.render.render(write_still=True)
        plain = exr_rgb('plain.exr')
        emit(tag=tag, de=mean_de00(ref, test, 2), control=mean_de00(ref, plain, 2), warn=warn, err=err,
             ref_mean=float(ref.mean()), test_mean=float(test.mean()))
    """,
        timeout=600,
    )
    rows = check(proc, res, 3)
    for r in rows:
        print(r)
    for r in rows:
        assert r["err"] is None and r["warn"] == [], r
        assert r["de"] <= 1.5, r
        assert r["control"] > 3 * max(r["de"], 0.5), r
