"""OpenUSD's own test stages (vendored in tests/data/usd/openusd, Tomorrow Open Source
Technology License 1.0 — OpenUSD's LICENSE.txt beside them) read by read_stage and checked
against what pxr computes from the same stage (XformCache, BBoxCache,
PointInstancer.ComputePointInstanceWorldBounds, Gf.Camera, primvars flattened), against
UsdLux's formulas and against closed forms, never against our own earlier output.

Stage frames: read_stage gives metres, Z up; a stage of metersPerUnit m and up axis Y is
scaled by m and turned +Y onto +Z (Rx(90°), as Blender's importer turns it)."""

import math
import warnings
from pathlib import Path

import numpy as np
import pytest

pxr = pytest.importorskip("pxr")
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade  # noqa: E402

import polychrome as pc  # noqa: E402
from polychrome import usd  # noqa: E402

DATA = Path(__file__).resolve().parent / "data" / "usd" / "openusd"
NO_CAMERA = "the stage has no UsdGeom.Camera"


def read(rel, **kw):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = usd.read_stage(DATA / rel, **kw)
    return scene, [str(w.message) for w in caught]


def to_ours(stage) -> np.ndarray:
    """4 × 4: the stage's frame → read_stage's (metres, Z up)."""
    c = np.eye(4) * UsdGeom.GetStageMetersPerUnit(stage)
    c[3, 3] = 1.0
    if UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.y:
        c = np.array([[1, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]], float) @ c
    return c


def apply(m, p) -> np.ndarray:
    p = np.atleast_2d(np.asarray(p, float))
    return p @ m[:3, :3].T + m[:3, 3]


def pxr_bounds(stage):
    """{name: (lo, hi, exact)} of every drawn gprim as pxr bounds it in the stage's
    frame at the earliest time: the world extent of each gprim (instance proxies
    included) computed from its points or dimensions, and BBoxCache's
    ComputePointInstanceWorldBounds per PointInstancer instance (named
    "<instancer>[i]", read_stage's instance names). ``exact``: a Cube or an
    unsubdivided mesh, whose tessellation fills the bound; other prims (spheres,
    subdivision surfaces) lie inside theirs."""
    time = Usd.TimeCode.EarliestTime()
    cache = UsdGeom.BBoxCache(time, [UsdGeom.Tokens.default_, UsdGeom.Tokens.render])
    out = {}
    it = iter(Usd.PrimRange.Stage(stage, Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)))
    for prim in it:
        img = UsdGeom.Imageable(prim)
        if img and img.ComputeVisibility(time) == UsdGeom.Tokens.invisible:
            it.PruneChildren()
            continue
        if prim.IsA(UsdGeom.PointInstancer):
            pi = UsdGeom.PointInstancer(prim)
            n = len(pi.GetProtoIndicesAttr().Get(time) or [])
            for i, box in enumerate(cache.ComputePointInstanceWorldBounds(pi, list(range(n)))):
                r = box.ComputeAlignedRange()
                out[f"{prim.GetPath()}[{i}]"] = (np.array(r.GetMin()), np.array(r.GetMax()), False)
            it.PruneChildren()
        elif prim.IsA(UsdGeom.Gprim):
            # From the points / radius / size (authored extents may be stale, as
            # subdivTags.usda's plane1's is), in world space.
            world = UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(time)
            lo, hi = UsdGeom.Boundable.ComputeExtentFromPlugins(UsdGeom.Boundable(prim), time, world)
            r = Gf.Range3d(Gf.Vec3d(lo), Gf.Vec3d(hi))
            exact = prim.IsA(UsdGeom.Cube) or (
                prim.IsA(UsdGeom.Mesh) and UsdGeom.Mesh(prim).GetSubdivisionSchemeAttr().Get() == UsdGeom.Tokens.none
            )
            out[str(prim.GetPath())] = (np.array(r.GetMin()), np.array(r.GetMax()), exact)
    return out


