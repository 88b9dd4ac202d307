"""Random-mutation fuzzing of every input parser (issue 8), with a fixed seed.

Targets: the JSON scene description + buffers (``_core.render``), the USD reader
(``polychrome.usd.read_stage`` on mutated .usda text), and the image readers
(``polychrome.imageio.read_image`` for EXR/PNG, ``polychrome.texture.read_radiance_hdr``
and ``Texture.from_file``). A case passes when the parser returns, or raises one of
the clear exceptions (ValueError, TypeError, OSError — which includes FileNotFoundError
and Pillow's UnidentifiedImageError); anything else (RuntimeError from a caught panic,
MemoryError, IndexError, ...) is a finding. A crash kills the process, a hang trips the
caller's timeout.

The test suite runs a bounded number of cases (tests/test_fuzz.py); the long run is

    .venv/bin/python tests/fuzzing.py --cases 5000 --seed 1

which prints the totals per target (recorded in docs/RELIABILITY.md).
"""

from __future__ import annotations

import argparse
import json
import random
import tempfile
import time
import warnings
from collections import Counter
from pathlib import Path

import numpy as np


CLEAR = (ValueError, TypeError, OSError)

SETTINGS = json.dumps({"width": 4, "height": 3, "samples": 1, "wavelength_count": 8, "max_bounces": 2, "threads": 1})


# ------------------------------------------------------------------------ mutation

INTERESTING = [0, -1, 1, 2**31, 2**32 - 1, 2**63, -(2**63), 1e308, -1e308, 1e-308, 0.5, 3, 65536, "", "x", None, True, [], {}]


def mutate_bytes(data: bytes, rng: random.Random) -> bytes:
    b = bytearray(data)
    for _ in range(rng.randint(1, 8)):
        op = rng.randrange(6)
        if not b:
            b.extend(rng.randbytes(4))
            continue
        i = rng.randrange(len(b))
        if op == 0:
            b[i] = rng.randrange(256)
        elif op == 1:
            b[i] ^= 1 << rng.randrange(8)
        elif op == 2:
            del b[i : i + rng.randint(1, 16)]
        elif op == 3:
            b[i:i] = rng.randbytes(rng.randint(1, 8))
        elif op == 4:
            j = rng.randrange(len(b))
            b[i:i] = b[j : j + rng.randint(1, 32)]
        else:
            del b[rng.randrange(len(b)) :]
    return bytes(b)


def mutate_json_tree(value, rng: random.Random, depth: int = 0):
    """Structure-aware mutation: replace, drop or retype one node of a JSON tree."""
    if isinstance(value, dict) and value and rng.random() < 0.8:
        k = rng.choice(list(value))
        v = dict(value)
        r = rng.random()
        if r < 0.15:
            del v[k]
        elif r < 0.25:
            v[k + "_x"] = rng.choice(INTERESTING)
        else:
            v[k] = mutate_json_tree(v[k], rng, depth + 1)
        return v
    if isinstance(value, list) and value and rng.random() < 0.8:
        v = list(value)
        i = rng.randrange(len(v))
        r = rng.random()
        if r < 0.15:
            del v[i]
        elif r < 0.25:
            v.append(v[i])
        else:
            v[i] = mutate_json_tree(v[i], rng, depth + 1)
        return v
    if isinstance(value, (int, float)) and not isinstance(value, bool) and rng.random() < 0.5:
        return rng.choice([value * rng.choice([-1, 0, 2, 1e6, 1e-6, 1e30]), value + rng.choice([-1, 1])])
    return rng.choice(INTERESTING)


# ------------------------------------------------------------------------ seeds


def seed_scene():
    import polychrome as pc

    scene = pc.Scene()
    scene.add_material(pc.Diffuse((0.8, 0.2, 0.1), name="red"))
    glass = scene.add_material(pc.Dielectric(pc.ior.named("N-BK7"), roughness=0.2, name="glass"))
    lamp = scene.add_material(pc.Emitter(pc.spectra.blackbody(3000), strength=5.0, name="lamp"))
    scene.add_mesh(
        "floor",
        [[-2, -2, 0], [2, -2, 0], [2, 2, 0], [-2, 2, 0]],
        [[0, 1, 2], [0, 2, 3]],
        normals=[[0, 0, 1]] * 4,
        uvs=[[0, 0], [1, 0], [1, 1], [0, 1]],
    )
    scene.add_mesh("pane", [[-1, 0, 0.5], [1, 0, 0.5], [0, 0, 1.5]], [[0, 1, 2]], material=glass)
    scene.add_mesh("lamp", [[-0.5, -0.5, 3], [0.5, -0.5, 3], [0, 0.5, 3]], [[0, 1, 2]], material=lamp)
    scene.add_light(pc.PointLight((0, 0, 2), power=20.0, name="bulb"))
    scene.add_light(pc.SpotLight((1, 1, 2), direction=(0, 0, -1), name="spot"))
    scene.add_light(pc.SunLight(direction=(0.2, 0.1, -1), strength=0.5, name="sun"))
    tex = pc.Texture.from_array(np.linspace(0, 2, 4 * 8 * 3, dtype=np.float32).reshape(4, 8, 3), name="sky")
    scene.set_world(texture=tex, strength=0.5)
    scene.camera = pc.Camera.looking_at((0, -5, 3), (0, 0, 0.5))
    desc, buffers = scene.description()
    return desc, buffers


