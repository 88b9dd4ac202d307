"""MaterialX networks in USD (issue 15 item 12): Standard Surface, OpenPBR and glTF PBR
surface shaders and MaterialX pattern nodes through the shading graph
(python/polychrome/usd/materialx.py).

Blender 4.5's USD importer does not read MaterialX shaders (a stage whose material is an
ND_standard_surface_surfaceshader, bound for the universal or the "mtlx" render context,
imports as a material without nodes; checked with bpy 4.5), so the references are closed
forms: an unlit emissive plane whose pixels equal the texture sampled by a numpy bilinear
filter written from MaterialX's node definitions (NG_tiledimage, mix, multiply, extract,
combine3), a Lambertian plane under a sun (ρ E cos θ / π), Fresnel at normal incidence of
smooth metals, coats and dielectrics under a white dome, and a tangent-space normal map
tilting the normal towards a sun. Stages are built here with pxr.
"""

import math

import numpy as np
import pytest

pxr = pytest.importorskip("pxr")
from pxr import Gf, Sdf, UsdLux, UsdShade  # noqa: E402

import polychrome as pc  # noqa: E402
from polychrome.imageio import write_exr  # noqa: E402
from conftest import luminance  # noqa: E402
from test_usd_preview import TEXELS, bilinear, footprint_mean, new_stage, quad, read, top_camera  # noqa: E402

T = Sdf.ValueTypeNames
N = 12


def mx_material(stage, path, surface_id, context="mtlx", **inputs):
    """A Material whose surface (for `context`, "" = universal) is a MaterialX shader."""
    mat = UsdShade.Material.Define(stage, path)
    sh = UsdShade.Shader.Define(stage, path + "/surface")
    sh.CreateIdAttr(surface_id)
    for k, v in inputs.items():
        set_input(sh, k, v)
    out = sh.CreateOutput("out", T.Token)
    mat.CreateSurfaceOutput(context).ConnectToSource(out)
    return mat, sh


def set_input(sh, name, v):
    if isinstance(v, UsdShade.Output):
        ty = {1: T.Float, 2: T.Float2}.get(getattr(v, "_width", 3), T.Color3f)
        sh.CreateInput(name, ty).ConnectToSource(v)
    elif isinstance(v, tuple):
        ty = {2: T.Float2, 3: T.Color3f}[len(v)]
        sh.CreateInput(name, ty).Set(Gf.Vec2f(*v) if len(v) == 2 else Gf.Vec3f(*v))
    elif isinstance(v, str):
        sh.CreateInput(name, T.String).Set(v)
    elif isinstance(v, bool):
        sh.CreateInput(name, T.Bool).Set(v)
    elif isinstance(v, int):
        sh.CreateInput(name, T.Int).Set(v)
    else:
        sh.CreateInput(name, T.Float).Set(float(v))


def node(stage, path, sid, out_type=T.Color3f, **inputs):
    """A MaterialX pattern node; returns its `out` output."""
    sh = UsdShade.Shader.Define(stage, path)
    sh.CreateIdAttr(sid)
    for k, v in inputs.items():
        set_input(sh, k, v)
    return sh.CreateOutput("out", out_type)


def image(stage, path, file, sid="ND_image_color3", colour_space="raw", texcoord=None, **inputs):
    sh = UsdShade.Shader.Define(stage, path)
    sh.CreateIdAttr(sid)
    f = sh.CreateInput("file", T.Asset)
    f.Set(Sdf.AssetPath(str(file)))
    if colour_space is not None:
        f.GetAttr().SetColorSpace(colour_space)
    if texcoord is not None:
        sh.CreateInput("texcoord", T.Float2).ConnectToSource(texcoord)
    for k, v in inputs.items():
        set_input(sh, k, v)
    return sh.CreateOutput("out", T.Vector3f if "vector3" in sid else T.Color3f)


def texcoord(stage, path):
    return node(stage, path, "ND_texcoord_vector2", T.Float2)


def render_rgb(scene, samples=16, n=N):
    r = pc.render(scene, width=n, height=n, samples=samples, max_bounces=1, seed=2)
    assert r.stats["nonfinite_samples"] == 0
    return r.rgba[..., :3].astype(np.float64)


def exr_texture(tmp_path):
    file = tmp_path / "tex.exr"
    write_exr(file, np.concatenate([TEXELS, np.ones((3, 4, 1))], axis=2).astype(np.float32))
    return file


def mirror_clamp(u, v, texels):
    """NG_tiledimage with uaddressmode mirror, vaddressmode clamp: (st·tiling − offset)."""
    return bilinear(texels, u, v, "mirror", "clamp")


# ---------------------------------------------------------------------------------- emission


TEXELS4 = np.array(
    [
        [[0.9, 0.2, 0.1], [0.2, 0.8, 0.3], [0.1, 0.3, 0.9], [0.7, 0.7, 0.2]],
        [[0.3, 0.6, 0.6], [0.8, 0.4, 0.7], [0.5, 0.5, 0.5], [0.2, 0.1, 0.4]],
        [[0.6, 0.9, 0.2], [0.1, 0.1, 0.1], [0.9, 0.6, 0.3], [0.4, 0.8, 0.9]],
        [[0.05, 0.05, 0.6], [1.0, 1.0, 1.0], [0.3, 0.02, 0.02], [0.6, 0.3, 0.8]],
    ],
    np.float64,
)