def our_bounds(scene):
    """{name: (lo, hi)} of read_stage's instances in world space; a PointInstancer
    instance's gprims ("<instancer>[i]/<gprim>") together under "<instancer>[i]"."""
    desc, buffers = scene.description()
    out = {}
    for inst in desc["instances"]:
        v = np.asarray(buffers[desc["meshes"][inst["mesh"]]["vertices"]], np.float64).reshape(-1, 3)
        w = apply(np.asarray(inst["transform"], float), v)
        name = inst["name"]
        if "]" in name:
            name = name[: name.index("]") + 1]
        lo, hi = w.min(axis=0), w.max(axis=0)
        if name in out:
            lo, hi = np.minimum(out[name][0], lo), np.maximum(out[name][1], hi)
        out[name] = (lo, hi)
    return out


PLACEMENT_STAGES = {
    # scenegraph instancing: instanceable references of a rotated cube set, nested
    "testUsdImagingGLInstancing/nestedInstancedCubes.usda": 12,
    # a PointInstancer inside native instances, its prototype under an `over` (Hydra
    # draws it: UsdImagingDelegate::_GetDisplayPredicateForPrototypes); Y up, cm
    "testUsdImagingGLInstancing/ni_pi.usda": 50,
    # PointInstancer: two prototypes, one of two meshes (one translated), time-sampled
    # xformOps in a prototype
    "testUsdImagingGLPointInstancer/pi_basic.usda": 4,
    # a variant set with an authored selection around a PointInstancer
    "testUsdImagingGLPointInstancer/ni_pi_variant.usda": 2,
    # a payload (the cube is in cubePayload.usda)
    "testUsdGeomBBoxCache/unloadedCubeModel.usda": 1,
    # xformOp:translate / scale on a Cube and a Sphere beside lights
    "testUsdImagingGLUsdLux/usdLux.usda": 2,
    # catmullClark meshes with creases, corners and each interpolateBoundary
    "testUsdImagingGLBasicDrawing/subdivTags.usda": 6,
}


@pytest.mark.parametrize("rel", sorted(PLACEMENT_STAGES))
def test_gprims_and_instances_land_where_pxr_bounds_them(rel):
    """Every gprim pxr draws (instance proxies, PointInstancer instances, payloads,
    variants) is one instance of the scene, whose world bounds equal pxr's (a Cube, an
    unsubdivided mesh) or lie inside them and span more than half of them (a sphere's
    tessellation; a subdivision surface, whose Catmull–Clark points lie in the cage's
    convex hull), within 1e-6 of the stage's size."""
    stage = Usd.Stage.Open(str(DATA / rel))
    want = pxr_bounds(stage)
    c = to_ours(stage)
    scene, _ = read(rel)
    got = our_bounds(scene)
    assert len(want) == PLACEMENT_STAGES[rel]
    assert sorted(got) == sorted(want)
    corners = np.concatenate([np.stack([lo, hi]) for lo, hi, _ in want.values()])
    size = float(np.ptp(apply(c, corners), axis=0).max())
    tol = 1e-6 * size
    for name, (lo, hi, exact) in want.items():
        box = apply(c, np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]))
        plo, phi = box.min(axis=0), box.max(axis=0)
        olo, ohi = got[name]
        if exact:
            assert np.allclose(olo, plo, atol=tol) and np.allclose(ohi, phi, atol=tol), name
        else:
            assert np.all(olo >= plo - tol) and np.all(ohi <= phi + tol), name
            assert np.all(ohi - olo > 0.5 * (phi - plo)), name  # not a point or a sliver


def test_native_instances_share_one_mesh():
    """Scenegraph instancing: the 12 instance-proxy cubes of nestedInstancedCubes are one
    mesh placed 12 times, not 12 copies."""
    scene, _ = read("testUsdImagingGLInstancing/nestedInstancedCubes.usda")
    desc, _ = scene.description()
    assert len(desc["meshes"]) == 1 and len(desc["instances"]) == 12


