"""USD: polychrome.usd.write_stage / read_stage, and `polychrome render` on stages.

References: the round trip is compared with the scene's own description (every field
and buffer); stages written by hand with pxr are checked against closed forms (a point
and a rectangular light over a Lambertian floor), against colour-science (the preview
colour of a measured reflectance) and against USD's own GfCamera (field of view).
"""

import json
import math
import os
import re
import subprocess
import sys
import textwrap
import warnings
from pathlib import Path

import numpy as np
import pytest

pxr = pytest.importorskip("pxr")
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdRender, UsdShade, Vt  # noqa: E402

import polychrome as pc  # noqa: E402
from polychrome import cli, usd  # noqa: E402
from conftest import luminance  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def uv_sphere(radius=1.0, rings=6, segments=12):
    theta = np.linspace(0, np.pi, rings + 1)
    phi = np.linspace(0, 2 * np.pi, segments + 1)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    v = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1).reshape(-1, 3) * radius
    row = segments + 1
    r, s = np.meshgrid(np.arange(rings), np.arange(segments), indexing="ij")
    a = (r * row + s).ravel()
    b = a + row
    tris = np.concatenate([np.stack([a, b, a + 1], 1), np.stack([a + 1, b, b + 1], 1)])
    return v, tris


def spectral_scene():
    """Every kind of spectrum, a mesh with normals and uvs, per-triangle materials, a
    mesh placed three times, a camera with shift, point lights and a world."""
    scene = pc.Scene()
    paint = scene.add_material(
        pc.Diffuse(pc.spectra.tabulated([400, 450, 500, 550, 600, 650, 700], [0.05, 0.1, 0.6, 0.8, 0.3, 0.1, 0.05]), name="green paint")
    )
    red = scene.add_material(pc.Diffuse((0.8, 0.2, 0.1), name="red"))
    grey = scene.add_material(pc.Diffuse(0.5, name="grey"))
    scene.add_material(pc.Emitter(pc.spectra.blackbody(3200), strength=8.0, name="lamp"))
    scene.add_material(pc.Diffuse(pc.spectra.narrow_band(550, 20) * 0.7, emission=pc.spectra.fluorescent(11, 0.5), name="glow"))
    v, t = uv_sphere(1.0)
    normals = v / np.linalg.norm(v, axis=1, keepdims=True)
    uvs = np.stack([np.arange(len(v)) % 13 / 13.0, np.arange(len(v)) // 13 / 13.0], 1)
    scene.add_mesh("ball", v, t, normals=normals, uvs=uvs, material=paint)
    floor = np.array([[-4, -4, -1], [4, -4, -1], [4, 4, -1], [-4, 4, -1]], float)
    scene.add_mesh("floor", floor, [[0, 1, 2], [0, 2, 3]], material_ids=[grey, red])
    small = scene.add_mesh("pebble", v * 0.2, t, material=4, place=False)
    for k in range(3):
        m = np.eye(4)
        c, s = math.cos(k), math.sin(k)
        m[:3, :3] = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) * (1 + 0.5 * k)
        m[:3, 3] = [2.0 * k - 2, 2.0, -0.5]
        scene.add_instance(small, m, f"pebble {k}")
    lamp = scene.add_mesh("lamp", v * 0.3, t, material=3, place=False)
    scene.add_instance(lamp, np.array([[1, 0, 0, 1.5], [0, 1, 0, -1.5], [0, 0, 1, 2.0], [0, 0, 0, 1]]), "lamp")
    scene.camera = pc.Camera.looking_at(
        (0.5, -6, 2), (0, 0, 0), focal_length=35.0, shift_x=0.05, shift_y=-0.02, clip_start=0.05, name="Shot cam"
    )
    scene.add_light(pc.PointLight((2, -2, 3), power=40.0, color=pc.spectra.blackbody(4500), name="key"))
    scene.add_light(pc.PointLight((-3, -1, 2), power=15.0, color=(0.2, 0.4, 1.0), name="fill"))
    scene.set_world(pc.spectra.d65(0.05))
    return scene


def expanded(scene):
    """The description with buffer indices replaced by the buffers' values."""
    desc, buffers = scene.description()
    desc = json.loads(json.dumps(desc))
    for m in desc["meshes"]:
        for key in ("vertices", "triangles", "normals", "uvs", "material_ids"):
            if m.get(key) is not None:
                m[key] = np.asarray(buffers[m[key]]).tolist()
    return desc


SETTINGS = pc.RenderSettings(width=24, height=16, samples=4, max_bounces=3, seed=7, wavelength_count=21)


@pytest.mark.parametrize("suffix", [".usda", ".usdc"])
def test_round_trip_keeps_every_spectrum_mesh_transform_camera_and_light(tmp_path, suffix):
    scene = spectral_scene()
    path = usd.write_stage(scene, tmp_path / f"scene{suffix}", SETTINGS)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # our own stage must read without any warning
        back = usd.read_stage(path)
    a, b = expanded(scene), expanded(back)
    for key in a:
        assert a[key] == b[key], key
    assert a == b
    assert [type(m).__name__ for m in back.materials] == ["Diffuse", "Diffuse", "Diffuse", "Emitter", "Diffuse"]
    stored = usd.read_settings(path)
    assert {k: stored[k] for k in ("width", "height", "samples", "max_bounces", "seed", "wavelength_count", "method")} == {
        "width": 24,
        "height": 16,
        "samples": 4,
        "max_bounces": 3,
        "seed": 7,
        "wavelength_count": 21,
        "method": "POLYCHROMATIC",
    }


def test_written_stage_follows_the_usd_schemas(tmp_path):
    scene = spectral_scene()
    path = usd.write_stage(scene, tmp_path / "scene.usda", SETTINGS)
    stage = Usd.Stage.Open(str(path))
    assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.z
    assert UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    # Camera lens and filmback in tenths of a scene unit: 35 mm = 0.035 m = 0.35 tenths.
    cam = UsdGeom.Camera(stage.GetPrimAtPath("/World/Camera"))
    assert cam.GetFocalLengthAttr().Get() == pytest.approx(0.35, rel=1e-6)
    assert cam.GetHorizontalApertureAttr().Get() == pytest.approx(0.36, rel=1e-6)  # 36 mm, landscape AUTO fit
    assert cam.GetVerticalApertureAttr().Get() == pytest.approx(0.36 * 16 / 24, rel=1e-6)
    fov = cam.GetCamera(Usd.TimeCode.Default()).GetFieldOfView(Gf.Camera.FOVHorizontal)
    assert fov == pytest.approx(math.degrees(2 * math.atan(18 / 35)), rel=1e-5)
    # Shared meshes are instanceable references; the pebble prims are instances.
    pebbles = [p for p in stage.Traverse() if p.IsInstance()]
    assert len(pebbles) == 3
    # Per-triangle materials are GeomSubsets bound to the right materials.
    floor = stage.GetPrimAtPath("/World/floor")
    subsets = UsdShade.MaterialBindingAPI(floor).GetMaterialBindSubsets()
    bound = {
        tuple(s.GetIndicesAttr().Get()): UsdShade.MaterialBindingAPI(s.GetPrim()).ComputeBoundMaterial()[0].GetPath().name for s in subsets
    }
    assert bound == {(0,): "grey", (1,): "red"}
    # Lights and world.
    key = UsdLux.SphereLight(stage.GetPrimAtPath("/World/Lights/key"))
    assert key.GetTreatAsPointAttr().Get() is True
    assert UsdLux.DomeLight(stage.GetPrimAtPath("/World/Lights/World"))
    rs = UsdRender.Settings(stage.GetPrimAtPath("/Render/PolychromeSettings"))
    assert tuple(rs.GetResolutionAttr().Get()) == (24, 16)


def test_preview_colour_of_a_measured_reflectance_matches_colour_science(tmp_path):
    colour = pytest.importorskip("colour")
    wl = np.arange(400, 701, 50.0)
    refl = np.array([0.05, 0.1, 0.6, 0.8, 0.3, 0.1, 0.05])
    scene = pc.Scene()
    scene.add_material(pc.Diffuse(pc.spectra.tabulated(wl, refl), name="paint"))
    scene.add_mesh("tri", [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    path = usd.write_stage(scene, tmp_path / "paint.usda", pc.RenderSettings(wavelength_count=81))
    stage = Usd.Stage.Open(str(path))
    shader = UsdShade.Shader(stage.GetPrimAtPath("/World/Looks/paint/PreviewSurface"))
    got = np.array(shader.GetInput("diffuseColor").Get())
    fine = np.arange(380, 781, 5.0)
    sd = colour.SpectralDistribution(dict(zip(fine, np.interp(fine, wl, refl))))  # constant beyond the ends
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    xyz = colour.sd_to_XYZ(sd, cmfs, colour.SDS_ILLUMINANTS["D65"]) / 100
    want = colour.XYZ_to_RGB(xyz, colour.RGB_COLOURSPACES["sRGB"], apply_cctf_encoding=False)
    assert np.allclose(got, want, atol=0.02), (got, want)


def test_round_tripped_scene_renders_identically(tmp_path):
    scene = spectral_scene()
    back = usd.read_stage(usd.write_stage(scene, tmp_path / "scene.usdc", SETTINGS))
    a = pc.render(scene, SETTINGS)
    b = pc.render(back, SETTINGS)
    assert np.array_equal(a.rgba, b.rgba)
    assert luminance(a.rgba).mean() > 0.0


# ---------------------------------------------------------------------------- hand-written stages


def new_stage(path, up="Z", mpu=1.0):
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, up)
    UsdGeom.SetStageMetersPerUnit(stage, mpu)
    return stage


def preview_material(stage, path, rgb):
    mat = UsdShade.Material.Define(stage, path)
    sh = UsdShade.Shader.Define(stage, path + "/Surface")
    sh.CreateIdAttr("UsdPreviewSurface")
    sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*rgb))
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
    return mat


