"""UsdPreviewSurface networks through the shading graph (issue 15 item 9): UsdUVTexture
(scale, bias, wrapS/wrapT, fallback, sourceColorSpace, outputs), UsdTransform2d and
UsdPrimvarReader on every input, opacityThreshold cut-outs and displayColor primvars.

References are independent of the reader: the expected pixels of an emissive plane are
the texture sampled by a numpy bilinear filter written here from the UsdPreviewSurface
specification (transform order scale → rotate → translate, OpenGL-style wrap modes,
sRGB decoding of IEC 61966-2-1), a cut-out is compared with geometry that has the cut
part removed, a roughness map's halves with Python-API Principled materials of the two
constant roughnesses, and displayColor under a uniform white dome with its albedo.
"""

import math
import warnings

import numpy as np
import pytest

pxr = pytest.importorskip("pxr")
from pxr import Gf, Sdf, UsdGeom, UsdLux, UsdShade, Vt  # noqa: E402

import polychrome as pc  # noqa: E402
from polychrome import usd  # noqa: E402
from polychrome.imageio import write_exr  # noqa: E402
from conftest import luminance  # noqa: E402


# ------------------------------------------------------------------------------ stage helpers


def new_stage(path):
    stage = pxr.Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, "Z")
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    return stage


def quad(stage, path, x0=-1.0, x1=1.0, y0=-1.0, y1=1.0, z=0.0, material=None, st_name="st", st=None):
    """A quad polygon with `st_name` = ((x-x0)/(x1-x0), (y-y0)/(y1-y0)) per vertex."""
    pts = np.array([[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]], np.float32)
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(pts))
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32) if st is None else np.asarray(st, np.float32)
    pv = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar(st_name, Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex)
    pv.Set(Vt.Vec2fArray.FromNumpy(uv))
    if material is not None:
        UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)
    return mesh


def top_camera(stage, width=2.0, height=3.0):
    cam = UsdGeom.Camera.Define(stage, "/cam")
    cam.CreateProjectionAttr("orthographic")
    cam.CreateHorizontalApertureAttr(width * 10.0)
    cam.CreateVerticalApertureAttr(width * 10.0)
    cam.CreateClippingRangeAttr(Gf.Vec2f(0.01, 100.0))
    cam.AddTranslateOp().Set(Gf.Vec3d(0, 0, height))
    return cam


def surface(stage, path, **constants):
    mat = UsdShade.Material.Define(stage, path)
    sh = UsdShade.Shader.Define(stage, path + "/Surface")
    sh.CreateIdAttr("UsdPreviewSurface")
    for k, v in constants.items():
        ty = Sdf.ValueTypeNames.Color3f if isinstance(v, tuple) else Sdf.ValueTypeNames.Float
        sh.CreateInput(k, ty).Set(Gf.Vec3f(*v) if isinstance(v, tuple) else v)
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
    return mat, sh


