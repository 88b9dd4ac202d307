"""A .blend exported with Blender's own USD exporter (bpy.ops.wm.usd_export) renders
through `polychrome render` like the .blend itself: sun, point, spot, area (square,
rectangle, disk) and world lights, Normalize on and off, scaled light objects, colour
temperature on and off. Both images come from `polychrome render` (the .blend through the
add-on's exporter, the .usda through polychrome.usd); they must agree within a mean
CIEDE2000 of 1 (colour-science, on 4 × 4 pixel blocks so that sampling noise stays small)."""

import json
import os
import subprocess
import sys
import textwrap

import pytest

pytestmark = pytest.mark.blender

SCENES = {
    # name: [(light type, settings, location, rotation (degrees), scale)], world (rgb, strength) or None
    "sun normalize on": ([("SUN", {"energy": 3.0}, (0, 0, 5), (35, 0, 30), (1, 1, 1))], ((0.05, 0.07, 0.1), 1.0)),
    "sun normalize off, 10 degrees": (
        [("SUN", {"energy": 300.0, "angle": 0.1745, "normalize": False}, (0, 0, 5), (35, 0, -40), (1, 1, 1))],
        None,
    ),
    "point and spot": (
        [
            ("POINT", {"energy": 150.0, "shadow_soft_size": 0.1}, (2.0, -1.5, 2.5), (0, 0, 0), (1, 1, 1)),
            ("POINT", {"energy": 40.0, "shadow_soft_size": 0.25, "normalize": False}, (-2.0, -1.0, 2.0), (0, 0, 0), (1, 1, 1)),
            ("SPOT", {"energy": 300.0, "spot_size": 1.0, "spot_blend": 0.3}, (0.0, -2.5, 3.0), (40, 0, 0), (1, 1, 1)),
            (
                "SPOT",
                {"energy": 20.0, "shadow_soft_size": 0.0, "spot_size": 1.4, "spot_blend": 0.1, "normalize": False},
                (1.5, 1.5, 3.0),
                (-25, 25, 0),
                (1, 1, 1),
            ),
        ],
        None,
    ),
    "area lights, scaled": (
        [
            ("AREA", {"energy": 200.0, "shape": "SQUARE", "size": 0.5}, (1.5, -1.5, 2.5), (20, 0, 0), (2, 2, 1)),
            ("AREA", {"energy": 30.0, "shape": "DISK", "size": 1.0, "normalize": False}, (-1.5, -1.0, 2.5), (-20, 0, 0), (0.5, 0.5, 1)),
            ("AREA", {"energy": 80.0, "shape": "RECTANGLE", "size": 1.0, "size_y": 0.4}, (0.0, 2.0, 2.0), (-40, 0, 0), (1, 1, 1)),
        ],
        None,
    ),
    "temperature on and off": (
        [
            ("POINT", {"energy": 200.0, "use_temperature": True, "temperature": 3000.0}, (2.0, -1.5, 2.5), (0, 0, 0), (1, 1, 1)),
            (
                "AREA",
                {"energy": 150.0, "size": 1.0, "use_temperature": True, "temperature": 9000.0, "color": (1.0, 0.8, 0.6)},
                (-1.5, -1.0, 2.5),
                (-20, 0, 0),
                (1, 1, 1),
            ),
            ("SUN", {"energy": 1.0, "color": (0.6, 0.7, 1.0)}, (0, 0, 5), (50, 0, 60), (1, 1, 1)),
        ],
        None,
    ),
    "world only": ([], ((0.4, 0.5, 0.6), 1.5)),
}


