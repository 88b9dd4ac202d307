"""Camera paths per second of two builds of the core, interleaved in one process, on
bench/throughput.py's scene (the Cornell box of examples/cornell_box.py): for checking
that a refactor did not slow the hot path on a machine too loaded for separate runs.

    python bench/compare_builds.py OLD NEW [--size 256] [--samples 32] [--repeats 6]

OLD and NEW are folders that each hold a `polychrome` package with its compiled
`_core` (e.g. a copy of python/polychrome after `pip install -e .` of each commit). The
scene and settings JSON come from OLD's Python package, so both cores get the same
input; renders alternate OLD, NEW, NEW, OLD, ... and the best of `--repeats` counts.

`--one {old,new} METHOD DIRECTION WAVELENGTHS` renders once on one thread instead, for
counting instructions (`valgrind --tool=callgrind`), which load does not disturb.

`--images` renders every case once with each build (same seed, spectral pass and
adaptive sampling on for the BACKWARD cases) and prints the largest difference of the
RGBA, albedo, depth, normal and spectral images relative to each image's peak: for
checking that a speed change left the image unchanged.
"""

from __future__ import annotations

import argparse
import importlib
import json
import shutil
import sys
import tempfile
from pathlib import Path

CASES = [
    ("POLYCHROMATIC", "BACKWARD", 41),
    ("POLYCHROMATIC", "BACKWARD", 4),
    ("MONOCHROMATIC_RAYS", "BACKWARD", 41),
    ("POLYCHROMATIC", "FORWARD", 41),
    ("POLYCHROMATIC", "BIDIRECTIONAL", 41),
]


def load(old: Path, new: Path):
    """Both builds importable side by side (as pc_old and pc_new), the scene built once."""
    tmp = Path(tempfile.mkdtemp(prefix="compare_builds_"))
    for name, src in (("pc_old", old), ("pc_new", new)):
        shutil.copytree(src / "polychrome", tmp / name)
    sys.path.insert(0, str(tmp))
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples"))
    pc_old = importlib.import_module("pc_old")
    sys.modules["polychrome"] = pc_old  # the example scene builds with OLD's Python API
    from cornell_box import build_scene

    cores = {k: importlib.import_module(f"pc_{k}._core") for k in ("old", "new")}
    desc, buffers = build_scene().description()
    return pc_old, cores, importlib.import_module("pc_old.render").description_json(desc), buffers


def rate(core, desc_json, buffers, settings_json) -> float:
    out = core.render(desc_json, buffers, settings_json, None)
    s = json.loads(out["stats"])
    return s["total_samples"] / (s["seconds"] - s["build_seconds"])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("old", type=Path)
    ap.add_argument("new", type=Path)
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--samples", type=int, default=32)
    ap.add_argument("--repeats", type=int, default=6)
    ap.add_argument("--images", action="store_true", help="compare the images of both builds instead of timing")
    ap.add_argument("--one", nargs=4, metavar=("BUILD", "METHOD", "DIRECTION", "WAVELENGTHS"))
    args = ap.parse_args(argv)
    pc_old, cores, desc_json, buffers = load(args.old, args.new)

    def settings(method, direction, n, **kw):
        return pc_old.RenderSettings(
            width=args.size,
            height=args.size,
            samples=args.samples,
            wavelength_count=int(n),
            seed=1,
            method=method,
            direction=direction,
            **kw,
        ).to_json()

    if args.images:
        import numpy as np

        print(f"Cornell box, {args.size}×{args.size}, {args.samples} spp, seed 1: max |new − old| / max |old| per image")
        print("| method | direction | λ | options | rgba | albedo | depth | normal | spectral | samples old/new |")
        print("| --- | --- | ---: | --- | ---: | ---: | ---: | ---: | ---: | --- |")
        for method, direction, n in CASES:
            opts = [{}]
            if direction == "BACKWARD":
                opts += [{"spectral_output": True}, {"noise_threshold": 0.3}]
            for kw in opts:
                st = settings(method, direction, n, **kw)
                out = {k: cores[k].render(desc_json, buffers, st, None) for k in ("old", "new")}

                def rel(key):
                    a, b = out["old"].get(key), out["new"].get(key)
                    if a is None or b is None:
                        return "—"
                    a, b = np.asarray(a, float), np.asarray(b, float)
                    return f"{np.max(np.abs(b - a)) / max(np.max(np.abs(a)), 1e-30):.1e}"

                tot = [json.loads(out[k]["stats"])["total_samples"] for k in ("old", "new")]
                cols = " | ".join(rel(k) for k in ("rgba", "albedo", "depth", "normal", "spectral"))
                label = ", ".join(f"{k}={v}" for k, v in kw.items()) or "—"
                print(f"| {method} | {direction} | {n} | {label} | {cols} | {tot[0]}/{tot[1]} |", flush=True)
        return 0
    if args.one:
        build, method, direction, n = args.one
        print(f"{rate(cores[build], desc_json, buffers, settings(method, direction, n, threads=1)):.0f} paths/s")
        return 0
    print(f"Cornell box, {args.size}×{args.size}, {args.samples} spp, best of {args.repeats}, interleaved")
    print("| method | direction | λ | old M paths/s | new M paths/s | new/old |")
    print("| --- | --- | ---: | ---: | ---: | ---: |")
    for method, direction, n in CASES:
        st = settings(method, direction, n)
        best = {"old": 0.0, "new": 0.0}
        for rep in range(args.repeats):
            for k in ("old", "new") if rep % 2 == 0 else ("new", "old"):
                best[k] = max(best[k], rate(cores[k], desc_json, buffers, st))
        o, w = best["old"], best["new"]
        print(f"| {method} | {direction} | {n} | {o / 1e6:.3f} | {w / 1e6:.3f} | {w / o:.3f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
