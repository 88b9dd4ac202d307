"""The Python API end to end: closed-form renders, determinism, progress, cancellation,
clear errors for bad input, and image files."""

import math

import numpy as np
import pytest

import polychrome as pc
from conftest import luminance
from meshes import uv_sphere


def furnace_scene(emission, albedo):
    scene = pc.Scene()
    scene.add_material(pc.Diffuse(albedo, emission=emission))
    v, t = uv_sphere(radius=3.0)
    scene.add_mesh("furnace", v, t)
    scene.camera = pc.Camera.looking_at((0, 0, 0), (1, 0, 0))
    return scene


def test_furnace_sees_emission_over_one_minus_albedo():
    result = pc.render(furnace_scene(0.25, 0.5), width=16, height=16, samples=16, max_bounces=100)
    y = luminance(result.rgba)
    expected = 0.25 / (1 - 0.5)
    se = y.std(ddof=1) / math.sqrt(y.size)
    assert abs(y.mean() - expected) < 4 * se + 1e-3, (y.mean(), expected, se)
    assert result.stats["nonfinite_samples"] == 0


def test_point_light_on_plane_matches_closed_form():
    rho, power, h = 0.6, 50.0, 1.5
    scene = pc.Scene()
    scene.add_material(pc.Diffuse(rho))
    scene.add_mesh("plane", [[-5, -5, 0], [5, -5, 0], [5, 5, 0], [-5, 5, 0]], [[0, 1, 2], [0, 2, 3]])
    scene.add_light(pc.PointLight((0, 0, h), power=power, color=1.0))
    scene.camera = pc.Camera(
        to_world=np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 4.0], [0, 0, 0, 1]]), projection="ORTHOGRAPHIC", ortho_scale=2.0
    )
    # Only the random position inside each pixel is noisy here; 256 samples keep it < 0.3 %.
    result = pc.render(scene, width=21, height=21, samples=256, max_bounces=1)
    intensity = power / (4 * math.pi)

    def expected(px, py):
        """L = ρ/π · I · cos θ / d², averaged over the pixel's footprint (the film's box filter)."""
        u = (px + (np.arange(64) + 0.5) / 64) / 21 * 2 - 1
        v = 1 - (py + (np.arange(64) + 0.5) / 64) / 21 * 2
        x, y = np.meshgrid(u, v)
        d2 = x * x + y * y + h * h
        return float(np.mean(rho / math.pi * intensity * (h / np.sqrt(d2)) / d2))

    for px, py in [(10, 10), (0, 0), (20, 3), (5, 17)]:
        got = luminance(result.rgba[py, px])
        assert abs(got - expected(px, py)) < 0.01 * expected(px, py), (px, py, got, expected(px, py))


def small_scene():
    scene = pc.Scene()
    scene.add_material(pc.Diffuse((0.8, 0.3, 0.2), name="red"))
    scene.add_material(pc.Emitter(pc.spectra.blackbody(4000), strength=20, name="lamp"))
    v, t = uv_sphere(radius=1.0, rings=8, segments=16)
    scene.add_mesh("ball", v, t, material=0)
    scene.add_mesh("lamp", v * 0.3 + [1.5, -1.0, 1.5], t, material=1)
    scene.camera = pc.Camera.looking_at((0, -5, 1), (0, 0, 0))
    return scene


def test_same_seed_same_pixels_on_one_and_two_threads():
    scene = small_scene()
    a = pc.render(scene, width=24, height=16, samples=3, seed=7, threads=1)
    b = pc.render(scene, width=24, height=16, samples=3, seed=7, threads=2)
    c = pc.render(scene, width=24, height=16, samples=3, seed=8, threads=2)
    assert np.array_equal(a.rgba, b.rgba)
    assert not np.array_equal(a.rgba, c.rgba)


