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


def flag(name: str) -> str:
    """The command-line flag of setting ``name``: ``--max-bounces`` for ``max_bounces``."""
    return "--" + name.replace("_", "-")


def _flag_help(spec: dict) -> tuple[str, str]:
    """(metavar, help) of a setting's flag, from the schema."""
    from .settings import describe_default

    kind = spec["kind"]
    t = kind["type"]
    metavar = {"int": "N", "float": kind.get("unit") or "X", "string": "TEXT", "float_list": "L1,L2,..."}.get(t, "")
    text = spec["help"]
    if t == "enum":
        metavar = "|".join(item["name"] for item in kind["items"])
    elif t == "float_list" and kind.get("count_setting"):
        metavar = "N|L1,L2,..."
        text += f" (a single whole number N sets {flag(kind['count_setting'])} instead)"
    if spec["applies_when"]:
        text += f"; {spec['applies_when']['value']} only"
    return metavar, f"{text} (default: {describe_default(spec)})".replace("%", "%%")


def _add_render_parser(subparsers) -> None:
    """Declare `polychrome render SCENE -o OUT [--passes] [--quiet]` and one flag per
    render setting, generated from the settings schema (``--samples``, ``--max-bounces``,
    ...): same names, help and defaults as the Python API and Blender."""
    from .settings import SETTINGS

    p = subparsers.add_parser(
        "render",
        help="render a USD stage or a .blend file to .exr/.png",
        description="Render a USD stage (.usd/.usda/.usdc/.usdz) or a .blend file (needs bpy). "
        "Settings stored in the scene are used unless a flag overrides them.",
    )
    p.add_argument("scene", metavar="SCENE", help="scene file: .usd, .usda, .usdc, .usdz or .blend")
    p.add_argument("-o", "--output", metavar="OUT", required=True, help="image to write: .exr or .png")
    p.add_argument("--passes", action="store_true", help="EXR only: also write Depth, Normal and Albedo layers")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument(
        "--frames",
        metavar="A-B",
        help="render an animation: frames A to B (or one frame), each written as it completes to OUT with the frame number "
        "in place of the last run of '#' (zero-padded to its length), else appended as 4 digits; with --scheduler the frames are tasks",
    )
    p.add_argument("--frame-step", metavar="N", type=int, default=1, help="with --frames: every N-th frame (default 1)")
    # A reader option (how the stage's geometry is tessellated), not a render setting: a
    # .blend's Subdivision Surface modifiers carry their own levels.
    p.add_argument(
        "--subdivision-level",
        metavar="N",
        type=int,
        default=None,
        help="USD stages: refine subdivision surfaces (subdivisionScheme catmullClark, USD's default, or bilinear) "
        "N times, 0 to 6; 0 renders the control cage (default 2; a prim's polychrome:subdivisionLevel wins)",
    )
    groups = {}
    for spec in SETTINGS.values():
        group = groups.get(spec["group"])
        if group is None:
            group = groups[spec["group"]] = p.add_argument_group(f"{spec['group'].lower()} settings")
        metavar, text = _flag_help(spec)
        if spec["kind"]["type"] == "bool":
            group.add_argument(flag(spec["name"]), dest=spec["name"], action=argparse.BooleanOptionalAction, default=None, help=text)
        else:
            # Values are checked against the schema in _render_overrides, so a bad one is
            # one line naming the flag; unset flags stay None (the scene's value is kept).
            group.add_argument(flag(spec["name"]), dest=spec["name"], metavar=metavar, help=text)
    p.set_defaults(handler=cmd_render)


def _flag_value(spec: dict, text):
    """A flag's text as the setting's value (before the schema's range check)."""
    t = spec["kind"]["type"]
    name = flag(spec["name"])
    if t in ("bool", "enum", "string"):
        return text
    try:
        if t == "int":
            return int(text)
        if t == "float":
            return float(text)
        parts = [x for x in str(text).replace(" ", "").split(",") if x]
        return [float(x) for x in parts]
    except ValueError:
        kind = {"int": "a whole number", "float": "a number"}.get(t, "a comma-separated list of numbers")
        raise ValueError(f"{name} must be {kind}, got '{text}'") from None