def floor_mesh(stage, path, half, material=None, up="Z", scale=1.0):
    """A square floor as ONE quad polygon (fan-triangulated by the reader)."""
    pts = np.array([[-half, -half, 0], [half, -half, 0], [half, half, 0], [-half, half, 0]], float)
    if up == "Y":
        pts = pts[:, [0, 2, 1]] * [1, 1, -1]
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy((pts * scale).astype(np.float32)))
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    if material is not None:
        UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)
    return mesh


def top_camera(stage, path, height, ortho_width, up="Z", scale=1.0):
    cam = UsdGeom.Camera.Define(stage, path)
    cam.CreateProjectionAttr("orthographic")
    cam.CreateHorizontalApertureAttr(ortho_width * scale * 10.0)  # tenths of a scene unit
    cam.CreateVerticalApertureAttr(ortho_width * scale * 10.0)
    cam.CreateClippingRangeAttr(Gf.Vec2f(0.01 * scale, 100.0 * scale))
    if up == "Z":
        cam.AddTranslateOp().Set(Gf.Vec3d(0, 0, height * scale))
    else:  # looking down −Y: rotate the camera's −Z onto −Y
        cam.AddTranslateOp().Set(Gf.Vec3d(0, height * scale, 0))
        cam.AddRotateXOp().Set(-90.0)
    return cam


def pixel_footprint_mean(fn, px, py, n, width, samples=32):
    """Mean of fn(x, y) over pixel (px, py) of an n×n ortho view `width` wide at the origin."""
    u = (px + (np.arange(samples) + 0.5) / samples) / n * width - width / 2
    v = width / 2 - (py + (np.arange(samples) + 0.5) / samples) / n * width
    x, y = np.meshgrid(u, v)
    return float(np.mean(fn(x, y)))


def test_plain_usd_stage_renders_with_sensible_defaults(tmp_path):
    """UsdGeom + UsdPreviewSurface + UsdLux only: a grey quad lit by a point-like
    SphereLight matches ρ/π · I cosθ / d² with I = intensity/4 (normalised sphere)."""
    rho, h, intensity = 0.5, 1.5, 60.0
    path = tmp_path / "plain.usda"
    stage = new_stage(path)
    UsdGeom.Xform.Define(stage, "/World")
    mat = preview_material(stage, "/World/Looks/grey", (rho, rho, rho))
    floor_mesh(stage, "/World/floor", 5.0, mat)
    light = UsdLux.SphereLight.Define(stage, "/World/bulb")
    light.CreateTreatAsPointAttr(True)
    light.CreateNormalizeAttr(True)
    light.CreateIntensityAttr(intensity)
    light.AddTranslateOp().Set(Gf.Vec3d(0, 0, h))
    top_camera(stage, "/World/cam", 4.0, 2.0)
    stage.Save()

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scene = usd.read_stage(path)
    n = 15
    result = pc.render(scene, width=n, height=n, samples=64, max_bounces=1)
    assert result.stats["nonfinite_samples"] == 0
    I = intensity / 4.0
    for px, py in [(7, 7), (0, 0), (14, 3)]:
        want = pixel_footprint_mean(lambda x, y: rho / math.pi * I * h / (x * x + y * y + h * h) ** 1.5, px, py, n, 2.0)
        got = luminance(result.rgba[py, px])
        assert abs(got - want) < 0.02 * want, (px, py, got, want)
    # Light where expected: the centre is brighter than the corners.
    y = luminance(result.rgba)
    assert y[7, 7] > 1.3 * y[0, 0]


def test_rect_light_shines_down_only_with_its_closed_form_irradiance(tmp_path):
    rho, h, a, b, radiance = 0.8, 1.0, 0.6, 0.4, 5.0
    path = tmp_path / "rect.usda"
    stage = new_stage(path)
    mat = preview_material(stage, "/Looks/white", (rho, rho, rho))
    floor_mesh(stage, "/floor", 5.0, mat)
    rect = UsdLux.RectLight.Define(stage, "/panel")  # emits along its local −Z: down
    rect.CreateWidthAttr(a)
    rect.CreateHeightAttr(b)
    rect.CreateIntensityAttr(radiance)
    rect.AddTranslateOp().Set(Gf.Vec3d(0, 0, h))
    ceiling = floor_mesh(stage, "/ceiling", 5.0, mat)
    ceiling.AddTranslateOp().Set(Gf.Vec3d(0, 0, 2 * h))
    top_camera(stage, "/cam", 0.5, 0.2)  # under the panel, looking down at the floor
    stage.Save()
    scene = usd.read_stage(path)
    result = pc.render(scene, width=5, height=5, samples=256, max_bounces=1)

    def corner(x, y):  # E of an x×y rectangle with a corner above the point, radiance 1
        return 0.5 * (x / math.hypot(x, h) * math.atan(y / math.hypot(x, h)) + y / math.hypot(y, h) * math.atan(x / math.hypot(y, h)))

    irradiance = radiance * 4 * corner(a / 2, b / 2)
    want = rho / math.pi * irradiance
    got = luminance(result.rgba[2, 2])
    assert abs(got - want) < 0.03 * want, (got, want)


