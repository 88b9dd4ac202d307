"""Cases of the emission oracle (test_node_oracle.py), run inside the bpy subprocess after
oracle_scene.py: each case is (family, label, build(nt) -> the socket shown, tolerance).

Constant-input cases: every node reads only constants, so the core folds the whole graph
(docs/shading.md) and each tile is one colour."""

import os

import bpy
import numpy as np
from oracle_scene import node, out

TOL = 1e-3
A3, B3, C3 = (0.2, 0.55, 0.9), (0.65, 0.3, 0.1), (0.4, 0.8, 0.35)


def math_cases():
    cases = []
    ops = [i.identifier for i in bpy.types.ShaderNodeMath.bl_rna.properties["operation"].enum_items]
    for op in ops:
        for tag, (a, b, c) in (("a", (0.7, 0.3, 0.45)), ("b", (-1.3, 2.1, 0.6))):

            def build(nt, op=op, a=a, b=b, c=c):
                return out(node(nt, "ShaderNodeMath", {"operation": op}, Value=a, Value_001=b, Value_002=c))

            cases.append(("Math", f"{op} {tag}", build, TOL))
    for op in ("ADD", "SINH", "SUBTRACT"):

        def clamped(nt, op=op):
            return out(node(nt, "ShaderNodeMath", {"operation": op, "use_clamp": True}, Value=0.8, Value_001=0.6))

        cases.append(("Math", f"{op} clamp", clamped, TOL))
    return cases


def vector_math_cases():
    cases = []
    ops = [i.identifier for i in bpy.types.ShaderNodeVectorMath.bl_rna.properties["operation"].enum_items]
    for op in ops:

        def build(nt, op=op):
            n = node(nt, "ShaderNodeVectorMath", {"operation": op}, Vector=(0.3, -0.8, 1.7), Vector_001=(0.6, 0.25, -0.4), Scale=1.45)
            if op in ("MULTIPLY_ADD", "FACEFORWARD", "WRAP"):
                n.inputs[2].default_value = (0.2, -0.5, 0.9)
            return out(n)

        cases.append(("Vector Math", op, build, TOL))
    return cases


def mix_cases():
    cases = []
    blends = [i.identifier for i in bpy.types.ShaderNodeMix.bl_rna.properties["blend_type"].enum_items]
    for blend in blends:
        for clamp in (False, True):

            def build(nt, blend=blend, clamp=clamp):
                n = node(nt, "ShaderNodeMix", {"data_type": "RGBA", "blend_type": blend, "clamp_result": clamp})
                n.inputs["Factor"].default_value = 0.65
                [s for s in n.inputs if s.identifier == "A_Color"][0].default_value = (0.8, 0.35, 0.1, 1.0)
                [s for s in n.inputs if s.identifier == "B_Color"][0].default_value = (0.3, 0.9, 1.4, 1.0)
                return out(n, "Result_Color")

            cases.append(("Mix", f"colour {blend}{' clamp' if clamp else ''}", build, TOL))

    def mix_float(nt):
        n = node(nt, "ShaderNodeMix", {"data_type": "FLOAT", "clamp_factor": False}, Factor_Float=1.3, A_Float=0.2, B_Float=0.9)
        return out(n, "Result_Float")

    def mix_vec(nt, mode="UNIFORM"):
        n = node(nt, "ShaderNodeMix", {"data_type": "VECTOR", "factor_mode": mode})
        [s for s in n.inputs if s.identifier == "Factor_Float"][0].default_value = 0.3
        [s for s in n.inputs if s.identifier == "Factor_Vector"][0].default_value = (0.1, 0.5, 0.9)
        [s for s in n.inputs if s.identifier == "A_Vector"][0].default_value = (0.2, -0.4, 0.6)
        [s for s in n.inputs if s.identifier == "B_Vector"][0].default_value = (0.9, 0.8, -0.7)
        return out(n, "Result_Vector")

    cases += [
        ("Mix", "float unclamped factor", mix_float, TOL),
        ("Mix", "vector uniform", mix_vec, TOL),
        ("Mix", "vector non-uniform", lambda nt: mix_vec(nt, "NON_UNIFORM"), TOL),
    ]
    return cases


