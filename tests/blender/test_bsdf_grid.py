"""Every Blender BSDF feature against Cycles CPU (issue 14): a grid of spheres, one shading
feature each, under a uniform white world and a sun, seen by an orthographic camera from
above, rendered by Cycles CPU and by Polychrome through the add-on in the same bpy
process (one subprocess for the whole grid). Each sphere is compared on 4×4-pixel blocks
(blocks whose centre lies well inside the sphere's disc) by mean CIEDE2000; the bar is
1.5. Features Polychrome does not match yet are xfail with the measured number.

Cycles renders with a one-pixel box filter, which is Polychrome's pixel filter (uniform
jitter over the pixel): with a point-like filter (width 0.01) the sun's sub-pixel
reflection in a smooth coat or glossy lobe fills a whole pixel at its full radiance in
Cycles (about 50 times its box average), and that one 4×4 block dominated the coat's
mean ΔE00 (4.7 with the point filter, 1.3 with the box)."""

import pytest

from .bhelper import check, run_bpy

pytestmark = pytest.mark.blender

CELL = 24  # pixels per grid cell; the sphere's diameter is 0.8 of it
COLS = 5
SPP = 256  # 128 until the subsurface walk: its noise in both renderers alone gave 1.49-1.65 there
BAR = 1.5

# name: (node type, {input: value}[, {Tangent node props}]); Principled spheres start from
# Blender's default node; a third entry links a Tangent node to the Tangent input.
FEATURES = {
    "principled_default": ("ShaderNodeBsdfPrincipled", {}),
    "coat": (
        "ShaderNodeBsdfPrincipled",
        {
            "Base Color": (0.1, 0.3, 0.7),
            "Roughness": 0.6,
            "Coat Weight": 1.0,
            "Coat Roughness": 0.05,
            "Coat IOR": 1.5,
            "Coat Tint": (0.9, 0.7, 0.4),
        },
    ),
    "sheen": (
        "ShaderNodeBsdfPrincipled",
        {"Base Color": (0.2, 0.05, 0.05), "Sheen Weight": 1.0, "Sheen Roughness": 0.5, "Sheen Tint": (1.0, 1.0, 1.0)},
    ),
    "anisotropic_metal": (
        "ShaderNodeBsdfPrincipled",
        {"Base Color": (0.9, 0.9, 0.9), "Metallic": 1.0, "Roughness": 0.4, "Anisotropic": 0.8},
    ),
    "anisotropic_tangent_x": (
        "ShaderNodeBsdfPrincipled",
        {"Base Color": (0.9, 0.6, 0.3), "Metallic": 1.0, "Roughness": 0.4, "Anisotropic": 0.8},
        {"direction_type": "RADIAL", "axis": "X"},
    ),
    "anisotropic_tangent_uv": (
        "ShaderNodeBsdfPrincipled",
        {"Base Color": (0.6, 0.7, 0.9), "Metallic": 1.0, "Roughness": 0.4, "Anisotropic": 0.8, "Anisotropic Rotation": 0.125},
        {"direction_type": "UV_MAP", "uv_map": "UVMap"},
    ),
    "anisotropic_glossy": (
        "ShaderNodeBsdfAnisotropic",
        {"Color": (0.9, 0.7, 0.5), "Roughness": 0.3, "Anisotropy": 0.7, "Rotation": 0.1},
    ),
    "alpha": ("ShaderNodeBsdfPrincipled", {"Base Color": (0.8, 0.2, 0.2), "Alpha": 0.35}),
    "rough_glass": ("ShaderNodeBsdfPrincipled", {"Transmission Weight": 1.0, "Roughness": 0.5}),
    "diffuse_roughness": ("ShaderNodeBsdfPrincipled", {"Diffuse Roughness": 1.0}),
    "specular_tint": (
        "ShaderNodeBsdfPrincipled",
        {"Base Color": (0.02, 0.02, 0.02), "Roughness": 0.2, "Specular Tint": (1.0, 0.3, 0.1)},
    ),
    "subsurface": (
        "ShaderNodeBsdfPrincipled",
        {"Base Color": (0.8, 0.5, 0.4), "Subsurface Weight": 1.0, "Subsurface Scale": 0.1},
    ),
    "translucent_bsdf": ("ShaderNodeBsdfTranslucent", {"Color": (0.8, 0.8, 0.3)}),
    "transparent_bsdf": ("ShaderNodeBsdfTransparent", {"Color": (0.9, 0.5, 0.2)}),
    "transparent_white": ("ShaderNodeBsdfTransparent", {"Color": (1.0, 1.0, 1.0)}),
    "sheen_bsdf": ("ShaderNodeBsdfSheen", {"Color": (0.8, 0.3, 0.3), "Roughness": 0.5}),
    "tinted_glass": ("ShaderNodeBsdfGlass", {"Color": (0.9, 0.5, 0.2), "Roughness": 0.0}),
    "refraction_bsdf": ("ShaderNodeBsdfRefraction", {"Roughness": 0.1}),
    "refraction_rough_tinted": ("ShaderNodeBsdfRefraction", {"Roughness": 0.5, "IOR": 1.33, "Color": (0.9, 0.8, 0.7)}),
    "holdout": ("ShaderNodeHoldout", {}),
    # Metallic BSDF (Blender 4.3+): F82 Tint (the default) and Physical Conductor (a
    # gold-like RGB index); ".name" keys set node properties.
    "metallic_bsdf_f82": (
        "ShaderNodeBsdfMetallic",
        {"Base Color": (0.9, 0.6, 0.3), "Edge Tint": (0.95, 0.85, 0.6), "Roughness": 0.35},
    ),
    "metallic_bsdf_physical": (
        "ShaderNodeBsdfMetallic",
        {".fresnel_type": "PHYSICAL_CONDUCTOR", "IOR": (0.18, 0.42, 1.37), "Extinction": (3.42, 2.35, 1.77), "Roughness": 0.35},
    ),
}

