"""Ray visibility of instances (Cycles' Object > Visibility > Ray Visibility) against
closed forms: what camera rays do not see, the camera sees through; what shadow rays do
not see casts no shadow; an instance no ray sees changes nothing at all."""

import math

import numpy as np
import pytest

import polychrome as pc
from conftest import luminance
from meshes import square

RHO, E = 0.5, 2.0


def floor_scene(card_visibility=None, card_material=None, sun=True, card_holdout=False):
    """A grey floor seen from above (orthographic), a sun straight down, and a card
    between them that covers the whole view."""
    scene = pc.Scene()
    grey = scene.add_material(pc.Diffuse(RHO, name="grey"))
    v, t = square(10.0, 0.0)
    scene.add_mesh("floor", v, t, material=grey)
    card = scene.add_material(card_material or pc.Diffuse(0.0, name="black card"))
    v, t = square(1.0, 0.0)
    m = scene.add_mesh("card", v, t, material=card, place=False)
    placed = np.eye(4)
    placed[2, 3] = 1.0
    scene.add_instance(m, placed, "card", visibility=card_visibility, holdout=card_holdout)
    if sun:
        scene.add_light(pc.SunLight((0, 0, -1), strength=E, name="sun"))
    scene.camera = pc.Camera.looking_at((0, 0, 3), (0, 0, 0), projection="ORTHOGRAPHIC", ortho_scale=0.5, name="top")
    return scene


def mean_luminance(scene, **kw):
    kw = {"width": 6, "height": 6, "samples": 16, "max_bounces": 2, "seed": 5, **kw}
    return float(luminance(pc.render(scene, **kw).rgba[..., :3]).mean())


LIT = RHO * E / math.pi  # the floor under the sun, nothing in the way


def test_card_hides_and_shadows_the_floor_by_default():
    assert mean_luminance(floor_scene()) == pytest.approx(0.0, abs=1e-6)


def test_camera_invisible_card_still_shadows():
    assert mean_luminance(floor_scene({"camera": False})) == pytest.approx(0.0, abs=1e-6)


def test_camera_and_shadow_invisible_card_lets_the_lit_floor_through():
    got = mean_luminance(floor_scene({"camera": False, "shadow": False}))
    assert got == pytest.approx(LIT, rel=0.01)


def test_shadow_invisible_card_hides_the_floor_but_casts_no_shadow_on_it():
    """Seen by the camera (black) but not by shadow rays: looking past it at an angle
    would show a lit floor; straight on, only the card (black)."""
    assert mean_luminance(floor_scene({"shadow": False})) == pytest.approx(0.0, abs=1e-6)
    scene = floor_scene({"shadow": False})
    scene.camera = pc.Camera.looking_at((2.5, 0, 1.5), (2.5, 0, 0), projection="ORTHOGRAPHIC", ortho_scale=0.5, name="beside")
    assert mean_luminance(scene) == pytest.approx(LIT, rel=0.01)  # next to it: not shadowed


@pytest.mark.parametrize("direction", ["BACKWARD", "FORWARD", "BIDIRECTIONAL"])
def test_camera_invisible_emitter_lights_the_floor_but_is_not_seen(direction):
    """A downward-facing emissive card of radiance L right in front of the camera:
    camera rays (and light paths' camera connections) pass through it, and the floor
    under it gets the irradiance of a square of half-width a at height h (sum of four
    corner rectangles), averaged over the pixel centres."""
    L, a, h, f, n = 3.0, 1.0, 1.0, 150.0, 6
    scene = floor_scene({"camera": False, "shadow": False}, pc.Emitter(L, name="panel"), sun=False)
    # light tracing needs a perspective camera: straight down from 3 units, 36 mm sensor
    lens = pc.Camera.looking_at((0, 0, 3), (0, 0, 0), focal_length=f, sensor_width=36.0, name="lens")
    scene.camera = lens

    def corner(x, y):  # E of an x×y rectangle with a corner above the point, radiance 1
        return 0.5 * (x / math.hypot(x, h) * math.atan(y / math.hypot(x, h)) + y / math.hypot(y, h) * math.atan(x / math.hypot(y, h)))

    half = 3.0 * 18.0 / f
    centres = ((np.arange(n) + 0.5) / n * 2 - 1) * half
    irradiance = np.mean([L * sum(corner(a + sx * x, a + sy * y) for sx in (1, -1) for sy in (1, -1)) for x in centres for y in centres])
    want = RHO / math.pi * irradiance
    samples = {"BACKWARD": 64, "FORWARD": 8192, "BIDIRECTIONAL": 256}[direction]
    got = mean_luminance(scene, direction=direction, samples=samples, max_bounces=1)
    assert got == pytest.approx(want, rel=0.04), (direction, got, want)
    # the camera would see the emitter itself (both faces emit) if it could
    visible = floor_scene(None, pc.Emitter(L, name="panel"), sun=False)
    visible.camera = lens
    assert mean_luminance(visible, direction=direction, max_bounces=1, samples=samples) == pytest.approx(L, rel=0.02)