def _render_overrides(args: argparse.Namespace) -> dict:
    """The RenderSettings fields given on the command line, checked against the schema
    (ValueError naming the flag)."""
    from .settings import SETTINGS, check

    out = {}
    for name, spec in SETTINGS.items():
        text = getattr(args, name, None)
        if text is None:
            continue
        target, value = name, _flag_value(spec, text)
        count = spec["kind"].get("count_setting")
        if count and str(text).strip().isdigit():  # --wavelengths 41: a count
            target, value = count, int(text)
        try:
            out[target] = check(target, value)
        except ValueError as e:
            raise ValueError(f"{flag(name)}: {str(e).split(': ', 1)[1]}") from None
        # A list with a count setting is a wavelength grid: strictly ascending.
        grid = spec["kind"]["type"] == "float_list" and spec["kind"].get("count_setting")
        if target == name and grid and any(b <= a for a, b in zip(out[name], out[name][1:])):
            raise ValueError(f"{flag(name)}: a list must be strictly ascending, got '{text}'")
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
    from .render import RenderSettings
    from .settings import SETTINGS

    return RenderSettings(**{k: v for k, v in values.items() if k in SETTINGS})


def _load_usd(path: str, overrides: dict, time=None, subdivision_level=None):
    from . import usd

    stored = usd.read_settings(path)
    if ("width" not in stored or "height" not in stored) and not ("width" in overrides and "height" in overrides):
        # No image size anywhere: take the camera aperture's aspect (one side from the
        # flags, else the default width).
        from .render import RenderSettings

        scene = usd.read_stage(path, time=time, subdivision_level=subdivision_level)  # camera fitted to its own aperture: kept as is
        cam = scene.camera
        aspect = cam.sensor_width / cam.sensor_height if cam.sensor_height > 0 else 4 / 3
        if "height" in overrides:
            stored = {**stored, "height": overrides["height"], "width": max(1, round(overrides["height"] * aspect))}
        else:
            width = overrides.get("width", RenderSettings.width)
            stored = {**stored, "width": width, "height": max(1, round(width / aspect))}
        return scene, _settings_from(_merge_size(stored, overrides))
    settings = _settings_from(_merge_size(stored, overrides))
    scene = usd.read_stage(path, resolution=(settings.width, settings.height), time=time, subdivision_level=subdivision_level)
    return scene, settings


def _load_blend(path: str, overrides: dict):
    """Opens a .blend with bpy and exports it with the add-on's exporter."""
    return next(_blend_frames(path, overrides, [None]))


