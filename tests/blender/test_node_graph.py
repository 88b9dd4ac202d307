"""The node-tree exporter (export/node_graph.py): Blender material node trees → the flat
graph of docs/shading.md. One bpy process builds every case and exports it; the checks
compare the export with what Blender itself says (sockets, curve evaluation, images)."""

import numpy as np
import pytest

from .bhelper import check, run_bpy

pytestmark = pytest.mark.blender

SCRIPT = r"""
from polychrome_blender.export.node_graph import export_graph
from polychrome_blender.export.textures import TextureCache
from polychrome_blender.export.warnings import Warnings
import polychrome as pc

def new_mat(name):
    m = bpy.data.materials.new(name); m.use_nodes = True
    nt = m.node_tree
    for n in list(nt.nodes):
        if n.type != 'OUTPUT_MATERIAL': nt.nodes.remove(n)
    return m, nt, nt.nodes['Material Output']

def plain(v):
    if isinstance(v, pc.Texture):
        return {'texture': v.name, 'shape': list(v.pixels.shape), 'encoding': v.encoding, 'dtype': str(v.pixels.dtype),
                'pixels': v.pixels.astype(float).ravel().tolist()}
    if isinstance(v, dict): return {k: plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)): return [plain(x) for x in v]
    return v

def run(m):
    w = Warnings()
    try:
        got = export_graph(m, w, TextureCache())
    except ValueError as e:
        return {'error': str(e), 'warnings': w.messages}
    if got is None:
        return {'none': True, 'warnings': w.messages}
    nodes, output, needs = got
    return {'nodes': plain(nodes), 'output': output, 'needs': sorted(map(list, needs)), 'warnings': w.messages}

out = {}

# 1. nested groups: Inner(x) = x + 1 (x defaults to 0.25); Outer(y) = Inner(y) with y defaulting to 0.5
inner = bpy.data.node_groups.new('Inner', 'ShaderNodeTree')
s = inner.interface.new_socket('x', in_out='INPUT', socket_type='NodeSocketFloat'); s.default_value = 0.25
inner.interface.new_socket('r', in_out='OUTPUT', socket_type='NodeSocketFloat')
gi, go = inner.nodes.new('NodeGroupInput'), inner.nodes.new('NodeGroupOutput')
add = inner.nodes.new('ShaderNodeMath'); add.name = 'Add'; add.operation = 'ADD'; add.inputs[1].default_value = 1.0
inner.links.new(gi.outputs['x'], add.inputs[0]); inner.links.new(add.outputs[0], go.inputs['r'])
outer = bpy.data.node_groups.new('Outer', 'ShaderNodeTree')
s = outer.interface.new_socket('y', in_out='INPUT', socket_type='NodeSocketFloat'); s.default_value = 0.5
outer.interface.new_socket('z', in_out='OUTPUT', socket_type='NodeSocketFloat')
gi, go = outer.nodes.new('NodeGroupInput'), outer.nodes.new('NodeGroupOutput')
rr = outer.nodes.new('NodeReroute')
g = outer.nodes.new('ShaderNodeGroup'); g.name = 'InnerNode'; g.node_tree = inner
outer.links.new(gi.outputs['y'], rr.inputs[0]); outer.links.new(rr.outputs[0], g.inputs['x']); outer.links.new(g.outputs['r'], go.inputs['z'])
m, nt, mo = new_mat('Groups')
val = nt.nodes.new('ShaderNodeValue'); val.name = 'Val'; val.outputs[0].default_value = 3.0
g1 = nt.nodes.new('ShaderNodeGroup'); g1.name = 'G1'; g1.node_tree = outer
g2 = nt.nodes.new('ShaderNodeGroup'); g2.name = 'G2'; g2.node_tree = outer   # input left at its default
g2.inputs['y'].default_value = 0.75
nt.links.new(val.outputs[0], g1.inputs['y'])
mix = nt.nodes.new('ShaderNodeMixShader'); e1 = nt.nodes.new('ShaderNodeEmission'); e2 = nt.nodes.new('ShaderNodeEmission')
e1.name, e2.name = 'E1', 'E2'
nt.links.new(g1.outputs['z'], e1.inputs['Strength']); nt.links.new(g2.outputs['z'], e2.inputs['Strength'])
nt.links.new(e1.outputs[0], mix.inputs[1]); nt.links.new(e2.outputs[0], mix.inputs[2])
nt.links.new(mix.outputs[0], mo.inputs['Surface'])
unused = nt.nodes.new('ShaderNodeTexNoise')   # not reachable: not exported
out['groups'] = run(m)
# a closure through a group: Shader in -> Add Shader with an inner emission -> Shader out
sg = bpy.data.node_groups.new('ShaderGroup', 'ShaderNodeTree')
sg.interface.new_socket('s', in_out='INPUT', socket_type='NodeSocketShader')
sg.interface.new_socket('o', in_out='OUTPUT', socket_type='NodeSocketShader')
gi, go = sg.nodes.new('NodeGroupInput'), sg.nodes.new('NodeGroupOutput')
ad = sg.nodes.new('ShaderNodeAddShader'); ad.name = 'InnerAdd'; ie = sg.nodes.new('ShaderNodeEmission'); ie.name = 'InnerEm'
sg.links.new(gi.outputs['s'], ad.inputs[0]); sg.links.new(ie.outputs[0], ad.inputs[1]); sg.links.new(ad.outputs[0], go.inputs['o'])
m, nt, mo = new_mat('ShaderThroughGroup')
d = nt.nodes.new('ShaderNodeBsdfDiffuse'); d.name = 'Outer'
g = nt.nodes.new('ShaderNodeGroup'); g.name = 'SG'; g.node_tree = sg
nt.links.new(d.outputs[0], g.inputs['s']); nt.links.new(g.outputs['o'], mo.inputs['Surface'])
out['shader_group'] = run(m)

# 2. reroutes, frames, muted nodes
m, nt, mo = new_mat('Muted')
frame = nt.nodes.new('NodeFrame')
rgb = nt.nodes.new('ShaderNodeRGB'); rgb.name = 'Col'; rgb.outputs[0].default_value = (0.1, 0.2, 0.3, 1.0); rgb.parent = frame
r1, r2 = nt.nodes.new('NodeReroute'), nt.nodes.new('NodeReroute')
inv = nt.nodes.new('ShaderNodeInvert'); inv.name = 'MutedInvert'; inv.mute = True
em = nt.nodes.new('ShaderNodeEmission')
nt.links.new(rgb.outputs[0], r1.inputs[0]); nt.links.new(r1.outputs[0], r2.inputs[0]); nt.links.new(r2.outputs[0], inv.inputs['Color'])
nt.links.new(inv.outputs[0], em.inputs['Color'])
val = nt.nodes.new('ShaderNodeValue'); val.name = 'V'; val.outputs[0].default_value = 2.0
mth = nt.nodes.new('ShaderNodeMath'); mth.name = 'MutedMath'; mth.mute = True; mth.operation = 'MULTIPLY'
nt.links.new(val.outputs[0], mth.inputs[1])   # Blender passes the first LINKED input through
mth.inputs[0].default_value = 0.625
mx = nt.nodes.new('ShaderNodeMix'); mx.name = 'MutedMix'; mx.data_type = 'RGBA'; mx.mute = True
mx.inputs['A'].default_value = (0.2, 0.4, 0.6, 1.0)
for s in mx.inputs:
    if s.identifier == 'A_Color': s.default_value = (0.2, 0.4, 0.6, 1.0)
tc = nt.nodes.new('ShaderNodeTexChecker'); tc.name = 'Checker'
nt.links.new(mx.outputs[2], tc.inputs['Color1'])
nt.links.new(mth.outputs[0], em.inputs['Strength'])
add = nt.nodes.new('ShaderNodeAddShader'); e2 = nt.nodes.new('ShaderNodeEmission'); e2.name = 'E2'
nt.links.new(tc.outputs['Color'], e2.inputs['Color'])
nt.links.new(em.outputs[0], add.inputs[0]); nt.links.new(e2.outputs[0], add.inputs[1]); nt.links.new(add.outputs[0], mo.inputs['Surface'])
out['muted'] = run(m)
out['muted_links'] = [[l.from_socket.identifier, l.to_socket.identifier] for l in mth.internal_links]

# 3. a cycle
m, nt, mo = new_mat('Cyclic')
a, b = nt.nodes.new('ShaderNodeMath'), nt.nodes.new('ShaderNodeMath'); a.name, b.name = 'A', 'B'
nt.links.new(a.outputs[0], b.inputs[0]); nt.links.new(b.outputs[0], a.inputs[0])
em = nt.nodes.new('ShaderNodeEmission'); nt.links.new(b.outputs[0], em.inputs['Strength']); nt.links.new(em.outputs[0], mo.inputs['Surface'])
out['cycle'] = run(m)

# 4. a group without a Group Output
broken = bpy.data.node_groups.new('NoOutput', 'ShaderNodeTree')
broken.interface.new_socket('o', in_out='OUTPUT', socket_type='NodeSocketColor')
m, nt, mo = new_mat('Broken')
g = nt.nodes.new('ShaderNodeGroup'); g.node_tree = broken; em = nt.nodes.new('ShaderNodeEmission')
nt.links.new(g.outputs[0], em.inputs['Color']); nt.links.new(em.outputs[0], mo.inputs['Surface'])
out['no_output'] = run(m)

# 5. an unsupported node used twice, and an unsupported closure
m, nt, mo = new_mat('Unknown')
sky = nt.nodes.new('ShaderNodeTexSky'); sky.name = 'Sky'
out['sky_default'] = list(sky.outputs[0].default_value)
p = nt.nodes.new('ShaderNodeBsdfPrincipled')
nt.links.new(sky.outputs[0], p.inputs['Base Color']); nt.links.new(sky.outputs[0], p.inputs['Emission Color'])
toon = nt.nodes.new('ShaderNodeBsdfToon'); toon.name = 'Toon'
add = nt.nodes.new('ShaderNodeAddShader')
nt.links.new(p.outputs[0], add.inputs[0]); nt.links.new(toon.outputs[0], add.inputs[1]); nt.links.new(add.outputs[0], mo.inputs['Surface'])
out['unknown'] = run(m)

# 6. Color Ramp, RGB Curves, Float Curve, Vector Curves
m, nt, mo = new_mat('Tables')
ramp = nt.nodes.new('ShaderNodeValToRGB'); cr = ramp.color_ramp
cr.interpolation = 'EASE'; cr.elements[0].position = 0.2; cr.elements[0].color = (1, 0, 0, 1)
el = cr.elements.new(0.6); el.color = (0, 1, 0, 0.5); cr.elements[2].color = (0, 0, 1, 1)
curves = nt.nodes.new('ShaderNodeRGBCurve'); cm = curves.mapping
cm.curves[3].points.new(0.25, 0.6); cm.curves[0].points[1].location = (0.9, 0.7); cm.curves[1].points[0].location = (-0.2, 0.1)
cm.extend = 'HORIZONTAL'; cm.update()
fc = nt.nodes.new('ShaderNodeFloatCurve'); fm = fc.mapping; fm.curves[0].points[0].location = (-1.0, 0.0); fm.curves[0].points[1].location = (2.0, 1.0)
fm.curves[0].points.new(0.5, 0.9); fm.update()
vc = nt.nodes.new('ShaderNodeVectorCurve')
nt.links.new(ramp.outputs['Color'], curves.inputs['Color'])
nt.links.new(fc.outputs[0], ramp.inputs['Fac'])
nt.links.new(vc.outputs[0], fc.inputs['Value'])
em = nt.nodes.new('ShaderNodeEmission'); nt.links.new(curves.outputs[0], em.inputs['Color']); nt.links.new(em.outputs[0], mo.inputs['Surface'])
out['tables'] = run(m)
cm.initialize(); fm.initialize()
probe = [-0.2 + 1.2 * i / 255 for i in (0, 37, 128, 255)]
out['rgb_probe'] = [[cm.evaluate(cm.curves[k], t) for t in probe] for k in (3, 0, 1, 2)]
out['float_probe'] = [fm.evaluate(fm.curves[0], -1.0 + 3.0 * i / 255) for i in (0, 37, 128, 255)]

# 7. Polychrome's own nodes, a colour on a closure input, NaN
m, nt, mo = new_mat('Spectral')
sr = nt.nodes.new('PolychromeSpectralReflectanceNode'); sr.mode = 'COLORCHECKER'; sr.patch = 'P15'
disp = nt.nodes.new('PolychromeDispersionNode'); disp.model = 'NAMED'; disp.named = 'N_SF11'
p = nt.nodes.new('ShaderNodeBsdfPrincipled'); nt.links.new(disp.outputs[0], p.inputs['IOR'])
mix = nt.nodes.new('ShaderNodeMixShader'); nt.links.new(sr.outputs[0], mix.inputs[1]); nt.links.new(p.outputs[0], mix.inputs[2])
se = nt.nodes.new('PolychromeSpectralEmissionNode'); se.kind = 'D65'; se.strength = 2.5
add = nt.nodes.new('ShaderNodeAddShader'); nt.links.new(mix.outputs[0], add.inputs[0]); nt.links.new(se.outputs[0], add.inputs[1])
nt.links.new(add.outputs[0], mo.inputs['Surface'])
out['spectral'] = run(m)
out['spectral_expected'] = {'patch': sr.spectrum().to_dict(), 'ior': disp.polychrome_ior().to_dict(), 'd65': se.spectrum().to_dict()}
m, nt, mo = new_mat('ColourOnSurface')
rgb = nt.nodes.new('ShaderNodeRGB'); rgb.outputs[0].default_value = (0.3, 0.4, 0.5, 1.0); nt.links.new(rgb.outputs[0], mo.inputs['Surface'])
out['colour_surface'] = run(m)
m, nt, mo = new_mat('NaNValue')
d = nt.nodes.new('ShaderNodeBsdfDiffuse'); d.name = 'Diff'; d.inputs['Roughness'].default_value = float('nan')
nt.links.new(d.outputs[0], mo.inputs['Surface'])
out['nan'] = run(m)
m, nt, mo = new_mat('Hidden')
mx = nt.nodes.new('ShaderNodeMix'); mx.data_type = 'RGBA'; val = nt.nodes.new('ShaderNodeValue'); val.name = 'Hid'
nt.links.new(val.outputs[0], [s for s in mx.inputs if s.identifier == 'A_Float'][0])   # hidden in colour mode
e = nt.nodes.new('ShaderNodeEmission'); nt.links.new(mx.outputs[2], e.inputs['Color']); nt.links.new(e.outputs[0], mo.inputs['Surface'])
out['hidden'] = run(m)
m, nt, mo = new_mat('Empty')
out['empty'] = run(m)

# 8. mesh data a graph needs
m, nt, mo = new_mat('Needs')
uvn = nt.nodes.new('ShaderNodeUVMap'); uvn.uv_map = 'Second'
img = bpy.data.images.new('Tiny', 2, 2, alpha=True)
img.pixels.foreach_set(np.array([0.25, 0.5, 0.75, 1.0] * 3 + [1.0, 0.0, 0.0, 0.5], np.float32))
img.pack()
tex = nt.nodes.new('ShaderNodeTexImage'); tex.image = img; tex.interpolation = 'Closest'; tex.extension = 'MIRROR'
nt.links.new(uvn.outputs['UV'], tex.inputs['Vector'])
nm = nt.nodes.new('ShaderNodeNormalMap'); nm.uv_map = 'Third'; nt.links.new(tex.outputs['Color'], nm.inputs['Color'])
ca = nt.nodes.new('ShaderNodeVertexColor'); ca.layer_name = 'Col'
at = nt.nodes.new('ShaderNodeAttribute'); at.attribute_name = 'wetness'
tex2 = nt.nodes.new('ShaderNodeTexImage'); tex2.image = img
p = nt.nodes.new('ShaderNodeBsdfPrincipled')
nt.links.new(nm.outputs[0], p.inputs['Normal']); nt.links.new(ca.outputs['Color'], p.inputs['Base Color'])
nt.links.new(at.outputs['Fac'], p.inputs['Roughness']); nt.links.new(tex2.outputs['Alpha'], p.inputs['Metallic'])
nt.links.new(p.outputs[0], mo.inputs['Surface'])
out['needs'] = run(m)

# 9. colour spaces of 8-bit images: the same PNG read as ACEScg, Linear Rec.709, Non-Color, sRGB
src = bpy.data.images.new('Src', 2, 1)
src.pixels.foreach_set(np.array([0.8, 0.4, 0.1, 1.0, 0.2, 0.6, 0.9, 1.0], np.float32))
src.filepath_raw = os.path.abspath('src.png'); src.file_format = 'PNG'; src.save()
spaces = {}
for cs in ('ACEScg', 'Linear Rec.709', 'Non-Color', 'sRGB'):
    im = bpy.data.images.load(os.path.abspath('src.png'), check_existing=False); im.colorspace_settings.name = cs
    m, nt, mo = new_mat('Space ' + cs)
    t = nt.nodes.new('ShaderNodeTexImage'); t.image = im; e = nt.nodes.new('ShaderNodeEmission')
    nt.links.new(t.outputs[0], e.inputs['Color']); nt.links.new(e.outputs[0], mo.inputs['Surface'])
    r = run(m)
    spaces[cs] = [n for n in r['nodes'] if n['type'] == 'ShaderNodeTexImage'][0]['props']['texture']
    buf = np.empty(8, np.float32); im.pixels.foreach_get(buf); spaces[cs]['raw'] = buf.tolist()
out['spaces'] = spaces
m, nt, mo = new_mat('Tiles')
udim = bpy.data.images.new('Udim', 4, 4, tiled=True); udim.tiles.new(1002)
t = nt.nodes.new('ShaderNodeTexImage'); t.image = udim; t2 = nt.nodes.new('ShaderNodeTexImage'); t2.image = udim
e = nt.nodes.new('ShaderNodeEmission'); nt.links.new(t.outputs[0], e.inputs['Color']); nt.links.new(t2.outputs[0], e.inputs['Strength'])
nt.links.new(e.outputs[0], mo.inputs['Surface'])
out['udim'] = run(m)
emit(**out)
"""


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("graph")
    proc, res = run_bpy(tmp, SCRIPT)
    return check(proc, res)[0]


