"""Dispersive glass that converges (issue 21): time to mean ΔE00 ≤ 1 against a converged
reference on three caustic scenes, for every method and direction, and for each way a
polychromatic path chooses its wavelength at a dispersive surface (setting `collapse`,
docs/methods.md): ENERGY (eq. 9), STRATIFIED, SPLIT into k, and the paper's splitting
into every wavelength (`dispersion_splitting`). Release build.

    python bench/caustics.py [--ref-spp 1024] [--spp 16 64] [--write docs/BENCHMARKS.md]

Scenes (small, so the whole bench runs in minutes):
- the glass room of fig. 13 (bench/methods.py `room(glass=True)`: an N-SF11 ball), 24×24;
- the prism of fig. 6 (examples/fig06_prism.py: D65 cone light through N-BK7 onto a
  screen, the camera facing the screen), 64×24;
- a glass of water on a table under a sun (a water column, index from the catalogue,
  the thin glass wall left out; the sun a distant light, a sharp caustic), 32×32.

Each configuration is rendered at the given sample counts with two seeds: render
seconds (scene build excluded), mean ΔE00 to the reference (polychrome.colordiff, white =
the reference's 99th-percentile luminance; for the prism only the pixels the reference
shows lit), and the mean ΔE00 between the two seeds / √2, the render's own error free of
the reference's noise (on this shared machine a reference converged to ΔE00 ≪ 1 took
longer than the bench may run: a 2048-spp one of the room was 0.94 from a second one).
The reference: POLYCHROMATIC BIDIRECTIONAL at `--ref-spp`. BACKWARD cannot sample a delta
light's caustic (the prism, the sun): those rows are left out; MONOCHROMATIC_RAYS and
HERO are measured in the last direction of each scene only.
"""

from __future__ import annotations

import argparse
import math
import platform
import sys
from pathlib import Path

import numpy as np

import polychrome as pc
from polychrome import spectra
from polychrome.colordiff import image_delta_e, linear_rgb_to_xyz

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "examples"))
from common import write_section  # noqa: E402
from methods import Glass, quad, room  # noqa: E402

import fig06_prism  # noqa: E402

N = 41

#: (label, method, extra settings) of the polychromatic collapse strategies.
COLLAPSES = [
    ("ENERGY", "POLYCHROMATIC", {"collapse": "ENERGY"}),
    ("STRATIFIED", "POLYCHROMATIC", {"collapse": "STRATIFIED"}),
    ("SPLIT k=4", "POLYCHROMATIC", {"collapse": "SPLIT", "collapse_k": 4}),
    ("SPLIT k=8", "POLYCHROMATIC", {"collapse": "SPLIT", "collapse_k": 8}),
    ("split into all 41", "POLYCHROMATIC", {"collapse": "ENERGY", "dispersion_splitting": True}),
]
OTHERS = [
    ("MONOCHROMATIC_RAYS", "MONOCHROMATIC_RAYS", {}),
    ("HERO", "HERO", {}),
]


def cylinder(center, radius, height, segments=48):
    """A closed cylinder standing on z = center[2]."""
    cx, cy, z0 = center
    ang = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    ring = np.stack([cx + radius * np.cos(ang), cy + radius * np.sin(ang)], -1)
    v = np.concatenate(
        [np.c_[ring, np.full(segments, z0)], np.c_[ring, np.full(segments, z0 + height)], [[cx, cy, z0], [cx, cy, z0 + height]]]
    )
    b, t = 2 * segments, 2 * segments + 1
    tris = []
    for i in range(segments):
        j = (i + 1) % segments
        tris += [[i, j, segments + j], [i, segments + j, segments + i], [b, j, i], [t, segments + i, segments + j]]
    return v.astype(np.float32), np.array(tris)


def water_glass() -> pc.Scene:
    """A water column (radius 0.3, 0.7 high) on a light table under a low sun: the sun's
    dispersed caustic lies on the table beside the shadow."""
    scene = pc.Scene()
    lam = np.arange(360.0, 831.0, 5.0)
    table = scene.add_material(pc.Diffuse(spectra.tabulated(lam, 0.6 + 0.15 / (1 + np.exp(-(lam - 520) / 30))), name="table"))
    water = scene.add_material(Glass("water", name="water"))
    s = 3.0
    scene.add_mesh("table", *quad((-s, -s, 0), (s, -s, 0), (s, s, 0), (-s, s, 0)), material=table)
    scene.add_mesh("water", *cylinder((0.0, 0.0, 0.0), 0.3, 0.7), material=water)
    elev = math.radians(35.0)
    scene.add_light(pc.SunLight(direction=(0.0, math.cos(elev), -math.sin(elev)), strength=3.0, color=spectra.d65(), name="sun"))
    scene.camera = pc.Camera.looking_at((0.0, -0.6, 2.2), (0.0, 0.55, 0.0), focal_length=24.0)
    return scene


def prism() -> pc.Scene:
    scene, _ = fig06_prism.build_scene(spectra.d65(), glass="N-BK7", camera="screen", table=False, spot_deg=2.0)
    return scene


