"""UsdLux lights read by polychrome.usd against the spec's closed forms.

UsdLux (LightAPI, "Quantities"): the radiance is L = intensity × 2^exposure × colour
(× the colour temperature's colour when enabled); ``normalize`` divides it by the light's
world-space surface area (a distant light's intensity is then the irradiance). A sphere of
radiance L and radius r has radiant intensity L·πr²; a sun disk of angular diameter θ gives
irradiance L·π·sin²(θ/2). Stages written by Blender (layer doc "Blender v…") store a sun
of strength S and angle θ as intensity S/4 and angle θ/2, which Blender's importer undoes.
"""

import math
import warnings

import numpy as np
import pytest

pxr = pytest.importorskip("pxr")
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux  # noqa: E402

import polychrome as pc  # noqa: E402
from polychrome import usd  # noqa: E402
from conftest import luminance  # noqa: E402
from test_usd import floor_mesh, new_stage, preview_material, top_camera  # noqa: E402


def read(path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = usd.read_stage(path)
    return scene, [str(w.message) for w in caught]


def lights_by_name(scene):
    return {d["name"]: d for d in (light.to_dict() for light in scene.lights)}


@pytest.mark.parametrize(
    "normalize, radius, scale, want",
    [
        (True, 0.5, 1.0, 10.0 * 2.0 / 4.0),  # L = I/(4πr²): πr²L = I/4, any radius
        (False, 0.5, 1.0, 10.0 * 2.0 * math.pi * 0.25),  # πr²·I
        (False, 0.0, 1.0, 10.0 * 2.0),  # zero radius: the intensity is the radiant intensity
        (False, 0.5, 2.0, 10.0 * 2.0 * math.pi * 1.0),  # the transform doubles the radius
        (True, 0.5, 2.0, 10.0 * 2.0 / 4.0),
    ],
)
def test_sphere_light_radiant_intensity_follows_usdlux(tmp_path, normalize, radius, scale, want):
    path = tmp_path / "sphere.usda"
    stage = new_stage(path)
    light = UsdLux.SphereLight.Define(stage, "/bulb")
    light.CreateIntensityAttr(10.0)
    light.CreateExposureAttr(1.0)
    light.CreateRadiusAttr(radius)
    light.CreateNormalizeAttr(normalize)
    light.AddTranslateOp().Set(Gf.Vec3d(0, 0, 2))
    light.AddScaleOp().Set(Gf.Vec3f(scale, scale, scale))
    stage.Save()
    scene, _ = read(path)
    d = lights_by_name(scene)["/bulb"]
    assert d["type"] == "point" and d["position"] == pytest.approx([0, 0, 2])
    assert d["intensity"]["type"] == "rgb" and d["intensity"]["rgb"] == [1.0, 1.0, 1.0]
    assert d["intensity"]["scale"] == pytest.approx(want, rel=1e-6)


def test_colour_temperature_multiplies_the_colour(tmp_path):
    """enableColorTemperature: colour × the temperature's colour (colour-science: Planck's
    law through CIE 1931, linear Rec.709, luminance 1), not the temperature alone."""
    colour = pytest.importorskip("colour")
    path = tmp_path / "warm.usda"
    stage = new_stage(path)
    light = UsdLux.SphereLight.Define(stage, "/warm")
    light.CreateIntensityAttr(3.0)
    light.CreateRadiusAttr(0.0)
    light.CreateColorAttr(Gf.Vec3f(1.0, 0.5, 0.25))
    light.CreateEnableColorTemperatureAttr(True)
    light.CreateColorTemperatureAttr(3000.0)
    stage.Save()
    scene, warns = read(path)
    d = lights_by_name(scene)["/warm"]["intensity"]
    shape = colour.SpectralShape(380, 780, 5)
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(shape)
    xyz = np.trapz(cmfs.values * colour.sd_blackbody(3000.0, shape).values[:, None], axis=0)
    xyz /= xyz[1]  # luminance 1
    rgb = colour.XYZ_to_RGB(xyz, colour.RGB_COLOURSPACES["sRGB"], apply_cctf_encoding=False)
    want = 3.0 * np.array([1.0, 0.5, 0.25]) * rgb
    assert d["type"] == "rgb"
    assert np.allclose(np.array(d["rgb"]) * d["scale"], want, rtol=0.01), (d, want)
    assert not [w for w in warns if "tint" in w]


def blender_layer(path):
    """A stage whose root layer says Blender wrote it, as usd_export does."""
    stage = new_stage(path)
    stage.GetRootLayer().documentation = "Blender v4.5.15 LTS"
    return stage


@pytest.mark.parametrize(
    "blender, normalize, intensity, angle, want",
    [
        (False, True, 2.0, 10.0, 2.0),  # normalised: the intensity is the irradiance
        (False, False, 50.0, 10.0, 50.0 * math.pi * math.sin(math.radians(5.0)) ** 2),
        (False, False, 3.0, 0.0, 3.0),  # zero angle: the intensity is the irradiance
        (True, True, 0.5, 5.0, 2.0),  # Blender: strength 4·0.5
        (True, False, 25.0, 5.0, 100.0 * math.pi * math.sin(math.radians(5.0)) ** 2),  # strength 100, angle 10°
    ],
)
def test_distant_light_irradiance_spec_and_blender_conventions(tmp_path, blender, normalize, intensity, angle, want):
    path = tmp_path / "sun.usda"
    stage = blender_layer(path) if blender else new_stage(path)
    sun = UsdLux.DistantLight.Define(stage, "/sun")
    sun.CreateIntensityAttr(intensity)
    sun.CreateAngleAttr(angle)
    sun.CreateNormalizeAttr(normalize)
    stage.Save()
    scene, _ = read(path)
    d = lights_by_name(scene)["/sun"]
    assert d["type"] == "distant" and d["direction"] == pytest.approx([0, 0, -1])
    assert d["irradiance"]["scale"] == pytest.approx(want, rel=1e-6)


def test_blender_convention_follows_the_layer_of_a_referenced_asset(tmp_path):
    """A Blender-exported asset referenced into a foreign stage keeps Blender's sun."""
    asset = tmp_path / "asset.usda"
    stage = blender_layer(asset)
    UsdGeom.Xform.Define(stage, "/root")
    sun = UsdLux.DistantLight.Define(stage, "/root/sun")
    sun.CreateIntensityAttr(0.5)
    sun.CreateNormalizeAttr(True)
    stage.SetDefaultPrim(stage.GetPrimAtPath("/root"))
    stage.Save()
    shot = tmp_path / "shot.usda"
    stage = new_stage(shot)
    stage.DefinePrim("/asset").GetReferences().AddReference(str(asset))
    own = UsdLux.DistantLight.Define(stage, "/own")
    own.CreateIntensityAttr(0.5)
    own.CreateNormalizeAttr(True)
    stage.Save()
    scene, _ = read(shot)
    lights = {n: d["irradiance"]["scale"] for n, d in lights_by_name(scene).items()}
    assert lights == {"/asset/sun": pytest.approx(2.0), "/own": pytest.approx(0.5)}


def test_unnormalised_sun_disk_renders_its_closed_form_irradiance(tmp_path):
    """A diffuse floor of albedo ρ under a DistantLight (normalize off, angle θ, straight
    down): radiance ρ/π · I·π·sin²(θ/2)."""
    rho, intensity, angle = 0.5, 400.0, 8.0
    path = tmp_path / "sunfloor.usda"
    stage = new_stage(path)
    floor_mesh(stage, "/floor", 5.0, preview_material(stage, "/Looks/grey", (rho, rho, rho)))
    top_camera(stage, "/cam", 1.0, 0.2)
    sun = UsdLux.DistantLight.Define(stage, "/sun")
    sun.CreateIntensityAttr(intensity)
    sun.CreateAngleAttr(angle)
    stage.Save()
    scene, _ = read(path)
    result = pc.render(scene, width=4, height=4, samples=4, max_bounces=1)
    want = rho / math.pi * intensity * math.pi * math.sin(math.radians(angle / 2)) ** 2
    assert luminance(result.rgba[..., :3]).mean() == pytest.approx(want, rel=0.02)


def test_sphere_light_radius_renders_its_closed_form_irradiance(tmp_path):
    """A SphereLight of radiance L (normalize off) and radius r (doubled by its transform)
    straight above a diffuse floor of albedo ρ at height d: the floor below it receives
    E = π L (r/d)² and has radiance ρ/π · E; treatAsPoint drops the radius."""
    rho, intensity, radius, d = 0.5, 10.0, 0.25, 2.0
    path = tmp_path / "spherefloor.usda"
    stage = new_stage(path)
    floor_mesh(stage, "/floor", 5.0, preview_material(stage, "/Looks/grey", (rho, rho, rho)))
    top_camera(stage, "/cam", 1.0, 0.05)
    light = UsdLux.SphereLight.Define(stage, "/bulb")
    light.CreateIntensityAttr(intensity)
    light.CreateRadiusAttr(radius)
    light.AddTranslateOp().Set(Gf.Vec3d(0, 0, d))
    light.AddScaleOp().Set(Gf.Vec3f(2, 2, 2))
    point = UsdLux.SphereLight.Define(stage, "/point")
    point.CreateIntensityAttr(0.0)
    point.CreateRadiusAttr(0.3)
    point.CreateTreatAsPointAttr(True)
    stage.Save()
    scene, caught = read(path)
    lights = lights_by_name(scene)
    assert lights["/bulb"]["radius"] == pytest.approx(2 * radius)
    assert "radius" not in lights["/point"]
    assert not any("/bulb" in w for w in caught), caught
    result = pc.render(scene, width=4, height=4, samples=64, max_bounces=1)
    want = rho / math.pi * math.pi * intensity * (2 * radius / d) ** 2
    assert luminance(result.rgba[..., :3]).mean() == pytest.approx(want, rel=0.02)


def test_point_sphere_and_sun_angle_bad_values_are_errors():
    for light in (pc.PointLight((0, 0, 1), radius=-1.0), pc.SpotLight((0, 0, 1), radius=float("nan")), pc.SunLight(angle=4.0)):
        with pytest.raises(ValueError, match="radius|angle"):
            light.to_dict()


def emitter_scales(scene):
    desc, bufs = scene.description()
    out = {}
    for mesh in desc["meshes"]:
        if "(back)" in mesh["name"]:
            continue
        mat = desc["materials"][mesh["material"]]
        out[mesh["name"]] = mat["emission"]["scale"]
    return out


def test_rect_and_disk_lights_divide_by_their_world_space_area(tmp_path):
    path = tmp_path / "panels.usda"
    stage = new_stage(path)
    rect = UsdLux.RectLight.Define(stage, "/rect")
    rect.CreateWidthAttr(0.5)
    rect.CreateHeightAttr(0.25)
    rect.CreateIntensityAttr(6.0)
    rect.CreateNormalizeAttr(True)
    rect.AddScaleOp().Set(Gf.Vec3f(2.0, 3.0, 1.0))
    disk = UsdLux.DiskLight.Define(stage, "/disk")
    disk.CreateRadiusAttr(0.5)
    disk.CreateIntensityAttr(6.0)
    disk.CreateNormalizeAttr(True)
    disk.AddTranslateOp().Set(Gf.Vec3d(3, 0, 0))
    disk.AddScaleOp().Set(Gf.Vec3f(2.0, 2.0, 1.0))
    plain = UsdLux.RectLight.Define(stage, "/plain")
    plain.CreateIntensityAttr(6.0)
    plain.AddScaleOp().Set(Gf.Vec3f(2.0, 3.0, 1.0))
    stage.Save()
    scene, _ = read(path)
    got = emitter_scales(scene)
    assert got["/rect"] == pytest.approx(6.0 / (0.5 * 2.0 * 0.25 * 3.0), rel=1e-5)
    assert got["/disk"] == pytest.approx(6.0 / (math.pi * 1.0**2), rel=1e-5)
    assert got["/plain"] == pytest.approx(6.0)  # not normalised: the intensity is the radiance


def test_shaping_cone_becomes_a_spot_and_focus_warns(tmp_path):
    path = tmp_path / "spot.usda"
    stage = new_stage(path)
    light = UsdLux.SphereLight.Define(stage, "/spot")
    light.CreateRadiusAttr(0.0)
    light.CreateIntensityAttr(8.0)
    shaping = UsdLux.ShapingAPI.Apply(light.GetPrim())
    shaping.CreateShapingConeAngleAttr(30.0)
    shaping.CreateShapingConeSoftnessAttr(0.2)
    shaping.CreateShapingFocusAttr(2.0)
    light.AddTranslateOp().Set(Gf.Vec3d(0, 0, 3))
    stage.Save()
    scene, warns = read(path)
    d = lights_by_name(scene)["/spot"]
    assert d["type"] == "spot" and d["direction"] == pytest.approx([0, 0, -1])
    assert d["spot_size"] == pytest.approx(math.radians(60.0)) and d["spot_blend"] == pytest.approx(0.2)
    assert d["intensity"]["scale"] == pytest.approx(8.0)
    assert [w for w in warns if "shaping:focus" in w and "/spot" in w]


def dome_rotation(tmp_path, name, make):
    from polychrome import imageio

    path = tmp_path / f"{name}.usda"
    imageio.write_exr(tmp_path / "sky.exr", np.full((4, 8, 3), 0.5, np.float32))
    stage = new_stage(path)
    make(stage)
    stage.Save()
    scene, warns = read(path)
    return scene.description()[0]["world"]["rotation"], warns


def test_dome_pole_axis_orients_the_texture(tmp_path):
    """DomeLight_1 poleAxis Z (or "scene" on a Z-up stage) is the Y-pole DomeLight turned
    by OrientToStageUpAxis (rotateX 90); a turn about Z adds to both alike."""

    def old(turn):
        def make(stage):
            dome = UsdLux.DomeLight.Define(stage, "/sky")
            dome.CreateTextureFileAttr("./sky.exr")
            dome.AddRotateZOp().Set(turn)
            dome.AddRotateXOp().Set(90.0)

        return make

    def new(pole, turn):
        def make(stage):
            dome = UsdLux.DomeLight_1.Define(stage, "/sky")
            dome.CreateTextureFileAttr("./sky.exr")
            if pole is not None:
                dome.CreatePoleAxisAttr(pole)
            dome.AddRotateZOp().Set(turn)

        return make

    for turn in (0.0, 30.0):
        want, _ = dome_rotation(tmp_path, f"old{turn}", old(turn))
        for pole in ("Z", "scene", None):
            got, warns = dome_rotation(tmp_path, f"new{pole}{turn}", new(pole, turn))
            assert math.remainder(got - want, 2 * math.pi) == pytest.approx(0.0, abs=1e-6), (pole, turn, got, want)
            assert not [w for w in warns if "tilted" in w]
    _, warns = dome_rotation(tmp_path, "ypole", new("Y", 0.0))  # pole along world −Y: tilted
    assert [w for w in warns if "tilted" in w and "/sky" in w]


def test_light_diffuse_and_specular_multipliers_warn(tmp_path):
    path = tmp_path / "mult.usda"
    stage = new_stage(path)
    light = UsdLux.SphereLight.Define(stage, "/l")
    light.CreateDiffuseAttr(0.5)
    light.CreateSpecularAttr(1.0)
    stage.Save()
    _, warns = read(path)
    assert [w for w in warns if "/l" in w and "diffuse multiplier" in w]
    assert not [w for w in warns if "specular multiplier" in w]


def test_stage_layer_doc_alone_marks_blender(tmp_path):
    """Only a doc starting "Blender v" switches conventions (not any mention of Blender)."""
    path = tmp_path / "doc.usda"
    stage = new_stage(path)
    stage.GetRootLayer().documentation = "exported from a Blender-like tool"
    sun = UsdLux.DistantLight.Define(stage, "/sun")
    sun.CreateIntensityAttr(0.5)
    sun.CreateNormalizeAttr(True)
    stage.Save()
    scene, _ = read(path)
    assert lights_by_name(scene)["/sun"]["irradiance"]["scale"] == pytest.approx(0.5)
    assert Sdf.Layer.FindOrOpen(str(path)).documentation.startswith("exported")
    assert Usd.Stage.Open(str(path))


def test_blender_layer_without_an_authored_temperature_reads_it_off(tmp_path):
    """Blender 4.5 writes enableColorTemperature = 1 on every light and colorTemperature
    only when it is not 6500 K: no authored temperature means the switch was (most
    likely) off; elsewhere the spec's fallback 6500 K applies."""
    for blender in (True, False):
        path = tmp_path / f"t{blender}.usda"
        stage = blender_layer(path) if blender else new_stage(path)
        for name, temperature in (("/plain", None), ("/warm", 3000.0)):
            light = UsdLux.SphereLight.Define(stage, name)
            light.CreateRadiusAttr(0.0)
            light.CreateEnableColorTemperatureAttr(True)
            if temperature is not None:
                light.CreateColorTemperatureAttr(temperature)
        stage.Save()
        lights = lights_by_name(read(path)[0])
        plain, warm = lights["/plain"]["intensity"], lights["/warm"]["intensity"]
        assert (plain["type"] == "rgb" and plain["rgb"] == [1.0, 1.0, 1.0]) is blender, (blender, plain)
        assert warm["type"] == "blackbody" and warm["temperature"] == 3000.0


def test_rect_light_in_front_of_the_camera_is_not_seen_but_lights_the_floor(tmp_path):
    """Camera rays pass through a UsdLux light (as Cycles and Karma treat lights): the
    camera looking down through a panel of radiance L sees the floor under it lit with
    ρ/π · L · 4·corner(a, a) (a square of half-width a at height h)."""
    rho, radiance, a, h = 0.5, 3.0, 1.0, 1.0
    path = tmp_path / "panel.usda"
    stage = new_stage(path)
    floor_mesh(stage, "/floor", 5.0, preview_material(stage, "/Looks/grey", (rho, rho, rho)))
    rect = UsdLux.RectLight.Define(stage, "/panel")
    rect.CreateWidthAttr(2 * a)
    rect.CreateHeightAttr(2 * a)
    rect.CreateIntensityAttr(radiance)
    rect.AddTranslateOp().Set(Gf.Vec3d(0, 0, h))
    top_camera(stage, "/cam", 3.0, 0.1)
    stage.Save()
    scene, _ = read(path)
    vis = {i["name"]: i.get("visibility") for i in scene.description()[0]["instances"]}
    assert vis == {"/panel": {"camera": False, "shadow": False}, "/floor": None}  # one-sided: no backing

    def corner(x, y):
        return 0.5 * (x / math.hypot(x, h) * math.atan(y / math.hypot(x, h)) + y / math.hypot(y, h) * math.atan(x / math.hypot(y, h)))

    want = rho / math.pi * radiance * 4 * corner(a, a)
    got = luminance(pc.render(scene, width=4, height=4, samples=64, max_bounces=1).rgba[..., :3]).mean()
    assert got == pytest.approx(want, rel=0.03)


@pytest.mark.parametrize("normalize", [False, True])
def test_cylinder_light_lights_the_floor_with_its_closed_form_irradiance(tmp_path, normalize):
    """A CylinderLight (UsdLux: emits outward from the side of a cylinder of `radius`
    and `length` along its local X, not from its caps) of radiance 5 at height 1 above a
    white floor, seen by a camera above it (the light is invisible to the camera): the
    floor under its axis has the irradiance of the cylinder's visible side, ∫ L cos θ_r
    cos θ_e / s² dA integrated here numerically (≈ π L r / h for an infinite one).
    Normalised, a cylinder scaled ×2 with intensity × 2^exposure = 5 × its world side
    area 2π r L gives the same radiance."""
    rho, h, r, length, radiance = 0.8, 1.0, 0.05, 6.0, 5.0
    path = tmp_path / "tube.usda"
    stage = new_stage(path)
    mat = preview_material(stage, "/Looks/white", (rho, rho, rho))
    floor_mesh(stage, "/floor", 5.0, mat)
    light = UsdLux.CylinderLight.Define(stage, "/tube")
    light.AddTranslateOp().Set(Gf.Vec3d(0, 0, h))
    if normalize:
        light.AddScaleOp().Set(Gf.Vec3f(2.0, 2.0, 2.0))
        light.CreateRadiusAttr(r / 2)
        light.CreateLengthAttr(length / 2)
        light.CreateNormalizeAttr(True)
        light.CreateExposureAttr(1.0)
        light.CreateIntensityAttr(radiance * 2 * math.pi * r * length / 2.0)
    else:
        light.CreateRadiusAttr(r)
        light.CreateLengthAttr(length)
        light.CreateIntensityAttr(radiance)
    top_camera(stage, "/cam", 3.0, 0.5)  # above the light, looking down at the floor
    stage.Save()
    scene, warns = read(path)
    assert not warns, warns
    n, width = 8, 0.5
    result = pc.render(scene, width=n, height=n, samples=1024, max_bounces=1)

    x = np.linspace(-length / 2, length / 2, 3001)
    phi = np.linspace(0.0, 2 * np.pi, 361)
    X, P = np.meshgrid(0.5 * (x[1:] + x[:-1]), 0.5 * (phi[1:] + phi[:-1]), indexing="ij")
    dA = r * (x[1] - x[0]) * (phi[1] - phi[0])

    def irradiance(px, py):  # at the floor point (px, py), normal +Z
        v = np.stack([X - px, r * np.cos(P) - py, h + r * np.sin(P)], -1)  # to the surface
        s = np.linalg.norm(v, axis=-1)
        cos_e = -(v[..., 1] * np.cos(P) + v[..., 2] * np.sin(P)) / s
        return radiance * np.sum(np.where(cos_e > 0, v[..., 2] / s * cos_e / s**2, 0.0)) * dA

    # Thin-cylinder check: an infinite one's π L r / h times the finite length's share,
    # (2/π)(t/(1 + t²) + atan t) with t = (length/2)/h.
    t = length / 2 / h
    thin = math.pi * radiance * r / h * (2 / math.pi) * (t / (1 + t * t) + math.atan(t))
    assert irradiance(0.0, 0.0) == pytest.approx(thin, rel=0.005)
    centres = ((np.arange(n) + 0.5) / n - 0.5) * width
    # E is even in y and flat in x within 0.25 of the middle of a 6 m light (< 0.1 %).
    rows = {abs(round(c, 9)): rho / math.pi * irradiance(0.0, c) for c in centres}
    want = np.array([[rows[abs(round(cy, 9))]] * n for cy in centres])
    got = luminance(result.rgba)
    # Mean over the 64 pixels (a thin light is a noisy one per pixel).
    assert np.mean(got / want) == pytest.approx(1.0, abs=0.02), np.mean(got / want)


@pytest.mark.parametrize("normalize", [False, True])
def test_ies_shaping_scales_a_sphere_light_by_the_relative_profile(tmp_path, normalize):
    """UsdLux ShapingAPI's shaping:ies:file on a SphereLight (radius 0, intensity I,
    turned 30° about X): the floor reads ρ/π · I · c(h, v)/s · cos θ / d², c the file's
    candela in the light's frame and s its largest value, or with shaping:ies:normalize
    its mean over the sphere (of tests/ies_files.py's closed form, on a fine grid); a
    missing file is one warning naming the prim."""
    from ies_files import candela, quadrant_file

    (tmp_path / "q.ies").write_text(quadrant_file())
    rho, intensity, height, n = 0.5, 10.0, 1.5, 16
    path = tmp_path / "ies.usda"
    stage = new_stage(path)
    floor_mesh(stage, "/floor", 5.0, preview_material(stage, "/Looks/grey", (rho, rho, rho)))
    top_camera(stage, "/cam", 3.0, 3.0)
    light = UsdLux.SphereLight.Define(stage, "/lamp")
    light.CreateIntensityAttr(intensity)
    light.CreateRadiusAttr(0.0)  # a point: intensity is the radiant intensity (normalize off)
    light.AddTranslateOp().Set(Gf.Vec3d(0.2, 0.1, height))
    light.AddRotateXOp().Set(30.0)
    shaping = UsdLux.ShapingAPI.Apply(light.GetPrim())
    shaping.CreateShapingIesFileAttr(Sdf.AssetPath("q.ies"))
    shaping.CreateShapingIesNormalizeAttr(normalize)
    gone = UsdLux.SphereLight.Define(stage, "/gone")
    gone.CreateIntensityAttr(0.0)
    UsdLux.ShapingAPI.Apply(gone.GetPrim()).CreateShapingIesFileAttr(Sdf.AssetPath("nowhere.ies"))
    stage.Save()
    scene, caught = read(path)
    assert any("/gone" in w and "nowhere.ies" in w for w in caught) and not any("/lamp" in w for w in caught), caught
    out = pc.render(scene, width=n, height=n, samples=16, max_bounces=1, seed=3)
    y = luminance(out.rgba[..., :3])
    # The profile's scale: its largest candela, or its mean over the sphere (fine grid).
    cv = np.linspace(1, -1, 801)
    vv, hh = np.meshgrid(np.degrees(np.arccos(0.5 * (cv[1:] + cv[:-1]))), np.linspace(0.25, 359.75, 720), indexing="ij")
    scale = candela(hh, vv).mean() if normalize else candela(0.0, 0.0)
    c30, s30 = math.cos(math.radians(30)), math.sin(math.radians(30))
    to_local = np.array([[1, 0, 0], [0, c30, s30], [0, -s30, c30]])  # world → light (rotate X by −30°)
    for px, py in [(8, 8), (11, 8), (13, 3), (3, 10), (6, 13)]:
        x, yy = (px + 0.5) / n * 3 - 1.5, 1.5 - (py + 0.5) / n * 3
        d = np.array([x - 0.2, yy - 0.1, -height])
        dist = np.linalg.norm(d)
        w = to_local @ (d / dist)
        v_deg, h_deg = math.degrees(math.acos(-w[2])), math.degrees(math.atan2(w[0], w[1]) + math.pi)
        want = rho / math.pi * intensity * candela(h_deg, v_deg) / scale * (height / dist) / dist**2
        assert y[py, px] == pytest.approx(want, rel=0.04), (px, py, normalize)


def ies_theta(theta, s):
    """UsdLux shaping:ies:angleScale s (OpenUSD's ShapingAPI user documentation,
    pxr/usd/usdLux/userDoc/schemaUserDoc.usda): the vertical
    angle (radians) at which the profile is read for a direction θ from the light's axis,
    clamped to [0, π] as hdEmbree's pxrIES clamps it."""
    if s > 0:
        t = theta / s
    elif s < 0:
        t = (theta - math.pi) / -s + math.pi
    else:
        t = theta
    return min(max(t, 0.0), math.pi)


@pytest.mark.parametrize("angle_scale, normalize", [(0.5, False), (1.6, False), (-0.7, False), (-1.5, True)])
def test_ies_angle_scale_rescales_the_profiles_vertical_angles(tmp_path, angle_scale, normalize):
    """shaping:ies:angleScale s: a direction at θ from the light's −Z reads the profile at
    θ/s (s > 0, scaled about straight down), (θ − π)/−s + π (s < 0, about straight up),
    clamped to [0, π]; normalize divides by the file's own mean (UsdLux: the profile
    power of the file). The floor under a tilted point light with tests/ies_files.py's
    closed-form profile reads ρ/π · I · c(h, θ_ies)/scale · cos θ / d², no warning."""
    from ies_files import candela, quadrant_file

    (tmp_path / "q.ies").write_text(quadrant_file())
    rho, intensity, height, n = 0.5, 10.0, 1.5, 16
    path = tmp_path / "ies.usda"
    stage = new_stage(path)
    floor_mesh(stage, "/floor", 5.0, preview_material(stage, "/Looks/grey", (rho, rho, rho)))
    top_camera(stage, "/cam", 3.0, 3.0)
    light = UsdLux.SphereLight.Define(stage, "/lamp")
    light.CreateIntensityAttr(intensity)
    light.CreateRadiusAttr(0.0)
    light.AddTranslateOp().Set(Gf.Vec3d(0.2, 0.1, height))
    light.AddRotateXOp().Set(30.0)
    shaping = UsdLux.ShapingAPI.Apply(light.GetPrim())
    shaping.CreateShapingIesFileAttr(Sdf.AssetPath("q.ies"))
    shaping.CreateShapingIesAngleScaleAttr(angle_scale)
    shaping.CreateShapingIesNormalizeAttr(normalize)
    stage.Save()
    scene, caught = read(path)
    assert not caught, caught
    out = pc.render(scene, width=n, height=n, samples=16, max_bounces=1, seed=3)
    y = luminance(out.rgba[..., :3])
    cv = np.linspace(1, -1, 801)
    vv, hh = np.meshgrid(np.degrees(np.arccos(0.5 * (cv[1:] + cv[:-1]))), np.linspace(0.25, 359.75, 720), indexing="ij")
    scale = candela(hh, vv).mean() if normalize else candela(0.0, 0.0)
    c30, s30 = math.cos(math.radians(30)), math.sin(math.radians(30))
    to_local = np.array([[1, 0, 0], [0, c30, s30], [0, -s30, c30]])
    checked = []
    for px, py in [(8, 8), (11, 8), (13, 3), (3, 10), (6, 13), (2, 2), (14, 14)]:
        x, yy = (px + 0.5) / n * 3 - 1.5, 1.5 - (py + 0.5) / n * 3
        d = np.array([x - 0.2, yy - 0.1, -height])
        dist = np.linalg.norm(d)
        w = to_local @ (d / dist)
        theta = math.acos(-w[2])
        h_deg = math.degrees(math.atan2(w[0], w[1]) + math.pi)
        want = rho / math.pi * intensity * candela(h_deg, math.degrees(ies_theta(theta, angle_scale))) / scale * (height / dist) / dist**2
        unscaled = rho / math.pi * intensity * candela(h_deg, math.degrees(theta)) / scale * (height / dist) / dist**2
        checked.append(abs(want / unscaled - 1.0))
        assert y[py, px] == pytest.approx(want, rel=0.04, abs=2e-4), (px, py, angle_scale)
    assert max(checked) > 0.2  # the scale changes what these pixels see


@pytest.mark.parametrize(
    "domes",
    [
        # (texture size or None for a uniform dome, linear colour, intensity, turn about Z in degrees)
        [(None, (0.2, 0.3, 0.1), 1.0, 0.0), (None, (0.1, 0.05, 0.4), 2.0, 0.0)],
        [((8, 4), (0.25, 0.25, 0.25), 2.0, 0.0), (None, (0.1, 0.05, 0.4), 1.0, 0.0)],
        [((8, 4), (0.1, 0.2, 0.3), 1.0, 0.0), ((16, 8), (0.3, 0.1, 0.05), 0.5, 30.0), (None, (0.05, 0.1, 0.2), 1.0, 0.0)],
    ],
    ids=["uniform+uniform", "texture+uniform", "texture+texture+uniform"],
)
def test_several_dome_lights_add_up(tmp_path, domes):
    """Lights add: several DomeLights are one world whose radiance is their sum (UsdLux:
    L = intensity × colour, or the texture × intensity). The background is the sum, and a
    convex grey diffuse (albedo ρ = 0.8) under it is a white furnace: radiance ρ × the sum."""
    from polychrome import imageio

    path = tmp_path / "domes.usda"
    stage = new_stage(path)
    want = np.zeros(3)
    for k, (size, colour, intensity, turn) in enumerate(domes):
        dome = UsdLux.DomeLight.Define(stage, f"/dome{k}")
        dome.CreateIntensityAttr(intensity)
        if size is None:
            dome.CreateColorAttr(Gf.Vec3f(*colour))
        else:
            imageio.write_exr(tmp_path / f"sky{k}.exr", np.tile(np.array(colour, np.float32), (size[1], size[0], 1)))
            dome.CreateTextureFileAttr(f"./sky{k}.exr")
            dome.AddRotateZOp().Set(turn)
            dome.AddRotateXOp().Set(90.0)
        want += intensity * np.array(colour)
    ball = UsdGeom.Sphere.Define(stage, "/ball")
    ball.CreateDisplayColorAttr([Gf.Vec3f(0.8, 0.8, 0.8)])
    top_camera(stage, "/cam", 3.0, 4.0)
    stage.Save()
    scene, warns = read(path)
    if all(size is None for size, *_ in domes):
        assert not warns, warns  # a uniform sum is exact
    else:  # a texture bake: one warning naming every dome
        assert len(warns) == 1 and all(f"/dome{k}" in warns[0] for k in range(len(domes))), warns
    rgb = pc.render(scene, width=8, height=8, samples=32, max_bounces=4, seed=1).rgba[..., :3]
    corners = np.stack([rgb[0, 0], rgb[0, -1], rgb[-1, 0], rgb[-1, -1]])
    assert corners.mean(axis=0) == pytest.approx(want, rel=1e-3), (corners, want)
    assert rgb[3:5, 3:5].reshape(-1, 3).mean(axis=0) == pytest.approx(0.8 * want, rel=0.02)


def test_summed_dome_textures_keep_each_ones_orientation(tmp_path):
    """Two latlong domes turned differently (0° and 90° about Z), baked into one: in every
    direction d the world's radiance (Polychrome's mapping, docs/usd.md: lookup Rz(rotation)·d,
    u = ½ − atan2(y, x)/2π, v = ½ + elevation/π) is the first texture's plus the second's,
    each looked up with its own rotation. Directions at the base's texel centres; a 90° turn
    moves the second by a quarter of its width, so both are read at texel centres."""
    from polychrome import imageio

    rng = np.random.default_rng(5)
    texs = [rng.uniform(0.0, 1.0, (8, 16, 3)).astype(np.float32) for _ in range(2)]
    path = tmp_path / "turned.usda"
    stage = new_stage(path)
    for k, (tex, turn, intensity) in enumerate(zip(texs, (0.0, 90.0), (1.0, 0.5))):
        imageio.write_exr(tmp_path / f"sky{k}.exr", tex)
        dome = UsdLux.DomeLight.Define(stage, f"/dome{k}")
        dome.CreateTextureFileAttr(f"./sky{k}.exr")
        dome.CreateIntensityAttr(intensity)
        dome.AddRotateZOp().Set(turn)
        dome.AddRotateXOp().Set(90.0)
    stage.Save()
    scene, _ = read(path)
    world = scene.world_texture
    baked = np.asarray(world["texture"].pixels, np.float64) * world["strength"]
    # each dome alone, as read_stage places it
    alone = []
    for k in range(2):
        solo = tmp_path / f"solo{k}.usda"
        st = new_stage(solo)
        st.GetRootLayer().subLayerPaths.append(str(path))
        for j in range(2):
            if j != k:
                st.OverridePrim(f"/dome{j}").SetActive(False)
        st.Save()
        alone.append(read(solo)[0].world_texture)

    def lookup(w, d):
        r = w["rotation"]
        x, y = math.cos(r) * d[0] - math.sin(r) * d[1], math.sin(r) * d[0] + math.cos(r) * d[1]
        u = (0.5 - math.atan2(y, x) / (2 * math.pi)) % 1.0
        v = 0.5 + math.atan2(d[2], math.hypot(x, y)) / math.pi
        px = np.asarray(w["texture"].pixels, np.float64)
        h, wd = px.shape[:2]
        i, j = (1.0 - v) * h - 0.5, u * wd - 0.5
        assert abs(i - round(i)) < 1e-6 and abs(j - round(j)) < 1e-6  # a texel centre
        return px[round(i), round(j) % wd] * w["strength"]

    for row in range(8):
        for col in range(16):
            u, v = (col + 0.5) / 16, 1.0 - (row + 0.5) / 8
            phi, elev = (0.5 - u) * 2 * math.pi - world["rotation"], (v - 0.5) * math.pi
            d = (math.cos(elev) * math.cos(phi), math.cos(elev) * math.sin(phi), math.sin(elev))
            assert lookup(world, d) == pytest.approx(lookup(alone[0], d) + lookup(alone[1], d), abs=1e-5)
            assert baked[row, col] == pytest.approx(lookup(world, d), abs=1e-5)