@pytest.mark.parametrize("rel", ["testUsdImagingGLUsdLux/usdLux.usda", "testUsdImagingGLMaterialXBasic/mxDirectLights.usda"])
def test_sphere_lights_follow_the_usdlux_formulas(rel):
    """Each SphereLight: at pxr's world translation, radiant intensity L·πr² per channel
    with L = intensity · 2^exposure · colour (UsdLux, normalize off) and r the radius in
    metres (metersPerUnit), a sphere light of that radius."""
    stage = Usd.Stage.Open(str(DATA / rel))
    c = to_ours(stage)
    mpu = UsdGeom.GetStageMetersPerUnit(stage)
    scene, caught = read(rel)
    ours = {d["name"]: d for d in (light.to_dict() for light in scene.lights)}
    prims = [p for p in stage.Traverse() if p.IsA(UsdLux.SphereLight)]
    assert prims and len(ours) == len(prims)
    for prim in prims:
        light = UsdLux.SphereLight(prim)
        d = ours[str(prim.GetPath())]
        world = np.array(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(Usd.TimeCode.EarliestTime()))
        assert d["position"] == pytest.approx(apply(c, world[3, :3])[0].tolist(), abs=1e-9)
        intensity = light.GetIntensityAttr().Get() * 2.0 ** light.GetExposureAttr().Get()
        r = light.GetRadiusAttr().Get() * mpu
        assert d["radius"] == pytest.approx(r)
        rgb = np.array(d["intensity"]["rgb"]) * d["intensity"]["scale"]
        want = np.array(light.GetColorAttr().Get()) * intensity * math.pi * r * r
        assert rgb == pytest.approx(want, rel=1e-6, abs=1e-12), prim.GetPath()
    assert all(NO_CAMERA in w for w in caught), caught


def test_animated_camera_matches_gf_camera():
    """cameraMoving.usda (cm, Y up, a translate sampled at times 1–9, read at the earliest):
    the camera sits where pxr's ComputeLocalToWorldTransform puts it at time 1, and its
    fields of view, clipping range, aperture radius (focalLength / 2 fStop) and focus
    distance are Gf.Camera's, in metres."""
    rel = "testUsdImagingGLAnimatedCamera/cameraMoving.usda"
    stage = Usd.Stage.Open(str(DATA / rel))
    prim = stage.GetPrimAtPath("/World/main_cam")
    t = Usd.TimeCode.EarliestTime()
    gf = UsdGeom.Camera(prim).GetCamera(t)
    c = to_ours(stage)
    mpu = UsdGeom.GetStageMetersPerUnit(stage)
    scene, caught = read(rel)
    assert not caught, caught
    cam = scene.description()[0]["camera"]
    world = np.array(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(t)).T  # column vectors
    m = np.asarray(cam["to_world"], float)
    assert m[:3, 3] == pytest.approx(apply(c, world[:3, 3])[0], abs=1e-12)
    turn = c[:3, :3] / mpu @ world[:3, :3]
    assert m[:3, :3] / np.linalg.norm(m[:3, :3], axis=0) == pytest.approx(turn, abs=1e-9)
    h = math.degrees(2 * math.atan(cam["sensor_width"] / (2 * cam["focal_length"])))
    v = math.degrees(2 * math.atan(cam["sensor_height"] / (2 * cam["focal_length"])))
    assert h == pytest.approx(gf.GetFieldOfView(Gf.Camera.FOVHorizontal), rel=1e-6)
    assert v == pytest.approx(gf.GetFieldOfView(Gf.Camera.FOVVertical), rel=1e-6)
    clip = gf.clippingRange
    assert (cam["clip_start"], cam["clip_end"]) == pytest.approx((clip.min * mpu, clip.max * mpu), rel=1e-6)
    # Gf.Camera's focal length is in tenths of a scene unit: a unit is 10 of them.
    assert cam["aperture_radius"] == pytest.approx(gf.focalLength / 10 * mpu / (2 * gf.fStop), rel=1e-6)
    assert cam["focus_distance"] == pytest.approx(gf.focusDistance * mpu, rel=1e-6)


def cage(stage, path):
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath(path))
    counts = np.asarray(mesh.GetFaceVertexCountsAttr().Get())
    holes = set(mesh.GetHoleIndicesAttr().Get() or [])
    return mesh, counts, holes