def map_range_clamp_cases():
    cases = []
    for interp in ("LINEAR", "STEPPED", "SMOOTHSTEP", "SMOOTHERSTEP"):
        for clamp in (True, False):

            def build(nt, interp=interp, clamp=clamp):
                n = node(nt, "ShaderNodeMapRange", {"data_type": "FLOAT", "interpolation_type": interp, "clamp": clamp})
                vals = {"Value": 0.37, "From Min": 0.1, "From Max": 0.6, "To Min": -0.5, "To Max": 2.0, "Steps": 3.0}
                for s in n.inputs:
                    if s.identifier in vals:
                        s.default_value = vals[s.identifier]
                return out(n, "Result")

            cases.append(("Map Range", f"float {interp}{' clamp' if clamp else ''}", build, TOL))

        def vec(nt, interp=interp):
            n = node(nt, "ShaderNodeMapRange", {"data_type": "FLOAT_VECTOR", "interpolation_type": interp, "clamp": False})
            vals = {
                "Vector": (0.37, 0.9, -0.2),
                "From_Min_FLOAT3": (0.1, 0.0, -1.0),
                "From_Max_FLOAT3": (0.6, 1.0, 1.0),
                "To_Min_FLOAT3": (0.0, -1.0, 0.5),
                "To_Max_FLOAT3": (1.0, 1.0, 2.5),
                "Steps_FLOAT3": (4.0, 2.0, 5.0),
            }
            for s in n.inputs:
                if s.identifier in vals:
                    s.default_value = vals[s.identifier]
            return out(n, "Vector")

        cases.append(("Map Range", f"vector {interp}", vec, TOL))
    for kind, lo, hi in (("MINMAX", 0.2, 0.5), ("RANGE", 0.5, 0.2), ("MINMAX", 0.5, 0.2)):

        def clamp(nt, kind=kind, lo=lo, hi=hi):
            return out(node(nt, "ShaderNodeClamp", {"clamp_type": kind}, Value=0.9, Min=lo, Max=hi))

        cases.append(("Clamp", f"{kind} {lo} {hi}", clamp, TOL))
    return cases


def ramp_curve_cases():
    cases = []
    modes = [("RGB", "NEAR", i) for i in ("CONSTANT", "LINEAR", "EASE", "CARDINAL", "B_SPLINE")]
    modes += [(cm, hue, "LINEAR") for cm in ("HSV", "HSL") for hue in ("NEAR", "FAR", "CW", "CCW")]
    for cm, hue, interp in modes:
        for fac in (0.15, 0.5, 0.83):

            def build(nt, cm=cm, hue=hue, interp=interp, fac=fac):
                n = node(nt, "ShaderNodeValToRGB", Fac=fac)
                r = n.color_ramp
                r.color_mode, r.hue_interpolation, r.interpolation = cm, hue, interp
                r.elements[0].position, r.elements[0].color = 0.1, (0.9, 0.2, 0.1, 1.0)
                e = r.elements.new(0.45)
                e.color = (0.1, 0.8, 0.3, 0.4)
                r.elements[2].position, r.elements[2].color = 0.9, (0.2, 0.3, 1.0, 1.0)
                return out(n, "Color")

            cases.append(("Color Ramp", f"{cm} {hue} {interp} {fac}", build, TOL))

    def ramp_alpha(nt):
        n = node(nt, "ShaderNodeValToRGB", Fac=0.3)
        n.color_ramp.elements[0].color = (1, 1, 1, 0.2)
        return out(n, "Alpha")

    cases.append(("Color Ramp", "alpha", ramp_alpha, TOL))

    def rgb_curves(nt, colour, fac, extend):
        n = node(nt, "ShaderNodeRGBCurve", Fac=fac, Color=colour)
        cm = n.mapping
        cm.curves[3].points.new(0.3, 0.55)
        cm.curves[0].points[1].location = (0.8, 0.9)
        cm.curves[1].points.new(0.5, 0.2)
        cm.curves[2].points[0].location = (0.1, 0.3)
        cm.extend = extend
        cm.update()
        return out(n)

    for colour in ((0.2, 0.5, 0.7), (1.3, -0.2, 0.95)):
        for extend in ("EXTRAPOLATED", "HORIZONTAL"):
            cases.append(("RGB Curves", f"{colour} {extend}", lambda nt, c=colour, e=extend: rgb_curves(nt, c, 0.8, e), TOL))

    def float_curve(nt, v):
        n = node(nt, "ShaderNodeFloatCurve", Factor=1.0, Value=v)
        c = n.mapping.curves[0]
        c.points[0].location = (-0.5, 0.2)
        c.points.new(0.4, 0.9)
        c.points[-1].location = (1.5, 0.1)
        n.mapping.update()
        return out(n)

    for v in (-0.8, 0.1, 0.7, 1.9):
        cases.append(("Float Curve", f"{v}", lambda nt, v=v: float_curve(nt, v), TOL))

    def vector_curves(nt):
        n = node(nt, "ShaderNodeVectorCurve", Fac=0.9, Vector=(0.3, -0.6, 0.8))
        n.mapping.curves[0].points.new(0.2, 0.7)
        n.mapping.curves[1].points[0].location = (-1.0, 0.5)
        n.mapping.update()
        return out(n)

    cases.append(("Vector Curves", "custom", vector_curves, TOL))
    return cases


