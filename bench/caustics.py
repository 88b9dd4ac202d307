"""Dispersive glass that converges (issue 21): time to mean ΔE00 ≤ 1 against a converged
reference on three caustic scenes, for every method and direction, and for each way a
polychromatic path chooses its wavelength at a dispersive surface (setting `collapse`,
docs/methods.md): ENERGY (eq. 9), STRATIFIED, SPLIT into k, and the paper's splitting
into every wavelength (`dispersion_splitting`). Release build.

    python bench/caustics.py [--max-seconds 3] [--ref-spp 4096] [--write docs/BENCHMARKS.md]

Scenes (small, so the whole bench runs in minutes):
- the glass room of fig. 13 (bench/methods.py `room(glass=True)`: an N-SF11 ball), 24×24;
- the prism of fig. 6 (examples/fig06_prism.py: D65 cone light through N-BK7 onto a
  screen, the camera facing the screen), 64×24;
- a glass of water on a table under a sun (a water column, index from the catalogue,
  the thin glass wall left out; the sun a distant light, a sharp caustic), 32×32.

Each configuration is rendered at doubling sample counts (from 2) and timed at the first
count whose mean ΔE00 (polychrome.colordiff, white = the reference's 99th-percentile
luminance; for the prism only the pixels the reference shows lit) is ≤ 1; render seconds,
scene build excluded. The reference: POLYCHROMATIC BIDIRECTIONAL at `--ref-spp`; its own
error is that of a second reference of another seed. BACKWARD cannot sample a delta
light's caustic (the prism, the sun): those rows are left out.
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
    v = np.concatenate([np.c_[ring, np.full(segments, z0)], np.c_[ring, np.full(segments, z0 + height)], [[cx, cy, z0], [cx, cy, z0 + height]]])
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


def time_to_target(scene, w, h, method, direction, extra, bounces, score, max_seconds, max_spp):
    spp, de = 2, float("nan")
    while True:
        img, t = render(scene, w, h, spp, method, direction, extra, bounces)
        de = score(img)
        if de <= 1.0:
            return t, spp, de
        if t > max_seconds or spp >= max_spp:
            return None, spp, de
        spp *= 2


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ref-spp", type=int, default=4096, help="samples of the converged reference")
    parser.add_argument("--max-seconds", type=float, default=3.0, help="give up after a render this long")
    parser.add_argument("--only", help="scene title prefix to run (default: all)")
    parser.add_argument("--write", help="Markdown file to update with the results")
    args = parser.parse_args(argv)
    lines = [
        f"{platform.processor() or platform.machine()}, all cores (2, shared: other jobs ran at the same time), "
        f"{N} wavelengths, one run each. Time to mean ΔE00 ≤ 1 (render seconds) at doubling sample counts from 2, "
        "so times resolve a factor of about 2; the ratio is to POLYCHROMATIC ENERGY (eq. 9) in the same direction. "
        f"`not reached`: ΔE00 at the last count, whose render took more than {args.max_seconds:g} s.",
        "",
    ]
    results = {}
    for title, make, w, h, directions, lit_only, bounces in SCENES:
        if args.only and not title.startswith(args.only):
            continue
        scene = make()
        reference, ref_t = render(scene, w, h, args.ref_spp, "POLYCHROMATIC", "BIDIRECTIONAL", {}, bounces, seed=12345)
        second, _ = render(scene, w, h, args.ref_spp, "POLYCHROMATIC", "BIDIRECTIONAL", {}, bounces, seed=54321)
        score = scorer(reference, lit_only)
        self_de = score(second)
        print(f"{title}: reference {ref_t:.1f} s, own error {self_de:.2f}", file=sys.stderr)
        lines += [
            f"**{title}**, {w}×{h}, max {bounces} bounces{', ΔE over the pixels the reference shows lit' if lit_only else ''}. "
            f"Reference: POLYCHROMATIC BIDIRECTIONAL, {args.ref_spp} spp ({ref_t:.1f} s); a second reference of another seed is at mean ΔE00 {self_de:.2f} from it.",
            "",
            "| direction | method | collapse | time to ΔE00 ≤ 1 | spp | vs ENERGY |",
            "| --- | --- | --- | ---: | ---: | ---: |",
        ]
        for d in directions:
            rows = COLLAPSES if d != "FORWARD" else COLLAPSES[:2]  # light paths never split
            base = None
            for label, method, extra in rows + OTHERS:
                t, spp, de = time_to_target(scene, w, h, method, d, extra, bounces, score, args.max_seconds, args.ref_spp // 4)
                results[(title, d, label)] = (t, spp, de)
                print(f"  {d} {label}: {t} s, {spp} spp, dE {de:.2f}", file=sys.stderr)
                if label == "ENERGY":
                    base = t
                shown_method = method if method != "POLYCHROMATIC" else "POLYCHROMATIC"
                collapse = label if method == "POLYCHROMATIC" else "—"
                if t is None:
                    cell = f"not reached (ΔE00 {de:.2f}) | {spp} | —"
                else:
                    ratio = f"{t / base:.2f}×" if base else "—"
                    cell = f"{t:.2f} s | {spp} | {ratio}"
                lines.append(f"| {d} | {shown_method} | {collapse} | {cell} |")
        lines.append("")
    text = "\n".join(lines).rstrip() + "\n"
    print(text)
    if args.write:
        cmd = f"python bench/caustics.py --ref-spp {args.ref_spp} --max-seconds {args.max_seconds:g} --write {args.write}"
        write_section(Path(args.write), "Dispersive glass: wavelength choice at the collapse", text, cmd)
    return 0


if __name__ == "__main__":
    sys.exit(main())
