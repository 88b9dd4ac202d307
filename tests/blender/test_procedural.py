"""Procedural textures against Cycles, node by node: the emission oracle.

One bpy process builds a grid of small planes seen straight on by an orthographic camera,
one plane (tile) per configuration: Texture Coordinate (Object) -> Mapping -> texture ->
Emission, rendered by Cycles CPU at 1 sample per pixel. Every output socket of the node
also goes to a shader AOV, and so does the Mapping output (the exact point the texture
was evaluated at, wherever Cycles' pixel jitter put the sample) and the W input. The
test then evaluates Polychrome's textures (`_core._evaluate_procedural`) at those points
and compares every output.

Cycles picks its AVX2 kernel on CPUs that have it; that build lets the compiler fuse
multiply-adds, so it agrees with Polychrome (which follows Cycles' SSE4.2 rounding) to
float rounding: 1e-4 here, plus the few pixels that sit within rounding of a
discontinuity of the pattern (a cell border). `CYCLES_CPU_NO_AVX2=1` selects the SSE4.2
kernel, which Polychrome reproduces bit for bit in almost every pixel.
"""

import json

import numpy as np
import pytest

from .bhelper import check, run_bpy

pytestmark = pytest.mark.blender

TILE = 12  # pixels per tile side; the plane covers 0.9 of it
COLS = 16

# Blender RNA properties of each node (everything else is an input socket, named by
# title-casing the key: "detail_scale" -> "Detail Scale").
PROPS = {
    "ShaderNodeTexNoise": {"dimensions": "noise_dimensions", "noise_type": "noise_type", "normalize": "normalize"},
    "ShaderNodeTexVoronoi": {
        "dimensions": "voronoi_dimensions",
        "feature": "feature",
        "distance": "distance",
        "normalize": "normalize",
    },
    "ShaderNodeTexGradient": {"gradient_type": "gradient_type"},
    "ShaderNodeTexWave": {k: k for k in ("wave_type", "bands_direction", "rings_direction", "wave_profile")},
    "ShaderNodeTexMagic": {"turbulence_depth": "turbulence_depth"},
    "ShaderNodeTexBrick": {k: k for k in ("offset", "offset_frequency", "squash", "squash_frequency")},
    "ShaderNodeTexWhiteNoise": {"dimensions": "noise_dimensions"},
    "ShaderNodeTexChecker": {},
}


def cfg(node, params, loc=(0.0, 0.0, 0.0), rot=(0.5, 0.35, 0.2), scale=(1.0, 1.0, 1.0), w=None, family=None):
    """One tile: node, Polychrome params (Blender's defaults for the rest), the Mapping
    node's location/rotation/scale (the rotation tilts the plane through z), and W as
    w[0] * x + w[1] of the mapped point (None: W stays 0)."""
    return dict(node=node, params=params, loc=list(loc), rot=list(rot), scale=list(scale), w=w, family=family or node)