def colour_cases():
    cases = []
    col = (0.8, 0.35, 0.15)
    for h, s, v, f in ((0.3, 1.2, 0.8, 0.9), (0.5, 1.0, 1.0, 1.0), (0.95, 0.4, 1.5, 0.6)):
        cases.append(
            (
                "Hue/Saturation/Value",
                f"{h} {s} {v} {f}",
                lambda nt, h=h, s=s, v=v, f=f: out(node(nt, "ShaderNodeHueSaturation", Hue=h, Saturation=s, Value=v, Fac=f, Color=col)),
                TOL,
            )
        )
    for fac in (0.7, 1.0):
        cases.append(("Invert", f"{fac}", lambda nt, fac=fac: out(node(nt, "ShaderNodeInvert", Fac=fac, Color=(0.8, 0.35, 1.3))), TOL))
    for g in (2.2, 0.45):
        cases.append(("Gamma", f"{g}", lambda nt, g=g: out(node(nt, "ShaderNodeGamma", Color=col, Gamma=g)), TOL))
    for b, c in ((0.1, 0.3), (-0.1, -0.4)):
        cases.append(
            (
                "Bright/Contrast",
                f"{b} {c}",
                lambda nt, b=b, c=c: out(node(nt, "ShaderNodeBrightContrast", Color=col, Bright=b, Contrast=c)),
                TOL,
            )
        )
    cases.append(("RGB to BW", "colour", lambda nt: out(node(nt, "ShaderNodeRGBToBW", Color=col)), TOL))
    for mode in ("RGB", "HSV", "HSL"):
        for o in ("Red", "Green", "Blue"):
            cases.append(
                (
                    "Separate Color",
                    f"{mode} {o}",
                    lambda nt, m=mode, o=o: out(node(nt, "ShaderNodeSeparateColor", {"mode": m}, Color=col), o),
                    TOL,
                )
            )
        cases.append(
            (
                "Combine Color",
                mode,
                lambda nt, m=mode: out(node(nt, "ShaderNodeCombineColor", {"mode": m}, Red=0.62, Green=0.7, Blue=0.45)),
                TOL,
            )
        )
    for o in ("X", "Y", "Z"):
        cases.append(("Separate XYZ", o, lambda nt, o=o: out(node(nt, "ShaderNodeSeparateXYZ", Vector=(0.3, -0.7, 1.2)), o), TOL))
    cases.append(("Combine XYZ", "xyz", lambda nt: out(node(nt, "ShaderNodeCombineXYZ", X=0.3, Y=-0.7, Z=1.2)), TOL))

    def value(nt):
        n = nt.nodes.new("ShaderNodeValue")
        n.outputs[0].default_value = 0.6180
        return n.outputs[0]

    def rgb(nt):
        n = nt.nodes.new("ShaderNodeRGB")
        n.outputs[0].default_value = (0.25, 0.5, 0.125, 1.0)
        return n.outputs[0]

    cases += [("Value", "0.618", value, TOL), ("RGB", "colour", rgb, TOL)]
    for k in (1500.0, 4000.0, 6500.0, 12000.0):
        cases.append(("Blackbody", f"{k:g} K", lambda nt, k=k: out(node(nt, "ShaderNodeBlackbody", Temperature=k)), TOL))
    for w in (450.0, 550.0, 650.0):
        cases.append(("Wavelength", f"{w:g} nm", lambda nt, w=w: out(node(nt, "ShaderNodeWavelength", Wavelength=w)), TOL))
    return cases


