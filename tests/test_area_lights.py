"""One-sided area emitters (``pc.Emitter(one_sided=True)``), as Cycles' area lights and
UsdLux's RectLight/DiskLight ("emits light along the -Z axis", from one side) against
closed forms: a Lambertian square of radiance L and half-width a at height h gives the
point under its centre the irradiance L·4·corner(a, a) (sum of four corner rectangles,
corner(x, y) = ½[x/√(x²+h²)·atan(y/√(x²+h²)) + y/√(y²+h²)·atan(x/√(y²+h²))]); a disk
of radius r gives L·π·r²/(r²+h²) on its axis; nothing reaches the side behind a
one-sided emitter, and it emits half the power of a two-sided one (light tracing)."""

import math

import numpy as np
import pytest

import polychrome as pc
from conftest import luminance

RHO = 0.5


def corner(x, y, h):
    """Irradiance under the corner of an x × y rectangle of radiance 1 at height h."""
    return 0.5 * (x / math.hypot(x, h) * math.atan(y / math.hypot(x, h)) + y / math.hypot(y, h) * math.atan(x / math.hypot(y, h)))


def square_irradiance(x, y, a, h):
    """Irradiance at (x, y, 0) under a square of half-width a centred at (0, 0, h)."""
    return sum(corner(a + sx * x, a + sy * y, h) for sx in (1, -1) for sy in (1, -1))


def plane(half, z, up):
    v = np.array([[-half, -half, z], [half, -half, z], [half, half, z], [-half, half, z]], np.float32)
    t = np.array([[0, 1, 2], [0, 2, 3]], np.uint32)
    return v, (t if up else t[:, ::-1].copy())


def panel_scene(one_sided, facing_down=True, L=3.0, a=0.5, h=1.0):
    """Floor at z = 0, ceiling at z = 2h, a square emitter at z = h between them."""
    scene = pc.Scene()
    grey = scene.add_material(pc.Diffuse(RHO, name="grey"))
    scene.add_mesh("floor", *plane(5.0, 0.0, True), material=grey)
    scene.add_mesh("ceiling", *plane(5.0, 2 * h, False), material=grey)
    panel = scene.add_material(pc.Emitter(L, one_sided=one_sided, name="panel"))
    scene.add_mesh("panel", *plane(a, h, not facing_down), material=panel)
    return scene


def lens(z, look_z, f=150.0):
    return pc.Camera.looking_at((0, 0, z), (0, 0, look_z), focal_length=f, sensor_width=36.0, up=(0, 1, 0), name="lens")


def mean_luminance(scene, **kw):
    kw = {"width": 6, "height": 6, "samples": 64, "max_bounces": 1, "seed": 7, **kw}
    return float(luminance(pc.render(scene, **kw).rgba[..., :3]).mean())


def expected_floor(L, a, h, cam_z, f=150.0, n=6):
    """ρ/π × the irradiance averaged over the pixel centres of the camera at cam_z
    looking straight down at the floor."""
    half = cam_z * 18.0 / f
    centres = ((np.arange(n) + 0.5) / n * 2 - 1) * half
    return RHO / math.pi * L * float(np.mean([square_irradiance(x, y, a, h) for x in centres for y in centres]))


@pytest.mark.parametrize("direction, samples", [("BACKWARD", 64), ("FORWARD", 8192), ("BIDIRECTIONAL", 256)])
def test_one_sided_square_lights_below_and_nothing_above(direction, samples):
    L, a, h = 3.0, 0.5, 1.0
    kw = {"direction": direction, "samples": samples}
    down = panel_scene(True, True, L, a, h)
    down.camera = lens(0.5 * h, 0.0)  # under the panel, looking down at the floor
    want = expected_floor(L, a, h, 0.5 * h)
    assert mean_luminance(down, **kw) == pytest.approx(want, rel=0.04), direction
    # above it, looking up at the ceiling: its back is dark and lights nothing
    down.camera = lens(1.5 * h, 2 * h)
    assert mean_luminance(down, **kw) == pytest.approx(0.0, abs=1e-6)
    # facing up instead, the ceiling is lit as the floor was
    up = panel_scene(True, False, L, a, h)
    up.camera = lens(1.5 * h, 2 * h)
    assert mean_luminance(up, **kw) == pytest.approx(want, rel=0.04), direction
    # a two-sided emitter lights both
    both = panel_scene(False, True, L, a, h)
    both.camera = lens(1.5 * h, 2 * h)
    assert mean_luminance(both, **kw) == pytest.approx(want, rel=0.04), direction


@pytest.mark.parametrize("direction", ["BACKWARD", "FORWARD"])
def test_one_sided_emitter_seen_from_front_is_its_radiance_and_from_behind_black(direction):
    L = 3.0
    scene = panel_scene(True, True, L, a=0.3)
    scene.camera = pc.Camera.looking_at((0, 0, 0.3), (0, 0, 1.0), focal_length=150.0, sensor_width=36.0, up=(0, 1, 0), name="up")
    samples = 64 if direction == "BACKWARD" else 4096
    assert mean_luminance(scene, direction=direction, samples=samples, max_bounces=0) == pytest.approx(L, rel=0.03)
    scene.camera = pc.Camera.looking_at((0, 0, 1.7), (0, 0, 1.0), focal_length=150.0, sensor_width=36.0, up=(0, 1, 0), name="down")
    assert mean_luminance(scene, direction=direction, samples=samples, max_bounces=0) == pytest.approx(0.0, abs=1e-6)


def test_one_sided_flag_is_in_the_description_only_when_set():
    assert pc.Emitter(1.0, one_sided=True).to_dict()["one_sided"] is True
    assert "one_sided" not in pc.Emitter(1.0).to_dict()