def by_name(case, name):
    found = [n for n in case["nodes"] if n["name"] == name]
    assert len(found) == 1, (name, [n["name"] for n in case["nodes"]])
    return found[0]


def index_of(case, name):
    return [n["name"] for n in case["nodes"]].index(name)


def test_nested_groups_are_inlined_with_their_defaults(exported):
    c = exported["groups"]
    assert c["warnings"] == []
    types = sorted(n["type"] for n in c["nodes"])
    # two instances of the inner Add (one per outer group node), the Value, two emissions, the mix
    assert types == sorted(
        ["ShaderNodeMath", "ShaderNodeMath", "ShaderNodeValue", "ShaderNodeEmission", "ShaderNodeEmission", "ShaderNodeMixShader"]
    )
    add1, add2 = by_name(c, "G1/InnerNode/Add"), by_name(c, "G2/InnerNode/Add")
    assert add1["inputs"]["Value"] == {"link": [index_of(c, "Val"), "Value"]}  # through both group inputs and a reroute
    assert add2["inputs"]["Value"] == pytest.approx(0.75)  # the group node's own (unlinked) input value
    assert add1["inputs"]["Value_001"] == pytest.approx(1.0) and add1["props"]["operation"] == "ADD"
    assert by_name(c, "E1")["inputs"]["Strength"] == {"link": [index_of(c, "G1/InnerNode/Add"), "Value"]}
    mix = c["nodes"][c["output"]["surface"][0]]
    assert mix["type"] == "ShaderNodeMixShader" and c["output"]["surface"][1] == "Shader"
    assert "ShaderNodeTexNoise" not in types  # unreachable nodes are not exported


