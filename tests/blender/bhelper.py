"""Runs bpy scripts in a subprocess (bpy hangs at exit if a class stays registered and
may crash on engine bugs, so the test process never imports it)."""

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

PRELUDE = """
import atexit, json, math, os, sys
import numpy as np
import bpy
import polychrome_blender
atexit.register(polychrome_blender.unregister)
polychrome_blender.register()
Engine = polychrome_blender.engine.PolychromeRenderEngine

def emit(**kw):
    print("RESULT " + json.dumps(kw), flush=True)

def empty_scene(width=32, height=24):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = width, height, 100
    sc.view_settings.view_transform = 'Standard'
    return sc

def add_camera(sc, location, target=(0, 0, 0), lens=50.0):
    from mathutils import Vector
    cd = bpy.data.cameras.new('Camera'); cd.lens = lens
    co = bpy.data.objects.new('Camera', cd); sc.collection.objects.link(co); sc.camera = co
    co.location = location
    co.rotation_euler = (Vector(target) - Vector(location)).to_track_quat('-Z', 'Y').to_euler()
    return co

def diffuse_material(name, rgb):
    m = bpy.data.materials.new(name); m.use_nodes = True
    nt = m.node_tree
    for n in list(nt.nodes):
        if n.type != 'OUTPUT_MATERIAL': nt.nodes.remove(n)
    d = nt.nodes.new('ShaderNodeBsdfDiffuse'); d.inputs['Color'].default_value = (*rgb, 1.0)
    nt.links.new(d.outputs['BSDF'], nt.nodes['Material Output'].inputs['Surface'])
    return m

def exr_channels(path):
    import OpenEXR
    return {k: np.asarray(v.pixels, np.float64) for k, v in OpenEXR.File(path, separate_channels=True).channels().items()}

# An EXR's RGB as (H, W, 3).
def exr_rgb(path):
    ch = exr_channels(path)
    return np.stack([ch[k] for k in 'RGB'], -1)

# Means of block x block pixels (the comparisons' unit), (H // block, W // block, 3).
def block_means(a, block=2):
    h, w = a.shape[0] // block, a.shape[1] // block
    return a[:block * h, :block * w].reshape(h, block, w, block, 3).mean(axis=(1, 3))

# The normal tests' stage: a W x W image, a dim grey world, a sun of 3 W/m² (`angle`
# radians wide) from (40°, 0, 30°), an orthographic camera 5 above the origin framing a
# smooth unit UV sphere (64 x 32), which it returns.
def ortho_sphere_under_sun(W, angle=0.0):
    sc = empty_scene(W, W)
    sc.world = bpy.data.worlds.new('W'); sc.world.use_nodes = True
    bg = sc.world.node_tree.nodes['Background']; bg.inputs['Color'].default_value = (0.05, 0.05, 0.05, 1.0)
    ld = bpy.data.lights.new('Sun', 'SUN'); ld.energy = 3.0; ld.angle = angle
    sun = bpy.data.objects.new('Sun', ld); sc.collection.objects.link(sun)
    sun.rotation_euler = (math.radians(40), 0.0, math.radians(30))
    cd = bpy.data.cameras.new('C'); cd.type = 'ORTHO'; cd.ortho_scale = 2.3
    cam = bpy.data.objects.new('C', cd); sc.collection.objects.link(cam); sc.camera = cam; cam.location = (0, 0, 5)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=1.0, segments=64, ring_count=32)
    bpy.ops.object.shade_smooth()
    return sc, bpy.context.object

# Cycles CPU as the reference: no denoising, adaptivity, clamping or glossy blur (none of
# which Polychrome has), a near-box pixel filter, `bounces` for every ray type.
def cycles_cpu(sc, samples, bounces=8):
    sc.render.engine = 'CYCLES'
    c = sc.cycles; c.device = 'CPU'; c.samples = samples; c.use_denoising = False; c.use_adaptive_sampling = False
    c.filter_width = 0.01; c.max_bounces = c.diffuse_bounces = c.glossy_bounces = bounces; c.blur_glossy = 0.0
    c.sample_clamp_indirect = 0.0; c.sample_clamp_direct = 0.0

# Renders `sc` with Cycles CPU and with Polychrome at the same samples and bounces; their
# RGB (H, W, 3) from cycles.exr and poly.exr.
def cycles_and_polychrome(sc, samples, bounces=8):
    sc.render.image_settings.file_format = 'OPEN_EXR'
    cycles_cpu(sc, samples, bounces)
    sc.render.filepath = os.path.abspath('cycles.exr'); bpy.ops.render.render(write_still=True)
    sc.render.engine = 'POLYCHROME'; sc.polychrome.samples = samples; sc.polychrome.max_bounces = bounces
    sc.render.filepath = os.path.abspath('poly.exr'); bpy.ops.render.render(write_still=True)
    return exr_rgb('cycles.exr'), exr_rgb('poly.exr')

# Renders `sc` with `engine` ('CYCLES', 'POLYCHROME') to tag.exr; its RGB as (H, W, 3).
def render_rgb(sc, engine, tag):
    sc.render.engine = engine
    sc.render.filepath = os.path.abspath(tag + '.exr'); bpy.ops.render.render(write_still=True)
    ch = exr_channels(tag + '.exr')
    pct = sc.render.resolution_percentage / 100.0
    h, w = int(sc.render.resolution_y * pct), int(sc.render.resolution_x * pct)
    return np.stack([ch[k] for k in 'RGB'], -1).reshape(h, w, 3)

# CIEDE2000 of block x block pixel means by colour-science (an independent reference),
# L*a*b* relative to a D65 white at the 99th-percentile luminance of `reference`.
def block_de00(reference, test, block):
    import colour
    rec709 = colour.RGB_COLOURSPACES['ITU-R BT.709']
    h, w = reference.shape[0] // block, reference.shape[1] // block
    blocks = [x[:h * block, :w * block].reshape(h, block, w, block, 3).mean(axis=(1, 3)) for x in (reference, test)]
    xyz = [colour.RGB_to_XYZ(x, rec709, apply_cctf_decoding=False) for x in blocks]
    white = max(float(np.percentile(xyz[0][..., 1], 99)), 1e-6)
    lab = [colour.XYZ_to_Lab(x / white, rec709.whitepoint) for x in xyz]
    return colour.delta_E(lab[0], lab[1], method='CIE 2000')

# The Cycles-vs-Polychrome score: mean block CIEDE2000 (<= 1.5 'looks the same').
def mean_de00(reference, test, block):
    return float(np.mean(block_de00(reference, test, block)))
"""

