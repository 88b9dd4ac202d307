"""Scene build time and peak memory against triangle count (issue 16): a displaced grid
mesh made with numpy and added through the Python API (positions, triangles, per-vertex
normals and uvs, one material), rendered at 16×16, 1 spp, 41 wavelengths. Each size runs
in a fresh Python process, so its peak RSS (`ru_maxrss`) is its own.

    python bench/scale.py [--tris 1,2,5,10,20] [--write docs/BENCHMARKS.md]

`--tris` is in millions of triangles. Per size it prints the core's `build_seconds`
(buffers → meshes → BVH, what `stats["build_seconds"]` reports), the BVH build rate
(triangles / build second), the peak RSS and the peak RSS growth over the process after
`import polychrome` and numpy, per triangle, both with and without the numpy input
arrays the caller holds (they are the caller's, not the renderer's).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def rss_now() -> int:
    """Resident bytes of this process now (Linux /proc)."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def grid(tris: int):
    """A displaced n×n vertex grid with 2 (n − 1)² ≥ `tris` triangles."""
    import numpy as np

    n = int(np.ceil(np.sqrt(tris / 2.0))) + 1
    u = np.linspace(0.0, 1.0, n, dtype=np.float32)
    x, y = np.meshgrid(u, u)
    z = 0.05 * np.sin(12.0 * x) * np.cos(9.0 * y)
    v = np.stack([x.ravel() * 2 - 1, y.ravel() * 2 - 1, z.ravel()], axis=1).astype(np.float32)
    del x, y, z
    nz = np.zeros_like(v)
    nz[:, 2] = 1.0
    uv = np.ascontiguousarray(v[:, :2] * 0.5 + 0.5)
    i = np.arange(n - 1, dtype=np.uint32)
    a = (i[None, :] + n * i[:, None]).ravel()
    t = np.empty((2 * a.size, 3), dtype=np.uint32)
    t[0::2, 0], t[0::2, 1], t[0::2, 2] = a, a + 1, a + n + 1
    t[1::2, 0], t[1::2, 1], t[1::2, 2] = a, a + n + 1, a + n
    return v, t, nz, uv


def one(millions: float) -> dict:
    import numpy as np  # noqa: F401

    import polychrome as pc

    base = rss_now()
    v, t, nrm, uv = grid(int(millions * 1e6))
    input_bytes = v.nbytes + t.nbytes + nrm.nbytes + uv.nbytes
    scene = pc.Scene()
    m = scene.add_material(pc.Diffuse(0.5))
    scene.add_mesh("grid", v, t, normals=nrm, uvs=uv, material=m)
    scene.add_light(pc.SunLight(direction=(0.3, 0.2, -1.0), strength=3.0))
    scene.camera = pc.Camera.looking_at((0.0, -2.5, 1.5), (0.0, 0.0, 0.0), focal_length=35.0)
    r = pc.render(scene, width=16, height=16, samples=1, wavelength_count=41, seed=1)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    return {
        "triangles": int(t.shape[0]),
        "vertices": int(v.shape[0]),
        "build_seconds": r.stats["build_seconds"],
        "peak": peak,
        "base": base,
        "input": input_bytes,
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tris", default="1,2,5,10,20", help="comma-separated millions of triangles")
    ap.add_argument("--one", type=float, help=argparse.SUPPRESS)
    ap.add_argument("--write", type=Path)
    args = ap.parse_args(argv)
    if args.one is not None:
        print(json.dumps(one(args.one)))
        return 0
    rows = []
    for m in [float(s) for s in args.tris.split(",")]:
        out = subprocess.run([sys.executable, __file__, "--one", str(m)], capture_output=True, text=True, check=True)
        d = json.loads(out.stdout.strip().splitlines()[-1])
        t = d["triangles"]
        grow = d["peak"] - d["base"]
        row = (
            f"| {t / 1e6:.2f} M | {d['build_seconds']:.2f} | {t / d['build_seconds'] / 1e6:.2f} M | "
            f"{d['peak'] / 2**30:.2f} GiB | {grow / t:.0f} | {(grow - d['input']) / t:.0f} |"
        )
        print(row, flush=True)
        rows.append(row)
    lines = [
        f"Displaced grid through the Python API (vertices, triangles, per-vertex normals and uvs: {2 * 12 + 8} bytes per vertex, "
        f"about half a vertex per triangle), one Diffuse material, a sun, 16×16, 1 spp, 41 λ, release build, "
        f"{os.cpu_count()} threads, {platform.machine()}; one fresh process per size.",
        "",
        "| triangles | build_seconds | triangles / build second | peak RSS | peak RSS growth, bytes / triangle | same without the caller's numpy input |",
        "| ---: | ---: | ---: | ---: | ---: | ---: |",
        *rows,
    ]
    body = "\n".join(lines)
    print(body)
    if args.write:
        sys.path.insert(0, str(ROOT / "bench"))
        from common import write_section

        write_section(
            args.write,
            "Scene build and memory against triangle count (issue 16)",
            body,
            f"python bench/scale.py --tris {args.tris} --write {args.write}",
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