def test_closures_pass_through_groups(exported):
    c = exported["shader_group"]
    add = by_name(c, "SG/InnerAdd")
    assert c["output"]["surface"] == [index_of(c, "SG/InnerAdd"), "Shader"]
    assert add["inputs"]["Shader"] == {"link": [index_of(c, "Outer"), "BSDF"]}
    assert add["inputs"]["Shader_001"] == {"link": [index_of(c, "SG/InnerEm"), "Emission"]}


def test_reroutes_frames_and_muted_nodes(exported):
    c = exported["muted"]
    assert exported["muted_links"][0] == ["Value_001", "Value"]
    types = sorted(n["type"] for n in c["nodes"])
    assert types == sorted(
        ["ShaderNodeAddShader", "ShaderNodeEmission", "ShaderNodeEmission", "ShaderNodeRGB", "ShaderNodeValue", "ShaderNodeTexChecker"]
    )
    em = by_name(c, "Emission")
    assert em["inputs"]["Color"] == {"link": [index_of(c, "Col"), "Color"]}  # muted Invert passes Color through
    assert em["inputs"]["Strength"] == {"link": [index_of(c, "V"), "Value"]}  # muted Math: its linked input
    # a muted Mix (colour) passes its A colour's value through
    assert by_name(c, "Checker")["inputs"]["Color1"] == pytest.approx([0.2, 0.4, 0.6, 1.0])


