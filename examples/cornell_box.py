"""A Cornell-style box with spectral walls and a spectral area light.

    python examples/cornell_box.py [--samples 256] [--size 320] [--out examples/out/cornell_box]

Writes PNG (sRGB preview) and EXR (scene-linear) images and prints the render stats.
The wall reflectances are smooth tabulated spectra (synthetic, shaped like the paint of
the original Cornell box); the light is a 3000 K blackbody, so the image is warm.
"""

from __future__ import annotations

import argparse
from pathlib import Path
import sys

import numpy as np

import polychrome as pc


def sigmoid_reflectance(low: float, high: float, center: float, width: float, falling: bool = False) -> pc.spectra.Spectrum:
    """A smooth step between two reflectance levels, sampled every 5 nm."""
    lam = np.arange(360.0, 831.0, 5.0)
    s = 1.0 / (1.0 + np.exp(-(lam - center) / width))
    if falling:
        s = 1.0 - s
    return pc.spectra.tabulated(lam, low + (high - low) * s)


def quad(a, b, c, d):
    return np.array([a, b, c, d], dtype=np.float32), np.array([[0, 1, 2], [0, 2, 3]])


def box(center, size, angle_deg):
    """An axis-aligned box rotated about Z."""
    cx, cy, cz = center
    sx, sy, sz = (s / 2 for s in size)
    corners = np.array([[x, y, z] for z in (-sz, sz) for y in (-sy, sy) for x in (-sx, sx)], dtype=np.float64)
    a = np.radians(angle_deg)
    rot = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    v = corners @ rot.T + [cx, cy, cz + sz]
    faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    tris = [[f[0], f[1], f[2]] for f in faces] + [[f[0], f[2], f[3]] for f in faces]
    return v, np.array(tris)


def build_scene() -> pc.Scene:
    scene = pc.Scene()
    white = scene.add_material(pc.Diffuse(sigmoid_reflectance(0.55, 0.75, 450, 20), name="white"))
    red = scene.add_material(pc.Diffuse(sigmoid_reflectance(0.05, 0.65, 600, 12), name="red"))
    green = scene.add_material(
        pc.Diffuse(
            pc.spectra.tabulated(
                np.arange(360.0, 831.0, 5.0),
                0.05 + 0.45 * np.exp(-0.5 * ((np.arange(360.0, 831.0, 5.0) - 530.0) / 35.0) ** 2),
            ),
            name="green",
        )
    )
    light = scene.add_material(pc.Emitter(pc.spectra.blackbody(3000.0), strength=30.0, name="light"))

    s = 1.0  # the box spans [-1, 1] in x and y, [0, 2] in z
    scene.add_mesh("floor", *quad((-s, -s, 0), (s, -s, 0), (s, s, 0), (-s, s, 0)), material=white)
    scene.add_mesh("ceiling", *quad((-s, -s, 2), (-s, s, 2), (s, s, 2), (s, -s, 2)), material=white)
    scene.add_mesh("back", *quad((-s, s, 0), (s, s, 0), (s, s, 2), (-s, s, 2)), material=white)
    scene.add_mesh("left", *quad((-s, -s, 0), (-s, s, 0), (-s, s, 2), (-s, -s, 2)), material=red)
    scene.add_mesh("right", *quad((s, -s, 0), (s, -s, 2), (s, s, 2), (s, s, 0)), material=green)
    l = 0.25
    scene.add_mesh("light", *quad((-l, -l, 1.999), (-l, l, 1.999), (l, l, 1.999), (l, -l, 1.999)), material=light)
    scene.add_mesh("tall box", *box((-0.35, 0.3, 0.0), (0.6, 0.6, 1.2), 18.0), material=white)
    scene.add_mesh("short box", *box((0.35, -0.35, 0.0), (0.6, 0.6, 0.6), -18.0), material=white)
    scene.camera = pc.Camera.looking_at((0.0, -3.9, 1.0), (0.0, 0.0, 1.0), focal_length=35.0)
    return scene


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=128)
    parser.add_argument("--size", type=int, default=256, help="image width and height in pixels")
    parser.add_argument("--wavelengths", type=int, default=41, help="wavelength_count")
    parser.add_argument("--out", default=str(Path(__file__).parent / "out" / "cornell_box"), help="output path without extension")
    args = parser.parse_args(argv)
    result = pc.render(
        build_scene(), width=args.size, height=args.size, samples=args.samples, wavelength_count=args.wavelengths, progress=True
    )
    out = Path(args.out)
    print("wrote", result.save(out.with_suffix(".png")), "and", result.save(out.with_suffix(".exr"), passes=True))
    s = result.stats
    print(f"{s['samples_per_pixel']} spp, {s['wavelengths']} wavelengths, {s['seconds']:.2f} s on {s['threads']} threads")
    return 0


if __name__ == "__main__":
    sys.exit(main())