def test_y_up_centimetre_stage_lands_where_its_z_up_metre_twin_does(tmp_path):
    def build(path, up, mpu):
        scale = 1.0 / mpu
        stage = new_stage(path, up, mpu)
        mat = preview_material(stage, "/Looks/grey", (0.5, 0.5, 0.5))
        floor_mesh(stage, "/floor", 2.0, mat, up=up, scale=scale)
        box = UsdGeom.Mesh.Define(stage, "/marker")  # a triangle off-centre, up in the air
        p = np.array([[0.5, 0.2, 0.3], [1.0, 0.2, 0.3], [0.5, 0.7, 0.6]])
        if up == "Y":
            p = p[:, [0, 2, 1]] * [1, 1, -1]
        box.CreatePointsAttr(Vt.Vec3fArray.FromNumpy((p * scale).astype(np.float32)))
        box.CreateFaceVertexCountsAttr([3])
        box.CreateFaceVertexIndicesAttr([0, 1, 2])
        xf = box.AddTranslateOp()
        xf.Set(Gf.Vec3d(*(np.array([0.1, 0.3, 0.2] if up == "Z" else [0.1, 0.2, -0.3]) * scale)))
        light = UsdLux.SphereLight.Define(stage, "/bulb")
        light.CreateNormalizeAttr(True)
        light.CreateTreatAsPointAttr(True)
        light.CreateIntensityAttr(40.0)
        light.CreateRadiusAttr(0.05 * scale)
        light.AddTranslateOp().Set(Gf.Vec3d(*(np.array([0.3, -0.2, 1.2] if up == "Z" else [0.3, 1.2, 0.2]) * scale)))
        top_camera(stage, "/cam", 3.0, 3.0, up=up, scale=scale)
        stage.Save()
        return usd.read_stage(path)

    z = build(tmp_path / "z.usda", "Z", 1.0)
    y = build(tmp_path / "y.usda", "Y", 0.01)

    def world_points(scene):
        desc, buffers = scene.description()
        out = []
        for inst in desc["instances"]:
            v = np.asarray(buffers[desc["meshes"][inst["mesh"]]["vertices"]], np.float64).reshape(-1, 3)
            m = np.asarray(inst["transform"])
            out.append(v @ m[:3, :3].T + m[:3, 3])
        return np.concatenate(out)

    assert np.allclose(world_points(z), world_points(y), atol=1e-5)
    assert np.allclose(z.camera.to_dict()["to_world"], y.camera.to_dict()["to_world"], atol=1e-6)
    assert z.camera.ortho_scale == pytest.approx(y.camera.ortho_scale, rel=1e-6)
    assert z.camera.clip_end == pytest.approx(y.camera.clip_end, rel=1e-6)
    lz, ly = z.lights[0].to_dict(), y.lights[0].to_dict()
    assert np.allclose(lz["position"], ly["position"], atol=1e-6)
    assert lz["intensity"]["scale"] == pytest.approx(ly["intensity"]["scale"], rel=1e-9)
    a = pc.render(z, width=12, height=12, samples=4, seed=3, max_bounces=2)
    b = pc.render(y, width=12, height=12, samples=4, seed=3, max_bounces=2)
    assert np.allclose(a.rgba, b.rgba, rtol=1e-3, atol=1e-4)
    assert luminance(a.rgba).max() > 0


def test_polygons_face_varying_data_and_instancing(tmp_path):
    path = tmp_path / "poly.usda"
    stage = new_stage(path)
    # A hexagon and a quad sharing an edge; face-varying uvs split the shared vertices.
    hexagon = [[math.cos(k * math.pi / 3), math.sin(k * math.pi / 3), 0.0] for k in range(6)]
    pts = np.array(hexagon + [[2.0, 0.0, 0.0], [2.0, 1.0, 0.0]], np.float32)
    proto_root = UsdGeom.Xform.Define(stage, "/Instancer/Prototypes/tile")
    mesh = UsdGeom.Mesh.Define(stage, "/Instancer/Prototypes/tile/shape")
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(pts))
    mesh.CreateFaceVertexCountsAttr([6, 4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3, 4, 5, 0, 6, 7, 1])
    mesh.CreateSubdivisionSchemeAttr("none")  # polygons (catmullClark, USD's default, would be refined)
    st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying)
    st.Set(Vt.Vec2fArray.FromNumpy(np.arange(20, dtype=np.float32).reshape(10, 2) / 20))
    inst = UsdGeom.PointInstancer.Define(stage, "/Instancer")
    inst.CreatePrototypesRel().SetTargets([proto_root.GetPath()])
    inst.CreateProtoIndicesAttr([0, 0, 0])
    inst.CreatePositionsAttr(Vt.Vec3fArray([Gf.Vec3f(0, 0, 0), Gf.Vec3f(0, 5, 0), Gf.Vec3f(0, 10, 1)]))
    top_camera(stage, "/cam", 5.0, 12.0)
    stage.Save()

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scene = usd.read_stage(path)
    desc, buffers = scene.description()
    assert len(desc["meshes"]) == 1 and len(desc["instances"]) == 3
    m = desc["meshes"][0]
    v = np.asarray(buffers[m["vertices"]]).reshape(-1, 3)
    t = np.asarray(buffers[m["triangles"]]).reshape(-1, 3)
    assert len(t) == 4 + 2  # fan: n − 2 triangles per polygon
    assert len(v) == 10  # every corner has its own uv
    area = 0.5 * np.linalg.norm(np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]]), axis=1).sum()
    hex_area = 3 * math.sqrt(3) / 2
    quad = np.array([pts[0], pts[6], pts[7], pts[1]], np.float64)
    quad_area = 0.5 * abs(np.dot(quad[:, 0], np.roll(quad[:, 1], -1)) - np.dot(quad[:, 1], np.roll(quad[:, 0], -1)))
    assert area == pytest.approx(hex_area + quad_area, rel=1e-6)
    offsets = sorted(tuple(np.round(np.asarray(i["transform"])[:3, 3], 6)) for i in desc["instances"])
    assert offsets == [(0.0, 0.0, 0.0), (0.0, 5.0, 0.0), (0.0, 10.0, 1.0)]


# ---------------------------------------------------------------------------- errors and warnings


def bad_mesh_stage(path, points=None, indices=None, counts=None):
    """/World/broken (a triangle, or the malformed data given) beside /World/good, a
    0.5-wide quad at the origin."""
    stage = new_stage(path)
    floor_mesh(stage, "/World/good", 0.25).CreateSubdivisionSchemeAttr("none")
    mesh = UsdGeom.Mesh.Define(stage, "/World/broken")
    mesh.CreatePointsAttr(points if points is not None else [(0, 0, 0), (1, 0, 0), (0, 1, 0)])
    mesh.CreateFaceVertexCountsAttr(counts if counts is not None else [3])
    mesh.CreateFaceVertexIndicesAttr(indices if indices is not None else [0, 1, 2])
    top_camera(stage, "/World/cam", 2.0, 2.0)
    stage.Save()
    return path


