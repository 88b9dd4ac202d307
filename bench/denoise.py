"""Denoising inside the speed-for-accuracy trade (issue 18): mean ΔE00 to a converged
reference against time, noisy and denoised, on the Cornell box (or the glass room of
fig. 13, `--scene glass_room`, or a textured glTF asset imported by Blender and exported
by the add-on, `--scene gltf`: bench/gltf_scene.py, needs bpy) at 1, 2, 4, ... 64 spp.

    python bench/denoise.py [--scene cornell|glass_room|gltf] [--size 64] [--ref-samples 2048] [--max-samples 64] [--write docs/BENCHMARKS.md]

Times are wall seconds of `pc.render` (scene build included) and of the denoiser
(`stats["denoise_seconds"]`: OIDN with prefiltered albedo and normal, as `denoise=True`
does), release build, all cores. ΔE00 is colour-science's CIE 2000 on linear sRGB
(white Y = 1), averaged over the image. The reference (same scene, another seed) is
itself noisy; its own error is estimated as that of a second reference of another seed
and printed, since no image can get closer to it than that.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "examples"))

import polychrome as pc  # noqa: E402
from common import write_section  # noqa: E402


def mean_de00(a, b) -> float:
    import colour

    cs = colour.RGB_COLOURSPACES["sRGB"]
    lab = [
        colour.XYZ_to_Lab(colour.RGB_to_XYZ(np.asarray(x, np.float64)[..., :3], cs, apply_cctf_decoding=False), cs.whitepoint)
        for x in (a, b)
    ]
    return float(np.mean(colour.delta_E(lab[0], lab[1], method="CIE 2000")))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", choices=("cornell", "glass_room", "gltf"), default="cornell")
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--ref-samples", type=int, default=2048)
    ap.add_argument("--max-samples", type=int, default=64)
    ap.add_argument("--write", type=Path)
    args = ap.parse_args()
    if args.scene == "cornell":
        from cornell_box import build_scene

        scene, what = build_scene(), "Cornell box (examples/cornell_box.py)"
    elif args.scene == "gltf":
        from gltf_scene import WHAT, build_scene

        scene, warnings = build_scene()
        for w in warnings:
            print("warning:", w)
        what = WHAT
    else:
        from methods import room

        scene, what = room(glass=True), "Glass room of fig. 13 (bench/methods.py: dispersive N-SF11 ball)"
    common = dict(width=args.size, height=args.size, wavelength_count=41, max_bounces=8, noise_threshold=0.0, quality="FINAL")
    reference = pc.render(scene, samples=args.ref_samples, seed=99, **common)
    floor = mean_de00(pc.render(scene, samples=args.ref_samples, seed=98, **common).rgba, reference.rgba)
    rows = []
    spp = 1
    while spp <= args.max_samples:
        r = pc.render(scene, samples=spp, seed=1, denoise=True, **common)
        t = r.stats["wall_seconds"]
        rows.append((spp, t, mean_de00(r.noisy, reference.rgba), r.stats["denoise_seconds"], mean_de00(r.rgba, reference.rgba)))
        print(
            f"{spp:3d} spp  render {t:6.2f} s  noisy {rows[-1][2]:.2f}  denoise {rows[-1][3]:.2f} s  denoised {rows[-1][4]:.2f}", flush=True
        )
        spp *= 2
    lines = [
        f"{what}, {args.size}×{args.size}, 41 wavelengths, 8 bounces, FINAL; mean ΔE00 "
        f"(colour-science) to a {args.ref_samples}-spp render of another seed, whose own error (a second reference against "
        f"it) is {floor:.2f}. Denoised: OIDN with prefiltered aux (`denoise=True`); time = render + denoise.",
        "",
        "| spp | render s | noisy ΔE00 | denoise s | denoised ΔE00 | denoised time | noisy ΔE00 at that time | noisy spp needed for the denoised error |",
        "| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    # Noisy error against render time, log-log, for the equal-time column (extrapolated past the last row).
    tfit = np.polyfit(np.log([x[1] for x in rows]), np.log([x[2] for x in rows]), 1)
    for spp, t, noisy, dt, den in rows:
        # Noisy error falls as 1/sqrt(spp) (fitted on the noisy column): spp where it meets `den`.
        needed = [s for s, _, n, _, _ in rows if n <= den]
        fit = np.polyfit(np.log([x[0] for x in rows]), np.log([x[2] for x in rows]), 1)
        est = float(np.exp((np.log(den) - fit[1]) / fit[0]))
        need = f"{needed[0]}" if needed else f"≈{est:.0f} (extrapolated)"
        at_time = float(np.exp(np.polyval(tfit, np.log(t + dt))))
        lines.append(f"| {spp} | {t:.2f} | {noisy:.2f} | {dt:.2f} | {den:.2f} | {t + dt:.2f} s | {at_time:.2f} | {need} |")
    body = "\n".join(lines)
    print(body)
    if args.write:
        title = "Denoising against time" + {"cornell": "", "glass_room": " (glass room)", "gltf": " (textured glTF asset)"}[args.scene]
        flags = "" if args.scene == "cornell" else f" --scene {args.scene} --ref-samples {args.ref_samples}"
        if args.size != 64:
            flags += f" --size {args.size}"
        if args.max_samples != 64:
            flags += f" --max-samples {args.max_samples}"
        after = "Denoising against time (glass room)" if args.scene == "gltf" else None
        write_section(args.write, title, body, f"python bench/denoise.py{flags} --write docs/BENCHMARKS.md", after=after)
    return 0


if __name__ == "__main__":
    sys.exit(main())
