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

    return getattr(polychrome, "__version__", "unknown")


def build_parser() -> argparse.ArgumentParser:
    """The top-level parser with one subparser per subcommand."""
    parser = argparse.ArgumentParser(
        prog="polychrome", description="Polychrome spectral path tracer tools."
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    _add_diff_parser(subparsers)
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
