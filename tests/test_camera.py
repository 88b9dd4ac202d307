"""The Python camera (pc.Camera), its USD form and the spectral panorama example
(docs/camera.md). The projections themselves are checked against Cycles in
tests/blender/test_camera.py and against closed forms in rust/core/src/camera."""

from __future__ import annotations

import math
from pathlib import Path
import sys

import numpy as np
import pytest

import polychrome as pc
from polychrome import colordiff, imageio

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def emissive_scene(camera: pc.Camera) -> pc.Scene:
    scene = pc.Scene()
    glow = scene.add_material(pc.Emitter(pc.spectra.constant(1.0), strength=1.0, name="glow"))
    v = np.array([[-50, 50, -50], [50, 50, -50], [50, 50, 50], [-50, 50, 50]], np.float32)
    scene.add_mesh("wall", v, np.array([[0, 1, 2], [0, 2, 3]]), material=glow)
    scene.camera = camera
    return scene


def test_fstop_sets_the_aperture_radius_as_cycles_does():
    # Cycles (blender/camera.cpp): radius = lens [m] / (2 N); orthographic: 1 / (2 N).
    assert pc.Camera(focal_length=50.0, fstop=2.0).to_dict()["aperture_radius"] == pytest.approx(0.0125)
    assert pc.Camera(projection="ORTHOGRAPHIC", fstop=4.0).to_dict()["aperture_radius"] == pytest.approx(0.125)
    assert pc.Camera(aperture_radius=0.3).to_dict()["aperture_radius"] == 0.3
    assert pc.Camera().to_dict()["aperture_radius"] == 0.0
    with pytest.raises(ValueError, match="fstop or aperture_radius"):
        pc.Camera(fstop=2.0, aperture_radius=0.1).to_dict()
    with pytest.raises(ValueError, match="camera 'Lens'.*zero or positive"):
        pc.Camera(fstop=-1.0, name="Lens").to_dict()


def test_bad_camera_settings_name_the_camera():
    with pytest.raises(ValueError, match="camera 'Pano'.*panorama_type"):
        pc.Camera(projection="PANORAMIC", panorama_type="SPHERE", name="Pano").to_dict()
    with pytest.raises(ValueError, match="5 coefficients"):
        pc.Camera(fisheye_polynomial=(1.0, 2.0)).to_dict()
    with pytest.raises(ValueError, match="aperture_blades"):
        pc.Camera(aperture_blades=-3).to_dict()
    # The core checks what needs the image: a lens with no focus distance, a bad aspect.
    for kwargs, message in [
        (dict(aperture_radius=0.1, focus_distance=0.0), "focus distance"),
        (dict(pixel_aspect=0.0), "pixel aspect"),
        (dict(projection="PANORAMIC", panorama_type="FISHEYE_EQUISOLID", fisheye_lens=0.0), "fisheye lens"),
    ]:
        with pytest.raises(ValueError, match=f"camera 'Bad'.*{message}"):
            pc.render(emissive_scene(pc.Camera(name="Bad", **kwargs)), width=4, height=4, samples=1)


def test_fisheye_renders_black_outside_its_circle():
    # An equidistant fisheye on a square image sees through a disk; the corners are black.
    cam = pc.Camera.looking_at((0, 0, 0), (0, 1, 0), projection="PANORAMIC", panorama_type="FISHEYE_EQUIDISTANT")
    img = pc.render(emissive_scene(cam), width=16, height=16, samples=4).rgba
    assert np.all(img[0, 0, :3] == 0) and np.all(img[-1, -1, :3] == 0)
    assert np.all(img[8, 8, :3] > 0.5)


def crossing(profile, x, level):
    """First x where ``profile`` reaches ``level`` (linear between samples)."""
    i = int(np.argmax(profile >= level))
    return float(np.interp(level, profile[i - 1 : i + 1], x[i - 1 : i + 1]))