def mutate_buffers(buffers, rng: random.Random):
    out = list(buffers)
    for _ in range(rng.randint(1, 3)):
        if not out:
            break
        i = rng.randrange(len(out))
        a = out[i]
        r = rng.random()
        if r < 0.25:
            out[i] = a[: rng.randrange(a.size + 1)].copy()
        elif r < 0.4:
            with np.errstate(invalid="ignore"):
                out[i] = a.astype(rng.choice([np.float32, np.uint32, np.uint8, np.float64, np.int64]))
        elif r < 0.7 and a.size:
            b = a.copy()
            k = rng.randrange(b.size)
            if np.issubdtype(b.dtype, np.floating):
                b[k] = rng.choice([np.nan, np.inf, -np.inf, 1e38, -1e-38, 0.0])
            else:
                info = np.iinfo(b.dtype)
                b[k] = rng.choice([0, 1, info.max // 2 + 1, info.max])
            out[i] = b
        elif r < 0.85:
            del out[i]
        else:
            out.append(out[i])
    return out


# ------------------------------------------------------------------------ targets


def fuzz_scene_json(cases: int, seed: int, findings: list) -> Counter:
    from polychrome import _core

    rng = random.Random(seed)
    desc, buffers = seed_scene()
    text = json.dumps(desc)
    tally = Counter()
    for k in range(cases):
        r = rng.random()
        bufs = buffers
        if r < 0.4:
            scene_json = json.dumps(mutate_json_tree(desc, rng))
        elif r < 0.7:
            scene_json = mutate_bytes(text.encode(), rng).decode("utf-8", errors="replace")
        else:
            scene_json = text if rng.random() < 0.5 else json.dumps(mutate_json_tree(desc, rng))
            bufs = mutate_buffers(buffers, rng)
        try:
            out = _core.render(scene_json, bufs, SETTINGS)
            stats = json.loads(out["stats"])
            if not all(np.isfinite(out[p]).all() for p in ("rgba", "depth", "normal", "albedo")) or stats["nonfinite_samples"]:
                findings.append(("scene json", k, "non-finite output", scene_json[:300]))
                tally["finding"] += 1
            else:
                tally["rendered"] += 1
        except CLEAR:
            tally["rejected"] += 1
        except BaseException as e:  # noqa: BLE001 - any other exception is a finding
            if isinstance(e, KeyboardInterrupt):
                raise
            findings.append(("scene json", k, f"{type(e).__name__}: {e}", scene_json[:300]))
            tally["finding"] += 1
    return tally


USDA_SEED = """#usda 1.0
(
    defaultPrim = "World"
    metersPerUnit = 1
    upAxis = "Z"
)

def Xform "World"
{
    def Camera "cam"
    {
        float focalLength = 50
        float horizontalAperture = 36
        double3 xformOp:translate = (0, -6, 2)
        float3 xformOp:rotateXYZ = (75, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateXYZ"]
    }

    def Mesh "floor" (
        prepend apiSchemas = ["MaterialBindingAPI"]
    )
    {
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        point3f[] points = [(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)]
        normal3f[] normals = [(0, 0, 1), (0, 0, 1), (0, 0, 1), (0, 0, 1)] (interpolation = "vertex")
        rel material:binding = </World/red>
        double3 xformOp:translate = (0, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }

    def Sphere "ball"
    {
        double radius = 0.5
        double3 xformOp:translate = (0, 0, 0.5)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }

    def Material "red"
    {
        token outputs:surface.connect = </World/red/pbr.outputs:surface>
        def Shader "pbr"
        {
            uniform token info:id = "UsdPreviewSurface"
            color3f inputs:diffuseColor = (0.8, 0.1, 0.1)
            float inputs:roughness = 0.4
            float inputs:ior = 1.5
            token outputs:surface
        }
    }

    def SphereLight "bulb"
    {
        float inputs:intensity = 30
        float inputs:radius = 0.1
        color3f inputs:color = (1, 0.9, 0.8)
        double3 xformOp:translate = (1, -1, 3)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }

    def DistantLight "sun"
    {
        float inputs:intensity = 1
        float inputs:angle = 0.5
    }
}
"""


def mutate_usda(text: str, rng: random.Random) -> str:
    lines = text.splitlines()
    r = rng.random()
    if r < 0.5:
        # Token-level: replace a number with an interesting value.
        import re

        spots = [(i, m) for i, line in enumerate(lines) for m in re.finditer(r"-?\d+(\.\d+)?", line)]
        for _ in range(rng.randint(1, 3)):
            i, m = rng.choice(spots)
            value = rng.choice(["nan", "inf", "-inf", "0", "-1", "1e38", "1e-45", "99999999999", "-0", "2147483648"])
            line = lines[i]
            lines[i] = line[: m.start()] + value + line[m.end() :]
            spots = [(j, mm) for j, l2 in enumerate(lines) for mm in re.finditer(r"-?\d+(\.\d+)?", l2)]
        return "\n".join(lines) + "\n"
    if r < 0.75:
        # Line-level: drop, duplicate or swap lines.
        for _ in range(rng.randint(1, 3)):
            i = rng.randrange(len(lines))
            op = rng.randrange(3)
            if op == 0:
                del lines[i]
            elif op == 1:
                lines.insert(i, lines[rng.randrange(len(lines))])
            else:
                j = rng.randrange(len(lines))
                lines[i], lines[j] = lines[j], lines[i]
        return "\n".join(lines) + "\n"
    return mutate_bytes(text.encode(), rng).decode("utf-8", errors="replace")


def fuzz_usd(cases: int, seed: int, findings: list, workdir: Path) -> Counter:
    import polychrome as pc
    from polychrome.usd import read_stage

    rng = random.Random(seed)
    tally = Counter()
    path = workdir / "fuzz.usda"
    for k in range(cases):
        text = mutate_usda(USDA_SEED, rng)
        path.write_text(text)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                scene = read_stage(path)
                pc.render(scene, width=4, height=3, samples=1, wavelength_count=8, max_bounces=2, threads=1)
            tally["rendered"] += 1
        except CLEAR:
            tally["rejected"] += 1
        except BaseException as e:  # noqa: BLE001
            if isinstance(e, KeyboardInterrupt):
                raise
            findings.append(("usd", k, f"{type(e).__name__}: {e}", text))
            tally["finding"] += 1
    return tally


def image_seeds(workdir: Path) -> dict[str, bytes]:
    from polychrome import imageio, texture

    img = np.linspace(0, 4, 6 * 10 * 4, dtype=np.float32).reshape(6, 10, 4)
    img[..., 3] = 1
    seeds = {}
    for name, write in [
        ("seed.exr", lambda p: imageio.write_exr(p, img)),
        ("seed.png", lambda p: imageio.write_png(p, img)),
        ("seed.hdr", lambda p: texture.write_radiance_hdr(p, img[..., :3])),
    ]:
        p = workdir / name
        write(p)
        seeds[name] = p.read_bytes()
    # A run-length-encoded Radiance file (width ≥ 8) exercises the RLE decoder.
    wide = np.abs(np.sin(np.arange(3 * 40 * 3, dtype=np.float32))).reshape(3, 40, 3) * 5
    p = workdir / "seed_rle.hdr"
    texture.write_radiance_hdr(p, wide)
    seeds["seed_rle.hdr"] = p.read_bytes()
    return seeds


def fuzz_images(cases: int, seed: int, findings: list, workdir: Path) -> Counter:
    import polychrome as pc
    from polychrome import imageio, texture

    rng = random.Random(seed)
    seeds = image_seeds(workdir)
    names = sorted(seeds)
    tally = Counter()
    for k in range(cases):
        name = rng.choice(names)
        data = mutate_bytes(seeds[name], rng)
        path = workdir / f"fuzz{Path(name).suffix}"
        path.write_bytes(data)
        reader = rng.randrange(2)
        try:
            if reader == 0:
                out = texture.read_radiance_hdr(path) if path.suffix == ".hdr" else imageio.read_image(path)
                np.asarray(out)
            else:
                pc.Texture.from_file(path, name="fuzzed")
            tally["read"] += 1
        except CLEAR:
            tally["rejected"] += 1
        except BaseException as e:  # noqa: BLE001
            if isinstance(e, KeyboardInterrupt):
                raise
            findings.append(("image " + name, k, f"{type(e).__name__}: {e}", data[:200]))
            tally["finding"] += 1
    return tally


def run(cases: int, seed: int, targets=("json", "usd", "images")) -> tuple[dict, list]:
    findings: list = []
    totals = {}
    with tempfile.TemporaryDirectory() as d:
        workdir = Path(d)
        if "json" in targets:
            totals["scene json + buffers"] = fuzz_scene_json(cases, seed, findings)
        if "usd" in targets:
            try:
                import pxr  # noqa: F401
            except ImportError:
                pass
            else:
                totals["usd (.usda)"] = fuzz_usd(max(1, cases // 4), seed, findings, workdir)
        if "images" in targets:
            totals["images (exr/png/hdr)"] = fuzz_images(cases, seed, findings, workdir)
    return totals, findings


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=2000, help="cases per target (USD gets a quarter)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--targets", default="json,usd,images")
    args = ap.parse_args()
    t0 = time.perf_counter()
    totals, findings = run(args.cases, args.seed, tuple(args.targets.split(",")))
    for target, tally in totals.items():
        print(f"{target:24s} {sum(tally.values()):6d} inputs  " + "  ".join(f"{k} {v}" for k, v in sorted(tally.items())))
    print(f"findings: {len(findings)}  ({time.perf_counter() - t0:.0f} s)")
    for f in findings[:20]:
        print("  ", f[0], f[1], f[2][:300])
    return 1 if findings else 0


if __name__ == "__main__":
    raise SystemExit(main())