def uv_texture(stage, path, file, st=None, **inputs):
    tex = UsdShade.Shader.Define(stage, path)
    tex.CreateIdAttr("UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(str(file))
    types = {"scale": Sdf.ValueTypeNames.Float4, "bias": Sdf.ValueTypeNames.Float4, "fallback": Sdf.ValueTypeNames.Float4}
    for k, v in inputs.items():
        if k in types:
            tex.CreateInput(k, types[k]).Set(Gf.Vec4f(*v))
        else:
            tex.CreateInput(k, Sdf.ValueTypeNames.Token).Set(v)
    if st is not None:
        tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(st)
    return tex


def primvar_reader(stage, path, varname):
    r = UsdShade.Shader.Define(stage, path)
    r.CreateIdAttr("UsdPrimvarReader_float2")
    r.CreateInput("varname", Sdf.ValueTypeNames.Token).Set(varname)
    return r.CreateOutput("result", Sdf.ValueTypeNames.Float2)


def transform2d(stage, path, source, rotation, scale, translation):
    t = UsdShade.Shader.Define(stage, path)
    t.CreateIdAttr("UsdTransform2d")
    t.CreateInput("in", Sdf.ValueTypeNames.Float2).ConnectToSource(source)
    t.CreateInput("rotation", Sdf.ValueTypeNames.Float).Set(rotation)
    t.CreateInput("scale", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(*scale))
    t.CreateInput("translation", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(*translation))
    return t.CreateOutput("result", Sdf.ValueTypeNames.Float2)


def connect(shader, name, tex, output, ty=Sdf.ValueTypeNames.Color3f):
    out_ty = Sdf.ValueTypeNames.Float3 if output == "rgb" else Sdf.ValueTypeNames.Float
    shader.CreateInput(name, ty).ConnectToSource(tex.ConnectableAPI(), output, UsdShade.AttributeType.Output, out_ty)


def read(path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = usd.read_stage(path)
    return scene, [str(w.message) for w in caught]


# ---------------------------------------------------------------------------------- reference


def srgb_decode(x):
    x = np.asarray(x, np.float64)
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)


def wrap_index(i, n, mode):
    """Texel index under a UsdUVTexture wrap mode (OpenGL REPEAT, MIRRORED_REPEAT,
    CLAMP_TO_EDGE, CLAMP_TO_BORDER with black); -1 marks a black border texel."""
    if mode == "repeat":
        return np.mod(i, n)
    if mode == "mirror":
        m = np.mod(i, 2 * n)
        return np.where(m < n, m, 2 * n - 1 - m)
    if mode == "clamp":
        return np.clip(i, 0, n - 1)
    return np.where((i < 0) | (i >= n), -1, i)


def bilinear(texels, u, v, wrap_s, wrap_t):
    """texels (H, W, C), row 0 = the top of the image (v = 1); st (0, 0) is its lower left."""
    h, w, c = texels.shape
    x = u * w - 0.5
    y = (1.0 - v) * h - 0.5
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]
    padded = np.concatenate([texels, np.zeros((h, 1, c))], axis=1)
    padded = np.concatenate([padded, np.zeros((1, w + 1, c))], axis=0)

    def at(ix, iy):
        ix, iy = wrap_index(ix, w, wrap_s), wrap_index(iy, h, wrap_t)
        black = (ix < 0) | (iy < 0)
        return padded[np.where(black, h, iy), np.where(black, w, ix)]

    return at(x0, y0) * (1 - fx) * (1 - fy) + at(x0 + 1, y0) * fx * (1 - fy) + at(x0, y0 + 1) * (1 - fx) * fy + at(x0 + 1, y0 + 1) * fx * fy


def transform_st(u, v, rotation_deg, scale, translation):
    """UsdTransform2d: scale, then rotate counter-clockwise, then translate."""
    su, sv = u * scale[0], v * scale[1]
    a = math.radians(rotation_deg)
    return (su * math.cos(a) - sv * math.sin(a) + translation[0], su * math.sin(a) + sv * math.cos(a) + translation[1])


def footprint_mean(fn, n, width=2.0, samples=8):
    """Mean of fn(x, y) (arrays → (..., 3)) over each pixel of an n×n ortho view `width` wide."""
    s = (np.arange(samples) + 0.5) / samples
    px = (np.arange(n)[:, None] + s[None, :]).ravel() / n * width - width / 2
    py = width / 2 - (np.arange(n)[:, None] + s[None, :]).ravel() / n * width
    x, y = np.meshgrid(px, py)
    vals = fn(x, y)
    return vals.reshape(n, samples, n, samples, -1).mean(axis=(1, 3))


# ------------------------------------------------------------------------------------- tests


TEXELS = np.array(
    [
        [[0.9, 0.2, 0.1], [0.2, 0.8, 0.3], [0.1, 0.3, 0.9], [0.7, 0.7, 0.2]],
        [[0.3, 0.6, 0.6], [0.8, 0.4, 0.7], [0.5, 0.5, 0.5], [0.2, 0.1, 0.4]],
        [[0.6, 0.9, 0.2], [0.1, 0.1, 0.1], [0.9, 0.6, 0.3], [0.4, 0.8, 0.9]],
    ],
    np.float64,
)


def emissive_stage(tmp_path, file, *, wrap_s, wrap_t, colour_space=None, output="rgb", scale=(1, 1, 1, 1), bias=(0, 0, 0, 0)):
    path = tmp_path / f"emissive_{wrap_s}_{wrap_t}.usda"
    stage = new_stage(path)
    mat, sh = surface(stage, "/Looks/m", diffuseColor=(0.0, 0.0, 0.0))
    st = primvar_reader(stage, "/Looks/m/st", "uvset")
    st = transform2d(stage, "/Looks/m/xf", st, 30.0, (1.5, 0.75), (0.25, -0.1))
    extra = {} if colour_space is None else {"sourceColorSpace": colour_space}
    tex = uv_texture(stage, "/Looks/m/tex", file, st=st, wrapS=wrap_s, wrapT=wrap_t, scale=scale, bias=bias, **extra)
    connect(sh, "emissiveColor", tex, output)
    # "st" is a decoy: the network reads the UV set "uvset".
    m = quad(stage, "/plane", material=mat, st_name="uvset")
    UsdGeom.PrimvarsAPI(m).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex).Set(
        Vt.Vec2fArray.FromNumpy(np.zeros((4, 2), np.float32))
    )
    top_camera(stage)
    stage.Save()
    return path


