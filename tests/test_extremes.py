"""Numerical stability at the extremes (docs/design.md#extremes), through the real pipeline.

Every case renders with the Python API (``polychrome.render``) and is checked by
:func:`check_finite`: no NaN or infinity in any pass (rgba, depth, normal, albedo,
spectral) and ``stats["nonfinite_samples"] == 0`` (the film's guard dropped nothing).
Most cases render with every method and direction (:func:`render_all`), so every
integrator's output passes the guard. Each case also checks a closed form or a bound.
"""

import json
import math

import numpy as np
import pytest

import polychrome as pc
from polychrome import _core, spectra
from conftest import luminance
from meshes import box, uv_sphere

# Explicit grid and bounces: the tests must not depend on quality presets.
SMALL = dict(width=12, height=10, samples=4, wavelength_count=41, max_bounces=8)

# (method, direction) pairs every integrator goes through.
ALL_METHODS = [
    ("POLYCHROMATIC", "BACKWARD"),
    ("MONOCHROMATIC_RAYS", "BACKWARD"),
    ("MONOCHROMATIC_SCENES", "BACKWARD"),
    ("RGB", "BACKWARD"),
    ("POLYCHROMATIC", "FORWARD"),
    ("POLYCHROMATIC", "BIDIRECTIONAL"),
    ("MONOCHROMATIC_RAYS", "FORWARD"),
]


def check_finite(result, what=""):
    """Fails on any non-finite value in any pass or any sample the film had to drop."""
    for name in ("rgba", "depth", "normal", "albedo", "spectral"):
        a = getattr(result, name)
        if a is None:
            continue
        bad = ~np.isfinite(a)
        assert not bad.any(), f"{what}: {name} has {int(bad.sum())} non-finite values"
    assert result.stats["nonfinite_samples"] == 0, f"{what}: {result.stats['nonfinite_samples']} non-finite samples dropped"
    return result


def render_checked(scene, **kw):
    settings = dict(SMALL, spectral_output=kw.get("method", "POLYCHROMATIC") != "RGB")
    settings.update(kw)
    if "wavelengths" in kw:
        settings.pop("wavelength_count")
    return check_finite(pc.render(scene, **settings), f"{settings.get('method', 'POLYCHROMATIC')}/{settings.get('direction', 'BACKWARD')}")


def render_all(scene, methods=ALL_METHODS, **kw):
    """Renders with each (method, direction); returns {(method, direction): result}."""
    out = {}
    for method, direction in methods:
        if direction == "FORWARD" and scene.camera.projection.upper() != "PERSPECTIVE":
            continue
        kw2 = dict(kw)
        if method == "MONOCHROMATIC_SCENES" and "wavelengths" not in kw2:
            kw2["wavelength_count"] = 9  # one image per wavelength: keep it short
        out[(method, direction)] = render_checked(scene, method=method, direction=direction, **kw2)
    return out


def mean_close(r, expected, rel, key):
    """Per pixel for the noise-free methods; image mean within 5 standard errors for
    MONOCHROMATIC_RAYS (one random wavelength per sample: colour noise)."""
    y = luminance(r.rgba)
    if key[0] == "MONOCHROMATIC_RAYS" or key[1] != "BACKWARD":
        se = y.std(ddof=1) / math.sqrt(y.size)
        assert abs(y.mean() - expected) <= 5 * se + rel * expected, (key, y.mean(), se)
    else:
        assert y == pytest.approx(expected, rel=rel), key


def quad(size, z=0.0, center=(0.0, 0.0)):
    cx, cy = center
    s = size
    v = [[cx - s, cy - s, z], [cx + s, cy - s, z], [cx + s, cy + s, z], [cx - s, cy + s, z]]
    return np.array(v, dtype=np.float64), np.array([[0, 1, 2], [0, 2, 3]])


# --- grazing incidence -------------------------------------------------------------------