def test_missing_and_malformed_files_raise_value_error_naming_the_file(tmp_path):
    with pytest.raises(ValueError, match="nothere.usda"):
        usd.read_stage(tmp_path / "nothere.usda")
    junk = tmp_path / "junk.usda"
    junk.write_text('#usda 1.0\ndef Xform "World" {\n  float3 x = (1, 2\n')
    with pytest.raises(ValueError, match="junk.usda"):
        usd.read_stage(junk)
    binary = tmp_path / "noise.usdc"
    binary.write_bytes(os.urandom(256))
    with pytest.raises(ValueError, match="noise.usdc"):
        usd.read_stage(binary)


@pytest.mark.parametrize(
    "kwargs, problem",
    [
        (dict(points=[(0, 0, 0), (1, float("nan"), 0), (0, 1, 0)]), "point 1 is not finite"),
        (dict(points=[(0, 0, 0), (1, 0, 0), (0, float("inf"), 0)]), "point 2 is not finite"),
        (dict(indices=[0, 1, 7]), r"faceVertexIndices\[2\] = 7 is out of range"),
        (dict(indices=[0, -1, 2]), r"faceVertexIndices\[1\] = -1 is out of range"),
        (dict(counts=[4]), "faceVertexCounts add up to 4"),
    ],
)
def test_bad_mesh_data_skips_the_prim_with_one_warning_naming_it(tmp_path, kwargs, problem):
    path = bad_mesh_stage(tmp_path / "bad.usda", **kwargs)
    scene, warns = read_warned(path)
    assert_only_good_left(scene, warns, rf"bad\.usda: prim /World/broken: {problem}.*; it is skipped")


