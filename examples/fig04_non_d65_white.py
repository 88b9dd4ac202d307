"""The paper's figures 4 and 5: the green sphere under a "white" light that is not D65.

    python examples/fig04_non_d65_white.py [--samples 64] [--width 320] [--height 240]
        [--wavelengths 41] [--light triband|F11] [--out examples/out/fig04_non_d65_white] [--docs]

The light has exactly the RGB of D65 (white, luminance 8) but a different spectrum:
by default three narrow bands (450, 540, 610 nm, 12 nm wide) mixed so that their RGB is
D65's white — a metamer of daylight, like a tri-band lamp; ``--light F11`` uses the CIE
fluorescent F11 instead (scaled to the same luminance; its RGB is only near white).
RGB mode sees a white light and renders the sphere as under daylight; the spectral
render shows what the paint really reflects. Same scene, layout and output as
``fig02_red_light_green_sphere.py``; the script also renders the spectral image under
true D65, to show that under D65 RGB and spectral agree.
"""

from __future__ import annotations

import argparse
from pathlib import Path
import sys

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import figlib  # noqa: E402
from fig02_red_light_green_sphere import build_scene, compare, render_pair, run  # noqa: E402

from polychrome import spectra  # noqa: E402

LUMINANCE = 8.0


def white_light(kind: str = "triband") -> spectra.Spectrum:
    if kind.lower() == "f11":
        return figlib.with_luminance(spectra.fluorescent(11), LUMINANCE)
    return figlib.metameric_white(y=LUMINANCE)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(add_help=False)
    parser.add_argument("--light", default="triband", choices=["triband", "F11", "f11"])
    known, rest = parser.parse_known_args(argv)
    light = white_light(known.light)
    rgb_of_light = figlib.spectrum_rgb(light)
    print(
        f"light '{known.light}': linear RGB {np.round(rgb_of_light, 4)}, D65 of the same luminance: "
        f"{np.round(figlib.spectrum_rgb(figlib.with_luminance(spectra.d65(), LUMINANCE)), 4)}"
    )
    run(light, "fig04_non_d65_white", f"'white' light ({known.light}, same RGB as D65)", rest)
    # Control: under real D65 of the same luminance, RGB and spectral agree.
    d65 = figlib.with_luminance(spectra.d65(), LUMINANCE)
    small = dict(width=80, height=60, samples=16, wavelength_count=41, max_bounces=6, seed=1, **figlib.fixed())
    c = compare(*render_pair(build_scene(d65), **small))
    print(f"control under D65 (80x60, 16 spp): RGB vs spectral sphere CIEDE2000 {c['delta_e']:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