def noise_configs():
    n = "ShaderNodeTexNoise"
    out = []
    typical = {
        "FBM": dict(offset=0.0, gain=1.0),
        "MULTIFRACTAL": dict(offset=0.0, gain=1.0),
        "HYBRID_MULTIFRACTAL": dict(offset=0.8, gain=1.7),
        "RIDGED_MULTIFRACTAL": dict(offset=1.0, gain=2.0),
        "HETERO_TERRAIN": dict(offset=0.6, gain=1.0),
    }
    for i, (t, extra) in enumerate(typical.items()):
        for d, dim in enumerate(("1D", "2D", "3D", "4D")):
            k = 4 * i + d
            p = dict(
                dimensions=dim,
                noise_type=t,
                normalize=(k % 2 == 0),
                scale=3.7,
                detail=2.6 if k % 3 else 3.0,
                roughness=0.55,
                lacunarity=2.2,
                distortion=0.8 if k % 2 else 0.0,
                **extra,
            )
            out.append(cfg(n, p, loc=(0.3 * k, -0.7 * k, 0.2), w=[1.3, 0.4]))
    fbm3 = dict(dimensions="3D", noise_type="FBM")
    out += [
        cfg(n, dict(fbm3, detail=0.0)),
        cfg(n, dict(fbm3, detail=15.0, roughness=1.0)),
        cfg(n, dict(fbm3, detail=15.0, roughness=0.5, normalize=False)),
        cfg(n, dict(fbm3, roughness=0.0, detail=4.0)),
        cfg(n, dict(fbm3, lacunarity=0.0, detail=3.0)),
        cfg(n, dict(fbm3, distortion=-4.0)),
        cfg(n, dict(fbm3, scale=-2.0), loc=(-50.0, -20.0, -7.0)),
        cfg(n, dict(fbm3, scale=1.0), loc=(12345.6, -9876.5, 3000.0)),
        cfg(n, dict(fbm3, scale=1.0, detail=0.0), loc=(99999.8, 100000.1, -99999.9)),
        cfg(n, dict(fbm3, scale=1.0), loc=(2.5e6, -1.5e6, 1e6), scale=(20.0, 20.0, 20.0)),
        cfg(n, dict(dimensions="4D", noise_type="RIDGED_MULTIFRACTAL", detail=15.0, offset=1.0, gain=2.0), w=[3.0, -40.0]),
        cfg(n, dict(dimensions="1D", noise_type="MULTIFRACTAL", detail=15.0, roughness=1.0, scale=1.0), w=[9.0, -1e5]),
        cfg(n, dict(dimensions="2D", noise_type="HETERO_TERRAIN", detail=6.3, offset=-0.4, distortion=2.0)),
        cfg(n, dict(dimensions="4D", noise_type="HYBRID_MULTIFRACTAL", detail=8.5, offset=0.2, gain=4.0), w=[-2.0, 7.5]),
    ]
    return out


def voronoi_configs():
    n = "ShaderNodeTexVoronoi"
    out = []
    for i, feat in enumerate(("F1", "F2", "SMOOTH_F1", "DISTANCE_TO_EDGE", "N_SPHERE_RADIUS")):
        out.append(cfg(n, dict(dimensions="1D", feature=feat, scale=2.0), w=[2.5, -3.0 + i]))
    metrics = [("EUCLIDEAN", 0.5), ("MANHATTAN", 0.5), ("CHEBYCHEV", 0.5), ("MINKOWSKI", 0.7), ("MINKOWSKI", 3.0)]
    for d, dim in enumerate(("2D", "3D", "4D")):
        for f, feat in enumerate(("F1", "F2", "SMOOTH_F1")):
            for m, (metric, e) in enumerate(metrics):
                k = 15 * d + 5 * f + m
                p = dict(dimensions=dim, feature=feat, distance=metric, exponent=e, scale=3.0, smoothness=0.4 + 0.1 * m)
                out.append(cfg(n, p, loc=(0.4 * k, 0.1 * k, -0.3 * k), w=[0.7, 0.1 * k]))
        for feat in ("DISTANCE_TO_EDGE", "N_SPHERE_RADIUS"):
            out.append(cfg(n, dict(dimensions=dim, feature=feat, scale=3.0), loc=(1.0 + d, 2.0, 3.0), w=[1.1, 0.3]))
    fractal = dict(detail=2.5, roughness=0.6, lacunarity=2.3, normalize=True, scale=2.0)
    for dim in ("1D", "2D", "3D", "4D"):
        for feat in ("F1", "F2", "SMOOTH_F1", "DISTANCE_TO_EDGE"):
            out.append(cfg(n, dict(fractal, dimensions=dim, feature=feat), w=[1.7, 0.2]))
    v3 = dict(dimensions="3D", scale=4.0)
    out += [
        cfg(n, dict(v3, randomness=0.0)),
        cfg(n, dict(v3, randomness=0.3, feature="F2")),
        cfg(n, dict(v3, feature="SMOOTH_F1", smoothness=0.0)),
        cfg(n, dict(v3, feature="SMOOTH_F1", smoothness=1.0, distance="MANHATTAN")),
        cfg(n, dict(v3, detail=15.0, roughness=1.0, normalize=True)),
        cfg(n, dict(v3, detail=3.0, lacunarity=0.0)),
        cfg(n, dict(v3, detail=15.0, roughness=0.5, feature="DISTANCE_TO_EDGE", normalize=True)),
        cfg(n, dict(v3, randomness=0.0, feature="N_SPHERE_RADIUS")),
        cfg(n, dict(v3, scale=1.0), loc=(-4321.7, 8765.2, -1234.5)),
        cfg(n, dict(v3, scale=1.0, feature="F2"), loc=(1.5e6, 2.5e5, -3e5), scale=(10.0, 10.0, 10.0)),
        cfg(n, dict(dimensions="2D", scale=-3.0, feature="SMOOTH_F1", distance="CHEBYCHEV"), loc=(-30.0, -40.0, 0.0)),
        cfg(n, dict(dimensions="4D", scale=2.0, feature="F1", distance="MINKOWSKI", exponent=1.0, detail=1.5), w=[-3.0, -20.0]),
    ]
    return out