@pytest.mark.parametrize(
    "surface",
    ["ND_open_pbr_surface_surfaceshader", "ND_standard_surface_surfaceshader", "ND_UsdPreviewSurface_surfaceshader", "houdini"],
)
def test_emission_through_image_and_texcoord_equals_the_texels(tmp_path, surface):
    """base weight 0, specular 0, emission 1 (OpenPBR: emission_luminance 1 nit = radiance 1;
    MaterialX's UsdPreviewSurface: black diffuseColor, emissiveColor) × an ND_image_color3 (filtertype closest) read at ND_texcoord_vector2 on a plane whose
    4 × 4 texels each cover 2 × 2 pixels of an orthographic view: every pixel of the unlit
    plane is its texel."""
    path = tmp_path / "emit.usda"
    stage = new_stage(path)
    if surface == "houdini":
        # Houdini's layout: a UsdPreviewSurface approximation on the universal surface
        # (here a green emitter) beside the MaterialX network on the mtlx one, which wins.
        surface = "ND_standard_surface_surfaceshader"
        preview = UsdShade.Shader.Define(stage, "/Looks/m/preview")
        preview.CreateIdAttr("UsdPreviewSurface")
        preview.CreateInput("emissiveColor", T.Color3f).Set(Gf.Vec3f(0.0, 1.0, 0.0))
        UsdShade.Material.Define(stage, "/Looks/m").CreateSurfaceOutput().ConnectToSource(preview.CreateOutput("surface", T.Token))
    o = "open_pbr" in surface
    params = {
        "base_weight" if o else "base": 0.0,
        "specular_weight" if o else "specular": 0.0,
        "emission_luminance" if o else "emission": 1.0,
    }
    if "Preview" in surface:  # MaterialX's UsdPreviewSurface: emissiveColor, black diffuse
        params = {"diffuseColor": (0.0, 0.0, 0.0)}
    mat, sh = mx_material(stage, "/Looks/m", surface, **params)
    file = tmp_path / "tex4.exr"
    write_exr(file, np.concatenate([TEXELS4, np.ones((4, 4, 1))], axis=2).astype(np.float32))
    img = image(stage, "/Looks/m/img", file, texcoord=texcoord(stage, "/Looks/m/uv"), filtertype="closest")
    set_input(sh, "emissiveColor" if "Preview" in surface else "emission_color", img)
    quad(stage, "/plane", material=mat)
    top_camera(stage)
    stage.Save()
    scene, warns = read(path)
    assert not warns, warns
    got = render_rgb(scene, samples=64, n=8)
    want = np.repeat(np.repeat(TEXELS4, 2, axis=0), 2, axis=1)  # row 0 of the image is the top (t = 1)
    err = np.abs(got - want)
    assert err.max() < 4e-3, (err.max(), np.median(err))
    assert np.median(err) < 1.5e-3, np.median(err)


def test_pattern_nodes_tiledimage_multiply_mix_extract_combine_dot(tmp_path):
    """Standard Surface emission_color = dot(mix(fg = combine3(b, g, r of a tiled image)·2,
    bg = constant (0.1, 0.2, 0.3), mix 0.75)), the tiled image with uvtiling (1.5, 0.75),
    uvoffset (0.25, −0.1), u mirrored and v clamped — against numpy from MaterialX's
    node definitions."""
    path = tmp_path / "nodes.usda"
    stage = new_stage(path)
    mat, sh = mx_material(stage, "/Looks/m", "ND_standard_surface_surfaceshader", context="", base=0.0, specular=0.0, emission=1.0)
    img = image(
        stage,
        "/Looks/m/img",
        exr_texture(tmp_path),
        sid="ND_tiledimage_color3",
        texcoord=texcoord(stage, "/Looks/m/uv"),
        uvtiling=(1.5, 0.75),
        uvoffset=(0.25, -0.1),
        uaddressmode="mirror",
        vaddressmode="clamp",
    )
    chans = []
    for i in (2, 1, 0):
        e = node(stage, f"/Looks/m/extract{i}", "ND_extract_color3", T.Float, index=i)
        UsdShade.Shader(e.GetPrim()).CreateInput("in", T.Color3f).ConnectToSource(img)
        chans.append(e)
    comb = UsdShade.Shader.Define(stage, "/Looks/m/combine")
    comb.CreateIdAttr("ND_combine3_color3")
    for k, e in enumerate(chans):
        comb.CreateInput(f"in{k + 1}", T.Float).ConnectToSource(e)
    comb_out = comb.CreateOutput("out", T.Color3f)
    mul = UsdShade.Shader.Define(stage, "/Looks/m/mul")
    mul.CreateIdAttr("ND_multiply_color3FA")
    mul.CreateInput("in1", T.Color3f).ConnectToSource(comb_out)
    mul.CreateInput("in2", T.Float).Set(2.0)
    mix = UsdShade.Shader.Define(stage, "/Looks/m/mix")
    mix.CreateIdAttr("ND_mix_color3")
    mix.CreateInput("fg", T.Color3f).ConnectToSource(mul.CreateOutput("out", T.Color3f))
    const = node(stage, "/Looks/m/const", "ND_constant_color3", value=(0.1, 0.2, 0.3))
    mix.CreateInput("bg", T.Color3f).ConnectToSource(const)
    mix.CreateInput("mix", T.Float).Set(0.75)
    dot = UsdShade.Shader.Define(stage, "/Looks/m/dot")
    dot.CreateIdAttr("ND_dot_color3")
    dot.CreateInput("in", T.Color3f).ConnectToSource(mix.CreateOutput("out", T.Color3f))
    sh.CreateInput("emission_color", T.Color3f).ConnectToSource(dot.CreateOutput("out", T.Color3f))
    quad(stage, "/plane", material=mat)
    top_camera(stage)
    stage.Save()
    scene, warns = read(path)
    assert not warns, warns
    got = render_rgb(scene)

    def fn(x, y):
        u, v = (x + 1) / 2 * 1.5 - 0.25, (y + 1) / 2 * 0.75 + 0.1
        t = mirror_clamp(u, v, TEXELS)[..., ::-1] * 2.0
        return 0.75 * t + 0.25 * np.array([0.1, 0.2, 0.3])

    want = footprint_mean(fn, N)
    err = np.abs(got - want)
    assert np.median(err / np.maximum(want, 0.05)) < 0.02, np.median(err)
    assert err.max() < 0.08, err.max()