def _blend_frames(path: str, overrides: dict, frames):
    """(scene, settings) of each frame of a .blend (None: the current frame), opened once."""
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
        for frame in frames:
            if frame is not None:
                bpy.context.scene.frame_set(frame)
            depsgraph = bpy.context.evaluated_depsgraph_get()
            bscene = depsgraph.scene
            width, height = render_size(bscene)
            stored = dataclasses.asdict(settings_from_scene(bscene.polychrome, width, height))
            scene, messages = export_scene(depsgraph)
            for message in messages:
                print(f"polychrome render: warning: {message}", file=sys.stderr)
            yield scene, _settings_from(_merge_size(stored, overrides))
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
    level = getattr(args, "subdivision_level", None)
    if level is not None and not 0 <= level <= 6:
        raise ValueError(f"--subdivision-level: must be from 0 to 6, got {level}")
    if level is not None and suffix not in USD_SUFFIXES:
        raise ValueError("--subdivision-level: USD stages only (a .blend's Subdivision Surface modifiers have their own levels)")
    if args.frames is not None:
        if overrides.get("checkpoint"):
            raise ValueError("--checkpoint: not with --frames (each frame is written when done; --resume skips those)")
        return _render_frames(args, out, overrides, suffix)
    if overrides.get("resume") and not overrides.get("checkpoint"):
        overrides["checkpoint"] = f"{out}.checkpoint.npz"  # beside the output
    if suffix in USD_SUFFIXES:
        import warnings

        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            scene, settings = _load_usd(args.scene, overrides, subdivision_level=level)
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
    except KeyboardInterrupt as e:
        partial = getattr(e, "result", None)  # a distributed render keeps what finished
        if partial is None:
            print("polychrome render: cancelled", file=sys.stderr)
            return EXIT_INTERRUPTED
        partial.save(out, passes=args.passes)
        print(
            f"polychrome render: cancelled; wrote the finished part to {out} ({partial.stats.get('samples_per_pixel')} samples, marked partial)",
            file=sys.stderr,
        )
        return EXIT_INTERRUPTED
    result.save(out, passes=args.passes)
    if settings.checkpoint and not result.partial:  # the image is written: nothing left to resume
        Path(settings.checkpoint).unlink(missing_ok=True)
    resumed = result.stats.get("checkpoint", {}).get("resumed_samples", 0)
    if resumed:
        print(f"resumed from {settings.checkpoint} ({resumed} pixel samples)")
    print(
        f"wrote {out} ({settings.width}x{settings.height}, {result.stats.get('samples_per_pixel')} samples, "
        f"{settings.method}, {result.stats.get('wavelengths')} wavelengths, quality {result.stats.get('quality')}, {time.perf_counter() - start:.1f} s)"
    )
    return EXIT_OK


def _complete_image(path) -> bool:
    """An image written by a render that was not cut short."""
    from .imageio import read_metadata

    try:
        return read_metadata(path).get("polychrome:partial") == "0"
    except (OSError, ValueError):
        return False


def _render_frames(args: argparse.Namespace, out, overrides: dict, suffix: str) -> int:
    """--frames: every frame rendered (locally, or as one task each on --scheduler) and
    written as it completes."""
    import warnings

    from .distributed import frame_path, parse_frames
    from .render import render

    frames = parse_frames(args.frames, args.frame_step)
    if overrides.pop("resume", False):  # frames already written whole are not rendered again
        frames = [f for f in frames if not _complete_image(frame_path(str(out), f))]
        if not frames:
            print("rendered 0 frame(s): every frame is written already")
            return EXIT_OK
    if suffix in USD_SUFFIXES:

        def scenes():
            for frame in frames:
                with warnings.catch_warnings(record=True) as caught:
                    warnings.simplefilter("always")
                    loaded = _load_usd(args.scene, overrides, time=frame, subdivision_level=args.subdivision_level)
                for w in caught:
                    print(f"polychrome render: warning: frame {frame}: {w.message}", file=sys.stderr)
                yield loaded

    elif suffix == ".blend":
        scenes = lambda: _blend_frames(args.scene, overrides, frames)
    else:
        raise ValueError(f"{args.scene}: unsupported scene type '{suffix}' (use {', '.join(USD_SUFFIXES)} or .blend)")

    def write(frame, result):
        path = frame_path(str(out), frame)
        result.save(path, passes=args.passes)
        print(f"wrote {path} (frame {frame}, {result.stats.get('samples_per_pixel')} samples)")

    source = scenes()
    first_scene, first_settings = next(source)
    scheduler = first_settings.scheduler
    try:
        if scheduler:
            from .distributed import render_frames

            pending = {"first": (first_scene, first_settings)}

            def describe(frame):
                scene, settings = pending.pop("first", None) or next(source)
                desc, buffers = scene.description()
                return desc, buffers, settings

            done = render_frames(frames, describe, scheduler, on_frame=write)
        else:
            done = []
            loaded = (first_scene, first_settings)
            for frame in frames:
                scene, settings = loaded if frame == frames[0] else next(source)
                write(frame, render(scene, settings, progress=not args.quiet))
                done.append(frame)
    except KeyboardInterrupt:
        print("polychrome render: cancelled; the frames written so far are complete", file=sys.stderr)
        return EXIT_INTERRUPTED
    finally:
        source.close()
    print(f"rendered {len(done)} frame(s)")
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