@pytest.mark.parametrize("rel", ["testUsdImagingGLBasicDrawing/subdivTags.usda", "testUsdImagingGLSubdivisionOsd3/subdivMesh.usda"])
def test_subdivision_face_counts_and_sharp_corners(rel):
    """Catmull–Clark at level L makes n·4^(L−1) quads of an n-gon (2 triangles each),
    holes left out; interpolateBoundary "none" leaves out the cage faces on the boundary
    (OpenSubdiv makes them holes). A vertex of corner sharpness s ≥ L stays on its cage
    point (Sdc: a corner vertex is not moved), as cube3's four corners do."""
    stage = Usd.Stage.Open(str(DATA / rel))
    for level in (1, 2):
        scene, _ = read(rel, subdivision_level=level)
        desc, buffers = scene.description()
        by_name = {m["name"]: m for m in desc["meshes"]}
        for prim in stage.Traverse():
            if not prim.IsA(UsdGeom.Mesh):
                continue
            mesh, counts, holes = cage(stage, prim.GetPath())
            keep = [f for f in range(len(counts)) if f not in holes]
            if mesh.GetInterpolateBoundaryAttr().Get() == UsdGeom.Tokens.none:
                idx = np.asarray(mesh.GetFaceVertexIndicesAttr().Get())
                starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
                edges = {}
                for f, (s, n) in enumerate(zip(starts, counts)):
                    for k in range(n):
                        e = tuple(sorted((idx[s + k], idx[s + (k + 1) % n])))
                        edges.setdefault(e, []).append(f)
                boundary = {fs[0] for fs in edges.values() if len(fs) == 1}
                keep = [f for f in keep if f not in boundary]
            want = 2 * int(sum(counts[f] for f in keep)) * 4 ** (level - 1)
            m = by_name[str(prim.GetPath())]
            assert len(buffers[m["triangles"]]) // 3 == want, (prim.GetPath(), level)
            corners = mesh.GetCornerIndicesAttr().Get()
            if corners:
                sharp = np.asarray(mesh.GetCornerSharpnessesAttr().Get())
                points = np.asarray(mesh.GetPointsAttr().Get(), float)[np.asarray(corners)[sharp >= level]]
                verts = np.asarray(buffers[m["vertices"]], float).reshape(-1, 3)
                for p in points:
                    assert np.min(np.linalg.norm(verts - p, axis=1)) < 1e-6, (prim.GetPath(), p)


def test_varying_primvar_refines_bilinearly():
    """A varying displayColor on a catmullClark mesh (testUsdImagingGLPrimvarRefinement):
    refined once, every refined vertex holds a cage vertex's colour, the mean of an edge's
    two, or the mean of a face's corners (UsdGeom: varying is bilinear over each face), and
    each of those appears; the two loop meshes warn once each, naming them."""
    rel = "testUsdImagingGLPrimvarRefinement/testUsdImagingGLPrimvarRefinement.usda"
    stage = Usd.Stage.Open(str(DATA / rel))
    scene, caught = read(rel, subdivision_level=1)
    loops = [w for w in caught if "'loop'" in w]
    assert sorted(w.split(":")[1].split()[1] for w in loops) == [
        "/Scene/Geom/TriangleMeshVaryingColor",
        "/Scene/Geom/TriangleMeshVertexColor",
    ], caught
    assert all(w in loops or NO_CAMERA in w for w in caught), caught
    path = "/Scene/Geom/QuadMeshVaryingColor"
    mesh, counts, holes = cage(stage, path)
    pv = UsdGeom.PrimvarsAPI(mesh).GetPrimvar("displayColor")
    assert pv.GetInterpolation() == UsdGeom.Tokens.varying
    col = np.asarray(pv.ComputeFlattened(), float)
    idx = np.asarray(mesh.GetFaceVertexIndicesAttr().Get())
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    expect = []
    for f, (s, n) in enumerate(zip(starts, counts)):
        if f in holes:
            continue
        face = idx[s : s + n]
        expect.append(col[face].mean(axis=0))
        for k in range(n):
            expect += [col[face[k]], (col[face[k]] + col[face[(k + 1) % n]]) / 2]
    expect = np.unique(np.round(np.array(expect), 5), axis=0)
    desc, buffers = scene.description()
    m = next(m for m in desc["meshes"] if m["name"] == path)
    got = np.unique(np.round(np.asarray(buffers[m["attributes"]["displayColor"]], float).reshape(-1, 3), 5), axis=0)
    assert len(got) == len(expect) and np.allclose(got, expect, atol=2e-5)