def test_cycle_and_missing_group_output_are_errors_naming_the_material(exported):
    err = exported["cycle"]["error"]
    assert "material 'Cyclic'" in err and "cycle" in err and ("A → B" in err or "B → A" in err)
    err = exported["no_output"]["error"]
    assert "material 'Broken'" in err and "'NoOutput'" in err and "Group Output" in err


def test_unsupported_node_warns_once_and_keeps_its_default(exported):
    c = exported["unknown"]
    sky = [w for w in c["warnings"] if "'Sky'" in w]
    assert len(sky) == 1 and "material 'Unknown'" in sky[0] and "ShaderNodeTexSky" in sky[0]
    toon = [w for w in c["warnings"] if "'Toon'" in w]
    assert len(toon) == 1 and "grey diffuse" in toon[0]
    p = by_name(c, "Principled BSDF")
    assert p["inputs"]["Base Color"] == pytest.approx(exported["sky_default"])
    assert p["inputs"]["Emission Color"] == pytest.approx(exported["sky_default"])
    assert by_name(c, "Toon")["type"] == "ShaderNodeBsdfDiffuse"


def test_color_ramp_and_curves_are_baked_as_cycles_bakes_them(exported):
    c = exported["tables"]
    ramp = by_name(c, "Color Ramp")["props"]["color_ramp"]
    assert ramp["interpolation"] == "EASE" and ramp["color_mode"] == "RGB"
    assert [e[0] for e in ramp["elements"]] == pytest.approx([0.2, 0.6, 1.0])
    assert ramp["elements"][1][1] == pytest.approx([0, 1, 0, 0.5])
    rgb = by_name(c, "RGB Curves")["props"]["curves"]
    # range: first to last point over all four curves (-0.2 from G, 1.0 from the others)
    assert (rgb["min_x"], rgb["max_x"], rgb["extrapolate"]) == (pytest.approx(-0.2), pytest.approx(1.0), False)
    assert [len(t) for t in rgb["tables"]] == [256] * 4
    for table, probe in zip(rgb["tables"], exported["rgb_probe"]):
        assert [table[i] for i in (0, 37, 128, 255)] == pytest.approx(probe, abs=1e-6)
    assert rgb["tables"][0][0] == pytest.approx(0.0) and max(rgb["tables"][0]) > 0.6  # C through (0.25, 0.6)
    flt = by_name(c, "Float Curve")["props"]["curves"]
    assert (flt["min_x"], flt["max_x"], len(flt["tables"])) == (pytest.approx(-1.0), pytest.approx(2.0), 1)
    assert [flt["tables"][0][i] for i in (0, 37, 128, 255)] == pytest.approx(exported["float_probe"], abs=1e-6)
    vec = by_name(c, "Vector Curves")["props"]["curves"]
    assert len(vec["tables"]) == 3 and vec["min_x"] == pytest.approx(-1.0) and vec["max_x"] == pytest.approx(1.0)
    assert vec["tables"][0] == pytest.approx(list(np.linspace(-1.0, 1.0, 256)), abs=1e-5)  # the default is the identity