# Measured mean ΔE00 of the features that do not match Cycles yet (at 128 spp unless said; the grid
# renders 256 since the subsurface walk, which moved the others by noise only, e.g. coat 0.74 -> 1.05).
# Before stochastic transparency: alpha 12.4, transparent_bsdf 59.2, transparent_white 100;
# before the Glass colour tinted the whole closure: tinted_glass 5.7; before the Principled
# layers: coat 19.1, sheen 7.5; before the Specular Tint on the dielectric layer: 10.0;
# before the Principled's Oren–Nayar base: diffuse_roughness 1.2 (warned); before rough glass's
# multiple scattering and the Principled's √(base colour) transmission tint: rough_glass 7.9
# (0.69 after, 128 spp); before suns were hittable by BSDF rays (MIS with light sampling): coat 1.55
# (the sun's reflection in the near-smooth coat one noisy block), 1.12 after (with the light sample
# leaving out the uniform world; 1.95 without that, from one pixel of BSDF-sampled hits of the sun's
# disk; 0.70 at 512 spp). Before anisotropic GGX: anisotropic_metal 2.8 (warned), 0.85 after. Before the
# subsurface random walk (a diffuse of the base colour, warned): subsurface 2.7; after, 1.49-1.65 at 128 spp
# (the sphere's place in the grid), 1.10 at 256, 0.79 at 512: noise of both walks (Polychrome's own,
# two seeds at 128 spp: 1.30), the means within 1 %.
XFAIL = {
    "translucent_bsdf": "Translucent BSDF borderline: dE00 1.26-1.52 between runs",
    # Inherent to spectral rendering, not a bug (test_tint_passed_twice_is_the_spectral_square):
    # the ray crosses the sphere's two faces, each tinting it. Cycles multiplies the RGB
    # twice, c² = (0.81, 0.25, 0.04); Polychrome multiplies the uplifted spectrum s(λ)
    # twice, and RGB(s²) = (0.788, 0.243, 0.027) with the default Linear uplift: dE00 1.61
    # between the two closed forms (3.38 with the Smooth uplift, whose s is more saturated).
    "transparent_bsdf": "tint passed twice: Cycles squares the RGB, Polychrome the uplifted spectrum, "
    "RGB(s²) vs RGB²: dE00 1.61 in closed form, 1.61 measured",
    "tinted_glass": "the tint squared spectrally (as transparent_bsdf: 1.61 in closed form for the light "
    "through both faces): dE00 3.22 at 128 spp, 2.54 at 256, where Cycles' own mean is high by fireflies (R "
    "0.884 at 128 spp, 0.842 at 256, 0.808 at 512; Polychrome 0.784); 1.52 at 512 spp, as without the sun (1.52)",
}