def test_depth_of_field_blurs_an_edge_by_the_circle_of_confusion():
    """An emissive half-plane edge 4 m away, focus at 1 m: on the image plane at distance
    1 a point spreads over a disk of radius R·|1/f − 1/z| (thin lens), so the edge becomes
    the disk's cumulative profile, which rises from 10 % to 90 % over ±0.6870 r (chord
    offsets where a disk's area fraction is 10 % and 90 %)."""
    radius, focus, z, n = 0.05, 1.0, 4.0, 200
    cam = pc.Camera(aperture_radius=radius, focus_distance=focus, sensor_width=36.0, focal_length=36.0)
    scene = pc.Scene()
    glow = scene.add_material(pc.Emitter(pc.spectra.constant(1.0), strength=1.0, name="glow"))
    v = np.array([[0, -50, -z], [50, -50, -z], [50, 50, -z], [0, 50, -z]], np.float32)  # x ≥ 0 at depth z
    scene.add_mesh("half", v, np.array([[0, 1, 2], [0, 2, 3]]), material=glow)
    scene.camera = cam
    img = pc.render(scene, width=n, height=4, samples=256, seed=1, wavelength_count=4).rgba
    profile = img[..., 1].mean(axis=0)
    profile = profile / profile[-20:].mean()
    x = (np.arange(n) + 0.5) / n - 0.5  # the image plane at distance 1 spans [-0.5, 0.5]
    r = radius * abs(1 / focus - 1 / z)  # 7.5 pixels
    lo, hi = crossing(profile, x, 0.1), crossing(profile, x, 0.9)
    assert hi - lo == pytest.approx(2 * 0.6870 * r, rel=0.1), (hi - lo, r)
    assert (lo + hi) / 2 == pytest.approx(0.0, abs=0.1 * r)


def test_usd_round_trip_keeps_lens_panorama_and_pixel_aspect(tmp_path):
    pytest.importorskip("pxr")
    from pxr import Usd, UsdGeom

    from polychrome import usd

    cam = pc.Camera.looking_at(
        (1, -4, 2),
        (0, 0, 0.5),
        focal_length=85.0,
        fstop=1.4,
        focus_distance=3.5,
        aperture_blades=7,
        aperture_rotation=0.2,
        aperture_ratio=1.3,
        pixel_aspect=1.5,
        shift_x=0.05,
    )
    scene = emissive_scene(cam)
    path = usd.write_stage(scene, tmp_path / "lens.usda", pc.RenderSettings(width=40, height=20))
    back = usd.read_stage(path).camera.to_dict()
    want = cam.to_dict()
    for k in want:
        if k in ("to_world", "name"):
            continue
        if isinstance(want[k], str):
            assert back[k] == want[k], k
        else:
            assert back[k] == pytest.approx(want[k], rel=1e-6), k
    # Other tools see the lens through UsdGeomCamera's fStop and focusDistance.
    stage = Usd.Stage.Open(str(path))
    g = UsdGeom.Camera(stage.GetPrimAtPath("/World/Camera")).GetCamera(Usd.TimeCode.Default())
    assert g.fStop == pytest.approx(1.4, rel=1e-6) and g.focusDistance == pytest.approx(3.5, rel=1e-6)
    # A panoramic camera survives through polychrome:camera.
    scene.camera = pc.Camera(projection="PANORAMIC", panorama_type="FISHEYE_EQUISOLID", fisheye_lens=8.0, latitude_min=-0.3)
    back = usd.read_stage(usd.write_stage(scene, tmp_path / "pano.usda")).camera
    assert (back.projection, back.panorama_type, back.fisheye_lens, back.latitude_min) == ("PANORAMIC", "FISHEYE_EQUISOLID", 8.0, -0.3)


