"""Cost of getting a 1M-triangle Blender scene into the renderer: depsgraph export
(numpy foreach_get, polychrome_blender.export) and scene build with its BVH (the
core's `build_seconds`), release build, one process; and the viewport's re-export after
moving the object, where the Exporter keeps the mesh it read (measured in the same run).

    python bench/blender_export.py [--level 5] [--write docs/BENCHMARKS.md]

Suzanne with a level-5 Subdivision Surface modifier has 1,007,616 triangles.
"""

from __future__ import annotations

import argparse
import atexit
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bpy  # noqa: E402

import polychrome  # noqa: E402
import polychrome_blender  # noqa: E402
from polychrome_blender.export import Exporter, export_scene  # noqa: E402

from common import write_section  # noqa: E402


def main(argv=None) -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--level", type=int, default=5)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--write")
    args = parser.parse_args(argv)
    polychrome_blender.register()
    atexit.register(polychrome_blender.unregister)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_monkey_add()
    mod = bpy.context.object.modifiers.new("subsurf", "SUBSURF")
    mod.levels = mod.render_levels = args.level
    bpy.ops.object.camera_add(location=(0, -4, 0), rotation=(1.5708, 0, 0))
    bpy.context.scene.camera = bpy.context.object
    bpy.ops.object.light_add(type="POINT", location=(2, -3, 2))
    rows = []
    for _ in range(args.repeat):
        dg = bpy.context.evaluated_depsgraph_get()
        t0 = time.perf_counter()
        scene, _warnings = export_scene(dg)
        t_export = time.perf_counter() - t0
        result = polychrome.render(scene, width=8, height=8, samples=1, quality="FINAL")
        rows.append((t_export, result.stats["build_seconds"], result.stats["triangles"]))
    best = min(rows, key=lambda r: r[0] + r[1])
    # The viewport: one Exporter, told what changed by the depsgraph update (as view_update).
    exporter = Exporter()
    exporter.export(bpy.context.evaluated_depsgraph_get())

    def follow(scene, depsgraph):
        exporter.update(depsgraph)

    bpy.app.handlers.depsgraph_update_post.append(follow)
    moves = []
    for i in range(args.repeat):
        bpy.context.object.location.x = 0.01 * (i + 1)
        bpy.context.view_layer.update()
        dg = bpy.context.evaluated_depsgraph_get()
        t0 = time.perf_counter()
        exporter.export(dg)
        cached = time.perf_counter() - t0
        assert exporter.counts["meshes"] == 0
        t0 = time.perf_counter()
        export_scene(dg)
        moves.append((cached, time.perf_counter() - t0))
    bpy.app.handlers.depsgraph_update_post.remove(follow)
    cached, fresh = min(moves)
    text = "\n".join(
        [
            f"Suzanne + Subdivision Surface level {args.level}: {best[2]:,} triangles; best of {args.repeat} "
            "(the first export also evaluates the modifier).",
            "",
            "| step | seconds |",
            "| --- | ---: |",
            f"| export from the depsgraph (polychrome_blender.export) | {best[0]:.3f} |",
            f"| scene build incl. BVH (core `build_seconds`) | {best[1]:.3f} |",
            f"| total | {best[0] + best[1]:.3f} |",
            "",
            "Target (issue 6): under 1 s in total. All runs: " + ", ".join(f"{a + b:.2f} s" for a, b, _ in rows) + ".",
            "",
            "Viewport re-export after moving the object (best of the same number of moves):",
            "",
            "| export | seconds |",
            "| --- | ---: |",
            f"| `Exporter` kept by the viewport (the mesh is cached, only transforms are read) | {cached:.4f} |",
            f"| fresh export of the same depsgraph | {fresh:.3f} |",
            f"| ratio | {fresh / cached:.0f}× |",
        ]
    )
    print(text)
    if args.write:
        write_section(
            Path(args.write),
            "Blender export of 1M triangles",
            text,
            f"python bench/blender_export.py --level {args.level} --write {args.write}",
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
