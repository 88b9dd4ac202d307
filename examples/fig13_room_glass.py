"""The paper's figure 13: the room of figure 12 with dispersive glass objects.

    python examples/fig13_room_glass.py [--samples 48] [--width 320] [--height 240] [--wavelengths 41]
        [--splitting] [--compare] [--out examples/out/fig13_room_glass] [--docs]

The closed room of ``fig12_room.py`` with a dense-flint (N-SF11) glass ball and an
N-BK7 glass prism on the floor in place of the white ball. Their index varies with
wavelength (Sellmeier, SCHOTT data), so every camera path that refracts collapses to
one wavelength chosen ∝ its energy (eq. 9) — or, with ``--splitting``, splits into one
path per wavelength (the paper's deterministic mode). Coloured fringes appear in the
caustics under the glass and in the refracted room.

Prints the time, and with ``--compare`` the monochromatic methods' times as ratios.
"""

from __future__ import annotations

from pathlib import Path
import sys

sys.path.insert(0, str(Path(__file__).resolve().parent))
import figlib  # noqa: E402

import polychrome as pc  # noqa: E402


def add_glass(scene: pc.Scene) -> None:
    """An N-SF11 ball and an N-BK7 triangular prism on the floor."""
    flint = scene.add_material(pc.Dielectric(pc.ior.named("N-SF11"), name="N-SF11"))
    crown = scene.add_material(pc.Dielectric(pc.ior.named("N-BK7"), name="N-BK7"))
    v, t, n = figlib.uv_sphere((0.12, -0.15, 0.32), 0.32)
    scene.add_mesh("flint ball", v, t, normals=n, material=flint)
    corners = [(-0.75, -0.35), (-0.25, -0.45), (-0.55, 0.05)]
    scene.add_mesh("crown prism", *figlib.prism(corners, 0.0, 0.5), material=crown)


def main(argv=None) -> int:
    from fig12_room import run

    return run(True, "fig13_room_glass", argv, doc=__doc__)


if __name__ == "__main__":
    sys.exit(main())
