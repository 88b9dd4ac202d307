"""Profile of the polychromatic path (issue 9): dumps the Cornell box
(examples/cornell_box.py) as JSON for the Rust example `profile_render`, builds it in
release mode with debug info, and records it with `perf record -g` (one thread), then
groups the self time of the hottest functions into traversal, shading, spectral
arithmetic, lights/sampling and film.

    python bench/profile.py [--spp 16] [--size 64] [--wavelengths 41] [--write docs/BENCHMARKS.md]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "examples"))
sys.path.insert(0, str(ROOT / "bench"))
from common import write_section  # noqa: E402

# Function-name patterns → category (first match wins).
CATEGORIES = [
    ("memory allocation (malloc/free/memset)", r"_int_free|malloc|calloc|realloc|^free|cfree|memset|memcpy|memmove|_int_"),
    ("traversal (BVH + triangle tests)", r"obvhs|accel|bvh|Bvh|traverse|intersect|triangle|Triangle|ray_|Ray"),
    ("spectral arithmetic (SampledSpectrum, observer)", r"SampledSpectrum|sampled::|spectrum::|Observer|xyz"),
    ("film", r"film::|Film"),
    ("shading (BSDF eval/sample, materials)", r"material::|Bsdf|bsdf|diffuse|Diffuse|dielectric|fresnel|microfacet"),
    ("lights, sampling, RNG", r"light::|Light|sampling::|Rng|Distribution|rand"),
    ("integrator (path walk)", r"integrator::|walk::|path::"),
    ("math library (exp, pow, sqrt, ...)", r"libm|__ieee|exp|pow|log|sqrt|sincos|__sin|__cos"),
]


def dump(path: Path) -> None:
    from cornell_box import build_scene

    desc, buffers = build_scene().description()
    out = []
    for b in buffers:
        a = np.asarray(b)
        kind = "u32" if a.dtype.kind in "ui" else "f32"
        out.append({"kind": kind, "data": a.ravel().tolist()})
    path.write_text(json.dumps({"scene": desc, "buffers": out}))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--spp", type=int, default=128)
    ap.add_argument("--size", type=int, default=48)
    ap.add_argument("--wavelengths", type=int, default=41)
    ap.add_argument("--write", type=Path)
    args = ap.parse_args(argv)
    env = dict(os.environ, CARGO_PROFILE_RELEASE_DEBUG="true")
    subprocess.run(
        ["cargo", "build", "--release", "-q", "-p", "polychrome-core", "--example", "profile_render"], cwd=ROOT, env=env, check=True
    )
    exe = ROOT / "target" / "release" / "examples" / "profile_render"
    with tempfile.TemporaryDirectory() as tmp:
        scene = Path(tmp) / "scene.json"
        dump(scene)
        run = [str(exe), str(scene), str(args.spp), str(args.wavelengths), str(args.size)]
        plain = subprocess.run(run, capture_output=True, text=True, check=True).stdout.strip()
        data = Path(tmp) / "perf.data"
        subprocess.run(
            ["perf", "record", "-q", "-e", "cpu-clock", "-F", "2000", "-g", "-o", str(data), *run], capture_output=True, check=True
        )
        report = subprocess.run(
            ["perf", "report", "-i", str(data), "--no-children", "--stdio", "--sort", "symbol", "--percent-limit", "0.3", "-g", "none"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout
    rows = []
    for line in report.splitlines():
        m = re.match(r"\s*([\d.]+)%\s+\[\.\]\s+(.*)", line)
        if m:
            rows.append((float(m.group(1)), re.sub(r"\s+-\s+-\s*$", "", m.group(2)).strip()))
    totals: dict[str, float] = {}
    for pct, sym in rows:
        cat = next((c for c, pat in CATEGORIES if re.search(pat, sym)), "other")
        totals[cat] = totals.get(cat, 0.0) + pct
    listed = sum(p for p, _ in rows)
    lines = [f"`{plain}`", "", "| where | share of samples (self time) |", "| --- | --- |"]
    for cat, pct in sorted(totals.items(), key=lambda x: -x[1]):
        lines.append(f"| {cat} | {pct:.1f} % |")
    lines.append(f"| (functions under 0.3 % each) | {100 - listed:.1f} % |")
    lines += ["", "Hottest functions:", "", "| self % | function |", "| --- | --- |"]
    for pct, sym in rows[:15]:
        lines.append(f"| {pct:.1f} | `{sym[:110]}` |")
    body = (
        f"`perf record -g` (2 kHz) of the release build with debug info (`rust/core/examples/profile_render.rs`), one thread, "
        f"Cornell box (examples/cornell_box.py), {args.size}×{args.size}, {args.spp} spp, {args.wavelengths} wavelengths, "
        "POLYCHROMATIC BACKWARD. Functions are grouped by name (inlined code counts where it was inlined: "
        "the path walk in `integrator::walk::Walk::run` includes inlined spectral arithmetic and BSDF code).\n\n" + "\n".join(lines)
    )
    print(body)
    if args.write:
        write_section(
            args.write,
            "Profile of the polychromatic path",
            body,
            f"python bench/profile.py --spp {args.spp} --size {args.size} --wavelengths {args.wavelengths} --write {args.write}",
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
