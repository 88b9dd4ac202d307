"""What denoising does to dispersion: the prism of figures 6/7 (examples/fig06_prism.py),
spectral (POLYCHROMATIC, 81 wavelengths), noisy and denoised with Open Image Denoise.

    python examples/denoise_prism.py [--samples 16] [--width 240] [--height 180] [--docs]

Writes ``examples/out/denoise_prism.png`` (noisy left, denoised right; with ``--docs``
also docs/images/) and prints, for the screen's rainbow, how many pixels are lit, which channel
dominates, their saturation and the mean dE00 between noisy and denoised. The image is the sum of the cone light traced
from the light and the dim ambient world traced from the camera (as fig06_prism.py);
the denoiser gets that sum with the camera render's albedo and normal.
"""

from __future__ import annotations

import argparse
from pathlib import Path
import sys

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import figlib  # noqa: E402
from fig06_prism import build_scene  # noqa: E402

import polychrome as pc  # noqa: E402
from polychrome import spectra  # noqa: E402
from polychrome.colordiff import image_delta_e  # noqa: E402


def rainbow_stats(rgba: np.ndarray, lit: np.ndarray) -> dict:
    """Lit-pixel count, how many are red/green/blue-dominant, and their mean saturation."""
    rgb = np.clip(rgba[..., :3], 0, None)[lit]
    mx, mn = rgb.max(axis=1), rgb.min(axis=1)
    dominant = np.bincount(rgb.argmax(axis=1), minlength=3)
    sat = (mx - mn) / np.maximum(mx, 1e-12)
    return {"pixels": int(lit.sum()), "rgb": dominant.tolist(), "saturation": float(sat.mean())}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--samples", type=int, default=16)
    p.add_argument("--width", type=int, default=240)
    p.add_argument("--height", type=int, default=180)
    p.add_argument("--docs", action="store_true")
    a = p.parse_args(argv)
    common = dict(width=a.width, height=a.height, wavelength_count=81, max_bounces=8, seed=1, **figlib.fixed())
    scene, _ = build_scene(spectra.d65())
    world, _ = build_scene(spectra.d65(), ambient=0.02, spot=False)
    light = pc.render(scene, method="POLYCHROMATIC", direction="FORWARD", samples=a.samples, **common)
    amb = pc.render(world, method="POLYCHROMATIC", direction="BACKWARD", samples=max(1, a.samples // 4), **common)
    noisy = light.rgba + amb.rgba * np.array([1, 1, 1, 0], np.float32)
    denoised = pc.denoise.denoise(noisy, amb.albedo, amb.normal)
    out = figlib.save(figlib.side_by_side(noisy, denoised), figlib.OUT / "denoise_prism", docs=a.docs)
    print("wrote", ", ".join(str(x) for x in out))
    lit = light.rgba[..., :3].sum(axis=-1) > 0.3  # the rainbow, located on the noisy light render
    for name, img in (("noisy", noisy), ("denoised", denoised)):
        s = rainbow_stats(img, lit)
        neg = float((img[..., :3] < 0).any(axis=-1)[lit].mean())
        print(
            f"{name:9s} rainbow: {s['pixels']} px, red/green/blue-dominant {s['rgb']}, mean saturation {s['saturation']:.2f}, with a negative component {neg:.0%}"
        )
    de = image_delta_e(noisy, denoised)[lit]
    print(f"rainbow noisy vs denoised: mean dE00 {de.mean():.2f}, background (unlit) {image_delta_e(noisy, denoised)[~lit].mean():.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
