"""Image Texture and Environment Texture export, against closed forms: a large diffuse
plane under a uniform white world (radiance 1) has radiance equal to its albedo; a camera
looking into a constant HDRI sees colour × strength."""

import numpy as np
import pytest

from .bhelper import check, run_bpy

pytestmark = pytest.mark.blender


def srgb_to_linear(v):
    v = np.asarray(v, dtype=np.float64)
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def test_image_texture_and_hdri_world(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        """
    import polychrome as pc
    if not hasattr(pc, 'Texture'):
        emit(skip='polychrome has no Texture'); raise SystemExit(0)
    sc = empty_scene(32, 16)
    sc.render.engine = 'POLYCHROME'; sc.polychrome.samples = 64
    # 8-bit sRGB image (large enough that bilinear filtering only blends the middle columns): left half (0.8, 0.3, 0.2), right half (0.1, 0.4, 0.9), sRGB-encoded
    img = bpy.data.images.new('Halves', 64, 64)
    px = np.zeros((64, 64, 4), np.float32); px[..., 3] = 1
    px[:, :32, :3] = (0.8, 0.3, 0.2); px[:, 32:, :3] = (0.1, 0.4, 0.9)
    img.pixels.foreach_set(px.ravel())
    bpy.ops.mesh.primitive_plane_add(size=20)
    plane = bpy.context.object
    m = diffuse_material('Tex', (1, 1, 1)); nt = m.node_tree
    tex = nt.nodes.new('ShaderNodeTexImage'); tex.image = img; tex.interpolation = 'Closest'
    nt.links.new(tex.outputs['Color'], nt.nodes['Diffuse BSDF'].inputs['Color'])
    plane.data.materials.append(m)
    cd = bpy.data.cameras.new('C'); cd.type = 'ORTHO'; cd.ortho_scale = 4.0
    cam = bpy.data.objects.new('C', cd); sc.collection.objects.link(cam); sc.camera = cam
    cam.location = (0, 0, 5)
    world = bpy.data.worlds.new('W'); world.use_nodes = True; sc.world = world
    bg = world.node_tree.nodes['Background']
    bg.inputs['Color'].default_value = (1, 1, 1, 1); bg.inputs['Strength'].default_value = 1.0
    sc.render.image_settings.file_format = 'OPEN_EXR'
    sc.render.filepath = os.path.abspath('tex.exr'); bpy.ops.render.render(write_still=True)
    e1, w1 = Engine.last_error, Engine.last_warnings
    ch = exr_channels('tex.exr')
    rgb = np.stack([ch['R'], ch['G'], ch['B']], -1)
    left = rgb[:, 2:12].reshape(-1, 3).mean(0).tolist(); right = rgb[:, 20:30].reshape(-1, 3).mean(0).tolist()
    # constant float HDRI, strength 2, seen straight up
    hdr = bpy.data.images.new('Sky', 16, 8, float_buffer=True)
    hp = np.zeros((8, 16, 4), np.float32); hp[..., :3] = (0.2, 0.4, 0.8); hp[..., 3] = 1
    hdr.pixels.foreach_set(hp.ravel())
    env = world.node_tree.nodes.new('ShaderNodeTexEnvironment'); env.image = hdr
    world.node_tree.links.new(env.outputs['Color'], bg.inputs['Color']); bg.inputs['Strength'].default_value = 2.0
    cam.rotation_euler = (math.pi, 0, 0)
    sc.render.filepath = os.path.abspath('sky.exr'); bpy.ops.render.render(write_still=True)
    ch = exr_channels('sky.exr')
    sky = [float(ch[c].mean()) for c in 'RGB']
    emit(e1=e1, w1=w1, left=left, right=right, e2=Engine.last_error, w2=Engine.last_warnings, sky=sky)
    """,
    )
    r = check(proc, res)[0]
    if "skip" in r:
        pytest.skip(r["skip"])
    assert r["e1"] is None and r["w1"] == [], r
    assert r["e2"] is None and r["w2"] == [], r
    # the uplift reproduces reflectance RGB under a D65-white world to within a few per cent
    for got, want in ((r["left"], srgb_to_linear([0.8, 0.3, 0.2])), (r["right"], srgb_to_linear([0.1, 0.4, 0.9]))):
        assert np.allclose(got, want, rtol=0.03, atol=0.005), (got, want.tolist())
    assert np.allclose(r["sky"], [0.4, 0.8, 1.6], rtol=0.03), r["sky"]


