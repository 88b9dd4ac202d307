"""Blender material node trees → the flat shading graph of docs/shading.md.

:class:`GraphExport` walks what the active Material Output's Surface reads (nothing
else), and writes one entry per real node: node groups are inlined (nested, with their
inputs' defaults and links), reroutes and frames disappear, a muted node becomes what
Blender passes through it (``node.internal_links``), Polychrome's own nodes become
constant inputs (``{"spectrum": ...}``, ``{"ior": ...}``) on Blender's own closures.
A node the core does not evaluate keeps its output's default value, with one warning
naming the material and the node. A node cycle, a group without a Group Output and a
non-finite input value are errors (``ValueError``) naming the material.

Besides ``nodes`` and ``output`` the export says which mesh data the graph reads
(``needs``: UV maps, colour attributes, attributes, tangents), so that meshes carry
them only for the materials that need them.
"""

import math

from .textures import graph_texture, missing_texture

#: Nodes the core evaluates (docs/shading.md, issue 12's list); any other node keeps its
#: output's default value with a warning.
SUPPORTED = frozenset(
    {
        # closures
        "ShaderNodeBsdfPrincipled",
        "ShaderNodeBsdfDiffuse",
        "ShaderNodeBsdfGlossy",
        "ShaderNodeBsdfAnisotropic",
        "ShaderNodeBsdfGlass",
        "ShaderNodeBsdfRefraction",
        "ShaderNodeBsdfTranslucent",
        "ShaderNodeBsdfTransparent",
        "ShaderNodeBsdfSheen",
        "ShaderNodeSubsurfaceScattering",
        "ShaderNodeBsdfMetallic",
        "ShaderNodeEmission",
        "ShaderNodeMixShader",
        "ShaderNodeAddShader",
        "ShaderNodeHoldout",
        # inputs
        "ShaderNodeValue",
        "ShaderNodeRGB",
        "ShaderNodeTexCoord",
        "ShaderNodeUVMap",
        "ShaderNodeTangent",
        "ShaderNodeNewGeometry",
        "ShaderNodeVertexColor",
        "ShaderNodeAttribute",
        "ShaderNodeObjectInfo",
        "ShaderNodeFresnel",
        "ShaderNodeLayerWeight",
        "ShaderNodeWavelength",
        "ShaderNodeBlackbody",
        # converters and colour
        "ShaderNodeMath",
        "ShaderNodeVectorMath",
        "ShaderNodeMix",
        "ShaderNodeMapRange",
        "ShaderNodeClamp",
        "ShaderNodeValToRGB",
        "ShaderNodeRGBCurve",
        "ShaderNodeFloatCurve",
        "ShaderNodeVectorCurve",
        "ShaderNodeHueSaturation",
        "ShaderNodeInvert",
        "ShaderNodeGamma",
        "ShaderNodeBrightContrast",
        "ShaderNodeRGBToBW",
        "ShaderNodeSeparateColor",
        "ShaderNodeCombineColor",
        "ShaderNodeSeparateXYZ",
        "ShaderNodeCombineXYZ",
        # vectors
        "ShaderNodeMapping",
        "ShaderNodeNormalMap",
        "ShaderNodeBump",
        # textures
        "ShaderNodeTexImage",
        "ShaderNodeTexEnvironment",
        "ShaderNodeTexNoise",
        "ShaderNodeTexVoronoi",
        "ShaderNodeTexChecker",
        "ShaderNodeTexGradient",
        "ShaderNodeTexWave",
        "ShaderNodeTexMagic",
        "ShaderNodeTexBrick",
        "ShaderNodeTexWhiteNoise",
    }
)