def other_configs():
    out = []
    c = "ShaderNodeTexChecker"
    colours = dict(color1=[0.9, 0.5, 0.1], color2=[0.05, 0.3, 0.7])
    out += [
        cfg(c, dict(colours)),
        cfg(c, dict(colours, scale=2.0), loc=(-3.0, -7.0, -1.0)),
        cfg(c, dict(colours, scale=1.0), loc=(1e6, -3e6, 2e6), scale=(1e5, 1e5, 1e5)),
    ]
    g = "ShaderNodeTexGradient"
    for t in ("LINEAR", "QUADRATIC", "EASING", "DIAGONAL", "SPHERICAL", "QUADRATIC_SPHERE", "RADIAL"):
        out.append(cfg(g, dict(gradient_type=t), loc=(0.3, 0.1, 0.0), scale=(2.4, 2.4, 2.4)))
    out.append(cfg(g, dict(gradient_type="RADIAL"), loc=(0.0, 0.0, 0.0), rot=(0.0, 0.0, 0.0), scale=(3.0, 3.0, 3.0)))
    wv = "ShaderNodeTexWave"
    k = 0
    for bands in ("X", "Y", "Z", "DIAGONAL"):
        for prof in ("SIN", "SAW", "TRI"):
            out.append(cfg(wv, dict(wave_type="BANDS", bands_direction=bands, wave_profile=prof, scale=1.3), loc=(0.2 * k, 0.0, 0.1)))
            k += 1
    for rings in ("X", "Y", "Z", "SPHERICAL"):
        out.append(cfg(wv, dict(wave_type="RINGS", rings_direction=rings, wave_profile="SAW", scale=1.7), loc=(0.2, -0.3, 0.4)))
    dist = dict(distortion=6.0, detail=3.5, detail_scale=2.0, detail_roughness=0.6, phase_offset=1.3)
    out += [
        cfg(wv, dict(dist, wave_type="BANDS", bands_direction="DIAGONAL", wave_profile="TRI")),
        cfg(wv, dict(dist, wave_type="RINGS", rings_direction="SPHERICAL", wave_profile="SIN")),
        cfg(wv, dict(dist, detail=0.0, wave_type="BANDS", wave_profile="SAW")),
        cfg(wv, dict(dist, detail=15.0, detail_roughness=1.0, wave_type="RINGS", rings_direction="Z")),
        cfg(wv, dict(scale=1.0), loc=(-1234.5, 678.9, -42.0)),
    ]
    mg = "ShaderNodeTexMagic"
    for depth in range(11):
        out.append(cfg(mg, dict(turbulence_depth=depth, distortion=1.3, scale=1.1), loc=(0.1 * depth, 0.3, 0.0)))
    out += [
        cfg(mg, dict(turbulence_depth=3, distortion=0.0)),
        cfg(mg, dict(turbulence_depth=5, scale=-2.0, distortion=-0.7), loc=(-40.0, 25.0, 9.0)),
        cfg(mg, dict(turbulence_depth=2, scale=1.0), loc=(1e5, -2e5, 3e4)),
    ]
    b = "ShaderNodeTexBrick"
    bc = dict(color1=[0.9, 0.4, 0.2], color2=[0.3, 0.6, 0.8], mortar=[0.1, 0.1, 0.05])
    out += [
        cfg(b, dict(bc)),
        cfg(b, dict(bc, mortar_smooth=0.0, mortar_size=0.05)),
        cfg(b, dict(bc, offset=0.3, offset_frequency=3, squash=0.6, squash_frequency=2, bias=0.4)),
        cfg(b, dict(bc, bias=-0.3, brick_width=0.3, row_height=0.4, mortar_smooth=0.7)),
        cfg(b, dict(bc, mortar_size=0.0)),
        cfg(b, dict(bc, scale=3.0), loc=(-7.3, -11.1, -2.0)),
        cfg(b, dict(bc, scale=1.0, squash=2.0, offset_frequency=1, squash_frequency=1), loc=(3000.0, -5000.0, 0.0)),
    ]
    wn = "ShaderNodeTexWhiteNoise"
    for dim in ("1D", "2D", "3D", "4D"):
        out.append(cfg(wn, dict(dimensions=dim), w=[1.0, 0.5]))
    out += [
        cfg(wn, dict(dimensions="3D"), loc=(-1e4, 3e7, -0.5)),
        cfg(wn, dict(dimensions="4D"), loc=(0.0, 0.0, 0.0), rot=(0.0, 0.0, 0.0), w=[0.0, -0.0]),
    ]
    return out


