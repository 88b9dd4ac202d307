"""The paper's method timing (figures 12 and 13, docs/design.md#timing): a closed room of spectral
diffuse walls with an area light, and the same room with a dispersive glass ball,
rendered at 41 wavelengths with each method, release build.

    python bench/methods.py [--size 32] [--max-seconds 60] [--write docs/BENCHMARKS.md]

Reports, as ratios to POLYCHROMATIC (backward tracing for every method):
(a) time at equal samples per wavelength: POLYCHROMATIC and RGB at S spp,
    MONOCHROMATIC_SCENES at S spp per wavelength image, MONOCHROMATIC_RAYS at S·n spp
    (each of its paths carries one of the n wavelengths);
(b) time to reach mean ΔE00 ≤ 1 against a converged POLYCHROMATIC reference: each
    method is rendered at doubling sample counts and timed at the first count that
    meets the target (render seconds, scene build excluded). RGB converges to a
    different image, so it has no (b).
"""

from __future__ import annotations

import argparse
import platform
import sys
from pathlib import Path
from typing import Any

import numpy as np

import polychrome as pc
from polychrome import spectra
from polychrome.colordiff import delta_e_stats, image_delta_e

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import write_section  # noqa: E402

N = 41
METHODS = ("POLYCHROMATIC", "MONOCHROMATIC_RAYS", "MONOCHROMATIC_SCENES", "RGB")
SPLIT = "POLYCHROMATIC + dispersion_splitting"


class Glass(pc.Material):
    """Dispersive glass of the catalogue (the core's dielectric)."""

    def __init__(self, glass: str = "N-SF11", name: str = "Glass"):
        self.glass = glass
        self.name = name

    def bsdf_dict(self) -> dict[str, Any]:
        return {"type": "dielectric", "ior": {"type": "named", "name": self.glass}}


def quad(a, b, c, d):
    return np.array([a, b, c, d], dtype=np.float32), np.array([[0, 1, 2], [0, 2, 3]])


def uv_sphere(center, radius, rings=24, segments=48):
    th = np.linspace(0, np.pi, rings + 1)[:, None]
    ph = np.linspace(0, 2 * np.pi, segments + 1)[None, :]
    v = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th) + 0 * ph], -1).reshape(-1, 3)
    v = v * radius + np.asarray(center)
    row = segments + 1
    t = [[r * row + s, r * row + s + row, r * row + s + 1] for r in range(rings) for s in range(segments)]
    t += [[r * row + s + 1, r * row + s + row, r * row + s + row + 1] for r in range(rings) for s in range(segments)]
    return v.astype(np.float32), np.array(t)


def room(glass: bool, lamp: spectra.Spectrum | None = None) -> pc.Scene:
    """Closed room (fig. 12): spectral diffuse walls, a ceiling light (3500 K, or the
    spectrum `lamp`), the camera inside; with `glass`, a dispersive N-SF11 ball on the
    floor (fig. 13)."""
    scene = pc.Scene()
    lam = np.arange(360.0, 831.0, 5.0)
    white = scene.add_material(pc.Diffuse(spectra.tabulated(lam, 0.55 + 0.2 / (1 + np.exp(-(lam - 450) / 20))), name="white"))
    red = scene.add_material(pc.Diffuse(spectra.tabulated(lam, 0.05 + 0.6 / (1 + np.exp(-(lam - 600) / 12))), name="red"))
    green = scene.add_material(pc.Diffuse(spectra.tabulated(lam, 0.05 + 0.45 * np.exp(-0.5 * ((lam - 530) / 35) ** 2)), name="green"))
    lamp = scene.add_material(pc.Emitter(lamp or spectra.blackbody(3500.0), strength=2.0, name="lamp"))
    s = 1.0
    scene.add_mesh("floor", *quad((-s, -s, 0), (s, -s, 0), (s, s, 0), (-s, s, 0)), material=white)
    scene.add_mesh("ceiling", *quad((-s, -s, 2), (-s, s, 2), (s, s, 2), (s, -s, 2)), material=white)
    scene.add_mesh("back", *quad((-s, s, 0), (s, s, 0), (s, s, 2), (-s, s, 2)), material=white)
    scene.add_mesh("front", *quad((-s, -s, 0), (-s, -s, 2), (s, -s, 2), (s, -s, 0)), material=white)
    scene.add_mesh("left", *quad((-s, -s, 0), (-s, s, 0), (-s, s, 2), (-s, -s, 2)), material=red)
    scene.add_mesh("right", *quad((s, -s, 0), (s, -s, 2), (s, s, 2), (s, s, 0)), material=green)
    l = 0.7
    scene.add_mesh("lamp", *quad((-l, -l, 1.99), (-l, l, 1.99), (l, l, 1.99), (l, -l, 1.99)), material=lamp)
    if glass:
        g = scene.add_material(Glass("N-SF11"))
        scene.add_mesh("ball", *uv_sphere((0.15, 0.2, 0.45), 0.45), material=g)
    scene.camera = pc.Camera.looking_at((0.0, -0.95, 1.0), (0.0, 1.0, 0.8), focal_length=14.0)
    return scene


