"""Textures and HDRIs (docs/design.md#rgb-data, deferred conversion): memory held for a large float HDRI
against its raw RGB size, and the cost of converting RGB to a spectrum at each lookup.

    python bench/textures.py [--width 8192 --height 4096] [--write docs/BENCHMARKS.md]

1. Memory: an 8192×4096 float32 RGB HDRI (384 MiB raw) as the world of a tiny render.
   `texture_bytes` is what the core's scene holds for it (texels + importance-sampling
   tables), from RenderStats; the process's peak RSS growth during the render is shown
   too (it also counts the binding's copy of the numpy buffer, see docs/textures.md).
2. Per-lookup cost: `cargo run --release -p polychrome-core --example texture_lookup`
   (single thread, best of 5 × 4M lookups, random uv), and timed renders of one scene
   with a constant colour and with a 1024×1024 texture of the same mean colour.
"""

from __future__ import annotations

import argparse
import platform
import resource
import subprocess
import sys
from pathlib import Path

import numpy as np

import polychrome as pc

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import write_section  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def peak_rss_bytes() -> int:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # Linux: KiB


def memory(width: int, height: int) -> dict:
    rng = np.random.default_rng(1)
    hdri = rng.random((height, width, 3), dtype=np.float32)
    hdri[height // 4, width // 3] = 1e6
    raw = hdri.nbytes
    tex = pc.Texture.from_array(hdri, name="big")
    del hdri
    scene = pc.Scene()
    scene.set_world(texture=tex)
    before = peak_rss_bytes()
    r = pc.render(scene, width=4, height=4, samples=1)
    after = peak_rss_bytes()
    return {"raw": raw, "texture_bytes": r.stats["texture_bytes"], "rss_growth": after - before, "build_seconds": r.stats["build_seconds"]}


def micro() -> dict[str, float]:
    out = subprocess.run(
        ["cargo", "run", "--release", "-q", "-p", "polychrome-core", "--example", "texture_lookup"],
        cwd=ROOT,
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    return {k: float(v) for k, v in (line.split() for line in out.strip().splitlines())}


def sphere(rings=48, segments=96):
    th = np.linspace(0, np.pi, rings + 1)[:, None]
    ph = np.linspace(0, 2 * np.pi, segments + 1)[None, :]
    v = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th) * np.ones_like(ph)], -1).reshape(-1, 3)
    row = segments + 1
    a = (np.arange(rings)[:, None] * row + np.arange(segments)[None, :]).ravel()
    t = np.concatenate([np.stack([a, a + row, a + 1], 1), np.stack([a + 1, a + row, a + row + 1], 1)])
    uv = np.stack([(ph * np.ones_like(th)).ravel() / (2 * np.pi), 1 - (th * np.ones_like(ph)).ravel() / np.pi], 1)
    return v, t, uv


def timed_render(reflectance, size: int, samples: int) -> float:
    scene = pc.Scene()
    v, t, uv = sphere()
    scene.add_mesh("ball", v + [0, 0, -3.0], t, uvs=uv, material=pc.Diffuse(reflectance))
    scene.set_world((0.8, 0.8, 0.8))
    scene.camera = pc.Camera(focal_length=40.0)
    best = float("inf")
    for _ in range(3):
        r = pc.render(scene, width=size, height=size, samples=samples, seed=1)
        best = min(best, r.stats["seconds"] - r.stats["build_seconds"])
    return best


def main(argv=None) -> int:
    p = argparse.ArgumentParser()
    p.add_argument("--width", type=int, default=8192)
    p.add_argument("--height", type=int, default=4096)
    p.add_argument("--size", type=int, default=128)
    p.add_argument("--samples", type=int, default=16)
    p.add_argument("--write", help="Markdown file to update (e.g. docs/BENCHMARKS.md)")
    args = p.parse_args(argv)

    m = memory(args.width, args.height)
    ns = micro()
    tex = pc.Texture.from_array(np.random.default_rng(2).random((1024, 1024, 3), dtype=np.float32))
    mean = tuple(float(x) for x in tex.pixels.reshape(-1, 3).mean(axis=0))
    t_const = timed_render(mean, args.size, args.samples)
    t_tex = timed_render(tex, args.size, args.samples)

    mib = 1024.0**2
    lines = [
        f"{platform.processor() or platform.machine()}, release build; {ns.get('wavelengths', 41):.0f} wavelengths.",
        "",
        "| memory for a float HDRI | bytes | × raw RGB |",
        "| --- | ---: | ---: |",
        f"| raw RGB float32 {args.width}×{args.height} | {m['raw'] / mib:.1f} MiB | 1.000 |",
        f"| held by the core's scene (`texture_bytes`: texels + sampling tables) | {m['texture_bytes'] / mib:.1f} MiB | {m['texture_bytes'] / m['raw']:.3f} |",
        f"| peak RSS growth of the Python process during the render | {m['rss_growth'] / mib:.1f} MiB | {m['rss_growth'] / m['raw']:.3f} |",
        "",
        f"Scene build with this HDRI (sampling tables included): {m['build_seconds']:.2f} s.",
        "",
        "| lookup (one thread, random uv) | ns |",
        "| --- | ---: |",
    ]
    labels = {
        "constant_spectrum": "constant spectrum (copy, no conversion)",
        "uplift_reflectance_only": "uplift alone (eq. 10, `reflectance_into`)",
        "bilinear_rgb_only": "bilinear RGB fetch alone, 2048×1024 f32",
        "texture_linear_f32": "textured reflectance, 2048×1024 f32 (fetch + uplift)",
        "texture_srgb_u8": "textured reflectance, 2048×1024 sRGB bytes",
        "texture_linear_f32_64x64": "textured reflectance, 64×64 f32 (cache-resident)",
        "hdri_radiance": "HDRI radiance (direction → uv, fetch, `illuminant_into`)",
    }
    for k, label in labels.items():
        if k in ns:
            lines.append(f"| {label} | {ns[k]:.1f} |")
    lines += [
        "",
        f"Timed renders, diffuse ball under a grey world, {args.size}×{args.size}, {args.samples} spp, best of 3: "
        f"constant colour {t_const:.3f} s, 1024×1024 texture {t_tex:.3f} s ({(t_tex / t_const - 1) * 100:+.1f} %).",
    ]
    body = "\n".join(lines)
    print(body)
    if args.write:
        write_section(
            ROOT / args.write if not Path(args.write).is_absolute() else Path(args.write),
            "Textures and HDRIs (deferred RGB → spectrum)",
            body,
            "python bench/textures.py --write docs/BENCHMARKS.md",
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
