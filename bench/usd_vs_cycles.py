"""Public USD stages, Polychrome against Cycles CPU (issue 15's first "Done when" item).

Each stage is wrapped in a new stage (`wrap_stage`) that references it (its default prim,
or the whole layer as a sublayer when other root prims hold what the default prim binds)
and adds a camera framing its bounds (`UsdGeom.BBoxCache`, render purpose), a sun (a
normalized `DistantLight`: irradiance 3 W/m², 1° wide) and a white `DomeLight` (radiance
0.3), with the stage's own `upAxis` and `metersPerUnit`. That wrapper is rendered three
ways at the same size, samples and bounces:

* (a) `polychrome.usd.read_stage` + `polychrome.render` (the project's reader);
* (b) Blender 4.5's USD importer (`bpy.ops.wm.usd_import`) + Polychrome's Blender engine;
* (c) Blender's importer + Cycles CPU (no denoising, adaptivity, clamping or filter): the
  reference of both.

The table: stage, mean CIEDE2000 over 4 × 4 blocks of (a) and of (b) against (c)
(`gltf_vs_cycles.delta_e`: colour-science, Rec.709 linear, white = Cycles' 99th-percentile
Y), the reader's and the add-on's warnings, the render times. Blender's importer reads
a DistantLight with its own export convention (strength = 4 × intensity, angle = 2 ×
angle; docs/usd.md, Lights), not UsdLux's; the bench undoes that on every imported sun
(strength / 4, angle / 2: the wrapper's sun is 3 W/m² and 1° again, and a stage's own
unnormalized DistantLight gets UsdLux's irradiance L·π·sin²(θ/2) in Cycles;
`--raw-import` keeps what the importer made), so that (b) and (c) see the lights the
stage describes. That is the only edit after the import (none of these stages is
Blender-authored, whose suns the importer reads right).

    python bench/usd_vs_cycles.py [--stages A,B] [--size 96] [--samples 64]
        [--assets DIR | --source GITDIR] [--out DIR] [--images DIR] [--raw-import] [--unbound 0.8]
        [--no-import-subdiv] [--subdivision-level N]

Subdivision surfaces: the importer runs with `import_subdiv` on for (b) and (c)
(Subdivision Surface modifiers on catmullClark meshes, whose levels it prints; off in
Blender's own default), as (a) refines catmullClark meshes at read_stage's level
(`--subdivision-level`, default 2; 0 = the cage). `--no-import-subdiv` makes (b) and (c)
render control cages (compare with `--subdivision-level 0`).

`--unbound 0.8` gives (a) a copy of the wrapper whose gprims bound to no material have
displayColor 0.8, what Blender's importer shows them as (it ignores displayColor without
a material; the reader, like Hydra, renders it, else the preview surface's 0.18 grey): what
is left of (a)'s difference once that importer difference is taken out.

Stages are files of usd-wg/assets (STAGES, below) under `--assets` (a checkout; default
$POLYCHROME_USD_ASSETS, else ~/.cache/polychrome/usd-wg-assets). `--source GITDIR`
(a local clone or a bare git directory of usd-wg/assets) first copies each chosen stage's
folder there (files whose content the clone lacks are skipped and listed). Nothing is
committed. `--images DIR` writes DIR/<stage>.png: Cycles | Polychrome via Blender |
Polychrome via read_stage, sRGB-encoded (docs/images/usd holds the table's; none for
stages whose licence forbids it). Each stage's Blender half runs in a subprocess under a
timeout (bpy hangs at exit with a class registered, and may crash). Needs `bpy`
(numpy < 2), usd-core, colour-science, OpenEXR and Pillow in the venv.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))

from gltf_vs_cycles import delta_e, engine_settings, render, side_by_side_png, summarise  # noqa: E402

DEFAULT_ASSETS = Path(os.environ.get("POLYCHROME_USD_ASSETS", Path.home() / ".cache" / "polychrome" / "usd-wg-assets"))
SUN_IRRADIANCE, SUN_ANGLE, DOME = 3.0, 1.0, 0.3
BOUNCES = 8
# Stage → (file in usd-wg/assets, the folder `--source` copies, licence, images, what it
# exercises); images: False where the licence forbids derived images in this MIT/Apache-2.0 repository.
STAGES = {
    "Teapot": ("full_assets/Teapot/Teapot.usd", "full_assets/Teapot", "CC0", True, "Y-up, payload, variants"),
    "McUsd": ("full_assets/McUsd/McUsd.usda", "full_assets/McUsd", "CC BY-NC-SA 4.0", False, "textures, cut-outs, normal maps, emission"),
    "OpenChessSet": (
        "full_assets/OpenChessSet/chess_set.usda",
        "full_assets/OpenChessSet",
        "CC BY 4.0",
        True,
        "Y-up, references, instancing, textures, MaterialX",
    ),
    "TextureTransformTest": (
        "test_assets/TextureTransformTest/TextureTransformTest.usd",
        "test_assets/TextureTransformTest",
        "CC0",
        True,
        "cm, Y-up, UsdTransform2d, wrap modes",
    ),
    "TextureCoordinateTest": (
        "test_assets/TextureCoordinateTest/TextureCoordinateTest.usda",
        "test_assets/TextureCoordinateTest",
        "CC BY 4.0",
        True,
        "st orientation",
    ),
    "RoughnessTest": (
        "test_assets/RoughnessTest/RoughnessTest.usdz",
        "test_assets/RoughnessTest",
        "CC0",
        True,
        ".usdz, roughness × metallic",
    ),
    "NormalsTextureBiasAndScale": (
        "test_assets/NormalsTextureBiasAndScale/NormalsTextureBiasAndScale.usdz",
        "test_assets/NormalsTextureBiasAndScale",
        "CC BY-NC-SA 4.0",
        False,
        ".usdz, normal-map scale and bias",
    ),
    "AlphaBlendModeTest": (
        "test_assets/AlphaBlendModeTest/AlphaBlendModeTest.usd",
        "test_assets/AlphaBlendModeTest",
        "CC BY 4.0",
        True,
        "opacity, opacityThreshold",
    ),
    "MaterialXTest": (
        "test_assets/MaterialXTest/basic.usda",
        "test_assets/MaterialXTest",
        "Apache-2.0",
        True,
        "MaterialX .mtlx reference, cm, Y-up, Sphere",
    ),
    "TextureFileFormats": (
        "test_assets/TextureFileFormatTests/all_files.usda",
        "test_assets/TextureFileFormatTests",
        "Apache-2.0",
        True,
        "JPEG/PNG 8/16/32-bit, grey, CMYK",
    ),
    "AllPrimitives": (
        "test_assets/schemaTests/usdGeom/primitives/all_primitives.usda",
        "test_assets/schemaTests/usdGeom/primitives",
        "Apache-2.0",
        True,
        "Sphere, Cube, Cylinder, Cone, Capsule",
    ),
    "SpinningPyramids": (
        "full_assets/SubdivisionSurfaces/Creases_SpinningPyramids.usda",
        "full_assets/SubdivisionSurfaces",
        "Apache-2.0",
        True,
        "subdivision creases, instancing",
    ),
    "VehicleVariants": (
        "full_assets/Vehicles/USD_Mini_Car_Kit/assets/vehicles/vehicleVariants.usda",
        "full_assets/Vehicles",
        "CC0",
        True,
        "variants, references, Y-up",
    ),
    "SimpleAssetScene": (
        "intent-vfx/scenes/simpleAssetScene.usd",
        "intent-vfx",
        "Apache-2.0",
        True,
        "instanceable references, payloads, lights",
    ),
    "ShaderBall": (
        "full_assets/StandardShaderBall/standard_shader_ball_scene.usda",
        "full_assets/StandardShaderBall",
        "Apache-2.0",
        True,
        "missing files, lights, dome texture",
    ),
}


def stage_file(name: str, assets: Path) -> Path:
    return assets / STAGES[name][0]


def copy_from_git(name: str, source: Path, assets: Path) -> list[str]:
    """Copies STAGES[name]'s folder out of a usd-wg/assets clone (work tree or bare git
    directory) into `assets`; returns the files the clone has no content for."""
    src = Path(source).expanduser()
    git = ["git", "--git-dir", str(src / ".git" if (src / ".git").exists() else src)]
    folder = STAGES[name][1]
    listing = subprocess.run([*git, "ls-tree", "-r", "HEAD", folder], capture_output=True, text=True, check=True)
    missing = []
    for line in listing.stdout.splitlines():
        meta, path = line.split("\t", 1)
        _, kind, sha = meta.split()
        if kind != "blob":
            continue
        dest = assets / path
        if dest.is_file():
            continue
        blob = subprocess.run([*git, "cat-file", "blob", sha], capture_output=True)
        if blob.returncode != 0:
            missing.append(path)
            continue
        dest.parent.mkdir(parents=True, exist_ok=True)
        dest.write_bytes(blob.stdout)
    return missing


def _look_at(eye, target, up) -> list[list[float]]:
    """USD's row-vector matrix of a camera at `eye` whose -Z looks at `target`."""
    z = np.asarray(eye, float) - np.asarray(target, float)
    z /= np.linalg.norm(z)
    x = np.cross(up, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return [[*x, 0.0], [*y, 0.0], [*z, 0.0], [*eye, 1.0]]


def _z_up_to_stage(up: str) -> np.ndarray:
    """Rotation taking a Z-up direction to the stage's frame (Y-up: −90° about X)."""
    return np.array([[1.0, 0, 0], [0, 0, 1.0], [0, -1.0, 0]]) if up == "Y" else np.eye(3)


def wrap_stage(asset: Path, out: Path, size: int = 96) -> dict:
    """Writes the wrapper stage `out` (see the module docstring); returns what it framed.
    Its `UsdRender.Settings` make /WrapCamera the render camera (stages bring their own
    cameras, which `read_stage` would otherwise take first); the stage's own DomeLights are
    deactivated (each renderer keeps one world); its time range is copied."""
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdRender

    src = Usd.Stage.Open(str(asset))
    up = UsdGeom.GetStageUpAxis(src)
    mpu = UsdGeom.GetStageMetersPerUnit(src)
    cache = UsdGeom.BBoxCache(Usd.TimeCode.EarliestTime(), [UsdGeom.Tokens.default_, UsdGeom.Tokens.render])
    box = cache.ComputeWorldBound(src.GetPseudoRoot()).ComputeAlignedRange()
    if box.IsEmpty():
        raise ValueError(f"{asset}: UsdGeom.BBoxCache finds no bounds")
    lo, hi = np.array(box.GetMin()), np.array(box.GetMax())
    centre, radius = (lo + hi) / 2, max(float(np.linalg.norm(hi - lo)) / 2, 1e-6)
    default = src.GetDefaultPrim()
    roots = [p for p in src.GetPseudoRoot().GetChildren() if p.GetSpecifier() != Sdf.SpecifierClass]
    stage = Usd.Stage.CreateNew(str(out))
    UsdGeom.SetStageUpAxis(stage, up)
    UsdGeom.SetStageMetersPerUnit(stage, mpu)
    if default and len(roots) == 1:
        prim = stage.DefinePrim(default.GetPath())
        prim.GetReferences().AddReference(str(asset))
        how = f"references {default.GetPath()}"
    else:
        stage.GetRootLayer().subLayerPaths.append(str(asset))
        how = "sublayer (" + ", ".join(str(p.GetPath()) for p in roots) + ")"
    if src.HasAuthoredTimeCodeRange():
        stage.SetStartTimeCode(src.GetStartTimeCode())
        stage.SetEndTimeCode(src.GetEndTimeCode())
    domes = [str(p.GetPath()) for p in src.Traverse() if p.GetTypeName() in ("DomeLight", "DomeLight_1")]
    for path in domes:
        stage.OverridePrim(path).SetActive(False)
    c = _z_up_to_stage(up)
    up_vec = c @ np.array([0.0, 0.0, 1.0])
    focal, aperture = 50.0, 36.0  # mm
    fov = 2 * math.atan(aperture / (2 * focal))
    dist = 1.15 * radius / math.sin(fov / 2)
    d = c @ (np.array([1.0, -1.0, 0.6]) / np.linalg.norm([1.0, -1.0, 0.6]))
    cam = UsdGeom.Camera.Define(stage, "/WrapCamera")
    tenth = 100.0 * mpu  # mm in a tenth of a scene unit (UsdGeomCamera's units)
    cam.CreateFocalLengthAttr(focal / tenth)
    cam.CreateHorizontalApertureAttr(aperture / tenth)
    cam.CreateVerticalApertureAttr(aperture / tenth)
    cam.CreateClippingRangeAttr(Gf.Vec2f(dist * 1e-3, dist * 100))
    cam.AddTransformOp().Set(Gf.Matrix4d(_look_at(centre + d * dist, centre, up_vec)))
    sun = UsdLux.DistantLight.Define(stage, "/WrapSun")
    sun.CreateIntensityAttr(SUN_IRRADIANCE)
    sun.CreateNormalizeAttr(True)
    sun.CreateAngleAttr(SUN_ANGLE)
    sun.CreateColorAttr(Gf.Vec3f(1, 1, 1))
    rx, rz = math.radians(50), math.radians(-35)  # bench/gltf_scene.py's sun, Blender XYZ Euler
    r = np.array([[math.cos(rz), -math.sin(rz), 0], [math.sin(rz), math.cos(rz), 0], [0, 0, 1]]) @ np.array(
        [[1, 0, 0], [0, math.cos(rx), -math.sin(rx)], [0, math.sin(rx), math.cos(rx)]]
    )
    m = np.eye(4)
    m[:3, :3] = (c @ r).T  # row vectors
    sun.AddTransformOp().Set(Gf.Matrix4d(m.tolist()))
    dome = UsdLux.DomeLight.Define(stage, "/WrapDome")
    dome.CreateIntensityAttr(DOME)
    dome.CreateColorAttr(Gf.Vec3f(1, 1, 1))
    settings = UsdRender.Settings.Define(stage, "/Render/WrapSettings")
    settings.CreateCameraRel().SetTargets([cam.GetPath()])
    settings.CreateResolutionAttr(Gf.Vec2i(size, size))
    stage.SetMetadata("renderSettingsPrimPath", "/Render/WrapSettings")
    stage.Save()
    t0 = src.GetStartTimeCode() if src.HasAuthoredTimeCodeRange() else 0.0
    return {"up": up, "metersPerUnit": mpu, "radius": radius, "how": how, "time": t0, "domes_off": domes}


def render_read_stage(wrapper: Path, size: int, samples: int, t0: float = 0.0, level: int | None = None):
    """(a): (linear RGB (H, W, 3), the reader's and the core's warnings, seconds)."""
    import polychrome as pc
    from polychrome import usd

    t = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = usd.read_stage(wrapper, resolution=(size, size), time=t0, subdivision_level=level)
        rgb = pc.render(scene, width=size, height=size, samples=samples, seed=1, max_bounces=BOUNCES).rgba[..., :3]
    said = [str(w.message).replace(f"{wrapper}: ", "") for w in caught]
    return np.asarray(rgb, np.float64), said, time.perf_counter() - t


BLENDER_WORKER = """
import atexit, json, math, sys
sys.path.insert(0, {bench!r})
import numpy as np
import bpy
import polychrome_blender
polychrome_blender.register()
atexit.register(polychrome_blender.unregister)
from usd_vs_cycles import blender_half
print("RESULT " + json.dumps(blender_half({wrapper!r}, {size}, {samples}, {out!r}, {raw}, {time!r}, {subdiv!r})), flush=True)
polychrome_blender.unregister()
atexit.unregister(polychrome_blender.unregister)
"""


def blender_half(wrapper: str, size: int, samples: int, out: str, raw: bool, t0: float = 0.0, subdiv: bool = False) -> dict:
    """(b) and (c), inside the bpy subprocess: imports the wrapper with Blender's USD
    importer (into an empty scene with a world, which the importer's DomeLight fills;
    `subdiv`: its import_subdiv, Subdivision Surface modifiers for catmullClark meshes),
    renders Cycles and Polychrome; the images go to OUT/{cycles,blender}.npy."""
    import bpy
    import polychrome_blender

    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    sc.world = bpy.data.worlds.new("World")
    sc.world.use_nodes = True
    bpy.ops.wm.usd_import(filepath=wrapper, import_subdiv=subdiv)
    subsurfs = sorted(
        {
            (m.levels, m.render_levels, m.use_limit_surface, m.boundary_smooth)
            for o in sc.objects
            for m in getattr(o, "modifiers", ())
            if m.type == "SUBSURF"
        }
    )
    sc.frame_set(round(t0))  # Blender frame = USD time code (the importer sets its fps)
    sc.render.resolution_x = sc.render.resolution_y = size
    sc.render.resolution_percentage = 100
    sc.view_settings.view_transform = "Standard"
    sc.render.image_settings.file_format = "OPEN_EXR"
    cams = [o for o in sc.objects if o.type == "CAMERA" and o.name.startswith("WrapCamera")]
    if not cams:
        raise ValueError("Blender's importer made no WrapCamera")
    sc.camera = cams[0]
    suns = {o.name: o.data for o in sc.objects if o.type == "LIGHT" and o.data.type == "SUN"}
    imported = {name: (s.energy, math.degrees(s.angle)) for name, s in suns.items()}
    if not raw:
        for s in suns.values():
            s.energy, s.angle = s.energy / 4.0, s.angle / 2.0
    engine_settings(sc, samples, BOUNCES)
    engine = polychrome_blender.engine.PolychromeRenderEngine
    cyc, t_c = render(sc, "CYCLES", Path(out) / "cycles.exr")
    np.save(Path(out) / "cycles.npy", cyc)
    try:
        poly, t_p = render(sc, "POLYCHROME", Path(out) / "blender.exr")
    except RuntimeError:  # the engine's error is in engine.last_error; (a) is still compared
        poly, t_p = np.zeros_like(cyc), float("nan")
    np.save(Path(out) / "blender.npy", poly)
    return {
        "imported_sun": imported,
        "meshes": sum(o.type == "MESH" for o in sc.objects),
        "subsurf": [list(x) for x in subsurfs],
        "warnings": list(engine.last_warnings),
        "error": engine.last_error,
        "t_cycles": t_c,
        "t_poly": t_p,
    }


def grey_unbound(wrapper: Path, out: Path, grey: float) -> int:
    """Writes `out`: `wrapper` with displayColor `grey` on every gprim bound to no material
    (what Blender's default material shows, 0.8, where the importer ignores displayColor);
    returns how many."""
    from pxr import Gf, Usd, UsdGeom, UsdShade

    stage = Usd.Stage.Open(str(wrapper))
    n = 0
    for prim in stage.Traverse():
        if prim.IsA(UsdGeom.Gprim) and not UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()[0]:
            UsdGeom.Gprim(prim).CreateDisplayColorPrimvar(UsdGeom.Tokens.constant).Set([Gf.Vec3f(grey, grey, grey)])
            n += 1
    stage.GetRootLayer().Export(str(out))
    return n


def compare(
    asset: Path,
    size: int = 96,
    samples: int = 64,
    tmp: Path | None = None,
    raw: bool = False,
    timeout: float = 900,
    unbound: float | None = None,
    subdiv: bool = False,
    level: int | None = None,
) -> dict:
    """One stage, the three renders: {'cycles', 'blender', 'read_stage' (images),
    'de_blender', 'de_read' ((mean, p95) against Cycles), warnings, times}."""
    tmp = Path(tmp or tempfile.mkdtemp(prefix="usd_vs_cycles_"))
    tmp.mkdir(parents=True, exist_ok=True)
    wrapper = tmp / "wrap.usda"
    info = wrap_stage(asset, wrapper, size)
    if unbound is not None:  # (a) only; Blender's importer reads the original wrapper
        info["greyed"] = grey_unbound(wrapper, tmp / "wrap_unbound.usda", unbound)
    read = tmp / "wrap_unbound.usda" if unbound is not None else wrapper
    ours, read_warnings, t_read = render_read_stage(read, size, samples, info["time"], level)
    script = tmp / "blender_worker.py"
    script.write_text(
        BLENDER_WORKER.format(
            bench=str(HERE), wrapper=str(wrapper), size=size, samples=samples, out=str(tmp), raw=raw, time=info["time"], subdiv=subdiv
        )
    )
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(tmp / "blender_user"))
    proc = subprocess.run(
        ["nice", "-n", "10", sys.executable, str(script)], cwd=tmp, env=env, capture_output=True, text=True, timeout=timeout
    )
    found = [json.loads(line[7:]) for line in proc.stdout.splitlines() if line.startswith("RESULT ")]
    if proc.returncode != 0 or not found:
        raise RuntimeError(f"Blender subprocess rc={proc.returncode}: {(proc.stderr or proc.stdout)[-1500:]}")
    r = found[0]
    importer = [
        line.strip()
        for line in (proc.stdout + proc.stderr).splitlines()
        if line.lstrip().upper().startswith(("WARNING", "ERROR")) and "not freed" not in line.lower()
    ]
    cyc, blend = np.load(tmp / "cycles.npy"), np.load(tmp / "blender.npy")
    return {
        **info,
        **r,
        "cycles": cyc,
        "blender": blend,
        "read_stage": ours,
        "de_blender": (float("nan"), float("nan")) if r["error"] else delta_e(cyc, blend),
        "de_read": delta_e(cyc, ours),
        "read_warnings": read_warnings,
        "importer_warnings": importer,
        "t_read": t_read,
    }


