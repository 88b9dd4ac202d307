"""The paper's figure 12: a closed room of spectral diffuse surfaces (no dispersion).

    python examples/fig12_room.py [--samples 48] [--width 320] [--height 240] [--wavelengths 41]
        [--compare] [--out examples/out/fig12_room] [--docs]

A closed room (the camera inside) with measured-looking spectral paints on the walls —
a warm white, a red and a green wall, a blue box and a yellow cylinder-like tall box —
lit by a ceiling panel with a 3500 K blackbody spectrum. Everything is spectral: the
walls are tabulated reflectance curves, the light a blackbody.

Renders POLYCHROMATIC (the paper's method) and prints the time. With ``--compare`` it
also renders the same image with MONOCHROMATIC_SCENES (one image per wavelength, the
same samples per wavelength: the paper's method timing of docs/design.md#timing) and
MONOCHROMATIC_RAYS, and prints their times as ratios and their mean ΔE00 to the
POLYCHROMATIC image (``bench/methods.py`` does this properly, at equal error).
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
from polychrome.colordiff import delta_e_stats, image_delta_e  # noqa: E402

L = figlib.LAM


def paints() -> dict[str, spectra.Spectrum]:
    """Smooth synthetic reflectance curves shaped like real paints."""
    g = lambda c, w: np.exp(-0.5 * ((L - c) / w) ** 2)
    s = lambda c, w: 1.0 / (1.0 + np.exp(-(L - c) / w))
    return {
        "warm white": spectra.tabulated(L, 0.55 + 0.2 * s(450, 20)),
        "red": spectra.tabulated(L, 0.05 + 0.6 * s(600, 12)),
        "green": spectra.tabulated(L, 0.06 + 0.45 * g(530, 35)),
        "blue": spectra.tabulated(L, 0.05 + 0.5 * g(455, 30) + 0.08 * s(680, 15)),
        "yellow": spectra.tabulated(L, 0.06 + 0.7 * s(530, 15)),
    }


def build_scene(glass: bool = False) -> pc.Scene:
    """The room (2 × 2 × 2: x, y in [-1, 1], z in [0, 2]); with ``glass`` the
    dispersive objects of figure 13 are added (see fig13_room_glass.py)."""
    scene = pc.Scene()
    p = {name: scene.add_material(pc.Diffuse(r, name=name)) for name, r in paints().items()}
    lamp = scene.add_material(pc.Emitter(spectra.blackbody(3500.0), strength=3.0, name="ceiling panel"))
    q = figlib.quad
    s = 1.0
    scene.add_mesh("floor", *q((-s, -s, 0), (s, -s, 0), (s, s, 0), (-s, s, 0)), material=p["warm white"])
    scene.add_mesh("ceiling", *q((-s, -s, 2), (-s, s, 2), (s, s, 2), (s, -s, 2)), material=p["warm white"])
    scene.add_mesh("back", *q((-s, s, 0), (s, s, 0), (s, s, 2), (-s, s, 2)), material=p["warm white"])
    scene.add_mesh("front", *q((-s, -s, 0), (-s, -s, 2), (s, -s, 2), (s, -s, 0)), material=p["warm white"])
    scene.add_mesh("left", *q((-s, -s, 0), (-s, s, 0), (-s, s, 2), (-s, -s, 2)), material=p["red"])
    scene.add_mesh("right", *q((s, -s, 0), (s, -s, 2), (s, s, 2), (s, s, 0)), material=p["green"])
    l = 0.45
    scene.add_mesh("lamp", *q((-l, -l, 1.99), (-l, l, 1.99), (l, l, 1.99), (l, -l, 1.99)), material=lamp)
    scene.add_mesh("blue box", *figlib.box((-0.45, 0.35, 0.0), (0.55, 0.55, 0.55), 20.0), material=p["blue"])
    scene.add_mesh("yellow tower", *figlib.box((0.5, 0.5, 0.0), (0.4, 0.4, 1.1), -15.0), material=p["yellow"])
    if glass:
        from fig13_room_glass import add_glass

        add_glass(scene)
    else:
        v, t, n = figlib.uv_sphere((0.1, -0.2, 0.3), 0.3)
        scene.add_mesh("white ball", v, t, normals=n, material=p["warm white"])
    scene.camera = pc.Camera.looking_at((0.0, -0.97, 1.15), (0.0, 1.0, 0.45), focal_length=14.0)
    return scene


def run(glass: bool, default_out: str, argv=None, doc: str | None = None) -> int:
    # The calling example passes its own docstring (fig13 reuses this runner).
    parser = argparse.ArgumentParser(description=(doc or __doc__).splitlines()[0])
    parser.add_argument("--samples", type=int, default=48)
    parser.add_argument("--width", type=int, default=320)
    parser.add_argument("--height", type=int, default=240)
    parser.add_argument("--wavelengths", type=int, default=41)
    parser.add_argument("--splitting", action="store_true", help="POLYCHROMATIC with dispersion_splitting")
    parser.add_argument("--compare", action="store_true", help="also time MONOCHROMATIC_SCENES and MONOCHROMATIC_RAYS")
    parser.add_argument("--out", default=str(figlib.OUT / default_out))
    parser.add_argument("--docs", action="store_true", help="also write a PNG to docs/images/")
    args = parser.parse_args(argv)
    scene = build_scene(glass)
    base = dict(width=args.width, height=args.height, wavelength_count=args.wavelengths, max_bounces=8, seed=1, **figlib.fixed())
    poly = pc.render(scene, samples=args.samples, dispersion_splitting=args.splitting, progress=True, **base)
    written = figlib.save(poly.rgba, Path(args.out), docs=args.docs)
    print("wrote", ", ".join(str(p) for p in written))
    t_poly = poly.stats["seconds"]
    print(f"POLYCHROMATIC{' + splitting' if args.splitting else ''}: {args.samples} spp, {args.wavelengths} wavelengths, {t_poly:.1f} s")
    if args.compare:
        for method, spp in (("MONOCHROMATIC_SCENES", args.samples), ("MONOCHROMATIC_RAYS", args.samples * args.wavelengths)):
            r = pc.render(scene, samples=spp, method=method, progress=True, **base)
            de = delta_e_stats(image_delta_e(r.rgba, poly.rgba))["mean"]
            figlib.save(r.rgba, Path(args.out).with_name(Path(args.out).name + "_" + method.lower()))
            print(
                f"{method}: {spp} spp{' per wavelength image' if method.endswith('SCENES') else ''}, {r.stats['seconds']:.1f} s "
                f"= {r.stats['seconds'] / t_poly:.1f}x POLYCHROMATIC; mean ΔE00 to it {de:.2f} (both noisy)"
            )
    return 0


def main(argv=None) -> int:
    return run(False, "fig12_room", argv)


if __name__ == "__main__":
    sys.exit(main())
