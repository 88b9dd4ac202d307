"""The ``polychrome`` console command.

Each subcommand has an ``_add_<name>_parser(subparsers)`` function that declares its
arguments and sets ``handler`` to a ``cmd_<name>(args) -> int`` function; to add one
(e.g. ``render``), write that pair and call the adder from :func:`build_parser`.
Handlers raise ``OSError``/``ValueError`` for bad input; :func:`main` turns those into a
one-line error on stderr and exit status 2, so no traceback reaches the user.
"""

from __future__ import annotations

import argparse
import json
import sys

EXIT_OK = 0
EXIT_BAD_INPUT = 2


def _version() -> str:
    """The package version, read lazily so that building the parser never imports the compiled core."""
    import polychrome

    return polychrome.__version__


def build_parser() -> argparse.ArgumentParser:
    """The top-level parser with one subparser per subcommand."""
    parser = argparse.ArgumentParser(prog="polychrome", description="Polychrome spectral path tracer tools.")
    parser.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    _add_diff_parser(subparsers)
    _add_render_parser(subparsers)
    return parser


# --------------------------------------------------------------------------- diff


def _add_diff_parser(subparsers) -> None:
    """Declare `polychrome diff A B [--heatmap PATH] [--white-luminance Y] [--json]`."""
    p = subparsers.add_parser(
        "diff",
        help="CIEDE2000 colour difference between two images",
        description="Per-pixel CIEDE2000 between two scene-linear images (.exr, or sRGB .png).",
    )
    p.add_argument("a", metavar="A", help="first image (.exr or .png)")
    p.add_argument("b", metavar="B", help="second image, same size")
    p.add_argument("--heatmap", metavar="PATH", help="also write a colour-mapped dE00 heat map PNG")
    p.add_argument(
        "--white-luminance",
        metavar="Y",
        type=float,
        default=1.0,
        help="luminance of the D65 reference white for L*a*b* (default 1: a white diffuser renders at Y=1)",
    )
    p.add_argument("--json", action="store_true", help="print the statistics as JSON")
    p.set_defaults(handler=cmd_diff)


def cmd_diff(args: argparse.Namespace) -> int:
    """Compare two images and print mean, median, 95th percentile and max ΔE00."""
    from .colordiff import diff_files

    stats = diff_files(args.a, args.b, heatmap=args.heatmap, white_luminance=args.white_luminance)
    if args.json:
        print(json.dumps({"a": args.a, "b": args.b, "heatmap": args.heatmap, **stats}))
    else:
        print(_format_diff_table(stats, args.heatmap))
    return EXIT_OK


def _format_diff_table(stats: dict, heatmap=None) -> str:
    """Human-readable ΔE00 summary (ASCII only, so it prints on any terminal encoding)."""
    rows = [("mean", stats["mean"]), ("median", stats["median"]), ("p95", stats["p95"]), ("max", stats["max"])]
    lines = [f"CIEDE2000 (dE00) over {stats['pixels']} pixels"]
    lines += [f"  {name:<7}{value:10.4f}" for name, value in rows]
    if heatmap:
        lines.append(f"heat map written to {heatmap}")
    return "\n".join(lines)


# --------------------------------------------------------------------------- render

USD_SUFFIXES = (".usd", ".usda", ".usdc", ".usdz")
EXIT_INTERRUPTED = 130


def _add_render_parser(subparsers) -> None:
    """Declare `polychrome render SCENE -o OUT [--samples N] [--method M] [--wavelengths N]
    [--seed S] [--threads T] [--time-limit SEC] [--width W --height H]`."""
    p = subparsers.add_parser(
        "render",
        help="render a USD stage or a .blend file to .exr/.png",
        description="Render a USD stage (.usd/.usda/.usdc/.usdz) or a .blend file (needs bpy). "
        "Settings stored in the scene are used unless a flag overrides them.",
    )
    p.add_argument("scene", metavar="SCENE", help="scene file: .usd, .usda, .usdc, .usdz or .blend")
    p.add_argument("-o", "--output", metavar="OUT", required=True, help="image to write: .exr or .png")
    p.add_argument("--samples", type=int, metavar="N", help="samples per pixel")
    p.add_argument("--method", metavar="M", help="POLYCHROMATIC, MONOCHROMATIC_RAYS, MONOCHROMATIC_SCENES or RGB")
    p.add_argument("--direction", metavar="D", help="BACKWARD (from the camera), FORWARD (light tracing) or BIDIRECTIONAL")
    p.add_argument(
        "--dispersion-splitting",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="POLYCHROMATIC: one monochromatic path per wavelength at the first dispersive surface (deterministic mode)",
    )
    p.add_argument(
        "--wavelengths",
        metavar="N|L1,L2,...",
        help="wavelength grid: a sample count (uniform over --wavelength-min..--wavelength-max, default 380-780 nm) "
        "or an explicit ascending list of wavelengths in nm",
    )
    p.add_argument("--wavelength-min", type=float, metavar="NM", help="start of the uniform grid (default 380)")
    p.add_argument("--wavelength-max", type=float, metavar="NM", help="end of the uniform grid (default 780)")
    p.add_argument("--max-bounces", type=int, metavar="B", help="scattering events per path (0: only what the camera sees)")
    p.add_argument("--uplift", metavar="U", help="RGB to spectrum map: LINEAR (the paper's eq. 10) or SMOOTH")
    p.add_argument(
        "--spectral-output",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="keep each pixel's spectrum (.exr output then uses the spectral EXR layout)",
    )
    p.add_argument("--seed", type=int, metavar="S", help="random seed (same seed, same pixels)")
    p.add_argument("--threads", type=int, metavar="T", help="worker threads (0: every core)")
    p.add_argument("--time-limit", type=float, metavar="SEC", help="seconds after which no new pass starts (0: none)")
    p.add_argument("--width", type=int, metavar="W", help="image width in pixels")
    p.add_argument("--height", type=int, metavar="H", help="image height in pixels")
    p.add_argument(
        "--quality",
        metavar="Q",
        help="AUTO (default: grid fitted to the scene, adaptive sampling), PREVIEW, FINAL or REFERENCE; "
        "explicit flags override what the preset chooses",
    )
    p.add_argument("--noise-threshold", type=float, metavar="DE", help="adaptive sampling: stop a pixel at this estimated dE00 (0: off)")
    p.add_argument("--passes", action="store_true", help="EXR only: also write Depth, Normal and Albedo layers")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(handler=cmd_render)


