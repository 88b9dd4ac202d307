"""The cost of the Principled's subsurface random walk (docs/materials.md#subsurface-random-walk):
a sphere of radius 0.4 (the Blender BSDF grid's) under a uniform world and a sun, the
same Principled with Subsurface Weight 1 against 0 (its diffuse), at Blender's default
radius (1, 0.2, 0.1) and two scales, for the POLYCHROMATIC (whole grid) and HERO methods.

    python bench/subsurface.py [--size 64] [--spp 64] [--write docs/BENCHMARKS.md]

Reports render seconds (scene build excluded) and the ratio to the diffuse.
"""

from __future__ import annotations

import argparse
import platform
import sys
import time
from pathlib import Path

import numpy as np

import polychrome as pc

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import write_section  # noqa: E402
from methods import uv_sphere  # noqa: E402


def scene(weight: float, scale: float) -> pc.Scene:
    s = pc.Scene()
    s.camera = pc.Camera.looking_at((0, -4, 0), (0, 0, 0), focal_length=150.0)
    v, t = uv_sphere((0.0, 0.0, 0.0), 0.4, rings=24, segments=48)
    mat = pc.Principled((0.8, 0.5, 0.4), subsurface_weight=weight, subsurface_scale=scale)
    s.add_mesh("ball", np.asarray(v, np.float32), np.asarray(t), material=mat)
    s.set_world((1.0, 1.0, 1.0))
    s.add_light(pc.SunLight(direction=(-0.4, 0.6, -0.7), strength=2.0))
    return s


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--write", type=Path)
    a = ap.parse_args()
    rows = ["| method | scale | diffuse s | walk s | walk / diffuse |", "| --- | --- | --- | --- | --- |"]
    for method in ("POLYCHROMATIC", "HERO"):
        for scale in (0.1, 1.0):
            t = []
            for weight in (0.0, 1.0):
                sc = scene(weight, scale)
                start = time.perf_counter()
                pc.render(sc, width=a.size, height=a.size, samples=a.spp, max_bounces=16, method=method)
                t.append(time.perf_counter() - start)
            rows.append(f"| {method} | {scale} | {t[0]:.2f} | {t[1]:.2f} | {t[1] / t[0]:.2f} |")
            print(rows[-1], flush=True)
    body = (
        f"{a.size}² pixels, {a.spp} spp, max 16 bounces, {platform.machine()}; a sphere of radius 0.4 filling "
        "about a third of the frame (base colour (0.8, 0.5, 0.4), Blender's default radius).\n\n" + "\n".join(rows)
    )
    if a.write:
        write_section(
            a.write, "Subsurface random walk: cost against the diffuse", body, "python bench/subsurface.py --write docs/BENCHMARKS.md"
        )


if __name__ == "__main__":
    main()
