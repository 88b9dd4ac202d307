"""Cameras against Cycles CPU in one bpy process (docs/camera.md): depth of field (f-stop,
focus distance or object, blades, rotation, aperture ratio; perspective, orthographic and
panoramic), every panoramic projection with its ranges, lens shift, sensor fit and pixel
aspect. Mean CIEDE2000 on 2×2 pixel blocks; emission-only scenes, so the only noise is the
lens and pixel sampling. Each group also renders a deliberately wrong Polychrome image to
show the comparison sees what it checks."""

import json
import textwrap

import pytest

from .bhelper import check, run_bpy

pytestmark = pytest.mark.blender

COMMON = """
import polychrome.colordiff as cd
def emission(name, rgb, strength=1.0):
    m = bpy.data.materials.new(name); m.use_nodes = True; nt = m.node_tree
    for n in list(nt.nodes):
        if n.type != 'OUTPUT_MATERIAL': nt.nodes.remove(n)
    e = nt.nodes.new('ShaderNodeEmission'); e.inputs['Color'].default_value = (*rgb, 1); e.inputs['Strength'].default_value = strength
    nt.links.new(e.outputs[0], nt.nodes['Material Output'].inputs['Surface'])
    return m
def setup_engines(sc, spp):
    sc.render.image_settings.file_format = 'OPEN_EXR'
    c = sc.cycles; c.device = 'CPU'; c.use_denoising = False; c.use_adaptive_sampling = False
    c.pixel_filter_type = 'BOX'; c.filter_width = 1.0   # Polychrome's pixel filter: a 1-pixel box
    c.samples = spp; c.max_bounces = 0
    sc.polychrome.samples = spp; sc.polychrome.max_bounces = 0
def render(sc, engine, name):
    sc.render.engine = engine; sc.render.filepath = os.path.abspath(name + '.exr')
    bpy.ops.render.render(write_still=True)
    return exr_rgb(name + '.exr')
def compare(a, b, white=1.0):
    return float(cd.image_delta_e(block_means(a), block_means(b), white_luminance=white).mean())
"""


def script(body):
    """COMMON followed by ``body`` (both at column 0 for run_bpy)."""
    return COMMON + textwrap.dedent(body)


def test_depth_of_field_matches_cycles(tmp_path):
    """A checkerboard of two emissive colours receding from the camera with emissive
    spheres at 1.9 m, 4 m (the focus object) and 8 m: perspective at f/0.1 and f/0.3
    (focus object, focus distance), orthographic at f/4, a 2:1 pixel aspect with shift and
    vertical sensor fit, and an equirectangular panorama with a lens (Cycles' sphere of
    focus). The pinhole control must differ clearly (ΔE00 > 3)."""
    proc, res = run_bpy(
        tmp_path,
        script(
            """
    from mathutils import Vector
    sc = empty_scene(48, 36); sc.world = None
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=19, y_subdivisions=19, size=12)
    me = bpy.context.object.data
    me.materials.append(emission('Yellow', (0.9, 0.8, 0.2))); me.materials.append(emission('Blue', (0.1, 0.2, 0.6)))
    for p in me.polygons:
        p.material_index = (int(math.floor(p.center.x * 1.5 + 100)) + int(math.floor(p.center.y * 1.5 + 100))) % 2
    for i, (loc, col) in enumerate([((-0.6, -2.2, 0.3), (1, 0.1, 0.1)), ((0.5, 0.0, 0.3), (0.1, 1, 0.2)), ((1.5, 4.0, 0.5), (0.2, 0.4, 1))]):
        bpy.ops.mesh.primitive_uv_sphere_add(radius=0.25, location=loc, segments=32, ring_count=16)
        bpy.context.object.data.materials.append(emission(f'S{i}', col))
    co = add_camera(sc, (0.0, -4.0, 1.0), (0, 0, 0.3)); cam = co.data
    target = bpy.data.objects.new('Target', None); sc.collection.objects.link(target); target.location = (0.5, 0.0, 0.3)
    setup_engines(sc, 128)
    cases = {
        'f/0.1 focus object': dict(fstop=0.1, obj=True),
        'f/0.3 focus distance': dict(fstop=0.3, dist=4.06),
        'orthographic f/4': dict(fstop=4.0, obj=True, type='ORTHO'),
        'pixel aspect 2:1, shift, vertical fit': dict(fstop=0.2, obj=True, aspect=(2, 1), shift=(0.1, -0.05), fit='VERTICAL'),
        'equirectangular f/0.1': dict(fstop=0.1, obj=True, type='PANO', size=(64, 32)),
    }
    out = {}
    for name, k in cases.items():
        cam.type = k.get('type', 'PERSP'); cam.panorama_type = 'EQUIRECTANGULAR'; cam.ortho_scale = 6.0
        cam.dof.use_dof = True; cam.dof.aperture_fstop = k['fstop']
        cam.dof.focus_object = target if k.get('obj') else None; cam.dof.focus_distance = k.get('dist', 10.0)
        cam.shift_x, cam.shift_y = k.get('shift', (0, 0)); cam.sensor_fit = k.get('fit', 'AUTO')
        sc.render.pixel_aspect_x, sc.render.pixel_aspect_y = k.get('aspect', (1, 1))
        sc.render.resolution_x, sc.render.resolution_y = k.get('size', (48, 36))
        a = render(sc, 'CYCLES', 'c'); b = render(sc, 'POLYCHROME', 'p')
        out[name] = dict(de=compare(a, b), err=Engine.last_error, warn=Engine.last_warnings)
        if name == 'f/0.1 focus object':
            cam.dof.use_dof = False
            out['control: pinhole vs f/0.1'] = dict(de=compare(a, render(sc, 'POLYCHROME', 'p0')), err=None, warn=[])
    emit(**out)
    """
        ),
        timeout=400,
    )
    r = check(proc, res)[0]
    print("depth of field vs Cycles (mean ΔE00, 2×2 blocks):", {k: round(v["de"], 2) for k, v in r.items()})
    control = r.pop("control: pinhole vs f/0.1")
    assert control["de"] > 3.0, control
    for name, v in r.items():
        assert v["err"] is None and v["warn"] == [], (name, v)
        assert v["de"] <= 1.5, (name, v)


