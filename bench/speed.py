"""Camera paths per second of Polychrome builds and Mitsuba 3 (llvm_ad_spectral,
scalar_spectral) on the Cornell box of examples/cornell_box.py, in one run (issue 16).

    python bench/speed.py [--size 256] [--spp 64] [--build NAME=FOLDER ...] [--write docs/BENCHMARKS.md]

Each `--build NAME=FOLDER` is a folder holding a `polychrome` package with its compiled
`_core` (as bench/compare_builds.py takes); without one, the installed `polychrome` is
measured. Polychrome renders POLYCHROMATIC at 41 and 4 wavelengths, BACKWARD, 2 threads,
no adaptive stop; loading and the scene build are excluded (`seconds - build_seconds`).
Mitsuba runs in its own virtual environment (bench/renderers.py creates it) through
bench/mitsuba_worker.py on the scene bench/renderers.py exports (the same meshes, camera,
spectra, path depth max_bounces + 1, 2 threads); every variant renders twice and the
second render counts, so the LLVM variant's kernel compilation is left out. The LLVM
variant needs libLLVM ≥ 16 (../shared/MITSUBA_NOTES.md): `--llvm` points to it
(`DRJIT_LIBLLVM_PATH`). Each Mitsuba sample carries 4 wavelengths, Polychrome's 41 or 4.
Renders alternate between the Polychrome builds, best of `--repeats`.
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "examples"))
sys.path.insert(0, str(ROOT / "bench"))


def load_builds(specs: list[str]):
    """NAME=FOLDER → (name, polychrome package, core) importable side by side."""
    if not specs:
        import polychrome

        return [("installed", polychrome, importlib.import_module("polychrome._core"))]
    tmp = Path(tempfile.mkdtemp(prefix="pc_speed_"))
    sys.path.insert(0, str(tmp))
    out = []
    for k, spec in enumerate(specs):
        name, folder = spec.split("=", 1)
        mod = f"pc_build{k}"
        shutil.copytree(Path(folder) / "polychrome", tmp / mod)
        out.append((name, importlib.import_module(mod), importlib.import_module(f"{mod}._core")))
    sys.modules["polychrome"] = out[0][1]  # the example scene and the export use the first build's Python API
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--max-bounces", type=int, default=8)
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--build", action="append", default=[], metavar="NAME=FOLDER")
    ap.add_argument("--mitsuba-python", type=Path, default=Path("/tmp/mitsuba-venv/bin/python"))
    ap.add_argument("--llvm", default=os.environ.get("DRJIT_LIBLLVM_PATH", ""), help="path of libLLVM ≥ 16")
    ap.add_argument("--variants", default="llvm_ad_spectral,scalar_spectral")
    ap.add_argument("--write", type=Path)
    args = ap.parse_args(argv)
    builds = load_builds(args.build)
    pc = builds[0][1]
    import renderers  # noqa: E402  (after the polychrome module is chosen)
    from cornell_box import build_scene

    scene = build_scene()
    desc, buffers = scene.description()
    desc_json = importlib.import_module(pc.__name__ + ".render").description_json(desc)
    size, paths = args.size, args.size * args.size * args.spp
    tmp = Path(tempfile.mkdtemp(prefix="pc-speed-"))
    renderers.export(scene, tmp, size, args.max_bounces)

    def settings(n):
        return pc.RenderSettings(
            width=size,
            height=size,
            samples=args.spp,
            wavelength_count=n,
            seed=1,
            max_bounces=args.max_bounces,
            noise_threshold=0.0,
            threads=2,
        ).to_json()

    rates: dict[tuple[str, int], float] = {}
    images = {}
    for rep in range(args.repeats):
        order = builds if rep % 2 == 0 else builds[::-1]
        for n in (41, 4):
            for name, _, core in order:
                out = core.render(desc_json, buffers, settings(n), None)
                s = json.loads(out["stats"])
                rate = s["total_samples"] / (s["seconds"] - s["build_seconds"])
                rates[(name, n)] = max(rates.get((name, n), 0.0), rate)
                images[(name, n)] = np.asarray(out["rgba"])[..., :3]
                print(f"{name} {n} λ: {rate / 1e6:.3f} M paths/s", flush=True)
    mitsuba = {}
    if renderers.ensure_mitsuba(args.mitsuba_python):
        for variant in args.variants.split(","):
            env = dict(os.environ, THREADS="2")
            if args.llvm:
                env["DRJIT_LIBLLVM_PATH"] = args.llvm
            rows = renderers.run_mitsuba_worker(args.mitsuba_python, tmp / "scene.json", variant, tmp, [args.spp, args.spp], env=env)
            if rows is None:
                continue
            sec = rows[-1]["seconds"]
            de = renderers.mean_de(images[(builds[-1][0], 41)], renderers.read_exr(rows[-1]["exr"]))
            mitsuba[variant] = (paths / sec, de)
            print(
                f"Mitsuba {variant}: {paths / sec / 1e6:.3f} M paths/s (first render {rows[0]['seconds']:.2f} s), ΔE00 to Polychrome {de:.2f}",
                flush=True,
            )

    ref = mitsuba.get("llvm_ad_spectral", (None,))[0]
    lines = [
        f"Cornell box (examples/cornell_box.py), {size}×{size}, {args.spp} spp, max {args.max_bounces} bounces (Mitsuba path depth "
        f"{args.max_bounces + 1}), 2 threads, x86_64; render seconds exclude loading and the scene build. Polychrome: POLYCHROMATIC, "
        f"BACKWARD, best of {args.repeats} alternating runs; Mitsuba 3: the second of two renders (no kernel compilation).",
        "",
        "| renderer | λ per path | camera paths / s | 41 λ cost per path vs 4 λ | vs Mitsuba llvm_ad_spectral |",
        "| --- | ---: | ---: | ---: | ---: |",
    ]
    for name, _, _ in builds:
        for n in (41, 4):
            r = rates[(name, n)]
            cost = f"{rates[(name, 4)] / r:.2f}×" if n == 41 else "1.00×"
            vs = f"{r / ref:.2f}×" if ref else "—"
            lines.append(f"| Polychrome {name} | {n} | {r / 1e6:.3f} M | {cost} | {vs} |")
    for variant, (r, _de) in mitsuba.items():
        vs = f"{r / ref:.2f}×" if ref else "—"
        lines.append(f"| Mitsuba 3 {variant} | 4 | {r / 1e6:.3f} M | — | {vs} |")
    if mitsuba:
        des = ", ".join(f"{v} {de:.2f}" for v, (_, de) in mitsuba.items())
        lines += [
            "",
            f"Mean ΔE00 (colour-science) of Polychrome {builds[-1][0]}'s 41-λ image to each Mitsuba image at the same spp: {des}.",
        ]
    text = "\n".join(lines)
    print(text)
    if args.write:
        from common import write_section

        given = sys.argv[1:] if argv is None else list(argv)
        cmd = " ".join(["python bench/speed.py", *given]).replace(f" --write {args.write}", "")
        write_section(args.write, "Camera paths per second against Mitsuba 3 (issue 16)", text, cmd)
    return 0


if __name__ == "__main__":
    sys.exit(main())