CONFIGS = noise_configs() + voronoi_configs() + other_configs()

BODY = """
import OpenEXR
configs = json.loads({configs!r})
PROPS = json.loads({props!r})
T, COLS = {tile}, {cols}
rows = (len(configs) + COLS - 1) // COLS
bpy.ops.wm.read_factory_settings(use_empty=True)
sc = bpy.context.scene
sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = T * COLS, T * rows, 100
sc.render.engine = 'CYCLES'; sc.cycles.device = 'CPU'; sc.cycles.samples = 1
sc.cycles.use_adaptive_sampling = False; sc.cycles.use_denoising = False
sc.cycles.pixel_filter_type = 'BOX'; sc.cycles.filter_width = 0.01; sc.cycles.max_bounces = 0
sc.render.threads_mode = 'FIXED'; sc.render.threads = 2
sc.view_settings.view_transform = 'Standard'; sc.render.use_compositing = False
sc.render.image_settings.file_format = 'OPEN_EXR_MULTILAYER'; sc.render.image_settings.color_depth = '32'
vl = sc.view_layers[0]
AOVS = [('pos', 'COLOR'), ('w', 'VALUE'), ('id', 'VALUE'), ('f0', 'VALUE'), ('f1', 'VALUE'), ('f2', 'VALUE'),
        ('c0', 'COLOR'), ('c1', 'COLOR')]
for name, typ in AOVS:
    a = vl.aovs.add(); a.name = name; a.type = typ
cd = bpy.data.cameras.new('C'); cd.type = 'ORTHO'; cd.ortho_scale = max(COLS, rows)
cam = bpy.data.objects.new('C', cd); sc.collection.objects.link(cam); sc.camera = cam
cam.location = (0, 0, 10)
def sock(node, identifier):
    # by identifier: sockets the node's current mode hides are missing from name lookups
    return next(s for s in node.inputs if s.identifier == identifier)
layout = []
for i, c in enumerate(configs):
    col, row = i % COLS, i // COLS
    s = 0.45
    me = bpy.data.meshes.new(f'M{{i}}')
    me.from_pydata([(-s, -s, 0), (s, -s, 0), (s, s, 0), (-s, s, 0)], [], [(0, 1, 2, 3)])
    ob = bpy.data.objects.new(f'O{{i}}', me); sc.collection.objects.link(ob)
    ob.location = (col - (COLS - 1) / 2, (rows - 1) / 2 - row, 0)
    m = bpy.data.materials.new(f'Mat{{i}}'); m.use_nodes = True; nt = m.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    out = nt.nodes.new('ShaderNodeOutputMaterial')
    tc = nt.nodes.new('ShaderNodeTexCoord'); mp = nt.nodes.new('ShaderNodeMapping')
    mp.inputs['Location'].default_value = c['loc']; mp.inputs['Rotation'].default_value = c['rot']
    mp.inputs['Scale'].default_value = c['scale']
    nt.links.new(tc.outputs['Object'], mp.inputs['Vector'])
    tex = nt.nodes.new(c['node'])
    props = PROPS[c['node']]
    for k, v in c['params'].items():
        if k in props:
            setattr(tex, props[k], v)
        else:
            sock(tex, k.replace('_', ' ').title()).default_value = (list(v) + [1.0]) if isinstance(v, list) else v
    nt.links.new(mp.outputs['Vector'], sock(tex, 'Vector'))
    def aov(name, sock):
        a = nt.nodes.new('ShaderNodeOutputAOV'); a.aov_name = name
        nt.links.new(sock, a.inputs['Color' if name in ('pos', 'c0', 'c1') else 'Value'])
    aov('pos', mp.outputs['Vector'])
    if c['w'] is not None and any(s.identifier == 'W' for s in tex.inputs):
        sep = nt.nodes.new('ShaderNodeSeparateXYZ'); nt.links.new(mp.outputs['Vector'], sep.inputs[0])
        ma = nt.nodes.new('ShaderNodeMath'); ma.operation = 'MULTIPLY_ADD'
        nt.links.new(sep.outputs['X'], ma.inputs[0]); ma.inputs[1].default_value = c['w'][0]
        ma.inputs[2].default_value = c['w'][1]
        nt.links.new(ma.outputs[0], sock(tex, 'W')); aov('w', ma.outputs[0])
    ident = nt.nodes.new('ShaderNodeValue'); ident.outputs[0].default_value = i + 1; aov('id', ident.outputs[0])
    # Only the outputs the node shows in its current mode: Cycles ignores links from
    # hidden ones (the linked input keeps its own default).
    shown = [o for o in tex.outputs if o.enabled]
    names = {{'f': [], 'c': []}}
    for o in shown:
        kind = 'f' if o.type == 'VALUE' else 'c'
        aov(f'{{kind}}{{len(names[kind])}}', o); names[kind].append(o.name)
    # The emission oracle: the node's first output is what the camera sees.
    em = nt.nodes.new('ShaderNodeEmission'); em.inputs['Strength'].default_value = 1.0
    nt.links.new(shown[0], em.inputs['Color']); nt.links.new(em.outputs[0], out.inputs['Surface'])
    ob.data.materials.append(m)
    layout.append(dict(floats=names['f'], colours=names['c'], emitted=shown[0].name))
sc.render.filepath = os.path.abspath('oracle.exr')
import time; t0 = time.time()
bpy.ops.render.render(write_still=True)
emit(layout=layout, exr=os.path.abspath('oracle.exr'), seconds=time.time() - t0)
"""


