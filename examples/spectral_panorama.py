"""A spectral equirectangular panorama of the Cornell-style box, written as a spectral EXR.

    python examples/spectral_panorama.py [--samples 64] [--width 256] [--out examples/out/panorama]

An equirectangular camera (Blender's and Cycles' mapping, docs/camera.md) at the middle
of the room sees every direction; with ``spectral_output`` every pixel keeps its whole
spectrum, and the result is written as an emissive spectral OpenEXR (Fichet et al. 2021
layout, an RGB preview alongside). Such an image is a "measured-looking" HDRI: the
radiance of each direction as a spectrum, not three numbers. Used as a world it shows the
room again (``--check`` renders a perspective view both ways and prints their ΔE00).
"""

from __future__ import annotations

import argparse
from pathlib import Path
import sys

import numpy as np

import polychrome as pc
from polychrome import imageio

sys.path.insert(0, str(Path(__file__).parent))
import cornell_box  # noqa: E402

CENTRE = (0.0, 0.0, 1.0)


def panorama_camera() -> pc.Camera:
    """From the middle of the room looking along +x, +z up: the image centre then faces
    +x, where an equirectangular environment texture has its centre (Blender's mapping),
    so the panorama is a world texture as it stands."""
    return pc.Camera.looking_at(CENTRE, (1.0, 0.0, 1.0), projection="PANORAMIC", panorama_type="EQUIRECTANGULAR", clip_start=0.01)


def render_panorama(width: int, samples: int, wavelengths: int = 41, seed: int = 0):
    scene = cornell_box.build_scene()
    scene.camera = panorama_camera()
    return pc.render(
        scene,
        width=width,
        height=width // 2,
        samples=samples,
        wavelength_count=wavelengths,
        spectral_output=True,
        seed=seed,
    )


def perspective_both_ways(panorama_rgb: np.ndarray, size: int, samples: int, seed: int = 0):
    """A 90° view from the centre, of the room and of the panorama used as a world."""
    view = pc.Camera.looking_at(CENTRE, (0.6, 1.0, 0.8), focal_length=18.0, sensor_width=36.0, clip_start=0.01)
    room = cornell_box.build_scene()
    room.camera = view
    direct = pc.render(room, width=size, height=size, samples=samples, seed=seed)
    world = pc.Scene()
    world.set_world(texture=pc.Texture.from_array(panorama_rgb, encoding="linear", wrap="REPEAT"))
    world.camera = view
    seen = pc.render(world, width=size, height=size, samples=samples, seed=seed)
    return direct.rgba, seen.rgba


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=64)
    parser.add_argument("--width", type=int, default=256, help="panorama width (height is half)")
    parser.add_argument("--wavelengths", type=int, default=41)
    parser.add_argument("--out", default=str(Path(__file__).parent / "out" / "panorama"), help="output path without extension")
    parser.add_argument("--check", action="store_true", help="also compare a view of the room with the same view of the panorama")
    args = parser.parse_args(argv)
    result = render_panorama(args.width, args.samples, args.wavelengths)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    exr = out.with_suffix(".exr")
    imageio.write_spectral_exr(exr, result.spectral, result.wavelengths, rgba=result.rgba)
    print("wrote", exr, f"({result.spectral.shape[2]} wavelengths) and", result.save(out.with_suffix(".png")))
    if args.check:
        from polychrome import colordiff

        a, b = perspective_both_ways(result.rgba[..., :3], 64, args.samples)
        de = colordiff.image_delta_e(a, b, white_luminance=float(np.percentile(a[..., 1], 99)))
        print(f"room vs panorama-as-world, 64×64 view: mean ΔE00 {de.mean():.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