EPILOGUE = """
polychrome_blender.unregister()
"""


def run_bpy(tmp_path, body, timeout=180, env=None):
    """Runs PRELUDE + body + EPILOGUE with the venv's Python (in `env`, default: this
    process's environment); returns (proc, [RESULT dicts])."""
    try:
        import importlib.util

        if importlib.util.find_spec("bpy") is None:
            pytest.skip("bpy is not installed")
    except ValueError:
        pytest.skip("bpy is not importable")
    script = tmp_path / "script.py"
    script.write_text(PRELUDE + textwrap.dedent(body) + EPILOGUE)
    env = dict(os.environ if env is None else env)
    res = tmp_path / "blender_user"
    res.mkdir(exist_ok=True)
    env["BLENDER_USER_RESOURCES"] = str(res)
    proc = subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=timeout)
    results = [json.loads(line[7:]) for line in proc.stdout.splitlines() if line.startswith("RESULT ")]
    return proc, results


def check(proc, results, n=1):
    assert proc.returncode == 0, f"rc={proc.returncode}\n--- stdout\n{proc.stdout[-4000:]}\n--- stderr\n{proc.stderr[-4000:]}"
    assert len(results) >= n, f"expected {n} results\n--- stdout\n{proc.stdout[-4000:]}\n--- stderr\n{proc.stderr[-4000:]}"
    return results