def test_polychrome_nodes_become_constant_inputs(exported):
    c, want = exported["spectral"], exported["spectral_expected"]
    assert c["warnings"] == []
    diffuse = [n for n in c["nodes"] if n["type"] == "ShaderNodeBsdfDiffuse"][0]
    assert diffuse["inputs"]["Color"] == {"spectrum": want["patch"]}
    p = by_name(c, "Principled BSDF")
    assert p["inputs"]["IOR"] == {"ior": want["ior"]}
    em = [n for n in c["nodes"] if n["type"] == "ShaderNodeEmission"][0]
    assert em["inputs"]["Color"] == {"spectrum": want["d65"]} and em["inputs"]["Strength"] == pytest.approx(2.5)
    assert not any(n["type"].startswith("Polychrome") for n in c["nodes"])


def test_colour_on_surface_nan_and_empty(exported):
    c = exported["colour_surface"]
    em = c["nodes"][c["output"]["surface"][0]]
    assert em["type"] == "ShaderNodeEmission" and em["inputs"]["Color"] == {"link": [index_of(c, "RGB"), "Color"]}
    err = exported["nan"]["error"]
    assert "material 'NaNValue'" in err and "'Diff'" in err and "Roughness" in err
    assert exported["empty"].get("none") is True
    h = exported["hidden"]  # a link to a socket the node's mode hides is ignored, as Cycles does
    assert [n["type"] for n in h["nodes"]] == ["ShaderNodeMix", "ShaderNodeEmission"]
    assert "A_Float" not in h["nodes"][0]["inputs"] and h["nodes"][0]["props"]["data_type"] == "RGBA"