def group_cases():
    """A node group (with a muted node and a reroute) evaluated as Cycles does."""

    def build(nt, linked):
        g = nt.nodes.new("ShaderNodeGroup")
        g.node_tree = bpy.data.node_groups.get("OracleInner") or inner_group()
        if linked:
            rr = nt.nodes.new("NodeReroute")
            v = node(nt, "ShaderNodeMath", {"operation": "MULTIPLY"}, Value=0.9, Value_001=0.5)
            nt.links.new(out(v), rr.inputs[0])
            nt.links.new(rr.outputs[0], g.inputs["x"])
        return g.outputs["y"]

    return [("Group", "default input", lambda nt: build(nt, False), TOL), ("Group", "linked input", lambda nt: build(nt, True), TOL)]


def inner_group():
    inner = bpy.data.node_groups.new("OracleInner", "ShaderNodeTree")
    s = inner.interface.new_socket("x", in_out="INPUT", socket_type="NodeSocketFloat")
    s.default_value = 0.3
    inner.interface.new_socket("y", in_out="OUTPUT", socket_type="NodeSocketColor")
    gi, go = inner.nodes.new("NodeGroupInput"), inner.nodes.new("NodeGroupOutput")
    ramp = inner.nodes.new("ShaderNodeValToRGB")
    muted = inner.nodes.new("ShaderNodeMath")
    muted.operation, muted.mute = "SINE", True
    inner.links.new(gi.outputs["x"], muted.inputs[0])
    inner.links.new(muted.outputs[0], ramp.inputs["Fac"])
    inner.links.new(ramp.outputs["Color"], go.inputs["y"])
    return inner


def legacy_cases():
    """Nodes of files from before Blender 3.3/3.4, which 4.5 still loads."""
    cases = []
    for blend in ("MIX", "OVERLAY", "SOFT_LIGHT", "HUE", "DIVIDE"):
        for clamp in (False, True):

            def build(nt, blend=blend, clamp=clamp):
                n = node(
                    nt,
                    "ShaderNodeMixRGB",
                    {"blend_type": blend, "use_clamp": clamp},
                    Fac=1.4,
                    Color1=(0.8, 0.35, 0.1),
                    Color2=(0.3, 0.9, 1.4),
                )
                return out(n)

            cases.append(("MixRGB (legacy)", f"{blend}{' clamp' if clamp else ''}", build, TOL))
    for o in ("R", "G", "B"):
        cases.append(("Separate RGB (legacy)", o, lambda nt, o=o: out(node(nt, "ShaderNodeSeparateRGB", Image=(0.8, 0.35, 0.15)), o), TOL))
    for o in ("H", "S", "V"):
        cases.append(("Separate HSV (legacy)", o, lambda nt, o=o: out(node(nt, "ShaderNodeSeparateHSV", Color=(0.8, 0.35, 0.15)), o), TOL))
    cases.append(("Combine RGB (legacy)", "rgb", lambda nt: out(node(nt, "ShaderNodeCombineRGB", R=0.6, G=0.2, B=0.9)), TOL))
    cases.append(("Combine HSV (legacy)", "hsv", lambda nt: out(node(nt, "ShaderNodeCombineHSV", H=0.6, S=0.7, V=0.9)), TOL))
    return cases


CONSTANT_CASES = (
    math_cases()
    + vector_math_cases()
    + mix_cases()
    + map_range_clamp_cases()
    + ramp_curve_cases()
    + colour_cases()
    + group_cases()
    + legacy_cases()
)


# -- per-hit cases (coordinates, mesh data, textures) -------------------------------------
# Polychrome averages each pixel over random positions in it, Cycles here takes its centre:
# these cases are compared on tile means and most vary slowly across a tile (a Mapping
# with a small scale), so the difference of the two is small where the pattern is smooth.
COORD_TOL = 1.5e-2  # sampling noise of the albedo oracle (test_node_oracle.py)


def mapped(nt, coord="Object", scale=0.1, loc=(0.0, 0.0, 0.0), rot=(0.0, 0.0, 0.0), kind="POINT"):
    tc = nt.nodes.new("ShaderNodeTexCoord")
    return out(node(nt, "ShaderNodeMapping", {"vector_type": kind}, Vector=out(tc, coord), Location=loc, Rotation=rot, Scale=(scale,) * 3))


