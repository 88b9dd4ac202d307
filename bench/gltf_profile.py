"""One glTF sample model rendered by Polychrome only, through Blender's importer and the
add-on exactly as bench/gltf_vs_cycles.py sets it up: a target for profilers.

    valgrind --tool=callgrind python bench/gltf_profile.py BoxTextured --size 48 --samples 8
    perf record -g python bench/gltf_profile.py BoxTextured

Prints the wall time and the engine's stats (threads: 1, so instruction counts do not
depend on scheduling). Needs `bpy` (numpy < 2), OpenEXR in the venv.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import gltf_vs_cycles  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("model", help="a model name of gltf_vs_cycles.MODELS (BoxTextured is vendored)")
    ap.add_argument("--size", type=int, default=48)
    ap.add_argument("--samples", type=int, default=8)
    ap.add_argument("--cache", type=Path, default=gltf_vs_cycles.DEFAULT_CACHE)
    args = ap.parse_args()
    import polychrome_blender

    path = gltf_vs_cycles.find_model(args.model, args.cache)
    if path is None:
        print(f"model {args.model} not found (vendored or in {args.cache}; see gltf_vs_cycles.py --fetch)")
        return 1
    polychrome_blender.register()
    try:
        sc = gltf_vs_cycles.setup_scene(path, args.size, args.samples)
        sc.polychrome.threads = 1
        out = Path(tempfile.mkdtemp(prefix="gltf_profile_")) / "poly.exr"
        _, seconds = gltf_vs_cycles.render(sc, "POLYCHROME", out)
        engine = polychrome_blender.engine.PolychromeRenderEngine
        if engine.last_error:
            print(f"render failed: {engine.last_error}")
            return 1
        stats = {k: v for k, v in engine.last_stats.items() if k not in ("warnings", "auto_reason")}
        print(f"{args.model}: {seconds:.2f} s wall, {stats}")
    finally:
        polychrome_blender.unregister()
    return 0


if __name__ == "__main__":
    sys.exit(main())
