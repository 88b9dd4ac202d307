"""A textured Principled Alpha against Cycles (issue 12, glTF alpha mask and blend): a
plane whose Base Color and Alpha come from one RGBA Image Texture (Color → Base Color,
Alpha → Alpha, as Blender's glTF importer wires them) floats over a coloured floor under
a sun and a dim world, seen from above by an orthographic camera. The image has a
cut-out disc (alpha 0), an opaque border and a band of partial alpha. Cycles CPU and
Polychrome render it in the same bpy process; mean CIEDE2000 on 4×4-pixel blocks must
be within 1.5, and the same plane with its Alpha unlinked (opaque) must be far off
(the test sees the cut-out). The colours are unsaturated: light bounced between a
saturated floor and the plane's underside differs between spectral and RGB products
(SPEC §1), which is not what this test is about."""

import pytest

from .bhelper import check, run_bpy

pytestmark = pytest.mark.blender

BAR = 1.5

SCRIPT = """
N, SPP = 32, 64
sc = empty_scene(N, N)
sc.render.dither_intensity = 0.0
w = bpy.data.worlds.new('W'); w.use_nodes = True; sc.world = w
bg = w.node_tree.nodes['Background']; bg.inputs['Color'].default_value = (0.5, 0.5, 0.5, 1); bg.inputs['Strength'].default_value = 1.0
sd = bpy.data.lights.new('Sun', 'SUN'); sd.energy = 2.0; sd.angle = math.radians(1.0)
so = bpy.data.objects.new('Sun', sd); sc.collection.objects.link(so); so.rotation_euler = (math.radians(20), 0, math.radians(30))
cd = bpy.data.cameras.new('C'); cd.type = 'ORTHO'; cd.ortho_scale = 2.0
cam = bpy.data.objects.new('C', cd); sc.collection.objects.link(cam); sc.camera = cam; cam.location = (0, 0, 5)
bpy.ops.mesh.primitive_plane_add(size=6)
bpy.context.object.data.materials.append(diffuse_material('Floor', (0.55, 0.45, 0.35)))
# 16x16 RGBA: a disc of alpha 0, an opaque border, a band of alpha 0.5 along the bottom rows
img = bpy.data.images.new('cutout', 16, 16, alpha=True)
y, x = (np.mgrid[0:16, 0:16] + 0.5) / 16.0        # row 0 = bottom in Blender
px = np.zeros((16, 16, 4), np.float32)
px[..., 0] = 0.25 + 0.4 * x; px[..., 1] = 0.45; px[..., 2] = 0.6
px[..., 3] = 1.0
px[..., 3][np.hypot(x - 0.5, y - 0.6) < 0.25] = 0.0
px[..., 3][y < 0.25] = 0.5
img.pixels.foreach_set(px.ravel())
img.pack()
m = bpy.data.materials.new('Cutout'); m.use_nodes = True; nt = m.node_tree
p = nt.nodes['Principled BSDF']
t = nt.nodes.new('ShaderNodeTexImage'); t.image = img; t.interpolation = 'Closest'
nt.links.new(t.outputs['Color'], p.inputs['Base Color'])
alpha_link = nt.links.new(t.outputs['Alpha'], p.inputs['Alpha'])
p.inputs['Roughness'].default_value = 0.6
bpy.ops.mesh.primitive_plane_add(size=1.6, location=(0, 0, 0.5))
bpy.context.object.data.materials.append(m)
sc.render.image_settings.file_format = 'OPEN_EXR'; sc.render.image_settings.color_depth = '32'
c = sc.cycles; c.device = 'CPU'; c.samples = SPP; c.use_denoising = False; c.use_adaptive_sampling = False
c.filter_width = 0.01; c.max_bounces = 8; c.transparent_max_bounces = 8
c.sample_clamp_direct = 0.0; c.sample_clamp_indirect = 0.0
sc.render.threads_mode = 'FIXED'; sc.render.threads = 2
sc.polychrome.samples = SPP; sc.polychrome.max_bounces = 8
cycles = render_rgb(sc, 'CYCLES', 'cycles')
poly = render_rgb(sc, 'POLYCHROME', 'poly')
err, warn = Engine.last_error, list(Engine.last_warnings or [])
nt.links.remove(alpha_link)
sc.polychrome.samples = 16  # the control is far off; few samples do
opaque = render_rgb(sc, 'POLYCHROME', 'opaque')
emit(de=mean_de00(cycles, poly, 4), control=mean_de00(cycles, opaque, 4), err=err, warn=warn,
     means=[float(cycles.mean()), float(poly.mean()), float(opaque.mean())])
"""


def test_textured_alpha_cutout_matches_cycles(tmp_path):
    proc, res = run_bpy(tmp_path, SCRIPT, timeout=900)
    r = check(proc, res)[0]
    print("textured alpha vs Cycles: dE00", round(r["de"], 3), "opaque control", round(r["control"], 3), r["means"])
    assert r["err"] is None, r
    assert not [w for w in r["warn"] if "Alpha" in w or "not supported" in w], r["warn"]
    assert r["de"] <= BAR, r
    assert r["control"] > 3 * BAR, r