def test_bad_point_instancers_warn_once_each_and_the_stage_reads():
    """pi_bad_schema_input.usda ("we should issue a warning and not add the PI"): an
    instancer without prototypes, one without protoIndices and one without positions are
    skipped with one warning each naming the prim and what is missing; nothing else."""
    scene, caught = read("testUsdImagingGLPointInstancer/pi_bad_schema_input.usda")
    assert not scene.description()[0]["instances"]
    said = [w for w in caught if NO_CAMERA not in w]
    assert len(said) == 3, caught
    for prim, what in (("NoPrototypes", "prototypes"), ("NoProtoIndices", "protoIndices"), ("NoPositions", "positions")):
        (w,) = [w for w in said if f"/BadPointInstancer{prim}:" in w]
        assert f"without {what}" in w


def test_unsupported_triangle_rule_warns_once_naming_the_prim():
    """triangleSubdivisionRule "smooth" (catmark_and_smooth_tris.usda) is read with the
    Catmark rule: one warning naming the prim and the feature; the catmark one is quiet."""
    scene, caught = read("testUsdImagingGLTriangleSubdivisionRuleOsd3/catmark_and_smooth_tris.usda")
    said = [w for w in caught if NO_CAMERA not in w]
    assert len(said) == 1 and "/catmark_smoothtris1" in said[0] and "triangleSubdivisionRule" in said[0], caught
    assert len(scene.description()[0]["meshes"]) == 2