def test_progress_is_reported_and_returning_false_cancels():
    calls = []

    def progress(done, total):
        calls.append((done, total))
        return False

    result = pc.render(small_scene(), width=256, height=256, samples=4096, progress=progress)
    assert calls and calls[0][1] == 256 * 256 * 4096
    assert result.stats["cancelled"]
    assert result.stats["samples_per_pixel"] < 4096


def test_time_limit_stops_early():
    result = pc.render(small_scene(), width=64, height=64, samples=1_000_000, time_limit=0.3)
    assert result.stats["time_limited"]
    assert 1 <= result.stats["samples_per_pixel"] < 1_000_000


@pytest.mark.parametrize(
    "vertices, triangles, message",
    [
        ([[0, 0, 0], [1, np.nan, 0], [0, 1, 0]], [[0, 1, 2]], "mesh 'Bad': vertex 1 has a non-finite"),
        ([[0, 0, 0], [1, np.inf, 0], [0, 1, 0]], [[0, 1, 2]], "mesh 'Bad': vertex 1 has a non-finite"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 5]], "mesh 'Bad': triangle 0 refers to vertex 5"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, -1]], "mesh 'Bad': triangle 0 has a negative"),
        ([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]], "mesh 'Bad': vertices must have shape"),
    ],
)
def test_bad_mesh_data_names_the_object(vertices, triangles, message):
    scene = pc.Scene()
    scene.add_material(pc.Diffuse(0.5))
    with pytest.raises(ValueError, match=message):
        scene.add_mesh("Bad", vertices, triangles)
        pc.render(scene, width=4, height=4, samples=1)


@pytest.mark.parametrize(
    "material, message",
    [
        (pc.Diffuse(-0.5, name="Neg"), "material 'Neg': reflectance: value -0.5"),
        (pc.Diffuse(1.5, name="Bright"), "material 'Bright': reflectance 1.5 exceeds 1"),
        (
            pc.Diffuse(pc.spectra.tabulated([500, 400], [0.1, 0.2]), name="Order"),
            "material 'Order': reflectance: wavelengths not strictly ascending",
        ),
        (pc.Emitter(pc.spectra.constant(-2), name="Dark"), "material 'Dark': emission: value -2"),
    ],
)
def test_bad_spectra_name_the_material(material, message):
    scene = pc.Scene()
    scene.add_material(material)
    scene.add_mesh("m", [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    with pytest.raises(ValueError, match=message):
        pc.render(scene, width=4, height=4, samples=1)


@pytest.mark.parametrize(
    "settings, message",
    [
        ({"wavelengths": [400, 500, 450, 600]}, "not strictly ascending"),
        ({"samples": 0}, "samples"),
        ({"method": "NOPE"}, "method"),
        ({"uplift": "NOPE"}, "uplift"),
        ({"width": 0}, "width"),
        ({"time_limit": -1}, "time_limit"),
    ],
)
def test_bad_settings_raise_value_error(settings, message):
    with pytest.raises(ValueError, match=message):
        pc.render(small_scene(), **{"width": 4, "height": 4, "samples": 1, **settings})


def test_empty_scene_renders_black():
    result = pc.render(pc.Scene(), width=8, height=8, samples=2)
    assert np.all(result.rgba[..., :3] == 0) and np.all(result.rgba[..., 3] == 1)


def test_result_files_are_written(tmp_path):
    import OpenEXR
    from PIL import Image

    result = pc.render(small_scene(), width=20, height=10, samples=2)
    png = result.save(tmp_path / "out.png")
    exr = result.save(tmp_path / "out.exr", passes=True)
    assert Image.open(png).size == (20, 10)
    channels = OpenEXR.File(str(exr), separate_channels=True).channels()
    assert {"Combined.R", "Depth.Z", "Normal.X", "Albedo.R"} <= set(channels)
    np.testing.assert_allclose(channels["Combined.G"].pixels, result.rgba[..., 1])
    with pytest.raises(ValueError, match="unsupported"):
        result.save(tmp_path / "out.tiff")