def test_mesh_data_needs_images_and_implicit_inputs(exported):
    c = exported["needs"]
    assert sorted(map(tuple, c["needs"])) == sorted(
        [("uv", "Second"), ("uv", "Third"), ("tangent", "Third"), ("color", "Col"), ("attribute", "wetness"), ("uv", "")]
    )
    tex = by_name(c, "Image Texture")
    assert tex["props"]["interpolation"] == "Closest" and tex["props"]["extension"] == "MIRROR"
    t = tex["props"]["texture"]
    # a packed 8-bit sRGB image: RGBA bytes, rows from the top (Blender's start at the bottom)
    assert t["encoding"] == "srgb" and t["dtype"] == "uint8"
    px = np.array(t["pixels"]).reshape(t["shape"])
    assert px.shape[2] in (3, 4)
    # its Alpha is not read: colour × alpha in bytes, as Cycles associates it (alpha 0.5 → 128)
    assert px[0, 1, :3].tolist() == [128, 0, 0] and px[1, 0, :3].tolist() == [64, 128, 191]
    tex2 = by_name(c, "Image Texture.001")
    assert "Vector" not in tex2["inputs"]  # unlinked implicit input: absent (the default UV map)
    p = by_name(c, "Principled BSDF")
    assert "Tangent" not in p["inputs"] and p["inputs"]["Normal"]["link"][1] == "Normal"
    assert c["warnings"] == []