def coordinate_cases():
    cases = []
    for o in ("Generated", "Object", "UV", "Normal"):
        cases.append(("Texture Coordinate", o, lambda nt, o=o: out(nt.nodes.new("ShaderNodeTexCoord"), o), COORD_TOL))
    for kind, coord, scale in (("POINT", "Object", 0.6), ("TEXTURE", "Object", 2.0), ("VECTOR", "Normal", 2.0), ("NORMAL", "Normal", 2.0)):

        def mapping(nt, k=kind, c=coord, s=scale):
            return mapped(nt, c, s, (0.3, 0.6, 0.2), (0.3, -0.5, 0.8), k)

        cases.append(("Mapping", kind, mapping, COORD_TOL))
    cases.append(("UV Map", "Second", lambda nt: out(node(nt, "ShaderNodeUVMap", {"uv_map": "Second"}), "UV"), COORD_TOL))
    for o in ("Position", "Normal", "True Normal", "Backfacing", "Incoming"):
        cases.append(("Geometry", o, lambda nt, o=o: out(nt.nodes.new("ShaderNodeNewGeometry"), o), COORD_TOL))
    cases.append(("Color Attribute", "Col", lambda nt: out(node(nt, "ShaderNodeVertexColor", {"layer_name": "Col"}), "Color"), COORD_TOL))
    cases.append(("Attribute", "wet", lambda nt: out(node(nt, "ShaderNodeAttribute", {"attribute_name": "wet"}), "Fac"), COORD_TOL))
    cases.append(
        ("Attribute", "Col colour", lambda nt: out(node(nt, "ShaderNodeAttribute", {"attribute_name": "Col"}), "Color"), COORD_TOL)
    )
    for o in ("Location", "Object Index", "Random"):
        cases.append(("Object Info", o, lambda nt, o=o: out(nt.nodes.new("ShaderNodeObjectInfo"), o), COORD_TOL))
    cases.append(("Fresnel", "1.45", lambda nt: out(node(nt, "ShaderNodeFresnel", IOR=1.45)), COORD_TOL))
    for o in ("Fresnel", "Facing"):
        cases.append(("Layer Weight", o, lambda nt, o=o: out(node(nt, "ShaderNodeLayerWeight", Blend=0.3), o), COORD_TOL))
    for space in ("TANGENT", "OBJECT", "WORLD"):
        cases.append(
            (
                "Normal Map",
                space,
                lambda nt, s=space: out(node(nt, "ShaderNodeNormalMap", {"space": s}, Strength=0.8, Color=(0.7, 0.4, 0.9))),
                COORD_TOL,
            )
        )
    cases.append(
        (
            "Bump",
            "noise height",
            lambda nt: out(
                node(nt, "ShaderNodeBump", Strength=0.5, Distance=0.2, Height=out(node(nt, "ShaderNodeTexNoise", Vector=mapped(nt))))
            ),
            COORD_TOL,
        )
    )
    return cases


def normal_cases():
    """Normal Map and Bump outputs that are constant over a flat tile (compared per pixel
    to TOL): Normal Map in every space and at several strengths (tangent space also on
    the "Second" UV map, whose tangent is along y and mirrored), and Bump of heights
    linear in the position (a constant gradient), with Strength, Distance, Invert and a
    Normal Map on its Normal input."""
    cases = []
    colour = (0.7, 0.4, 0.9)
    for space in ("TANGENT", "OBJECT", "WORLD", "BLENDER_OBJECT", "BLENDER_WORLD"):
        for strength in (0.5, 1.0, 2.0):

            def nm(nt, sp=space, s=strength):
                return out(node(nt, "ShaderNodeNormalMap", {"space": sp}, Strength=s, Color=colour))

            cases.append(("Normal Map", f"{space} strength {strength}", nm, TOL))
    cases.append(
        (
            "Normal Map",
            "TANGENT on UV map Second",
            lambda nt: out(node(nt, "ShaderNodeNormalMap", {"space": "TANGENT", "uv_map": "Second"}, Strength=1.0, Color=colour)),
            TOL,
        )
    )

    def linear_height(nt, kx, ky):
        sep = node(nt, "ShaderNodeSeparateXYZ", Vector=out(nt.nodes.new("ShaderNodeNewGeometry"), "Position"))
        hx = node(nt, "ShaderNodeMath", {"operation": "MULTIPLY"}, Value=out(sep, "X"), Value_001=kx)
        return out(node(nt, "ShaderNodeMath", {"operation": "MULTIPLY_ADD"}, Value=out(sep, "Y"), Value_001=ky, Value_002=out(hx)))

    for label, strength, distance, invert in (
        ("strength 1", 1.0, 0.5, False),
        ("strength 0.4", 0.4, 0.5, False),
        ("distance 2 inverted", 1.0, 2.0, True),
    ):

        def bump(nt, s=strength, d=distance, inv=invert):
            return out(node(nt, "ShaderNodeBump", {"invert": inv}, Strength=s, Distance=d, Height=linear_height(nt, 0.8, -0.3)))

        cases.append(("Bump", f"linear height, {label}", bump, TOL))

    def bump_on_map(nt):
        nm = node(nt, "ShaderNodeNormalMap", {"space": "TANGENT"}, Strength=1.0, Color=colour)
        return out(node(nt, "ShaderNodeBump", Strength=1.0, Distance=0.5, Height=linear_height(nt, 0.8, -0.3), Normal=out(nm)))

    cases.append(("Bump", "linear height over a Normal Map", bump_on_map, TOL))

    def uv_height(nt):  # a height read through the UV map: its offsets move the UVs
        sep = node(nt, "ShaderNodeSeparateXYZ", Vector=out(node(nt, "ShaderNodeUVMap", {"uv_map": "Second"}), "UV"))
        return out(node(nt, "ShaderNodeBump", Strength=1.0, Distance=0.3, Height=out(sep, "X")))

    cases.append(("Bump", "height from UV map Second", uv_height, TOL))
    return cases