def render_oracle(tmp_path, env=None):
    body = BODY.format(configs=json.dumps(CONFIGS), props=json.dumps(PROPS), tile=TILE, cols=COLS)
    proc, res = run_bpy(tmp_path, body, timeout=300, env=env)
    r = check(proc, res)[0]
    with open(r["exr"] + ".layout.json", "w") as f:
        json.dump(r["layout"], f)
    import OpenEXR

    ch = {k.split(".", 1)[1]: np.asarray(v.pixels) for k, v in OpenEXR.File(r["exr"], separate_channels=True).channels().items()}
    r["channels"] = ch
    return r


def rgb(ch, name):
    return np.stack([ch[f"{name}.R"], ch[f"{name}.G"], ch[f"{name}.B"]], -1)


def compare(oracle, core):
    """Per configuration and output: Cycles' value, Polychrome's, and whether the
    pixel sits next to a discontinuity of the pattern (ours jumps within 1e-4 relative
    of the point)."""
    ch = oracle["channels"]
    ids = np.rint(ch["id.X"]).astype(int)
    pos, wv = rgb(ch, "pos"), ch["w.X"]
    rows = []
    for i, (c, lay) in enumerate(zip(CONFIGS, oracle["layout"])):
        m = ids == i + 1
        p = pos[m].astype(np.float32)
        w = wv[m].astype(np.float32)
        params = json.dumps(c["params"])
        ours = core._evaluate_procedural(c["node"], params, p, w)
        # Discontinuity probe: ours at points nudged by a few ulps of the coordinates.
        step = np.maximum(np.abs(p), 1.0) * 2.0**-20
        nudged = [
            core._evaluate_procedural(
                c["node"], params, (p + s * step * d).astype(np.float32), (w + s * 2.0**-20 * np.maximum(np.abs(w), 1)).astype(np.float32)
            )
            for d in np.eye(3, dtype=np.float32)
            for s in (-1.0, 1.0)
        ]
        emitted = rgb(ch, "Combined")[m]
        for kind, names in (("f", lay["floats"]), ("c", lay["colours"])):
            for j, name in enumerate(names):
                theirs = ch[f"{kind}{j}.X"][m] if kind == "f" else rgb(ch, f"c{j}")[m]
                mine = ours[name]
                jump = np.max([np.abs(n[name] - mine) for n in nudged], axis=0)
                if kind == "c":
                    jump = jump.max(-1)
                rows.append(dict(i=i, config=c, output=name, theirs=theirs, ours=mine, jump=jump))
                if name == lay["emitted"]:
                    # a float output is emitted as grey
                    aov = np.repeat(theirs[:, None], 3, 1) if kind == "f" else theirs
                    rows.append(dict(i=i, config=c, output="Combined", theirs=emitted, ours=aov, jump=np.zeros(len(p))))
    return rows