# ---------------------------------------------------------------------------------- reflection


def sun(stage, irradiance, tilt_deg):
    light = UsdLux.DistantLight.Define(stage, "/sun")
    light.CreateIntensityAttr(irradiance)
    light.CreateNormalizeAttr(True)
    light.CreateAngleAttr(0.5)
    light.AddRotateXOp().Set(-tilt_deg)  # −Z tilted towards +Y
    return light


@pytest.mark.parametrize(
    "surface, params",
    [
        ("ND_standard_surface_surfaceshader", {"base": 0.8, "base_color": (0.5, 0.2, 0.1), "specular": 0.0}),
        ("ND_open_pbr_surface_surfaceshader", {"base_weight": 0.8, "base_color": (0.5, 0.2, 0.1), "specular_weight": 0.0}),
    ],
)
def test_diffuse_plane_under_a_sun_is_rho_e_cos_over_pi(tmp_path, surface, params):
    """base 0.8 × base_color (0.5, 0.2, 0.1), no specular: a Lambertian plane of albedo
    ρ = (0.4, 0.16, 0.08) under a sun of irradiance E = 3 at 40° reflects ρ E cos 40° / π
    per channel (through the RGB → spectrum uplift and back)."""
    path = tmp_path / "sun.usda"
    stage = new_stage(path)
    mat, _ = mx_material(stage, "/Looks/m", surface, **params)
    quad(stage, "/plane", material=mat)
    sun(stage, 3.0, 40.0)
    top_camera(stage, width=1.0)
    stage.Save()
    scene, warns = read(path)
    assert not warns, warns
    got = render_rgb(scene, samples=16).reshape(-1, 3).mean(axis=0)
    want = np.array([0.4, 0.16, 0.08]) * 3.0 * math.cos(math.radians(40.0)) / math.pi
    np.testing.assert_allclose(got, want, rtol=0.02)


def schlick_f0(n):
    return ((n - 1.0) / (n + 1.0)) ** 2


@pytest.mark.parametrize(
    "case, surface, params, want",
    [
        ("metal", "ND_standard_surface_surfaceshader", {"metalness": 1.0, "base_color": (0.9, 0.6, 0.3), "specular_roughness": 0.0}, (0.9, 0.6, 0.3)),
        ("openpbr metal", "ND_open_pbr_surface_surfaceshader", {"base_metalness": 1.0, "base_color": (0.3, 0.6, 0.9), "specular_roughness": 0.0}, (0.3, 0.6, 0.9)),
        ("gltf metal", "ND_gltf_pbr_surfaceshader", {"base_color": (0.7, 0.7, 0.2), "roughness": 0.0}, (0.7, 0.7, 0.2)),
        ("coat", "ND_standard_surface_surfaceshader", {"base_color": (0.0, 0.0, 0.0), "specular": 0.0, "coat": 1.0, "coat_IOR": 2.0, "coat_roughness": 0.0}, (schlick_f0(2.0),) * 3),
        ("dielectric", "ND_open_pbr_surface_surfaceshader", {"base_weight": 0.0, "specular_weight": 0.5, "specular_ior": 1.8, "specular_roughness": 0.0}, (0.5 * schlick_f0(1.8),) * 3),
    ],
)  # fmt: skip
def test_fresnel_at_normal_incidence_under_a_white_dome(tmp_path, case, surface, params, want):
    """A smooth plane seen straight down by an orthographic camera under a dome of radiance 1
    shows F(0): a metal's base colour (Standard Surface, OpenPBR, glTF: Principled's F82
    tint model, F0 = Base Color), a coat of index 2 over black ((n−1)²/(n+1)² = 1/9, the
    base's specular off), OpenPBR specular_weight 0.5 of index 1.8 over black (0.5·F0)."""
    path = tmp_path / "fresnel.usda"
    stage = new_stage(path)
    mat, _ = mx_material(stage, "/Looks/m", surface, **params)
    quad(stage, "/plane", x0=-3, x1=3, y0=-3, y1=3, material=mat)
    UsdLux.DomeLight.Define(stage, "/dome").CreateIntensityAttr(1.0)
    top_camera(stage, width=1.0)
    stage.Save()
    scene, warns = read(path)
    assert not warns, warns
    got = render_rgb(scene, samples=64, n=8).reshape(-1, 3).mean(axis=0)  # the coat picks a lobe per sample: noisy
    np.testing.assert_allclose(got, want, rtol=0.02, atol=2e-3)


