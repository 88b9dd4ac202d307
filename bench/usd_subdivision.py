"""Time to read a subdivision-surface USD stage (polychrome/usd/subdivision.py): a bumpy
open grid of N × N quads (catmullClark, USD's default scheme, face-varying st), written
as .usdc with pxr, read by `read_stage` at levels 0 (the cage), 1, 2 and 3; the
refinement alone (`subdivision.refine`, face-varying st bilinear) timed beside it; the
reader refines st with the default cornersPlus1 rules (a second refinement, of the st mesh).

    python bench/usd_subdivision.py [--side 316] [--levels 0,1,2,3] [--repeat 2] [--write docs/BENCHMARKS.md]
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path
import platform
import sys
import tempfile
import time
import warnings

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import write_section  # noqa: E402

from polychrome import usd  # noqa: E402
from polychrome.usd import subdivision  # noqa: E402


def grid(n: int):
    u = np.linspace(-1, 1, n + 1)
    x, y = np.meshgrid(u, u, indexing="ij")
    pts = np.stack([x, y, 0.1 * np.sin(7 * x) * np.cos(5 * y)], -1).reshape(-1, 3)
    a = (np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]).ravel()
    idx = np.stack([a, a + n + 1, a + n + 2, a + 1], 1).ravel()
    return pts, np.full(n * n, 4), idx


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--side", type=int, default=316)
    ap.add_argument("--levels", default="0,1,2,3")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--write", type=Path, default=None)
    args = ap.parse_args()
    from pxr import Sdf, Usd, UsdGeom, Vt

    pts, counts, idx = grid(args.side)
    tmp = Path(tempfile.mkdtemp(prefix="usd_subdiv_"))
    path = tmp / "grid.usdc"
    stage = Usd.Stage.CreateNew(str(path))
    mesh = UsdGeom.Mesh.Define(stage, "/grid")
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(pts.astype(np.float32)))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(counts.astype(np.int32)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(idx.astype(np.int32)))
    st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying)
    st.Set(Vt.Vec2fArray.FromNumpy((pts[idx, :2] * 0.5 + 0.5).astype(np.float32)))
    stage.GetRootLayer().Save()
    rows = []
    for level in [int(x) for x in args.levels.split(",")]:
        best_read = best_refine = float("inf")
        for _ in range(args.repeat):
            t = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # no camera
                scene = usd.read_stage(path, subdivision_level=level)
            best_read = min(best_read, time.perf_counter() - t)
            if level:
                t = time.perf_counter()
                subdivision.refine(pts, counts, idx, level, face_varying=[pts[idx, :2]])
                best_refine = min(best_refine, time.perf_counter() - t)
        del scene
        faces = len(counts) * 4**level
        refine = f"{best_refine:.2f}" if level else "-"
        rows.append(f"| {level} | {faces:,} | {2 * faces:,} | {refine} | {best_read:.2f} |")
        print(rows[-1], flush=True)
    body = (
        f"A {args.side} × {args.side} grid ({len(counts):,} quads, face-varying st) as .usdc; best of {args.repeat}; "
        f"Python {platform.python_version()}, numpy {np.__version__}; load average {os.getloadavg()[0]:.1f} on this 2-core machine "
        "when it ended (other jobs' load inflates every time).\n\n"
        "| level | faces | triangles | `subdivision.refine` (s) | `read_stage` (s) |\n| ---: | ---: | ---: | ---: | ---: |\n"
        + "\n".join(rows)
    )
    print(body)
    if args.write:
        cmd = f"python bench/usd_subdivision.py --side {args.side} --levels {args.levels} --repeat {args.repeat} --write {args.write}"
        write_section(args.write, "USD subdivision surfaces: read time", body, cmd, after="USD write and read")
    return 0


if __name__ == "__main__":
    sys.exit(main())
