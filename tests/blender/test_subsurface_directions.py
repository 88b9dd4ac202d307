"""The Principled subsurface random walk in every direction against Cycles CPU in the same
bpy process: a sphere with the BSDF grid's subsurface material (base (0.8, 0.5, 0.4),
Subsurface Weight 1, Scale 0.1, Blender's radius (1, 0.2, 0.1): a diffusive walk) under a
sun, no world, seen by a perspective camera (FORWARD needs a pinhole). BACKWARD, FORWARD
(light paths walk from the sun's side) and BIDIRECTIONAL each against Cycles: mean
CIEDE2000 on 4 × 4 blocks inside the sphere's disc (colour-science via
polychrome.colordiff) and the disc's mean colour, with no warning."""

import pytest

from .bhelper import check, run_bpy

pytestmark = pytest.mark.blender

SCRIPT = """
sc = empty_scene(48, 48); sc.world = None
bpy.ops.mesh.primitive_uv_sphere_add(radius=0.5, segments=64, ring_count=32)
bpy.ops.object.shade_smooth()
m = bpy.data.materials.new('Wax'); m.use_nodes = True
p = m.node_tree.nodes['Principled BSDF']
p.inputs['Base Color'].default_value = (0.8, 0.5, 0.4, 1.0)
p.inputs['Subsurface Weight'].default_value = 1.0; p.inputs['Subsurface Scale'].default_value = 0.1
bpy.context.object.data.materials.append(m)
ld = bpy.data.lights.new('Sun', 'SUN'); ld.energy = 3.0; ld.angle = 0.0
so = bpy.data.objects.new('Sun', ld); sc.collection.objects.link(so); so.rotation_euler = (math.radians(50), 0, math.radians(30))
add_camera(sc, (0, -4.0, 0), (0, 0, 0), lens=100)
sc.render.image_settings.file_format = 'OPEN_EXR'; sc.render.image_settings.color_depth = '32'
cycles_cpu(sc, 256, 16)
c = sc.cycles; c.pixel_filter_type = 'BOX'; c.filter_width = 1.0
sc.render.filepath = os.path.abspath('cycles.exr'); bpy.ops.render.render(write_still=True)
sc.render.engine = 'POLYCHROME'; sc.polychrome.max_bounces = 16
import polychrome.colordiff as cdiff
def load(p):
    ch = exr_channels(p)
    return np.stack([ch[k] for k in 'RGB'], -1).reshape(48, 48, 3)
A = load('cycles.exr')
# The disc: radius tan(asin(0.5 / 4)) / (18 / 100) × 24 = 16.8 pixels about the centre.
yy, xx = np.mgrid[0:12, 0:12]
inside = np.hypot((yy + 0.5) * 4 - 24, (xx + 0.5) * 4 - 24) < 0.8 * 16.8
a = A.reshape(12, 4, 12, 4, 3).mean(axis=(1, 3))[inside]
white = float(np.percentile(a[:, 1], 99))
out = dict(cycles=a.mean(axis=0).tolist())
for direction, spp in (('BACKWARD', 256), ('FORWARD', 1024), ('BIDIRECTIONAL', 256)):
    sc.polychrome.direction = direction; sc.polychrome.samples = spp
    sc.render.filepath = os.path.abspath(direction + '.exr'); bpy.ops.render.render(write_still=True)
    b = load(direction + '.exr').reshape(12, 4, 12, 4, 3).mean(axis=(1, 3))[inside]
    de = cdiff.image_delta_e(a[None], b[None], white_luminance=white)
    out[direction] = dict(de=float(de.mean()), mean=b.mean(axis=0).tolist(), err=Engine.last_error, warn=list(Engine.last_warnings or []))
emit(**out)
"""


def test_subsurface_walks_in_every_direction_as_cycles(tmp_path):
    proc, res = run_bpy(tmp_path, SCRIPT, timeout=900)
    r = check(proc, res)[0]
    print("subsurface directions vs Cycles:", r)
    for direction in ("BACKWARD", "FORWARD", "BIDIRECTIONAL"):
        d = r[direction]
        assert d["err"] is None and d["warn"] == [], (direction, d)
        assert d["de"] < 1.5, (direction, d)
        for c in range(3):
            assert d["mean"][c] == pytest.approx(r["cycles"][c], rel=0.05), (direction, c, d, r["cycles"])