def test_image_colour_spaces_become_scene_linear(exported):
    import colour

    sp = exported["spaces"]
    raw = np.array(sp["sRGB"]["raw"]).reshape(2, 4)
    # sRGB stays bytes (the core decodes after filtering, as Cycles); linear spaces are the values as they are
    assert sp["sRGB"]["encoding"] == "srgb" and np.array(sp["sRGB"]["pixels"]).reshape(2, -1)[0, :3].tolist() == list(
        np.rint(raw[0, :3] * 255)
    )
    for cs in ("Linear Rec.709", "Non-Color"):
        assert sp[cs]["encoding"] == "linear"
        assert np.array(sp[cs]["pixels"]).reshape(2, -1)[:, :3] == pytest.approx(raw[:, :3], abs=1e-6)
    # ACEScg bytes → linear Rec.709 (colour-science's matrix; CAT02 vs Blender's Bradford: ~1e-3)
    got = np.array(sp["ACEScg"]["pixels"]).reshape(2, -1)
    want = colour.RGB_to_RGB(
        raw[:, :3], colour.RGB_COLOURSPACES["ACEScg"], colour.RGB_COLOURSPACES["sRGB"], chromatic_adaptation_transform="Bradford"
    )
    assert sp["ACEScg"]["encoding"] == "linear" and got[:, :3] == pytest.approx(want, abs=3e-3)


def test_mesh_carries_what_graphs_read(tmp_path):
    """Per-vertex graph data equals Blender's value at every triangle corner (vertices
    split where corners differ); missing names warn once naming object and material."""
    proc, res = run_bpy(
        tmp_path,
        """
    from polychrome_blender.export.meshes import mesh_arrays
    from polychrome_blender.export.warnings import Warnings
    sc = empty_scene()
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=4, y_subdivisions=3, size=2.0)
    ob = bpy.context.object; me = ob.data
    me.uv_layers.new(name='Second')
    sec = me.uv_layers['Second'].uv
    for i, d in enumerate(sec): d.vector = (0.3 * i % 1.0, 0.7 * i % 1.0)   # a seam at every corner
    col = me.color_attributes.new('Col', 'BYTE_COLOR', 'CORNER')
    for i, d in enumerate(col.data): d.color = ((i % 5) / 4, (i % 3) / 2, 0.25, 1.0)
    wet = me.attributes.new('wetness', 'FLOAT', 'POINT')
    for i, d in enumerate(wet.data): d.value = 0.1 * i
    face = me.attributes.new('facevec', 'FLOAT_VECTOR', 'FACE')
    for i, d in enumerate(face.data): d.vector = (i, -i, 2 * i)
    needs = {('uv', 'Second'): "material 'M' node 'UV Map'", ('color', 'Col'): 'c', ('attribute', 'wetness'): 'a',
             ('attribute', 'facevec'): 'f', ('attribute', 'Second'): 'uv by name', ('tangent', 'Second'): 't',
             ('tangent', ''): 'default tangents', ('uv', 'Nope'): "material 'M' node 'Lost'", ('color', ''): 'default colour'}
    dg = bpy.context.evaluated_depsgraph_get(); ev = ob.evaluated_get(dg)
    w = Warnings()
    a = mesh_arrays(ev, ob.name, needs, w)
    em = ev.to_mesh(); em.calc_loop_triangles(); em.calc_tangents(uvmap='Second')
    tl = [list(t.loops) for t in em.loop_triangles]
    blender = dict(
        second=[[list(em.uv_layers['Second'].uv[l].vector) for l in t] for t in tl],
        col=[[list(em.color_attributes['Col'].data[l].color) for l in t] for t in tl],
        wet=[[em.attributes['wetness'].data[em.loops[l].vertex_index].value for l in t] for t in tl],
        face=[[list(em.attributes['facevec'].data[lt.polygon_index].vector) for l in lt.loops] for lt in em.loop_triangles],
        tangent=[[list(em.loops[l].tangent) + [em.loops[l].bitangent_sign] for l in t] for t in tl],
    )
    em.calc_tangents(uvmap='UVMap')
    blender['default_tangent'] = [[list(em.loops[l].tangent) + [em.loops[l].bitangent_sign] for l in t] for t in tl]
    ev.to_mesh_clear()
    d = a.data; tri = a.triangles
    emit(tri=tri.tolist(), second=d['uv_maps']['Second'].tolist(), col=d['colors']['Col'].tolist(), default=d['colors'][''].tolist(),
         wet=d['attributes']['wetness'].tolist(), face=d['attributes']['facevec'].tolist(), uvname=d['attributes']['Second'].tolist(),
         tangent=d['tangent_maps']['Second'].tolist(), default_tangent=d['tangents'].tolist(), nv=len(a.vertices), uv_maps=sorted(d['uv_maps']), warnings=w.messages, blender=blender)
    """,
    )
    r = check(proc, res)[0]
    tri = np.array(r["tri"])
    b = r["blender"]
    assert np.array(r["second"])[tri] == pytest.approx(np.array(b["second"]), abs=1e-6)
    assert np.array(r["col"])[tri] == pytest.approx(np.array(b["col"]), abs=1e-6)
    assert np.array(r["default"]) == pytest.approx(np.array(r["col"]))  # the only colour attribute is the default
    assert np.array(r["wet"])[tri][..., 0] == pytest.approx(np.array(b["wet"]), abs=1e-6)
    assert np.array(r["face"])[tri] == pytest.approx(np.array(b["face"]), abs=1e-6)
    assert np.array(r["uvname"])[tri][..., :2] == pytest.approx(np.array(b["second"]), abs=1e-6)
    assert np.array(r["tangent"])[tri] == pytest.approx(np.array(b["tangent"]), abs=1e-6)
    # One tangent set per UV map a node names: the default map's beside Second's.
    assert np.array(r["default_tangent"])[tri] == pytest.approx(np.array(b["default_tangent"]), abs=1e-6)
    assert not np.allclose(np.array(b["default_tangent"]), np.array(b["tangent"]), atol=1e-3)
    assert r["uv_maps"] == ["Second"]
    lost = [w for w in r["warnings"] if "'Nope'" in w]
    assert len(lost) == 1 and "material 'M' node 'Lost'" in lost[0] and "object 'Grid'" in lost[0]


