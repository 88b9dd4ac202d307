#!/usr/bin/env python3
"""The paper's figure 2/3 scene built in Blender from nothing: a green sphere on a grey
floor lit by a narrow-band red light (650 nm, 20 nm wide), rendered by Polychrome.

    python examples/blender/green_sphere_red_light.py [OUT_DIR] [--samples N]

Needs the ``bpy`` module (``pip install -e .[blender]``). Writes ``spectral.png``,
``spectral.exr`` (multilayer, with Depth/Normal/Albedo) and ``scene.blend``; when the
installed polychrome has the RGB method it also renders ``rgb.png`` and prints the
CIEDE2000 difference between the two (the paper's point: RGB gets this wrong).
"""

import argparse
import atexit
from pathlib import Path

HERE = Path(__file__).resolve().parent

import bpy  # noqa: E402
import polychrome_blender  # noqa: E402
from mathutils import Vector  # noqa: E402

atexit.register(polychrome_blender.unregister)  # bpy hangs at exit if the engine stays registered


def node_material(name, idname=None, **props):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    for n in list(nt.nodes):
        if n.type != "OUTPUT_MATERIAL":
            nt.nodes.remove(n)
    node = nt.nodes.new(idname)
    for k, v in props.items():
        if k in node.inputs:
            node.inputs[k].default_value = v
        else:
            setattr(node, k, v)
    nt.links.new(node.outputs[0], nt.nodes["Material Output"].inputs["Surface"])
    return mat


def build_scene(samples):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    sc.render.engine = "POLYCHROME"
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = 320, 240, 100
    sc.view_settings.view_transform = "Standard"
    sc.polychrome.samples = samples
    sc.polychrome.wavelength_count = 41
    sc.world = None
    vl = sc.view_layers[0]
    vl.use_pass_z = vl.use_pass_normal = True

    bpy.ops.mesh.primitive_uv_sphere_add(segments=64, ring_count=32, radius=1.0, location=(0, 0, 1))
    bpy.ops.object.shade_smooth()
    bpy.context.object.data.materials.append(node_material("Green", "ShaderNodeBsdfDiffuse", Color=(0.05, 0.45, 0.08, 1.0)))
    bpy.ops.mesh.primitive_plane_add(size=20)
    bpy.context.object.data.materials.append(node_material("Floor", "ShaderNodeBsdfDiffuse", Color=(0.5, 0.5, 0.5, 1.0)))

    # the light: an emissive quad with Polychrome's Spectral Emission node (narrow band)
    bpy.ops.mesh.primitive_plane_add(size=2.0, location=(4.0, -1.5, 5.5))
    lamp = bpy.context.object
    lamp.rotation_euler = (Vector((0, 0, 1)) - lamp.location).to_track_quat("-Z", "Y").to_euler()
    lamp.data.materials.append(
        node_material("Red Light", "PolychromeSpectralEmissionNode", kind="NARROW_BAND", center=650.0, width=20.0, strength=80.0)
    )

    cam_data = bpy.data.cameras.new("Camera")
    cam_data.lens = 40
    cam = bpy.data.objects.new("Camera", cam_data)
    sc.collection.objects.link(cam)
    sc.camera = cam
    cam.location = (5.5, -5.5, 3.5)
    cam.rotation_euler = (Vector((0, 0, 0.8)) - cam.location).to_track_quat("-Z", "Y").to_euler()
    return sc


def render(sc, path, fmt):
    sc.render.image_settings.file_format = fmt
    sc.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    err = polychrome_blender.engine.PolychromeRenderEngine.last_error
    if err:
        raise SystemExit(f"render failed: {err}")
    print(f"wrote {path}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", nargs="?", default=str(HERE / "out"))
    ap.add_argument("--samples", type=int, default=64)
    args = ap.parse_args()
    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    polychrome_blender.register()
    sc = build_scene(args.samples)
    bpy.ops.wm.save_as_mainfile(filepath=str(out / "scene.blend"))
    render(sc, out / "spectral.png", "PNG")
    render(sc, out / "spectral.exr", "OPEN_EXR_MULTILAYER")
    from polychrome.render import METHODS

    if "RGB" in METHODS:
        sc.polychrome.method = "RGB"
        render(sc, out / "rgb.exr", "OPEN_EXR")
        render(sc, out / "rgb.png", "PNG")
        import numpy as np
        import OpenEXR
        from polychrome import colordiff

        def rgb(p):
            ch = OpenEXR.File(str(p), separate_channels=True).channels()
            keys = sorted(k for k in ch if k.endswith((".R", ".G", ".B")) or k in ("R", "G", "B"))
            pick = {k[-1]: ch[k].pixels for k in keys if "Combined" in k or len(k) == 1}
            return np.stack([pick["R"], pick["G"], pick["B"]], -1)

        de = colordiff.image_delta_e(rgb(out / "spectral.exr"), rgb(out / "rgb.exr"))
        print(f"RGB vs spectral: mean dE00 {de.mean():.2f}, 95th percentile {np.percentile(de, 95):.2f}")
    else:
        print("(this polychrome has no RGB method yet: only the spectral image was rendered)")
    polychrome_blender.unregister()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