def _render_overrides(args: argparse.Namespace) -> dict:
    """RenderSettings fields given on the command line."""
    pairs = {
        "samples": args.samples,
        **_spectral_overrides(args),
        "seed": args.seed,
        "threads": args.threads,
        "time_limit": args.time_limit,
        "width": args.width,
        "height": args.height,
        "quality": None if args.quality is None else args.quality.upper(),
        "noise_threshold": args.noise_threshold,
    }
    for key in ("samples", "wavelength_count", "width", "height"):
        if pairs[key] is not None and pairs[key] <= 0:
            raise ValueError(f"--{key.replace('_count', 's').replace('_', '-')} must be positive, got {pairs[key]}")
    for key in ("seed", "threads"):
        if pairs[key] is not None and pairs[key] < 0:
            raise ValueError(f"--{key} must not be negative, got {pairs[key]}")
    if pairs["quality"] is not None and pairs["quality"] not in ("AUTO", "PREVIEW", "FINAL", "REFERENCE"):
        raise ValueError(f"--quality must be AUTO, PREVIEW, FINAL or REFERENCE, got {args.quality}")
    if pairs["noise_threshold"] is not None and not pairs["noise_threshold"] >= 0:
        raise ValueError(f"--noise-threshold must not be negative, got {pairs['noise_threshold']}")
    if pairs["time_limit"] is not None and not pairs["time_limit"] >= 0:
        raise ValueError(f"--time-limit must not be negative, got {pairs['time_limit']}")
    return {k: v for k, v in pairs.items() if v is not None}


def _choice(flag: str, value, choices) -> str | None:
    if value is None:
        return None
    if value.upper() not in choices:
        raise ValueError(f"--{flag} must be one of {', '.join(choices)}, got {value}")
    return value.upper()


def _spectral_overrides(args: argparse.Namespace) -> dict:
    """The method, direction, grid and uplift flags as RenderSettings fields (None: not given).
    ``--wavelengths`` is a count (``wavelength_count``) or a comma-separated list (``wavelengths``)."""
    from .render import DIRECTIONS, METHODS, UPLIFTS

    out = {
        "method": _choice("method", args.method, METHODS),
        "direction": _choice("direction", args.direction, DIRECTIONS),
        "dispersion_splitting": args.dispersion_splitting,
        "uplift": _choice("uplift", args.uplift, UPLIFTS),
        "spectral_output": args.spectral_output,
        "max_bounces": args.max_bounces,
        "wavelength_min": args.wavelength_min,
        "wavelength_max": args.wavelength_max,
        "wavelength_count": None,
        "wavelengths": None,
    }
    if out["max_bounces"] is not None and out["max_bounces"] < 0:
        raise ValueError(f"--max-bounces must not be negative, got {out['max_bounces']}")
    for key in ("wavelength_min", "wavelength_max"):
        if out[key] is not None and not 360.0 <= out[key] <= 830.0:
            raise ValueError(f"--{key.replace('_', '-')} must lie in 360..830 nm, got {out[key]}")
    text = args.wavelengths
    if text is not None:
        parts = [p for p in str(text).replace(" ", "").split(",") if p]
        try:
            values = [float(p) for p in parts]
        except ValueError:
            raise ValueError(f"--wavelengths must be a count or a comma-separated list of nm, got '{text}'") from None
        if len(parts) == 1 and parts[0].isdigit():
            out["wavelength_count"] = int(parts[0])
            if out["wavelength_count"] <= 0:
                raise ValueError(f"--wavelengths must be positive, got {text}")
        elif len(values) < 2 or any(b <= a for a, b in zip(values, values[1:])):
            raise ValueError(f"--wavelengths: a list must hold at least two strictly ascending wavelengths, got '{text}'")
        else:
            out["wavelengths"] = values
    return out