SCRIPT = """
features = json.loads(FEATURES_JSON)
CELL, COLS, SPP = {cell}, {cols}, {spp}
names = list(features)
rows = (len(names) + COLS - 1) // COLS
sc = empty_scene(CELL * COLS, CELL * rows)
sc.render.dither_intensity = 0.0
sc.render.use_compositing = False
w = bpy.data.worlds.new('White'); w.use_nodes = True; sc.world = w
bg = w.node_tree.nodes['Background']; bg.inputs['Color'].default_value = (1, 1, 1, 1); bg.inputs['Strength'].default_value = 1.0
sd = bpy.data.lights.new('Sun', 'SUN'); sd.energy = 2.0; sd.angle = math.radians(2.0)
so = bpy.data.objects.new('Sun', sd); sc.collection.objects.link(so); so.rotation_euler = (math.radians(35), 0, math.radians(30))
cd = bpy.data.cameras.new('Camera'); cd.type = 'ORTHO'; cd.ortho_scale = float(COLS)
co = bpy.data.objects.new('Camera', cd); sc.collection.objects.link(co); sc.camera = co; co.location = (0, 0, 10)
for k, name in enumerate(names):
    kind, inputs = features[name][:2]
    m = bpy.data.materials.new(name); m.use_nodes = True; nt = m.node_tree
    for n in list(nt.nodes):
        if n.type != 'OUTPUT_MATERIAL': nt.nodes.remove(n)
    if kind == 'MIX_HOLDOUT':   # Mix Shader (Fac) of a Holdout and a Diffuse BSDF (Color)
        node = nt.nodes.new('ShaderNodeMixShader'); node.inputs['Fac'].default_value = inputs['Fac']
        d = nt.nodes.new('ShaderNodeBsdfDiffuse'); d.inputs['Color'].default_value = (*inputs['Color'], 1.0)
        nt.links.new(nt.nodes.new('ShaderNodeHoldout').outputs[0], node.inputs[1]); nt.links.new(d.outputs[0], node.inputs[2])
    else:
        node = nt.nodes.new(kind)
        for key, v in inputs.items():
            if key.startswith('.'):
                setattr(node, key[1:], v); continue
            s = node.inputs[key]
            s.default_value = (*v, 1.0) if isinstance(v, list) and s.type == 'RGBA' else v
    nt.links.new(node.outputs[0], nt.nodes['Material Output'].inputs['Surface'])
    if len(features[name]) > 2:
        tn = nt.nodes.new('ShaderNodeTangent')
        for key, v in features[name][2].items():
            setattr(tn, key, v)
        nt.links.new(tn.outputs['Tangent'], node.inputs['Tangent'])
    col, row = k % COLS, k // COLS
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.4, location=(col - (COLS - 1) / 2, (rows - 1) / 2 - row, 0), segments=48, ring_count=24)
    bpy.ops.object.shade_smooth()
    bpy.context.object.data.materials.append(m)
sc.render.image_settings.file_format = 'OPEN_EXR'; sc.render.image_settings.color_depth = '32'
sc.render.film_transparent = {transparent}
sc.render.engine = 'CYCLES'
c = sc.cycles; c.device = 'CPU'; c.samples = SPP; c.use_denoising = False; c.use_adaptive_sampling = False
c.pixel_filter_type = 'BOX'; c.filter_width = 1.0; c.max_bounces = 16; c.diffuse_bounces = 16; c.glossy_bounces = 16; c.transmission_bounces = 16
c.transparent_max_bounces = 16; c.blur_glossy = 0.0; c.sample_clamp_indirect = 0.0; c.sample_clamp_direct = 0.0
c.caustics_reflective = True; c.caustics_refractive = True
sc.render.threads_mode = 'FIXED'; sc.render.threads = 2
sc.render.filepath = os.path.abspath('cycles.exr'); bpy.ops.render.render(write_still=True)
sc.render.engine = 'POLYCHROME'
sc.polychrome.samples = SPP; sc.polychrome.max_bounces = 16
sc.render.filepath = os.path.abspath('poly.exr'); bpy.ops.render.render(write_still=True)
import polychrome.colordiff as cdiff
def load(p):
    ch = exr_channels(p)
    h = sc.render.resolution_y
    return np.stack([ch[k] for k in 'RGBA'], -1).reshape(h, -1, 4)   # row 0 = top (EXR order)
A, B = load('cycles.exr'), load('poly.exr')
out = {{}}
nb = CELL // 4
yy, xx = np.mgrid[0:nb, 0:nb]
inside = np.hypot((yy + 0.5) * 4 - CELL / 2, (xx + 0.5) * 4 - CELL / 2) < 0.8 * 0.4 * CELL
for k, name in enumerate(names):
    col, row = k % COLS, k // COLS
    a = A[row * CELL:(row + 1) * CELL, col * CELL:(col + 1) * CELL]
    b = B[row * CELL:(row + 1) * CELL, col * CELL:(col + 1) * CELL]
    a = a.reshape(nb, 4, nb, 4, 4).mean(axis=(1, 3))[inside]; b = b.reshape(nb, 4, nb, 4, 4).mean(axis=(1, 3))[inside]
    de = cdiff.image_delta_e(a[None, :, :3], b[None, :, :3], white_luminance=1.0)
    out[name] = dict(de=float(de.mean()), cycles=a[:, :4].mean(axis=0).tolist(), polychrome=b[:, :4].mean(axis=0).tolist())
emit(spheres=out, err=Engine.last_error, warn=list(Engine.last_warnings or []))
"""


