"""Malformed prims (bad array lengths, NaN points, out-of-range indices, topology without
points or points without topology, non-finite light values, bad JSON, malformed materials) are skipped with one warning each naming the prim
and the problem; the rest of the stage renders as its closed form says."""

import math
import re
import warnings

import numpy as np
import pytest

pxr = pytest.importorskip("pxr")
from pxr import Gf, Sdf, UsdGeom, UsdLux, UsdShade, Vt  # noqa: E402

import polychrome as pc  # noqa: E402
from polychrome import usd  # noqa: E402
from test_usd import new_stage, top_camera  # noqa: E402

RHO = 0.5  # the good floor's displayColor
E = math.pi  # the sun's irradiance: the floor's radiance is RHO E / π = RHO


def read(path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = usd.read_stage(path)
    return scene, [str(w.message) for w in caught]


def quad(stage, path, half, z=0.0, colour=(RHO, RHO, RHO)):
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr([(-half, -half, z), (half, -half, z), (half, half, z), (-half, half, z)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    mesh.CreateSubdivisionSchemeAttr("none")
    mesh.CreateDisplayColorAttr([Gf.Vec3f(*colour)])
    return mesh


def sun(stage):
    """Straight down; with normalize its irradiance is its intensity E (UsdLux)."""
    light = UsdLux.DistantLight.Define(stage, "/sun")
    light.CreateIntensityAttr(E)
    light.CreateNormalizeAttr(True)


def bad_mesh(stage, path, points=None, counts=(3,), indices=(0, 1, 2)):
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr(points or [(0, 0, 0.5), (0.1, 0, 0.5), (0, 0.1, 0.5)])
    mesh.CreateFaceVertexCountsAttr(list(counts))
    mesh.CreateFaceVertexIndicesAttr(list(indices))
    mesh.CreateSubdivisionSchemeAttr("none")
    mesh.CreateDisplayColorAttr([Gf.Vec3f(1, 0, 0)])  # red: seen if it were not skipped
    return mesh


#: prim → the problem its warning names.
BAD = {
    "/bad/nanPoint": r"point 1 is not finite",
    "/bad/indexOut": r"faceVertexIndices\[2\] = 9 is out of range",
    "/bad/countsShort": r"faceVertexCounts add up to 4 but there are 3 faceVertexIndices",
    "/bad/noIndices": r"it has points, faceVertexCounts but no faceVertexIndices",
    "/bad/curveNoCounts": r"it has points but no curveVertexCounts",
    "/bad/subset": r"/bad/subset/s: face index 5 is out of range",
    "/bad/curveWidths": r"widths has 2 values for vertex interpolation; expected 4",
    "/bad/curveCounts": r"curveVertexCounts add up to 5 but there are 4 points",
    "/bad/hermite": r"tangents has 1 values; expected 2",
    "/bad/pointsWidths": r"widths has 2 values for vertex interpolation; expected 3",
    "/bad/nanXform": r"its transform is not finite",
    "/bad/farMesh": r"vertex 1 has a coordinate 1e\+13 beyond ±1e\+12",
    "/bad/farXform": r"its transform places vertices beyond ±1e\+12",
    "/bad/flat": r"its transform is singular \(zero scale\?\)",
    r"/bad/instancerFlat\[0\]": r"its transform is singular \(zero scale\?\)(?=; it is skipped \(and 1 more of its instances\))",
    "/bad/unknownType": r"a value of an unusable type",
    "/bad/negativeBulb": r"its intensity × 2\^exposure -2 is negative",
    "/bad/instancer": r"protoIndices\[1\] = 3 is out of range",
    "/bad/instancerNaN": r"its instance positions, orientations or scales are not finite",
    "/bad/instancerProto": r"prototype /bad/nothere does not exist",
    "/bad/bulb": r"its intensity, exposure or colour is not finite",
    "/bad/rect": r"its width or height is not finite",
    "/bad/sun": r"its angle is not finite",
    "/bad/json": r"polychrome:light is not valid JSON",
    "/bad/dome": r"polychrome:radiance:wavelengths must be ascending",
}


def bad_stage(path):
    stage = new_stage(path)
    quad(stage, "/good", 0.5)
    top_camera(stage, "/cam", 2.0, 1.0)
    sun(stage)
    bad_mesh(stage, "/bad/nanPoint", points=[(0, 0, 0.5), (float("nan"), 0, 0.5), (0, 0.1, 0.5)])
    bad_mesh(stage, "/bad/indexOut", indices=(0, 1, 9))
    bad_mesh(stage, "/bad/countsShort", counts=(4,))
    bad_mesh(stage, "/bad/noIndices").GetFaceVertexIndicesAttr().Clear()
    c = UsdGeom.BasisCurves.Define(stage, "/bad/curveNoCounts")
    c.CreatePointsAttr([(0, 0, 0.5), (0.1, 0, 0.5)])
    UsdGeom.Mesh.Define(stage, "/quiet/empty")  # nothing authored: nothing to draw, no warning
    UsdGeom.BasisCurves.Define(stage, "/quiet/emptyCurves")
    m = bad_mesh(stage, "/bad/subset")
    mat = UsdShade.Material.Define(stage, "/Looks/m")
    sub = UsdShade.MaterialBindingAPI.Apply(m.GetPrim()).CreateMaterialBindSubset("s", Vt.IntArray([0, 5]), UsdGeom.Tokens.face)
    UsdShade.MaterialBindingAPI.Apply(sub.GetPrim()).Bind(mat)
    c = UsdGeom.BasisCurves.Define(stage, "/bad/curveWidths")
    c.CreateTypeAttr("linear")
    c.CreatePointsAttr([(0, 0, 0.5), (0.1, 0, 0.5), (0.2, 0, 0.5), (0.3, 0, 0.5)])
    c.CreateCurveVertexCountsAttr([4])
    c.CreateWidthsAttr([0.1, 0.2])  # pointsAndCurves.usda's malformation, on curves
    c = UsdGeom.BasisCurves.Define(stage, "/bad/curveCounts")
    c.CreatePointsAttr([(0, 0, 0.5), (0.1, 0, 0.5), (0.2, 0, 0.5), (0.3, 0, 0.5)])
    c.CreateCurveVertexCountsAttr([5])
    h = UsdGeom.HermiteCurves.Define(stage, "/bad/hermite")
    h.CreatePointsAttr([(0, 0, 0.5), (0.1, 0, 0.5)])
    h.CreateCurveVertexCountsAttr([2])
    h.CreateTangentsAttr([(1, 0, 0)])
    p = UsdGeom.Points.Define(stage, "/bad/pointsWidths")
    p.CreatePointsAttr([(0, 0, 0.5), (0.1, 0, 0.5), (0.2, 0, 0.5)])
    p.CreateWidthsAttr([0.1, 0.2])  # OpenUSD's pointsAndCurves.usda invalidNumWidthsAndPoints
    UsdGeom.Cube.Define(stage, "/bad/nanXform").AddTranslateOp().Set(Gf.Vec3d(0, float("nan"), 0))
    bad_mesh(stage, "/bad/farMesh", points=[(0, 0, 0.5), (1e13, 0, 0.5), (0, 0.1, 0.5)])  # the core's limit: ±1e12
    UsdGeom.Cube.Define(stage, "/bad/farXform").AddTranslateOp().Set(Gf.Vec3d(0, 0, 2e12))
    UsdGeom.Cube.Define(stage, "/bad/flat").AddScaleOp().Set(Gf.Vec3f(1, 0, 1))
    light = UsdLux.SphereLight.Define(stage, "/bad/negativeBulb")
    light.CreateIntensityAttr(-1.0)
    light.CreateExposureAttr(1.0)
    UsdGeom.Cube.Define(stage, "/protos/box").CreateSizeAttr(0.1)
    for name, indices, positions, protos in (
        ("instancer", [0, 3], [(0, 0, 0.5), (0.2, 0, 0.5)], ["/protos/box"]),
        ("instancerNaN", [0, 0], [(0, 0, 0.5), (float("inf"), 0, 0.5)], ["/protos/box"]),
        ("instancerProto", [0], [(0, 0, 0.5)], ["/bad/nothere"]),
        ("instancerFlat", [0, 0], [(0, 0, 0.5), (0.2, 0, 0.5)], ["/protos/box"]),
    ):
        pi = UsdGeom.PointInstancer.Define(stage, f"/bad/{name}")
        pi.CreatePrototypesRel().SetTargets([Sdf.Path(t) for t in protos])
        pi.CreateProtoIndicesAttr(indices)
        pi.CreatePositionsAttr(positions)
        if name == "instancerFlat":  # both instances squashed flat: one warning for the two
            pi.CreateScalesAttr([(1, 1, 0), (0, 1, 1)])
    stage.OverridePrim("/protos").SetSpecifier(Sdf.SpecifierOver)  # drawn only through instancers
    UsdLux.SphereLight.Define(stage, "/bad/bulb").CreateIntensityAttr(float("inf"))
    UsdLux.RectLight.Define(stage, "/bad/rect").CreateWidthAttr(float("nan"))
    UsdLux.DistantLight.Define(stage, "/bad/sun").CreateAngleAttr(float("nan"))
    bulb = UsdLux.SphereLight.Define(stage, "/bad/json")
    bulb.GetPrim().CreateAttribute("polychrome:light", Sdf.ValueTypeNames.String).Set("{nope")
    dome = UsdLux.DomeLight.Define(stage, "/bad/dome").GetPrim()
    dome.CreateAttribute("polychrome:radiance:wavelengths", Sdf.ValueTypeNames.DoubleArray).Set([500.0, 400.0])
    dome.CreateAttribute("polychrome:radiance:values", Sdf.ValueTypeNames.DoubleArray).Set([1.0, 1.0])
    # A value of a type USD does not know (pxr reads it as an UnregisteredValue, as a typo in
    # a hand-edited .usda gives), from a sublayer: the API cannot author it.
    (path.parent / "unknown.usda").write_text(
        '#usda 1.0\nover "bad"\n{\n    def Mesh "unknownType"\n    {\n        int[] faceVertexCounts = [3]\n'
        "        int[] faceVertexIndices = [0, 1, 2]\n        poynt3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n    }\n}\n"
    )
    stage.GetRootLayer().subLayerPaths.append("./unknown.usda")
    stage.Save()
    return stage


def test_each_bad_prim_is_skipped_with_one_warning_and_the_good_floor_renders_its_closed_form(tmp_path):
    path = tmp_path / "bad.usda"
    bad_stage(path)
    scene, warns = read(path)
    for prim, problem in BAD.items():
        hits = [w for w in warns if re.search(rf"bad\.usda: prim {prim}: {problem}.*; it is skipped", w)]
        assert len(hits) == 1, (prim, warns)
    # nothing else is warned, and no warning names a prim twice
    assert len(warns) == len(BAD), warns
    desc, buffers = scene.description()
    # only the good floor is left, with its authored corners; only the good sun lights it
    assert [i["name"] for i in desc["instances"]] == ["/good"]
    v = np.asarray(buffers[desc["meshes"][desc["instances"][0]["mesh"]]["vertices"]], np.float64).reshape(-1, 3)
    assert v.min(axis=0).tolist() == [-0.5, -0.5, 0.0] and v.max(axis=0).tolist() == [0.5, 0.5, 0.0]
    assert [light.to_dict()["type"] for light in scene.lights] == ["distant"]
    assert scene.world is None and scene.world_texture is None
    result = pc.render(scene, width=8, height=8, samples=16, max_bounces=1, seed=1)
    rgb = result.rgba[..., :3]
    # a diffuse of albedo RHO under irradiance E straight down: radiance RHO E / π per channel
    assert rgb.mean(axis=(0, 1)) == pytest.approx([RHO * E / math.pi] * 3, rel=0.01)
    assert float(rgb.std()) < 0.01  # no red stray, no hole


def test_a_malformed_material_falls_back_to_grey_with_one_warning(tmp_path):
    """A Material whose polychrome:bsdf:extra is not JSON: UsdPreviewSurface's fallback
    (0.18 grey diffuse), one warning naming it; the mesh bound to it still renders."""
    path = tmp_path / "mat.usda"
    stage = new_stage(path)
    mesh = quad(stage, "/good", 0.5)
    mat = UsdShade.Material.Define(stage, "/Looks/broken")
    mat.GetPrim().CreateAttribute("polychrome:bsdf", Sdf.ValueTypeNames.Token).Set("diffuse")
    mat.GetPrim().CreateAttribute("polychrome:bsdf:extra", Sdf.ValueTypeNames.String).Set("[1, 2")
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(mat)
    top_camera(stage, "/cam", 2.0, 1.0)
    sun(stage)
    stage.Save()
    scene, warns = read(path)
    assert len(warns) == 1 and re.search(r"prim /Looks/broken: .*; UsdPreviewSurface's fallback 0.18 grey is used", warns[0]), warns
    result = pc.render(scene, width=4, height=4, samples=16, max_bounces=1, seed=1)
    assert result.rgba[..., :3].mean(axis=(0, 1)) == pytest.approx([0.18] * 3, rel=0.01)


def test_bad_render_settings_values_are_ignored_with_a_warning(tmp_path):
    from pxr import UsdRender

    path = tmp_path / "settings.usda"
    stage = new_stage(path)
    quad(stage, "/good", 0.5)
    top_camera(stage, "/cam", 2.0, 1.0)
    rs = UsdRender.Settings.Define(stage, "/Render/s")
    rs.CreateResolutionAttr(Gf.Vec2i(0, 10))
    rs.CreateCameraRel().SetTargets([Sdf.Path("/nocam")])
    rs.GetPrim().CreateAttribute("polychrome:time_limit", Sdf.ValueTypeNames.Double).Set(float("nan"))
    stage.Save()
    scene, warns = read(path)
    assert len([w for w in warns if "prim /Render/s: resolution" in w and "is ignored" in w]) == 1, warns
    assert len([w for w in warns if "camera /nocam is not a UsdGeom.Camera; the stage's first camera is used" in w]) == 1, warns
    assert scene.camera.to_dict()["projection"] == "ORTHOGRAPHIC"  # /cam
    assert "time_limit" not in usd.read_settings(path) and "width" not in usd.read_settings(path)


def test_malformed_normals_and_uvs_are_dropped_and_the_mesh_renders(tmp_path):
    """Optional data that is malformed — normals of the wrong count or of a non-array
    type (usd-wg's normalsTypes.usda authors `point3f normals = (0, 0, 1)` and
    `int normals = 7`; Storm draws those meshes), uvs of the wrong count, a displayColor
    that is no array of colours — is dropped with one warning per prim naming it; the mesh
    renders (flat shaded) its closed form."""
    path = tmp_path / "optional.usda"
    stage = new_stage(path)
    quads = {}
    for k, name in enumerate(("count", "scalar", "int", "st")):
        quads[name] = quad(stage, f"/{name}", 0.25)
        quads[name].AddTranslateOp().Set(Gf.Vec3d(-0.25 + 0.5 * (k % 2), -0.25 + 0.5 * (k // 2), 0))  # 2 × 2: the whole view
    quads["count"].CreateNormalsAttr([(0, 0, 1), (0, 0, 1)])
    quads["st"].GetPrim().RemoveProperty("primvars:displayColor")  # authored below as 2 floats

    quads["st"].GetPrim().CreateAttribute("primvars:st", Sdf.ValueTypeNames.TexCoord2fArray).Set([(0, 0)])
    UsdGeom.Primvar(quads["st"].GetPrim().GetAttribute("primvars:st")).SetInterpolation(UsdGeom.Tokens.faceVarying)
    top_camera(stage, "/cam", 2.0, 1.0)
    sun(stage)
    stage.Save()
    text = path.read_text()
    for name, line in (
        ("scalar", "point3f normals = (0, 0, 1)"),
        ("int", "int normals = 7"),
        ("st", "float[] primvars:displayColor = [0.5, 0.5]"),
    ):
        text = text.replace(f'def Mesh "{name}"\n{{\n', f'def Mesh "{name}"\n{{\n    {line}\n', 1)
    edited = tmp_path / "edited.usda"  # a new layer: the saved one stays open, unedited, in USD's registry
    edited.write_text(text)
    scene, warns = read(edited)
    want = {
        "/count": r"normals has 2 values for vertex interpolation; expected 4; its normals are ignored",
        "/scalar": r"normals has 1 values for vertex interpolation; expected 4; its normals are ignored",
        "/int": r"a value of an unusable type .*; its normals are ignored",
        "/st": r"primvars:st has 1 values for faceVarying interpolation; expected 4; its primvars:st are ignored",
        "/st: displayColor": r"is not an array of 3-value items; it is ignored",
    }
    for prim, problem in want.items():
        assert len([w for w in warns if re.search(rf"prim {prim}:? {problem}", w)]) == 1, (prim, warns)
    assert len(warns) == len(want), warns
    desc, _ = scene.description()
    assert sorted(i["name"] for i in desc["instances"]) == ["/count", "/int", "/scalar", "/st"]
    assert all(m.get("normals") is None and m.get("uvs") is None for m in desc["meshes"])
    rgb = pc.render(scene, width=8, height=8, samples=16, max_bounces=1, seed=1).rgba[..., :3]
    # three quads of albedo RHO, /st's of UsdPreviewSurface's fallback 0.18 (its displayColor dropped)
    assert rgb.mean(axis=(0, 1)) == pytest.approx([(3 * RHO + 0.18) / 4 * E / math.pi] * 3, rel=0.01)
