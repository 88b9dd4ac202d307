"""The bpy side of the emission oracle (test_node_oracle.py), run inside a bpy subprocess.

Every case is a small node graph whose result drives the Color of an Emission shader on
its own plane (a tile of a grid) seen straight on by an orthographic camera: each pixel
is then the graph's value, in Cycles and in Polychrome, with no lighting. A float result
f is shown as the colour (f, -f, 0), a vector or colour v on two tiles, v and -v, so
that negative values (which an emitter cannot show) are compared too. The scene is
rendered by Cycles CPU (1 sample, a box filter of 0.01 pixel: each pixel is its centre's
value) and by Polychrome through the add-on, in the same process.
"""

import json
import math
import os
import time

import bpy
import numpy as np

T = 6  # pixels per tile side; the plane covers 0.9 of it
COLS = 24


def sock(node, ident, output=False):
    """A socket by identifier (sockets the node's mode hides are missing from name lookups)."""
    for s in node.outputs if output else node.inputs:
        if s.identifier == ident or (s.name == ident and s.enabled):
            return s
    raise KeyError(f"{node.bl_idname} has no {'output' if output else 'input'} {ident!r}")


def node(nt, kind, props=None, **inputs):
    """A node with ``props`` set and inputs given by identifier: a value, or a socket to link."""
    n = nt.nodes.new(kind)
    for k, v in (props or {}).items():
        setattr(n, k, v)
    for ident, v in inputs.items():
        s = sock(n, ident)
        if isinstance(v, bpy.types.NodeSocket):
            nt.links.new(v, s)
        elif s.type == "RGBA" and len(v) == 3:
            s.default_value = (*v, 1.0)
        else:
            s.default_value = v
    return n


def out(n, ident=None):
    """A node's output by identifier (default: the first shown)."""
    if ident is None:
        return next(o for o in n.outputs if o.enabled)
    return sock(n, ident, output=True)


def build_tiles(cases, shader="ShaderNodeEmission"):
    """One material per shown value; returns the tile list [(case index, material, sign)].
    ``shader``: the Emission (the value is the pixel) or a Diffuse BSDF (the value is the
    albedo: under a uniform white world the pixel is the albedo, clamped to [0, 1])."""
    tiles = []
    for i, (family, label, build, _tol) in enumerate(cases):
        m = bpy.data.materials.new(f"{family}: {label}")
        m.use_nodes = True
        nt = m.node_tree
        for n in list(nt.nodes):
            nt.nodes.remove(n)
        mo = nt.nodes.new("ShaderNodeOutputMaterial")
        result = build(nt)
        em = nt.nodes.new(shader)
        if shader == "ShaderNodeEmission":
            em.inputs["Strength"].default_value = 1.0
        nt.links.new(em.outputs[0], mo.inputs["Surface"])
        if result.type in ("VALUE", "INT", "BOOLEAN"):
            neg = node(nt, "ShaderNodeMath", {"operation": "MULTIPLY"}, Value=result, Value_001=-1.0)
            shown = node(nt, "ShaderNodeCombineXYZ", X=result, Y=out(neg), Z=0.0)
            nt.links.new(out(shown), em.inputs["Color"])
            tiles.append((i, m, "value"))
        else:
            nt.links.new(result, em.inputs["Color"])
            tiles.append((i, m, "+"))
            m2 = m.copy()
            m2.name = m.name + " (negated)"
            nt2 = m2.node_tree
            em2 = next(n for n in nt2.nodes if n.bl_idname == shader)
            src = em2.inputs["Color"].links[0].from_socket
            neg = node(nt2, "ShaderNodeVectorMath", {"operation": "SCALE"}, Vector=src, Scale=-1.0)
            nt2.links.new(out(neg, "Vector"), em2.inputs["Color"])
            tiles.append((i, m2, "-"))
    return tiles