def test_material_interface_names_the_primvar_a_preview_surface_reads(tmp_path):
    """testPreviewSurfaceMaterialInterface.usda: the Material's interface input names the
    primvar ("mydisplayColor", a constant green) its UsdPrimvarReader_float3 feeds into
    diffuseColor. Under a uniform white dome of radiance 1 (a furnace) a convex diffuse
    object's radiance is its albedo: the sphere renders green (the authored diffuseColor
    (1, 0, 0) behind the connection does not show). The Sphere is an intrinsic shape: its
    constant primvars reach the material as on meshes (they were dropped before, silently:
    black)."""
    stage = Usd.Stage.Open(str(DATA / "testUsdImagingGLPreviewSurface/testPreviewSurfaceMaterialInterface.usda"))
    shader = UsdShade.Shader(stage.GetPrimAtPath("/Scene/Looks/Material/Primvar"))
    (src,) = shader.GetInput("varname").GetValueProducingAttributes()
    name = src.Get()
    green = np.array(UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/Scene/Geom/Sphere")).GetPrimvar(name).Get()[0], float)
    wrap = tmp_path / "wrap.usda"
    w = Usd.Stage.CreateNew(str(wrap))
    w.GetRootLayer().subLayerPaths.append(str(DATA / "testUsdImagingGLPreviewSurface/testPreviewSurfaceMaterialInterface.usda"))
    UsdGeom.SetStageUpAxis(w, UsdGeom.Tokens.z)
    cam = UsdGeom.Camera.Define(w, "/Cam")
    cam.CreateProjectionAttr("orthographic")
    cam.CreateHorizontalApertureAttr(8.0)  # tenths of a unit: 0.8 wide, inside the unit sphere
    cam.CreateVerticalApertureAttr(8.0)
    cam.AddTranslateOp().Set(Gf.Vec3d(0, 0, 5))
    dome = UsdLux.DomeLight.Define(w, "/Dome")
    dome.CreateIntensityAttr(1.0)
    w.Save()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = usd.read_stage(wrap)
    assert not caught, [str(x.message) for x in caught]
    out = pc.render(scene, width=8, height=8, samples=64, max_bounces=8, seed=1)
    rgb = out.rgba[..., :3].reshape(-1, 3).mean(axis=0)
    assert name == "mydisplayColor" and green.tolist() == [0.0, 1.0, 0.0]
    # Green: albedo 1 (specular and diffuse together conserve energy); red and blue: the
    # specular layer's Fresnel reflectance of the white dome, F0 = ((1.5 − 1)/(1.5 + 1))²
    # = 0.04 at normal incidence (the view reaches 34° from it).
    assert rgb[1] == pytest.approx(1.0, abs=0.02), rgb
    assert rgb[0] == pytest.approx(0.04, abs=0.01) and rgb[2] == pytest.approx(0.04, abs=0.01), rgb


def test_vendored_stages_carry_the_openusd_licence():
    text = (DATA / "LICENSE.txt").read_text()
    assert "TOMORROW OPEN SOURCE TECHNOLOGY LICENSE 1.0" in text
    assert (DATA / "README.md").exists() and (DATA / "NOTICE.txt").exists()
    assert Sdf.Layer.FindOrOpen(str(DATA / "testUsdImagingGLUsdLux/usdLux.usda"))


def srgb_decode(c):
    c = np.asarray(c, float) / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


@pytest.mark.parametrize("up", ["Zup", "Yup"])
@pytest.mark.parametrize("camera", ["Front", "Back"])
def test_dome_texture_faces_the_camera_as_in_hydra(tmp_path, up, camera):
    """testUsdImagingGLDomeLight: the same scene on a Z-up stage (its dome turned by
    rotateX 90) and a Y-up one, seen by a front and a back camera (rotateZ 180). The
    background is the dome's latlong texel in the view direction by OpenEXR's convention
    (ImfEnvmap: u = ½ − atan2(x, z)/2π, v = ½ − latitude/π from the top, +Y up, in the
    dome's frame from pxr's transforms), sRGB-decoded: red, magenta, cyan and blue, the
    colours Storm's baselines show (testUsdImagingGLDomeLight_{Z,Y}up{Front,Back}.png)."""
    from PIL import Image

    rel = f"testUsdImagingGLDomeLight/domeLight{up}.usda"
    src = Usd.Stage.Open(str(DATA / rel))
    wrap = tmp_path / "wrap.usda"
    w = Usd.Stage.CreateNew(str(wrap))
    w.GetRootLayer().subLayerPaths.append(str(DATA / rel))
    UsdGeom.SetStageUpAxis(w, UsdGeom.GetStageUpAxis(src))
    if camera == "Back":
        w.OverridePrim("/Scene/FrontCamera").SetActive(False)
    w.Save()
    t = Usd.TimeCode.EarliestTime()
    cam = np.array(UsdGeom.Xformable(src.GetPrimAtPath(f"/Scene/{camera}Camera")).ComputeLocalToWorldTransform(t))
    dome = np.array(UsdGeom.Xformable(src.GetPrimAtPath("/Scene/lights/DomeLight")).ComputeLocalToWorldTransform(t))
    view = np.array([0.0, 0.0, -1.0]) @ cam[:3, :3]  # row vectors
    x, y, z = view @ np.linalg.inv(dome[:3, :3])
    u = 0.5 - math.atan2(x, z) / (2 * math.pi)
    v = 0.5 - math.asin(y / math.sqrt(x * x + y * y + z * z)) / math.pi
    tex = np.asarray(Image.open(DATA / "testUsdImagingGLDomeLight/testImage.png").convert("RGB"))
    want = srgb_decode(tex[round(v * (tex.shape[0] - 1)), round(u * (tex.shape[1] - 1)) % tex.shape[1]])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = usd.read_stage(wrap, resolution=(32, 24))
    assert not caught, [str(c.message) for c in caught]
    rgb = pc.render(scene, width=32, height=24, samples=16, max_bounces=4, seed=1).rgba[..., :3]
    corners = np.concatenate([rgb[:3, :3], rgb[:3, -3:], rgb[-3:, :3], rgb[-3:, -3:]]).reshape(-1, 3)
    named = {"Zup": {"Front": (1, 0, 0), "Back": (1, 0, 1)}, "Yup": {"Front": (0, 0.86, 1), "Back": (0, 0, 1)}}[up][camera]
    assert want == pytest.approx(named, abs=0.01)
    assert corners.mean(axis=0) == pytest.approx(want, abs=0.02), (corners.mean(axis=0), want)


def pxr_nested_instances(stage):
    """[(gprim path, 4 × 4 row-vector world matrix in the stage's frame)] of every gprim
    that PointInstancers (nested in prototypes or not) place, composed by hand from pxr:
    per level, ComputeInstanceTransformsAtTime (prototype root transform included) times
    the gprim's (or inner instancer's) transform relative to its prototype root times the
    instancer's own placement (XformCache for the outermost)."""
    time = Usd.TimeCode.EarliestTime()
    cache = UsdGeom.XformCache(time)
    out = []

    def place(prim, parents):
        pi = UsdGeom.PointInstancer(prim)
        protos = pi.GetPrototypesRel().GetTargets()
        for m, p in zip(pi.ComputeInstanceTransformsAtTime(time, time), pi.GetProtoIndicesAttr().Get(time)):
            root = stage.GetPrimAtPath(protos[p])
            root_inv = cache.GetLocalToWorldTransform(root).GetInverse()
            it = iter(Usd.PrimRange(root))
            for sub in it:
                rel = cache.GetLocalToWorldTransform(sub) * root_inv
                worlds = [rel * m * parent for parent in parents]
                if sub.IsA(UsdGeom.PointInstancer):
                    place(sub, worlds)
                    it.PruneChildren()
                elif sub.IsA(UsdGeom.Gprim):
                    out.extend((str(sub.GetPath()), np.array(w)) for w in worlds)

    it = iter(Usd.PrimRange.Stage(stage))
    for prim in it:
        if prim.IsA(UsdGeom.PointInstancer):
            place(prim, [cache.GetLocalToWorldTransform(prim)])
            it.PruneChildren()
    return out


def test_nested_point_instancers_compose_every_level_as_pxr_does():
    """pi_pi.usda: PointInstancers whose prototypes hold PointInstancers (a prototype that
    references /Cube, which instances 3 cubes), under rotated instances, translated Xforms
    and beside plain ones. Every cube of read_stage's scene is one instance whose transform
    is pxr's per-level ComputeInstanceTransformsAtTime composed by hand, and the cubes of each
    outermost instancer fill its authored extent (written by OpenUSD, in its own frame)."""
    rel = "testUsdImagingGLPointInstancer/pi_pi.usda"
    stage = Usd.Stage.Open(str(DATA / rel))
    c = to_ours(stage)
    want = pxr_nested_instances(stage)
    scene, caught = read(rel)
    assert [w for w in caught if NO_CAMERA not in w] == []
    desc, buffers = scene.description()
    got = [(i["name"], np.asarray(i["transform"], float)) for i in desc["instances"]]
    assert len(got) == len(want) == 24  # 5 outer instancers × 3 nested cubes + 3 plain × 3
    key = lambda m: tuple(np.round(m, 6).ravel())  # noqa: E731
    ours = sorted((key(m) for _, m in got))
    theirs = sorted(key(c @ m.T) for _, m in want)  # row vectors → ours (columns, metres)
    assert np.allclose(np.array(ours), np.array(theirs), atol=1e-9)
    # Authored extents: the union of each outermost instancer's cubes in its own frame.
    cube = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    time = Usd.TimeCode.EarliestTime()
    for prim in stage.Traverse():
        outer = prim.GetPath().GetPrefixes()[:-1]
        if not prim.IsA(UsdGeom.PointInstancer) or any(stage.GetPrimAtPath(q).IsA(UsdGeom.PointInstancer) for q in outer):
            continue
        to_local = np.linalg.inv(c @ np.array(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(time)).T)
        pts = np.concatenate([apply(to_local @ m, cube) for n, m in got if n.startswith(f"{prim.GetPath()}[")])
        lo, hi = np.array(UsdGeom.Boundable(prim).GetExtentAttr().Get(time), float)
        assert np.allclose(pts.min(axis=0), lo, atol=2e-3) and np.allclose(pts.max(axis=0), hi, atol=2e-3), prim.GetPath()


def test_nested_point_instancer_under_prototype_xforms_lands_at_its_closed_form():
    """pi_pi_xform.usda: an instancer inside an Xform inside the outer instancer's
    prototype root, each translated: Yellow sits at (−1, −1, 0) + its points, Blue at
    (−10, −10, 0) +, Green (inner prototype (10, 0, 0) + middle (−9, −9, 0) + outer root
    (−1, −1, 0)) at (0, −10, 0) +, Red as authored (Y up, centimetres)."""
    rel = "testUsdImagingGLPointInstancer/pi_pi_xform.usda"
    stage = Usd.Stage.Open(str(DATA / rel))
    c = to_ours(stage)
    scene, caught = read(rel)
    assert [w for w in caught if NO_CAMERA not in w] == []
    by_leaf = {name.rsplit("/", 1)[1]: name for name in (i["name"] for i in scene.description()[0]["instances"])}
    assert sorted(by_leaf) == ["Blue", "Green", "Red", "Yellow"]
    want = {
        "Yellow": ([-1, -1, 1], [1, 1, 1]),
        "Blue": ([-10, -10, 0], [0, 10, 0]),
        "Green": ([0, -10, 0], [10, 10, 0]),
        "Red": ([-10, 0, 0], [10, 10, 0]),
    }
    desc, buffers = scene.description()
    for inst in desc["instances"]:
        leaf = inst["name"].rsplit("/", 1)[1]
        v = np.asarray(buffers[desc["meshes"][inst["mesh"]]["vertices"]], np.float64).reshape(-1, 3)
        w = apply(np.linalg.inv(c) @ np.asarray(inst["transform"], float), v)  # back to the stage's frame
        assert np.allclose(w.min(axis=0), want[leaf][0], atol=1e-5) and np.allclose(w.max(axis=0), want[leaf][1], atol=1e-5), leaf


def test_points_and_curves_with_a_malformed_prim_skip_only_it():
    """testUsdGeomBBoxCache/pointsAndCurves.usda: its ErrorPrims/invalidNumWidthsAndPoints
    (2 widths for 3 points) is skipped with one warning naming it and its widths (it raised
    for the whole stage before); every other drawn Points and BasisCurves prim is read, and
    those with authored widths lie inside pxr's extent (ComputeExtentFromPlugins, widths
    included) spanning more than half of it."""
    rel = "testUsdGeomBBoxCache/pointsAndCurves.usda"
    stage = Usd.Stage.Open(str(DATA / rel))
    c = to_ours(stage)
    scene, caught = read(rel)
    said = [w for w in caught if NO_CAMERA not in w]
    assert len(said) == 1 and "prim /ErrorPrims/invalidNumWidthsAndPoints: widths has 2 values" in said[0], caught
    got = our_bounds(scene)
    time = Usd.TimeCode.EarliestTime()
    drawn = set()
    for prim in stage.Traverse():
        if not prim.IsA(UsdGeom.Gprim) or prim.GetName() == "invalidNumWidthsAndPoints":
            continue
        pts = prim.GetAttribute("points").Get(time) if prim.HasAttribute("points") else None
        if prim.IsA(UsdGeom.PointBased) and not pts:
            continue  # nothing to draw
        drawn.add(str(prim.GetPath()))
        widths = prim.GetAttribute("widths")
        if not (widths and widths.HasAuthoredValue()):
            continue
        world = UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(time)
        lo, hi = UsdGeom.Boundable.ComputeExtentFromPlugins(UsdGeom.Boundable(prim), time, world)
        box = apply(c, np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]))
        plo, phi = box.min(axis=0), box.max(axis=0)
        olo, ohi = got[str(prim.GetPath())]
        # tubes and spheres are polygons of the circle's area: their corners reach a few % past it
        tol = 0.05 * max(widths.Get(time)) * UsdGeom.GetStageMetersPerUnit(stage)
        assert np.all(olo >= plo - tol) and np.all(ohi <= phi + tol), prim.GetPath()
        assert np.all(ohi - olo >= 0.5 * (phi - plo)), prim.GetPath()
    assert sorted(got) == sorted(drawn)