@pytest.mark.parametrize(
    "material",
    [
        pc.Diffuse(0.7, name="diffuse"),
        pc.Dielectric(1.5, name="glass"),
        pc.Dielectric(1.5, roughness=0.3, name="rough glass"),
        pc.Conductor("gold", roughness=0.2, name="rough gold"),
        pc.Conductor("silver", name="silver"),
        pc.Glossy(0.8, roughness=0.05, name="glossy"),
    ],
    ids=lambda m: m.name,
)
def test_grazing_camera_rays_at_89_99_degrees(material):
    """Camera rays skim a plane at 89.99° from its normal (cos θ ≈ 1.7e-4)."""
    scene = pc.Scene()
    scene.add_material(material)
    v, t = quad(1e4)
    scene.add_mesh("plane", v, t)
    elevation = math.radians(0.01)
    pos = (0.0, 0.0, 0.01)
    target = (math.cos(elevation), 0.0, 0.01 - math.sin(elevation))
    scene.camera = pc.Camera.looking_at(pos, target, focal_length=5000.0)  # a narrow field: all rays near 89.99°
    scene.add_light(pc.SunLight(direction=(0.3, 0.0, -1.0), strength=3.0))
    scene.set_world(0.5)
    results = render_all(scene)
    for key, r in results.items():
        y = luminance(r.rgba)
        # Bounded: nothing here is brighter than the sun's irradiance reflected by a
        # white Lambertian plus the world (3/π + 0.5 ≈ 1.45); glass and metals at
        # grazing incidence reflect at most the world (0.5) and the sun's specular
        # peak, which a 0.3° sun direction cannot reach from this view.
        assert np.all(y >= -1e-6) and y.mean() <= 1.5, (key, y.mean())
        if key[1] == "FORWARD":
            continue  # light tracing fills no depth/normal passes
        hit = r.depth > 0
        assert hit.mean() > 0.3, key  # the plane is really hit at grazing angles
        n = r.normal[hit]
        # Perfect glass and mirrors pass the normal pass on to what is seen through them
        # (docs/denoise.md): here nothing, the rays leave the scene (normal 0).
        seen = np.linalg.norm(n, axis=1) > 0
        assert np.allclose(np.abs(n[seen, 2]), 1.0, atol=1e-4), key
        if material.name in ("glass", "silver"):
            assert not seen.any(), key
        else:
            assert seen.all(), key


# --- total internal reflection, camera inside glass, index extremes ----------------------


def test_camera_inside_glass_sphere_sees_n_squared_radiance():
    """A lossless glass sphere in a uniform world of radiance L: inside, radiance is n²·L
    in every direction (étendue conservation); from the centre every ray leaves
    perpendicularly, so the estimate is exact up to the bounce cut-off."""
    n = 1.5
    scene = pc.Scene()
    scene.add_material(pc.Dielectric(n, name="glass"))
    v, t = uv_sphere(radius=1.0, rings=48, segments=96)
    scene.add_mesh("ball", v, t)
    scene.camera = pc.Camera.looking_at((0, 0, 0), (1, 0.2, 0.1))
    scene.set_world(spectra.equal_energy(1.0))
    for key, r in render_all(scene, methods=ALL_METHODS[:4], max_bounces=32).items():
        y = luminance(r.rgba)
        assert y.mean() == pytest.approx(n * n, rel=0.02), (key, y.mean())
    # Light tracing cannot reach a pinhole behind a smooth interface (every connection is
    # blocked by the glass): only finiteness and no more than n²·L for those.
    for key, r in render_all(scene, methods=ALL_METHODS[4:], max_bounces=32).items():
        assert luminance(r.rgba).mean() <= n * n * 1.02, key


def test_total_internal_reflection_in_a_slab_is_bounded():
    """Camera inside a glass slab, looking along it at 80° from the faces' normal (beyond
    the critical angle 41.8°): every ray is trapped by TIR until it reaches a side face.
    Radiance can never exceed n²·L; paths still trapped at the bounce limit give 0."""
    n = 1.5
    scene = pc.Scene()
    scene.add_material(pc.Dielectric(n, name="slab glass"))
    v, t = box((-50, -50, -0.5), (50, 50, 0.5))
    scene.add_mesh("slab", v, t)
    d = (math.sin(math.radians(80)), 0.0, math.cos(math.radians(80)))
    scene.camera = pc.Camera.looking_at((0, 0, 0), d, focal_length=200.0)
    scene.set_world(spectra.equal_energy(1.0))
    for key, r in render_all(scene, methods=ALL_METHODS[:4] + [("POLYCHROMATIC", "BIDIRECTIONAL")], max_bounces=16).items():
        y = luminance(r.rgba)
        assert np.all(y >= -1e-6), key
        if key[0] == "MONOCHROMATIC_RAYS":
            se = y.std(ddof=1) / math.sqrt(y.size)
            assert y.mean() <= n * n + 5 * se, (key, y.mean())
        else:
            assert np.all(y <= n * n * 1.02), (key, y.max())


