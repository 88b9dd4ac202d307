"""Before/after check for refactors that must not change images: renders a matrix of
scenes × methods × directions (small, fixed seed) and saves every pass, or compares a
new run with a saved one and prints the largest difference per render.

    python bench/image_regression.py --save /tmp/before.npz      # on the old build
    python bench/image_regression.py --compare /tmp/before.npz   # on the new build

"identical" means bit-identical passes and equal stats counts; otherwise the largest
absolute RGBA difference and its ratio to the image's mean are shown, so ulp-level
drift (a changed summation order) is told apart from a changed random-number order.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples"))

import polychrome as pc  # noqa: E402
from polychrome import spectra  # noqa: E402

SIZE = 24
SAMPLES = 8


def scenes() -> dict[str, tuple[pc.Scene, dict]]:
    import cornell_box
    import fig06_prism
    import fig12_room

    out = {
        "cornell": (cornell_box.build_scene(), {}),
        "glass_room": (fig12_room.build_scene(glass=True), {}),
    }
    prism, _ = fig06_prism.build_scene(spectra.d65(1.0), camera="screen", ambient=0.05)
    out["prism"] = (prism, {"max_bounces": 6})
    # A point light and an HDRI-free uniform world: delta lights, environment MIS.
    s = cornell_box.build_scene()
    s.add_light(pc.PointLight(position=(0.0, 0.0, 0.5), power=5.0, name="point"))
    s.set_world(spectra.d65(0.1))
    out["cornell_point_world"] = (s, {})
    return out


def matrix():
    for method in ("POLYCHROMATIC", "MONOCHROMATIC_RAYS", "MONOCHROMATIC_SCENES", "RGB"):
        for direction in ("BACKWARD", "FORWARD", "BIDIRECTIONAL"):
            yield f"{method}/{direction}", dict(method=method, direction=direction)
    yield "POLYCHROMATIC/BACKWARD/splitting", dict(method="POLYCHROMATIC", dispersion_splitting=True)
    yield "POLYCHROMATIC/BIDIRECTIONAL/splitting", dict(method="POLYCHROMATIC", direction="BIDIRECTIONAL", dispersion_splitting=True)
    yield "POLYCHROMATIC/adaptive", dict(method="POLYCHROMATIC", samples=40, noise_threshold=2.0)


def run() -> dict[str, np.ndarray]:
    arrays = {}
    for sname, (scene, extra) in scenes().items():
        for mname, settings in matrix():
            kw = dict(width=SIZE, height=SIZE, samples=SAMPLES, wavelength_count=16, max_bounces=5, seed=11)
            kw.update(extra)
            kw.update(settings)
            if kw["method"] == "MONOCHROMATIC_SCENES":
                kw["wavelength_count"] = 8
            key = f"{sname}/{mname}"
            r = pc.render(scene, **kw)
            for p in ("rgba", "depth", "normal", "albedo"):
                arrays[f"{key}/{p}"] = np.asarray(getattr(r, p), dtype=np.float32)
            st = r.stats
            counts = [st[k] for k in ("samples_per_pixel", "total_samples", "nonfinite_samples", "converged_pixels")]
            arrays[f"{key}/stats"] = np.array(counts + [int(st["incomplete_spectrum"])], dtype=np.int64)
            print(key, json.dumps({k: st[k] for k in ("samples_per_pixel", "total_samples", "nonfinite_samples")}), flush=True)
    return arrays


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument("--save")
    g.add_argument("--compare")
    args = ap.parse_args(argv)
    arrays = run()
    if args.save:
        np.savez_compressed(args.save, **arrays)
        return 0
    old = np.load(args.compare)
    renders = sorted({k.rsplit("/", 1)[0] for k in arrays})
    identical = 0
    for key in renders:
        diffs = []
        for p in ("rgba", "depth", "normal", "albedo", "stats"):
            a, b = arrays[f"{key}/{p}"], old[f"{key}/{p}"]
            if a.shape != b.shape or not np.array_equal(a, b):
                d = float(np.abs(a.astype(np.float64) - b).max()) if a.shape == b.shape else float("inf")
                scale = float(np.abs(b).mean()) or 1.0
                diffs.append(f"{p}: max |Δ| {d:.3g} ({d / scale:.2g} of mean)")
        if diffs:
            print(f"DIFFERS   {key}: " + "; ".join(diffs))
        else:
            identical += 1
            print(f"identical {key}")
    print(f"{identical}/{len(renders)} renders bit-identical")
    return 0


if __name__ == "__main__":
    sys.exit(main())