def tangent_cases():
    """The Tangent node's UV map tangent (the default map, "UVMap" and "Second", whose
    tangent is along y and mirrored) and tangent-space Normal Maps, with materials that
    read the tangents of both UV maps at once (each node must get its own map's tangent
    set, not the mesh's one), compared per pixel. (Radial tangents are left out: on a
    flat tile they point every way, and the oracle's v / −v tiles show only colours whose
    components share a sign, as an emitter's spectrum clamps the rest together.)"""
    cases = []

    def tangent(nt, props):
        return out(node(nt, "ShaderNodeTangent", props), "Tangent")

    for uv in ("", "UVMap", "Second"):
        cases.append(("Tangent", f"UV map '{uv}'", lambda nt, u=uv: tangent(nt, {"direction_type": "UV_MAP", "uv_map": u}), TOL))

    def both_tangents(nt):
        a = tangent(nt, {"direction_type": "UV_MAP", "uv_map": "UVMap"})
        b = tangent(nt, {"direction_type": "UV_MAP", "uv_map": "Second"})
        half_b = out(node(nt, "ShaderNodeVectorMath", {"operation": "SCALE"}, Vector=b, Scale=0.5), "Vector")
        return out(node(nt, "ShaderNodeVectorMath", {"operation": "ADD"}, Vector=a, Vector_001=half_b), "Vector")

    cases.append(("Tangent", "UVMap's + ½ Second's in one material", both_tangents, TOL))
    colour = (0.7, 0.4, 0.9)

    def both_maps(nt):
        a = out(node(nt, "ShaderNodeNormalMap", {"space": "TANGENT", "uv_map": "UVMap"}, Strength=1.0, Color=colour))
        b = out(node(nt, "ShaderNodeNormalMap", {"space": "TANGENT", "uv_map": "Second"}, Strength=1.0, Color=colour))
        half_b = out(node(nt, "ShaderNodeVectorMath", {"operation": "SCALE"}, Vector=b, Scale=0.5), "Vector")
        return out(node(nt, "ShaderNodeVectorMath", {"operation": "ADD"}, Vector=a, Vector_001=half_b), "Vector")

    cases.append(("Normal Map", "TANGENT on UVMap + ½ on Second in one material", both_maps, TOL))
    return cases