@pytest.mark.parametrize("shape", ["rect", "disk"])
def test_usd_rect_and_disk_lights_light_below_on_axis_as_the_closed_form_and_nothing_above(tmp_path, shape):
    pytest.importorskip("pxr")
    from pxr import Gf, UsdLux

    from polychrome import usd
    from test_usd import floor_mesh, new_stage, preview_material

    L, h, r = 4.0, 1.0, 0.4
    path = tmp_path / f"{shape}.usda"
    stage = new_stage(path)
    mat = preview_material(stage, "/Looks/grey", (RHO, RHO, RHO))
    floor_mesh(stage, "/floor", 5.0, mat)
    ceiling = floor_mesh(stage, "/ceiling", 5.0, mat)
    ceiling.AddTranslateOp().Set(Gf.Vec3d(0, 0, 2 * h))
    if shape == "rect":
        light = UsdLux.RectLight.Define(stage, "/light")
        light.CreateWidthAttr(2 * r)
        light.CreateHeightAttr(2 * r)
        irradiance = L * 4 * corner(r, r, h)
    else:
        light = UsdLux.DiskLight.Define(stage, "/light")
        light.CreateRadiusAttr(r)
        irradiance = L * math.pi * r * r / (r * r + h * h)
    light.CreateIntensityAttr(L)
    light.AddTranslateOp().Set(Gf.Vec3d(0, 0, h))
    stage.Save()
    scene = usd.read_stage(path)
    assert [m["one_sided"] for m in scene.description()[0]["materials"] if m.get("emission")] == [True]
    # a narrow view straight down the axis (from above the light: camera rays pass
    # through it), then straight up at the ceiling from below it
    scene.camera = lens(1.9 * h, 0.0, f=2000.0)
    got = mean_luminance(scene, samples=256)
    assert got == pytest.approx(RHO / math.pi * irradiance, rel=0.02), (shape, got)
    scene.camera = lens(0.1 * h, 2 * h, f=2000.0)
    assert mean_luminance(scene, samples=64) == pytest.approx(0.0, abs=1e-6)


def test_see_through_emitter_lets_camera_and_bounce_rays_through_and_casts_no_shadow():
    """Cycles' lights are a transparent bounce: the camera looking down at the back of a
    see-through panel sees the floor behind it, lit by the panel (and by a sun the panel
    does not shadow); an opaque panel is black from behind and shadows the sun."""
    L, a, h, E = 3.0, 0.5, 1.0, 2.0

    def scene(see_through):
        s = pc.Scene()
        grey = s.add_material(pc.Diffuse(RHO, name="grey"))
        s.add_mesh("floor", *plane(5.0, 0.0, True), material=grey)
        panel = s.add_material(pc.Emitter(L, one_sided=True, see_through=see_through, name="panel"))
        s.add_mesh("panel", *plane(a, h, False), material=panel)
        s.add_light(pc.SunLight((0, 0, -1), strength=E, name="sun"))
        s.camera = lens(1.5 * h, 0.0)
        return s

    want = expected_floor(L, a, h, 1.5 * h) + RHO * E / math.pi
    assert mean_luminance(scene(True)) == pytest.approx(want, rel=0.03)
    assert mean_luminance(scene(False)) == pytest.approx(0.0, abs=1e-6)
    # seen from the front through the floor side: the panel's radiance plus what lies
    # behind it (nothing: no world)
    s = scene(True)
    s.camera = pc.Camera.looking_at((0, 0, 0.5), (0, 0, 1.0), focal_length=150.0, sensor_width=36.0, up=(0, 1, 0), name="up")
    assert mean_luminance(s, max_bounces=0) == pytest.approx(L, rel=0.03)


def test_one_sided_see_through_light_round_trips_through_usd_as_a_rect_light(tmp_path):
    pytest.importorskip("pxr")
    from pxr import Usd, UsdGeom, UsdLux

    from polychrome import usd

    L, a, h = 3.0, 0.4, 1.0
    scene = pc.Scene()
    scene.add_mesh("floor", *plane(5.0, 0.0, True), material=pc.Diffuse(RHO, name="floor"))
    m = scene.add_mesh(
        "panel", *plane(a, 0.0, False), material=pc.Emitter(L, one_sided=True, see_through=True, name="panel light"), place=False
    )
    placed = np.eye(4)
    placed[2, 3] = h
    scene.add_instance(m, placed, "panel", visibility={"camera": False, "shadow": False})
    scene.camera = lens(1.5 * h, 0.0)
    path = usd.write_stage(scene, tmp_path / "panel.usda", pc.RenderSettings(width=6, height=6))
    stage = Usd.Stage.Open(str(path))
    rect = UsdLux.RectLight(stage.GetPrimAtPath("/World/Lights/panel"))
    assert rect and (rect.GetWidthAttr().Get(), rect.GetHeightAttr().Get()) == pytest.approx((2 * a, 2 * a))
    frame = np.array(UsdGeom.Xformable(rect).ComputeLocalToWorldTransform(Usd.TimeCode.Default())).T
    assert frame[:3, 2] == pytest.approx([0, 0, 1]) and frame[:3, 3] == pytest.approx([0, 0, h])  # −Z: down
    assert not rect.GetPrim().HasAttribute("polychrome:hasBacking")
    back = usd.read_stage(path)
    light = [m for m in back.description()[0]["materials"] if m.get("emission")]
    assert [(m["name"], m["one_sided"], m["see_through"]) for m in light] == [("panel light", True, True)]
    want = expected_floor(L, a, h, 1.5 * h)
    assert mean_luminance(scene) == pytest.approx(want, rel=0.03)
    assert mean_luminance(back) == pytest.approx(want, rel=0.03)
