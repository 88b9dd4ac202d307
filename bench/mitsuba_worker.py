"""Runs inside Mitsuba 3's own virtual environment (numpy 2; see bench/renderers.py):
renders the scene written by bench/renderers.py with one variant at several sample
counts and writes linear-sRGB EXRs plus timings as JSON on stdout.

    /tmp/mitsuba-venv/bin/python bench/mitsuba_worker.py SCENE.json VARIANT OUT_DIR SPP[,SPP...]
"""

import json
import os
import sys
import time
from pathlib import Path


def main() -> int:
    scene_path, variant, out_dir, spps = sys.argv[1], sys.argv[2], Path(sys.argv[3]), [int(s) for s in sys.argv[4].split(",")]
    os.environ.setdefault("DRJIT_CACHE_DIR", str(out_dir / "drjit-cache"))
    import drjit as dr
    import mitsuba as mi

    mi.set_variant(variant)
    dr.set_thread_count(int(os.environ.get("THREADS", "2")))
    s = json.loads(Path(scene_path).read_text())
    rgb = variant.endswith("_rgb")

    def spectrum(entry, emitter):
        if rgb:
            return {
                "type": "rgb",
                "value": mi.spectrum_list_to_srgb(entry["wavelengths"], entry["values"], bounded=not emitter, d65=not emitter),
            }
        return {
            "type": "irregular",
            "wavelengths": ", ".join(f"{x:g}" for x in entry["wavelengths"]),
            "values": ", ".join(f"{x:g}" for x in entry["values"]),
        }

    d = {"type": "scene", "integrator": {"type": "path", "max_depth": s["max_depth"]}}
    cam = s["camera"]
    d["sensor"] = {
        "type": "perspective",
        "fov": cam["fov_x"],
        "fov_axis": "x",
        "to_world": mi.ScalarTransform4f.look_at(origin=cam["origin"], target=cam["target"], up=cam["up"]),
        "film": {"type": "hdrfilm", "width": s["size"], "height": s["size"], "rfilter": {"type": "box"}, "pixel_format": "rgb"},
        "sampler": {"type": "independent", "sample_count": 1},
    }
    for i, m in enumerate(s["meshes"]):
        mat = s["materials"][m["material"]]
        shape = {"type": "ply", "filename": m["ply"], "face_normals": True}
        if "emission" in mat:
            shape["emitter"] = {"type": "area", "radiance": spectrum(mat["emission"], True)}
            shape["bsdf"] = {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.0, 0.0, 0.0]}}
        else:
            shape["bsdf"] = {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": spectrum(mat["reflectance"], False)}}
        d[f"shape{i}"] = shape
    scene = mi.load_dict(d)
    results = []
    for spp in spps:
        t = time.perf_counter()
        img = mi.render(scene, spp=spp, seed=spp)
        dr.eval(img)
        dr.sync_thread()  # the LLVM variants launch kernels asynchronously: wait for the render
        sec = time.perf_counter() - t
        path = out_dir / f"{variant}_{spp}.exr"
        dr.set_thread_count(int(os.environ.get("THREADS", "2")))
        mi.Bitmap(img).write(str(path))
        results.append({"spp": spp, "seconds": sec, "exr": str(path)})
        print(json.dumps(results[-1]), file=sys.stderr, flush=True)
    print(json.dumps(results))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
