"""Cost of emission that varies over a surface (docs/shading.md, "Emission per hit"):
scene build and render time of Blender's material preview, whose preview scene has
textured emitters, and of one big textured emitter mesh.

    python bench/emitters.py [--triangles 100000] [--write docs/BENCHMARKS.md] [--label NAME]

Runs bpy in this process (it needs numpy < 2) with the add-on registered; use a release
build of the core (`cargo build --release -p polychrome-python` and copy
target/release/lib_core.so to python/polychrome/_core.abi3.so).

1. Material preview: `Material.asset_generate_preview()` of a red diffuse material, as
   tests/blender/test_viewport.py does (16 samples, its time limit
   viewport.MATERIAL_PREVIEW_TIME_LIMIT): wall time, the engine's export, the core's scene
   build and render time, samples reached, lights, and the emitters of the preview scene.
2. A plane of about `--triangles` triangles with a 256×256 image texture into an Emission
   shader (strength 5) over a diffuse floor, 64×64 pixels, 16 samples: build and render.
"""

from __future__ import annotations

import argparse
import atexit
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import write_section  # noqa: E402

import bpy  # noqa: E402

import polychrome_blender  # noqa: E402

atexit.register(polychrome_blender.unregister)
polychrome_blender.register()
Engine = polychrome_blender.engine.PolychromeRenderEngine


def empty_material(name):
    """A node material with only its Material Output."""
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nt = m.node_tree
    for n in list(nt.nodes):
        if n.type != "OUTPUT_MATERIAL":
            nt.nodes.remove(n)
    return m, nt


def diffuse(name, rgb):
    m, nt = empty_material(name)
    d = nt.nodes.new("ShaderNodeBsdfDiffuse")
    d.inputs["Color"].default_value = (*rgb, 1.0)
    nt.links.new(d.outputs["BSDF"], nt.nodes["Material Output"].inputs["Surface"])
    return m


def stats_row(label, wall, st):
    return (
        f"| {label} | {wall:.2f} | {st.get('export_seconds', 0):.2f} | {st.get('build_seconds', 0):.3f} | "
        f"{st.get('seconds', 0) - st.get('build_seconds', 0):.2f} | {st.get('samples_per_pixel')} | "
        f"{st.get('lights')} | {st.get('triangles')} |"
    )


def preview():
    bpy.ops.wm.read_factory_settings()
    bpy.context.scene.render.engine = "POLYCHROME"
    m = diffuse("Red", (0.8, 0.05, 0.05))
    Engine.last_stats = None
    t0 = time.perf_counter()
    m.asset_generate_preview()
    wall = time.perf_counter() - t0
    return wall, dict(Engine.last_stats or {})


def big_emitter(triangles):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    sc.render.engine = "POLYCHROME"
    sc.render.resolution_x = sc.render.resolution_y = 64
    sc.render.resolution_percentage = 100
    sc.polychrome.samples = 16
    side = max(1, int(round((triangles / 2) ** 0.5)))
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=side + 1, y_subdivisions=side + 1, size=2.0, location=(0, 0, 2))
    lamp = bpy.context.active_object
    lamp.rotation_euler = (np.pi, 0, 0)  # facing down
    img = bpy.data.images.new("emit", 256, 256, float_buffer=True)
    rng = np.random.default_rng(1)
    px = np.ones((256, 256, 4), np.float32)
    px[..., :3] = rng.random((256, 256, 3), dtype=np.float32)
    img.pixels.foreach_set(px.ravel())
    m, nt = empty_material("Textured lamp")
    tex = nt.nodes.new("ShaderNodeTexImage")
    tex.image = img
    em = nt.nodes.new("ShaderNodeEmission")
    em.inputs["Strength"].default_value = 5.0
    nt.links.new(tex.outputs["Color"], em.inputs["Color"])
    nt.links.new(em.outputs["Emission"], nt.nodes["Material Output"].inputs["Surface"])
    lamp.data.materials.append(m)
    bpy.ops.mesh.primitive_plane_add(size=8.0, location=(0, 0, 0))
    bpy.context.active_object.data.materials.append(diffuse("Floor", (0.8, 0.8, 0.8)))
    cd = bpy.data.cameras.new("Camera")
    co = bpy.data.objects.new("Camera", cd)
    sc.collection.objects.link(co)
    sc.camera = co
    co.location = (0, -6, 1.0)
    co.rotation_euler = (np.radians(85), 0, 0)
    sc.render.filepath = "/tmp/polychrome_bench_emitters.png"
    t0 = time.perf_counter()
    bpy.ops.render.render(write_still=False)
    wall = time.perf_counter() - t0
    return wall, dict(Engine.last_stats or {}), len(lamp.data.loop_triangles) or 2 * side * side


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--triangles", type=int, default=100_000)
    ap.add_argument("--label", default="this build")
    ap.add_argument("--write", type=Path)
    args = ap.parse_args()
    rows = []
    wall, st = preview()
    rows.append(stats_row(f"material preview ({args.label})", wall, st))
    try:
        wall, st, tris = big_emitter(args.triangles)
        rows.append(stats_row(f"textured emitter, {tris} triangles ({args.label})", wall, st))
    except RuntimeError as e:  # a build without per-hit emission refuses the textured lamp
        rows.append(f"| textured emitter ({args.label}) | failed: {e} |")
    head = (
        "| scene | wall s | export s | core build s | core render s | spp | lights | triangles |\n"
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"
    )
    table = head + "\n" + "\n".join(rows)
    print(table)
    if args.write:
        write_section(
            args.write,
            f"Varying emitters ({args.label})",
            table,
            "python bench/emitters.py" + (f" --label '{args.label}'" if args.label != "this build" else ""),
        )
    polychrome_blender.unregister()


if __name__ == "__main__":
    main()