def render(cases, samples=1, albedo=False, pixel_average=False):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    tiles = build_tiles(cases, "ShaderNodeBsdfDiffuse" if albedo else "ShaderNodeEmission")
    rows = (len(tiles) + COLS - 1) // COLS
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = T * COLS, T * rows, 100
    sc.view_settings.view_transform = "Standard"
    sc.render.dither_intensity = 0.0
    sc.render.use_compositing = False
    sc.world = None
    if albedo:  # a uniform white world: a lone diffuse plane reflects its albedo
        sc.world = bpy.data.worlds.new("White")
        sc.world.use_nodes = True
        bg = sc.world.node_tree.nodes["Background"]
        bg.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
        bg.inputs["Strength"].default_value = 1.0
    cd = bpy.data.cameras.new("C")
    cd.type = "ORTHO"
    cd.ortho_scale = max(COLS, rows)
    cam = bpy.data.objects.new("C", cd)
    sc.collection.objects.link(cam)
    sc.camera = cam
    cam.location = (0, 0, 10)
    s = 0.45
    for k, (_, m, _sign) in enumerate(tiles):
        col, row = k % COLS, k // COLS
        me = bpy.data.meshes.new(f"M{k}")
        me.from_pydata([(-s, -s, 0), (s, -s, 0), (s, s, 0), (-s, s, 0)], [], [(0, 1, 2, 3)])
        corners = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
        uv = me.uv_layers.new(name="UVMap")
        second = me.uv_layers.new(name="Second")
        for c, (u, v) in enumerate(corners):
            uv.uv[c].vector = (u, v)
            second.uv[c].vector = (0.2 + 0.5 * v, 0.1 + 0.3 * u)
        me.color_attributes.new("Col", "BYTE_COLOR", "POINT")
        me.attributes.new("wet", "FLOAT", "POINT")
        for v in range(4):  # (looked up again: adding a layer moves the others)
            me.color_attributes["Col"].data[v].color = (0.2 + 0.2 * v, 0.9 - 0.2 * v, 0.5, 1.0)
            me.attributes["wet"].data[v].value = 0.1 + 0.25 * v
        ob = bpy.data.objects.new(f"O{k}", me)
        ob.pass_index = k % 7
        sc.collection.objects.link(ob)
        ob.location = (col - (COLS - 1) / 2, (rows - 1) / 2 - row, 0)
        ob.data.materials.append(m)
    sc.render.image_settings.file_format = "OPEN_EXR"
    sc.render.image_settings.color_depth = "32"
    images, seconds = {}, {}
    sc.render.engine = "CYCLES"
    sc.cycles.device = "CPU"
    sc.cycles.use_adaptive_sampling = False
    sc.cycles.use_denoising = False
    sc.cycles.pixel_filter_type = "BOX"
    # pixel_average: both renderers estimate the pixel's box integral (Cycles' Box filter
    # one pixel wide, ``samples`` each) instead of Cycles' pixel centre.
    sc.cycles.filter_width = 1.0 if pixel_average else 0.01
    sc.cycles.max_bounces = 1 if albedo else 0
    sc.cycles.samples = samples if pixel_average else 64 if albedo else 1
    sc.render.threads_mode = "FIXED"
    sc.render.threads = 2
    for engine in ("CYCLES", "POLYCHROME"):
        sc.render.engine = engine
        if engine == "POLYCHROME":
            sc.polychrome.samples = samples
            sc.polychrome.max_bounces = 1
        path = os.path.abspath(f"oracle_{engine.lower()}.exr")
        sc.render.filepath = path
        t0 = time.time()
        try:
            bpy.ops.render.render(write_still=True)
        except RuntimeError as e:  # the engine reported an error: Engine.last_error says which
            print("render error", e)
        seconds[engine] = time.time() - t0
        images[engine] = path if os.path.exists(path) else None
    from polychrome_blender.engine import PolychromeRenderEngine as Engine

    return tiles, rows, images, seconds, Engine.last_error, list(Engine.last_warnings or [])


def tile_values(path, tiles, rows):
    """The interior pixels of each tile (away from the plane's edges), (n, (T-2)², 3)."""
    import OpenEXR

    ch = {k: np.asarray(v.pixels, np.float64) for k, v in OpenEXR.File(path, separate_channels=True).channels().items()}
    img = np.stack([ch["R"], ch["G"], ch["B"]], -1)
    vals = []
    for k in range(len(tiles)):
        col, row = k % COLS, k // COLS
        vals.append(img[row * T + 1 : (row + 1) * T - 1, col * T + 1 : (col + 1) * T - 1].reshape(-1, 3))
    return np.array(vals)


def run(cases, samples=1, albedo=False, pixel_average=False):
    """Renders ``cases`` [(family, label, build(nt) -> socket, tolerance)] both ways and
    prints the RESULT line the test reads."""
    tiles, rows, images, seconds, error, warnings = render(cases, samples, albedo, pixel_average)
    cyc = tile_values(images["CYCLES"], tiles, rows)
    pc = tile_values(images["POLYCHROME"], tiles, rows) if images["POLYCHROME"] else np.zeros_like(cyc)
    result = []
    for k, (i, _m, sign) in enumerate(tiles):
        family, label, _, tol = cases[i]
        result.append(dict(family=family, label=label, sign=sign, tol=tol, cycles=cyc[k].tolist(), polychrome=pc[k].tolist()))
    finite = all(math.isfinite(x) for r in result for p in r["cycles"] for x in p)
    line = dict(tiles=result, seconds=seconds, error=error, warnings=warnings, cycles_finite=finite)
    print("RESULT " + json.dumps(line), flush=True)