def _merge_size(stored: dict, overrides: dict) -> dict:
    """Flags win; one of --width/--height alone keeps the stored aspect ratio."""
    merged = {**stored, **overrides}
    if ("width" in overrides) != ("height" in overrides) and "width" in stored and "height" in stored:
        aspect = stored["width"] / stored["height"]
        if "width" in overrides:
            merged["height"] = max(1, round(overrides["width"] / aspect))
        else:
            merged["width"] = max(1, round(overrides["height"] * aspect))
    return merged


def _settings_from(values: dict):
    import dataclasses

    from .render import RenderSettings

    known = {f.name for f in dataclasses.fields(RenderSettings)}
    return RenderSettings(**{k: v for k, v in values.items() if k in known})


def _load_usd(path: str, overrides: dict):
    from . import usd

    stored = usd.read_settings(path)
    if ("width" not in stored or "height" not in stored) and not ("width" in overrides and "height" in overrides):
        # No image size anywhere: take the camera aperture's aspect (one side from the
        # flags, else the default width).
        from .render import RenderSettings

        scene = usd.read_stage(path)  # camera fitted to its own aperture: kept as is
        cam = scene.camera
        aspect = cam.sensor_width / cam.sensor_height if cam.sensor_height > 0 else 4 / 3
        if "height" in overrides:
            stored = {**stored, "height": overrides["height"], "width": max(1, round(overrides["height"] * aspect))}
        else:
            width = overrides.get("width", RenderSettings.width)
            stored = {**stored, "width": width, "height": max(1, round(width / aspect))}
        return scene, _settings_from(_merge_size(stored, overrides))
    settings = _settings_from(_merge_size(stored, overrides))
    scene = usd.read_stage(path, resolution=(settings.width, settings.height))
    return scene, settings


def _load_blend(path: str, overrides: dict):
    """Opens a .blend with bpy and exports it with the add-on's exporter."""
    import dataclasses
    import os

    try:
        import bpy
    except ImportError:
        raise ValueError(f"{path}: rendering a .blend needs the bpy module (pip install 'polychrome[blender]')") from None
    if not os.path.isfile(path):
        raise ValueError(f"{path}: no such file")
    import polychrome_blender
    from polychrome_blender.engine import settings_from_scene
    from polychrome_blender.export import export_scene
    from polychrome_blender.export.camera import render_size

    polychrome_blender.register()  # before opening, so scene.polychrome is read back
    try:
        bpy.ops.wm.open_mainfile(filepath=os.path.abspath(path))
        depsgraph = bpy.context.evaluated_depsgraph_get()
        bscene = depsgraph.scene
        width, height = render_size(bscene)
        stored = dataclasses.asdict(settings_from_scene(bscene.polychrome, width, height))
        scene, messages = export_scene(depsgraph)
        for message in messages:
            print(f"polychrome render: warning: {message}", file=sys.stderr)
        return scene, _settings_from(_merge_size(stored, overrides))
    finally:
        polychrome_blender.unregister()


def cmd_render(args: argparse.Namespace) -> int:
    """Render a scene file and write the image."""
    import time
    from pathlib import Path

    out = Path(args.output)
    if out.suffix.lower() not in (".exr", ".png"):
        raise ValueError(f"{out}: unsupported image type '{out.suffix}' (use .exr or .png)")
    overrides = _render_overrides(args)
    suffix = Path(args.scene).suffix.lower()
    if suffix in USD_SUFFIXES:
        import warnings

        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            scene, settings = _load_usd(args.scene, overrides)
        for w in caught:  # unsupported prims etc.: one line each
            print(f"polychrome render: warning: {w.message}", file=sys.stderr)
    elif suffix == ".blend":
        scene, settings = _load_blend(args.scene, overrides)
    else:
        raise ValueError(f"{args.scene}: unsupported scene type '{suffix}' (use {', '.join(USD_SUFFIXES)} or .blend)")
    from .render import render

    start = time.perf_counter()
    try:
        result = render(scene, settings, progress=not args.quiet)
    except KeyboardInterrupt:
        print("polychrome render: cancelled", file=sys.stderr)
        return EXIT_INTERRUPTED
    result.save(out, passes=args.passes)
    print(
        f"wrote {out} ({settings.width}x{settings.height}, {result.stats.get('samples_per_pixel')} samples, "
        f"{settings.method}, {result.stats.get('wavelengths')} wavelengths, quality {result.stats.get('quality')}, {time.perf_counter() - start:.1f} s)"
    )
    return EXIT_OK


# --------------------------------------------------------------------------- entry point


def main(argv=None) -> int:
    """Run the command line; returns the exit status instead of exiting."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse exits on --help, --version and usage errors
        return exc.code if isinstance(exc.code, int) else EXIT_BAD_INPUT
    handler = getattr(args, "handler", None)
    if handler is None:
        parser.print_usage(sys.stderr)
        print("polychrome: error: a command is required (see --help)", file=sys.stderr)
        return EXIT_BAD_INPUT
    try:
        return handler(args)
    except (OSError, ValueError) as exc:
        print(f"polychrome {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT


if __name__ == "__main__":
    sys.exit(main())