def test_instance_no_ray_sees_changes_nothing():
    none = {k: False for k in pc.scene.RAY_KINDS}
    with_card = pc.render(floor_scene(none), width=6, height=6, samples=8, seed=3).rgba
    scene = floor_scene(none)
    scene._instances = [i for i in scene._instances if i["name"] != "card"]
    without = pc.render(scene, width=6, height=6, samples=8, seed=3).rgba
    assert np.array_equal(with_card, without)


def test_bad_visibility_raises_naming_the_instance():
    scene = pc.Scene()
    m = scene.add_mesh("m", *square(1.0, 0.0), material=scene.add_material(pc.Diffuse(0.5)), place=False)
    with pytest.raises(ValueError, match="instance 'x'.*camra"):
        scene.add_instance(m, np.eye(4), "x", visibility={"camra": False})
    with pytest.raises(ValueError, match="instance 'x'.*True or False"):
        scene.add_instance(m, np.eye(4), "x", visibility={"camera": "no"})
    scene.add_instance(m, np.eye(4), "x", visibility={"camera": True})
    assert "visibility" not in scene.description()[0]["instances"][0]  # the default is left out


# -- diffuse / glossy / transmission visibility, by the kind of lobe (Cycles' closure
# labels) that scatters a ray or is lit by a light ------------------------------------


def lamp_scene(floor_material, light_visibility=None, panel_visibility=None, point=True):
    """A floor under a point light of power P at height h (or a camera-invisible
    emissive square of half-width 1 at height 1), seen from above (orthographic)."""
    scene = pc.Scene()
    floor = scene.add_material(floor_material)
    scene.add_mesh("floor", *square(10.0, 0.0), material=floor)
    if point:
        scene.add_light(pc.PointLight((0, 0, 1.0), power=40.0, name="lamp", visibility=light_visibility))
    else:
        panel = scene.add_material(pc.Emitter(3.0, name="panel"))
        m = scene.add_mesh("panel", *square(1.0, 0.0), material=panel, place=False)
        placed = np.eye(4)
        placed[2, 3] = 1.0
        scene.add_instance(m, placed, "panel", visibility={"camera": False, **(panel_visibility or {})})
    scene.camera = pc.Camera.looking_at((0, 0, 3), (0, 0, 0), projection="ORTHOGRAPHIC", ortho_scale=0.05, name="top")
    return scene


def test_light_invisible_to_diffuse_rays_does_not_light_a_diffuse_floor():
    lit = RHO / math.pi * 40.0 / (4 * math.pi) / 1.0**2  # ρ/π · I/h² under the lamp
    assert mean_luminance(lamp_scene(pc.Diffuse(RHO))) == pytest.approx(lit, rel=0.01)
    assert mean_luminance(lamp_scene(pc.Diffuse(RHO), {"glossy": False, "transmission": False})) == pytest.approx(lit, rel=0.01)
    assert mean_luminance(lamp_scene(pc.Diffuse(RHO), {"diffuse": False})) == pytest.approx(0.0, abs=1e-7)
    with pytest.raises(ValueError, match="light 'x'.*camra"):
        pc.PointLight((0, 0, 1), name="x", visibility={"camra": False}).to_dict()