def test_every_blender_shader_node_exports_or_warns(tmp_path):
    """Every shader node type Blender 4.5 has, on its own in a material, exports without an
    exception: supported ones as themselves, any other with one warning naming it."""
    proc, res = run_bpy(
        tmp_path,
        """
    from polychrome_blender.export.node_graph import SUPPORTED, export_graph
    from polychrome_blender.export.textures import TextureCache
    from polychrome_blender.export.warnings import Warnings
    kinds = sorted(t for t in dir(bpy.types) if t.startswith('ShaderNode') and t not in ('ShaderNodeTree', 'ShaderNodeCustomGroup')
                   and issubclass(getattr(bpy.types, t), bpy.types.ShaderNode))
    rows = []
    for kind in kinds:
        m = bpy.data.materials.new(kind); m.use_nodes = True; nt = m.node_tree
        for n in list(nt.nodes):
            if n.type != 'OUTPUT_MATERIAL': nt.nodes.remove(n)
        mo = nt.nodes['Material Output']
        try:
            n = nt.nodes.new(kind)
        except RuntimeError:
            continue  # not allowed in a material tree
        n.name = 'Probe'
        outs = [o for o in n.outputs if o.enabled]
        if not outs:
            continue
        if outs[0].type == 'SHADER':
            nt.links.new(outs[0], mo.inputs['Surface'])
        else:
            e = nt.nodes.new('ShaderNodeEmission'); nt.links.new(outs[0], e.inputs['Color']); nt.links.new(e.outputs[0], mo.inputs['Surface'])
        w = Warnings()
        try:
            got = export_graph(m, w, TextureCache())
            err = None
        except ValueError as e:
            got, err = None, str(e)
        types = [x['type'] for x in got[0]] if got else []
        rows.append(dict(kind=kind, supported=kind in SUPPORTED, types=types, warnings=w.messages, error=err))
    emit(rows=rows)
    """,
    )
    # legacy nodes and what they are written as (export/node_graph.py LEGACY)
    legacy = {
        "ShaderNodeMixRGB": "ShaderNodeMix",
        "ShaderNodeSeparateRGB": "ShaderNodeSeparateColor",
        "ShaderNodeCombineRGB": "ShaderNodeCombineColor",
        "ShaderNodeSeparateHSV": "ShaderNodeSeparateColor",
        "ShaderNodeCombineHSV": "ShaderNodeCombineColor",
    }
    rows = check(proc, res)[0]["rows"]
    assert len(rows) > 80, len(rows)
    for r in rows:
        assert r["error"] is None, r
        probe = [w for w in r["warnings"] if "'Probe'" in w]
        if r["kind"] in legacy:
            assert legacy[r["kind"]] in r["types"] and not probe, r
        elif r["supported"]:
            assert r["kind"] in r["types"] and not probe, r
        else:
            assert len(probe) == 1 and r["kind"] in probe[0] and "material '" in probe[0], r
            assert r["kind"] not in r["types"], r


def test_udim_image_warns_once(exported):
    c = exported["udim"]
    udim = [w for w in c["warnings"] if "UDIM" in w]
    assert len(udim) == 1 and "material 'Tiles'" in udim[0] and "'Udim'" in udim[0], c["warnings"]
    assert "error" not in c