def test_graph_pixels_replace_non_finite_values(tmp_path):
    """A float image's NaN and ±inf pixels read 0 in the graph texture (export/textures.py
    `finite`); finite pixels and 8-bit images are passed through unchanged."""
    proc, res = run_bpy(
        tmp_path,
        """
    from polychrome_blender.export.textures import graph_rgba, finite
    from polychrome_blender.export.warnings import Warnings
    img = bpy.data.images.new('F', 4, 1, float_buffer=True)
    px = np.array([[0.5, 2.0, 0.25, 1.0], [np.nan, 1.0, 0.0, 1.0], [np.inf, -np.inf, 3.0, 0.5], [0.1, 0.2, 0.3, 0.4]], np.float32)
    img.pixels.foreach_set(px.ravel())
    got, enc = graph_rgba(img, 'material M', Warnings())
    b = bpy.data.images.new('B', 2, 1)
    b.pixels.foreach_set(np.array([0.2, 0.4, 0.6, 1.0, 1.0, 0.0, 0.5, 0.5], np.float32))
    gb, encb = graph_rgba(b, 'material M', Warnings())
    same = np.arange(6, dtype=np.float32)
    emit(got=got.reshape(-1, 4).tolist(), enc=enc, gb=gb.reshape(-1, 4).tolist(), encb=encb, same=finite(same) is same)
    """,
    )
    r = check(proc, res)[0]
    assert r["enc"] == "linear" and r["encb"] == "srgb", r
    assert np.allclose(r["got"], [[0.5, 2.0, 0.25, 1.0], [0.0, 1.0, 0.0, 1.0], [0.0, 0.0, 3.0, 0.5], [0.1, 0.2, 0.3, 0.4]]), r
    assert np.array_equal(r["gb"], [[51, 102, 153, 255], [255, 0, 128, 128]]), r
    assert r["same"] is True


def test_image_without_pixels_reads_magenta_as_in_cycles(tmp_path):
    """An Image Texture whose file is missing, or with no image at all (what Blender's USD
    importer leaves for a missing file: usd-wg's AlphaBlendModeTest and ShaderBall with a
    texture absent), made the render fail ("node 'Image Texture': has no 'texture'").
    Cycles reads both as magenta (1, 0, 1) with alpha 1: a large plane under a white world
    (radiance 1) with the node on a Diffuse BSDF's colour has radiance (1, 0, 1) in Cycles
    and in Polychrome, and on a Principled Base Color the two agree; one warning names the
    material and the image without pixels (none for the empty node: Cycles gives none, and
    test_node_graph's probe of every node has them empty)."""
    proc, res = run_bpy(
        tmp_path,
        """
    sc = empty_scene(16, 16)
    sc.world = bpy.data.worlds.new('W'); sc.world.use_nodes = True
    sc.world.node_tree.nodes['Background'].inputs['Color'].default_value = (1, 1, 1, 1)
    add_camera(sc, (0, 0, 3))
    bpy.ops.mesh.primitive_plane_add(size=20)
    plane = bpy.context.object
    gone = bpy.data.images.new('gone', 4, 4); gone.source = 'FILE'; gone.filepath = '/nonexistent/gone.png'; gone.reload()
    for kind in ('diffuse', 'principled', 'diffuse-no-image'):
        img = None if kind.endswith('no-image') else gone
        m = bpy.data.materials.new(kind); m.use_nodes = True; nt = m.node_tree
        tex = nt.nodes.new('ShaderNodeTexImage'); tex.image = img
        if kind.startswith('diffuse'):
            d = nt.nodes.new('ShaderNodeBsdfDiffuse'); nt.links.new(tex.outputs['Color'], d.inputs['Color'])
            nt.links.new(d.outputs['BSDF'], nt.nodes['Material Output'].inputs['Surface'])
        else:
            nt.links.new(tex.outputs['Color'], nt.nodes['Principled BSDF'].inputs['Base Color'])
        plane.data.materials.clear(); plane.data.materials.append(m)
        ref, test = cycles_and_polychrome(sc, 16, 4)
        emit(kind=kind, size=list(gone.size), ref=ref.reshape(-1, 3).mean(0).tolist(), test=test.reshape(-1, 3).mean(0).tolist(),
             err=Engine.last_error, warn=Engine.last_warnings)
    """,
    )
    diffuse, principled, empty = check(proc, res, 3)
    assert diffuse["size"] == [0, 0], diffuse  # the image really has no pixels
    for r in (diffuse, principled, empty):
        assert r["err"] is None, r
        np.testing.assert_allclose(r["test"], r["ref"], atol=0.01)
    for r in (diffuse, principled):
        assert len(r["warn"]) == 1 and f"material '{r['kind']}'" in r["warn"][0] and "'gone'" in r["warn"][0], r
    assert empty["warn"] == [], empty
    for r in (diffuse, empty):
        np.testing.assert_allclose(r["ref"], [1.0, 0.0, 1.0], atol=1e-3)