def read_warned(path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = usd.read_stage(path)
    return scene, [str(w.message) for w in caught]


def assert_only_good_left(scene, warns, pattern, good=1):
    """One warning matches ``pattern``; the scene holds only /World/good's quad, with its
    authored corners (±0.25, ±0.25, 0)."""
    import re

    assert len([w for w in warns if re.search(pattern, w)]) == 1, warns
    desc, buffers = scene.description()
    assert [i["name"] for i in desc["instances"]] == ["/World/good"] * good
    v = np.asarray(buffers[desc["meshes"][desc["instances"][0]["mesh"]]["vertices"]]).reshape(-1, 3)
    assert sorted(map(tuple, v.tolist())) == [(-0.25, -0.25, 0), (-0.25, 0.25, 0), (0.25, -0.25, 0), (0.25, 0.25, 0)]


def test_bad_subset_and_instancer_indices_skip_the_prim_with_one_warning(tmp_path):
    path = bad_mesh_stage(tmp_path / "subset.usda")
    stage = Usd.Stage.Open(str(path))
    mesh = stage.GetPrimAtPath("/World/broken")
    api = UsdShade.MaterialBindingAPI.Apply(mesh)
    sub = api.CreateMaterialBindSubset("s", Vt.IntArray([0, 3]), UsdGeom.Tokens.face)
    UsdShade.MaterialBindingAPI.Apply(sub.GetPrim()).Bind(preview_material(stage, "/Looks/m", (1, 1, 1)))
    stage.Save()
    scene, warns = read_warned(path)
    assert_only_good_left(scene, warns, r"subset\.usda: prim /World/broken: /World/broken/s: face index 3 is out of range")

    path = bad_mesh_stage(tmp_path / "instancer.usda")
    stage = Usd.Stage.Open(str(path))
    stage.RemovePrim("/World/broken")
    UsdGeom.Cube.Define(stage, "/I/proto/box")
    inst = UsdGeom.PointInstancer.Define(stage, "/I")
    inst.CreatePrototypesRel().SetTargets([Sdf.Path("/I/proto")])
    inst.CreateProtoIndicesAttr([0, 2])
    inst.CreatePositionsAttr([(0, 0, 0), (1, 0, 0)])
    stage.Save()
    scene, warns = read_warned(path)
    assert_only_good_left(scene, warns, r"instancer\.usda: prim /I: protoIndices\[1\] = 2 is out of range")


def test_unsupported_prim_warns_once_and_the_render_still_works(tmp_path):
    path = bad_mesh_stage(tmp_path / "extra.usda")
    stage = Usd.Stage.Open(str(path))
    UsdGeom.NurbsPatch.Define(stage, "/World/ball")
    UsdGeom.NurbsCurves.Define(stage, "/World/hair")
    UsdLux.PortalLight.Define(stage, "/World/tube")
    stage.Save()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = usd.read_stage(path)
    messages = [str(w.message) for w in caught]
    for prim in ("/World/ball", "/World/hair", "/World/tube"):
        assert sum(prim in m for m in messages) == 1, messages
    assert len(messages) == 3, messages
    result = pc.render(scene, width=8, height=8, samples=2)
    assert np.all(np.isfinite(result.rgba))


# ---------------------------------------------------------------------------- CLI


def test_cli_renders_usda_to_exr_and_png_with_stage_settings_and_flag_overrides(tmp_path, capsys):
    from polychrome import imageio

    scene = spectral_scene()
    stage = usd.write_stage(scene, tmp_path / "shot.usda", pc.RenderSettings(width=20, height=10, samples=2, seed=3))
    exr, png = tmp_path / "out.exr", tmp_path / "out.png"
    assert cli.main(["render", str(stage), "-o", str(exr)]) == 0
    err = capsys.readouterr().err
    assert "Polychrome" in err  # the progress bar
    img = imageio.read_image(exr)
    assert img.shape[:2] == (10, 20) and np.all(np.isfinite(img)) and img[..., :3].max() > 0
    assert cli.main(["render", str(stage), "-o", str(png), "--width", "12", "--samples", "1", "--wavelengths", "16", "--quiet"]) == 0
    from PIL import Image

    with Image.open(png) as im:
        assert im.size == (12, 6)  # --width alone keeps the stage's 2:1 aspect


def test_cli_reports_bad_input_with_exit_2_and_one_line(tmp_path, capsys):
    junk = tmp_path / "junk.usda"
    junk.write_text('#usda 1.0\ndef Xform "World" {\n  float3 x = (1, 2\n')
    assert cli.main(["render", str(junk), "-o", str(tmp_path / "x.png"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "junk.usda" in err[0], err
    # A malformed prim is skipped with a warning naming it; the rest renders.
    path = bad_mesh_stage(tmp_path / "bad.usda", points=[(0, 0, 0), (1, float("nan"), 0), (0, 1, 0)])
    assert (
        cli.main(["render", str(path), "-o", str(tmp_path / "ok.png"), "--quiet", "--samples", "1", "--width", "8", "--height", "8"]) == 0
    )
    err = capsys.readouterr().err
    assert "bad.usda: prim /World/broken: point 1 is not finite; it is skipped" in err, err
    assert cli.main(["render", str(tmp_path / "missing.usdc"), "-o", str(tmp_path / "x.png")]) == 2
    assert "missing.usdc" in capsys.readouterr().err
    assert cli.main(["render", str(path), "-o", str(tmp_path / "x.jpg")]) == 2
    assert cli.main(["render", str(tmp_path / "scene.obj"), "-o", str(tmp_path / "x.png")]) == 2
    assert cli.main(["render", str(path), "-o", str(tmp_path / "x.png"), "--samples", "0"]) == 2


@pytest.mark.blender
def test_cli_renders_a_blend_file(tmp_path):
    pytest.importorskip("bpy")
    blend = tmp_path / "cube.blend"
    png = tmp_path / "cube.png"
    script = textwrap.dedent(f"""
        import sys
        import bpy
        bpy.ops.wm.read_factory_settings()
        bpy.context.scene.render.resolution_x, bpy.context.scene.render.resolution_y = 32, 24
        bpy.ops.wm.save_as_mainfile(filepath={str(blend)!r})
        from polychrome import cli
        sys.exit(cli.main(["render", {str(blend)!r}, "-o", {str(png)!r}, "--samples", "2", "--quiet"]))
    """)
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    from PIL import Image

    with Image.open(png) as im:
        assert im.size == (32, 24)
        assert np.asarray(im).astype(float)[..., :3].mean() > 1.0  # the default cube is lit


@pytest.mark.blender
def test_blender_export_operator_writes_a_stage_polychrome_reads_back(tmp_path):
    pytest.importorskip("bpy")
    stage = tmp_path / "default.usda"
    script = textwrap.dedent(f"""
        import json, sys
        import bpy
        import polychrome_blender
        polychrome_blender.register()
        try:
            bpy.ops.wm.read_factory_settings()
            polychrome_blender.unregister(); polychrome_blender.register()
            sc = bpy.context.scene
            sc.render.resolution_x, sc.render.resolution_y = 40, 30
            sc.polychrome.samples = 5
            assert 'FINISHED' in bpy.ops.export_scene.polychrome_usd(filepath={str(stage)!r})
            from polychrome import usd
            scene = usd.read_stage({str(stage)!r})
            desc, _ = scene.description()
            print("RESULT " + json.dumps({{"meshes": [m["name"] for m in desc["meshes"]],
                                          "lights": len(desc["lights"]), "settings": usd.read_settings({str(stage)!r})}}))
        finally:
            polychrome_blender.unregister()
    """)
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    res = json.loads(next(line[7:] for line in proc.stdout.splitlines() if line.startswith("RESULT ")))
    assert res["meshes"] == ["Cube"]
    assert res["lights"] == 1
    assert res["settings"]["samples"] == 5 and (res["settings"]["width"], res["settings"]["height"]) == (40, 30)


# ---------------------------------------------------------------------------- glass, metals, spots, suns, textures


def test_round_trip_of_glass_metals_spot_sun_and_textures(tmp_path):
    from polychrome import ior

    scene = pc.Scene()
    rng = np.random.default_rng(5)
    srgb = pc.Texture.from_array(rng.integers(0, 256, (6, 8, 3), dtype=np.uint8), "srgb", "CLIP", name="bytes.png")
    linear = pc.Texture.from_array(rng.random((4, 5, 3)).astype(np.float32) * 2, "linear", "EXTEND", name="floats")
    scene.add_material(pc.Diffuse(srgb, name="printed"))
    scene.add_material(pc.Diffuse(linear, emission=pc.spectra.rgb(0.1, 0.2, 0.3), name="lit print"))
    scene.add_material(
        pc.Dielectric(
            ior.sellmeier([1.03961212, 0.231792344, 1.01046945], [0.00600069867, 0.0200179144, 103.560653]), roughness=0.1, name="bk7"
        )
    )
    scene.add_material(pc.Dielectric(ior.abbe(1.5, 40.0), name="abbe glass"))
    scene.add_material(pc.Dielectric("Diamond", name="diamond"))
    scene.add_material(pc.Dielectric(ior.cauchy(1.5, 0.0042), name="cauchy"))
    scene.add_material(pc.Conductor("gold", roughness=0.3, name="gold"))
    scene.add_material(pc.Conductor(eta=pc.spectra.constant(0.2), k=pc.spectra.tabulated([400, 700], [3.0, 4.0]), name="nk"))
    scene.add_material(pc.Glossy((0.9, 0.5, 0.2), roughness=0.4, name="glossy"))
    v, t = uv_sphere(0.5)
    uvs = np.stack([np.linspace(0, 1, len(v)), np.linspace(1, 0, len(v))], 1)
    for i in range(len(scene.materials)):
        m = np.eye(4)
        m[:3, 3] = [i % 3 - 1.0, 0.0, i // 3 - 1.0]
        scene.add_mesh(f"ball{i}", v, t, uvs=uvs, material=i, transform=m)
    scene.add_light(
        pc.SpotLight((0, -3, 3), (0, 1, -1), power=80, color=pc.spectra.blackbody(3000), spot_size=0.7, spot_blend=0.3, name="spot")
    )
    scene.add_light(pc.SunLight((0.2, 0.3, -1.0), strength=2.5, color=pc.spectra.d65(), name="sun"))
    hdri = pc.Texture.from_array(rng.random((8, 16, 3)).astype(np.float32), name="sky.exr")
    scene.set_world(texture=hdri, strength=1.5, rotation=0.4, importance_sampling=False)
    scene.camera = pc.Camera.looking_at((0, -5, 0), (0, 0, 0))

    path = usd.write_stage(scene, tmp_path / "mix.usda", SETTINGS)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        back = usd.read_stage(path)
    a, b = expanded(scene), expanded(back)
    da, ba = scene.description()
    db, bb = back.description()
    for key in ("materials", "lights", "world", "instances", "meshes"):
        assert a[key] == b[key], key
    assert [{k: v for k, v in t.items() if k != "buffer"} for t in da["textures"]] == [
        {k: v for k, v in t.items() if k != "buffer"} for t in db["textures"]
    ]
    for ta, tb in zip(da["textures"], db["textures"]):
        assert np.array_equal(np.asarray(ba[ta["buffer"]]), np.asarray(bb[tb["buffer"]])), ta["name"]
    assert [type(m).__name__ for m in back.materials] == [
        "Diffuse",
        "Diffuse",
        "Dielectric",
        "Dielectric",
        "Dielectric",
        "Dielectric",
        "Conductor",
        "Conductor",
        "Glossy",
    ]
    assert [type(light).__name__ for light in back.lights] == ["SpotLight", "SunLight"]
    r1 = pc.render(scene, SETTINGS)
    r2 = pc.render(back, SETTINGS)
    assert np.array_equal(r1.rgba, r2.rgba)

    # Other tools see standard values: glass is transparent with its nd, gold is metallic,
    # the spot has a cone of half its full angle, the texture is a UsdUVTexture.
    stage = Usd.Stage.Open(str(path))
    glass = UsdShade.Shader(stage.GetPrimAtPath("/World/Looks/abbe_glass/PreviewSurface"))
    assert glass.GetInput("opacity").Get() == 0.0 and glass.GetInput("ior").Get() == pytest.approx(1.5)
    assert UsdShade.Shader(stage.GetPrimAtPath("/World/Looks/gold/PreviewSurface")).GetInput("metallic").Get() == 1.0
    spot = UsdLux.ShapingAPI(stage.GetPrimAtPath("/World/Lights/spot"))
    assert spot.GetShapingConeAngleAttr().Get() == pytest.approx(math.degrees(0.35), rel=1e-6)
    tex = UsdShade.Shader(stage.GetPrimAtPath("/World/Looks/printed/Texture"))
    assert tex.GetShaderId() == "UsdUVTexture" and tex.GetInput("wrapS").Get() == "black"
    assert (tmp_path / "mix_textures" / "bytes.png").is_file()


def test_foreign_dome_texture_lands_where_usd_puts_it(tmp_path):
    """OpenEXR/USD latlong (ImfEnvmap.cpp: u = 0.5 − atan2(x, z)/2π, top = +Y): the
    image centre faces the dome's +Z; a dome oriented to a
    Z-up stage (OrientToStageUpAxis: rotateX 90) therefore puts it towards world −Y,
    and its left quarter (u = 0.25, +X in the dome) towards world +X."""
    from polychrome import imageio

    h, w = 32, 64
    img = np.full((h, w, 3), 0.01, np.float32)
    img[12:20, 30:34] = [4.0, 0.0, 0.0]  # red patch at the centre (u = 0.5)
    img[12:20, 14:18] = [0.0, 0.0, 4.0]  # blue patch at u = 0.25
    imageio.write_exr(tmp_path / "env.exr", img)
    path = tmp_path / "dome.usda"
    stage = new_stage(path)
    dome = UsdLux.DomeLight.Define(stage, "/Sky")
    dome.CreateTextureFileAttr("./env.exr")
    dome.CreateTextureFormatAttr("latlong")
    dome.OrientToStageUpAxis()
    cam = UsdGeom.Camera.Define(stage, "/cam")
    cam.CreateFocalLengthAttr(5.0)  # narrow view: 50 mm on a 20.955 mm aperture, in tenths of a unit
    cam.CreateHorizontalApertureAttr(2.0955)
    cam.CreateVerticalApertureAttr(2.0955)
    cam.AddRotateXOp().Set(-90.0)  # camera −Z → world −Y
    stage.Save()

    def look(z_degrees):
        st = Usd.Stage.Open(str(path))
        op = UsdGeom.Xformable(st.GetPrimAtPath("/cam"))
        op.ClearXformOpOrder()
        op.AddRotateZOp().Set(z_degrees)
        op.AddRotateXOp().Set(-90.0)
        st.Save()
        return pc.render(usd.read_stage(path), width=8, height=8, samples=4, max_bounces=1).rgba[..., :3].mean(axis=(0, 1))

    towards_minus_y = look(0.0)
    towards_plus_x = look(90.0)  # camera −Y rotated +90° about Z looks along +X
    towards_plus_y = look(180.0)
    assert towards_minus_y[0] > 20 * towards_minus_y[2] and towards_minus_y[0] > 1.0, towards_minus_y
    assert towards_plus_x[2] > 20 * towards_plus_x[0] and towards_plus_x[2] > 1.0, towards_plus_x
    assert towards_plus_y.max() < 0.05, towards_plus_y


def test_intrinsic_shapes_are_tessellated_with_their_size_and_axis(tmp_path):
    path = tmp_path / "shapes.usda"
    stage = new_stage(path)
    UsdGeom.Sphere.Define(stage, "/sphere").CreateRadiusAttr(2.0)
    UsdGeom.Cube.Define(stage, "/cube").CreateSizeAttr(3.0)
    cyl = UsdGeom.Cylinder.Define(stage, "/cylinder")
    cyl.CreateRadiusAttr(0.5)
    cyl.CreateHeightAttr(4.0)
    cyl.CreateAxisAttr("X")
    UsdGeom.Cone.Define(stage, "/cone")
    top_camera(stage, "/cam", 10.0, 10.0)
    stage.Save()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scene = usd.read_stage(path)
    desc, buffers = scene.description()
    shapes = {m["name"]: np.asarray(buffers[m["vertices"]]).reshape(-1, 3) for m in desc["meshes"]}
    tris = {m["name"]: np.asarray(buffers[m["triangles"]]).reshape(-1, 3) for m in desc["meshes"]}

    def volume(name):  # divergence theorem: a closed, outward-wound mesh has positive volume
        v, t = shapes[name].astype(np.float64), tris[name]
        return float(np.einsum("ij,ij->i", v[t[:, 0]], np.cross(v[t[:, 1]], v[t[:, 2]])).sum() / 6)

    assert np.allclose(np.linalg.norm(shapes["/sphere"], axis=1), 2.0, atol=1e-6)
    assert volume("/sphere") == pytest.approx(4 / 3 * math.pi * 8, rel=0.02)
    assert volume("/cube") == pytest.approx(27.0, rel=1e-6)
    assert np.allclose(shapes["/cylinder"][:, 0].min(), -2.0) and np.allclose(np.abs(shapes["/cylinder"][:, 1:]).max(), 0.5)
    assert volume("/cylinder") == pytest.approx(math.pi * 0.25 * 4, rel=0.01)
    assert volume("/cone") == pytest.approx(math.pi * 1 * 2 / 3, rel=0.01)


def test_preview_surface_glass_metal_and_emission_map_to_polychrome_materials(tmp_path):
    path = tmp_path / "looks.usda"
    stage = new_stage(path)
    specs = {
        "glass": {"opacity": 0.0, "ior": 1.33, "roughness": 0.0},
        "metal": {"metallic": 1.0, "diffuseColor": Gf.Vec3f(0.9, 0.6, 0.2), "roughness": 0.25},
        "lamp": {"diffuseColor": Gf.Vec3f(0.1, 0.1, 0.1), "emissiveColor": Gf.Vec3f(2.0, 1.0, 0.5)},
    }
    for name, inputs in specs.items():
        mat = UsdShade.Material.Define(stage, f"/Looks/{name}")
        sh = UsdShade.Shader.Define(stage, f"/Looks/{name}/s")
        sh.CreateIdAttr("UsdPreviewSurface")
        for key, value in inputs.items():
            sh.CreateInput(key, Sdf.ValueTypeNames.Color3f if isinstance(value, Gf.Vec3f) else Sdf.ValueTypeNames.Float).Set(value)
        mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
        floor_mesh(stage, f"/{name}", 1.0, mat)
    top_camera(stage, "/cam", 2.0, 2.0)
    stage.Save()
    scene = usd.read_stage(path)
    by_name = {m.name: m for m in scene.materials}
    glass = by_name["/Looks/glass"].to_dict()["bsdf"]
    assert glass == {"type": "dielectric", "ior": {"type": "constant", "ior": pytest.approx(1.33)}, "roughness": 0.0}
    metal = by_name["/Looks/metal"].to_dict()["bsdf"]
    assert metal["type"] == "glossy" and metal["roughness"] == 0.25
    assert metal["reflectance"]["rgb"] == pytest.approx([0.9, 0.6, 0.2])
    lamp = by_name["/Looks/lamp"].to_dict()
    assert lamp["bsdf"]["reflectance"]["rgb"] == pytest.approx([0.1, 0.1, 0.1])
    assert lamp["emission"]["rgb"] == pytest.approx([2.0, 1.0, 0.5])


@pytest.mark.parametrize(
    "edit, prim, problem",
    [
        (
            lambda st: UsdGeom.Xformable(st.GetPrimAtPath("/World/broken")).AddTranslateOp().Set(Gf.Vec3d(0, float("nan"), 0)),
            "/World/broken",
            "transform is not finite",
        ),
        (lambda st: UsdLux.SphereLight.Define(st, "/World/bulb").CreateIntensityAttr(float("inf")), "/World/bulb", "not finite"),
        (lambda st: UsdGeom.Camera(st.GetPrimAtPath("/World/cam")).CreateHorizontalApertureAttr(float("nan")), "/World/cam", "not finite"),
        (
            lambda st: st.GetPrimAtPath("/World/cam").CreateAttribute("polychrome:camera", Sdf.ValueTypeNames.String).Set("{oops"),
            "/World/cam",
            "not valid JSON",
        ),
        (
            lambda st: UsdGeom.Mesh(st.GetPrimAtPath("/World/broken")).CreateNormalsAttr([(0, 0, 1), (0, 0, float("nan")), (0, 0, 1)]),
            "/World/broken",
            r"normals\[1\] is not finite",
        ),
    ],
)
def test_non_finite_values_and_bad_json_skip_the_prim_with_one_warning(tmp_path, edit, prim, problem):
    """The prim is skipped (a camera: the default camera is used; non-finite normals are
    dropped, the mesh kept), the rest is read."""
    path = bad_mesh_stage(tmp_path / "odd.usda")
    stage = Usd.Stage.Open(str(path))
    edit(stage)
    stage.Save()
    scene, warns = read_warned(path)
    dropped = "normals" in problem  # optional data: dropped, the mesh kept
    assert len([w for w in warns if "prim /World/" in w]) == 1, warns
    then = "its normals are ignored" if dropped else "it is skipped"
    assert len([w for w in warns if re.search(rf"odd\.usda: prim {prim}: .*{problem}.*; {then}", w)]) == 1, warns
    names = [i["name"] for i in scene.description()[0]["instances"]]
    assert names == (["/World/good"] if prim == "/World/broken" and not dropped else ["/World/good", "/World/broken"])
    assert not scene.lights
    if prim == "/World/cam":  # the default camera
        assert scene.camera.to_dict() == pc.Camera().to_dict()


def test_stage_without_camera_warns_and_uses_the_default_camera(tmp_path):
    path = tmp_path / "nocam.usda"
    stage = new_stage(path)
    floor_mesh(stage, "/floor", 1.0)
    stage.Save()
    with pytest.warns(UserWarning, match="no UsdGeom.Camera"):
        scene = usd.read_stage(path)
    assert scene.camera.to_dict() == pc.Camera().to_dict()


def test_every_render_setting_but_threads_round_trips(tmp_path):
    import dataclasses

    scene = pc.Scene()
    scene.add_mesh("t", [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    settings = pc.RenderSettings(
        width=10,
        height=7,
        samples=3,
        wavelengths=[400, 450, 500, 550, 600, 650, 700],
        uplift="SMOOTH",
        spectral_output=True,
        time_limit=2.5,
        seed=11,
        max_bounces=2,
        threads=3,
    )
    path = usd.write_stage(scene, tmp_path / "settings.usdc", settings)
    back = pc.RenderSettings(**usd.read_settings(path))
    assert back == dataclasses.replace(settings, threads=0)


@pytest.mark.blender
def test_blenders_own_usd_export_renders_like_the_addon_export(tmp_path):
    """Blender's USD exporter (bpy.ops.wm.usd_export: SphereLight intensity P/π normalised,
    colour temperature, the world as a tiny HDR dome) read by polychrome.usd gives the
    same picture as the add-on's direct export of the same scene (ΔE00)."""
    pytest.importorskip("bpy")
    stage = tmp_path / "blender.usda"
    script = textwrap.dedent(f"""
        import json, sys, warnings
        import bpy
        import polychrome as pc, polychrome_blender
        polychrome_blender.register()
        try:
            bpy.ops.wm.read_factory_settings()
            polychrome_blender.unregister(); polychrome_blender.register()
            bpy.ops.wm.usd_export(filepath={str(stage)!r}, export_materials=True)
            from polychrome_blender.export import export_scene
            from polychrome import usd
            from polychrome.colordiff import delta_e_stats, image_delta_e
            direct, _ = export_scene(bpy.context.evaluated_depsgraph_get())
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                via_usd = usd.read_stage({str(stage)!r})
            a = pc.render(direct, width=48, height=27, samples=32, seed=1).rgba[..., :3]
            b = pc.render(via_usd, width=48, height=27, samples=32, seed=1).rgba[..., :3]
            print("RESULT " + json.dumps({{"de": delta_e_stats(image_delta_e(a, b)), "a": a.mean(axis=(0, 1)).tolist(),
                                          "b": b.mean(axis=(0, 1)).tolist(), "warnings": [str(w.message) for w in caught],
                                          "world": via_usd.description()[0]["world"]}}))
        finally:
            polychrome_blender.unregister()
    """)
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    res = json.loads(next(line[7:] for line in proc.stdout.splitlines() if line.startswith("RESULT ")))
    assert res["de"]["mean"] < 1.0, res
    assert np.allclose(res["a"], res["b"], rtol=0.05), res
    assert res["world"]["texture"] == 0 and abs(res["world"]["rotation"]) < 1e-9  # Blender's dome: rotateXYZ (90, 0, 90)
    assert res["warnings"] == [], res["warnings"]  # its 0.1 m radius: a sphere light on both paths


@pytest.mark.blender
def test_blender_imports_a_polychrome_stage_with_the_same_camera_and_lights(tmp_path):
    """Blender's USD importer (an independent reader of the tenths-of-a-unit camera and of
    UsdLux intensities) sees the lens, sensor, shift and point-light power we wrote."""
    pytest.importorskip("bpy")
    stage = usd.write_stage(spectral_scene(), tmp_path / "ours.usda", SETTINGS)
    script = textwrap.dedent(f"""
        import json, sys
        import bpy
        bpy.ops.wm.read_factory_settings(use_empty=True)
        assert 'FINISHED' in bpy.ops.wm.usd_import(filepath={str(stage)!r})
        cam = next(o for o in bpy.data.objects if o.type == 'CAMERA')
        lights = {{o.name: [o.data.energy, list(o.matrix_world.translation)] for o in bpy.data.objects if o.type == 'LIGHT'}}
        print("RESULT " + json.dumps({{"lens": cam.data.lens, "sensor": [cam.data.sensor_width, cam.data.sensor_height],
                                      "shift": [cam.data.shift_x, cam.data.shift_y], "position": list(cam.matrix_world.translation),
                                      "lights": lights}}))
    """)
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    res = json.loads(next(line[7:] for line in proc.stdout.splitlines() if line.startswith("RESULT ")))
    assert res["lens"] == pytest.approx(35.0, rel=1e-5)
    assert res["sensor"] == pytest.approx([36.0, 24.0], rel=1e-5)  # 24 mm: the 3:2 image's fitted height
    assert res["shift"] == pytest.approx([0.05, -0.02], abs=1e-6)
    assert res["position"] == pytest.approx([0.5, -6.0, 2.0], abs=1e-6)
    # The RGB-coloured fill light: power = 4π × radiant intensity of the brightest channel.
    energy, position = res["lights"]["fill"]
    assert energy == pytest.approx(15.0, rel=1e-4) and position == pytest.approx([-3.0, -1.0, 2.0])


def test_cli_takes_the_image_aspect_from_a_foreign_camera_without_render_settings(tmp_path):
    from PIL import Image

    path = bad_mesh_stage(tmp_path / "plain.usda")  # its camera: a square 2 × 2 aperture
    stage = Usd.Stage.Open(str(path))
    UsdGeom.Camera(stage.GetPrimAtPath("/World/cam")).CreateVerticalApertureAttr(10.0)  # 20:10
    stage.Save()
    out = tmp_path / "plain.png"
    assert cli.main(["render", str(path), "-o", str(out), "--width", "30", "--samples", "1", "--quiet"]) == 0
    with Image.open(out) as im:
        assert im.size == (30, 15)


def addon_style_area_light(scene, name, shape, size, matrix, radiance):
    """What polychrome_blender exports for an area light: an emission-only polygon in
    the local XY plane shining along −Z and a black copy 1/1000 of its size behind it."""
    if shape == "rect":
        pts = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], np.float64) * [size[0] / 2, size[1] / 2]
    else:
        a = np.linspace(0, 2 * math.pi, 32, endpoint=False)
        pts = np.stack([np.cos(a), np.sin(a)], 1) * size[0] / 2
    n = len(pts)
    tris = np.stack([np.zeros(n - 2, int), np.arange(1, n - 1), np.arange(2, n)], 1)
    verts = np.concatenate([pts, np.zeros((n, 1))], 1)
    back = verts.copy()
    back[:, 2] = 1e-3 * max(size)
    m = scene.add_mesh(name, verts, tris, material=pc.Emitter(radiance, name=f"{name} (area light)"), place=False)
    scene.add_instance(m, matrix, name)
    b = scene.add_mesh(f"{name} (back)", back, tris, material=pc.Diffuse(0.0, name=f"{name} (back)"), place=False)
    scene.add_instance(b, matrix, f"{name} (back)")


def test_area_lights_become_rect_and_disk_lights_that_render_the_same(tmp_path):
    rho, h = 0.8, 1.0
    scene = pc.Scene()
    scene.add_mesh(
        "floor", [[-5, -5, 0], [5, -5, 0], [5, 5, 0], [-5, 5, 0]], [[0, 1, 2], [0, 2, 3]], material=pc.Diffuse(rho, name="floor")
    )
    down = np.eye(4)
    down[:3, 3] = [0.0, 0.0, h]  # local −Z is world −Z: shining down
    addon_style_area_light(scene, "panel", "rect", (0.6, 0.4), down, pc.spectra.blackbody(5000) * 6.0)
    tilted = np.eye(4)
    c, s_ = math.cos(0.3), math.sin(0.3)
    tilted[:3, :3] = [[1, 0, 0], [0, c, -s_], [0, s_, c]]
    tilted[:3, 3] = [3.0, 0.0, 1.5]
    addon_style_area_light(scene, "spot disk", "disk", (0.5, 0.5), tilted, pc.spectra.rgb(1.0, 0.5, 0.2) * 4.0)
    scene.camera = pc.Camera(
        to_world=np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0.5], [0, 0, 0, 1.0]]), projection="ORTHOGRAPHIC", ortho_scale=0.2
    )
    path = usd.write_stage(scene, tmp_path / "area.usda", SETTINGS)

    stage = Usd.Stage.Open(str(path))
    rect = UsdLux.RectLight(stage.GetPrimAtPath("/World/Lights/panel"))
    assert (rect.GetWidthAttr().Get(), rect.GetHeightAttr().Get()) == pytest.approx((0.6, 0.4))
    frame = np.array(UsdGeom.Xformable(rect).ComputeLocalToWorldTransform(Usd.TimeCode.Default())).T
    assert frame[:3, 2] == pytest.approx([0, 0, 1]) and frame[:3, 3] == pytest.approx([0, 0, h])  # shines along −Z: down
    disk = UsdLux.DiskLight(stage.GetPrimAtPath("/World/Lights/spot_disk"))
    polygon_area = 0.5 * 32 * 0.25**2 * math.sin(2 * math.pi / 32)
    assert math.pi * disk.GetRadiusAttr().Get() ** 2 == pytest.approx(polygon_area, rel=1e-6)
    meshes = {p.GetAttribute("polychrome:instanceName").Get() for p in stage.Traverse() if p.GetTypeName() == "Mesh"}
    assert meshes == {"floor", "panel (back)", "spot disk (back)"}  # the emitters became lights

    back = usd.read_stage(path)
    emitters = [m for m in back.materials if m.to_dict()["bsdf"]["type"] == "none"]
    assert sorted(m.to_dict()["emission"]["type"] for m in emitters) == ["blackbody", "rgb"]
    assert len(back.description()[0]["meshes"]) == 5  # floor, 2 backings, 2 emitters: no extra backing
    settings = pc.RenderSettings(width=3, height=3, samples=256, max_bounces=1, seed=2)
    a = luminance(pc.render(scene, settings).rgba[1, 1])
    b = luminance(pc.render(back, settings).rgba[1, 1])
    assert b == pytest.approx(a, rel=0.03), (a, b)


def test_unresolved_reference_is_one_warning_and_the_rest_renders(tmp_path, capfd):
    path = bad_mesh_stage(tmp_path / "refs.usda")
    stage = Usd.Stage.Open(str(path))
    UsdGeom.Xform.Define(stage, "/World/asset").GetPrim().GetReferences().AddReference("./missing_asset.usd")
    stage.Save()
    capfd.readouterr()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = usd.read_stage(path)
    messages = [str(w.message) for w in caught]
    assert len(messages) == 1 and "missing_asset.usd" in messages[0] and "/World/asset" in messages[0], messages
    assert "missing_asset" not in capfd.readouterr().err  # not printed by USD itself
    assert len(scene.description()[0]["meshes"]) == 2  # /World/good and /World/broken


def test_cli_prints_each_stage_warning_on_one_line(tmp_path, capsys):
    path = bad_mesh_stage(tmp_path / "warn.usda")
    stage = Usd.Stage.Open(str(path))
    UsdGeom.NurbsPatch.Define(stage, "/World/dust")
    stage.Save()
    assert cli.main(["render", str(path), "-o", str(tmp_path / "w.png"), "--samples", "1", "--quiet"]) == 0
    err = capsys.readouterr().err.splitlines()
    assert [line for line in err if "warning" in line] == [
        f"polychrome render: warning: {path}: prim /World/dust: prim type 'NurbsPatch' is not supported and is skipped"
    ]


def test_pre_2102_usdlux_attribute_names_are_read(tmp_path):
    """Old stages name light attributes without "inputs:" (intensity, radius, ...)."""
    path = tmp_path / "old.usda"
    path.write_text(
        textwrap.dedent("""\
        #usda 1.0
        (
            metersPerUnit = 1
            upAxis = "Z"
        )
        def SphereLight "bulb"
        {
            float intensity = 40
            float radius = 0
            bool treatAsPoint = 1
            double3 xformOp:translate = (0, 0, 2)
            uniform token[] xformOpOrder = ["xformOp:translate"]
        }
    """)
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = usd.read_stage(path)
    light = scene.lights[0].to_dict()
    assert light["position"] == [0.0, 0.0, 2.0]
    assert light["intensity"]["scale"] == pytest.approx(40.0)  # radius 0, not normalised: the radiant intensity