#: (title, scene, width, height, directions, only lit pixels, max bounces)
SCENES = [
    ("Glass room (fig. 13, N-SF11 ball)", lambda: room(True), 24, 24, ("BACKWARD", "FORWARD", "BIDIRECTIONAL"), False, 8),
    ("Prism (fig. 6, N-BK7, D65 cone light onto a screen)", prism, 64, 24, ("FORWARD", "BIDIRECTIONAL"), True, 3),
    ("Glass of water on a table under a sun", water_glass, 32, 32, ("FORWARD", "BIDIRECTIONAL"), False, 6),
]


def render(scene, w, h, spp, method, direction, extra, bounces, seed=1):
    r = pc.render(
        scene,
        width=w,
        height=h,
        samples=spp,
        method=method,
        direction=direction,
        wavelength_count=N,
        max_bounces=bounces,
        noise_threshold=0.0,
        seed=seed,
        **extra,
    )
    assert r.stats["nonfinite_samples"] == 0
    return r.rgba, r.stats["seconds"] - r.stats["build_seconds"]


def scorer(reference, lit_only):
    y = linear_rgb_to_xyz(reference[..., :3])[..., 1]
    white = float(np.percentile(y, 99)) or 1.0
    mask = y > 0.02 * white if lit_only else np.ones(y.shape, bool)

    def score(img):
        return float(image_delta_e(img, reference, white_luminance=white)[mask].mean())

    return score


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ref-spp", type=int, default=1024, help="samples of the reference")
    parser.add_argument("--spp", type=int, nargs="+", default=[16, 64], help="the sample counts measured")
    parser.add_argument("--only", help="scene title prefix to run (default: all)")
    parser.add_argument("--write", help="Markdown file to update with the results")
    args = parser.parse_args(argv)
    lines = [
        f"{platform.processor() or platform.machine()}, all cores (2, shared: the load average was above 20 while this ran, "
        f"so seconds are slow and noisy; compare rows of one table), {N} wavelengths, one run each. "
        "For each sample count: render seconds (scene build excluded), the mean ΔE00 to the reference, and the mean ΔE00 "
        "between two renders of different seeds divided by √2 (`noise`: the render's own error, free of the reference's "
        "noise). Lower noise at equal time is better.",
        "",
    ]
    for title, make, w, h, directions, lit_only, bounces in SCENES:
        if args.only and not title.startswith(args.only):
            continue
        scene = make()
        reference, ref_t = render(scene, w, h, args.ref_spp, "POLYCHROMATIC", "BIDIRECTIONAL", {}, bounces, seed=12345)
        score = scorer(reference, lit_only)
        print(f"{title}: reference {ref_t:.1f} s", file=sys.stderr)
        head = " | ".join(f"{n} spp: s / ΔE ref / noise" for n in args.spp)
        lines += [
            f"**{title}**, {w}×{h}, max {bounces} bounces{', ΔE over the pixels the reference shows lit' if lit_only else ''}. "
            f"Reference: POLYCHROMATIC BIDIRECTIONAL, {args.ref_spp} spp ({ref_t:.1f} s).",
            "",
            f"| direction | method | collapse | {head} |",
            "| --- | --- | --- | " + " | ".join("---:" for _ in args.spp) + " |",
        ]
        for d in directions:
            rows = COLLAPSES if d != "FORWARD" else COLLAPSES[:2]  # light paths never split
            for label, method, extra in rows + (OTHERS if d == directions[-1] else []):
                cells = []
                for n in args.spp:
                    a, t = render(scene, w, h, n, method, d, extra, bounces, seed=1)
                    b, _ = render(scene, w, h, n, method, d, extra, bounces, seed=2)
                    noise = score_pair(a, b, reference, lit_only) / math.sqrt(2.0)
                    cells.append(f"{t:.2f} / {score(a):.2f} / **{noise:.2f}**")
                    print(f"  {d} {label} {n} spp: {t:.2f} s, dE {score(a):.2f}, noise {noise:.2f}", file=sys.stderr)
                collapse = label if method == "POLYCHROMATIC" else "—"
                lines.append(f"| {d} | {method} | {collapse} | " + " | ".join(cells) + " |")
        lines.append("")
    text = "\n".join(lines).rstrip() + "\n"
    print(text)
    if args.write:
        cmd = f"python bench/caustics.py --ref-spp {args.ref_spp} --spp {' '.join(map(str, args.spp))} --write {args.write}"
        write_section(Path(args.write), "Dispersive glass: wavelength choice at the collapse", text, cmd)
    return 0


def score_pair(a, b, reference, lit_only):
    """Mean ΔE00 between two renders, white and mask from the reference."""
    y = linear_rgb_to_xyz(reference[..., :3])[..., 1]
    white = float(np.percentile(y, 99)) or 1.0
    mask = y > 0.02 * white if lit_only else np.ones(y.shape, bool)
    return float(image_delta_e(a, b, white_luminance=white)[mask].mean())


if __name__ == "__main__":
    sys.exit(main())