#: Legacy nodes Blender 4.5 still loads from old files, written as their successors (as
#: Cycles evaluates them): type, fixed props, renamed props, input and output identifiers.
LEGACY = {
    "ShaderNodeMixRGB": (
        "ShaderNodeMix",
        {"data_type": "RGBA", "clamp_factor": True, "factor_mode": "UNIFORM"},
        {"use_clamp": "clamp_result", "blend_type": "blend_type"},
        {"Fac": "Factor_Float", "Color1": "A_Color", "Color2": "B_Color"},
        {"Color": "Result_Color"},
    ),
    "ShaderNodeSeparateRGB": ("ShaderNodeSeparateColor", {"mode": "RGB"}, {}, {"Image": "Color"}, {"R": "Red", "G": "Green", "B": "Blue"}),
    "ShaderNodeCombineRGB": ("ShaderNodeCombineColor", {"mode": "RGB"}, {}, {"R": "Red", "G": "Green", "B": "Blue"}, {"Image": "Color"}),
    "ShaderNodeSeparateHSV": ("ShaderNodeSeparateColor", {"mode": "HSV"}, {}, {"Color": "Color"}, {"H": "Red", "S": "Green", "V": "Blue"}),
    "ShaderNodeCombineHSV": ("ShaderNodeCombineColor", {"mode": "HSV"}, {}, {"H": "Red", "S": "Green", "V": "Blue"}, {"Color": "Color"}),
}

#: Nodes whose value changes from hit to hit (everything else folds to a constant when
#: its inputs are constant).
PER_HIT = frozenset(
    {
        "ShaderNodeTexCoord",
        "ShaderNodeUVMap",
        "ShaderNodeTangent",
        "ShaderNodeNewGeometry",
        "ShaderNodeVertexColor",
        "ShaderNodeAttribute",
        "ShaderNodeObjectInfo",
        "ShaderNodeFresnel",
        "ShaderNodeLayerWeight",
        "ShaderNodeNormalMap",
        "ShaderNodeBump",
        *(t for t in SUPPORTED if t.startswith("ShaderNodeTex")),
    }
)

#: Entries of Cycles' curve and ramp tables (RAMP_TABLE_SIZE, intern/cycles/scene/shader_nodes.h).
TABLE_SIZE = 256
#: Blender's default scene-linear luminance coefficients (colour → float conversion).
LUMINANCE = (0.2126, 0.7152, 0.0722)
#: RNA properties every node has (not exported as props).
_NODE_BASE_PROPS = None
#: Pointer properties exported in a plain form (or deliberately left out).
_SPECIAL_PROPS = {"color_ramp", "mapping", "image", "image_user", "node_tree", "texture_mapping", "color_mapping", "object"}


def _base_props():
    global _NODE_BASE_PROPS
    if _NODE_BASE_PROPS is None:
        import bpy

        _NODE_BASE_PROPS = {p.identifier for p in bpy.types.ShaderNode.bl_rna.properties} | {"rna_type"}
    return _NODE_BASE_PROPS


def convert_value(value, from_type, to_type):
    """A constant of socket type ``from_type`` as socket type ``to_type``, as Blender
    converts it on a link (colour → float: luminance; vector → float: average)."""
    if from_type == to_type or to_type in ("SHADER", None):
        return value
    scalar = from_type in ("VALUE", "INT", "BOOLEAN")
    if to_type in ("VALUE", "INT", "BOOLEAN"):
        if scalar:
            return float(value)
        if from_type == "RGBA":
            return sum(c * w for c, w in zip(value[:3], LUMINANCE))
        return sum(value[:3]) / 3.0
    if to_type == "RGBA":
        return [float(value)] * 3 + [1.0] if scalar else [*value[:3], 1.0]
    if to_type == "VECTOR":
        return [float(value)] * 3 if scalar else list(value[:3])
    return value


def implicit_input(kind, ident):
    """Whether an unlinked input reads an implicit value rather than its default (texture
    coordinates, the shading normal, the tangent: Blender's ``implicit_field``), as the
    core's sockets.rs ``implicit`` table says."""
    if ident == "Vector" and kind.startswith("ShaderNodeTex"):
        return True
    return ident in ("Normal", "Coat Normal") and kind != "ShaderNodeNormalMap" or ident == "Tangent"


