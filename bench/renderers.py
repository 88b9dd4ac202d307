"""Polychrome against Mitsuba 3 (scalar_spectral, scalar_rgb) and Blender Cycles (CPU)
on the Cornell box of examples/cornell_box.py, on this machine, in one run (issue 9).

    python bench/renderers.py [--size 64] [--ref-samples 4096] [--max-spp 1024] [--write docs/BENCHMARKS.md]

Mitsuba wants numpy 2 and lives in its own virtual environment: the script creates it
with `python3 -m venv /tmp/mitsuba-venv && /tmp/mitsuba-venv/bin/pip install mitsuba`
when `--mitsuba-python` does not exist yet. The scene is exported identically for it:
each mesh as a PLY file, the walls' and the lamp's spectra evaluated by Polychrome on a
1 nm grid (380–780 nm) as `irregular` spectra (scalar_rgb gets their sRGB equivalents via
`mi.spectrum_list_to_srgb`, reflectances under D65), two-sided diffuse walls, the same
pinhole camera, path depth max_bounces + 1. Cycles gets the same meshes and camera
built through `bpy` in a subprocess (saved as a .blend), walls as Diffuse BSDF with the
linear-sRGB equivalents of the reflectances under D65 and the lamp as an Emission of
the lamp's linear-sRGB radiance, box filter, no denoising, no adaptive sampling.

Reported per renderer: camera samples per second (pixels × spp / render seconds at the
highest sample count), time to mean ΔE00 ≤ 1 against Polychrome's converged reference
(doubling sample counts), and the ΔE00 of its most converged image to that reference.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import numpy as np

import polychrome as pc
from polychrome import _core
from polychrome.colordiff import image_delta_e

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "examples"))
sys.path.insert(0, str(ROOT / "bench"))
from common import write_section  # noqa: E402

GRID = json.dumps({"wavelength_count": 401, "wavelength_min": 380.0, "wavelength_max": 780.0})
LAMBDA = np.linspace(380.0, 780.0, 401)
# CIE 1931 → linear sRGB (Rec.709 primaries, D65 white).
XYZ_TO_RGB = np.array([[3.2404542, -1.5371385, -0.4985314], [-0.9692660, 1.8760108, 0.0415560], [0.0556434, -0.2040259, 1.0572252]])


def cmfs():
    import colour

    c = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(colour.SpectralShape(380, 780, 1))
    return c.values


def spectrum_rgb(values, emitter):
    """Linear sRGB of a spectrum on LAMBDA: emitters as radiance (Y of a flat 1 = 1), reflectances under D65."""
    import colour

    xyz_bar = cmfs()
    if emitter:
        xyz = (values[:, None] * xyz_bar).sum(0) / xyz_bar[:, 1].sum()
    else:
        d65 = colour.SDS_ILLUMINANTS["D65"].copy().align(colour.SpectralShape(380, 780, 1)).values
        xyz = (values[:, None] * d65[:, None] * xyz_bar).sum(0) / (d65 * xyz_bar[:, 1]).sum()
    return (XYZ_TO_RGB @ xyz).tolist()


def write_ply(path: Path, v: np.ndarray, f: np.ndarray) -> None:
    head = f"ply\nformat ascii 1.0\nelement vertex {len(v)}\nproperty float x\nproperty float y\nproperty float z\nelement face {len(f)}\nproperty list uchar int vertex_indices\nend_header\n"
    body = "".join(f"{a:.7g} {b:.7g} {c:.7g}\n" for a, b, c in v) + "".join(f"3 {a} {b} {c}\n" for a, b, c in f)
    path.write_text(head + body)


def export(scene: pc.Scene, tmp: Path, size: int, max_bounces: int) -> dict:
    desc, buffers = scene.description()
    mats = []
    for m in desc["materials"]:
        if m.get("emission"):
            vals = np.asarray(_core.spectrum_values(json.dumps(m["emission"]), GRID, "illuminant"), float)
            mats.append({"emission": {"wavelengths": LAMBDA.tolist(), "values": vals.tolist()}, "rgb": spectrum_rgb(vals, True)})
        else:
            vals = np.asarray(_core.spectrum_values(json.dumps(m["bsdf"]["reflectance"]), GRID, "reflectance"), float)
            mats.append({"reflectance": {"wavelengths": LAMBDA.tolist(), "values": vals.tolist()}, "rgb": spectrum_rgb(vals, False)})
    meshes = []
    for m in desc["meshes"]:
        v = np.asarray(buffers[m["vertices"]], float).reshape(-1, 3)
        f = np.asarray(buffers[m["triangles"]], int).reshape(-1, 3)
        ply = tmp / f"{len(meshes)}.ply"
        write_ply(ply, v, f)
        meshes.append({"ply": str(ply), "material": m["material"], "name": m["name"], "vertices": v.tolist(), "faces": f.tolist()})
    cam = desc["camera"]
    M = np.asarray(cam["to_world"], float)
    origin = M[:3, 3]
    fov_x = math.degrees(2 * math.atan(cam["sensor_width"] / 2 / cam["focal_length"]))
    camera = {
        "origin": origin.tolist(),
        "target": (origin - M[:3, 2]).tolist(),
        "up": M[:3, 1].tolist(),
        "fov_x": fov_x,
        "matrix": M.tolist(),
        "focal_length": cam["focal_length"],
        "sensor_width": cam["sensor_width"],
    }
    s = {"materials": mats, "meshes": meshes, "camera": camera, "size": size, "max_depth": max_bounces + 1}
    (tmp / "scene.json").write_text(json.dumps(s))
    return s


def mean_de(rgb, ref):
    return float(np.mean(image_delta_e(np.asarray(rgb)[..., :3], ref)))


def time_to(rows, target=1.0):
    for r in rows:
        if r["de"] <= target:
            return r["seconds"]
    return None


def read_exr(path):
    from polychrome.imageio import read_image

    return np.asarray(read_image(path), float)[..., :3]


def ensure_mitsuba(py: Path) -> bool:
    if py.exists():
        return True
    venv = py.parent.parent
    subprocess.run(["python3", "-m", "venv", str(venv)], check=True)
    subprocess.run([str(py), "-m", "pip", "install", "-q", "mitsuba"], check=True)
    return py.exists()


CYCLES = textwrap.dedent(
    """
    import bpy, json, math, sys, time
    from mathutils import Matrix
    s = json.load(open(sys.argv[-4])); out = sys.argv[-3]; spps = [int(x) for x in sys.argv[-2].split(',')]; blend = sys.argv[-1]
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    sc.render.engine = 'CYCLES'; sc.cycles.device = 'CPU'
    sc.render.resolution_x = sc.render.resolution_y = s['size']; sc.render.resolution_percentage = 100
    sc.render.threads_mode = 'FIXED'; sc.render.threads = 2
    sc.view_settings.view_transform = 'Standard'
    sc.cycles.use_denoising = False; sc.cycles.use_adaptive_sampling = False
    sc.cycles.max_bounces = s['max_depth'] - 1
    for k in ('diffuse_bounces', 'glossy_bounces', 'transmission_bounces', 'volume_bounces', 'transparent_max_bounces'):
        setattr(sc.cycles, k, s['max_depth'] - 1)
    sc.cycles.sample_clamp_direct = 0.0; sc.cycles.sample_clamp_indirect = 0.0
    sc.cycles.pixel_filter_type = 'BOX'; sc.cycles.filter_width = 1.0
    sc.cycles.caustics_reflective = True; sc.cycles.caustics_refractive = True; sc.cycles.blur_glossy = 0.0
    sc.world = bpy.data.worlds.new('W'); sc.world.use_nodes = True
    sc.world.node_tree.nodes['Background'].inputs['Strength'].default_value = 0.0
    mats = []
    for i, m in enumerate(s['materials']):
        mat = bpy.data.materials.new(f'm{i}'); mat.use_nodes = True; nt = mat.node_tree
        for n in list(nt.nodes):
            if n.type != 'OUTPUT_MATERIAL': nt.nodes.remove(n)
        if 'emission' in m:
            e = nt.nodes.new('ShaderNodeEmission'); e.inputs['Color'].default_value = (*m['rgb'], 1.0); e.inputs['Strength'].default_value = 1.0
            nt.links.new(e.outputs[0], nt.nodes['Material Output'].inputs['Surface'])
        else:
            d = nt.nodes.new('ShaderNodeBsdfDiffuse'); d.inputs['Color'].default_value = (*m['rgb'], 1.0)
            nt.links.new(d.outputs[0], nt.nodes['Material Output'].inputs['Surface'])
        mats.append(mat)
    for m in s['meshes']:
        me = bpy.data.meshes.new(m['name']); me.from_pydata(m['vertices'], [], m['faces']); me.update()
        me.materials.append(mats[m['material']])
        ob = bpy.data.objects.new(m['name'], me); sc.collection.objects.link(ob)
    cd = bpy.data.cameras.new('Camera'); cd.lens = s['camera']['focal_length']; cd.sensor_width = s['camera']['sensor_width']; cd.sensor_fit = 'AUTO'
    co = bpy.data.objects.new('Camera', cd); sc.collection.objects.link(co); sc.camera = co
    co.matrix_world = Matrix(s['camera']['matrix'])
    sc.render.image_settings.file_format = 'OPEN_EXR'; sc.render.image_settings.color_depth = '32'
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    res = []
    for spp in spps:
        sc.cycles.samples = spp; sc.cycles.seed = spp
        t = time.perf_counter(); bpy.ops.render.render(write_still=False); sec = time.perf_counter() - t
        img = bpy.data.images['Render Result']; path = f"{out}/cycles_{spp}.exr"
        img.save_render(path)
        res.append({'spp': spp, 'seconds': sec, 'exr': path})
        print('ROW', json.dumps(res[-1]), flush=True)
    print('RESULT ' + json.dumps(res), flush=True)
    """
)


def run_cycles(scene_json: Path, tmp: Path, spps: list[int]):
    script = tmp / "cycles_job.py"
    script.write_text("import sys\nsys.argv = sys.argv\n" + CYCLES)
    code = f"import sys; sys.argv = ['x', {str(scene_json)!r}, {str(tmp)!r}, {','.join(map(str, spps))!r}, {str(tmp / 'cornell.blend')!r}]; exec(open({str(script)!r}).read())"
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=3600)
    for line in p.stdout.splitlines():
        if line.startswith("RESULT "):
            return json.loads(line[7:])
    raise RuntimeError(f"Cycles run failed:\n{p.stdout[-2000:]}\n{p.stderr[-2000:]}")


def run_mitsuba_worker(python, scene_json, variant, out_dir, spps, env=None, timeout=3600):
    """Renders `scene_json` with bench/mitsuba_worker.py in Mitsuba's own venv at each
    of `spps`; the worker's rows (seconds, exr path per spp), or None after printing
    why it failed. Two threads unless `env` says otherwise."""
    p = subprocess.run(
        [str(python), str(ROOT / "bench" / "mitsuba_worker.py"), str(scene_json), variant, str(out_dir), ",".join(map(str, spps))],
        capture_output=True,
        text=True,
        env=env if env is not None else dict(os.environ, THREADS="2"),
        timeout=timeout,
    )
    if p.returncode != 0:
        print(f"Mitsuba {variant} failed:", p.stderr[-3000:])
        return None
    last = [ln for ln in p.stdout.splitlines() if "[{" in ln][-1]
    return json.loads(last[last.index("[{") :])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--ref-samples", type=int, default=4096)
    ap.add_argument("--max-spp", type=int, default=1024)
    ap.add_argument("--max-bounces", type=int, default=8)
    ap.add_argument("--mitsuba-python", type=Path, default=Path("/tmp/mitsuba-venv/bin/python"))
    ap.add_argument("--skip", default="", help="comma list of mitsuba,cycles to skip")
    ap.add_argument("--write", type=Path)
    args = ap.parse_args(argv)
    from cornell_box import build_scene

    scene = build_scene()
    size, px = args.size, args.size * args.size
    spps = [2**k for k in range(int(math.log2(args.max_spp)) + 1)]
    tmp = Path(tempfile.mkdtemp(prefix="pc-renderers-"))
    export(scene, tmp, size, args.max_bounces)
    common = dict(width=size, height=size, max_bounces=args.max_bounces, noise_threshold=0.0, threads=2)
    t0 = time.perf_counter()
    ref = pc.render(scene, samples=args.ref_samples, wavelength_count=81, seed=12345, **common).rgba[..., :3]
    print(f"reference: {time.perf_counter() - t0:.0f} s", flush=True)
    results = {}
    for label, kw in (
        ("Polychrome POLYCHROMATIC, 41 λ", dict(wavelength_count=41)),
        ("Polychrome POLYCHROMATIC, AUTO grid", {}),
        ("Polychrome RGB", dict(method="RGB", wavelength_count=41)),
    ):
        rows = []
        for spp in spps:
            r = pc.render(scene, samples=spp, seed=spp, **kw, **common)
            rows.append(
                {
                    "spp": spp,
                    "seconds": r.stats["seconds"] - r.stats["build_seconds"],
                    "de": mean_de(r.rgba, ref),
                    "wavelengths": r.stats["wavelengths"],
                }
            )
            print(label, rows[-1], flush=True)
        results[label] = rows
    # AUTO as shipped: adaptive to ΔE00 1 with the fitted grid.
    r = pc.render(scene, width=size, height=size, threads=2, seed=1)
    auto = {
        "seconds": r.stats["seconds"] - r.stats["build_seconds"],
        "de": mean_de(r.rgba, ref),
        "spp": r.stats["total_samples"] / px,
        "wavelengths": r.stats["wavelengths"],
    }
    print("AUTO", auto, r.stats["auto_reason"], flush=True)
    skip = set(args.skip.split(","))
    blend_note = ""
    if "mitsuba" not in skip and ensure_mitsuba(args.mitsuba_python):
        for variant in ("scalar_spectral", "scalar_rgb"):
            rows = run_mitsuba_worker(args.mitsuba_python, tmp / "scene.json", variant, tmp, spps, timeout=7200)
            if rows is None:
                continue
            for row in rows:
                row["de"] = mean_de(read_exr(row["exr"]), ref)
                print("Mitsuba", variant, row, flush=True)
            results[f"Mitsuba 3 {variant}"] = rows
    if "cycles" not in skip:
        try:
            rows = run_cycles(tmp / "scene.json", tmp, spps)
            for row in rows:
                row["de"] = mean_de(read_exr(row["exr"]), ref)
                print("Cycles", row, flush=True)
            results["Blender Cycles CPU"] = rows
            # The same .blend through the add-on (`polychrome render`, RGB materials uplifted).
            blend_out = tmp / "polychrome_blend.exr"
            p = subprocess.run(
                [
                    sys.executable,
                    "-m",
                    "polychrome.cli",
                    "render",
                    str(tmp / "cornell.blend"),
                    "-o",
                    str(blend_out),
                    "--samples",
                    str(args.ref_samples),
                    "--wavelengths",
                    "41",
                    "--threads",
                    "2",
                    "--seed",
                    "3",
                    "--quiet",
                ],
                capture_output=True,
                text=True,
                timeout=3600,
            )
            if p.returncode == 0:
                same_blend = read_exr(blend_out)
                cyc = read_exr(rows[-1]["exr"])
                blend_note = (
                    f"The Cycles scene saved as .blend and rendered by Polychrome through the add-on (`polychrome render cornell.blend "
                    f"--samples {args.ref_samples} --wavelengths 41`; RGB diffuse colours uplifted, emission as Blender gives it): "
                    f"mean ΔE00 {mean_de(same_blend, ref):.2f} to the spectral reference, {mean_de(same_blend, cyc):.2f} to Cycles at {rows[-1]['spp']} spp."
                )
                print(blend_note, flush=True)
            else:
                print("polychrome render of the .blend failed:", p.stderr[-2000:])
        except Exception as e:  # noqa: BLE001
            print("Cycles failed:", e)

    lines = [
        "| renderer | camera samples/s (at max spp) | time to mean ΔE00 ≤ 1 | mean ΔE00 at max spp vs reference |",
        "| --- | --- | --- | --- |",
    ]
    for label, rows in results.items():
        last = rows[-1]
        t1 = time_to(rows)
        lines.append(
            f"| {label} | {px * last['spp'] / last['seconds'] / 1e6:.3f} M | {'not reached' if t1 is None else f'{t1:.2f} s'} | {last['de']:.2f} ({last['spp']} spp) |"
        )
    lines.append(
        f"| Polychrome AUTO (adaptive to ΔE00 1, {auto['wavelengths']} λ) | — | {auto['seconds']:.2f} s (mean ΔE00 {auto['de']:.2f}, mean {auto['spp']:.0f} spp) | — |"
    )
    detail = [
        "",
        "Mean ΔE00 against the reference at each sample count (seconds in brackets):",
        "",
        "| spp | " + " | ".join(results) + " |",
        "| --- |" + " --- |" * len(results),
    ]
    for i, spp in enumerate(spps):
        detail.append(
            f"| {spp} | "
            + " | ".join(f"{rows[i]['de']:.2f} ({rows[i]['seconds']:.2f})" if i < len(rows) else "" for rows in results.values())
            + " |"
        )
    body = (
        f"Cornell box (examples/cornell_box.py), {size}×{size}, path depth {args.max_bounces} bounces, 2 threads for every renderer, "
        f"reference Polychrome POLYCHROMATIC 81 λ {args.ref_samples} spp. Render seconds exclude scene loading/building "
        "(Cycles' include its per-render sync). Mitsuba samples carry 4 wavelengths each (scalar_spectral), Polychrome's 41 (or AUTO's grid).\n\n"
        + "\n".join(lines + detail)
        + ("\n\n" + blend_note if blend_note else "")
    )
    print(body)
    if args.write:
        write_section(
            args.write,
            "Against other renderers",
            body,
            f"python bench/renderers.py --size {size} --ref-samples {args.ref_samples} --max-spp {args.max_spp} --write {args.write}",
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
