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