@pytest.fixture(scope="module")
def grid(tmp_path_factory):
    import json

    tmp = tmp_path_factory.mktemp("bsdf_grid")
    body = f"FEATURES_JSON = {json.dumps(json.dumps(FEATURES))!s}\n" + SCRIPT.format(cell=CELL, cols=COLS, spp=SPP, transparent=False)
    proc, res = run_bpy(tmp, body, timeout=900)
    r = check(proc, res)[0]
    print("BSDF grid vs Cycles:")
    for k, v in r["spheres"].items():
        print(f"  {k:20s} dE00 {v['de']:6.2f}  cycles {v['cycles']}  polychrome {v['polychrome']}")
    print("warnings:", r["warn"])
    return r


@pytest.mark.parametrize(
    "feature",
    [pytest.param(f, marks=pytest.mark.xfail(reason=XFAIL[f], strict=False)) if f in XFAIL else f for f in FEATURES],
)
def test_sphere_matches_cycles(grid, feature):
    assert grid["err"] is None, grid["err"]
    s = grid["spheres"][feature]
    assert s["de"] < BAR, s
    if feature == "holdout":  # Combined alpha 0 where the holdout is
        assert s["polychrome"][3] == pytest.approx(s["cycles"][3], abs=0.05), s
    ours = [w for w in grid["warn"] if f"'{feature}'" in w]
    assert ours == [], ours