@pytest.mark.parametrize("ior", [1.0001, 4.0, pc.ior.named("diamond")], ids=["1.0001", "4.0", "diamond"])
@pytest.mark.parametrize("roughness", [0.0, 0.4])
def test_dielectric_sphere_in_uniform_world_is_invisible(ior, roughness):
    """Any lossless dielectric in a uniform world returns the world's radiance along every
    camera ray (white furnace): Y = L for index 1.0001 and 4.0 (and a dispersive one)."""
    scene = pc.Scene()
    scene.add_material(pc.Dielectric(ior, roughness=roughness, name="glass"))
    v, t = uv_sphere(radius=1.0, rings=24, segments=48)
    scene.add_mesh("ball", v, t)
    scene.camera = pc.Camera.looking_at((0, -4, 0), (0, 0, 0))
    scene.set_world(spectra.equal_energy(1.0))
    results = render_all(scene, methods=ALL_METHODS[:4], max_bounces=64, samples=8)
    for key, r in results.items():
        y = luminance(r.rgba)
        if key[0] == "RGB":
            continue  # RGB lanes are not an equal-energy spectrum: only finiteness
        se = y.std(ddof=1) / math.sqrt(y.size)
        # Rough glass loses some energy (single-scattering microfacets, up to ~10 % at
        # α = 0.16 for n = 4); smooth glass only what is still trapped after 64 bounces.
        tol = 0.15 if roughness else 0.01
        assert y.mean() <= 1.0 + 5 * se + 0.01, (key, y.mean())
        assert y.mean() >= 1.0 - tol - 5 * se, (key, y.mean())


# --- wavelengths at the grid's ends ------------------------------------------------------


@pytest.mark.parametrize("center", [380.0, 780.0])
def test_narrow_band_exactly_at_grid_end(center):
    """A 5 nm band centred on the grid's first or last sample: half its energy is outside
    the grid, the rest lands in the end sample's half cell, nowhere else."""
    scene = pc.Scene()
    scene.add_material(pc.Diffuse(0.5, name="white"))
    v, t = quad(5.0)
    scene.add_mesh("floor", v, t)
    scene.add_light(pc.PointLight((0, 0, 2), power=100.0, color=spectra.narrow_band(center, 5.0)))
    scene.camera = pc.Camera.looking_at((0, -3, 3), (0, 0, 0))
    for key, r in render_all(scene).items():
        if key[0] in ("RGB", "MONOCHROMATIC_SCENES", "MONOCHROMATIC_RAYS"):
            continue  # RGB has no spectrum; the others use a 9-sample grid or random wavelengths
        s = r.spectral.reshape(-1, r.spectral.shape[-1]).sum(0)
        end = 0 if center == 380.0 else len(s) - 1
        assert s[end] > 0 and np.argmax(s) == end, (key, s)
        # Closed form of the Gaussian (FWHM 5 nm) averaged over the grid cells: the end
        # sample's half cell [380, 385] against its neighbour's [385, 395]. The white
        # floor is flat, so the rendered spectrum keeps exactly this ratio.
        sigma = 5.0 / (2.0 * math.sqrt(2.0 * math.log(2.0)))
        cdf = lambda x: 0.5 * (1.0 + math.erf(abs(x) / (sigma * math.sqrt(2.0))) * math.copysign(1.0, x))
        ratio = ((cdf(15.0) - cdf(5.0)) / 10.0) / ((cdf(5.0) - cdf(0.0)) / 5.0)
        nxt = 1 if end == 0 else len(s) - 2
        assert s[nxt] / s[end] == pytest.approx(ratio, rel=2e-3), (key, s[nxt] / s[end], ratio)
        far = s[3:] if end == 0 else s[:-3]
        assert far.sum() <= 1e-6 * s.sum(), (key, s)


