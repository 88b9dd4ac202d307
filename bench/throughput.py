"""Camera paths per second on the Cornell box, at 41 wavelengths and at the grid's
minimum, release build, one run on this machine.

    python bench/throughput.py [--size 256] [--samples 64] [--write docs/BENCHMARKS.md]

Figures are ratios measured in one run, on the same machine (noisy: 2 cores), so
compare rows of one table, not tables of different runs.
"""

from __future__ import annotations

import argparse
import platform
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples"))

import polychrome as pc  # noqa: E402
from cornell_box import build_scene  # noqa: E402

from common import write_section  # noqa: E402


def measure(scene, size: int, samples: int, wavelengths: int, repeats: int = 3) -> float:
    """Best of `repeats` renders: camera paths (pixel samples) per second."""
    best = 0.0
    for _ in range(repeats):
        r = pc.render(scene, width=size, height=size, samples=samples, wavelength_count=wavelengths, seed=1)
        rate = size * size * r.stats["samples_per_pixel"] / (r.stats["seconds"] - r.stats["build_seconds"])
        best = max(best, rate)
    return best


def main(argv=None) -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--samples", type=int, default=32)
    parser.add_argument("--write", help="Markdown file to update with the results table")
    args = parser.parse_args(argv)
    scene = build_scene()
    rows = []
    base = None
    for n in (4, 41, 81):
        rate = measure(scene, args.size, args.samples, n)
        base = base or rate
        rows.append((n, rate, base / rate))
    lines = [
        f"Cornell box (examples/cornell_box.py), {args.size}×{args.size}, {args.samples} spp, max 8 bounces, "
        f"{platform.processor() or platform.machine()}, all cores. Best of 3.",
        "",
        "| wavelengths | camera paths / s | cost per path vs 4 wavelengths |",
        "| ---: | ---: | ---: |",
    ]
    lines += [f"| {n} | {rate / 1e6:.3f} M | {ratio:.2f}× |" for n, rate, ratio in rows]
    lines += [
        "",
        "The grid's minimum is 4 samples, so 4 stands in for the single-wavelength path; "
        "a true 1-wavelength path is the MONOCHROMATIC_RAYS method (see the methods table).",
    ]
    text = "\n".join(lines)
    print(text)
    if args.write:
        write_section(
            Path(args.write),
            "Throughput",
            text,
            f"python bench/throughput.py --size {args.size} --samples {args.samples} --write {args.write}",
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
