"""The paper's fixed polychromatic grid against hero wavelengths at equal time
(docs/methods.md, HERO), release build.

    python bench/hero.py [--size 32] [--seconds 2 8] [--write docs/BENCHMARKS.md]

Three scenes of bench/methods.py: the closed room of spectral diffuse walls under a
3500 K lamp (fig. 12), the same room with a dispersive N-SF11 ball (fig. 13), and the
diffuse room under a CIE F11 tri-band fluorescent lamp (a line spectrum; its strength is
set so the room is as bright as under the 3500 K lamp). Each is rendered by
POLYCHROMATIC and HERO, backward tracing, on a 41-sample grid (10 nm, the paper's) and
on an 81-sample grid (5 nm: the resolution of the CIE F-series tables, so the
continuous limit of this scene data), every render stopped by the same time limit. The
error is the mean ΔE00 against a converged reference: POLYCHROMATIC on the 81-sample
grid at many samples. A grid of 41 samples converges to a slightly different image (its
quadrature of the spectra), shown as the 41-sample reference's own ΔE00.
"""

from __future__ import annotations

import argparse
import platform
import sys
from pathlib import Path

import numpy as np

import polychrome as pc
from polychrome import spectra
from polychrome.colordiff import delta_e_stats, image_delta_e

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import write_section  # noqa: E402
from methods import room  # noqa: E402

CONTENDERS = [("POLYCHROMATIC", 41), ("HERO", 41), ("POLYCHROMATIC", 81), ("HERO", 81)]


def render(scene, method, n, size, *, samples, seconds=0.0, seed=1):
    r = pc.render(
        scene,
        width=size,
        height=size,
        samples=samples,
        method=method,
        wavelength_count=n,
        max_bounces=8,
        noise_threshold=0.0,
        time_limit=seconds,
        seed=seed,
    )
    return r.rgba, r.stats


def f11_room(size: int) -> pc.Scene:
    """The diffuse room under F11, scaled to the luminance of the 3500 K room."""

    def mean_y(scene):
        img, _ = render(scene, "POLYCHROMATIC", 41, size, samples=16, seed=99)
        return float(np.mean(img[..., :3] @ np.array([0.2126, 0.7152, 0.0722])))

    scene = room(False, lamp=spectra.fluorescent(11))
    scale = mean_y(room(False)) / mean_y(scene)
    return room(False, lamp=spectra.fluorescent(11, scale))


def measure(scene, size, seconds, ref_spp):
    reference, ref_stats = render(scene, "POLYCHROMATIC", 81, size, samples=ref_spp, seed=12345)
    grid41, _ = render(scene, "POLYCHROMATIC", 41, size, samples=ref_spp, seed=12345)
    bias41 = delta_e_stats(image_delta_e(grid41, reference))["mean"]
    rows = []
    for t in seconds:
        for method, n in CONTENDERS:
            img, st = render(scene, method, n, size, samples=1_000_000, seconds=t)
            de = delta_e_stats(image_delta_e(img, reference))["mean"]
            rows.append(dict(seconds=t, method=method, n=n, spp=st["samples_per_pixel"], de=de))
            print(rows[-1], file=sys.stderr)
    return rows, bias41, ref_stats


def table(name, rows, bias41, ref_spp, ref_stats):
    lines = [
        f"**{name}.** Reference: POLYCHROMATIC, 81 wavelengths, {ref_spp} spp ({ref_stats['seconds']:.0f} s); "
        f"POLYCHROMATIC at 41 wavelengths and {ref_spp} spp is ΔE00 {bias41:.3f} from it (the 10 nm grid's own error).",
        "",
        "| time limit | method | λ | spp reached | mean ΔE00 | best at this time |",
        "| ---: | --- | ---: | ---: | ---: | :---: |",
    ]
    for t in sorted({r["seconds"] for r in rows}):
        at = [r for r in rows if r["seconds"] == t]
        best = min(r["de"] for r in at)
        for r in at:
            mark = "✓" if r["de"] == best else ""
            lines.append(f"| {t:g} s | {r['method']} | {r['n']} | {r['spp']} | {r['de']:.3f} | {mark} |")
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=32)
    ap.add_argument("--seconds", type=float, nargs="+", default=[2.0, 8.0])
    ap.add_argument("--ref-spp", type=int, default=8192)
    ap.add_argument("--write", help="Markdown file to update with the results")
    args = ap.parse_args(argv)
    scenes = [
        ("Diffuse room, 3500 K lamp (fig. 12)", room(False)),
        ("Room with a dispersive N-SF11 ball (fig. 13)", room(True)),
        ("Diffuse room, CIE F11 lamp (line spectrum)", f11_room(args.size)),
    ]
    lines = [
        f"{args.size}×{args.size}, max 8 bounces, backward tracing, no adaptive stop; every render of a table stopped by "
        f"the same time limit. {platform.processor() or platform.machine()}, all cores, shared machine, one run each.",
        "",
    ]
    for name, scene in scenes:
        rows, bias41, ref_stats = measure(scene, args.size, args.seconds, args.ref_spp)
        lines += table(name, rows, bias41, args.ref_spp, ref_stats) + [""]
    text = "\n".join(lines).rstrip() + "\n"
    print(text)
    if args.write:
        secs = " ".join(f"{s:g}" for s in args.seconds)
        cmd = f"python bench/hero.py --size {args.size} --seconds {secs} --ref-spp {args.ref_spp} --write {args.write}"
        write_section(Path(args.write), "Hero wavelengths against the paper's grid", text, cmd)
    return 0


if __name__ == "__main__":
    sys.exit(main())