def test_usd_fstop_and_focus_distance_from_another_tool(tmp_path):
    pytest.importorskip("pxr")
    from pxr import Usd, UsdGeom

    from polychrome import usd

    stage = Usd.Stage.CreateNew(str(tmp_path / "dof.usda"))
    UsdGeom.SetStageMetersPerUnit(stage, 0.01)  # centimetres
    cam = UsdGeom.Camera.Define(stage, "/cam")
    cam.CreateFocalLengthAttr(5.0)  # tenths of a unit: 0.5 cm = 5 mm
    cam.CreateFStopAttr(2.0)
    cam.CreateFocusDistanceAttr(250.0)  # 2.5 m
    stage.Save()
    c = usd.read_stage(tmp_path / "dof.usda").camera
    # Aperture diameter = focal length / f-number: 0.5 cm / 2 → radius 0.125 cm.
    assert c.focal_length == pytest.approx(5.0)
    assert c.aperture_radius == pytest.approx(0.00125) and c.focus_distance == pytest.approx(2.5)


def test_spectral_panorama_example_is_an_hdri_of_the_room(tmp_path):
    """The example's equirectangular render, used as an environment, shows the room as the
    room itself does from the same point (its RGB preview; mean ΔE00 on 2×2 blocks); a
    mirrored panorama does not. The spectral EXR reads back exactly."""
    sys.path.insert(0, str(EXAMPLES))
    import spectral_panorama as sp

    result = sp.render_panorama(256, 32, wavelengths=21)
    assert result.spectral.shape == (128, 256, 21)
    path = tmp_path / "pano.exr"
    imageio.write_spectral_exr(path, result.spectral, result.wavelengths, rgba=result.rgba)
    wl, spectral = imageio.read_spectral_exr(path)
    np.testing.assert_allclose(wl, result.wavelengths, rtol=1e-6)
    np.testing.assert_array_equal(spectral, result.spectral.astype(np.float32))

    def blocks(a):
        return a[..., :3].reshape(16, 2, 16, 2, 3).mean(axis=(1, 3))

    a, b = sp.perspective_both_ways(result.rgba[..., :3], 32, 32)
    white = float(np.percentile(a[..., 1], 99))
    de = colordiff.image_delta_e(blocks(a), blocks(b), white_luminance=white).mean()
    a, m = sp.perspective_both_ways(result.rgba[:, ::-1, :3].copy(), 32, 32)
    mirrored = colordiff.image_delta_e(blocks(a), blocks(m), white_luminance=white).mean()
    print(f"room vs its panorama as a world: ΔE00 {de:.2f} (mirrored: {mirrored:.1f})")
    assert de < 2.5 and mirrored > 20.0


def test_pixel_aspect_squeezes_the_view():
    # 2:1 pixels on a 20×10 image see what a 40×10 image of square pixels sees.
    cam = pc.Camera.looking_at((0, -3, 0), (0, 0, 0), shift_x=0.1)
    scene = pc.Scene()
    glow = scene.add_material(pc.Emitter(pc.spectra.constant(1.0), strength=1.0, name="glow"))
    v = np.array([[0.0, 0, -5], [5, 0, -5], [5, 0, 5], [0.0, 0, 5]], np.float32)
    scene.add_mesh("half", v, np.array([[0, 1, 2], [0, 2, 3]]), material=glow)
    scene.camera = cam
    wide = pc.render(scene, width=40, height=10, samples=64, seed=2, wavelength_count=4).rgba[..., 1].mean(axis=0)
    cam.pixel_aspect = 2.0
    squeezed = pc.render(scene, width=20, height=10, samples=64, seed=2, wavelength_count=4).rgba[..., 1].mean(axis=0)
    assert 5 < np.argmax(squeezed > 0.5 * squeezed.max()) < 15  # the edge is in view
    np.testing.assert_allclose(squeezed, wide.reshape(20, 2).mean(axis=1), atol=0.05 * wide.max())
    assert math.isclose(squeezed.mean(), wide.mean(), rel_tol=0.02)