def test_normalmap_tilts_the_normal_in_the_tangent_frame(tmp_path):
    """ND_image_vector3 (raw) → ND_normalmap (scale 1) on Standard Surface `normal`: a
    constant map (0.6, 0, 0.8) on a plane whose st has s along world +Y tilts the normal to
    (0, 0.6, 0.8); a sun along −(0, 0.6, 0.8) on the pure diffuse gives ρ E / π. With
    scale 0.5 the tangent part is halved (mx_normalmap): ρ E cos / π with
    n ∝ (0, 0.3, 0.8)."""
    from PIL import Image

    file = tmp_path / "n.png"
    Image.fromarray(np.tile(np.array([204, 128, 230], np.uint8), (4, 4, 1))).save(file)
    c = np.array([204, 128, 230]) / 255 * 2 - 1
    rho, irradiance = 0.5, 3.0
    for scale in (1.0, 0.5):
        path = tmp_path / f"nm{scale}.usda"
        stage = new_stage(path)
        mat, sh = mx_material(stage, "/Looks/m", "ND_standard_surface_surfaceshader", base=1.0, base_color=(rho,) * 3, specular=0.0)
        img = image(stage, "/Looks/m/img", file, sid="ND_image_vector3", texcoord=texcoord(stage, "/Looks/m/uv"))
        nm = UsdShade.Shader.Define(stage, "/Looks/m/nm")
        nm.CreateIdAttr("ND_normalmap")
        nm.CreateInput("in", T.Vector3f).ConnectToSource(img)
        nm.CreateInput("scale", T.Float).Set(scale)
        sh.CreateInput("normal", T.Vector3f).ConnectToSource(nm.CreateOutput("out", T.Vector3f))
        quad(stage, "/plane", material=mat, st=np.array([[0, 1], [0, 0], [1, 0], [1, 1]], np.float32))
        sun(stage, irradiance, math.degrees(math.atan2(0.6, 0.8)))
        top_camera(stage, width=1.0)
        stage.Save()
        scene, warns = read(path)
        assert not warns, warns
        got = luminance(render_rgb(scene)).mean()
        n_world = np.array([-c[1] * scale, c[0] * scale, c[2]])
        n_world /= np.linalg.norm(n_world)
        want = rho * irradiance / math.pi * float(n_world @ np.array([0.0, 0.6, 0.8]))
        assert got == pytest.approx(want, rel=0.02), (scale, got, want)


# ---------------------------------------------------------------------------------- bad input


def test_unsupported_parameters_and_unknown_nodes_warn_once_each(tmp_path):
    """specular_anisotropy and subsurface (rendered as a diffuse of subsurface_color): one
    warning each naming the prim and the parameter (subsurface_color, which acts only
    through subsurface, none); an input that
    is no parameter of the shader: one warning; an unknown node (ND_noise2d_color3) on base_color: one warning naming the
    node and the prim, base_color's default (0.8) is used (checked in the graph); a stage
    referencing a truncated .mtlx document: one warning naming the prim and the file, the
    rest renders."""
    path = tmp_path / "bad.usda"
    stage = new_stage(path)
    mat, sh = mx_material(
        stage, "/Looks/m", "ND_standard_surface_surfaceshader", specular_anisotropy=0.5, subsurface=0.3, subsurface_color=(1.0, 0.5, 0.5)
    )
    set_input(sh, "displacement", 0.1)  # not a standard_surface parameter
    noise = node(stage, "/Looks/m/noise", "ND_noise2d_color3", amplitude=(1.0, 1.0, 1.0))
    set_input(sh, "base_color", noise)
    quad(stage, "/plane", material=mat)
    other = UsdShade.Material.Define(stage, "/Looks/fromfile")
    other.GetPrim().GetReferences().AddReference(str(tmp_path / "looks.mtlx"), "/MaterialX/Materials/m")
    quad(stage, "/plane2", z=-1, material=other)
    top_camera(stage)
    stage.Save()
    (tmp_path / "looks.mtlx").write_text('<?xml version="1.0"?>\n<materialx version="1.38">\n')  # truncated
    scene, warns = read(path)
    mine = [w for w in warns if "/Looks/m" in w]
    assert len([w for w in mine if "specular_anisotropy" in w]) == 1, warns
    assert len([w for w in mine if "'subsurface'" in w]) == 1, warns
    assert len([w for w in mine if "'displacement' is not a parameter" in w]) == 1, warns
    assert not [w for w in mine if "'subsurface_color'" in w], warns  # acts through subsurface, warned once
    assert len([w for w in mine if "ND_noise2d_color3" in w and "/Looks/m/noise" in w]) == 1, warns
    assert len([w for w in warns if "looks.mtlx" in w and "/Looks/fromfile" in w and "cannot read MaterialX document" in w]) == 1, warns
    (m,) = [m for m in scene.materials if isinstance(m, pc.NodeMaterial)]
    (p,) = [n for n in m.nodes if n["type"] == "ShaderNodeBsdfPrincipled"]
    # base_color's default 0.8 (the noise is dropped), blended with subsurface_color by the
    # subsurface weight 0.3 (subsurface rendered as a diffuse of its colour).
    assert p["inputs"]["Base Color"] == pytest.approx([0.7 * 0.8 + 0.3 * c for c in (1.0, 0.5, 0.5)])
    assert render_rgb(scene, samples=1).shape == (N, N, 3)


