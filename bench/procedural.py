"""Cost of one procedural texture evaluation (docs/procedural.md), per node and mode.

    python bench/procedural.py [--points 200000] [--write docs/BENCHMARKS.md]

Each row evaluates one node at the same random points through the testing hook
`_core._evaluate_procedural` (a Rust loop, one thread; the numpy output columns are the
only allocation), best of 3. Times are per point, all outputs; ratios are to the
Checker Texture in the same run.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

from polychrome import _core

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import write_section  # noqa: E402

CASES = [
    ("Checker", "ShaderNodeTexChecker", {}),
    ("White Noise 3D", "ShaderNodeTexWhiteNoise", {}),
    ("Gradient (spherical)", "ShaderNodeTexGradient", {"gradient_type": "SPHERICAL"}),
    ("Brick", "ShaderNodeTexBrick", {}),
    ("Magic (depth 2)", "ShaderNodeTexMagic", {}),
    ("Wave (bands, sine)", "ShaderNodeTexWave", {}),
    ("Wave (distortion 5, detail 2)", "ShaderNodeTexWave", {"distortion": 5.0}),
    ("Noise 3D fBM, detail 2 (default)", "ShaderNodeTexNoise", {}),
    ("Noise 3D fBM, detail 15", "ShaderNodeTexNoise", {"detail": 15.0}),
    ("Noise 4D fBM, detail 2", "ShaderNodeTexNoise", {"dimensions": "4D"}),
    ("Noise 3D ridged, detail 2, distortion 1", "ShaderNodeTexNoise", {"noise_type": "RIDGED_MULTIFRACTAL", "distortion": 1.0}),
    ("Voronoi 3D F1 (default)", "ShaderNodeTexVoronoi", {}),
    ("Voronoi 3D smooth F1", "ShaderNodeTexVoronoi", {"feature": "SMOOTH_F1"}),
    ("Voronoi 3D distance to edge", "ShaderNodeTexVoronoi", {"feature": "DISTANCE_TO_EDGE"}),
    ("Voronoi 4D F1", "ShaderNodeTexVoronoi", {"dimensions": "4D"}),
    ("Voronoi 3D F1, detail 2", "ShaderNodeTexVoronoi", {"detail": 2.0}),
]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--points", type=int, default=200000)
    ap.add_argument("--write", type=Path)
    args = ap.parse_args()
    rng = np.random.default_rng(7)
    points = rng.uniform(-10, 10, (args.points, 3)).astype(np.float32)
    w = rng.uniform(-10, 10, args.points).astype(np.float32)
    rows = []
    for label, idname, params in CASES:
        js = json.dumps(params)
        best = np.inf
        for _ in range(3):
            t0 = time.perf_counter()
            _core._evaluate_procedural(idname, js, points, w)
            best = min(best, time.perf_counter() - t0)
        rows.append((label, best / args.points * 1e9))
        print(f"{label:45s} {rows[-1][1]:9.1f} ns")
    base = rows[0][1]
    load = os.getloadavg()[0]
    body = f"{args.points} random points in [-10, 10]³, one thread, best of 3, all outputs of the node. "
    body += f"Load average {load:.1f} on {os.cpu_count()} cores during the run: compare the ratios, not the nanoseconds.\n\n"
    body += "| node | ns per point | × Checker |\n| --- | ---: | ---: |\n"
    body += "".join(f"| {label} | {ns:.0f} | {ns / base:.1f} |\n" for label, ns in rows)
    if args.write:
        write_section(args.write, "Procedural textures", body, "python bench/procedural.py --write docs/BENCHMARKS.md")


if __name__ == "__main__":
    main()
