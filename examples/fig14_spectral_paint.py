"""The paper's fig. 14 idea: objects with a measured spectral paint, lit by an RGB HDRI.

    python examples/fig14_spectral_paint.py [--samples 64] [--width 384] [--height 216]
                                            [--out examples/out/fig14_spectral_paint]

Mixed RGB and spectral data in one scene (docs/design.md#rgb-data): the sky is an RGB HDRI (generated
here, procedurally: a blue-to-white gradient, a warm sun disk with a glow, a dim ground)
converted to radiance at each lookup; the left ball wears a *measured* reflectance
spectrum (the ColorChecker "orange" patch, BabelColor average, from colour-science; a
smooth stand-in if colour-science is missing); the middle ball wears the RGB of that
same spectrum (seen under D65), converted by the linear uplift (eq. 10) — a metamer of
the paint, equal under D65 but not under the sky; the right ball and the ground are
image textures (an 8-bit sRGB checker and stripes) kept RGB and converted per hit.

Writes `<out>.png` (sRGB preview), `<out>.exr` (scene-linear, with passes) and the sky
as `<out>_sky.hdr` (Radiance RGBE), and prints the colour difference (ΔE00) between the
measured-paint ball and its RGB twin.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
import sys

import numpy as np

import polychrome as pc
from polychrome.colordiff import image_delta_e
from polychrome.texture import write_radiance_hdr


def sky_hdri(width: int = 512, height: int = 256, sun_elevation: float = 32.0, sun_azimuth: float = -50.0) -> np.ndarray:
    """A procedural lat-long sky (float32 RGB, top row = zenith), Blender's mapping:
    u = 0.5 − atan2(y, x)/2π, v = 0.5 + elevation/π (Z up)."""
    u = (np.arange(width) + 0.5) / width
    v = 1.0 - (np.arange(height) + 0.5) / height
    phi = (0.5 - u)[None, :] * 2 * np.pi
    el = ((v - 0.5) * np.pi)[:, None]
    d = np.stack([np.cos(el) * np.cos(phi), np.cos(el) * np.sin(phi), np.sin(el) * np.ones_like(phi)], axis=-1)
    se, sa = math.radians(sun_elevation), math.radians(sun_azimuth)
    sun = np.array([math.cos(se) * math.cos(sa), math.cos(se) * math.sin(sa), math.sin(se)])
    cos_sun = np.clip(d @ sun, -1.0, 1.0)
    angle = np.degrees(np.arccos(cos_sun))
    # Sky: horizon white-ish, zenith blue; a dim brownish ground below the horizon.
    t = np.clip(np.sin(el), 0.0, 1.0) ** 0.5
    horizon, zenith = np.array([0.95, 0.95, 1.0]), np.array([0.18, 0.35, 0.85])
    sky = (1 - t)[..., None] * horizon + t[..., None] * zenith
    sky = sky + (0.6 * np.exp(-angle / 12.0))[..., None] * np.array([1.0, 0.85, 0.6])  # glow
    ground = np.broadcast_to(np.array([0.12, 0.10, 0.08]), sky.shape)
    img = np.where((el >= 0)[..., None], sky, ground)
    img = np.where((angle < 1.5)[..., None], np.array([1500.0, 1300.0, 1050.0]), img)  # the sun
    return img.astype(np.float32)


def orange_paint() -> pc.spectra.Spectrum:
    """Measured reflectance of the ColorChecker "orange" patch (BabelColor average)."""
    try:
        import colour

        sd = colour.SDS_COLOURCHECKERS["BabelColor Average"]["orange"]
        return pc.spectra.tabulated(sd.wavelengths, np.clip(sd.values, 0.0, 1.0))
    except Exception:  # pragma: no cover - colour-science is a test extra
        print("colour-science not found: using a smooth stand-in for the orange paint", file=sys.stderr)
        lam = np.arange(380.0, 781.0, 10.0)
        return pc.spectra.tabulated(lam, 0.05 + 0.55 / (1 + np.exp(-(lam - 585.0) / 15.0)))


def rgb_under_d65(spectrum: pc.spectra.Spectrum) -> tuple[float, float, float]:
    """Linear Rec.709 RGB of a reflectance seen under D65 (white → (1, 1, 1))."""
    from polychrome import _core
    import json

    settings = json.dumps({})
    lam, w = _core.wavelength_grid(settings)
    refl = _core.spectrum_values(json.dumps(spectrum.to_dict()), settings, "reflectance")
    d65 = _core.spectrum_values(json.dumps(pc.spectra.d65().to_dict()), settings, "illuminant")
    xyz = lambda s: np.array(_core.spectrum_xyz(json.dumps(pc.spectra.tabulated(lam, s).to_dict()), settings))
    m = np.array([[3.2404542, -1.5371385, -0.4985314], [-0.9692660, 1.8760108, 0.0415560], [0.0556434, -0.2040259, 1.0572252]])
    rgb = (m @ xyz(refl * d65)) / (m @ xyz(d65))
    return tuple(float(c) for c in np.clip(rgb, 0.0, 1.0))


def sphere(center, radius, rings=48, segments=96):
    th = np.linspace(0, np.pi, rings + 1)[:, None]
    ph = np.linspace(0, 2 * np.pi, segments + 1)[None, :]
    n = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th) * np.ones_like(ph)], -1).reshape(-1, 3)
    row = segments + 1
    a = (np.arange(rings)[:, None] * row + np.arange(segments)[None, :]).ravel()
    t = np.concatenate([np.stack([a, a + row, a + 1], 1), np.stack([a + 1, a + row, a + row + 1], 1)])
    uv = np.stack([(ph * np.ones_like(th)).ravel() / (2 * np.pi), 1 - (th * np.ones_like(ph)).ravel() / np.pi], 1)
    return n * radius + np.asarray(center), t, n, uv


def build_scene() -> tuple[pc.Scene, np.ndarray]:
    scene = pc.Scene()
    sky = sky_hdri()
    scene.set_world(texture=pc.Texture.from_array(sky, name="procedural sky"), strength=1.0, rotation=0.0)

    paint = orange_paint()
    twin = rgb_under_d65(paint)
    checker = ((np.indices((64, 64)) // 8).sum(axis=0) % 2 * 150 + 60).astype(np.uint8)
    checker = np.stack([checker, checker, (checker * 0.9).astype(np.uint8)], axis=-1)
    stripes = np.zeros((1, 8, 3), np.uint8)
    stripes[0, ::2] = (30, 90, 200)
    stripes[0, 1::2] = (230, 220, 200)

    ground = np.array([[-6, -6, 0], [6, -6, 0], [6, 6, 0], [-6, 6, 0]], np.float32)
    scene.add_mesh(
        "ground",
        ground,
        [[0, 1, 2], [0, 2, 3]],
        uvs=[[0, 0], [3, 0], [3, 3], [0, 3]],
        material=pc.Diffuse(pc.Texture.from_array(checker, encoding="srgb", name="checker"), name="ground"),
    )
    for name, x, refl in [
        ("measured paint", -1.1, paint),
        ("RGB twin", 0.0, twin),
        ("striped texture", 1.1, pc.Texture.from_array(stripes, encoding="srgb", name="stripes")),
    ]:
        v, t, n, uv = sphere((x, 0.0, 0.5), 0.5)
        scene.add_mesh(name, v, t, normals=n, uvs=uv, material=pc.Diffuse(refl, name=name))
    scene.camera = pc.Camera.looking_at((0.0, -4.4, 0.9), (0.0, 0.0, 0.55), focal_length=40.0)
    return scene, sky


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=64)
    parser.add_argument("--width", type=int, default=384)
    parser.add_argument("--height", type=int, default=216)
    parser.add_argument("--out", default=str(Path(__file__).parent / "out" / "fig14_spectral_paint"))
    args = parser.parse_args(argv)
    scene, sky = build_scene()
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    write_radiance_hdr(out.with_name(out.name + "_sky.hdr"), sky)
    result = pc.render(scene, width=args.width, height=args.height, samples=args.samples, progress=True)
    print("wrote", result.save(out.with_suffix(".png")), "and", result.save(out.with_suffix(".exr"), passes=True))
    # The paint ball and its RGB twin: same colour under D65, different under the sky.
    h, w = args.height, args.width
    rgba = result.rgba
    left = rgba[h // 2 - 4 : h // 2 + 4, int(w * 0.27) - 4 : int(w * 0.27) + 4].reshape(-1, 4).mean(axis=0)
    mid = rgba[h // 2 - 4 : h // 2 + 4, w // 2 - 4 : w // 2 + 4].reshape(-1, 4).mean(axis=0)
    de = float(image_delta_e(left[None, None, :3], mid[None, None, :3]).mean())
    print(f"measured paint {left[:3].round(4)} vs RGB twin {mid[:3].round(4)}: ΔE00 {de:.2f}")
    s = result.stats
    print(
        f"{s['samples_per_pixel']} spp, {s['wavelengths']} wavelengths, {s['seconds']:.2f} s, textures {s['texture_bytes'] / 1024:.0f} KiB"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