def test_explicit_grid_360_to_830():
    """An explicit grid spanning the whole CIE table, 360..830 nm: a camera inside an
    emissive sphere of equal-energy radiance 1 sees Y = 1 exactly (the observer is
    normalised on the grid), and the spectral pass holds 1 at both end samples."""
    grid = [360.0] + list(np.arange(380.0, 781.0, 20.0)) + [800.0, 830.0]
    scene = pc.Scene()
    scene.add_material(pc.Diffuse(0.0, emission=spectra.equal_energy(1.0), name="glow"))
    v, t = uv_sphere(radius=2.0, rings=24, segments=48)
    scene.add_mesh("inside", v, t)
    scene.camera = pc.Camera.looking_at((0, 0, 0), (1, 0, 0))
    for key, r in render_all(scene, methods=ALL_METHODS[:3] + ALL_METHODS[4:6], wavelengths=grid).items():
        mean_close(r, 1.0, 1e-3, key)
        if key[0] == "POLYCHROMATIC" and key[1] == "BACKWARD":
            assert list(r.wavelengths) == pytest.approx(grid)
            assert r.spectral[..., 0] == pytest.approx(1.0, rel=1e-5)
            assert r.spectral[..., -1] == pytest.approx(1.0, rel=1e-5)


# --- Sellmeier pole ----------------------------------------------------------------------


@pytest.mark.parametrize("c1, where", [(0.25, "500"), (0.2601, "510"), (0.25 + 1e-4, "500")])
def test_sellmeier_pole_is_a_load_time_error_naming_material_and_wavelength(c1, where):
    """C1 = λ0² puts a pole at λ0 (500 nm, 510 nm, and just beside 500 nm): the index there
    is infinite or imaginary; the render refuses to start and names both."""
    scene = pc.Scene()
    scene.add_material(pc.Dielectric(pc.ior.sellmeier([1.0, 0.0, 0.0], [c1, 0.0, 0.0]), name="near pole"))
    v, t = quad(1.0)
    scene.add_mesh("pane", v, t)
    scene.camera = pc.Camera.looking_at((0, 0, 3), (0, 0, 0))
    with pytest.raises(ValueError) as e:
        pc.render(scene, **SMALL)
    msg = str(e.value)
    # The error names the material and the first grid wavelength where the index is
    # not a real number ≥ 1 (below the pole n² < 0, so that is 380 nm here).
    assert "near pole" in msg and "nm" in msg, msg


# --- HDRI with a texel of 1e6 ------------------------------------------------------------


@pytest.mark.parametrize("importance", [True, False])
def test_hdri_texel_of_1e6(importance):
    """One texel of 1e6 in an otherwise dim HDRI: every pass finite, the diffuse plane's
    radiance bounded by ρ · max L, and seen directly the image keeps its RGB."""
    img = np.full((8, 16, 3), 0.1, np.float32)
    img[2, 5] = 1e6
    tex = pc.Texture.from_array(img, name="sun texel")
    scene = pc.Scene()
    scene.add_material(pc.Diffuse(0.5, name="white"))
    v, t = quad(1.0)
    scene.add_mesh("floor", v, t)
    scene.set_world(texture=tex, importance_sampling=importance)
    scene.camera = pc.Camera.looking_at((0, -3, 2), (0, 0, 0))
    # The RGB method has no RGB → spectrum map, and image worlds need one (reported as a
    # clear error; a known limitation), so it is left out here.
    for key, r in render_all(scene, methods=[m for m in ALL_METHODS if m[0] != "RGB"]).items():
        y = luminance(r.rgba)
        assert y.max() <= 0.5 * 1e6 * 1.01, key
        if key[1] == "FORWARD":
            continue  # no depth pass from light tracing (and few splats at 4 spp): finiteness only
        floor = r.depth > 0
        assert floor.any() and y[floor].min() > 0, key


def test_uniform_hdri_of_1e6_reflects_rho_times_radiance():
    """Closed form at an extreme magnitude: under an HDRI of 1e6 everywhere, a diffuse
    plane of reflectance 0.5 seen from above reflects ρ·L = 5e5 (one bounce)."""
    img = np.full((4, 8, 3), 1e6, np.float32)
    scene = pc.Scene()
    scene.add_material(pc.Diffuse(0.5, name="white"))
    v, t = quad(1.0)
    scene.add_mesh("floor", v, t)
    scene.set_world(texture=pc.Texture.from_array(img, name="bright"))
    scene.camera = pc.Camera.looking_at((0, 0, 3), (0, 0, 0), focal_length=120.0)
    r = render_checked(scene, max_bounces=1, samples=16)
    y = luminance(r.rgba)
    se = y.std(ddof=1) / math.sqrt(y.size)
    assert abs(y.mean() - 0.5e6) <= 5 * se + 0.005 * 0.5e6, (y.mean(), se)


