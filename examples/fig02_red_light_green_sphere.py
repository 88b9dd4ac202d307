"""The paper's figures 2 and 3: a green sphere under a narrow-band red light.

    python examples/fig02_red_light_green_sphere.py [--samples 64] [--width 320] [--height 240]
        [--wavelengths 41] [--center 630] [--fwhm 20] [--out examples/out/fig02_red_light_green_sphere] [--docs]

The scene is rendered twice with the same settings: once in RGB mode (``method="RGB"``:
the sphere's reflectance and the light reduced to their RGB, multiplied per channel)
and once spectrally (``POLYCHROMATIC``, 41 wavelengths). The image shows the RGB render
on the left half and the spectral one on the right (the paper's layout). RGB is only
right when the surface colour was defined under the light that shines on it (eq. 2, 5):
here the light is a narrow band in the red, where the green paint reflects almost
nothing, yet RGB mode multiplies the light's red by the paint's (non-zero) red.

Prints the mean colour of the sphere in both renders and their CIEDE2000 difference.
Writes ``<out>.png``/``.exr`` (split), and ``<out>_rgb``/``<out>_spectral`` full images.
"""

from __future__ import annotations

import argparse
from pathlib import Path
import sys

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import figlib  # noqa: E402

import polychrome as pc  # noqa: E402
from polychrome import spectra  # noqa: E402


def build_scene(light: spectra.Spectrum, sphere=None) -> pc.Scene:
    """Green sphere (radius 1) on a light grey floor under a large square area light
    whose radiance is ``light``; the camera looks slightly down at the sphere."""
    scene = pc.Scene()
    paint = scene.add_material(pc.Diffuse(sphere or figlib.green_paint(), name="green paint"))
    floor = scene.add_material(pc.Diffuse(0.6, name="grey floor"))
    lamp = scene.add_material(pc.Emitter(light, name="lamp"))
    v, t, n = figlib.uv_sphere((0.0, 0.0, 1.0), 1.0)
    scene.add_mesh("sphere", v, t, normals=n, material=paint)
    s = 12.0
    scene.add_mesh("floor", *figlib.quad((-s, -s, 0), (s, -s, 0), (s, s, 0), (-s, s, 0)), material=floor)
    # A 3 × 3 lamp up and to the left, facing the sphere.
    c, target = np.array([-3.0, -2.5, 5.0]), np.array([0.0, 0.0, 1.0])
    m = pc.look_at(c, target)
    right, up = m[:3, 0] * 1.5, m[:3, 1] * 1.5
    corners = [c - right - up, c - right + up, c + right + up, c + right - up]
    scene.add_mesh("lamp", *figlib.quad(*corners), material=lamp)
    scene.camera = pc.Camera.looking_at((0.0, -6.5, 2.4), (0.0, 0.0, 0.9), focal_length=45.0)
    return scene


def sphere_mask(result: pc.RenderResult) -> np.ndarray:
    """Pixels that see the sphere: their first-hit albedo (under D65) is the green paint's."""
    a = result.albedo[..., :3]
    return (a[..., 1] > 1.5 * a[..., 0]) & (a[..., 1] > 0.05)


def render_pair(scene: pc.Scene, **settings):
    """(RGB-mode render, spectral render) with the same settings."""
    rgb = pc.render(scene, method="RGB", **settings)
    spectral = pc.render(scene, method="POLYCHROMATIC", **settings)
    return rgb, spectral


def compare(rgb: pc.RenderResult, spectral: pc.RenderResult) -> dict:
    """Mean sphere colour in each render (same pixels) and their ΔE00. The Lab white is
    the luminance of the brightest floor pixel of the spectral image, so that both
    halves are judged against the same white."""
    mask = sphere_mask(spectral)
    a, b = figlib.masked_mean(rgb.rgba, mask), figlib.masked_mean(spectral.rgba, mask)
    white = float(np.percentile((spectral.rgba[..., :3] @ figlib.RGB_TO_XYZ[1])[~mask], 99))
    return {"rgb": a, "spectral": b, "white_y": white, "delta_e": figlib.delta_e(a, b, white), "pixels": int(mask.sum())}


def run(light: spectra.Spectrum, default_out: str, what: str, argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=64)
    parser.add_argument("--width", type=int, default=320)
    parser.add_argument("--height", type=int, default=240)
    parser.add_argument("--wavelengths", type=int, default=41)
    parser.add_argument("--out", default=str(figlib.OUT / default_out))
    parser.add_argument("--docs", action="store_true", help="also write a PNG to docs/images/")
    args = parser.parse_args(argv)
    settings = dict(
        width=args.width,
        height=args.height,
        samples=args.samples,
        wavelength_count=args.wavelengths,
        max_bounces=6,
        seed=1,
        **figlib.fixed(),
    )
    rgb, spectral = render_pair(build_scene(light), **settings)
    out = Path(args.out)
    figlib.save(rgb.rgba, out.with_name(out.name + "_rgb"))
    figlib.save(spectral.rgba, out.with_name(out.name + "_spectral"))
    written = figlib.save(figlib.split(rgb.rgba, spectral.rgba), out, docs=args.docs)
    c = compare(rgb, spectral)
    print("wrote", ", ".join(str(p) for p in written))
    print(f"{what}: sphere colour (linear Rec.709, mean of {c['pixels']} pixels)")
    print(f"  RGB mode   {np.round(c['rgb'], 4)}")
    print(f"  spectral   {np.round(c['spectral'], 4)}")
    print(f"  CIEDE2000  {c['delta_e']:.1f}  (Lab white Y = {c['white_y']:.3f}, the bright floor)")
    print(f"  {spectral.stats['seconds'] + rgb.stats['seconds']:.1f} s for both renders")
    return c


def red_light() -> spectra.Spectrum:
    """Narrow band at 630 nm, 20 nm wide, luminance 2.5."""
    return figlib.with_luminance(spectra.narrow_band(630.0, 20.0), 2.5)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(add_help=False)
    parser.add_argument("--center", type=float, default=630.0)
    parser.add_argument("--fwhm", type=float, default=20.0)
    known, rest = parser.parse_known_args(argv)
    light = figlib.with_luminance(spectra.narrow_band(known.center, known.fwhm), 2.5)
    run(light, "fig02_red_light_green_sphere", f"narrow-band red light ({known.center:g} nm, FWHM {known.fwhm:g} nm)", rest)
    return 0


if __name__ == "__main__":
    sys.exit(main())