def procedural_cases():
    cases = []
    textures = [
        ("ShaderNodeTexNoise", {"noise_dimensions": "3D"}, {"Scale": 2.0, "Detail": 3.0}),
        ("ShaderNodeTexNoise", {"noise_dimensions": "4D", "noise_type": "RIDGED_MULTIFRACTAL"}, {"W": 0.4}),
        ("ShaderNodeTexVoronoi", {"feature": "F1"}, {"Scale": 1.5}),
        ("ShaderNodeTexVoronoi", {"feature": "SMOOTH_F1", "voronoi_dimensions": "2D"}, {}),
        ("ShaderNodeTexChecker", {}, {"Scale": 0.5, "Color1": (0.9, 0.5, 0.1), "Color2": (0.1, 0.3, 0.7)}),
        ("ShaderNodeTexGradient", {"gradient_type": "LINEAR"}, {}),
        ("ShaderNodeTexGradient", {"gradient_type": "RADIAL"}, {}),
        ("ShaderNodeTexWave", {"wave_type": "RINGS"}, {"Scale": 0.2}),
        ("ShaderNodeTexMagic", {"turbulence_depth": 3}, {"Scale": 0.2}),
        ("ShaderNodeTexBrick", {}, {"Scale": 0.4}),
    ]
    for k, (kind, props, inputs) in enumerate(textures):
        cases.append(
            (
                kind.replace("ShaderNodeTex", "") + " Texture",
                f"{props}",
                lambda nt, t=kind, p=props, i=inputs, k=k: out(
                    node(nt, t, p, Vector=mapped(nt, loc=(0.4 if "Gradient" in t else 0.37 * k, 1.1, -0.4)), **i)
                ),
                COORD_TOL,
            )
        )

    def white_noise(nt):
        # White noise hashes the exact point: the floor of the mapped point gives each tile one value
        cell = out(node(nt, "ShaderNodeVectorMath", {"operation": "FLOOR"}, Vector=mapped(nt, scale=0.1, loc=(3.5, -2.5, 0.5))), "Vector")
        return out(node(nt, "ShaderNodeTexWhiteNoise", {"noise_dimensions": "3D"}, Vector=cell), "Color")

    cases.append(("WhiteNoise Texture", "3D floor", white_noise, COORD_TOL))
    return cases


def image(name, float_buffer, colorspace="sRGB"):
    """A 16×16 smooth RGBA image written by Blender (PNG or EXR) and loaded in ``colorspace``."""
    img = bpy.data.images.get(name)
    if img is not None:
        return img
    path = os.path.abspath(f"{name}.{'exr' if float_buffer else 'png'}")
    if not os.path.exists(path):
        src = bpy.data.images.new(name + " source", 16, 16, alpha=True, float_buffer=float_buffer)
        y, x = np.mgrid[0:16, 0:16] / 15.0
        px = np.stack([0.1 + 0.8 * x, 0.2 + 0.6 * y, 0.5 + 0.4 * np.sin(3 * x + 2 * y), 0.5 + 0.5 * x], -1)
        src.pixels.foreach_set(px.astype(np.float32).ravel())
        src.colorspace_settings.is_data = True  # write the values as they are
        src.filepath_raw, src.file_format = path, ("OPEN_EXR" if float_buffer else "PNG")
        src.save()
        bpy.data.images.remove(src)
    img = bpy.data.images.load(path)
    img.name = name
    img.colorspace_settings.name = colorspace
    return img


def image_cases():
    cases = []
    for name, fb, cs in (
        ("bytes", False, "sRGB"),
        ("float", True, "Linear Rec.709"),
        ("data", False, "Non-Color"),
        ("acescg", False, "ACEScg"),
    ):
        for interp in ("Linear", "Closest", "Cubic"):

            def build(nt, name=name, fb=fb, cs=cs, interp=interp):
                t = node(nt, "ShaderNodeTexImage", {"interpolation": interp})
                t.image = image(name, fb, cs)
                return out(t, "Color")

            cases.append(("Image Texture", f"{name} {interp}", build, COORD_TOL))
    for ext in ("REPEAT", "EXTEND", "CLIP", "MIRROR"):

        def outside(nt, ext=ext):
            t = node(nt, "ShaderNodeTexImage", {"extension": ext}, Vector=mapped(nt, "UV", 0.3, (1.2, -0.7, 0.0)))
            t.image = image("bytes", False)
            return out(t, "Color")

        cases.append(("Image Texture", f"extension {ext}", outside, COORD_TOL))

    def alpha(nt):
        t = node(nt, "ShaderNodeTexImage")
        t.image = image("bytes", False)
        return out(t, "Alpha")

    cases.append(("Image Texture", "alpha", alpha, COORD_TOL))
    return cases + alpha_cases(), environment_cases()


def image_copy(name, mode, float_buffer=False, colorspace="sRGB"):
    """Another datablock of ``name``'s file with alpha mode ``mode``."""
    base = image(name, float_buffer, colorspace)
    img = bpy.data.images.get(f"{name} {mode}")
    if img is None:
        img = bpy.data.images.load(base.filepath, check_existing=False)
        img.name = f"{name} {mode}"
        img.colorspace_settings.name = colorspace
        img.alpha_mode = mode
    return img