def socket_value(sock, owner, node_name):
    """The default value of a socket as JSON (None for sockets without one: closures,
    strings, ...). A non-finite value is an error naming the material, node and socket."""
    t = sock.type
    if t in ("VALUE", "INT"):
        v = [float(sock.default_value)]
    elif t == "BOOLEAN":
        v = [1.0 if sock.default_value else 0.0]
    elif t in ("VECTOR", "RGBA"):
        v = [float(c) for c in sock.default_value]
    else:
        return None
    if not all(math.isfinite(c) for c in v):
        raise ValueError(f"{owner}: node '{node_name}' input '{sock.name}' has a non-finite value {v}")
    if t == "INT":
        return int(v[0])
    return v[0] if len(v) == 1 and t != "VECTOR" else v


def _plain(value):
    """An RNA property value as JSON."""
    if isinstance(value, (bool, int, float, str)) or value is None:
        return value
    if isinstance(value, set):
        return sorted(value)
    try:
        return [_plain(v) for v in value]
    except TypeError:
        return str(value)


def color_ramp_dict(ramp):
    """A Color Ramp's elements. B-Spline and Cardinal interpolation and the HSV / HSL
    colour modes are written as Cycles renders them: the ramp baked to TABLE_SIZE entries
    with Blender's own ``ColorRamp.evaluate`` (colorramp_to_array,
    intern/cycles/blender/util.h) and read back linearly between entries (rgb_ramp_lookup,
    kernel/svm/ramp.h)."""
    if ramp.interpolation in ("B_SPLINE", "CARDINAL") or ramp.color_mode != "RGB":
        ts = [i / (TABLE_SIZE - 1) for i in range(TABLE_SIZE)]
        elements = [[t, [float(c) for c in ramp.evaluate(t)]] for t in ts]
        return {"interpolation": "LINEAR", "color_mode": "RGB", "hue_interpolation": "NEAR", "elements": elements}
    return {
        "interpolation": ramp.interpolation,
        "color_mode": ramp.color_mode,
        "hue_interpolation": ramp.hue_interpolation,
        "elements": [[float(e.position), [float(c) for c in e.color]] for e in ramp.elements],
    }


def _curve_range(mapping, curves):
    """Cycles' curvemapping_minmax: from the first point of each curve to the last
    (intern/cycles/blender/util.h)."""
    lo, hi = math.inf, -math.inf
    for c in curves:
        pts = c.points
        lo = min(lo, float(pts[0].location[0]))
        hi = max(hi, float(pts[len(pts) - 1].location[0]))
    return lo, hi


def curves_dict(node):
    """RGB Curves (tables C, R, G, B), Vector Curves (X, Y, Z), Float Curve: each curve
    baked to TABLE_SIZE values over the x range of all its curves, as Cycles bakes them
    (curvemapping_color_to_array / curvemapping_float_to_array, intern/cycles/blender/util.h)."""
    mapping = node.mapping
    mapping.initialize()  # evaluate() needs the curve tables
    mapping.update()
    curves = list(mapping.curves)
    if node.bl_idname == "ShaderNodeRGBCurve":
        curves = [curves[3], curves[0], curves[1], curves[2]]
    elif node.bl_idname == "ShaderNodeVectorCurve":
        curves = curves[:3]
    else:
        curves = curves[:1]
    lo, hi = _curve_range(mapping, curves)
    ts = [lo + i / (TABLE_SIZE - 1) * (hi - lo) for i in range(TABLE_SIZE)]
    tables = [[float(mapping.evaluate(c, t)) for t in ts] for c in curves]
    return {"min_x": lo, "max_x": hi, "tables": tables, "extrapolate": mapping.extend == "EXTRAPOLATED"}


class _Scope:
    """Where a node lives: the material's tree, or a group node's tree inside another scope."""

    def __init__(self, parent=None, group_node=None):
        self.parent, self.group_node = parent, group_node
        self.key = () if parent is None else (*parent.key, group_node.as_pointer())
        self.path = "" if parent is None else f"{parent.path}{group_node.name}/"