def cauchy_from_abbe(nd, vd, lam_nm):
    """n(λ) = A + B/λ²: n(d) = nd and n(F) − n(C) = (nd − 1)/Vd with SCHOTT's d, F, C lines."""
    d, f, c = 0.5875618, 0.4861327, 0.6562725
    b = (nd - 1.0) / vd / (1.0 / f**2 - 1.0 / c**2)
    return nd - b / d**2 + b / (np.asarray(lam_nm) / 1000.0) ** 2


@pytest.mark.parametrize(
    "surface, params, vd",
    [
        ("ND_open_pbr_surface_surfaceshader", {"transmission_dispersion_scale": 1.0}, 20.0),
        ("ND_open_pbr_surface_surfaceshader", {"transmission_dispersion_scale": 0.5, "transmission_dispersion_abbe_number": 15.0}, 30.0),
        ("ND_standard_surface_surfaceshader", {"transmission_dispersion": 12.0}, 12.0),
    ],
)
def test_dispersion_is_the_abbe_model_seen_in_the_spectral_fresnel(tmp_path, surface, params, vd):
    """OpenPBR Vd = abbe_number / dispersion_scale, Standard Surface Vd = transmission_dispersion,
    with the specular IOR 1.6 as nd: a smooth dielectric over black seen at normal incidence
    under a white dome, rendered spectrally, reflects F0(n(λ)) = ((n − 1)/(n + 1))² with n the
    two-term Cauchy through nd and nF − nC = (nd − 1)/Vd: its ratio to the same material
    without dispersion is F0(n(λ)) / F0(nd) at every wavelength."""
    o = "open_pbr" in surface
    base = {"base_weight" if o else "base": 0.0, "specular_roughness": 0.0, "specular_ior" if o else "specular_IOR": 1.6}
    grid = [420.0, 480.0, 540.0, 600.0, 660.0]
    images = []
    for extra in (params, {}):
        path = tmp_path / f"disp{len(extra)}.usda"
        stage = new_stage(path)
        mat, _ = mx_material(stage, "/Looks/m", surface, **base, **extra)
        quad(stage, "/plane", x0=-3, x1=3, y0=-3, y1=3, material=mat)
        UsdLux.DomeLight.Define(stage, "/dome").CreateIntensityAttr(1.0)
        top_camera(stage, width=1.0)
        stage.Save()
        scene, warns = read(path)
        assert not warns, warns
        r = pc.render(scene, width=4, height=4, samples=4, max_bounces=1, seed=1, wavelengths=grid, spectral_output=True)
        images.append(r.spectral.reshape(-1, len(grid)).mean(axis=0))
    n = cauchy_from_abbe(1.6, vd, grid)
    want = ((n - 1) / (n + 1)) ** 2 / ((0.6 / 2.6) ** 2)
    np.testing.assert_allclose(images[0] / images[1], want, rtol=1e-5)
    assert want[0] / want[-1] > 1.05  # the effect is well above the tolerance


def place2d_reference(s, t, pivot, scale, rotate, offset, order):
    """NG_place2d_vector2 with mx_rotate_vector2 (ca·x + sa·y, −sa·x + ca·y)."""
    a = math.radians(rotate)

    def rot(x, y):
        return math.cos(a) * x + math.sin(a) * y, -math.sin(a) * x + math.cos(a) * y

    x, y = s - pivot[0], t - pivot[1]
    if order == 0:
        x, y = rot(x / scale[0], y / scale[1])
        x, y = x - offset[0], y - offset[1]
    else:
        x, y = rot(x - offset[0], y - offset[1])
        x, y = x / scale[0], y / scale[1]
    return x + pivot[0], y + pivot[1]


@pytest.mark.parametrize("order", [0, 1])
def test_place2d_geompropvalue_and_clamp(tmp_path, order):
    """emission_color = clamp(image(place2d(geompropvalue "uvset")), 0.2, 0.7) with pivot
    (0.5, 0.5), scale (0.8, 1.25), rotate 30°, offset (0.1, −0.2), SRT and TRS; "st" is a
    decoy. Against numpy from NG_place2d and mx_rotate_vector2."""
    path = tmp_path / "place.usda"
    stage = new_stage(path)
    mat, sh = mx_material(
        stage, "/Looks/m", "ND_open_pbr_surface_surfaceshader", base_weight=0.0, specular_weight=0.0, emission_luminance=1.0
    )
    uv = node(stage, "/Looks/m/uv", "ND_geompropvalue_vector2", T.Float2, geomprop="uvset")
    pl = UsdShade.Shader.Define(stage, "/Looks/m/place")
    pl.CreateIdAttr("ND_place2d_vector2")
    pl.CreateInput("texcoord", T.Float2).ConnectToSource(uv)
    for k, v in {"pivot": (0.5, 0.5), "scale": (0.8, 1.25), "rotate": 30.0, "offset": (0.1, -0.2), "operationorder": order}.items():
        set_input(pl, k, v)
    img = image(stage, "/Looks/m/img", exr_texture(tmp_path), texcoord=pl.CreateOutput("out", T.Float2))
    cl = UsdShade.Shader.Define(stage, "/Looks/m/clamp")
    cl.CreateIdAttr("ND_clamp_color3FA")
    cl.CreateInput("in", T.Color3f).ConnectToSource(img)
    set_input(cl, "low", 0.2)
    set_input(cl, "high", 0.7)
    sh.CreateInput("emission_color", T.Color3f).ConnectToSource(cl.CreateOutput("out", T.Color3f))
    m = quad(stage, "/plane", material=mat, st_name="uvset")
    from pxr import UsdGeom, Vt

    UsdGeom.PrimvarsAPI(m).CreatePrimvar("st", T.TexCoord2fArray, UsdGeom.Tokens.vertex).Set(
        Vt.Vec2fArray.FromNumpy(np.zeros((4, 2), np.float32))
    )
    top_camera(stage)
    stage.Save()
    scene, warns = read(path)
    assert not warns, warns
    got = render_rgb(scene)

    def fn(x, y):
        u, v = place2d_reference((x + 1) / 2, (y + 1) / 2, (0.5, 0.5), (0.8, 1.25), 30.0, (0.1, -0.2), order)
        return np.clip(bilinear(TEXELS, u, v, "repeat", "repeat"), 0.2, 0.7)

    want = footprint_mean(fn, N)
    err = np.abs(got - want)
    assert np.median(err / want) < 0.02, np.median(err / want)
    assert err.max() < 0.08, err.max()


