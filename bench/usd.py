"""Time to write and re-read a 1M-triangle USD stage (polychrome.usd).

The mesh is a UV sphere subdivided into rings × segments quads (two triangles each),
built with numpy, with per-vertex normals and uvs and two materials (GeomSubsets).

    python bench/usd.py [--rings 500 --segments 1000] [--repeat 3] [--write docs/BENCHMARKS.md]
"""

from __future__ import annotations

import argparse
from pathlib import Path
import platform
import sys
import tempfile
import time
import warnings

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import write_section  # noqa: E402

import polychrome as pc  # noqa: E402
from polychrome import usd  # noqa: E402


def sphere(rings: int, segments: int):
    theta = np.linspace(0.0, np.pi, rings + 1)
    phi = np.linspace(0.0, 2.0 * np.pi, segments + 1)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    v = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1).reshape(-1, 3).astype(np.float32)
    uv = np.stack([p / (2 * np.pi), t / np.pi], -1).reshape(-1, 2).astype(np.float32)
    row = segments + 1
    r, s = np.meshgrid(np.arange(rings), np.arange(segments), indexing="ij")
    a = (r * row + s).ravel()
    b = a + row
    tris = np.concatenate([np.stack([a, b, a + 1], 1), np.stack([a + 1, b, b + 1], 1)]).astype(np.uint32)
    return v, tris, v.copy(), uv


def build_scene(rings: int, segments: int) -> pc.Scene:
    v, t, n, uv = sphere(rings, segments)
    scene = pc.Scene()
    scene.add_material(pc.Diffuse(pc.spectra.tabulated([400, 500, 600, 700], [0.1, 0.7, 0.3, 0.2]), name="paint"))
    scene.add_material(pc.Diffuse((0.8, 0.2, 0.1), name="red"))
    ids = (np.arange(len(t)) % 7 == 0).astype(np.uint32)
    scene.add_mesh("sphere", v, t, normals=n, uvs=uv, material_ids=ids)
    scene.camera = pc.Camera.looking_at((0, -4, 1), (0, 0, 0))
    scene.add_light(pc.PointLight((2, -2, 3), power=100.0))
    return scene


def foreign_quads(path: Path, n: int) -> int:
    """A stage as another tool writes it: an n×n grid of quads (fan-triangulated on read)
    with face-varying st and normals (vertices split on read). Returns its triangles."""
    from pxr import Sdf, Usd, UsdGeom, Vt

    x, y = np.meshgrid(np.arange(n + 1, dtype=np.float32), np.arange(n + 1, dtype=np.float32))
    pts = np.stack([x.ravel(), y.ravel(), np.zeros(x.size, np.float32)], 1)
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    a = (i * (n + 1) + j).ravel()
    quads = np.stack([a, a + 1, a + n + 2, a + n + 1], 1).astype(np.int32)
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    mesh = UsdGeom.Mesh.Define(stage, "/grid")
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(pts))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(quads), 4, np.int32)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(quads.ravel()))
    st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying)
    st.Set(Vt.Vec2fArray.FromNumpy(np.ascontiguousarray(pts[quads.ravel(), :2] / n)))
    mesh.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy(np.tile(np.array([[0, 0, 1]], np.float32), (quads.size, 1))))
    mesh.SetNormalsInterpolation(UsdGeom.Tokens.faceVarying)
    stage.Save()
    return 2 * n * n


def timed(fn, repeat: int) -> tuple[float, object]:
    best, out = float("inf"), None
    for _ in range(repeat):
        start = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - start)
    return best, out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rings", type=int, default=500)
    parser.add_argument("--segments", type=int, default=1000)
    parser.add_argument("--repeat", type=int, default=3, help="runs per figure; the best is reported")
    parser.add_argument("--write", help="Markdown file to update with the results table")
    args = parser.parse_args(argv)
    warnings.filterwarnings("ignore", message=".*has no UsdGeom.Camera")  # the bare grid stage

    scene = build_scene(args.rings, args.segments)
    triangles = 2 * args.rings * args.segments
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for suffix in (".usdc", ".usda"):
            path = Path(tmp) / f"sphere{suffix}"
            repeat = args.repeat if suffix == ".usdc" else 1
            t_write, _ = timed(lambda: usd.write_stage(scene, path), repeat)
            size = path.stat().st_size / 2**20
            t_read, back = timed(lambda: usd.read_stage(path), repeat)
            desc, buffers = back.description()
            got = len(buffers[desc["meshes"][0]["triangles"]]) // 3
            if got != triangles:
                raise SystemExit(f"read {got} triangles, wrote {triangles}")
            rows.append((suffix, f"{t_write:.2f}", t_read, size))
            print(f"{suffix}: write {t_write:.2f} s, read {t_read:.2f} s, {size:.1f} MiB", flush=True)
        path = Path(tmp) / "quads.usdc"
        quad_tris = foreign_quads(path, int(round((triangles / 2) ** 0.5)))
        t_read, _ = timed(lambda: usd.read_stage(path), args.repeat)
        rows.append(
            (
                f".usdc, {quad_tris:,} triangles as quads with face-varying st and normals (written with pxr)",
                "-",
                t_read,
                path.stat().st_size / 2**20,
            )
        )
        print(f"foreign quads: read {t_read:.2f} s", flush=True)

    table = [
        f"{triangles:,} triangles ({(args.rings + 1) * (args.segments + 1):,} vertices with normals and uvs, "
        f"two materials as GeomSubsets), `polychrome.usd.write_stage` then `read_stage` "
        f"(best of {args.repeat} for .usdc, one run for .usda); usd-core {'.'.join(map(str, __import__('pxr.Usd', fromlist=['Usd']).GetVersion()))}, "
        f"Python {platform.python_version()}.",
        "",
        "| format | write (s) | read (s) | file (MiB) |",
        "| --- | ---: | ---: | ---: |",
    ]
    table += [f"| {s} | {w} | {r:.2f} | {m:.1f} |" for s, w, r, m in rows]
    text = "\n".join(table)
    print(text)
    if args.write:
        command = f"python bench/usd.py --rings {args.rings} --segments {args.segments} --repeat {args.repeat} --write {args.write}"
        write_section(Path(args.write), "USD write and read", text, command)
    return 0


if __name__ == "__main__":
    sys.exit(main())