def test_emitter_invisible_to_a_lobe_kind_lights_nothing_through_that_kind():
    """A diffuse floor under an emissive square it cannot see by diffuse rays is black
    (next-event estimation skips it, BSDF rays pass through it); by glossy rays, lit as
    the closed form; a rough glossy floor the other way round."""
    L, a, h = 3.0, 1.0, 1.0

    def corner(x, y):
        return 0.5 * (x / math.hypot(x, h) * math.atan(y / math.hypot(x, h)) + y / math.hypot(y, h) * math.atan(x / math.hypot(y, h)))

    lit = RHO / math.pi * L * 4 * corner(a, a)
    kw = {"samples": 64, "max_bounces": 1}
    assert mean_luminance(lamp_scene(pc.Diffuse(RHO), point=False, panel_visibility={"glossy": False}), **kw) == pytest.approx(
        lit, rel=0.02
    )
    assert mean_luminance(lamp_scene(pc.Diffuse(RHO), point=False, panel_visibility={"diffuse": False}), **kw) == pytest.approx(
        0.0, abs=1e-7
    )
    glossy = pc.Glossy(0.8, roughness=0.4, name="satin")
    seen = mean_luminance(lamp_scene(glossy, point=False), **kw)
    assert seen > 0.05
    assert mean_luminance(lamp_scene(glossy, point=False, panel_visibility={"diffuse": False}), **kw) == pytest.approx(seen, rel=1e-6)
    assert mean_luminance(lamp_scene(glossy, point=False, panel_visibility={"glossy": False}), **kw) == pytest.approx(0.0, abs=1e-7)


def test_card_invisible_to_glossy_rays_is_not_in_the_mirror():
    """A mirror floor (reflectance 1) under a black card and, above it, a camera-invisible
    emissive panel of radiance L: the camera sees the panel in the mirror only when the
    card is invisible to glossy rays."""
    L = 3.0

    def scene(card_visibility):
        s = pc.Scene()
        s.add_mesh("mirror", *square(10.0, 0.0), material=s.add_material(pc.Conductor(eta=1.0, k=1e4, name="mirror")))
        for name, z, mat, vis in (
            ("card", 1.0, pc.Diffuse(0.0, name="card"), card_visibility),
            ("panel", 2.0, pc.Emitter(L, name="panel"), {"camera": False}),
        ):
            m = s.add_mesh(name, *square(2.0, 0.0), material=s.add_material(mat), place=False)
            placed = np.eye(4)
            placed[2, 3] = z
            s.add_instance(m, placed, name, visibility=vis)
        s.camera = pc.Camera.looking_at((0, 0, 0.5), (0, 0, 0), projection="ORTHOGRAPHIC", ortho_scale=0.2, name="top")
        return s

    assert mean_luminance(scene({"camera": False, "glossy": False}), max_bounces=1) == pytest.approx(L, rel=0.01)
    assert mean_luminance(scene({"camera": False}), max_bounces=1) == pytest.approx(0.0, abs=1e-7)
    assert mean_luminance(scene({"camera": False, "diffuse": False}), max_bounces=1) == pytest.approx(0.0, abs=1e-7)


def test_holdout_card_is_transparent_to_the_camera_and_still_casts_its_shadow():
    """Cycles' object holdout: where the camera sees the card, alpha 0 and black (with a
    white card too, in BACKWARD and FORWARD); shadow rays still see it, so with camera
    rays passing it the floor shows, shadowed, at alpha 1."""
    for direction in ("BACKWARD", "FORWARD"):
        scene = floor_scene(card_material=pc.Diffuse(1.0, name="white card"), card_holdout=True)
        # Light tracing connects to a pinhole: a perspective view 0.8 above the card, within it.
        scene.camera = pc.Camera.looking_at((0, 0, 1.8), (0, 0, 0), name="top")
        img = pc.render(
            scene,
            width=6,
            height=6,
            samples=16,
            max_bounces=2,
            seed=5,
            direction=direction,
        ).rgba
        assert np.all(img == 0.0), direction
    img = pc.render(floor_scene({"camera": False}, card_holdout=True), width=6, height=6, samples=16, max_bounces=2, seed=5).rgba
    assert np.all(img[..., 3] == 1.0)
    assert float(luminance(img[..., :3]).mean()) == pytest.approx(0.0, abs=1e-6)
