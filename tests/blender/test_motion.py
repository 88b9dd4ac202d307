"""Motion blur and the render border against Cycles CPU in one bpy process
(docs/camera.md): an animated object (translation, rotation with more motion steps),
a deforming mesh (an animated shape key), a moving camera, the shutter positions and a
shutter curve; the render border with and without cropping. Mean CIEDE2000 on 2×2
blocks of emission-only scenes; the motion-blur control renders Polychrome with motion
blur off, which must differ clearly. Closed forms for the smear are in
tests/test_motion.py and rust/core/tests/motion.rs."""

import textwrap

import numpy as np
import pytest

from .bhelper import check, run_bpy
from .test_camera import COMMON

pytestmark = pytest.mark.blender

# Every keyframe linear (uniform motion between keys), for the bpy scripts below.
ALL_LINEAR = """
def all_linear():
    for a in bpy.data.actions:
        fcs = getattr(a, 'fcurves', None)
        if fcs is None:  # Blender 5: layered actions
            fcs = [fc for layer in a.layers for strip in layer.strips for bag in strip.channelbags for fc in bag.fcurves]
        for fc in fcs:
            for k in fc.keyframe_points:
                k.interpolation = 'LINEAR'
"""

SCENE = (
    ALL_LINEAR
    + """
sc = empty_scene(48, 32); sc.world = None
cd_ = bpy.data.cameras.new('Cam'); cd_.type = 'ORTHO'; cd_.ortho_scale = 6.0
cam = bpy.data.objects.new('Cam', cd_); sc.collection.objects.link(cam); sc.camera = cam
cam.location = (0, 0, 5)
# A bar moving along x, a square spinning, a ground of another colour.
bpy.ops.mesh.primitive_plane_add(size=8, location=(0, 0, -1)); bpy.context.object.data.materials.append(emission('Ground', (0.1, 0.15, 0.3)))
bpy.ops.mesh.primitive_plane_add(size=1, location=(-1.2, 0.6, 0)); bar = bpy.context.object
bar.scale = (0.4, 1.0, 1.0); bar.data.materials.append(emission('Bar', (1.0, 0.7, 0.2)))
bar.location.x = -2.2; bar.keyframe_insert('location', frame=9)
bar.location.x = 0.2; bar.keyframe_insert('location', frame=11)
bpy.ops.mesh.primitive_plane_add(size=1.2, location=(1.3, -0.7, 0)); spin = bpy.context.object
spin.data.materials.append(emission('Spin', (0.2, 1.0, 0.4)))
spin.rotation_euler.z = 0.0; spin.keyframe_insert('rotation_euler', frame=9)
spin.rotation_euler.z = 2.4; spin.keyframe_insert('rotation_euler', frame=11)
# A deforming square: its shape key slides the right edge (deformation motion).
bpy.ops.mesh.primitive_plane_add(size=0.8, location=(-1.4, -0.8, 0)); blob = bpy.context.object
blob.data.materials.append(emission('Blob', (0.9, 0.2, 0.8)))
blob.shape_key_add(name='Basis'); k = blob.shape_key_add(name='Stretch')
for v in k.data:
    if v.co.x > 0: v.co.x += 1.5
k.value = 0.0; k.keyframe_insert('value', frame=9); k.value = 1.0; k.keyframe_insert('value', frame=11)
all_linear()
sc.frame_set(10)
setup_engines(sc, 128)
sc.render.use_motion_blur = True; sc.render.motion_blur_shutter = 0.5; sc.render.motion_blur_position = 'CENTER'
"""
)


def script(body):
    return COMMON + SCENE + textwrap.dedent(body)


def test_motion_blur_matches_cycles(tmp_path):
    """Objects, a deforming mesh and the camera over Blender's shutter: centre, start and
    end positions, a 1-frame shutter with 2 motion steps on the spinning square, a
    shutter curve and a rolling shutter. Compared on the blocks where Cycles' blurred
    frame differs from its still frame (motion shows there); controls: Polychrome with
    half the shutter, and without the rolling shutter."""
    proc, res = run_bpy(
        tmp_path,
        script(
            """
    def block_de(a, b):
        return cd.image_delta_e(block_means(a), block_means(b), white_luminance=1.0)
    sc.render.use_motion_blur = False
    still = render(sc, 'CYCLES', 'c0')  # the frame itself: where blocks differ from it, motion shows
    sc.render.use_motion_blur = True
    def case(**k):
        sc.render.motion_blur_position = k.get('position', 'CENTER')
        sc.render.motion_blur_shutter = k.get('shutter', 0.5)
        spin.cycles.motion_steps = k.get('steps', 1)
        cam.animation_data_clear(); cam.location = (0, 0, 5)
        if k.get('camera'):
            cam.location.y = -0.8; cam.keyframe_insert('location', frame=9)
            cam.location.y = 0.8; cam.keyframe_insert('location', frame=11)
            all_linear()
        sc.frame_set(10)
        curve = sc.render.motion_blur_shutter_curve
        pts = curve.curves[0].points
        while len(pts) > 2: pts.remove(pts[1])
        pts[0].location = (0.0, 1.0); pts[1].location = (1.0, 1.0)
        if k.get('curve'):  # opens slowly: a ramp from 0 to 1
            pts[0].location = (0.0, 0.0)
        curve.update()
        sc.cycles.rolling_shutter_type = 'TOP' if k.get('rolling') else 'NONE'
        sc.cycles.rolling_shutter_duration = 0.2
        a = render(sc, 'CYCLES', 'c'); b = render(sc, 'POLYCHROME', 'p')
        moving = block_de(a, still) > 2.0
        de = block_de(a, b)
        return a, moving, dict(de=float(de[moving].mean()), de_all=float(de.mean()), blocks=int(moving.sum()),
                               err=Engine.last_error, warn=Engine.last_warnings)
    out = {}
    a, moving, out['centre'] = case()
    # Control: Polychrome's shutter half as long, on the blocks where motion shows.
    sc.render.motion_blur_shutter = 0.25
    out['control: half the shutter'] = dict(de=float(block_de(a, render(sc, 'POLYCHROME', 'p0'))[moving].mean()))
    _, _, out['start, 1-frame shutter, 2 steps'] = case(position='START', shutter=1.0, steps=2)
    _, _, out['end'] = case(position='END')
    _, _, out['camera moves'] = case(camera=True)
    _, _, out['shutter curve'] = case(curve=True, shutter=1.0)
    a, moving, out['rolling shutter'] = case(rolling=True, shutter=1.0)
    sc.cycles.rolling_shutter_type = 'NONE'  # control: no rolling shutter in Polychrome
    out['control: rolling shutter off'] = dict(de=float(block_de(a, render(sc, 'POLYCHROME', 'p1'))[moving].mean()))
    emit(**out)
    """
        ),
        timeout=600,
    )
    r = check(proc, res)[0]
    print("motion blur vs Cycles (mean ΔE00 over the 2×2 blocks where motion shows; all blocks):", r)
    for name in ("control: half the shutter", "control: rolling shutter off"):
        assert r.pop(name)["de"] > 3.0, (name, r)
    for name, v in r.items():
        assert v["err"] is None and v["warn"] == [], (name, v)
        assert v["blocks"] >= 12, (name, v)
        # The rolling shutter included (0.73 against 10.2 for none; docs/camera.md).
        assert v["de"] <= 1.5, (name, v)