class GraphExport:
    """The graph of one Blender material: :meth:`export` returns ``(nodes, output)`` (or
    None when nothing is connected to Surface); ``needs`` the mesh data it reads: a dict
    from ``("uv", name)``, ``("color", name)``, ``("attribute", name)``,
    ``("tangent", uv name)`` (name "" = the default UV map / colour attribute) to who
    reads it ("material 'M' node 'N'", for messages)."""

    def __init__(self, mat, warnings, textures):
        self.mat, self.warnings, self.textures = mat, warnings, textures
        self.name = mat.name
        self.owner = f"material '{mat.name}'"
        self.nodes = []
        self.needs = {}
        self.per_hit = False  # some node's value changes from hit to hit
        self.emits = False  # an Emission, or a Principled BSDF with an emission
        self._index = {}  # (scope key, node pointer) -> index in nodes
        self._active = []  # nodes being exported (cycle detection), as (key, name)
        self._images = []  # (props, image node, name) whose texture convert_textures() sets

    # -- entry point ---------------------------------------------------------------
    def export(self):
        nt = self.mat.node_tree
        out = nt.get_output_node("CYCLES") if nt is not None else None
        surface = out.inputs.get("Surface") if out is not None else None
        if surface is None:
            return None
        src = self.resolve_input(_Scope(), surface)
        if src is None or src[0] != "link":
            return None
        return self.nodes, {"surface": list(src[1:3])}

    def convert_textures(self):
        """Converts the images the graph reads (after :meth:`export`; separate, so that an
        export that is not used converts nothing).

        Cycles associates alpha when it loads an image (colour × alpha, except for
        Non-Color data and the Channel Packed / None alpha modes; Blender's float buffers
        are associated already) and the texture holds what Cycles holds. When the
        node's Alpha output is read, Cycles' Color output divides the filtered colour by
        the filtered alpha (ImageTextureNode::compile, intern/cycles/scene/shader_nodes.cpp;
        svm_image_texture): the ``associated`` property asks the core to do the same.
        The None alpha mode reads alpha 1 (Cycles ignores the channel)."""
        for props, node, name, _index in self._images:
            img = node.image
            mode = img.alpha_mode
            associate = not img.colorspace_settings.is_data and mode not in ("CHANNEL_PACKED", "NONE")
            props["associated"] = associate
            if mode == "PREMUL" and not img.is_float and index_reads_alpha(self.nodes, _index):
                self.warnings.add(
                    ("premul", self.name, img.name),
                    f"{self.owner}: node '{name}': alpha mode Premultiplied on the 8-bit image '{img.name}' is not supported "
                    "with the Alpha output read (its colour is read as Straight)",
                )
            props["texture"] = graph_texture(
                node,
                self.owner,
                name,
                self.warnings,
                self.textures,
                user=("MATERIAL", self.name),
                associate=associate,
                ignore_alpha=mode == "NONE",
            )
        self._images = []

    # -- resolving sockets -----------------------------------------------------------
    def resolve_input(self, scope, sock):
        """What feeds input ``sock``: ("link", index, output identifier, type),
        ("value", value, type), or None (unconnected: the socket's own default)."""
        # Cycles ignores muted links and links from or to sockets the node's mode hides
        # (intern/cycles/blender/shader.cpp); a link Blender marks invalid because it
        # closes a cycle is followed, so that the cycle is reported.
        links = [lk for lk in sock.links if not lk.is_muted and lk.from_socket.enabled and lk.to_socket.enabled]
        if not links:
            return None
        link = links[0]
        from_sock = link.from_socket
        if from_sock.type == "SHADER" and sock.type != "SHADER":
            if link.from_node.bl_idname == "PolychromeDispersionNode" and sock.name == "IOR":
                return ("value", {"ior": self._dispersion_ior(link.from_node)}, "IOR")
            return None  # Blender draws the link red and ignores it
        got = self.resolve_output(scope, link.from_node, from_sock)
        if got is not None and got[0] == "link" and sock.type == "SHADER" and got[3] != "SHADER":
            # a colour or value on a closure input is an emission of that colour (as Cycles)
            got = self._add(
                scope,
                None,
                {
                    "type": "ShaderNodeEmission",
                    "name": f"{scope.path}{link.from_node.name} (emission)",
                    "inputs": {"Color": {"link": list(got[1:3])}, "Strength": 1.0},
                },
                "Emission",
                "SHADER",
            )
        return got

    def resolve_output(self, scope, node, out):
        kind = node.type
        if kind == "REROUTE":
            return self.resolve_input(scope, node.inputs[0])
        if kind == "GROUP_INPUT":
            if scope.parent is None:
                return None
            gsock = next((s for s in scope.group_node.inputs if s.identifier == out.identifier), None)
            if gsock is None:
                return None
            got = self.resolve_input(scope.parent, gsock)
            if got is None:
                v = socket_value(gsock, self.owner, f"{scope.parent.path}{scope.group_node.name}")
                return None if v is None else ("value", v, gsock.type)
            return got
        if node.mute:
            return self._muted(scope, node, out)
        if kind == "GROUP" or getattr(node, "node_tree", None) is not None:
            return self._group_output(scope, node, out)
        if node.bl_idname.startswith("Polychrome"):
            return self._polychrome(scope, node, out)
        if node.bl_idname not in SUPPORTED and node.bl_idname not in LEGACY:
            return self._unsupported(scope, node, out)
        return self._real(scope, node, out)

    def _muted(self, scope, node, out):
        """A muted node passes the input of its internal link to ``out`` through, else
        gives the output's default value (no closure for a shader output)."""
        for il in node.internal_links:
            if il.to_socket.identifier == out.identifier:
                src = il.from_socket
                got = self.resolve_input(scope, src)
                if got is None:
                    v = socket_value(src, self.owner, f"{scope.path}{node.name}")
                    return None if v is None else ("value", v, src.type)
                return got
        v = socket_value(out, self.owner, f"{scope.path}{node.name}")
        return None if v is None else ("value", v, out.type)

    def _group_output(self, scope, node, out):
        tree = node.node_tree
        if tree is None:
            return self._unsupported(scope, node, out)
        outputs = [n for n in tree.nodes if n.type == "GROUP_OUTPUT"]
        active = next((n for n in outputs if n.is_active_output), outputs[0] if outputs else None)
        if active is None:
            raise ValueError(f"{self.owner}: node group '{tree.name}' (node '{scope.path}{node.name}') has no Group Output node")
        inner = _Scope(scope, node)
        if len(inner.key) > 64:
            raise ValueError(f"{self.owner}: node group '{tree.name}' is nested more than 64 levels deep (a group containing itself?)")
        gsock = next((s for s in active.inputs if s.identifier == out.identifier), None)
        if gsock is None:
            return None
        got = self.resolve_input(inner, gsock)
        if got is None:
            v = socket_value(gsock, self.owner, f"{inner.path}{active.name}")
            return None if v is None else ("value", v, gsock.type)
        return got

    def _unsupported(self, scope, node, out):
        self.warnings.add(
            ("node", self.name, scope.path + node.name),
            f"{self.owner}: node '{scope.path}{node.name}' ({node.bl_idname}) is not supported; "
            + ("rendered as grey diffuse" if out.type == "SHADER" else "its output's default value is used"),
        )
        if out.type == "SHADER":  # today's behaviour for an unknown closure: grey diffuse
            entry = {"type": "ShaderNodeBsdfDiffuse", "name": f"{scope.path}{node.name}", "inputs": {"Color": [0.8, 0.8, 0.8, 1.0]}}
            return self._add(scope, node, entry, "BSDF", "SHADER")
        v = socket_value(out, self.owner, f"{scope.path}{node.name}")
        return None if v is None else ("value", v, out.type)

    def _polychrome(self, scope, node, out):
        """Polychrome's own nodes (nodes.py) on Blender's closures with constant inputs."""
        name = f"{scope.path}{node.name}"
        t = node.bl_idname
        if t == "PolychromeSpectralReflectanceNode":
            entry = {"type": "ShaderNodeBsdfDiffuse", "name": name, "inputs": {"Color": {"spectrum": node.spectrum().to_dict()}}}
            return self._add(scope, node, entry, "BSDF", "SHADER")
        if t == "PolychromeDispersionNode":
            entry = {
                "type": "ShaderNodeBsdfGlass",
                "name": name,
                "props": {"distribution": "GGX"},
                "inputs": {"Color": [1.0, 1.0, 1.0, 1.0], "Roughness": float(node.roughness), "IOR": {"ior": self._dispersion_ior(node)}},
            }
            return self._add(scope, node, entry, "BSDF", "SHADER")
        if t == "PolychromeSpectralEmissionNode":
            entry = {
                "type": "ShaderNodeEmission",
                "name": name,
                "inputs": {"Color": {"spectrum": node.spectrum().to_dict()}, "Strength": float(node.strength)},
            }
            return self._add(scope, node, entry, "Emission", "SHADER")
        return self._unsupported(scope, node, out)

    def _dispersion_ior(self, node):
        node.polychrome_export(self.mat, self.warnings)  # validates the index over 380–780 nm
        return node.polychrome_ior().to_dict()

    # -- real nodes ----------------------------------------------------------------
    def _add(self, scope, node, entry, out_ident, out_type):
        key = (scope.key, node.as_pointer() if node is not None else entry["name"])
        if key not in self._index:
            self.nodes.append(entry)
            self._index[key] = len(self.nodes) - 1
        return ("link", self._index[key], out_ident, out_type)

    def _real(self, scope, node, out):
        key = (scope.key, node.as_pointer())
        name = f"{scope.path}{node.name}"
        legacy = LEGACY.get(node.bl_idname)
        out_ident = legacy[4].get(out.identifier, out.identifier) if legacy else out.identifier
        if key in self._index:
            return ("link", self._index[key], out_ident, out.type)
        if any(k == key for k, _ in self._active):
            start = next(i for i, (k, _) in enumerate(self._active) if k == key)
            ring = " → ".join(n for _, n in self._active[start:]) + f" → {name}"
            raise ValueError(f"{self.owner}: the node graph has a cycle ({ring})")
        self._active.append((key, name))
        try:
            entry = {"type": legacy[0] if legacy else node.bl_idname, "name": name}
            props = self.props(node, name)
            if legacy:
                props = {**legacy[1], **{legacy[2][k]: v for k, v in props.items() if k in legacy[2]}}
            if props:
                entry["props"] = props
            inputs = {}
            for sock in node.inputs:
                if not sock.enabled:
                    continue
                ident = legacy[3].get(sock.identifier, sock.identifier) if legacy else sock.identifier
                got = self.resolve_input(scope, sock)
                if got is None and implicit_input(entry["type"], ident):
                    continue  # absent: the core gives it Blender's implicit value (UV, normal, ...)
                if got is None:
                    v = socket_value(sock, self.owner, name)
                    if v is not None:
                        inputs[ident] = v
                elif got[0] == "link":
                    inputs[ident] = {"link": [got[1], got[2]]}
                else:
                    inputs[ident] = got[1] if isinstance(got[1], dict) else convert_value(got[1], got[2], sock.type)
            entry["inputs"] = inputs
        finally:
            self._active.pop()
        self.nodes.append(entry)
        self._index[key] = len(self.nodes) - 1
        self._note_needs(node, entry, name)
        self.per_hit = self.per_hit or node.bl_idname in PER_HIT
        if entry["type"] == "ShaderNodeEmission" or (
            entry["type"] == "ShaderNodeBsdfPrincipled" and entry["inputs"].get("Emission Strength", 0.0) != 0.0
        ):
            self.emits = True
        return ("link", self._index[key], out_ident, out.type)

    def props(self, node, name):
        """The node's own RNA properties under Blender's names, plus the plain forms of
        Color Ramp, curves and images (docs/shading.md)."""
        base = _base_props()
        props = {}
        for p in node.bl_rna.properties:
            ident = p.identifier
            if ident in base or ident in _SPECIAL_PROPS or p.type in ("POINTER", "COLLECTION"):
                continue
            if ident in ("is_active_output", "target"):
                continue
            props[ident] = _plain(getattr(node, ident))
        t = node.bl_idname
        if t == "ShaderNodeValue":
            props["value"] = socket_value(node.outputs[0], self.owner, name)
        elif t == "ShaderNodeRGB":
            props["color"] = socket_value(node.outputs[0], self.owner, name)
        elif t == "ShaderNodeValToRGB":
            props["color_ramp"] = color_ramp_dict(node.color_ramp)
        elif t in ("ShaderNodeRGBCurve", "ShaderNodeVectorCurve", "ShaderNodeFloatCurve"):
            props["curves"] = curves_dict(node)
        elif t in ("ShaderNodeTexImage", "ShaderNodeTexEnvironment"):
            props["texture"] = None  # set by convert_textures()
            if node.image is not None:
                props["alpha_mode"] = node.image.alpha_mode
                self._images.append((props, node, name, len(self.nodes)))  # its index once appended
            else:  # magenta, as Cycles reads it, silently (a node not yet given an image is no error;
                # Blender's USD importer leaves a missing file's node so, and says so itself)
                props["texture"], props["associated"] = missing_texture(), False
        elif t == "ShaderNodeTexCoord" and node.object is not None:
            self.warnings.add(
                ("texcoord-object", self.name, name),
                f"{self.owner}: node '{name}': the Object output relative to object '{node.object.name}' is not supported "
                "(this object's coordinates are used)",
            )
        return props

    def _note_needs(self, node, entry, name):
        t = node.bl_idname
        props = entry.get("props", {})
        who = f"{self.owner} node '{name}'"
        need = []
        if t == "ShaderNodeUVMap":
            need.append(("uv", props.get("uv_map", "")))
        elif t == "ShaderNodeTangent" and props.get("direction_type") == "UV_MAP":
            need += [("uv", props.get("uv_map", "")), ("tangent", props.get("uv_map", ""))]
        elif t == "ShaderNodeNormalMap" and props.get("space") == "TANGENT":
            need += [("uv", props.get("uv_map", "")), ("tangent", props.get("uv_map", ""))]
        elif t == "ShaderNodeVertexColor":
            need.append(("color", props.get("layer_name", "")))
        elif t == "ShaderNodeAttribute" and props.get("attribute_type", "GEOMETRY") == "GEOMETRY":
            need.append(("attribute", props.get("attribute_name", "")))
        elif t == "ShaderNodeTexImage" and "Vector" not in entry["inputs"]:
            need.append(("uv", ""))
        for k in need:
            self.needs.setdefault(k, who)


def index_reads_alpha(nodes, index):
    """Whether some node of ``nodes`` reads the Alpha output of node ``index``."""
    return any(
        isinstance(inp, dict) and inp.get("link") is not None and inp["link"][0] == index and inp["link"][1] == "Alpha"
        for n in nodes
        for inp in n.get("inputs", {}).values()
    )


def export_graph(mat, warnings, textures):
    """``(nodes, output, needs)`` of a node material, or None when nothing is on Surface."""
    g = GraphExport(mat, warnings, textures)
    got = g.export()
    if got is None:
        return None
    g.convert_textures()
    return got[0], got[1], g.needs


__all__ = ["GraphExport", "SUPPORTED", "PER_HIT", "export_graph", "convert_value", "curves_dict", "color_ramp_dict"]