@pytest.mark.parametrize("mode", ["openpbr", "gltf mask", "gltf blend"])
def test_color4_alpha_drives_coverage(tmp_path, mode):
    """An unlit white emitter over a black world whose coverage is a 2 × 1 color4 image's
    alpha (0.3 | 0.8, closest filter): OpenPBR geometry_opacity ← separate4 outa, and glTF
    PBR alpha ← extract index 3 with alpha_mode 1 (mask, cutoff 0.5: 0 | 1) and 2 (blend:
    0.3 | 0.8). The left half of the view shows the left texel."""
    from PIL import Image

    file = tmp_path / "a.png"
    Image.fromarray(np.array([[[255, 255, 255, 77], [255, 255, 255, 204]]], np.uint8), "RGBA").save(file)
    path = tmp_path / "alpha.usda"
    stage = new_stage(path)
    if mode == "openpbr":
        mat, sh = mx_material(
            stage, "/Looks/m", "ND_open_pbr_surface_surfaceshader", base_weight=0.0, specular_weight=0.0, emission_luminance=1.0
        )
    else:
        mat, sh = mx_material(
            stage, "/Looks/m", "ND_gltf_pbr_surfaceshader", base_color=(0.0, 0.0, 0.0), metallic=0.0, specular=0.0, emissive=(1.0, 1.0, 1.0)
        )
        set_input(sh, "alpha_mode", 1 if mode == "gltf mask" else 2)
    img = UsdShade.Shader.Define(stage, "/Looks/m/img")
    img.CreateIdAttr("ND_image_color4")
    img.CreateInput("file", T.Asset).Set(Sdf.AssetPath(str(file)))
    set_input(img, "filtertype", "closest")
    out = img.CreateOutput("out", T.Color4f)
    if mode == "openpbr":
        sep = UsdShade.Shader.Define(stage, "/Looks/m/sep")
        sep.CreateIdAttr("ND_separate4_color4")
        sep.CreateInput("in", T.Color4f).ConnectToSource(out)
        sh.CreateInput("geometry_opacity", T.Float).ConnectToSource(sep.CreateOutput("outa", T.Float))
    else:
        ex = UsdShade.Shader.Define(stage, "/Looks/m/extract")
        ex.CreateIdAttr("ND_extract_color4")
        ex.CreateInput("in", T.Color4f).ConnectToSource(out)
        set_input(ex, "index", 3)
        sh.CreateInput("alpha", T.Float).ConnectToSource(ex.CreateOutput("out", T.Float))
    quad(stage, "/plane", material=mat)
    top_camera(stage)
    stage.Save()
    scene, warns = read(path)
    assert not warns, warns
    got = luminance(render_rgb(scene, samples=256, n=4))
    left, right = (0.0, 1.0) if mode == "gltf mask" else (77 / 255, 204 / 255)
    np.testing.assert_allclose(got[:, :2].mean(), left, atol=0.03)
    np.testing.assert_allclose(got[:, 2:].mean(), right, atol=0.03)