def test_render_border_matches_cycles(tmp_path):
    """Blender's render border, cropped and not: Polychrome renders only the border
    (its sample count says so) and the image matches Cycles' there."""
    proc, res = run_bpy(
        tmp_path,
        script(
            """
    sc.render.use_motion_blur = False
    sc.polychrome.noise_threshold = 0.0  # every pixel takes every sample: the counts say what was rendered
    sc.render.use_border = True
    sc.render.border_min_x, sc.render.border_max_x = 0.1, 0.6
    sc.render.border_min_y, sc.render.border_max_y = 0.25, 0.9
    out = {}
    for crop in (True, False):
        sc.render.use_crop_to_border = crop
        a = render(sc, 'CYCLES', 'c'); b = render(sc, 'POLYCHROME', 'p')
        out[f'crop {crop}'] = dict(de=compare(a, b), shape=[list(a.shape), list(b.shape)], err=Engine.last_error,
                                   warn=Engine.last_warnings, samples=Engine.last_stats['total_samples'])
    sc.render.use_border = False
    full = render(sc, 'POLYCHROME', 'f')
    out['full samples'] = Engine.last_stats['total_samples']
    emit(**out)
    """
        ),
        timeout=300,
    )
    r = check(proc, res)[0]
    print("render border vs Cycles (mean ΔE00, 2×2 blocks):", r)
    full = r.pop("full samples")
    assert full == 48 * 32 * 128
    for name, v in r.items():
        assert v["err"] is None and v["warn"] == [], (name, v)
        assert v["shape"][0] == v["shape"][1], (name, v)
        assert v["de"] <= 1.5, (name, v)
        # 24 × 20 pixels of the border (Blender truncates its corners to pixels).
        assert v["samples"] == 24 * 20 * 128, (name, v)


def test_a_turning_sun_exports_its_keys(tmp_path):
    """A sun whose rotation is animated over the shutter exports motion keys whose −Z
    axes are the sun's direction at the shutter's opening and closing (Blender's own
    matrix_world there), without a warning; Polychrome turns the sun with them (closed
    form of the lit floor in rust/core/tests/motion.rs). Cycles keeps its lights at the
    frame, so there is no Cycles comparison."""
    proc, res = run_bpy(
        tmp_path,
        ALL_LINEAR
        + textwrap.dedent(
            """
    import mathutils
    from polychrome_blender.export import export_scene
    sc = empty_scene(8, 8)
    add_camera(sc, (0, -10, 3))
    sc.render.use_motion_blur = True; sc.render.motion_blur_shutter = 1.0
    ld = bpy.data.lights.new('Sun', 'SUN'); ld.energy = 3.0
    sun = bpy.data.objects.new('Sun', ld); sc.collection.objects.link(sun)
    sun.rotation_euler.x = -0.4; sun.keyframe_insert('rotation_euler', frame=9)
    sun.rotation_euler.x = 1.0; sun.keyframe_insert('rotation_euler', frame=11)
    all_linear()
    def axis_at(frame, sub):
        sc.frame_set(frame, subframe=sub)
        return list(sun.matrix_world.to_3x3() @ mathutils.Vector((0, 0, -1)))
    want = [axis_at(9, 0.5), axis_at(10, 0.5)]
    sc.frame_set(10)
    scene, warns = export_scene(bpy.context.evaluated_depsgraph_get(), frame_set=lambda f, s: sc.frame_set(f, subframe=s))
    desc, _ = scene.description()
    (light,) = desc['lights']
    keys = [[-row[2] for row in k[:3]] for k in light.get('motion', [])]
    emit(keys=keys, want=want, direction=light['direction'], warns=[str(w) for w in warns])
    """
        ),
    )
    r = check(proc, res)[0]
    assert len(r["keys"]) >= 2, r
    assert not [w for w in r["warns"] if "Sun" in w], r["warns"]
    assert np.allclose(r["keys"][0], r["want"][0], atol=1e-4) and np.allclose(r["keys"][-1], r["want"][1], atol=1e-4), r
    assert not np.allclose(r["keys"][0], r["keys"][-1], atol=0.1)