def test_environment_texture_without_pixels_is_a_magenta_world_as_in_cycles(tmp_path):
    """The world's Environment Texture with no image, or with an image whose file is
    missing: Cycles' sky is its missing-image magenta (1, 0, 1) × the Background strength
    (EnvironmentTextureNode::compile); Polychrome's was the Background's default colour.
    The camera sees only the sky; one warning names the world and the image without pixels."""
    proc, res = run_bpy(
        tmp_path,
        """
    sc = empty_scene(8, 8)
    add_camera(sc, (0, 0, 3))
    gone = bpy.data.images.new('gone', 4, 4); gone.source = 'FILE'; gone.filepath = '/nonexistent/sky.exr'; gone.reload()
    for kind in ('missing-file', 'no-image'):
        w = bpy.data.worlds.new(kind); w.use_nodes = True; sc.world = w
        bg = w.node_tree.nodes['Background']; bg.inputs['Color'].default_value = (0.2, 0.3, 0.4, 1); bg.inputs['Strength'].default_value = 0.5
        env = w.node_tree.nodes.new('ShaderNodeTexEnvironment'); env.image = gone if kind == 'missing-file' else None
        w.node_tree.links.new(env.outputs['Color'], bg.inputs['Color'])
        ref, test = cycles_and_polychrome(sc, 8, 4)
        emit(kind=kind, ref=ref.reshape(-1, 3).mean(0).tolist(), test=test.reshape(-1, 3).mean(0).tolist(),
             err=Engine.last_error, warn=Engine.last_warnings)
    """,
    )
    missing, empty = check(proc, res, 2)
    for r in (missing, empty):
        assert r["err"] is None, r
        np.testing.assert_allclose(r["ref"], [0.5, 0.0, 0.5], atol=1e-3)
        np.testing.assert_allclose(r["test"], r["ref"], atol=0.01)
    assert len(missing["warn"]) == 1 and "world 'missing-file'" in missing["warn"][0] and "'gone'" in missing["warn"][0], missing
    assert empty["warn"] == [], empty


def test_cubic_interpolation_matches_cycles_per_pixel(tmp_path):
    """Image Texture Cubic (and Smart, which Cycles' CPU kernel filters the same way) on a
    6 × 6 float image of random texels magnified over a plane by an orthographic camera,
    into an Emission shader: every pixel is the filtered texture, compared per pixel with
    Cycles (Repeat and Clip; max error ≤ 1.5e-2, pixel-jitter averaging of a smooth
    filter). Control: Linear in Polychrome against Cubic in Cycles is far off."""
    proc, res = run_bpy(
        tmp_path,
        """
    W = 48
    sc = empty_scene(W, W)
    sc.world = None
    cd = bpy.data.cameras.new('C'); cd.type = 'ORTHO'; cd.ortho_scale = 2.0
    cam = bpy.data.objects.new('C', cd); sc.collection.objects.link(cam); sc.camera = cam; cam.location = (0, 0, 3)
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    plane = bpy.context.object
    rng = np.random.default_rng(4)
    img = bpy.data.images.new('Dots', 6, 6, float_buffer=True)
    px = np.ones((6, 6, 4), np.float32); px[..., :3] = rng.uniform(0.0, 1.0, (6, 6, 3))
    img.pixels.foreach_set(px.ravel())
    m = bpy.data.materials.new('E'); m.use_nodes = True; nt = m.node_tree
    for n in list(nt.nodes):
        if n.type != 'OUTPUT_MATERIAL':
            nt.nodes.remove(n)
    tex = nt.nodes.new('ShaderNodeTexImage'); tex.image = img
    em = nt.nodes.new('ShaderNodeEmission')
    nt.links.new(tex.outputs['Color'], em.inputs['Color']); nt.links.new(em.outputs['Emission'], nt.nodes['Material Output'].inputs['Surface'])
    plane.data.materials.append(m)
    for interp, ext in [('Cubic', 'REPEAT'), ('Smart', 'CLIP')]:
        tex.interpolation = interp; tex.extension = ext
        ref, test = cycles_and_polychrome(sc, 16, 1)
        warn = list(Engine.last_warnings)
        tex.interpolation = 'Linear'
        sc.render.filepath = os.path.abspath('lin.exr'); bpy.ops.render.render(write_still=True)
        lin = exr_rgb('lin.exr')
        emit(interp=interp, err=float(np.abs(ref - test).max()), control=float(np.abs(ref - lin).max()), warn=warn)
    """,
    )
    for r in check(proc, res, 2):
        print(r)
        assert r["warn"] == [], r
        assert r["err"] <= 1.5e-2, r
        assert r["control"] > 5 * r["err"], r
