"""`polychrome render` flags for every RenderSettings field of the spectral methods:
--method, --direction, --dispersion-splitting, --wavelengths (a count or a list),
--wavelength-min/--wavelength-max, --max-bounces, --uplift, --spectral-output. Each flag
must reach the render as the RenderSettings field of the same name, and bad values
give exit status 2 with a one-line message naming the flag."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pxr")

import polychrome as pc  # noqa: E402
from polychrome import cli, imageio, usd  # noqa: E402
import sys  # noqa: E402

render_module = sys.modules["polychrome.render"]  # the module (polychrome.render is also the function)


def small_stage(tmp_path):
    """A lit diffuse plane and a glass slab, seen from above; 8×6 pixels, 2 spp."""
    scene = pc.Scene()
    scene.add_mesh(
        "floor",
        np.array([[-2, -2, 0], [2, -2, 0], [2, 2, 0], [-2, 2, 0]], float),
        [[0, 1, 2], [0, 2, 3]],
        material=pc.Diffuse(pc.spectra.narrow_band(560.0, 80.0) * 0.7, name="paint"),
    )
    scene.add_mesh(
        "slab",
        np.array([[-1, -1, 0.5], [1, -1, 0.5], [1, 1, 0.5], [-1, 1, 0.5]], float),
        [[0, 1, 2], [0, 2, 3]],
        material=pc.Dielectric(pc.ior.named("N-SF11"), name="flint"),
    )
    scene.add_light(pc.PointLight((0.5, -0.5, 3.0), power=300.0, color=pc.spectra.d65(), name="key"))
    scene.camera = pc.Camera.looking_at((0.0, -4.0, 3.0), (0.0, 0.0, 0.0), focal_length=35.0)
    return usd.write_stage(scene, tmp_path / "shot.usda", pc.RenderSettings(width=8, height=6, samples=2, seed=1))


@pytest.fixture
def captured(monkeypatch):
    """Records the RenderSettings each CLI render receives (and still renders)."""
    seen = []
    original = render_module.render

    def spy(scene, settings=None, **kw):
        result = original(scene, settings, **kw)
        seen.append((settings, result.stats))
        return result

    monkeypatch.setattr(render_module, "render", spy)
    return seen


def test_spectral_flags_reach_the_render_settings(tmp_path, captured):
    stage = small_stage(tmp_path)
    out = tmp_path / "a.exr"
    argv = [
        "render",
        str(stage),
        "-o",
        str(out),
        "--quiet",
        "--method",
        "polychromatic",
        "--direction",
        "bidirectional",
        "--dispersion-splitting",
        "--wavelengths",
        "21",
        "--wavelength-min",
        "400",
        "--wavelength-max",
        "700",
        "--max-bounces",
        "3",
        "--uplift",
        "smooth",
    ]
    assert cli.main(argv) == 0
    settings, stats = captured[-1]
    assert (settings.method, settings.direction, settings.dispersion_splitting) == ("POLYCHROMATIC", "BIDIRECTIONAL", True)
    assert (settings.wavelength_count, settings.wavelength_min, settings.wavelength_max) == (21, 400.0, 700.0)
    assert (settings.max_bounces, settings.uplift) == (3, "SMOOTH")
    assert stats["direction"] == "BIDIRECTIONAL" and stats["wavelengths"] == 21 and stats["max_bounces"] == 3
    # --no-dispersion-splitting and the other methods/directions.
    assert (
        cli.main(
            [
                "render",
                str(stage),
                "-o",
                str(out),
                "--quiet",
                "--method",
                "MONOCHROMATIC_RAYS",
                "--direction",
                "FORWARD",
                "--no-dispersion-splitting",
                "--wavelengths",
                "16",
            ]
        )
        == 0
    )
    settings, stats = captured[-1]
    assert (settings.method, settings.direction, settings.dispersion_splitting) == ("MONOCHROMATIC_RAYS", "FORWARD", False)
    assert stats["method"] == "MONOCHROMATIC_RAYS" and stats["direction"] == "FORWARD" and stats["wavelengths"] == 16
    # Without the flags the stage's settings (and RenderSettings defaults) stand.
    assert cli.main(["render", str(stage), "-o", str(out), "--quiet"]) == 0
    settings, _ = captured[-1]
    assert (settings.method, settings.direction, settings.dispersion_splitting) == ("POLYCHROMATIC", "BACKWARD", False)


def test_explicit_wavelength_list_and_spectral_output_write_a_spectral_exr(tmp_path, captured):
    stage = small_stage(tmp_path)
    out = tmp_path / "spectral.exr"
    grid = [400.0, 450.0, 500.0, 540.0, 560.0, 580.0, 620.0, 700.0]  # non-uniform
    assert (
        cli.main(["render", str(stage), "-o", str(out), "--quiet", "--wavelengths", ",".join(f"{x:g}" for x in grid), "--spectral-output"])
        == 0
    )
    settings, stats = captured[-1]
    assert settings.wavelengths == grid and settings.spectral_output is True and stats["wavelengths"] == len(grid)
    wavelengths, spectral = imageio.read_spectral_exr(out)
    np.testing.assert_allclose(np.asarray(wavelengths, float), grid)
    assert spectral.shape[:2] == (6, 8) and spectral.shape[2] == len(grid) and np.all(np.isfinite(spectral))


def test_rgb_method_flag_changes_the_image(tmp_path):
    """--method reaches the core: RGB mode renders the narrow-band paint differently."""
    stage = small_stage(tmp_path)
    a, b = tmp_path / "spectral.exr", tmp_path / "rgb.exr"
    common = ["--quiet", "--samples", "8", "--wavelengths", "41", "--max-bounces", "1", "--direction", "BACKWARD"]
    assert cli.main(["render", str(stage), "-o", str(a), *common]) == 0
    assert cli.main(["render", str(stage), "-o", str(b), "--method", "RGB", *common]) == 0
    ia, ib = imageio.read_image(a)[..., :3], imageio.read_image(b)[..., :3]
    assert np.abs(ia - ib).max() > 0.01 * max(ia.max(), 1e-6)


@pytest.mark.parametrize(
    "flags,message",
    [
        (["--method", "HYPERSPECTRAL"], "--method"),
        (["--direction", "SIDEWAYS"], "--direction"),
        (["--uplift", "CUBIC"], "--uplift"),
        (["--wavelengths", "0"], "--wavelengths"),
        (["--wavelengths", "500,450"], "--wavelengths"),
        (["--wavelengths", "blue"], "--wavelengths"),
        (["--wavelength-min", "200"], "--wavelength-min"),
        (["--max-bounces", "-1"], "--max-bounces"),
        (["--method", "RGB", "--dispersion-splitting"], "dispersion_splitting"),
    ],
)
def test_bad_flag_values_exit_2_with_one_line(tmp_path, capsys, flags, message):
    stage = small_stage(tmp_path)
    assert cli.main(["render", str(stage), "-o", str(tmp_path / "x.png"), "--quiet", *flags]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