def expected_emission(texels, wrap_s, wrap_t, n, scale=(1, 1, 1), bias=(0, 0, 0)):
    def fn(x, y):
        u, v = transform_st((x + 1) / 2, (y + 1) / 2, 30.0, (1.5, 0.75), (0.25, -0.1))
        return bilinear(texels, u, v, wrap_s, wrap_t) * np.asarray(scale) + np.asarray(bias)

    return footprint_mean(fn, n)


N = 12


def render_rgb(scene, samples=16):
    r = pc.render(scene, width=N, height=N, samples=samples, max_bounces=1, seed=2)
    assert r.stats["nonfinite_samples"] == 0
    return r.rgba[..., :3].astype(np.float64)


@pytest.mark.parametrize("wrap_s, wrap_t", [("repeat", "repeat"), ("mirror", "mirror"), ("mirror", "repeat"), ("clamp", "black")])
def test_emissive_texture_through_transform2d_and_named_uv_set_equals_the_spec(tmp_path, wrap_s, wrap_t):
    """Pixels of an unlit emissive plane = the texture sampled at R·(S·st) + T with the
    wrap modes, × scale + bias (numpy bilinear reference)."""
    file = tmp_path / "tex.exr"
    write_exr(file, np.concatenate([TEXELS, np.ones((3, 4, 1))], axis=2).astype(np.float32))
    scale, bias = (1.2, 0.8, 1.5, 1.0), (0.05, 0.1, 0.0, 0.0)
    path = emissive_stage(tmp_path, file, wrap_s=wrap_s, wrap_t=wrap_t, scale=scale, bias=bias)
    scene, warns = read(path)
    assert not warns, warns
    got = render_rgb(scene)
    want = expected_emission(TEXELS, wrap_s, wrap_t, N, scale[:3], bias[:3])
    err = np.abs(got - want)
    assert np.median(err / np.maximum(want, 0.05)) < 0.02, np.median(err)
    assert err.max() < 0.08, (err.max(), np.unravel_index(err.argmax(), err.shape))


def test_srgb_png_and_raw_single_channel_outputs(tmp_path):
    """An 8-bit RGB PNG under `auto` is sRGB; a grey (1-channel) PNG under `auto` is raw;
    `raw` on an RGB PNG keeps the bytes / 255; the `g` output is the green channel."""
    from PIL import Image

    rgb8 = np.rint(TEXELS * 255).astype(np.uint8)
    Image.fromarray(rgb8, "RGB").save(tmp_path / "rgb.png")
    Image.fromarray(rgb8[..., 1], "L").save(tmp_path / "grey.png")
    cases = [
        ("rgb.png", None, "rgb", srgb_decode(rgb8 / 255.0)),
        ("rgb.png", "raw", "rgb", rgb8 / 255.0),
        ("grey.png", None, "rgb", np.repeat(rgb8[..., 1:2] / 255.0, 3, axis=2)),
        ("rgb.png", "sRGB", "g", np.repeat(srgb_decode(rgb8[..., 1:2] / 255.0), 3, axis=2)),
    ]
    for k, (name, cs, output, texels) in enumerate(cases):
        sub = tmp_path / str(k)
        sub.mkdir()
        path = emissive_stage(sub, tmp_path / name, wrap_s="repeat", wrap_t="repeat", colour_space=cs, output=output)
        scene, warns = read(path)
        assert not warns, (name, warns)
        got = render_rgb(scene, samples=32)
        want = expected_emission(texels, "repeat", "repeat", N)
        err = np.abs(got - want)
        assert np.median(err / np.maximum(want, 0.05)) < 0.025, (name, cs, np.median(err))


def lit_plane_stage(path, constants, mapped_input, file, scale):
    """A plane under a sphere light seen at a glancing angle, `mapped_input` read from the
    `r` channel of `file` × `scale`."""
    stage = new_stage(path)
    mat, sh = surface(stage, "/Looks/m", diffuseColor=(0.9, 0.6, 0.3), **constants)
    tex = uv_texture(stage, "/Looks/m/tex", file, wrapS="clamp", wrapT="clamp", scale=(scale, scale, scale, 1.0))
    connect(sh, mapped_input, tex, "r", Sdf.ValueTypeNames.Float)
    quad(stage, "/plane", -2, 2, -2, 2, material=mat)
    cam = UsdGeom.Camera.Define(stage, "/cam")
    cam.CreateFocalLengthAttr(3.5)
    cam.CreateHorizontalApertureAttr(3.6)
    cam.CreateVerticalApertureAttr(3.6)
    cam.AddTranslateOp().Set(Gf.Vec3d(0, -3, 1.2))
    cam.AddRotateXOp().Set(70.0)
    lamp = UsdLux.SphereLight.Define(stage, "/lamp")
    lamp.CreateRadiusAttr(0.3)
    lamp.CreateIntensityAttr(30.0)
    lamp.AddTranslateOp().Set(Gf.Vec3d(0, 2.5, 1.5))
    stage.Save()