def alpha_cases():
    """Image Texture's Alpha output and what reading it does to Color (Cycles divides
    the filtered associated colour by the filtered alpha): R and G of the Color output
    with the Alpha output in B, so that Alpha is read and both are seen."""
    cases = []

    def rg_alpha(nt, t):
        sep = node(nt, "ShaderNodeSeparateColor", Color=out(t, "Color"))
        return out(node(nt, "ShaderNodeCombineColor", Red=out(sep, "Red"), Green=out(sep, "Green"), Blue=out(t, "Alpha")))

    for label, get, interp in (
        ("bytes", lambda: image("bytes", False), "Linear"),
        ("bytes closest", lambda: image("bytes", False), "Closest"),
        ("float", lambda: image("float", True, "Linear Rec.709"), "Linear"),
        ("data", lambda: image("data", False, "Non-Color"), "Linear"),
        ("channel packed", lambda: image_copy("bytes", "CHANNEL_PACKED"), "Linear"),
        ("alpha none", lambda: image_copy("bytes", "NONE"), "Linear"),
    ):

        def build(nt, get=get, interp=interp):
            t = node(nt, "ShaderNodeTexImage", {"interpolation": interp})
            t.image = get()
            return rg_alpha(nt, t)

        cases.append(("Image Texture Alpha", f"{label} colour and alpha", build, COORD_TOL))

    def float_alpha(nt):
        t = node(nt, "ShaderNodeTexImage")
        t.image = image("float", True, "Linear Rec.709")
        return out(t, "Alpha")

    cases.append(("Image Texture Alpha", "float alpha", float_alpha, COORD_TOL))

    def clip(nt):
        t = node(nt, "ShaderNodeTexImage", {"extension": "CLIP"}, Vector=mapped(nt, "UV", 0.3, (1.2, -0.7, 0.0)))
        t.image = image("bytes", False)
        return out(t, "Alpha")

    cases.append(("Image Texture Alpha", "clip alpha", clip, COORD_TOL))

    def packed_color(nt):  # Color alone: not associated in Channel Packed mode
        t = node(nt, "ShaderNodeTexImage")
        t.image = image_copy("bytes", "CHANNEL_PACKED")
        return out(t, "Color")

    cases.append(("Image Texture Alpha", "channel packed colour", packed_color, COORD_TOL))
    return cases


def environment_cases():
    def environment(nt, linked):
        t = node(nt, "ShaderNodeTexEnvironment")
        t.image = image("float", True, "Linear Rec.709")
        if linked:  # a direction through Mapping instead of the incoming ray
            nt.links.new(mapped(nt, "Normal", 1.0, (0.0, 0.0, 0.0), (0.4, 0.3, 0.0), "VECTOR"), t.inputs["Vector"])
        return out(t, "Color")

    return [
        ("Environment Texture", "incoming", lambda nt: environment(nt, False), COORD_TOL),
        ("Environment Texture", "mapped normal", lambda nt: environment(nt, True), COORD_TOL),
    ]


IMAGE_CASES, ENVIRONMENT_CASES = image_cases()
#: Normal Map and Bump through the emission oracle itself (per pixel, 1 sample).
NORMAL_CASES = normal_cases()
#: The Tangent node and Normal Maps of two UV maps in one material (per pixel, 1 sample).
TANGENT_CASES = tangent_cases()
ALPHA_CASES = [c for c in IMAGE_CASES if c[0] == "Image Texture Alpha"]
HIT_CASES = coordinate_cases() + procedural_cases() + [c for c in IMAGE_CASES if c[0] != "Image Texture Alpha"]
#: Per-hit emission, compared per pixel (test_textured_emission_matches_cycles_per_pixel):
#: the image cases Polychrome evaluates as Cycles does (Cubic too; not Alpha). Tolerance:
#: pixel-average noise at Closest texel edges (measured worst 1.1e-2 at 512 samples); the
#: ACEScg image has colours outside Rec.709 whose negative components Polychrome clamps
#: per hit while Cycles averages them over the pixel (measured 1.6e-2).
EMISSION_HIT_CASES = [
    (f, label, b, 2.5e-2 if "acescg" in label else 1.5e-2) for f, label, b, _t in IMAGE_CASES if f == "Image Texture" and label != "alpha"
]