def summarize(rows, tol):
    """Failures: outputs off by more than `tol` (relative above 1) plus what a nudge of a
    few ulps does to the pattern there (cell borders, and fractals so fine that rounding
    is amplified). Where Cycles itself gives NaN or infinity, Polychrome must give 0."""
    bad = []
    for r in rows:
        theirs, ours = r["theirs"], r["ours"]
        finite = np.isfinite(theirs)
        err = np.where(finite, np.abs(ours - np.where(finite, theirs, 0)), np.abs(ours))
        scale = np.where(finite, np.maximum(1.0, np.abs(np.where(finite, theirs, 0))), np.inf)
        if err.ndim == 2:
            err, scale, finite = err.max(-1), scale.max(-1), finite.all(-1)
        bound = np.where(finite, tol * scale + r["jump"], 0.0)
        over = err > bound
        if over.any():
            k = int(np.argmax(err - bound))
            bad.append(
                f"tile {r['i']} {r['config']['node']} {r['config']['params']} {r['output']}: "
                f"{int(over.sum())}/{len(err)} pixels off, worst {float(err[k]):.3g} (allowed {float(bound[k]):.3g})"
            )
    return bad


def render_and_compare(tmp_path_factory, name, **env):
    import os

    from polychrome import _core

    return compare(render_oracle(tmp_path_factory.mktemp(name), env=dict(os.environ, **env)), _core)


@pytest.fixture(scope="module")
def rows(tmp_path_factory):
    """Cycles' default CPU kernel (AVX2 where the CPU has it)."""
    return render_and_compare(tmp_path_factory, "procedural")


@pytest.fixture(scope="module")
def sse_rows(tmp_path_factory):
    """Cycles' SSE4.2 CPU kernel."""
    return render_and_compare(tmp_path_factory, "procedural_sse", CYCLES_CPU_NO_AVX2="1")


FAMILIES = sorted(PROPS)


@pytest.mark.parametrize("family", FAMILIES)
def test_texture_matches_cycles(rows, family):
    mine = [r for r in rows if r["config"]["family"] == family and r["output"] != "Combined"]
    assert mine, family
    # every tile got its pixels, so a material that failed to build cannot pass silently
    for r in mine:
        assert len(r["theirs"]) >= 0.6 * (0.9 * TILE) ** 2, (r["i"], len(r["theirs"]))
    bad = summarize(mine, 1e-4)
    assert not bad, "\n".join(bad)


def test_emission_is_the_first_colour_output(rows):
    emitted = [r for r in rows if r["output"] == "Combined"]
    assert len(emitted) == len(CONFIGS)
    for r in emitted:
        assert np.array_equal(r["ours"], r["theirs"]), r["config"]


@pytest.mark.parametrize("family", FAMILIES)
def test_sse42_kernel_is_reproduced_bit_for_bit(sse_rows, family):
    """Cycles' SSE4.2 kernel has no fused multiply-adds, and Polychrome follows its
    operation order: the values are identical, not just close (measured: every pixel of
    every tile; the assertion leaves room for a compiler that rounds one op differently)."""
    mine = [r for r in sse_rows if r["config"]["family"] == family and r["output"] != "Combined"]
    finite = [r for r in mine if np.isfinite(r["theirs"]).all()]
    exact = np.concatenate([(lambda e: e.all(-1) if e.ndim == 2 else e)(r["ours"] == r["theirs"]) for r in finite])
    assert exact.mean() >= 0.999, f"{family}: {exact.mean():.5f} of the values are bit-identical"
    bad = summarize(mine, 1e-6)
    assert not bad, "\n".join(bad)