# --- lights of zero power ----------------------------------------------------------------


def zero_light_scene(kind):
    scene = pc.Scene()
    scene.add_material(pc.Diffuse(0.8, name="white"))
    v, t = quad(3.0)
    scene.add_mesh("floor", v, t)
    if kind == "point":
        scene.add_light(pc.PointLight((0, 0, 1), power=0.0, name="dark bulb"))
    elif kind == "spot":
        scene.add_light(pc.SpotLight((0, 0, 1), power=0.0, name="dark spot"))
    elif kind == "sun":
        scene.add_light(pc.SunLight(strength=0.0, name="dark sun"))
    elif kind == "emitter":
        m = scene.add_material(pc.Emitter((1, 1, 1), strength=0.0, name="dark panel"))
        v2, t2 = quad(0.5, z=1.0)
        scene.add_mesh("panel", v2, t2, material=m)
    scene.camera = pc.Camera.looking_at((0, -3, 3), (0, 0, 0))
    return scene


@pytest.mark.parametrize("kind", ["point", "spot", "sun", "emitter"])
def test_only_light_of_zero_power_renders_black(kind):
    """The light distribution over all-zero powers picks nothing: black, not NaN."""
    for key, r in render_all(zero_light_scene(kind)).items():
        assert np.all(r.rgba[..., :3] == 0.0), key


def test_zero_power_light_beside_a_real_one_changes_nothing():
    def scene(with_dark):
        s = pc.Scene()
        s.add_material(pc.Diffuse(0.8, name="white"))
        v, t = quad(3.0)
        s.add_mesh("floor", v, t)
        if with_dark:
            s.add_light(pc.PointLight((1, 0, 1), power=0.0, name="dark bulb"))
        s.add_light(pc.PointLight((0, 0, 1), power=50.0, name="bulb"))
        s.camera = pc.Camera.looking_at((0, -3, 3), (0, 0, 0))
        return s

    a = render_checked(scene(False))
    b = render_checked(scene(True))
    # Light choice ∝ power gives the dark light probability 0: the same estimate.
    assert np.allclose(a.rgba, b.rgba, rtol=1e-5, atol=1e-7)


# --- degenerate triangles ----------------------------------------------------------------

DEGENERATE_V = np.array(
    [
        [0, 0, 0],
        [1, 0, 0],
        [2, 0, 0],  # collinear
        [0, 1, 0],  # repeated below
        [1e-30, 0, 0],
        [0, 1e-30, 0],  # area underflows to 0 in f32
    ],
    float,
)
DEGENERATE_T = np.array([[0, 1, 2], [3, 3, 3], [3, 3, 0], [0, 4, 5]])


def test_degenerate_triangles_render_and_never_emit():
    scene = pc.Scene()
    scene.add_material(pc.Diffuse(0.5, name="white"))
    em = scene.add_material(pc.Emitter((1, 1, 1), strength=10.0, name="degenerate emitter"))
    v, t = quad(3.0)
    scene.add_mesh("floor", v, t)
    scene.add_mesh("slivers", DEGENERATE_V, DEGENERATE_T)
    scene.add_mesh("sliver lights", DEGENERATE_V + [0, 0, 1], DEGENERATE_T, material=em)
    scene.camera = pc.Camera.looking_at((0, -3, 3), (0, 0, 0))
    scene.set_world(0.2)
    results = render_all(scene)
    base = pc.Scene()
    base.add_material(pc.Diffuse(0.5, name="white"))
    base.add_mesh("floor", v, t)
    base.camera = scene.camera
    base.set_world(0.2)
    ref = render_checked(base)
    for key, r in results.items():
        assert r.stats["lights"] == 1, key  # only the world: zero-area triangles cannot emit
    # Degenerate triangles are never hit: the same image as without them.
    assert np.allclose(results[("POLYCHROMATIC", "BACKWARD")].rgba, ref.rgba, rtol=1e-5, atol=1e-6)


def test_mesh_of_only_degenerate_emitters_is_black():
    scene = pc.Scene()
    em = scene.add_material(pc.Emitter((1, 1, 1), strength=10.0, name="degenerate emitter"))
    scene.add_mesh("sliver lights", DEGENERATE_V, DEGENERATE_T, material=em)
    scene.camera = pc.Camera.looking_at((0.5, -3, 0.5), (0.5, 0, 0.5))
    for key, r in render_all(scene).items():
        assert np.all(r.rgba[..., :3] == 0.0), key