MAPS = {
    # USD input: (constant inputs, the two mapped values, texture scale, Principled kwargs)
    "roughness": ({"metallic": 1.0}, (0.15, 0.8), 1.0, lambda v: {"metallic": 1.0, "roughness": v}),
    "metallic": ({"roughness": 0.3}, (0.0, 1.0), 1.0, lambda v: {"metallic": v, "roughness": 0.3}),
    "clearcoat": (
        {"roughness": 0.9, "clearcoatRoughness": 0.05},
        (0.0, 1.0),
        1.0,
        lambda v: {"roughness": 0.9, "coat_weight": v, "coat_roughness": 0.05},
    ),
    "ior": ({"roughness": 0.2}, (1.2, 2.2), 2.5, lambda v: {"roughness": 0.2, "ior": v}),
}


@pytest.mark.parametrize("mapped_input", sorted(MAPS))
def test_input_map_halves_match_constant_principled(tmp_path, mapped_input):
    """A raw grey PNG (two values, × the texture's scale) on one input: each half of the
    image equals the render of a Python-API Principled with that constant value."""
    from PIL import Image

    constants, values, scale, kwargs = MAPS[mapped_input]
    img = np.zeros((4, 16), np.uint8)
    img[:, :8], img[:, 8:] = (round(v / scale * 255) for v in values)
    Image.fromarray(img, "L").save(tmp_path / "map.png")
    lit_plane_stage(tmp_path / "mapped.usda", constants, mapped_input, tmp_path / "map.png", scale)
    scene, warns = read(tmp_path / "mapped.usda")
    assert not warns, warns
    assert isinstance(scene.materials[0], pc.NodeMaterial)
    n = 20

    def render(s):
        return luminance(pc.render(s, width=n, height=n, samples=48, max_bounces=2, seed=5).rgba[..., :3])

    mapped = render(scene)
    refs = []
    for byte in (img[0, 0], img[0, 15]):
        ref_scene = usd.read_stage(tmp_path / "mapped.usda")
        ref_scene.materials[0] = pc.Principled(pc.spectra.rgb(0.9, 0.6, 0.3), **kwargs(byte / 255.0 * scale))
        refs.append(render(ref_scene))
    # The texture's seam is x = 0 on the plane (image column n/2); compare away from it.
    left, right = slice(0, n // 2 - 3), slice(n // 2 + 3, n)
    for half, ref in ((left, refs[0]), (right, refs[1])):
        a, b = mapped[:, half].mean(), ref[:, half].mean()
        assert abs(a - b) < 0.03 * b + 1e-3, (a, b)
    # ... and the two constant values differ clearly there.
    a, b = refs[0][:, left].mean(), refs[1][:, left].mean()
    assert abs(a - b) > 0.1 * max(a, b), (a, b)


def test_opacity_threshold_cuts_out_like_geometry(tmp_path):
    """A black plane whose texture alpha is 0.2 on the left half and 1 on the right,
    opacityThreshold 0.5, over an emissive floor: the same image as a plane that is only
    the right half."""
    from PIL import Image

    rgba = np.zeros((4, 8, 4), np.uint8)
    rgba[..., 3] = 255
    rgba[:, :4, 3] = 51
    Image.fromarray(rgba, "RGBA").save(tmp_path / "cut.png")

    def stage_with(plane):
        path = tmp_path / f"{plane}.usda"
        stage = new_stage(path)
        floor, _ = surface(stage, "/Looks/floor", diffuseColor=(0.0, 0.0, 0.0), emissiveColor=(0.8, 0.7, 0.6))
        quad(stage, "/floor", -3, 3, -3, 3, -1.0, material=floor)
        if plane == "cut":
            mat, sh = surface(stage, "/Looks/m", diffuseColor=(0.0, 0.0, 0.0), opacityThreshold=0.5)
            tex = uv_texture(stage, "/Looks/m/tex", tmp_path / "cut.png", wrapS="clamp", wrapT="clamp")
            connect(sh, "opacity", tex, "a", Sdf.ValueTypeNames.Float)
            quad(stage, "/plane", material=mat)
        else:
            mat, _ = surface(stage, "/Looks/m", diffuseColor=(0.0, 0.0, 0.0))
            quad(stage, "/plane", 0.0, 1.0, material=mat)
        top_camera(stage)
        stage.Save()
        scene, warns = read(path)
        assert not warns, warns
        return render_rgb(scene, samples=8)

    cut, geometry = stage_with("cut"), stage_with("half")
    assert geometry[:, : N // 2 - 1].mean() > 0.5 and geometry[:, N // 2 + 1 :].max() < 0.05
    keep = np.r_[0 : N // 2 - 1, N // 2 + 1 : N]  # the seam's two pixel columns are filtered
    assert np.abs(cut[:, keep] - geometry[:, keep]).max() < 0.02


def test_missing_texture_on_any_input_warns_once_and_uses_its_fallback(tmp_path):
    path = tmp_path / "missing.usda"
    stage = new_stage(path)
    mat, sh = surface(stage, "/Looks/m", diffuseColor=(0.0, 0.0, 0.0))
    tex = uv_texture(stage, "/Looks/m/tex", "./gone.exr", fallback=(0.3, 0.2, 0.1, 1.0))
    connect(sh, "emissiveColor", tex, "rgb")
    rough = uv_texture(stage, "/Looks/m/rough", "./gone.exr", fallback=(0.25, 0.0, 0.0, 1.0))
    connect(sh, "roughness", rough, "r", Sdf.ValueTypeNames.Float)
    quad(stage, "/plane", material=mat)
    top_camera(stage)
    stage.Save()
    scene, warns = read(path)
    missing = [w for w in warns if "gone.exr" in w]
    assert len(missing) == 2 and all("does not exist" in w for w in missing), warns
    assert any("/Looks/m/tex" in w for w in missing) and any("/Looks/m/rough" in w for w in missing)
    got = render_rgb(scene, samples=4)
    assert np.allclose(got.mean(axis=(0, 1)), [0.3, 0.2, 0.1], rtol=0.03, atol=0.005)


def test_display_color_per_face_and_per_vertex_under_a_white_dome(tmp_path):
    """Unbound meshes with displayColor uniform (per face) and vertex: a Lambertian plane
    under a uniform white dome of radiance 1 shows its albedo, interpolated."""
    path = tmp_path / "display.usda"
    stage = new_stage(path)
    # Two quads side by side: per-face colours.
    mesh = UsdGeom.Mesh.Define(stage, "/faces")
    pts = np.array([[-1, -1, 0], [0, -1, 0], [0, 1, 0], [-1, 1, 0], [1, -1, 0], [1, 1, 0]], np.float32)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(pts))
    mesh.CreateFaceVertexCountsAttr([4, 4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3, 1, 4, 5, 2])
    faces = [(0.7, 0.2, 0.1), (0.1, 0.3, 0.6)]
    mesh.CreateDisplayColorPrimvar(UsdGeom.Tokens.uniform).Set(faces)
    dome = UsdLux.DomeLight.Define(stage, "/dome")
    dome.CreateIntensityAttr(1.0)
    top_camera(stage)
    stage.Save()
    scene, warns = read(path)
    assert not warns, warns
    got = render_rgb(scene, samples=64)
    left, right = got[:, : N // 2 - 1].reshape(-1, 3).mean(axis=0), got[:, N // 2 + 1 :].reshape(-1, 3).mean(axis=0)
    assert np.allclose(left, faces[0], rtol=0.04, atol=0.01), left
    assert np.allclose(right, faces[1], rtol=0.04, atol=0.01), right

    # Per vertex, varying along x only: barycentric = linear in x on both triangles.
    mesh.GetDisplayColorPrimvar().SetInterpolation(UsdGeom.Tokens.vertex)
    colours = np.array([[0.1, 0.1, 0.1], [0.5, 0.4, 0.3], [0.5, 0.4, 0.3], [0.1, 0.1, 0.1], [0.9, 0.7, 0.5], [0.9, 0.7, 0.5]])
    mesh.GetDisplayColorPrimvar().Set(Vt.Vec3fArray.FromNumpy(colours.astype(np.float32)))
    stage.Save()
    scene, warns = read(path)
    assert not warns, warns
    got = render_rgb(scene, samples=64)
    want = footprint_mean(lambda x, y: 0.1 + (x[..., None] + 1) / 2 * (np.array([0.9, 0.7, 0.5]) - 0.1), N)
    # Column means (12 pixels each) against the linear ramp: noise ~0.01 at 64 samples.
    err = np.abs(got.mean(axis=0) - want.mean(axis=0))
    assert err.max() < 0.03, err.max()


def test_display_opacity_per_face_and_constant_is_coverage(tmp_path):
    """An unbound black mesh over an emissive floor: displayOpacity 0 on the left face and
    1 on the right shows the floor on the left only; a constant 0.4 lets 60 % through."""
    path = tmp_path / "opacity.usda"
    stage = new_stage(path)
    floor, _ = surface(stage, "/Looks/floor", diffuseColor=(0.0, 0.0, 0.0), emissiveColor=(0.8, 0.7, 0.6))
    quad(stage, "/floor", -3, 3, -3, 3, -1.0, material=floor)
    mesh = UsdGeom.Mesh.Define(stage, "/faces")
    pts = np.array([[-1, -1, 0], [0, -1, 0], [0, 1, 0], [-1, 1, 0], [1, -1, 0], [1, 1, 0]], np.float32)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(pts))
    mesh.CreateFaceVertexCountsAttr([4, 4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3, 1, 4, 5, 2])
    mesh.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant).Set([(0.0, 0.0, 0.0)])
    mesh.CreateDisplayOpacityPrimvar(UsdGeom.Tokens.uniform).Set([0.0, 1.0])
    top_camera(stage)
    stage.Save()
    scene, warns = read(path)
    assert not warns, warns
    got = render_rgb(scene, samples=16)
    floor_rgb = np.array([0.8, 0.7, 0.6])
    assert np.allclose(got[:, : N // 2 - 1].reshape(-1, 3).mean(axis=0), floor_rgb, rtol=0.03)
    assert got[:, N // 2 + 1 :].max() < 0.02

    mesh.GetDisplayOpacityPrimvar().SetInterpolation(UsdGeom.Tokens.constant)
    mesh.GetDisplayOpacityPrimvar().Set([0.4])
    stage.Save()
    scene, warns = read(path)
    assert not warns, warns
    got = render_rgb(scene, samples=64)
    assert np.allclose(got.reshape(-1, 3).mean(axis=0), 0.6 * floor_rgb, rtol=0.04), got.reshape(-1, 3).mean(axis=0)


def test_network_in_a_node_graph_driven_by_material_interface_inputs(tmp_path):
    """A UsdUVTexture inside a NodeGraph whose `file` and wraps are connected to the
    material's interface inputs, its output reaching emissiveColor through the graph's
    output: read as if authored on the texture."""
    file = tmp_path / "tex.exr"
    write_exr(file, np.concatenate([TEXELS, np.ones((3, 4, 1))], axis=2).astype(np.float32))
    path = tmp_path / "iface.usda"
    stage = new_stage(path)
    mat, sh = surface(stage, "/Looks/m", diffuseColor=(0.0, 0.0, 0.0))
    graph = UsdShade.NodeGraph.Define(stage, "/Looks/m/graph")
    tex = UsdShade.Shader.Define(stage, "/Looks/m/graph/tex")
    tex.CreateIdAttr("UsdUVTexture")
    file_in = mat.CreateInput("texfile", Sdf.ValueTypeNames.Asset)
    file_in.Set(str(file))
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).ConnectToSource(file_in)
    wrap_in = mat.CreateInput("wrap", Sdf.ValueTypeNames.Token)
    wrap_in.Set("mirror")
    for w in ("wrapS", "wrapT"):
        tex.CreateInput(w, Sdf.ValueTypeNames.Token).ConnectToSource(wrap_in)
    out = graph.CreateOutput("color", Sdf.ValueTypeNames.Float3)
    out.ConnectToSource(tex.CreateOutput("rgb", Sdf.ValueTypeNames.Float3))
    sh.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(out)
    quad(stage, "/plane", material=mat)
    top_camera(stage)
    stage.Save()
    scene, warns = read(path)
    assert not warns, warns
    got = render_rgb(scene)
    want = footprint_mean(lambda x, y: bilinear(TEXELS, (x + 1) / 2, (y + 1) / 2, "mirror", "mirror"), N)
    assert np.median(np.abs(got - want) / np.maximum(want, 0.05)) < 0.02


def test_missing_uv_set_reads_the_primvar_readers_fallback_with_one_warning(tmp_path):
    """A mesh without the UV set a UsdPrimvarReader_float2 reads gets the reader's
    `fallback` (here (0.6, 0.3): the whole plane shows the texture at
    Transform2d(0.6, 0.3)); one warning naming the mesh, the primvar and the reader."""
    file = tmp_path / "tex.exr"
    write_exr(file, np.concatenate([TEXELS, np.ones((3, 4, 1))], axis=2).astype(np.float32))
    path = emissive_stage(tmp_path, file, wrap_s="repeat", wrap_t="repeat")
    stage = pxr.Usd.Stage.Open(str(path))
    UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/plane")).RemovePrimvar("uvset")
    reader = UsdShade.Shader(stage.GetPrimAtPath("/Looks/m/st"))
    reader.CreateInput("fallback", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(0.6, 0.3))
    stage.Save()
    scene, warns = read(path)
    assert len(warns) == 1 and "/plane" in warns[0] and "'uvset'" in warns[0] and "/Looks/m/st" in warns[0], warns
    got = render_rgb(scene)
    u, v = transform_st(np.array([0.6]), np.array([0.3]), 30.0, (1.5, 0.75), (0.25, -0.1))
    want = bilinear(TEXELS, u, v, "repeat", "repeat")[0]
    assert np.allclose(got, want, rtol=0.02, atol=0.005), (got.reshape(-1, 3).mean(axis=0), want)


def test_transform2d_parameters_connected_to_interface_inputs_and_primvar_readers(tmp_path):
    """UsdTransform2d's rotation through a material interface input (30°), its scale from
    a UsdPrimvarReader_float2 of a constant primvar ((1.5, 0.75)) and its translation from
    one of a per-vertex primvar varying over the plane ((0.25, −0.1) + (0.1 u, 0.05 v)):
    the pixels are the spec's transform evaluated with those values at every point."""
    file = tmp_path / "tex.exr"
    write_exr(file, np.concatenate([TEXELS, np.ones((3, 4, 1))], axis=2).astype(np.float32))
    path = emissive_stage(tmp_path, file, wrap_s="mirror", wrap_t="repeat")
    stage = pxr.Usd.Stage.Open(str(path))
    mat = UsdShade.Material(stage.GetPrimAtPath("/Looks/m"))
    xf = UsdShade.Shader(stage.GetPrimAtPath("/Looks/m/xf"))
    angle = mat.CreateInput("angle", Sdf.ValueTypeNames.Float)
    angle.Set(30.0)
    xf.GetInput("rotation").GetAttr().Clear()
    xf.GetInput("rotation").ConnectToSource(angle)
    for name, varname in (("scale", "xfscale"), ("translation", "xfshift")):
        xf.GetInput(name).GetAttr().Clear()
        xf.GetInput(name).ConnectToSource(primvar_reader(stage, f"/Looks/m/{varname}", varname))
    api = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/plane"))
    api.CreatePrimvar("xfscale", Sdf.ValueTypeNames.Float2Array, UsdGeom.Tokens.constant).Set([Gf.Vec2f(1.5, 0.75)])
    corners = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32)
    shift = np.array([0.25, -0.1], np.float32) + corners * np.array([0.1, 0.05], np.float32)
    api.CreatePrimvar("xfshift", Sdf.ValueTypeNames.Float2Array, UsdGeom.Tokens.vertex).Set(Vt.Vec2fArray.FromNumpy(shift))
    stage.Save()
    scene, warns = read(path)
    assert not warns, warns
    got = render_rgb(scene)

    def fn(x, y):
        u, v = (x + 1) / 2, (y + 1) / 2
        su, sv = transform_st(u, v, 30.0, (1.5, 0.75), (0.25 + 0.1 * u, -0.1 + 0.05 * v))
        return bilinear(TEXELS, su, sv, "mirror", "repeat")

    want = footprint_mean(fn, N)
    err = np.abs(got - want)
    assert np.median(err / np.maximum(want, 0.05)) < 0.02, np.median(err)


@pytest.mark.parametrize("uv_set", ["st", "second"])
def test_normal_map_tilts_the_normal_in_the_tangent_frame_of_its_uv_set(tmp_path, uv_set):
    """A `normal` fed by a UsdUVTexture (raw, scale 2, bias -1) is a tangent-space Normal
    Map (Color ½·n + ½) on the Principled Normal and Coat Normal. A constant map
    n = (0.6, 0, 0.8) on a plane whose `uv_set` has s growing along world +Y (t along
    −X) tilts the normal to (0, 0.6, 0.8): a sun shining along −(0, 0.6, 0.8) onto this
    pure diffuse (specular workflow, black specularColor) of albedo ρ gives ρ E / π,
    and 0.64 of that if the tangent came from another UV set. Through "st" the core
    derives the tangents; through "second" (with "st" a decoy along +X) the reader does."""
    file = tmp_path / "n.png"
    from PIL import Image

    Image.fromarray(np.tile(np.array([204, 128, 230], np.uint8), (4, 4, 1))).save(file)  # (0.6, 0.004, 0.8)·½ + ½
    path = tmp_path / "nm.usda"
    stage = new_stage(path)
    rho, irradiance = 0.5, 3.0
    mat, sh = surface(stage, "/Looks/m", diffuseColor=(rho, rho, rho), specularColor=(0.0, 0.0, 0.0))
    sh.CreateInput("useSpecularWorkflow", Sdf.ValueTypeNames.Int).Set(1)
    st = primvar_reader(stage, "/Looks/m/uv", uv_set)
    tex = uv_texture(stage, "/Looks/m/tex", file, st=st, scale=(2, 2, 2, 1), bias=(-1, -1, -1, 0), sourceColorSpace="raw")
    connect(sh, "normal", tex, "rgb", Sdf.ValueTypeNames.Normal3f)
    rotated = np.array([[0, 1], [0, 0], [1, 0], [1, 1]], np.float32)  # s = (y+1)/2, t = (1-x)/2
    mesh = quad(stage, "/plane", material=mat, st_name=uv_set, st=rotated)
    if uv_set != "st":
        pv = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex)
        pv.Set(Vt.Vec2fArray.FromNumpy(np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32)))
    sun = UsdLux.DistantLight.Define(stage, "/sun")
    sun.CreateIntensityAttr(irradiance)
    sun.CreateNormalizeAttr(True)
    sun.CreateAngleAttr(0.5)
    sun.AddRotateXOp().Set(-math.degrees(math.atan2(0.6, 0.8)))  # its −Z onto −(0, 0.6, 0.8)
    top_camera(stage, width=1.0)
    stage.Save()
    scene, warns = read(path)
    assert not warns, warns
    (m,) = [m for m in scene.materials if isinstance(m, pc.NodeMaterial)]
    nodes = m.nodes
    (nm,) = [n for n in nodes if n["type"] == "ShaderNodeNormalMap"]
    assert nm["props"] == {"space": "TANGENT", "uv_map": uv_set}
    (principled,) = [n for n in nodes if n["type"] == "ShaderNodeBsdfPrincipled"]
    assert principled["inputs"]["Normal"] == {"link": [nodes.index(nm), "Normal"]} == principled["inputs"]["Coat Normal"]
    got = luminance(render_rgb(scene, samples=16)).mean()
    n = np.array([204, 128, 230]) / 255 * 2 - 1
    n_world = np.array([-n[1], n[0], n[2]]) / np.linalg.norm(n)  # T = +Y, B = −X (s, t above)
    want = rho * irradiance / math.pi * float(n_world @ np.array([0.0, 0.6, 0.8]))
    assert got == pytest.approx(want, rel=0.02), (got, want)


