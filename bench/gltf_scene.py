"""A textured glTF asset as a Polychrome scene, the way a Blender user gets one: Blender's
own glTF importer (`bpy.ops.import_scene.gltf`) reads the Khronos sample *Box Textured*
(tests/data/gltf/BoxTextured, CC-BY 4.0, see its README.md), and the add-on's exporter
(`polychrome_blender.export.export_scene`) turns the evaluated depsgraph into a
`polychrome.Scene` — the Principled BSDF with an Image Texture on Base Color that the
importer builds included. Around it: a grey floor, a sun and a dim sky-grey world.

    python bench/gltf_scene.py [--out box.png] [--samples 64] [--size 96]

renders it once (a look at the scene). `build_scene()` is what bench/denoise.py
(`--scene gltf`) uses. Needs `bpy` (numpy < 2) in the same venv; the add-on is
registered for the export and unregistered at exit (bpy hangs at exit otherwise).
"""

from __future__ import annotations

import argparse
import atexit
import math
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
GLTF = ROOT / "tests" / "data" / "gltf" / "BoxTextured" / "BoxTextured.gltf"
WHAT = "Khronos glTF sample Box Textured (tests/data/gltf, Blender's glTF importer → the add-on's exporter, bench/gltf_scene.py)"

_registered = False


def _register():
    global _registered
    import polychrome_blender

    if not _registered:
        polychrome_blender.register()
        atexit.register(polychrome_blender.unregister)
        _registered = True


def add_floor_sun_world(sc, size: float, location) -> None:
    """What every glTF bench scene is lit by (this file and bench/gltf_vs_cycles.py): a
    grey rough floor plane of `size` at `location`, a sun of 3 W/m² (10° wide) from the
    upper left and a dim sky-grey world (soft shadows, indirect light on the floor)."""
    import bpy

    bpy.ops.mesh.primitive_plane_add(size=size, location=tuple(location))
    floor = bpy.context.object
    mat = bpy.data.materials.new("Floor")
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.5, 0.5, 0.5, 1.0)
    bsdf.inputs["Roughness"].default_value = 1.0
    floor.data.materials.append(mat)
    sun = bpy.data.lights.new("Sun", "SUN")
    sun.energy, sun.angle = 3.0, math.radians(10)
    so = bpy.data.objects.new("Sun", sun)
    sc.collection.objects.link(so)
    so.rotation_euler = (math.radians(50), 0.0, math.radians(-35))
    world = bpy.data.worlds.new("World")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.25, 0.27, 0.3, 1.0)
    sc.world = world


def build_scene(path: Path = GLTF):
    """(scene, warnings): the glTF file imported by Blender and exported by the add-on."""
    import bpy
    from mathutils import Vector

    _register()
    from polychrome_blender.export import export_scene

    if not path.is_file():
        raise FileNotFoundError(f"glTF asset '{path}' not found")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    sc.render.engine = "POLYCHROME"
    bpy.ops.import_scene.gltf(filepath=str(path))
    imported = [o for o in sc.objects if o.type == "MESH"]
    if not imported:
        raise ValueError(f"glTF asset '{path}': Blender's importer made no mesh")
    for o in imported:  # a quarter turn about z so three faces show
        o.rotation_mode = "XYZ"
        o.rotation_euler.z += math.radians(25)
    add_floor_sun_world(sc, size=8.0, location=(0.0, 0.0, -0.5))  # the unit cube's faces at ±0.5
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    sc.collection.objects.link(cam)
    cam.location = (2.6, -2.6, 1.9)
    cam.rotation_euler = (Vector((0, 0, -0.05)) - cam.location).to_track_quat("-Z", "Y").to_euler()
    cam.data.lens = 45
    sc.camera = cam
    return export_scene(bpy.context.evaluated_depsgraph_get())


def main() -> int:
    import polychrome as pc

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("gltf_box.png"))
    ap.add_argument("--samples", type=int, default=64)
    ap.add_argument("--size", type=int, default=96)
    args = ap.parse_args()
    scene, warnings = build_scene()
    for w in warnings:
        print("warning:", w)
    r = pc.render(scene, width=args.size, height=args.size, samples=args.samples, quality="FINAL")
    r.save(str(args.out))
    print(f"{args.out}: {r.stats['wall_seconds']:.2f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
