"""Distance sampling in chromatic media (docs/media.md): the paper's collapse to one
wavelength (eq. 9) against spectral MIS over the ray's wavelengths, on a coloured
liquid in glass and a chromatic fog, 41 wavelengths, release build.

    python bench/media.py [--size 32] [--ref-spp 4096] [--max-seconds 60] [--write docs/BENCHMARKS.md]

Reports per scene and option: (a) render time at equal samples, (b) time to mean
ΔE00 ≤ 1 against a converged reference (SPECTRAL_MIS at --ref-spp with another
seed), found by doubling the sample count (render seconds, scene build excluded).
"""

from __future__ import annotations

import argparse
import platform
import sys
from pathlib import Path

import numpy as np

import polychrome as pc
from polychrome import spectra
from polychrome.colordiff import delta_e_stats, image_delta_e

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import write_section  # noqa: E402
from methods import quad, uv_sphere  # noqa: E402

N = 41
OPTIONS = ("SPECTRAL_MIS", "COLLAPSE")
LAM = np.arange(380.0, 781.0, 10.0)


def cube(lo, hi):
    v = np.array([[x, y, z] for z in (lo[2], hi[2]) for y in (lo[1], hi[1]) for x in (lo[0], hi[0])], dtype=np.float32)
    faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    return v, np.array([t for a, b, c, d in faces for t in ([a, b, c], [a, c, d])])


def stage(scene: pc.Scene) -> None:
    """A floor, a warm area lamp above and a dim blue world."""
    floor = scene.add_material(pc.Diffuse(0.7, name="floor"))
    lamp = scene.add_material(pc.Emitter(spectra.blackbody(4500.0), strength=12.0, name="lamp"))
    scene.add_mesh("floor", *quad((-4, -4, 0), (4, -4, 0), (4, 4, 0), (-4, 4, 0)), material=floor)
    scene.add_mesh("lamp", *quad((-0.6, -0.6, 3), (-0.6, 0.6, 3), (0.6, 0.6, 3), (0.6, -0.6, 3)), material=lamp)
    scene.set_world(spectra.rgb(0.2, 0.25, 0.35))
    scene.camera = pc.Camera.looking_at((0.0, -3.0, 1.4), (0.0, 0.0, 0.6), focal_length=35.0)


def liquid() -> pc.Scene:
    """A glass ball (n = 1.33) of cloudy orange juice: absorption rising steeply towards
    the blue, weak scattering rising towards the blue (extinction varies 20× over the
    spectrum)."""
    scene = pc.Scene()
    stage(scene)
    sigma_a = spectra.tabulated(LAM, 0.05 + 3.0 / (1 + np.exp((LAM - 520) / 25)))
    sigma_s = spectra.tabulated(LAM, 0.6 * (450.0 / LAM) ** 4)
    juice = pc.Dielectric(1.33, volume=pc.Medium(sigma_a, sigma_s, anisotropy=0.5), name="juice")
    scene.add_mesh("ball", *uv_sphere((0.0, 0.0, 0.6), 0.6), material=scene.add_material(juice))
    return scene


def fog() -> pc.Scene:
    """A cube of chromatic fog with no surface: Rayleigh-like scattering ∝ λ⁻⁴ (σs 0.7
    at 700 nm to 6 at 380 nm) and a little absorption."""
    scene = pc.Scene()
    stage(scene)
    sigma_s = spectra.tabulated(LAM, 0.7 * (700.0 / LAM) ** 4)
    medium = pc.Medium(0.05, sigma_s, anisotropy=0.2)
    scene.add_mesh("fog", *cube((-0.8, -0.8, 0.0), (0.8, 0.8, 1.4)), material=scene.add_material(pc.Volume(medium, name="fog")))
    return scene


def run(scene, option, samples, size, seed=1):
    r = pc.render(scene, width=size, height=size, samples=samples, medium_sampling=option, wavelength_count=N, max_bounces=16, seed=seed)
    return r.rgba, r.stats["seconds"] - r.stats["build_seconds"]


def measure(scene, size, spp, ref_spp, max_seconds, target=1.0):
    reference, ref_time = run(scene, "SPECTRAL_MIS", ref_spp, size, seed=4242)
    out = {}
    for option in OPTIONS:
        _, t_equal = run(scene, option, spp, size)
        s, t_target, de = 1, None, None
        while True:
            img, t = run(scene, option, s, size)
            de = delta_e_stats(image_delta_e(img, reference))["mean"]
            if de <= target:
                t_target = t
                break
            if t > max_seconds or s >= ref_spp // 4:
                break
            s *= 2
        out[option] = dict(equal=t_equal, target=t_target, spp=s, de=de)
        print(option, out[option], file=sys.stderr)
    return out, ref_time


def table(name, res, size, spp):
    base = res["SPECTRAL_MIS"]
    lines = [
        f"**{name}**, {size}×{size}, {N} wavelengths, max 16 bounces, backward tracing, POLYCHROMATIC.",
        "",
        f"| medium_sampling | (a) time at {spp} spp | vs SPECTRAL_MIS | (b) time to mean ΔE00 ≤ 1 | spp needed | vs SPECTRAL_MIS |",
        "| --- | ---: | ---: | ---: | ---: | ---: |",
    ]
    for option in OPTIONS:
        r = res[option]
        a = f"{r['equal']:.2f} s | {r['equal'] / base['equal']:.2f}×"
        if r["target"] is None:
            b = f"not reached (ΔE {r['de']:.2f} at {r['spp']} spp) | {r['spp']} | —"
        else:
            ratio = r["target"] / base["target"] if base["target"] else float("nan")
            b = f"{r['target']:.2f} s | {r['spp']} | {ratio:.2f}×"
        lines.append(f"| {option} | {a} | {b} |")
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=32)
    parser.add_argument("--spp", type=int, default=64, help="samples for (a)")
    parser.add_argument("--ref-spp", type=int, default=4096, help="samples of the converged reference")
    parser.add_argument("--max-seconds", type=float, default=60.0, help="give up on (b) after a render this long")
    parser.add_argument("--write", help="Markdown file to update with the results")
    args = parser.parse_args(argv)
    lines = [
        "Free-flight distances in media whose extinction depends on wavelength (docs/media.md): "
        "COLLAPSE is the paper's eq. 9 (the ray continues with one wavelength chosen ∝ energy), "
        "SPECTRAL_MIS keeps all 41 and weights them by the balance heuristic. "
        f"{platform.processor() or platform.machine()}, all cores, one run each; (b) doubles the sample count, "
        "so it resolves a factor of about 2. The machine is shared: times are noisy.",
        "",
    ]
    for name, scene in (("Cloudy orange juice in a glass ball", liquid()), ("Chromatic (Rayleigh-like) fog cube", fog())):
        res, ref_time = measure(scene, args.size, args.spp, args.ref_spp, args.max_seconds)
        lines += table(name, res, args.size, args.spp)
        lines += ["", f"Reference: SPECTRAL_MIS, {args.ref_spp} spp, another seed ({ref_time:.1f} s).", ""]
    text = "\n".join(lines).rstrip() + "\n"
    print(text)
    if args.write:
        cmd = f"python bench/media.py --size {args.size} --spp {args.spp} --ref-spp {args.ref_spp} --max-seconds {args.max_seconds:g} --write {args.write}"
        write_section(Path(args.write), "Media: distance sampling (collapse vs spectral MIS)", text, cmd)
    return 0


if __name__ == "__main__":
    sys.exit(main())
