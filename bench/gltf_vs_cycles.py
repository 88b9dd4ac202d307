"""Khronos glTF 2.0 sample models, Polychrome against Cycles CPU (issue 12's acceptance).

Each model is imported with Blender's own glTF importer (`bpy.ops.import_scene.gltf`),
framed by a camera from its bounding box, lit by the same sun and grey world and given a
grey floor; then rendered by Cycles CPU and by Polychrome through the add-on (same
`bpy` scene, EXR, Standard view). The table: model, mean CIEDE2000 over 4 × 4 blocks
(colour-science, Rec.709 linear, white = Cycles' 99th-percentile Y), 95th percentile,
the add-on's warnings, the two render times.

    python bench/gltf_vs_cycles.py [--models A,B] [--size 128] [--samples 64]
        [--cache ~/.cache/polychrome/gltf] [--fetch [--source DIR]] [--out DIR] [--images DIR]

Models are looked up as tests/data/gltf/<Name>/ (only BoxTextured is vendored) or
CACHE/<Name>/<Name>.gltf|.glb (CACHE: --cache, else $POLYCHROME_GLTF_CACHE, else
~/.cache/polychrome/gltf). They are never committed. `--fetch` fills the cache with the
variant MODELS names for each model (Models/<Name>/<variant>/ of
KhronosGroup/glTF-Sample-Assets): from GitHub (raw.githubusercontent.com, the .glb, or the
.gltf and the buffers and images it names), or with `--source DIR` from a local clone of
that repository (a work tree, or a bare git directory). A model still missing is listed as
such. `--images DIR` writes DIR/<Name>.png: Cycles left, Polychrome right, sRGB-encoded
(docs/images/gltf holds the table's). Needs `bpy` (numpy < 2), OpenEXR and Pillow in the venv.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
VENDORED = ROOT / "tests" / "data" / "gltf"
DEFAULT_CACHE = Path(os.environ.get("POLYCHROME_GLTF_CACHE", Path.home() / ".cache" / "polychrome" / "gltf"))
# Model → the KhronosGroup/glTF-Sample-Assets variant `--fetch` takes (glTF-Binary where the
# repository has one whole, else glTF: a .gltf with its .bin and images beside it). Chosen to
# cover issue 12's list: base colour / metallic-roughness / normal / occlusion / emissive maps,
# alpha blend and mask, vertex colours, texture transforms and coordinates, clearcoat, sheen,
# transmission, specular, anisotropy (iridescence: Blender 4.5's importer refuses
# KHR_materials_iridescence, which IridescenceSuzanne and IridescenceLamp require).
MODELS = {
    "BoxTextured": "glTF-Embedded",  # vendored in tests/data/gltf
    "BoxVertexColors": "glTF-Binary",
    "VertexColorTest": "glTF-Binary",
    "TextureTransformTest": "glTF",
    "TextureCoordinateTest": "glTF-Binary",
    "AlphaBlendModeTest": "glTF-Binary",
    "MetalRoughSpheresNoTextures": "glTF-Binary",
    "NormalTangentTest": "glTF-Binary",
    "NormalTangentMirrorTest": "glTF-Binary",  # mirrored UVs: the tangent's sign
    "EmissiveStrengthTest": "glTF-Binary",
    "DamagedHelmet": "glTF-Binary",
    "ClearCoatTest": "glTF-Binary",
    "SheenCloth": "glTF",
    "TransmissionTest": "glTF-Binary",
    "SpecularTest": "glTF-Binary",
    "AnisotropyStrengthTest": "glTF-Binary",
    "AnisotropyRotationTest": "glTF-Binary",  # an anisotropy texture: the importer's Tangent node (UV map)
}
RAW = "https://raw.githubusercontent.com/KhronosGroup/glTF-Sample-Assets/main/Models"


def find_model(name: str, cache: Path) -> Path | None:
    for d in (VENDORED / name, cache / name):
        for ext in (".gltf", ".glb"):
            p = d / f"{name}{ext}"
            if p.is_file():
                return p
    return None


def _fetch_files(name: str, variant: str, source: str | None) -> dict[str, bytes]:
    """{file name: bytes} of Models/<name>/<variant>/ from a local glTF-Sample-Assets clone
    (a work tree or a bare git directory) or, with `source` None, from GitHub."""
    import json
    import subprocess
    import urllib.parse
    import urllib.request

    sub = f"Models/{name}/{variant}/"
    if source is not None:
        src = Path(source).expanduser()
        if (src / sub).is_dir():  # a checked-out work tree
            return {f.name: f.read_bytes() for f in (src / sub).iterdir() if f.is_file()}
        git = ["git", "--git-dir", str(src / ".git" if (src / ".git").exists() else src)]
        names = subprocess.run([*git, "ls-tree", "--name-only", "HEAD", sub], capture_output=True, text=True, check=True)
        files = {}
        for path in names.stdout.split():
            blob = subprocess.run([*git, "cat-file", "blob", f"HEAD:{path}"], capture_output=True)
            if blob.returncode != 0:
                raise FileNotFoundError(f"{name}: '{path}' is listed in {src} but its content is missing")
            files[Path(path).name] = blob.stdout
        return files

    def get(fname):
        url = f"{RAW}/{name}/{variant}/{urllib.parse.quote(fname)}"
        with urllib.request.urlopen(url, timeout=120) as r:  # noqa: S310 - a fixed https host
            return r.read()

    main = f"{name}.glb" if variant == "glTF-Binary" else f"{name}.gltf"
    files = {main: get(main)}
    if main.endswith(".gltf"):  # the buffers and images a .gltf names beside it
        doc = json.loads(files[main])
        for item in doc.get("buffers", []) + doc.get("images", []):
            uri = item.get("uri")
            if uri and not uri.startswith("data:"):
                files[urllib.parse.unquote(uri)] = get(urllib.parse.unquote(uri))
    return files


def fetch_model(name: str, cache: Path, source: str | None = None) -> Path:
    """Puts model `name` into CACHE/<name>/ (see the module docstring) and returns its path."""
    have = find_model(name, cache)
    if have is not None:
        return have
    if name not in MODELS:
        raise KeyError(f"glTF model '{name}': not in bench/gltf_vs_cycles.py's MODELS, so no variant to fetch")
    files = _fetch_files(name, MODELS[name], source)
    if not any(f in files for f in (f"{name}.gltf", f"{name}.glb")):
        raise FileNotFoundError(f"glTF model '{name}': no {name}.gltf/.glb in {MODELS[name]} of {source or RAW}")
    d = cache / name
    d.mkdir(parents=True, exist_ok=True)
    for fname, data in files.items():
        (d / fname).write_bytes(data)
    return find_model(name, cache)


def setup_scene(path: Path, size: int, samples: int):
    """Imports `path` into an empty scene, adds floor, sun, world and a framing camera."""
    import bpy
    from gltf_scene import add_floor_sun_world
    from mathutils import Vector

    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    sc.render.resolution_x = sc.render.resolution_y = size
    sc.render.resolution_percentage = 100
    sc.view_settings.view_transform = "Standard"
    sc.render.image_settings.file_format = "OPEN_EXR"
    bpy.ops.import_scene.gltf(filepath=str(path))
    meshes = [o for o in sc.objects if o.type == "MESH"]
    if not meshes:
        raise ValueError(f"glTF asset '{path}': Blender's importer made no mesh")
    bpy.context.view_layer.update()
    pts = [o.matrix_world @ Vector(c) for o in meshes for c in o.bound_box]
    lo = Vector([min(p[i] for p in pts) for i in range(3)])
    hi = Vector([max(p[i] for p in pts) for i in range(3)])
    centre, radius = (lo + hi) / 2, max((hi - lo).length / 2, 1e-3)
    add_floor_sun_world(sc, size=radius * 20, location=(centre.x, centre.y, lo.z))
    cd = bpy.data.cameras.new("Camera")
    cd.lens = 50.0
    cam = bpy.data.objects.new("Camera", cd)
    sc.collection.objects.link(cam)
    fov = 2 * math.atan(cd.sensor_width / (2 * cd.lens))
    dist = 1.15 * radius / math.sin(fov / 2)
    d = Vector((1.0, -1.0, 0.6)).normalized()
    cam.location = centre + d * dist
    cam.rotation_euler = (centre - cam.location).to_track_quat("-Z", "Y").to_euler()
    cd.clip_start, cd.clip_end = dist * 1e-3, dist * 100
    sc.camera = cam
    engine_settings(sc, samples)
    return sc


def engine_settings(sc, samples: int, bounces: int | None = None) -> None:
    """Cycles CPU as the reference (no denoising, adaptivity, clamping, a near-box pixel
    filter) and Polychrome at `samples`; with `bounces`, that for every Cycles ray type and
    Polychrome's max_bounces (else each engine's default)."""
    c = sc.cycles
    c.device, c.samples = "CPU", samples
    c.use_denoising = c.use_adaptive_sampling = False
    c.filter_width = 0.01
    c.sample_clamp_direct = c.sample_clamp_indirect = 0.0
    sc.polychrome.samples = samples
    if bounces is not None:
        c.max_bounces = c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = bounces
        c.blur_glossy = 0.0
        sc.polychrome.max_bounces = bounces


def render(sc, engine: str, out: Path):
    import bpy
    import numpy as np
    import OpenEXR

    sc.render.engine = engine
    sc.render.filepath = str(out)
    t = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    dt = time.perf_counter() - t
    ch = {k: np.asarray(v.pixels, np.float64) for k, v in OpenEXR.File(str(out), separate_channels=True).channels().items()}
    h, w = sc.render.resolution_y, sc.render.resolution_x
    return np.stack([ch[k] for k in "RGB"], -1).reshape(h, w, 3), dt


def delta_e(ref, img):
    """Mean and 95th percentile CIEDE2000 over 4 × 4 blocks (white: ref's 99th-percentile Y)."""
    import colour
    import numpy as np

    h, w, _ = ref.shape
    rec709 = colour.RGB_COLOURSPACES["ITU-R BT.709"]
    blocks = [x.reshape(h // 4, 4, w // 4, 4, 3).mean(axis=(1, 3)) for x in (ref, img)]
    xyz = [colour.RGB_to_XYZ(x, rec709, apply_cctf_decoding=False) for x in blocks]
    white = max(float(np.percentile(xyz[0][..., 1], 99)), 1e-6)
    lab = [colour.XYZ_to_Lab(x / white, rec709.whitepoint) for x in xyz]
    d = colour.delta_E(lab[0], lab[1], method="CIE 2000")
    return float(np.mean(d)), float(np.percentile(d, 95))


def compare(path: Path, size: int = 128, samples: int = 64, tmp: Path | None = None) -> dict:
    """One model: {'de', 'p95', 'warnings', 'error', 't_cycles', 't_poly'} and the two linear
    images {'cycles', 'polychrome'} (numpy arrays)."""
    import polychrome_blender

    engine = polychrome_blender.engine.PolychromeRenderEngine
    tmp = Path(tmp or tempfile.mkdtemp(prefix="gltf_vs_cycles_"))
    sc = setup_scene(path, size, samples)
    cyc, t_c = render(sc, "CYCLES", tmp / f"{path.stem}_cycles.exr")
    poly, t_p = render(sc, "POLYCHROME", tmp / f"{path.stem}_poly.exr")
    de, p95 = delta_e(cyc, poly)
    return {
        "cycles": cyc,
        "polychrome": poly,
        "de": de,
        "p95": p95,
        "warnings": list(engine.last_warnings),
        "error": engine.last_error,
        "t_cycles": t_c,
        "t_poly": t_p,
    }


def side_by_side_png(path: Path, *images) -> None:
    """Linear Rec.709 images side by side, left to right, sRGB-encoded 8-bit, 2-pixel gaps."""
    import numpy as np
    from PIL import Image

    def srgb(x):
        x = np.clip(x, 0.0, 1.0)
        return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)

    gap = np.ones((images[0].shape[0], 2, 3))
    parts = [srgb(images[0])]
    for img in images[1:]:
        parts += [gap, srgb(img)]
    rgb = np.concatenate(parts, 1)
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray((rgb * 255 + 0.5).astype(np.uint8)).save(path)


def summarise(warnings: list[str]) -> str:
    """The add-on's warnings without the material and node they name, each once with a
    count of the materials that gave it (the table's column; the full text is printed)."""
    import re
    from collections import Counter

    # Numbers too (one "Anisotropic … is not supported" for a sweep of values).
    c = Counter(re.sub(r"-?\d+(\.\d+)?", "…", re.sub(r"^material '[^']*': (node '[^']*' \([^)]*\): )?", "", w)) for w in warnings)
    return "; ".join(f"{w} (×{n})" if n > 1 else w for w, n in c.items())


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", default=",".join(MODELS))
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--samples", type=int, default=64)
    ap.add_argument("--cache", type=Path, default=DEFAULT_CACHE)
    ap.add_argument("--fetch", action="store_true", help="fetch models missing from the cache (see --source)")
    ap.add_argument("--source", default=None, help="a local glTF-Sample-Assets clone to fetch from (default: GitHub)")
    ap.add_argument("--out", type=Path, default=None, help="directory for the EXRs (default: a temp dir)")
    ap.add_argument("--images", type=Path, default=None, help="directory for side-by-side PNGs (Cycles | Polychrome)")
    args = ap.parse_args()
    import atexit

    import polychrome_blender

    polychrome_blender.register()
    atexit.register(polychrome_blender.unregister)
    rows = []
    for name in args.models.split(","):
        p = find_model(name, args.cache)
        if p is None and args.fetch:
            try:
                p = fetch_model(name, args.cache, args.source)
            except Exception as e:  # noqa: BLE001 - one model failing must not stop the table
                print(f"{name}: fetch failed: {e}", flush=True)
        if p is None:
            rows.append(f"| {name} | – | – | not in {args.cache} | – | – |")
            print(rows[-1], flush=True)
            continue
        try:
            r = compare(p, args.size, args.samples, args.out)
        except Exception as e:  # noqa: BLE001 - one model failing must not stop the table
            rows.append(f"| {name} | – | – | failed: {e} | – | – |")
        else:
            if args.images:
                side_by_side_png(args.images / f"{name}.png", r["cycles"], r["polychrome"])
            for w in r["warnings"]:
                print(f"{name}: warning: {w}", flush=True)
            warn = summarise(r["warnings"]) or ("error: " + r["error"] if r["error"] else "none")
            rows.append(f"| {name} | {r['de']:.2f} | {r['p95']:.2f} | {warn} | {r['t_cycles']:.1f} | {r['t_poly']:.1f} |")
        print(rows[-1], flush=True)
    print()
    print(f"| model | mean ΔE00 | p95 ΔE00 | add-on warnings | Cycles s | Polychrome s |  ({args.size}², {args.samples} spp)")
    print("|---|---|---|---|---|---|")
    print("\n".join(rows))
    polychrome_blender.unregister()
    atexit.unregister(polychrome_blender.unregister)
    return 0


if __name__ == "__main__":
    sys.exit(main())