def test_node_graph_with_interface_inputs_swizzle_power_invert_luminance(tmp_path):
    """A NodeGraph (as usdMtlx writes them) whose image reads the file given by the
    Material's interface input, the surface's `emission` driven by another (1.5):
    emission_color = invert(power(swizzle(image, "bgr"), 2)) × luminance(image) (Rec.709
    luma, the working space's) — per texel with the closest filter, exact."""
    path = tmp_path / "ng.usda"
    stage = new_stage(path)
    mat, sh = mx_material(stage, "/Looks/m", "ND_standard_surface_surfaceshader", base=0.0, specular=0.0)
    file = tmp_path / "tex4.exr"
    write_exr(file, np.concatenate([TEXELS4, np.ones((4, 4, 1))], axis=2).astype(np.float32))
    tex_file = mat.CreateInput("tex_file", T.Asset)
    tex_file.Set(Sdf.AssetPath(str(file)))
    glow = mat.CreateInput("glow", T.Float)
    glow.Set(1.5)
    sh.CreateInput("emission", T.Float).ConnectToSource(glow)
    ng = UsdShade.NodeGraph.Define(stage, "/Looks/m/NG")
    img = UsdShade.Shader.Define(stage, "/Looks/m/NG/img")
    img.CreateIdAttr("ND_image_color3")
    img.CreateInput("file", T.Asset).ConnectToSource(tex_file)
    set_input(img, "filtertype", "closest")
    img.CreateInput("texcoord", T.Float2).ConnectToSource(texcoord(stage, "/Looks/m/NG/uv"))
    img_out = img.CreateOutput("out", T.Color3f)

    def shader(name, sid, **inputs):
        s = UsdShade.Shader.Define(stage, f"/Looks/m/NG/{name}")
        s.CreateIdAttr(sid)
        for k, v in inputs.items():
            if isinstance(v, UsdShade.Output):
                s.CreateInput(k, T.Color3f).ConnectToSource(v)
            else:
                set_input(s, k, v)
        return s.CreateOutput("out", T.Color3f)

    sw = shader("swizzle", "ND_swizzle_color3_color3", channels="bgr")
    UsdShade.Shader(sw.GetPrim()).CreateInput("in", T.Color3f).ConnectToSource(img_out)
    pw = shader("power", "ND_power_color3FA", in1=sw, in2=2.0)
    inv = shader("invert", "ND_invert_color3", **{"in": pw})
    lum = shader("luminance", "ND_luminance_color3", **{"in": img_out})
    out = shader("product", "ND_multiply_color3", in1=inv, in2=lum)
    ng_out = ng.CreateOutput("out", T.Color3f)
    ng_out.ConnectToSource(out)
    sh.CreateInput("emission_color", T.Color3f).ConnectToSource(ng_out)
    quad(stage, "/plane", material=mat)
    top_camera(stage)
    stage.Save()
    scene, warns = read(path)
    assert not warns, warns
    got = render_rgb(scene, samples=64, n=8)
    t = np.repeat(np.repeat(TEXELS4, 2, axis=0), 2, axis=1)
    want = 1.5 * (1.0 - t[..., ::-1] ** 2) * (t @ np.array([0.2126, 0.7152, 0.0722]))[..., None]
    np.testing.assert_allclose(got, want, atol=1e-4)


MTLX_DOC = """<?xml version="1.0"?>
<materialx version="1.38" colorspace="lin_rec709" fileprefix="tex/">
  <nodegraph name="NG_glow">
    <input name="file" type="filename" value="glow.png" colorspace="srgb_texture" />
    <texcoord name="uv" type="vector2" />
    <image name="img" type="color3">
      <input name="file" type="filename" interfacename="file" />
      <input name="texcoord" type="vector2" nodename="uv" />
      <input name="filtertype" type="string" value="closest" />
    </image>
    <multiply name="twice" type="color3">
      <input name="in1" type="color3" nodename="img" />
      <input name="in2" type="float" value="2" />
    </multiply>
    <output name="out" type="color3" nodename="twice" />
  </nodegraph>
  <standard_surface name="glow_surface" type="surfaceshader">
    <input name="base" type="float" value="0" />
    <input name="specular" type="float" value="0" />
    <input name="emission" type="float" value="1" />
    <input name="emission_color" type="color3" nodegraph="NG_glow" output="out" />
  </standard_surface>
  <surfacematerial name="glow" type="material">
    <input name="surfaceshader" type="surfaceshader" nodename="glow_surface" />
  </surfacematerial>
</materialx>
"""


def test_referenced_mtlx_document_inside_a_variant(tmp_path):
    """A .mtlx document (nodegraph with an interface filename, fileprefix, colorspace
    srgb_texture, image → multiply_color3FA, a standard_surface and its surfacematerial)
    referenced as usdMtlx lays it out (`doc.mtlx</MaterialX/Materials>`) from the selected
    variant of a variant set — the other variant references a missing document — is read by
    mtlxdoc.py without usdMtlx: the plane bound to its material shows 2 × the sRGB-decoded
    texels, no warning."""
    from PIL import Image

    from test_usd_preview import srgb_decode

    (tmp_path / "tex").mkdir()
    q = np.round(TEXELS4 * 255).astype(np.uint8)
    Image.fromarray(q, "RGB").save(tmp_path / "tex" / "glow.png")
    (tmp_path / "looks.mtlx").write_text(MTLX_DOC)
    path = tmp_path / "doc.usda"
    stage = new_stage(path)
    looks = stage.DefinePrim("/Looks")
    vset = looks.GetVariantSets().AddVariantSet("model")
    for name, doc in (("other", "missing.mtlx"), ("mtlx", "looks.mtlx")):
        vset.AddVariant(name)
        vset.SetVariantSelection(name)
        with vset.GetVariantEditContext():
            stage.OverridePrim("/Looks/mx").GetReferences().AddReference(f"./{doc}", "/MaterialX/Materials")
    vset.SetVariantSelection("mtlx")
    mesh = quad(stage, "/plane")
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).GetDirectBindingRel().SetTargets([Sdf.Path("/Looks/mx/glow")])
    top_camera(stage)
    stage.Save()
    scene, warns = read(path)
    assert not warns, warns
    got = render_rgb(scene, samples=64, n=8)
    want = 2.0 * np.repeat(np.repeat(srgb_decode(q / 255.0), 2, axis=0), 2, axis=1)
    np.testing.assert_allclose(got, want, atol=1e-4)