# Film > Transparent (Cycles' integrate_surface_holdout and transparent background): a
# Holdout, a Mix Shader of a Holdout and a Diffuse at Fac 0.3 and 0.5 (holdout weight 0.7,
# 0.5), a Diffuse; Combined's alpha (mean over each sphere's inner blocks) vs Cycles'.
TRANSPARENT = {
    "holdout": ("ShaderNodeHoldout", {}),
    "mix_holdout_0.3": ("MIX_HOLDOUT", {"Fac": 0.3, "Color": (0.8, 0.3, 0.2)}),
    "mix_holdout_0.5": ("MIX_HOLDOUT", {"Fac": 0.5, "Color": (0.8, 0.3, 0.2)}),
    "diffuse": ("ShaderNodeBsdfDiffuse", {"Color": (0.8, 0.3, 0.2)}),
}


@pytest.fixture(scope="module")
def transparent_film(tmp_path_factory):
    import json

    tmp = tmp_path_factory.mktemp("bsdf_grid_transparent")
    body = f"FEATURES_JSON = {json.dumps(json.dumps(TRANSPARENT))!s}\n" + SCRIPT.format(
        cell=CELL, cols=len(TRANSPARENT), spp=32, transparent=True
    )
    proc, res = run_bpy(tmp, body, timeout=600)
    r = check(proc, res)[0]
    print("Film > Transparent vs Cycles:")
    for k, v in r["spheres"].items():
        print(f"  {k:20s} dE00 {v['de']:6.2f}  cycles {v['cycles']}  polychrome {v['polychrome']}")
    print("warnings:", r["warn"])
    return r


@pytest.mark.parametrize("feature", list(TRANSPARENT))
def test_holdout_alpha_with_a_transparent_film_matches_cycles(transparent_film, feature):
    assert transparent_film["err"] is None, transparent_film["err"]
    s = transparent_film["spheres"][feature]
    # Cycles' alpha on the sphere: 0 (holdout), 1 − weight (mixes), 1 (diffuse).
    assert s["polychrome"][3] == pytest.approx(s["cycles"][3], abs=0.02), s
    assert s["de"] < BAR, s
    assert [w for w in transparent_film["warn"] if f"'{feature}'" in w] == []


def _spectral_square(color):
    """RGB of the uplifted spectrum s(λ) squared, under the white world (the white
    illuminant's spectrum W, RGB(W) = 1), with the core's default uplift and grid as the
    add-on leaves them: the colour a ray tinted by s at two faces carries."""
    import json

    import numpy as np

    from polychrome import _core, spectra

    settings = json.dumps({})
    wl = np.asarray(_core.wavelength_grid(settings), dtype=np.float64)[0]

    def up(c, role):
        return np.asarray(_core.uplift(np.array([c], np.float32), role, settings), np.float64)[0]

    w, s = up([1.0, 1.0, 1.0], "illuminant"), up(list(color), "reflectance")

    def rgb(spectrum):
        return np.array(spectra.rec709(spectra.tabulated(wl.tolist(), (w * spectrum).tolist())))

    return rgb(s * s) / rgb(np.ones_like(s))


def test_tint_passed_twice_is_the_spectral_square(grid):
    """transparent_bsdf's gap to Cycles is inherent: through the sphere (straight on to the
    white world, no noise) Cycles' colour is the tint's RGB squared and Polychrome's is
    the RGB of its uplifted spectrum squared, each within 0.005 of its closed form; the
    two closed forms are 1.61 apart in dE00."""
    import numpy as np

    import polychrome.colordiff as cdiff

    s = grid["spheres"]["transparent_bsdf"]
    c = np.array(FEATURES["transparent_bsdf"][1]["Color"])
    expected = _spectral_square(c)
    assert np.allclose(s["cycles"][:3], c * c, atol=5e-3), (s, c * c)
    assert np.allclose(s["polychrome"][:3], expected, atol=5e-3), (s, expected)
    de = float(cdiff.image_delta_e((c * c)[None, None], expected[None, None], white_luminance=1.0).mean())
    assert de == pytest.approx(s["de"], abs=0.1), (de, s["de"])