# --- non-finite vertex data --------------------------------------------------------------

BAD_VALUES = [float("nan"), float("inf"), -float("inf")]


@pytest.mark.parametrize("bad", BAD_VALUES, ids=["nan", "inf", "-inf"])
@pytest.mark.parametrize("where", ["vertices", "normals", "uvs"])
def test_non_finite_vertex_data_is_rejected_naming_the_mesh(bad, where):
    scene = pc.Scene()
    scene.add_material(pc.Diffuse(0.5))
    v, t = quad(1.0)
    normals = np.tile([0.0, 0.0, 1.0], (4, 1))
    uvs = np.zeros((4, 2))
    arrays = dict(vertices=v.copy(), normals=normals, uvs=uvs)
    arrays[where][2, 1] = bad
    scene.add_mesh("broken mesh", arrays["vertices"], t, normals=arrays["normals"], uvs=arrays["uvs"])
    scene.camera = pc.Camera.looking_at((0, 0, 3), (0, 0, 0))
    with pytest.raises(ValueError, match="broken mesh") as e:
        pc.render(scene, **SMALL)
    assert "finite" in str(e.value)


@pytest.mark.parametrize("bad", BAD_VALUES, ids=["nan", "inf", "-inf"])
def test_non_finite_transform_and_light_are_rejected_naming_the_object(bad):
    scene = pc.Scene()
    v, t = quad(1.0)
    m = np.eye(4)
    m[0, 3] = bad
    with pytest.raises(ValueError, match="mover"):
        scene.add_mesh("mover", v, t, transform=m)
    scene = pc.Scene()
    scene.add_mesh("mesh", v, t)
    scene.add_light(pc.PointLight((0, bad, 1), name="bad bulb"))
    with pytest.raises(ValueError, match="bad bulb"):
        pc.render(scene, **SMALL)


USDA_BAD_POINTS = """#usda 1.0
(
    upAxis = "Z"
    metersPerUnit = 1
)
def Xform "World"
{
    def Mesh "broken"
    {
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 2]
        point3f[] points = [(0, 0, 0), (1, 0, 0), (0, %s, 0)]
    }
}
"""


@pytest.mark.parametrize("bad", ["nan", "inf", "-inf"])
def test_non_finite_usd_points_are_rejected_naming_the_prim(tmp_path, bad):
    """The prim is skipped with one warning naming it (docs/usd.md, "Bad input"); the
    (now empty) scene renders black."""
    pytest.importorskip("pxr")
    from polychrome.usd import read_stage

    path = tmp_path / "bad.usda"
    path.write_text(USDA_BAD_POINTS % bad)
    with pytest.warns(UserWarning, match="/World/broken: point 2 is not finite; it is skipped"):
        scene = read_stage(path)
    assert not scene.description()[0]["instances"]
    assert np.all(pc.render(scene, **SMALL).rgba[..., :3] == 0.0)


# --- empty scene -------------------------------------------------------------------------


def test_empty_scene_renders_black():
    scene = pc.Scene()
    for key, r in render_all(scene).items():
        assert np.all(r.rgba[..., :3] == 0.0) and np.all(r.depth == 0.0), key


def test_empty_scene_with_world_sees_the_world():
    scene = pc.Scene()
    scene.set_world(spectra.equal_energy(0.5))
    for key, r in render_all(scene, methods=ALL_METHODS[:3]).items():
        mean_close(r, 0.5, 1e-4, key)


# --- coordinates of 1e6 units ------------------------------------------------------------


def room(offset):
    """A closed room 200 units wide with a sphere and a ceiling light, shifted by offset."""
    o = np.asarray(offset, float)
    scene = pc.Scene()
    wall = scene.add_material(pc.Diffuse((0.7, 0.6, 0.5), name="wall"))
    ball = scene.add_material(pc.Diffuse((0.2, 0.5, 0.8), name="ball"))
    lamp = scene.add_material(pc.Emitter((1, 1, 1), strength=4.0, name="lamp"))
    v, t = box((-100, -100, 0), (100, 100, 200))
    scene.add_mesh("room", v + o, t, material=wall)
    v, t = uv_sphere((20.0, 10.0, 40.0), 40.0, rings=24, segments=48)
    scene.add_mesh("ball", v + o, t, material=ball)
    v, t = quad(30.0, z=199.0)
    scene.add_mesh("lamp", v + o, t[:, ::-1], material=lamp)
    scene.camera = pc.Camera.looking_at(o + (0, -95, 100), o + (0, 0, 60), focal_length=20.0)
    return scene