def test_unary_modulo_and_ifgreater_nodes(tmp_path):
    """emission_color = ifgreater(extract(T, 0), 0.5, absval(T − 0.5), modulo(3T, 1))
    + sin(T)·0.1 + sqrt(T)·0.05 per texel T (closest filter): numpy from the node
    definitions (mx_mod floored), within 1e-4."""
    path = tmp_path / "unary.usda"
    stage = new_stage(path)
    mat, sh = mx_material(stage, "/Looks/m", "ND_standard_surface_surfaceshader", base=0.0, specular=0.0, emission=1.0)
    file = tmp_path / "tex4.exr"
    write_exr(file, np.concatenate([TEXELS4, np.ones((4, 4, 1))], axis=2).astype(np.float32))
    img = image(stage, "/Looks/m/img", file, texcoord=texcoord(stage, "/Looks/m/uv"), filtertype="closest")

    def n(name, sid, out_type=T.Color3f, **inputs):
        s = UsdShade.Shader.Define(stage, f"/Looks/m/{name}")
        s.CreateIdAttr(sid)
        for k, v in inputs.items():
            if isinstance(v, UsdShade.Output):
                ty = T.Float if k in ("value1", "value2") else T.Color3f
                s.CreateInput(k, ty).ConnectToSource(v)
            else:
                set_input(s, k, v)
        return s.CreateOutput("out", out_type)

    half = n("half", "ND_subtract_color3FA", in1=img, in2=0.5)
    a = n("abs", "ND_absval_color3", **{"in": half})
    b = n("mod", "ND_modulo_color3FA", in1=n("x3", "ND_multiply_color3FA", in1=img, in2=3.0), in2=1.0)
    r = n("r", "ND_extract_color3", T.Float, **{"in": img})
    c = n("if", "ND_ifgreater_color3", value1=r, value2=0.5, in1=a, in2=b)
    sin = n("sin01", "ND_multiply_color3FA", in1=n("sin", "ND_sin_color3", **{"in": img}), in2=0.1)
    sq = n("sqrt05", "ND_multiply_color3FA", in1=n("sqrt", "ND_sqrt_color3", **{"in": img}), in2=0.05)
    total = n("total", "ND_add_color3", in1=n("sum", "ND_add_color3", in1=c, in2=sin), in2=sq)
    sh.CreateInput("emission_color", T.Color3f).ConnectToSource(total)
    quad(stage, "/plane", material=mat)
    top_camera(stage)
    stage.Save()
    scene, warns = read(path)
    assert not warns, warns
    got = render_rgb(scene, samples=64, n=8)
    t = np.repeat(np.repeat(TEXELS4.astype(np.float32).astype(np.float64), 2, axis=0), 2, axis=1)
    x3 = 3.0 * t
    pick = np.where(t[..., :1] > 0.5, np.abs(t - 0.5), x3 - np.floor(x3))
    want = pick + 0.1 * np.sin(t) + 0.05 * np.sqrt(t)
    np.testing.assert_allclose(got, want, atol=1e-4)


def test_mtlx_document_referenced_from_a_referenced_layer_lands_where_it_composes(tmp_path):
    """usd-wg/assets' OpenChessSet layout: an asset layer whose /Asset/Looks references a
    .mtlx document, referenced (twice, under other prim paths) by the shot stage. The
    document's materials compose at /Shot/A/Looks and /Shot/B/Looks, not at the asset
    layer's /Asset/Looks; both planes show 2 × the sRGB-decoded texels (as
    test_referenced_mtlx_document_inside_a_variant), no warning."""
    from PIL import Image

    from test_usd_preview import srgb_decode

    (tmp_path / "tex").mkdir()
    q = np.round(TEXELS4 * 255).astype(np.uint8)
    Image.fromarray(q, "RGB").save(tmp_path / "tex" / "glow.png")
    (tmp_path / "looks.mtlx").write_text(MTLX_DOC)
    asset = new_stage(tmp_path / "asset.usda")
    root = asset.DefinePrim("/Asset", "Xform")
    asset.SetDefaultPrim(root)
    asset.DefinePrim("/Asset/Looks").GetReferences().AddReference("./looks.mtlx", "/MaterialX/Materials")
    mesh = quad(asset, "/Asset/plane", x0=-0.5, x1=0.5, y0=-0.5, y1=0.5)
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).GetDirectBindingRel().SetTargets([Sdf.Path("/Asset/Looks/glow")])
    asset.Save()
    path = tmp_path / "shot.usda"
    stage = new_stage(path)
    for name, x in (("A", -0.5), ("B", 0.5)):
        prim = stage.DefinePrim(f"/Shot/{name}", "Xform")
        prim.GetReferences().AddReference("./asset.usda")
        pxr.UsdGeom.Xformable(prim).AddTranslateOp().Set(Gf.Vec3d(x, 0, 0))
    top_camera(stage, width=2.0)
    stage.Save()
    scene, warns = read(path)
    assert not warns, warns
    got = render_rgb(scene, samples=64, n=8)
    texel = 2.0 * srgb_decode(q / 255.0)  # each plane: 1 × 1 of the 2 × 2 view, 4 × 4 pixels
    want = np.zeros((8, 8, 3))
    want[2:6, 0:4] = want[2:6, 4:8] = texel
    np.testing.assert_allclose(got, want, atol=1e-4)