def _brief(warnings_: list[str]) -> str:
    """summarise() of warnings without the prim each names (the full text is printed)."""
    import re

    return summarise([re.sub(r"^prim \S+: ", "", w) for w in warnings_])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--stages", default=",".join(STAGES))
    ap.add_argument("--size", type=int, default=96)
    ap.add_argument("--samples", type=int, default=64)
    ap.add_argument("--assets", type=Path, default=DEFAULT_ASSETS, help="a usd-wg/assets checkout (or the folders --source copied)")
    ap.add_argument("--source", type=Path, default=None, help="a usd-wg/assets clone or bare git directory to copy stages from")
    ap.add_argument("--out", type=Path, default=None, help="directory for the wrappers and renders (default: a temp dir)")
    ap.add_argument("--images", type=Path, default=None, help="directory for PNGs: Cycles | Polychrome via Blender | via read_stage")
    ap.add_argument("--raw-import", action="store_true", help="keep the sun Blender's importer makes (see the docstring)")
    ap.add_argument(
        "--unbound",
        type=float,
        default=None,
        help="for (a), displayColor GREY on gprims bound to no material (0.8: what Blender's importer shows them as)",
    )
    ap.add_argument("--timeout", type=float, default=900, help="seconds for each stage's Blender subprocess")
    ap.add_argument(
        "--import-subdiv",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="Blender's importer with import_subdiv: Subdivision Surface modifiers on catmullClark meshes (default on, "
        "as read_stage refines them; Blender's own default is off)",
    )
    ap.add_argument(
        "--subdivision-level",
        type=int,
        default=None,
        help="read_stage's subdivision_level for (a) (default: the reader's, 2; 0 = the cage)",
    )
    args = ap.parse_args()
    out = Path(args.out or tempfile.mkdtemp(prefix="usd_vs_cycles_"))
    rows = []
    for name in args.stages.split(","):
        if name not in STAGES:
            raise SystemExit(f"unknown stage '{name}' (known: {', '.join(STAGES)})")
        if args.source is not None:
            for path in copy_from_git(name, args.source, args.assets):
                print(f"{name}: {path}: no content in {args.source} (skipped)", flush=True)
        path = stage_file(name, args.assets)
        if not path.is_file():
            rows.append(f"| {name} | – | – | not in {args.assets} | – | – | {STAGES[name][2]} |")
            print(rows[-1], flush=True)
            continue
        try:
            r = compare(
                path,
                args.size,
                args.samples,
                out / name,
                args.raw_import,
                args.timeout,
                args.unbound,
                args.import_subdiv,
                args.subdivision_level,
            )
        except Exception as e:  # noqa: BLE001 - one stage failing must not stop the table
            rows.append(f"| {name} | – | – | failed: {str(e)[-300:]} | – | – | {STAGES[name][2]} |")
            print(rows[-1], flush=True)
            continue
        for w in r["read_warnings"]:
            print(f"{name}: read_stage warning: {w}", flush=True)
        for w in r["warnings"]:
            print(f"{name}: add-on warning: {w}", flush=True)
        for w in r["importer_warnings"]:
            print(f"{name}: Blender importer: {w}", flush=True)
        print(
            f"{name}: {r['how']}, upAxis {r['up']}, metersPerUnit {r['metersPerUnit']}, time {r['time']}, "
            f"own domes off {r['domes_off']}, imported suns (strength, angle°) {r['imported_sun']}, "
            f"importer's subsurf modifiers (levels, render_levels, limit, boundary) {r['subsurf']}",
            flush=True,
        )
        if args.images and STAGES[name][3]:
            side_by_side_png(args.images / f"{name}.png", r["cycles"], r["blender"], r["read_stage"])
        warn = "; ".join(
            x
            for x in (
                f"reader: {_brief(r['read_warnings'])}" if r["read_warnings"] else "",
                f"add-on: {_brief(r['warnings'])}" if r["warnings"] else "",
                f"add-on error: {r['error']}" if r["error"] else "",
            )
            if x
        )
        (db, pb), (dr, pr) = r["de_blender"], r["de_read"]
        rows.append(
            f"| {name} | {db:.2f} ({pb:.1f}) | {dr:.2f} ({pr:.1f}) | {warn or 'none'} "
            f"| {r['t_cycles']:.1f} / {r['t_poly']:.1f} / {r['t_read']:.1f} | {STAGES[name][2]} |"
        )
        print(rows[-1], flush=True)
    print()
    print(f"({args.size}², {args.samples} spp, {BOUNCES} bounces; mean ΔE00 (p95) against Blender's importer + Cycles)")
    print("| stage | via Blender + Polychrome | via read_stage | warnings | s: Cycles / add-on / read_stage | licence |")
    print("|---|---|---|---|---|---|")
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
