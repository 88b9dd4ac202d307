"""Speed against accuracy (issue 9): mean ΔE00 against a converged reference as a
function of render time, for each method and wavelength count (4, 8, 16, 41, 81) and
RGB, on the paper's rooms (fig. 12 without, fig. 13 with the dispersive ball), plus
the AUTO quality preset at several noise thresholds.

    python bench/quality.py [--size 24] [--budget 12] [--write docs/BENCHMARKS.md]

Each curve renders at doubling sample counts (1, 2, 4, ... spp; MONOCHROMATIC_RAYS
counts paths, so it starts at n spp) until one render takes more than `budget`
seconds. Times are render seconds of the core (scene build excluded), release build.
The reference is POLYCHROMATIC on 81 wavelengths at `--ref-samples` spp. (The
first run of this script, recorded in docs/BENCHMARKS.md on 2026-11-23, timed
stats["seconds"], which includes the scene build: up to ~0.1 s, visible only at the
left end of the curves.)
Plots: docs/images/quality_room.png, docs/images/quality_glass_room.png.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

import polychrome as pc
from polychrome.colordiff import image_delta_e

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from common import write_section  # noqa: E402
from methods import room  # noqa: E402

COUNTS = (4, 8, 16, 41, 81)
METHODS = ("POLYCHROMATIC", "MONOCHROMATIC_RAYS", "MONOCHROMATIC_SCENES")


def render(scene, size, **kw):
    r = pc.render(scene, width=size, height=size, max_bounces=8, seed=7, **kw)
    return r, r.stats["seconds"] - r.stats["build_seconds"]


def curve(scene, ref, size, budget, **kw):
    pts = []
    spp = kw.pop("start", 1)
    while True:
        r, sec = render(scene, size, samples=spp, noise_threshold=0.0, **kw)
        pts.append((sec, float(np.mean(image_delta_e(r.rgba, ref.rgba))), spp))
        if sec > budget or spp >= 8192:
            return pts
        spp *= 2


def time_to(pts, target=1.0):
    for sec, de, _ in pts:
        if de <= target:
            return sec
    return None


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=24)
    ap.add_argument("--budget", type=float, default=12.0, help="stop a curve after a render longer than this (s)")
    ap.add_argument("--ref-samples", type=int, default=8192)
    ap.add_argument("--scenes", default="room,glass_room")
    ap.add_argument("--write", type=Path)
    args = ap.parse_args(argv)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    img_dir = HERE.parent / "docs" / "images"
    img_dir.mkdir(parents=True, exist_ok=True)
    text = []
    for name in args.scenes.split(","):
        scene = room(glass=(name == "glass_room"))
        t0 = time.perf_counter()
        ref, _ = render(scene, args.size, samples=args.ref_samples, wavelength_count=81, noise_threshold=0.0)
        print(f"{name}: reference {time.perf_counter() - t0:.0f} s", flush=True)
        curves = {}
        for m in METHODS:
            for n in COUNTS:
                start = n if m == "MONOCHROMATIC_RAYS" else 1
                curves[(m, n)] = curve(scene, ref, args.size, args.budget, method=m, wavelength_count=n, start=start)
                print(name, m, n, [(round(s, 3), round(d, 2)) for s, d, _ in curves[(m, n)]], flush=True)
        curves[("RGB", 3)] = curve(scene, ref, args.size, args.budget, method="RGB", wavelength_count=41)
        auto = []
        for thr in (4.0, 2.0, 1.0, 0.5):
            r, sec = render(scene, args.size, samples=4096, noise_threshold=thr)
            de = float(np.mean(image_delta_e(r.rgba, ref.rgba)))
            auto.append((sec, de, thr, r.stats["wavelengths"], r.stats["total_samples"] / args.size**2))
            print(name, "AUTO", thr, auto[-1], r.stats["auto_reason"], flush=True)

        fig, axes = plt.subplots(1, 4, figsize=(18, 4.2), sharey=True)
        for ax, m in zip(axes, METHODS + ("RGB / AUTO",)):
            if m == "RGB / AUTO":
                p = curves[("RGB", 3)]
                ax.loglog([x[0] for x in p], [x[1] for x in p], "o-", label="RGB")
                ax.loglog([a[0] for a in auto], [a[1] for a in auto], "s-", label="AUTO (thr 4, 2, 1, 0.5)")
                p = curves[("POLYCHROMATIC", 41)]
                ax.loglog([x[0] for x in p], [x[1] for x in p], ":", color="grey", label="POLY 41")
            else:
                for n in COUNTS:
                    p = curves[(m, n)]
                    ax.loglog([x[0] for x in p], [x[1] for x in p], "o-", ms=3, label=f"{n} λ")
            ax.axhline(1.0, color="k", lw=0.5)
            ax.set_title(m)
            ax.set_xlabel("render time (s)")
            ax.legend(fontsize=8)
        axes[0].set_ylabel("mean ΔE00 vs converged")
        fig.suptitle(f"{name}, {args.size}×{args.size}, reference POLYCHROMATIC 81 λ {args.ref_samples} spp")
        fig.tight_layout()
        png = img_dir / f"quality_{name}.png"
        fig.savefig(png, dpi=80)
        plt.close(fig)

        rows = ["| method | wavelengths | time to mean ΔE00 ≤ 1 (s) | lowest mean ΔE00 reached (at s) |", "| --- | --- | --- | --- |"]
        for (m, n), p in curves.items():
            t1 = time_to(p)
            best = min(p, key=lambda x: x[1])
            rows.append(
                f"| {m} | {'RGB' if m == 'RGB' else n} | {'not reached' if t1 is None else f'{t1:.2f}'} | {best[1]:.2f} ({best[0]:.1f}) |"
            )
        for sec, de, thr, nw, spp in auto:
            rows.append(f"| AUTO, noise_threshold {thr} | {nw} (fitted) | — | {de:.2f} ({sec:.1f}; mean {spp:.0f} spp) |")
        text.append(f"### {name}\n\n![{name}](images/quality_{name}.png)\n\n" + "\n".join(rows))
    body = (
        "Mean ΔE00 against a converged reference (POLYCHROMATIC, 81 wavelengths) as a function of render "
        f"time, {args.size}×{args.size} pixels, max 8 bounces, doubling samples per point. "
        "Wavelength counts below the scene's needs converge to a biased image (the curve flattens above 0).\n\n" + "\n\n".join(text)
    )
    print(body)
    if args.write:
        write_section(
            args.write,
            "Speed against accuracy",
            body,
            f"python bench/quality.py --size {args.size} --budget {args.budget} --ref-samples {args.ref_samples} --write {args.write}",
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