@pytest.mark.parametrize("direction", ["BACKWARD", "BIDIRECTIONAL", "FORWARD"])
def test_scene_translated_by_1e6_renders_like_the_original(direction):
    """At 1e6 units an f32 ulp is 0.0625: without robust ray offsets every bounce would
    re-hit its own surface (acne, black speckles). Compare 4×4-pixel block means."""
    kw = dict(width=32, height=32, samples=16, max_bounces=4, direction=direction)
    a = render_checked(room((0, 0, 0)), **kw)
    b = render_checked(room((1e6, -1e6, 1e6)), **kw)
    ya = luminance(a.rgba).reshape(8, 4, 8, 4)
    yb = luminance(b.rgba).reshape(8, 4, 8, 4)
    ma, mb = ya.mean((1, 3)), yb.mean((1, 3))
    se = np.sqrt(ya.var((1, 3), ddof=1) / 16 + yb.var((1, 3), ddof=1) / 16)
    assert np.all(np.abs(ma - mb) <= 5 * se + 0.03 * ma + 1e-4), np.max(np.abs(ma - mb) / (se + 1e-9))
    la, lb = luminance(a.rgba), luminance(b.rgba)
    se_mean = math.sqrt(la.var(ddof=1) / la.size + lb.var(ddof=1) / lb.size)
    assert abs(lb.mean() - la.mean()) <= 5 * se_mean + 0.02 * la.mean(), (la.mean(), lb.mean(), se_mean)
    if direction == "FORWARD":
        return  # light tracing fills no depth pass
    # Depth is measured from the camera, so it must not change (beyond the 0.06-unit
    # vertex rounding at 1e6, which moves a few silhouette samples).
    close = np.isclose(a.depth, b.depth, rtol=2e-3, atol=0.1)
    assert close.mean() >= 0.97, close.mean()
    assert b.depth.mean() == pytest.approx(a.depth.mean(), rel=2e-3)


# --- RGB colours on tiny grids (the uplift's fallback) ----------------------------------


@pytest.mark.parametrize("count", [4, 5, 6, 7, 8, 9, 10, 11])
def test_rgb_scene_renders_on_tiny_grids(count):
    """docs/design.md#spectra: 4..401 samples work. On 4, 5, 7, 8, 9 and 11 samples over 380..780 nm no
    bounded, exactly reversible basis exists; the fallback (a fine-grid basis averaged
    over each sample's cell) keeps reflectances in [0, 1] and white flat, and the render
    reports its round-trip error."""
    settings = json.dumps({"wavelength_count": count})
    rgb = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1], [0.2, 0.7, 0.4], [0, 0, 0]], np.float32)
    refl = _core.uplift(rgb, "reflectance", settings)
    assert refl.shape == (6, count)
    assert np.all(refl >= 0) and np.all(refl <= 1 + 1e-6)
    assert np.allclose(refl[3], 1.0, atol=1e-6)  # white stays flat
    assert np.allclose(refl[5], 0.0)
    scene = pc.Scene()
    red = scene.add_material(pc.Diffuse((0.9, 0.1, 0.1), name="red"))
    lamp = scene.add_material(pc.Emitter((1.0, 0.9, 0.8), strength=3.0, name="lamp"))
    v, t = quad(2.0)
    scene.add_mesh("floor", v, t, material=red)
    v, t = quad(0.5, z=2.0)
    scene.add_mesh("lamp", v, t[:, ::-1], material=lamp)
    scene.add_light(pc.PointLight((1, 1, 1), power=20.0, color=(0.2, 0.4, 1.0), name="blue bulb"))
    scene.set_world((0.1, 0.1, 0.1))
    scene.camera = pc.Camera.looking_at((0, -3, 3), (0, 0, 0))
    r = render_checked(scene, wavelength_count=count)
    y = luminance(r.rgba)
    assert y.mean() > 0
    err = r.stats["uplift_round_trip_error"]
    assert 0 <= err < (1.0 if count <= 5 else 0.3), err
    if count in (6, 10):
        assert err < 1e-4  # the exact basis exists on these grids