def test_bokeh_shape_follows_blades_rotation_and_ratio(tmp_path):
    """A small bright emitter 1 m away, focus at 20 m, f/0.1 with 5 blades rotated 0.4 rad
    and aperture ratio 1.6: its out-of-focus image is the squeezed pentagon of the
    aperture. Matching Cycles needs the polygon, its rotation and the squeeze; rotating the
    blades by half a corner (control) must be seen."""
    proc, res = run_bpy(
        tmp_path,
        script(
            """
    sc = empty_scene(32, 32); sc.world = None
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.04, location=(0.05, 0.03, -1.0), segments=16, ring_count=8)
    bpy.context.object.data.materials.append(emission('E', (1.0, 0.6, 0.3), 50.0))
    cd_ = bpy.data.cameras.new('Cam'); co = bpy.data.objects.new('Cam', cd_); sc.collection.objects.link(co); sc.camera = co
    d = cd_.dof; d.use_dof = True; d.focus_distance = 20.0; d.aperture_fstop = 0.1
    d.aperture_blades = 5; d.aperture_rotation = 0.4; d.aperture_ratio = 1.6
    setup_engines(sc, 1024)
    a = render(sc, 'CYCLES', 'c')
    white = float(block_means(a)[..., 1].max())
    same = compare(a, render(sc, 'POLYCHROME', 'p'), white); err, warn = Engine.last_error, Engine.last_warnings
    d.aperture_rotation = 0.4 + math.pi / 5
    rotated = compare(a, render(sc, 'POLYCHROME', 'q'), white)
    d.aperture_rotation = 0.4; d.aperture_ratio = 1.0
    round_ = compare(a, render(sc, 'POLYCHROME', 'r'), white)
    emit(same=same, rotated=rotated, unsqueezed=round_, err=err, warn=warn)
    """
        ),
        timeout=300,
    )
    r = check(proc, res)[0]
    print("bokeh vs Cycles (mean ΔE00, 2×2 blocks):", r)
    assert r["err"] is None and r["warn"] == []
    assert r["same"] <= 1.5, r
    assert r["rotated"] > 2.0 and r["unsqueezed"] > 2.0, r


PANORAMAS = [
    ("equirectangular", (48, 24), {"panorama_type": "EQUIRECTANGULAR"}, (1, 1)),
    (
        "equirectangular, ranges and shift",
        (48, 24),
        {
            "panorama_type": "EQUIRECTANGULAR",
            "latitude_min": -0.5,
            "latitude_max": 1.0,
            "longitude_min": -1.5,
            "longitude_max": 2.0,
            "shift_x": 0.1,
            "shift_y": -0.05,
        },
        (1, 1),
    ),
    ("fisheye equidistant", (32, 32), {"panorama_type": "FISHEYE_EQUIDISTANT"}, (1, 1)),
    (
        "fisheye equidistant 200°, shift, 4:3",
        (40, 30),
        {"panorama_type": "FISHEYE_EQUIDISTANT", "fisheye_fov": 3.5, "shift_x": 0.05},
        (1, 1),
    ),
    ("fisheye equisolid", (40, 32), {"panorama_type": "FISHEYE_EQUISOLID"}, (1, 1)),
    (
        "fisheye equisolid, 2:1 pixels, vertical fit",
        (40, 32),
        {"panorama_type": "FISHEYE_EQUISOLID", "sensor_fit": "VERTICAL", "fisheye_lens": 8.0, "fisheye_fov": 2.8},
        (2, 1),
    ),
    ("mirror ball, shift", (32, 32), {"panorama_type": "MIRRORBALL", "shift_y": 0.1}, (1, 1)),
    ("fisheye lens polynomial, 1:2 pixels", (40, 32), {"panorama_type": "FISHEYE_LENS_POLYNOMIAL", "fisheye_polynomial_k1": -0.05}, (1, 2)),
    ("equiangular cubemap face", (32, 32), {"panorama_type": "EQUIANGULAR_CUBEMAP_FACE"}, (1, 1)),
    (
        "central cylindrical",
        (48, 24),
        {
            "panorama_type": "CENTRAL_CYLINDRICAL",
            "central_cylindrical_range_u_min": -1.0,
            "central_cylindrical_range_u_max": 2.5,
            "central_cylindrical_radius": 2.0,
        },
        (1, 1),
    ),
]


