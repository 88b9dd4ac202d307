"""Stages with broken parts: missing or unreadable texture files, unresolvable payloads,
unknown shader ids and render-context-only (MaterialX) materials each give one warning
naming the prim (and the file), use the fallback the spec defines, and the rest of the
stage renders."""

import warnings

import numpy as np
import pytest

pxr = pytest.importorskip("pxr")
from pxr import Gf, Sdf, UsdLux, UsdShade  # noqa: E402

import polychrome as pc  # noqa: E402
from polychrome import usd  # noqa: E402
from test_usd import floor_mesh, new_stage, top_camera  # noqa: E402


def read(path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = usd.read_stage(path)
    return scene, [str(w.message) for w in caught]


def textured_material(stage, path, file, fallback=None):
    mat = UsdShade.Material.Define(stage, path)
    surf = UsdShade.Shader.Define(stage, path + "/Surface")
    surf.CreateIdAttr("UsdPreviewSurface")
    tex = UsdShade.Shader.Define(stage, path + "/Tex")
    tex.CreateIdAttr("UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(file)
    if fallback is not None:
        tex.CreateInput("fallback", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(*fallback))
    out = tex.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
    surf.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(out)
    mat.CreateSurfaceOutput().ConnectToSource(surf.ConnectableAPI(), "surface")
    return mat


def materials_by_name(scene):
    return {m["name"]: m for m in scene.description()[0]["materials"]}


def test_missing_and_unreadable_textures_warn_once_and_use_the_fallback(tmp_path):
    (tmp_path / "broken.png").write_bytes(b"not a png at all")
    path = tmp_path / "tex.usda"
    stage = new_stage(path)
    a = textured_material(stage, "/Looks/a", "./nope.png", fallback=(0.2, 0.4, 0.6, 1.0))
    b = textured_material(stage, "/Looks/b", "./nope.png")
    c = textured_material(stage, "/Looks/c", "./broken.png", fallback=(0.7, 0.7, 0.7, 1.0))
    for i, mat in enumerate((a, b, c, a)):  # "a" bound twice: still one warning
        floor_mesh(stage, f"/floor{i}", 1.0, mat).AddTranslateOp().Set(Gf.Vec3d(3 * i, 0, 0))
    top_camera(stage, "/cam", 2.0, 2.0)
    UsdLux.DistantLight.Define(stage, "/sun").CreateIntensityAttr(1.0)
    stage.Save()
    scene, warns = read(path)
    mats = materials_by_name(scene)
    # UsdUVTexture's authored fallback, else UsdPreviewSurface's diffuseColor fallback 0.18
    assert mats["/Looks/a"]["bsdf"]["reflectance"]["rgb"] == pytest.approx([0.2, 0.4, 0.6])
    assert mats["/Looks/b"]["bsdf"]["reflectance"]["rgb"] == pytest.approx([0.18, 0.18, 0.18])
    assert mats["/Looks/c"]["bsdf"]["reflectance"]["rgb"] == pytest.approx([0.7, 0.7, 0.7])
    missing = [w for w in warns if "nope.png" in w]
    assert len(missing) == 2 and {"/Looks/a/Tex" in w for w in missing} == {True, False}, missing
    assert all("does not exist" in w for w in missing)
    unreadable = [w for w in warns if "broken.png" in w]
    assert len(unreadable) == 1 and "/Looks/c/Tex" in unreadable[0] and "cannot read" in unreadable[0]
    result = pc.render(scene, width=4, height=4, samples=2, max_bounces=1)
    assert np.all(np.isfinite(result.rgba)) and result.rgba[..., :3].mean() > 0


def test_missing_dome_texture_falls_back_to_its_colour(tmp_path):
    path = tmp_path / "dome.usda"
    stage = new_stage(path)
    dome = UsdLux.DomeLight.Define(stage, "/sky")
    dome.CreateTextureFileAttr("./gone.exr")
    dome.CreateIntensityAttr(2.0)
    dome.CreateColorAttr(Gf.Vec3f(0.5, 0.25, 1.0))
    top_camera(stage, "/cam", 2.0, 2.0)
    stage.Save()
    scene, warns = read(path)
    world = scene.description()[0]["world"]
    assert world["radiance"]["rgb"] == pytest.approx([0.5, 0.25, 1.0]) and world["radiance"]["scale"] == pytest.approx(2.0)
    assert len([w for w in warns if "gone.exr" in w and "/sky" in w]) == 1


def test_unknown_shaders_payloads_and_materialx_warn_once_and_the_rest_renders(tmp_path):
    path = tmp_path / "mixed.usda"
    stage = new_stage(path)
    odd = UsdShade.Material.Define(stage, "/Looks/odd")
    sh = UsdShade.Shader.Define(stage, "/Looks/odd/Surface")
    sh.CreateIdAttr("SomeStudioShader_v3")
    odd.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
    mx = UsdShade.Material.Define(stage, "/Looks/mx")
    msh = UsdShade.Shader.Define(stage, "/Looks/mx/Surface")
    # A MaterialX surface the reader does not translate (materialx.py reads Standard
    # Surface, OpenPBR and glTF PBR), bound for the "mtlx" context.
    msh.CreateIdAttr("ND_disney_brdf_2012_surfaceshader")
    mx.CreateSurfaceOutput("mtlx").ConnectToSource(msh.ConnectableAPI(), "out")
    ri = UsdShade.Material.Define(stage, "/Looks/ri")
    rsh = UsdShade.Shader.Define(stage, "/Looks/ri/Surface")
    rsh.CreateIdAttr("PxrSurface")
    ri.CreateSurfaceOutput("ri").ConnectToSource(rsh.ConnectableAPI(), "out")
    # A shader defined by its source file, no id (OpenUSD's glslfx test materials).
    fx = UsdShade.Material.Define(stage, "/Looks/fx")
    fsh = UsdShade.Shader.Define(stage, "/Looks/fx/Surface")
    fsh.SetSourceAsset(Sdf.AssetPath("surface.glslfx"), "glslfx")
    fx.CreateSurfaceOutput().ConnectToSource(fsh.ConnectableAPI(), "surface")
    floor_mesh(stage, "/fx", 1.0, fx).AddTranslateOp().Set(Gf.Vec3d(12, 0, 0))
    floor_mesh(stage, "/odd", 1.0, odd)
    floor_mesh(stage, "/mx", 1.0, mx).AddTranslateOp().Set(Gf.Vec3d(3, 0, 0))
    floor_mesh(stage, "/mx2", 1.0, mx).AddTranslateOp().Set(Gf.Vec3d(6, 0, 0))
    floor_mesh(stage, "/ri", 1.0, ri).AddTranslateOp().Set(Gf.Vec3d(9, 0, 0))
    stage.DefinePrim("/gone").GetPayloads().AddPayload("./no_such_payload.usda")
    top_camera(stage, "/cam", 2.0, 2.0)
    UsdLux.DistantLight.Define(stage, "/sun").CreateIntensityAttr(1.0)
    stage.Save()
    scene, warns = read(path)
    odd_w = [w for w in warns if "/Looks/odd" in w]
    mx_w = [w for w in warns if "/Looks/mx" in w]
    payload_w = [w for w in warns if "no_such_payload" in w]
    assert len(odd_w) == 1 and "SomeStudioShader_v3" in odd_w[0], warns
    ri_w = [w for w in warns if "/Looks/ri" in w]
    assert len(mx_w) == 1 and "ND_disney_brdf_2012_surfaceshader" in mx_w[0], warns
    assert len(ri_w) == 1 and "outputs:ri:surface" in ri_w[0], warns
    assert len(payload_w) == 1 and "/gone" in payload_w[0], warns
    fx_w = [w for w in warns if "/Looks/fx" in w]
    assert len(fx_w) == 1 and "sourceAsset 'surface.glslfx'" in fx_w[0], warns
    assert len(scene.description()[0]["meshes"]) == 5
    result = pc.render(scene, width=4, height=4, samples=2, max_bounces=1)
    assert np.all(np.isfinite(result.rgba))