def test_usdz_package_textures_are_read_from_inside_the_package(tmp_path):
    """The vendored TextureTransformTest packaged by UsdUtils.CreateNewUsdzPackage: its
    textures resolve to `pkg.usdz[0/….png]` and are read out of the package (through Ar),
    no warning; every texture's texels equal the PNG decoded by Pillow straight from the
    zip archive (sRGB colour decoded per IEC 61966-2-1, alpha linear), and the package
    renders as the loose stage does."""
    import zipfile
    from pathlib import Path

    from PIL import Image
    from pxr import UsdUtils

    src = Path(__file__).parent / "data" / "usd" / "TextureTransformTest" / "TextureTransformTest.usd"
    pkg = tmp_path / "TextureTransformTest.usdz"
    assert UsdUtils.CreateNewUsdzPackage(Sdf.AssetPath(str(src)), str(pkg))
    scene, warns = read(pkg)
    assert len(warns) == 1 and "no UsdGeom.Camera" in warns[0], warns  # the asset has none
    with zipfile.ZipFile(pkg) as z:
        pngs = {
            Path(n).name: np.asarray(Image.open(z.open(n)).convert("RGBA"), np.float64) / 255 for n in z.namelist() if n.endswith(".png")
        }
    assert len(pngs) == 5
    textures = [
        n["props"]["texture"]
        for m in scene.materials
        if isinstance(m, pc.NodeMaterial)
        for n in m.nodes
        if n["type"] == "ShaderNodeTexImage"
    ]
    checked = set()
    for t in textures:
        want = pngs[t.name]
        want = np.concatenate([srgb_decode(want[..., :3]), want[..., 3:]], axis=2)[..., : t.pixels.shape[2]]  # opaque: RGB kept
        if t.pixels.shape != want.shape:  # prepared for mixed wrap modes (padded / mirrored)
            continue
        assert np.allclose(t.pixels, want, atol=1e-6), t.name
        checked.add(t.name)
    assert len(checked) >= 4, checked
    loose, _ = read(src)
    a = pc.render(scene, width=34, height=23, samples=2, seed=3).rgba
    b = pc.render(loose, width=34, height=23, samples=2, seed=3).rgba
    assert np.array_equal(a, b)
