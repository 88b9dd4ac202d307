"""The paper's figures 6 and 7: a D65 cone light through a glass prism onto a screen.

    python examples/fig06_prism.py [--samples 64] [--width 320] [--height 240] [--wavelengths 81]
        [--glass N-SF11] [--direction BIDIRECTIONAL] [--out examples/out/fig06_prism] [--docs]

A narrow spot (cone) light with a D65 spectrum shines on one face of an equilateral
prism standing on a table, at the angle of minimum deviation; the dispersed beam lands
on a white screen. The caustic of a small light seen through glass cannot be found by
tracing from the camera, so it is traced from the light (``direction`` FORWARD or
BIDIRECTIONAL); a dim ambient world, traced from the camera in a second render and
added, shows the table and the screen. At the prism each light path collapses to one wavelength
(eq. 9): with 81 wavelengths the screen shows a continuous rainbow. RGB mode has three
wavelengths (R 620, G 540, B 460 nm) and shows three discrete coloured spots.

Writes ``<out>.png``/``.exr`` (RGB mode left, spectral right) and the two full images,
and prints the closed-form deviation (Snell's law with the glass's Sellmeier index) and
where the rendered rainbow lies on the screen.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
import sys

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import figlib  # noqa: E402

import polychrome as pc  # noqa: E402
from polychrome import spectra  # noqa: E402

# Sellmeier coefficients (λ in µm): SCHOTT data sheets, as in the core's catalogue.
SELLMEIER = {
    "N-BK7": ([1.03961212, 0.231792344, 1.01046945], [0.00600069867, 0.0200179144, 103.560653]),
    "N-SF11": ([1.73759695, 0.313747346, 1.89878101], [0.013188707, 0.0623068142, 155.23629]),
}

APEX = math.radians(60.0)
SIDE = 1.0
HEIGHT = 0.5  # the beam's height above the table (the prism stands from z = 0 to 1)


def sellmeier(glass: str, lam_nm) -> np.ndarray:
    b, c = SELLMEIER[glass]
    l2 = (np.asarray(lam_nm, np.float64) / 1000.0) ** 2
    return np.sqrt(1.0 + sum(bk * l2 / (l2 - ck) for bk, ck in zip(b, c)))


def geometry(glass: str = "N-SF11", throw: float = 1.5, screen: float = 6.0) -> dict:
    """Where everything is (in the z = HEIGHT plane): prism corners, the beam's entry
    point and direction (minimum deviation at 550 nm), exit direction, screen plane."""
    r = SIDE / math.sqrt(3.0)
    corners = np.array([[-SIDE / 2, -r / 2], [SIDE / 2, -r / 2], [0.0, r]])  # CCW from +Z
    n_ref = float(sellmeier(glass, 550.0))
    theta1 = math.asin(n_ref * math.sin(APEX / 2))
    alpha = theta1 - APEX / 2  # the incoming beam climbs at alpha, leaves falling at alpha
    d_in = np.array([math.cos(alpha), math.sin(alpha)])
    d_out = np.array([math.cos(alpha), -math.sin(alpha)])
    y_entry = 0.0
    entry = np.array([corners[0, 0] + (y_entry - corners[0, 1]) / math.tan(math.radians(60.0)), y_entry])
    exit_ = np.array([-entry[0], y_entry])
    center = exit_ + screen * d_out
    return {
        "glass": glass,
        "corners": corners,
        "n_ref": n_ref,
        "alpha": alpha,
        "d_in": d_in,
        "d_out": d_out,
        "entry": entry,
        "exit": exit_,
        "light": entry - throw * d_in,
        "screen_center": center,
        "screen_normal": -d_out,
    }


def build_scene(
    light: spectra.Spectrum,
    *,
    glass: str = "N-SF11",
    power: float = 2000.0,
    spot_deg: float = 0.8,
    camera: str = "view",
    ambient: float = 0.0,
    table: bool = True,
    spot: bool = True,
) -> tuple[pc.Scene, dict]:
    """The prism scene and its geometry. ``camera="view"``: the figure's view from above
    the table; ``camera="screen"``: a pinhole 1.5 in front of the screen on its normal,
    looking straight at it (image x = the screen's horizontal axis; for the tests).
    ``light`` is the spot's colour (power ``power`` W as Blender's spot light);
    ``ambient`` a dim uniform D65 world; ``spot=False`` leaves the spot out."""
    g = geometry(glass)
    scene = pc.Scene()
    screen_mat = scene.add_material(pc.Diffuse(0.8, name="white screen"))
    table_mat = scene.add_material(pc.Diffuse(figlib.smooth_step(0.25, 0.45, 560, 40), name="table"))
    glass_mat = scene.add_material(pc.Dielectric(pc.ior.named(glass), name=glass))
    scene.add_mesh("prism", *figlib.prism(g["corners"], 0.0, 1.0), material=glass_mat)
    # The screen: 3 wide, 2 high, standing on the table, facing the prism.
    c, n = g["screen_center"], g["screen_normal"]
    h = np.array([-n[1], n[0]])  # horizontal axis along the screen (n rotated +90°)
    w = 1.5
    a0, a1 = c - w * h, c + w * h
    scene.add_mesh("screen", *figlib.quad((*a0, 0.0), (*a1, 0.0), (*a1, 2.0), (*a0, 2.0)), material=screen_mat)
    if table:
        s = 8.0
        scene.add_mesh("table", *figlib.quad((-s, -s, 0), (s, -s, 0), (s, s, 0), (-s, s, 0)), material=table_mat)
    if spot:
        scene.add_light(
            pc.SpotLight(
                position=(*g["light"], HEIGHT),
                direction=(*g["d_in"], 0.0),
                power=power,
                color=light,
                spot_size=math.radians(spot_deg),
                spot_blend=0.0,
                name="cone light",
            )
        )
    if ambient > 0:
        scene.set_world(spectra.d65(ambient))
    if camera == "screen":
        eye = np.array([*(c + 1.5 * n), HEIGHT])
        scene.camera = pc.Camera.looking_at(eye, (*c, HEIGHT), focal_length=50.0)
        g["camera_distance"] = 1.5
        g["screen_axis"] = h  # image +x: camera right = forward × up = h
    else:
        # In front of the screen, a little to the side of the dispersed beam.
        side = np.array([-g["d_out"][1], g["d_out"][0]])  # left of the outgoing beam
        eye = c + 2.6 * n + 0.9 * side
        scene.camera = pc.Camera.looking_at((*eye, 1.3), (*c, 0.55), focal_length=35.0)
    return scene, g


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=64)
    parser.add_argument("--width", type=int, default=320)
    parser.add_argument("--height", type=int, default=240)
    parser.add_argument("--wavelengths", type=int, default=81)
    parser.add_argument("--glass", default="N-SF11", choices=sorted(SELLMEIER))
    parser.add_argument("--direction", default="FORWARD", choices=["FORWARD", "BIDIRECTIONAL"], help="for the cone light")
    parser.add_argument("--ambient", type=float, default=0.02, help="dim D65 world radiance (0: none)")
    parser.add_argument("--out", default=str(figlib.OUT / "fig06_prism"))
    parser.add_argument("--docs", action="store_true", help="also write a PNG to docs/images/")
    args = parser.parse_args(argv)

    # Radiance is linear in the lights: the cone light (traced from the light) and the
    # dim ambient world (traced from the camera; it shows the table, screen and prism)
    # are rendered separately and added. Rendered together, light selection ∝ power
    # (eq. 7) would start almost every light path at the far more powerful world.
    scene, g = build_scene(spectra.d65(), glass=args.glass)
    settings = dict(
        width=args.width,
        height=args.height,
        samples=args.samples,
        wavelength_count=args.wavelengths,
        max_bounces=8,
        seed=1,
        **figlib.fixed(),
    )
    images = {}
    for method in ("RGB", "POLYCHROMATIC"):
        r = pc.render(scene, method=method, direction=args.direction, **settings)
        images[method] = [r.rgba, r.stats["seconds"]]
        if args.ambient > 0:
            world, _ = build_scene(spectra.d65(), glass=args.glass, ambient=args.ambient, spot=False)
            a = pc.render(world, method=method, direction="BACKWARD", **{**settings, "samples": max(1, args.samples // 4)})
            images[method][0] = r.rgba + a.rgba * np.array([1, 1, 1, 0], np.float32)
            images[method][1] += a.stats["seconds"]
    rgb, spectral = images["RGB"][0], images["POLYCHROMATIC"][0]
    out = Path(args.out)
    figlib.save(rgb, out.with_name(out.name + "_rgb"))
    figlib.save(spectral, out.with_name(out.name + "_spectral"))
    written = figlib.save(figlib.side_by_side(rgb, spectral), out, docs=args.docs)
    print("wrote", ", ".join(str(p) for p in written))

    # Closed form: deviation of a ray at minimum deviation for 550 nm, by wavelength.
    print(f"{args.glass}, apex 60°, incidence {math.degrees(math.asin(g['n_ref'] * 0.5)):.2f}° (minimum deviation at 550 nm)")
    for lam in (380.0, 460.0, 540.0, 550.0, 620.0, 780.0):
        n = float(sellmeier(args.glass, lam))
        theta1 = math.asin(g["n_ref"] * 0.5)
        t1 = math.asin(math.sin(theta1) / n)
        t2 = APEX - t1
        s = n * math.sin(t2)
        dev = math.degrees(theta1 + math.asin(s) - APEX) if s < 1 else float("nan")
        print(f"  {lam:5.0f} nm  n = {n:.5f}  deviation {dev:6.3f}°")
    lit = lambda img: int((img[..., :3].sum(axis=-1) > 0.3).sum())
    print(f"screen pixels brighter than 0.3: spectral {lit(spectral)}, RGB mode {lit(rgb)}")
    print(
        f"{images['POLYCHROMATIC'][1]:.1f} s spectral ({args.wavelengths} wavelengths), {images['RGB'][1]:.1f} s RGB; cone light {args.direction}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