def test_panoramic_cameras_match_cycles(tmp_path):
    """Every Blender panorama type, from a tilted and turned camera, seeing an
    equirectangular environment whose colour encodes the direction (red/green: longitude,
    blue: latitude, dark lines every 30°). A horizontally mirrored equirectangular image
    (control) must differ clearly."""
    proc, res = run_bpy(
        tmp_path,
        script(
            f"""
    PANORAMAS = json.loads({json.dumps(json.dumps(PANORAMAS))!s})
    sc = empty_scene(48, 24)
    W, H = 128, 64
    lon = (np.arange(W) + 0.5) / W * 2 * np.pi - np.pi
    lat = (np.arange(H) + 0.5) / H * np.pi - np.pi / 2      # row 0 = bottom
    L, T = np.meshgrid(lon, lat)
    img = np.ones((H, W, 4), np.float32)
    img[..., 0] = 0.5 + 0.4 * np.cos(L); img[..., 1] = 0.5 + 0.4 * np.sin(L); img[..., 2] = 0.5 + 0.4 * np.sin(T)
    grid = (np.abs(((np.degrees(L) + 15) % 30) - 15) < 2) | (np.abs(((np.degrees(T) + 15) % 30) - 15) < 2)
    img[grid, :3] *= 0.3
    im = bpy.data.images.new('env', W, H, float_buffer=True); im.pixels.foreach_set(img.ravel())
    w = bpy.data.worlds.new('W'); w.use_nodes = True; sc.world = w
    env = w.node_tree.nodes.new('ShaderNodeTexEnvironment'); env.image = im
    w.node_tree.links.new(env.outputs['Color'], w.node_tree.nodes['Background'].inputs['Color'])
    cam_data = bpy.data.cameras.new('Cam'); co = bpy.data.objects.new('Cam', cam_data); sc.collection.objects.link(co); sc.camera = co
    co.location = (0.3, -0.2, 0.1); co.rotation_euler = (math.radians(80), math.radians(5), math.radians(30))
    setup_engines(sc, 64)
    out = {{}}
    defaults = {{k: getattr(cam_data, k) for case in PANORAMAS for k in case[2]}}
    for name, size, props, aspect in PANORAMAS:
        cam_data.type = 'PANO'
        for k, v in defaults.items(): setattr(cam_data, k, v)
        for k, v in props.items(): setattr(cam_data, k, v)
        sc.render.resolution_x, sc.render.resolution_y = size
        sc.render.pixel_aspect_x, sc.render.pixel_aspect_y = aspect
        a = render(sc, 'CYCLES', 'c'); b = render(sc, 'POLYCHROME', 'p')
        out[name] = dict(de=compare(a, b), err=Engine.last_error, warn=Engine.last_warnings)
        if name == 'equirectangular':
            out['control: mirrored'] = dict(de=compare(a, b[:, ::-1]), err=None, warn=[])
    emit(**out)
    """
        ),
        timeout=400,
    )
    r = check(proc, res)[0]
    print("panoramas vs Cycles (mean ΔE00, 2×2 blocks):", {k: round(v["de"], 2) for k, v in r.items()})
    control = r.pop("control: mirrored")
    assert control["de"] > 5.0, control
    for name, v in r.items():
        assert v["err"] is None and v["warn"] == [], (name, v)
        assert v["de"] <= 1.5, (name, v)


def test_unsupported_camera_and_scene_features_warn(tmp_path):
    """An OSL (custom) camera and motion blur each give one warning naming the object and
    the feature."""
    proc, res = run_bpy(
        tmp_path,
        """
    from polychrome_blender.export import export_scene
    import polychrome as pc
    sc = empty_scene(8, 8)
    co = add_camera(sc, (0, -5, 0)); co.data.type = 'CUSTOM'
    sc.render.use_motion_blur = True
    dg = bpy.context.evaluated_depsgraph_get()
    scene, warnings = export_scene(dg)
    emit(warnings=warnings, projection=scene.camera.projection)
    """,
    )
    r = check(proc, res)[0]
    w = r["warnings"]
    assert r["projection"] == "PERSPECTIVE"
    assert any("camera 'Camera'" in m and "CUSTOM" in m for m in w), w
    assert any("motion blur" in m for m in w), w