def test_blender_usd_export_renders_like_the_blend(tmp_path):
    pytest.importorskip("bpy")
    colour = pytest.importorskip("colour")
    script = textwrap.dedent(f"""
        import json, math, os, sys, warnings
        import bpy
        from polychrome import cli
        SCENES = {SCENES!r}
        out = {{}}
        for i, (name, (lights, world)) in enumerate(SCENES.items()):
            bpy.ops.wm.read_factory_settings(use_empty=True)
            sc = bpy.context.scene
            sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = 32, 24, 100
            def diffuse(mname, rgb):
                m = bpy.data.materials.new(mname); m.use_nodes = True; nt = m.node_tree
                for n in list(nt.nodes):
                    if n.type != 'OUTPUT_MATERIAL': nt.nodes.remove(n)
                d = nt.nodes.new('ShaderNodeBsdfDiffuse'); d.inputs['Color'].default_value = (*rgb, 1.0)
                nt.links.new(d.outputs['BSDF'], nt.nodes['Material Output'].inputs['Surface'])
                return m
            bpy.ops.mesh.primitive_plane_add(size=10)
            bpy.context.object.data.materials.append(diffuse('Floor', (0.7, 0.6, 0.5)))
            bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0, 0, 0.5))
            bpy.context.object.data.materials.append(diffuse('Cube', (0.2, 0.5, 0.7)))
            bpy.ops.mesh.primitive_uv_sphere_add(radius=0.4, location=(1.1, 0.6, 0.4))
            bpy.context.object.data.materials.append(diffuse('Ball', (0.8, 0.3, 0.2)))
            for j, (kind, settings, loc, rot, scale) in enumerate(lights):
                ld = bpy.data.lights.new(f'L{{j}}', kind)
                for k, v in settings.items():
                    setattr(ld, k, v)
                ob = bpy.data.objects.new(f'L{{j}}', ld); sc.collection.objects.link(ob)
                ob.location = loc; ob.rotation_euler = [math.radians(a) for a in rot]; ob.scale = scale
            if world is not None:
                w = bpy.data.worlds.new('W'); w.use_nodes = True; sc.world = w
                bg = w.node_tree.nodes['Background']
                bg.inputs['Color'].default_value = (*world[0], 1.0); bg.inputs['Strength'].default_value = world[1]
            else:
                sc.world = None
            from mathutils import Vector
            cd = bpy.data.cameras.new('Cam'); cd.lens = 30
            co = bpy.data.objects.new('Cam', cd); sc.collection.objects.link(co); sc.camera = co
            co.location = (4.5, -5.0, 3.5)
            co.rotation_euler = (Vector((0, 0, 0.4)) - co.location).to_track_quat('-Z', 'Y').to_euler()
            blend, usda = os.path.abspath(f's{{i}}.blend'), os.path.abspath(f's{{i}}.usda')
            bpy.ops.wm.save_as_mainfile(filepath=blend)
            bpy.ops.wm.usd_export(filepath=usda, export_materials=True)
            out[name] = (blend, usda)
        common = ['--width', '32', '--height', '24', '--samples', '64', '--seed', '3', '--max-bounces', '4', '--quiet']
        res = {{}}
        for name, (blend, usda) in out.items():
            codes = []
            for src in (blend, usda):
                with warnings.catch_warnings(record=True) as caught:
                    warnings.simplefilter('always')
                    codes.append(cli.main(['render', src, '-o', src + '.exr', *common]))
                res.setdefault(name, {{}})[os.path.splitext(src)[1]] = [str(w.message) for w in caught]
            res[name]['codes'] = codes
            res[name]['files'] = [blend + '.exr', usda + '.exr']
        print('RESULT ' + json.dumps(res))
    """)
    env = dict(os.environ)
    (tmp_path / "user").mkdir()
    env["BLENDER_USER_RESOURCES"] = str(tmp_path / "user")
    proc = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    res = json.loads(next(line[7:] for line in proc.stdout.splitlines() if line.startswith("RESULT ")))

    import numpy as np
    from polychrome import imageio

    rec709 = colour.RGB_COLOURSPACES["ITU-R BT.709"]
    failures = []
    for name, r in res.items():
        assert r["codes"] == [0, 0], (name, r)
        a, b = (np.asarray(imageio.read_image(f), np.float64)[..., :3] for f in r["files"])
        h, w = a.shape[:2]
        blocks = [x.reshape(h // 4, 4, w // 4, 4, 3).mean(axis=(1, 3)) for x in (a, b)]
        # Lab relative to a white of the blend render's 99th-percentile luminance
        xyz = [colour.RGB_to_XYZ(x, rec709, apply_cctf_decoding=False) for x in blocks]
        white_y = max(float(np.percentile(xyz[0][..., 1], 99)), 1e-6)
        lab = [colour.XYZ_to_Lab(x / white_y, rec709.whitepoint) for x in xyz]
        de = float(np.mean(colour.delta_E(lab[0], lab[1], method="CIE 2000")))
        ratio = (b.mean(axis=(0, 1)) / np.maximum(a.mean(axis=(0, 1)), 1e-9)).round(4).tolist()
        if not de < 1.0:
            failures.append((name, round(de, 3), ratio, r[".usda"]))
    assert not failures, failures