def run(scene, method, samples, size, seed=1):
    split = method == SPLIT
    method = "POLYCHROMATIC" if split else method
    r = pc.render(
        scene,
        width=size,
        height=size,
        samples=samples,
        method=method,
        dispersion_splitting=split,
        wavelength_count=N,
        max_bounces=8,
        seed=seed,
    )
    return r.rgba, r.stats["seconds"] - r.stats["build_seconds"]


def measure(scene, size: int, spp: int, ref_spp: int, max_seconds: float, target: float = 1.0, methods=METHODS):
    reference, ref_time = run(scene, "POLYCHROMATIC", ref_spp, size, seed=12345)
    out = {}
    for m in methods:
        equal = spp * N if m == "MONOCHROMATIC_RAYS" else spp
        _, t_equal = run(scene, m, equal, size)
        t_target, s_target, de = None, None, None
        if m != "RGB":
            s = 1
            while True:
                img, t = run(scene, m, s, size)
                de = delta_e_stats(image_delta_e(img, reference))["mean"]
                if de <= target:
                    t_target, s_target = t, s
                    break
                if t > max_seconds or s >= ref_spp // 4 * (N if m == "MONOCHROMATIC_RAYS" else 1):
                    t_target, s_target = None, s
                    break
                s *= 2
        out[m] = dict(equal=t_equal, target=t_target, spp=s_target, de=de)
        print(m, out[m], file=sys.stderr)
    return out, ref_time


def table(name: str, res, size: int, spp: int, methods=METHODS) -> list[str]:
    base = res["POLYCHROMATIC"]
    lines = [
        f"**{name}**, {size}×{size}, {N} wavelengths, max 8 bounces, backward tracing.",
        "",
        f"| method | (a) time at {spp} spp per wavelength | vs POLYCHROMATIC | (b) time to mean ΔE00 ≤ 1 | spp needed | vs POLYCHROMATIC |",
        "| --- | ---: | ---: | ---: | ---: | ---: |",
    ]
    for m in methods:
        r = res[m]
        a = f"{r['equal']:.2f} s | {r['equal'] / base['equal']:.2f}×"
        if m == "RGB":
            b = "— (converges to a different image) | — | —"
        elif r["target"] is None:
            b = f"not reached (ΔE {r['de']:.2f} at {r['spp']} spp) | {r['spp']} | —"
        else:
            ratio = r["target"] / base["target"] if base["target"] else float("nan")
            b = f"{r['target']:.2f} s | {r['spp']} | {ratio:.2f}×"
        lines.append(f"| {m} | {a} | {b} |")
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=24)
    parser.add_argument("--spp", type=int, default=64, help="samples per wavelength for (a)")
    parser.add_argument("--ref-spp", type=int, default=16384, help="samples of the converged reference")
    parser.add_argument("--max-seconds", type=float, default=60.0, help="give up on (b) after a render this long")
    parser.add_argument("--write", help="Markdown file to update with the results")
    args = parser.parse_args(argv)
    lines = [
        "The paper (41 wavelengths, Core2 Duo): monochromatic scenes take 3.1× (fig. 12) and 2.9× (fig. 13) "
        "the time of polychromatic rays. Ratios > 1 mean slower than POLYCHROMATIC. "
        f"{platform.processor() or platform.machine()}, all cores, one run each (noisy).",
        "(b) doubles the sample count until the target is met, so its times resolve a factor of about 2. "
        "The machine is shared (other builds may run at the same time): small (a) times are the noisiest.",
        "",
    ]
    for name, glass in (("Room, spectral diffuse walls (fig. 12)", False), ("Room with a dispersive N-SF11 ball (fig. 13)", True)):
        methods = METHODS[:1] + ((SPLIT,) if glass else ()) + METHODS[1:]
        res, ref_time = measure(room(glass), args.size, args.spp, args.ref_spp, args.max_seconds, methods=methods)
        lines += table(name, res, args.size, args.spp, methods)
        lines += ["", f"Reference: POLYCHROMATIC, {args.ref_spp} spp ({ref_time:.1f} s).", ""]
    text = "\n".join(lines).rstrip() + "\n"
    print(text)
    if args.write:
        cmd = f"python bench/methods.py --size {args.size} --spp {args.spp} --ref-spp {args.ref_spp} --max-seconds {args.max_seconds:g} --write {args.write}"
        write_section(Path(args.write), "Methods (paper figures 12 and 13)", text, cmd)
    return 0


if __name__ == "__main__":
    sys.exit(main())
