"""UsdPreviewSurface shading networks → the shading graph of docs/shading.md.

A UsdPreviewSurface whose inputs are driven by ``UsdUVTexture``, ``UsdTransform2d`` and
``UsdPrimvarReader_*`` shaders becomes a :class:`polychrome.NodeMaterial` in Blender's
node vocabulary, the graph the Blender add-on writes (a Principled BSDF fed by Image
Texture, Mapping, UV Map, Attribute, Math, Vector Math and Separate Color nodes), so
the core compiles USD networks and Blender node trees with one compiler.

The meaning of every node follows the UsdPreviewSurface specification
(openusd.org/release/spec_usdpreviewsurface.html, version 2.5):

* UsdUVTexture: ``file`` sampled at ``st`` with ``wrapS``/``wrapT`` (repeat, mirror,
  clamp, black; ``useMetadata`` reads as repeat), ``sourceColorSpace`` (``raw``,
  ``sRGB``, ``auto``: sRGB for 8-bit images of 3 or 4 channels, else raw), every
  output = texel × ``scale`` + ``bias`` (per channel, after decoding), ``fallback`` when
  the file cannot be read; outputs ``r``, ``g``, ``b``, ``a``, ``rgb``.
* UsdTransform2d: ``in`` × ``scale``, rotated by ``rotation`` degrees counter-clockwise,
  plus ``translation`` — scale first, then rotation, then translation, which is exactly
  Blender's Mapping node of type Point (Cycles' svm_mapping: R·(S·v) + T).
* UsdPrimvarReader_float2: the UV set named by ``varname`` (a UV Map node);
  UsdPrimvarReader_float / float3 / float4 / color...: the primvar as a mesh attribute
  (an Attribute node), e.g. ``displayColor`` per vertex or face-varying.

When every input resolves to a constant (no network, or only textures whose files are
missing) :func:`build` returns the constants and the reader builds the fixed material
as before.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np


@dataclass
class Const:
    value: Any  # float or tuple of floats


@dataclass
class Link:
    node: int
    output: str


#: UsdPreviewSurface inputs read as Principled BSDF inputs: USD name → (kind, spec fallback).
INPUTS = {
    "diffuseColor": ("color", (0.18, 0.18, 0.18)),
    "emissiveColor": ("color", (0.0, 0.0, 0.0)),
    "useSpecularWorkflow": ("float", 0.0),
    "specularColor": ("color", (0.0, 0.0, 0.0)),
    "metallic": ("float", 0.0),
    "roughness": ("float", 0.5),
    "clearcoat": ("float", 0.0),
    "clearcoatRoughness": ("float", 0.01),
    "opacity": ("float", 1.0),
    "opacityThreshold": ("float", 0.0),
    "ior": ("float", 1.5),
}

#: Direct Principled sockets.
SOCKETS = {
    "diffuseColor": "Base Color",
    "metallic": "Metallic",
    "roughness": "Roughness",
    "clearcoat": "Coat Weight",
    "clearcoatRoughness": "Coat Roughness",
    "ior": "IOR",
}

WRAPS = {"repeat": "REPEAT", "mirror": "MIRROR", "clamp": "EXTEND", "black": "CLIP"}
_CHANNEL = {"r": 0, "g": 1, "b": 2, "a": 3}


def _srgb_to_linear(x: np.ndarray) -> np.ndarray:
    """IEC 61966-2-1 decoding."""
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4).astype(np.float32)


def load_texture(path: Path, colour_space: str, wrap: str, name: str):
    """A polychrome.Texture holding what UsdUVTexture reads from ``path``: RGB (one
    channel replicated) and alpha, decoded as ``sourceColorSpace`` says. Raises OSError /
    ValueError when the file cannot be read."""
    from ..imageio import read_image
    from ..texture import Texture, read_radiance_hdr

    suffix = path.suffix.lower()
    if suffix == ".exr":
        a = read_image(path)
        return Texture.from_array(_srgb_to_linear(a[..., :3]) if colour_space == "sRGB" else a, "linear", wrap, name)
    if suffix == ".hdr":
        a = read_radiance_hdr(path)
        return Texture.from_array(_srgb_to_linear(a) if colour_space == "sRGB" else a, "linear", wrap, name)
    from PIL import Image

    try:
        with Image.open(path) as im:
            mode = im.mode
            if mode in ("I;16", "I;16B", "I;16L", "I"):
                a = np.asarray(im, dtype=np.float64)
                a = (a / (65535.0 if mode.startswith("I;16") or a.max() > 255 else 255.0)).astype(np.float32)
                a = np.repeat(a[:, :, None], 3, axis=2)
                eight_bit = False
            elif mode == "F":
                a = np.repeat(np.asarray(im, dtype=np.float32)[:, :, None], 3, axis=2)
                eight_bit = False
            else:
                if mode in ("L", "LA"):
                    la = np.asarray(im.convert("LA"), dtype=np.uint8)
                    a = np.concatenate([np.repeat(la[:, :, :1], 3, axis=2), la[:, :, 1:]], axis=2)
                    channels = 1 if mode == "L" else 2
                else:
                    has_alpha = "A" in mode or "transparency" in im.info
                    a = np.asarray(im.convert("RGBA" if has_alpha else "RGB"), dtype=np.uint8)
                    channels = 4 if has_alpha else 3
                eight_bit = True
    except (OSError, Image.DecompressionBombError, SyntaxError) as exc:
        raise ValueError(str(exc)) from exc
    if eight_bit:
        srgb = colour_space == "sRGB" or (colour_space != "raw" and channels in (3, 4))
        if srgb:
            if a.shape[2] == 4:  # alpha stays linear: a float texture with decoded colour
                f = a.astype(np.float32) / 255.0
                f[..., :3] = _srgb_to_linear(f[..., :3])
                return Texture.from_array(f, "linear", wrap, name)
            return Texture.from_array(a, "srgb", wrap, name)
        return Texture.from_array(a.astype(np.float32) / 255.0, "linear", wrap, name)
    return Texture.from_array(_srgb_to_linear(a) if colour_space == "sRGB" else a, "linear", wrap, name)


def texture_shape(texture) -> tuple[int, int]:
    return int(texture.pixels.shape[0]), int(texture.pixels.shape[1])


_WRAPPED: dict[tuple, Any] = {}


def wrapped_texture(texture, wrap_s: str, wrap_t: str):
    """``texture`` prepared for REPEAT lookups that reproduce ``wrap_s``/``wrap_t``:
    mirrored axes doubled with the flipped image (row 0 is the top: v grows upwards),
    black axes padded by one black, transparent texel on each side."""
    from ..texture import Texture

    key = (id(texture), wrap_s, wrap_t)
    if key in _WRAPPED and _WRAPPED[key][0] is texture:
        return _WRAPPED[key][1]
    a = texture.pixels
    if "black" in (wrap_s, wrap_t) and a.shape[2] == 3:
        alpha = np.full(a.shape[:2] + (1,), 255 if a.dtype == np.uint8 else 1.0, a.dtype)
        a = np.concatenate([a, alpha], axis=2)
    if wrap_s == "mirror":
        a = np.concatenate([a, a[:, ::-1]], axis=1)
    if wrap_t == "mirror":
        a = np.concatenate([a[::-1], a], axis=0)
    if wrap_s == "black":
        a = np.pad(a, ((0, 0), (1, 1), (0, 0)))
    if wrap_t == "black":
        a = np.pad(a, ((1, 1), (0, 0), (0, 0)))
    out = Texture.from_array(np.ascontiguousarray(a), texture.encoding, "REPEAT", texture.name)
    _WRAPPED[key] = (texture, out)
    return out


class Graph:
    """One material's graph, built from its UsdPreviewSurface network."""

    def __init__(self, reader, material_prim, shader):
        self.r = reader
        self.material = material_prim
        self.shader = shader
        self.nodes: list[dict[str, Any]] = []
        self.memo: dict[tuple, Any] = {}
        self.reads: set[tuple[str, str]] = set()  # ("uv" | "attr", primvar name)
        # What a mesh without the primvar reads: (kind, name) → (reader prim path, fallback).
        self.fallbacks: dict[tuple[str, str], tuple[str, tuple[float, ...]]] = {}

    # -- plumbing ----------------------------------------------------------------------
    def add(self, kind: str, name: str, props=None, inputs=None) -> int:
        self.nodes.append({"type": kind, "name": name, "props": props or {}, "inputs": inputs or {}})
        return len(self.nodes) - 1

    def warn(self, key: str, message: str) -> None:
        self.r.warn(f"{key}:{self.material.GetPath()}", f"prim {self.material.GetPath()}: {message}")

    @staticmethod
    def socket(v, kind: str):
        """A Const or Link as the JSON of an input socket."""
        if isinstance(v, Link):
            return {"link": [v.node, v.output]}
        x = v.value
        if kind == "float":
            return float(x[0] if isinstance(x, tuple) else x)
        t = x if isinstance(x, tuple) else (float(x),) * 3
        return [float(c) for c in (tuple(t) + (0.0, 0.0, 0.0))[:3]]

    def value(self, inp, kind: str):
        """What drives a shader input: Const, Link, or None when nothing is authored."""
        if not inp:
            return None
        attrs = inp.GetValueProducingAttributes()
        if not attrs:
            return None
        attr = attrs[0]
        UsdShade = self.r.UsdShade
        if UsdShade.Output.IsOutput(attr):
            out = UsdShade.Output(attr)
            source = UsdShade.Shader(attr.GetPrim())
            return self.output(source, str(out.GetBaseName()), kind, inp)
        v = attr.Get(self.r.time)
        if v is None:
            return None
        return Const(self.plain(v, kind))

    def raw(self, inp):
        """The value of a non-connectable input (file, tokens), following connections to
        a material's or node graph's interface inputs; None when nothing is authored."""
        if not inp:
            return None
        attrs = inp.GetValueProducingAttributes()
        if not attrs or self.r.UsdShade.Output.IsOutput(attrs[0]):
            return None
        return attrs[0].Get(self.r.time)

    def plain(self, v, kind: str):
        if isinstance(v, str) or kind == "string":
            return str(v)
        try:
            t = tuple(float(c) for c in v)
        except TypeError:
            t = float(v)
        vals = t if isinstance(t, tuple) else (t,)
        if not all(math.isfinite(c) for c in vals):
            raise self.r.error(self.material, "its UsdPreviewSurface inputs are not finite")
        return t

    def const(self, inp, default):
        """A constant input of a non-surface shader (rotation, scale, ...)."""
        v = self.value(inp, "float" if not isinstance(default, tuple) else "color")
        if v is None:
            return default
        if isinstance(v, Link):
            self.warn(
                f"linkparam:{inp.GetAttr().GetPath()}",
                f"{inp.GetAttr().GetPath()} is connected; only a constant is supported there, its fallback is used",
            )
            return default
        return v.value

    def output(self, shader, name: str, kind: str, consumer):
        key = (str(shader.GetPath()), name, kind)
        if key not in self.memo:
            self.memo[key] = self._output(shader, name, kind, consumer)
        return self.memo[key]

    def _output(self, shader, name: str, kind: str, consumer):
        sid = str(shader.GetShaderId() or "")
        path = shader.GetPath()
        if sid == "UsdUVTexture":
            return self.texture_output(shader, name, kind)
        if sid == "UsdTransform2d":
            return self.transform2d(shader)
        if sid.startswith("UsdPrimvarReader_"):
            return self.primvar_reader(shader, sid[len("UsdPrimvarReader_") :], kind)
        self.r.warn(
            f"node:{path}",
            f"prim {path}: shader '{sid}' driving {consumer.GetAttr().GetPath()} is not supported; the input's fallback is used",
        )
        return None

    def uv_set_of(self, link) -> str:
        """The UV set the nodes upstream of ``link`` read ("" = the default set): the
        first UV Map met walking back through their inputs."""
        seen, stack = set(), [link.node] if isinstance(link, Link) else []
        while stack:
            i = stack.pop()
            if i in seen:
                continue
            seen.add(i)
            node = self.nodes[i]
            if node["type"] == "ShaderNodeUVMap":
                return str(node["props"].get("uv_map", ""))
            if node["type"] == "ShaderNodeTexImage" and "Vector" not in node["inputs"]:
                return ""
            stack += [v["link"][0] for v in node["inputs"].values() if isinstance(v, dict) and "link" in v]
        return ""

    # -- nodes -------------------------------------------------------------------------
    def primvar_reader(self, shader, ty: str, kind: str):
        var = self.value(shader.GetInput("varname"), "string")
        varname = str(var.value) if isinstance(var, Const) else ""
        if not varname:
            self.r.warn(f"varname:{shader.GetPath()}", f"prim {shader.GetPath()}: primvar reader without a varname; its fallback is used")
            fb = self.value(shader.GetInput("fallback"), kind)
            return fb if isinstance(fb, Const) else None
        # The reader's fallback (spec: zeros of its type) for meshes without the primvar.
        width = {"float2": 2, "float3": 3, "normal": 3, "point": 3, "vector": 3, "float4": 4}.get(ty, 1)
        fb = self.value(shader.GetInput("fallback"), "vector" if width > 1 else "float")
        fb_t = fb.value if isinstance(fb, Const) else 0.0
        fb_t = tuple(float(c) for c in (fb_t if isinstance(fb_t, tuple) else (fb_t,)))
        fb_t = (fb_t + (0.0,) * width)[:width]
        tag = "uv" if ty == "float2" else "attr"
        self.fallbacks.setdefault((tag, varname), (str(shader.GetPath()), fb_t))
        if ty == "float2":
            self.r.uv_names.add(varname)
            self.reads.add(("uv", varname))
            return Link(self.add("ShaderNodeUVMap", f"{shader.GetPath()}", {"uv_map": varname}), "UV")
        self.r.attribute_names.add(varname)
        self.reads.add(("attr", varname))
        node = self.add("ShaderNodeAttribute", f"{shader.GetPath()}", {"attribute_name": varname, "attribute_type": "GEOMETRY"})
        if ty in ("float", "int"):
            return Link(node, "Fac")
        return Link(node, "Color" if kind == "color" else "Vector")

    def transform2d(self, shader):
        vin = self.value(shader.GetInput("in"), "vector")
        # rotation, scale, translation: constants (a connection to the material's
        # interface inputs resolves to their value), or connected to a network (a
        # primvar reader, a texture): then the Mapping's sockets are driven by it,
        # evaluated at every hit like any input.
        path = str(shader.GetPath())
        inputs: dict[str, Any] = {}
        rotation = self.value(shader.GetInput("rotation"), "float")
        if isinstance(rotation, Link):
            deg = self.add(
                "ShaderNodeMath",
                f"{path} rotation",
                {"operation": "MULTIPLY"},
                {"Value": self.socket(rotation, "float"), "Value_001": math.pi / 180.0},
            )
            comb = self.add("ShaderNodeCombineXYZ", f"{path} rotation", inputs={"X": 0.0, "Y": 0.0, "Z": {"link": [deg, "Value"]}})
            inputs["Rotation"] = {"link": [comb, "Vector"]}
        else:
            r = 0.0 if rotation is None else rotation.value
            inputs["Rotation"] = [0.0, 0.0, math.radians(float(r[0] if isinstance(r, tuple) else r))]
        for socket, usd_name, default, z in (("Scale", "scale", (1.0, 1.0), 1.0), ("Location", "translation", (0.0, 0.0), 0.0)):
            v = self.value(shader.GetInput(usd_name), "vector")
            if isinstance(v, Link):
                sep = self.add("ShaderNodeSeparateXYZ", f"{path} {usd_name}", inputs={"Vector": self.socket(v, "vector")})
                comb = self.add(
                    "ShaderNodeCombineXYZ", f"{path} {usd_name}", inputs={"X": {"link": [sep, "X"]}, "Y": {"link": [sep, "Y"]}, "Z": z}
                )
                inputs[socket] = {"link": [comb, "Vector"]}
            else:
                t = default if v is None else v.value
                t = t if isinstance(t, tuple) else (float(t),) * 2
                inputs[socket] = [float(t[0]), float(t[1]), z]
        if vin is None:  # UsdTransform2d's `in` fallback is (0, 0)
            vin = Const((0.0, 0.0, 0.0))
        inputs["Vector"] = self.socket(vin, "vector")
        return Link(self.add("ShaderNodeMapping", f"{shader.GetPath()}", {"vector_type": "POINT"}, inputs), "Vector")

    def texture_file(self, shader):
        """(Texture or None, colour space) of a UsdUVTexture; warns once per prim."""
        key = str(shader.GetPath())
        if key in self.r.textures:
            return self.r.textures[key]
        self.r.textures[key] = None  # warn once, whatever happens below
        value = self.raw(shader.GetInput("file"))
        if value is None or not (getattr(value, "path", "") or ""):
            self.r.warn(f"texfile:{key}", f"prim {key}: {shader.GetShaderId() or 'UsdUVTexture'} without a file; its fallback is used")
            return None
        path = self.r.asset_path(value, shader.GetPrim(), "texture file")
        if path is None:
            return None
        cs = self.colour_space(shader)
        from . import attributes as A

        name = str(self.r.custom(shader.GetPrim(), A.NAME, path.name))
        try:
            texture = load_texture(path, cs, "REPEAT", name)
        except (OSError, ValueError) as e:
            self.r.warn(f"unreadable:{key}", f"prim {key}: cannot read texture {path} ({e}); its fallback is used")
            return None
        self.r.textures[key] = texture
        return texture

    def colour_space(self, shader) -> str:
        """ "raw", "sRGB" or "auto": how the texture's file is decoded."""
        key = str(shader.GetPath())
        cs = self.raw(shader.GetInput("sourceColorSpace"))
        if cs is None:
            cs = self.raw(shader.GetInput("isSRGB"))  # its name in stages written before the 2.3 spec
        cs = "auto" if cs is None else str(cs)
        cs = {"True": "sRGB", "False": "raw", "1": "sRGB", "0": "raw"}.get(cs, cs)
        if cs not in ("raw", "sRGB", "auto"):
            self.r.warn(f"colorspace:{key}", f"prim {key}: sourceColorSpace '{cs}' is not known; read as auto")
            cs = "auto"
        return cs

    def texture_coordinates(self, shader):
        """What drives the texture's coordinates (None: the default UV set)."""
        return self.value(shader.GetInput("st"), "vector")

    def interpolation(self, shader) -> str:
        return "Linear"  # UsdUVTexture is bilinear

    def wraps(self, shader) -> tuple[str, str]:
        return self.wrap(shader, "wrapS"), self.wrap(shader, "wrapT")

    def wrap(self, shader, which: str) -> str:
        w = self.raw(shader.GetInput(which))
        w = "useMetadata" if w is None else str(w)
        if w not in WRAPS:
            if w != "useMetadata":
                self.r.warn(f"wrap:{shader.GetPath()}", f"prim {shader.GetPath()}: {which} '{w}' is not known; repeat is used")
            w = "repeat"
        return w

    def texture_node(self, shader):
        """(node index of the Image Texture, scale, bias), or None when the file is unusable."""
        key = ("image", str(shader.GetPath()))
        if key in self.memo:
            return self.memo[key]
        texture = self.texture_file(shader)
        result = None
        if texture is not None:
            st = self.texture_coordinates(shader)
            ws, wt = self.wraps(shader)
            inputs: dict[str, Any] = {}
            if ws == wt:
                extension = WRAPS[ws]
            else:
                # The core has one extension per image: mixed modes become REPEAT on an
                # image prepared per axis, exactly (the bilinear filter included): mirror
                # = the image and its flipped copy repeated (coordinate / 2), clamp = the
                # coordinate clamped to the edge texels' centres, black = one black
                # texel around the image and the coordinate clamped to its centres.
                extension = "REPEAT"
                texture = wrapped_texture(texture, ws, wt)
                if st is None:
                    st = Link(self.add("ShaderNodeUVMap", f"{shader.GetPath()} st", {"uv_map": ""}), "UV")
                sep = self.add("ShaderNodeSeparateXYZ", f"{shader.GetPath()} st", inputs={"Vector": self.socket(st, "vector")})
                h, w = texture_shape(self.texture_file(shader))
                axes = []
                for mode, out, n in ((ws, "X", w), (wt, "Y", h)):
                    src: Any = {"link": [sep, out]}
                    if mode == "mirror":
                        src = {
                            "link": [
                                self.add("ShaderNodeMath", "mirror", {"operation": "MULTIPLY"}, {"Value": src, "Value_001": 0.5}),
                                "Value",
                            ]
                        }
                    elif mode in ("clamp", "black"):
                        m = n
                        if mode == "black":
                            m = n + 2
                            op = {"operation": "MULTIPLY_ADD"}
                            src = {
                                "link": [
                                    self.add("ShaderNodeMath", "border", op, {"Value": src, "Value_001": n / m, "Value_002": 1.0 / m}),
                                    "Value",
                                ]
                            }
                        lo, hi = 0.5 / m, 1.0 - 0.5 / m
                        clamp = self.add("ShaderNodeClamp", "clamp", {"clamp_type": "MINMAX"}, {"Value": src, "Min": lo, "Max": hi})
                        src = {"link": [clamp, "Result"]}
                    axes.append(src)
                st = Link(self.add("ShaderNodeCombineXYZ", "st", inputs={"X": axes[0], "Y": axes[1], "Z": 0.0}), "Vector")
            if st is not None:
                inputs["Vector"] = self.socket(st, "vector")
            img = self.add(
                "ShaderNodeTexImage",
                str(shader.GetPath()),
                {"texture": texture, "interpolation": self.interpolation(shader), "extension": extension},
                inputs,
            )
            scale = self.const(shader.GetInput("scale"), (1.0, 1.0, 1.0, 1.0))
            bias = self.const(shader.GetInput("bias"), (0.0, 0.0, 0.0, 0.0))
            result = (img, tuple(scale) + (1.0,) * (4 - len(scale)), tuple(bias) + (0.0,) * (4 - len(bias)))
        self.memo[key] = result
        return result

    def texture_output(self, shader, name: str, kind: str):
        if name not in ("r", "g", "b", "a", "rgb", "rgba"):
            self.r.warn(
                f"texout:{shader.GetPath()}:{name}",
                f"prim {shader.GetPath()}: output '{name}' is not a UsdUVTexture output; the fallback is used",
            )
            return None
        t = self.texture_node(shader)
        if t is None:
            fb = self.const(shader.GetInput("fallback"), (0.0, 0.0, 0.0, 1.0))
            fb = tuple(fb) + (0.0, 0.0, 0.0, 1.0)[len(fb) :]
            if name in _CHANNEL:
                return Const(fb[_CHANNEL[name]])
            # Not authored: the preview surface input's own fallback (None).
            fb_in = shader.GetInput("fallback")
            return Const(tuple(fb[:3])) if fb_in and fb_in.GetAttr().HasAuthoredValue() else None
        img, scale, bias = t
        if name == "a":
            key = ("alpha", str(shader.GetPath()))
            if key not in self.memo:
                link = Link(img, "Alpha")
                if scale[3] != 1.0 or bias[3] != 0.0:
                    link = Link(
                        self.add(
                            "ShaderNodeMath",
                            "scale/bias a",
                            {"operation": "MULTIPLY_ADD"},
                            {"Value": {"link": [img, "Alpha"]}, "Value_001": scale[3], "Value_002": bias[3]},
                        ),
                        "Value",
                    )
                self.memo[key] = link
            return self.memo[key]
        key = ("rgb", str(shader.GetPath()))
        if key not in self.memo:
            link = Link(img, "Color")
            if scale[:3] != (1.0, 1.0, 1.0) or bias[:3] != (0.0, 0.0, 0.0):
                n = self.add(
                    "ShaderNodeVectorMath",
                    "scale/bias rgb",
                    {"operation": "MULTIPLY_ADD"},
                    {"Vector": {"link": [img, "Color"]}, "Vector_001": list(scale[:3]), "Vector_002": list(bias[:3])},
                )
                link = Link(n, "Vector")
            self.memo[key] = link
        rgb = self.memo[key]
        if name in ("rgb", "rgba"):
            return rgb
        key = ("sep", str(shader.GetPath()))
        if key not in self.memo:
            self.memo[key] = self.add("ShaderNodeSeparateColor", "channels", {"mode": "RGB"}, {"Color": {"link": [rgb.node, rgb.output]}})
        return Link(self.memo[key], {"r": "Red", "g": "Green", "b": "Blue"}[name])


def smooth_tangents(vertices, triangles, uvs, normals=None) -> np.ndarray:
    """(V, 4) tangents of the UV set ``uvs`` (tangent xyz, bitangent sign), as the core's
    ``smooth_tangents`` derives them for the default set (rust/core/src/scene/hit.rs):
    each triangle's ∂p/∂u and ∂p/∂v weighted by its angle at the vertex and summed,
    the sum made orthogonal to the vertex normal, the sign that of (n × t) · Σ ∂p/∂v.
    Vertices that get nothing have a zero tangent (the core then uses the triangle's
    ∂p/∂u of the default UVs)."""
    p = np.asarray(vertices, np.float64)
    uv = np.asarray(uvs, np.float64)
    tri = np.asarray(triangles, np.int64)
    e1, e2 = p[tri[:, 1]] - p[tri[:, 0]], p[tri[:, 2]] - p[tri[:, 0]]
    d1, d2 = uv[tri[:, 1]] - uv[tri[:, 0]], uv[tri[:, 2]] - uv[tri[:, 0]]
    det = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    face = np.cross(e1, e2)
    ok = (np.abs(det) >= 1e-12) & (np.einsum("ij,ij->i", face, face) > 0)
    safe = np.where(ok, det, 1.0)[:, None]

    def unit(v):
        n = np.linalg.norm(v, axis=-1, keepdims=True)
        return np.divide(v, n, out=np.zeros_like(v), where=n > 0)

    t = unit((e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) / safe)
    b = unit((e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) / safe)
    f = unit(face)
    ts, bs, ns = (np.zeros_like(p) for _ in range(3))
    for k in range(3):
        a, c = p[tri[:, (k + 1) % 3]] - p[tri[:, k]], p[tri[:, (k + 2) % 3]] - p[tri[:, k]]
        la, lc = np.linalg.norm(a, axis=1), np.linalg.norm(c, axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            angle = np.arccos(np.clip(np.einsum("ij,ij->i", a, c) / (la * lc), -1.0, 1.0))
        w = np.where(ok & np.isfinite(angle), angle, 0.0)[:, None]
        np.add.at(ts, tri[:, k], t * w)
        np.add.at(bs, tri[:, k], b * w)
        np.add.at(ns, tri[:, k], f * w)
    n = unit(np.asarray(normals, np.float64) if normals is not None else ns)
    tt = unit(ts - n * np.einsum("ij,ij->i", n, ts)[:, None])
    sign = np.where(np.einsum("ij,ij->i", np.cross(n, tt), bs) < 0, -1.0, 1.0)
    return np.concatenate([tt, sign[:, None]], axis=1).astype(np.float32)


def _triple(v) -> tuple[float, float, float]:
    t = tuple(float(x) for x in v) if isinstance(v, tuple) else (float(v),) * 3
    return (t + t[-1:] * 3)[:3]


def build(reader, material_prim, shader, name: str, graph_class=None):
    """(NodeMaterial, None) when some input of ``shader`` varies over the surface, else
    (None, {input: constant}) with every input of :data:`INPUTS` resolved (missing
    textures replaced by their fallbacks)."""
    from ..scene import NodeMaterial

    g = (graph_class or Graph)(reader, material_prim, shader)  # materialx.MxGraph: MaterialX pattern nodes too
    values = {}
    for usd_name, (kind, fallback) in INPUTS.items():
        v = g.value(shader.GetInput(usd_name), kind)
        values[usd_name] = Const(fallback) if v is None else v
    normal = g.value(shader.GetInput("normal"), "vector")
    if isinstance(normal, Const):
        # A constant tangent-space normal other than +Z tilts the whole surface: rare, not supported.
        n = _triple(normal.value)
        if n != (0.0, 0.0, 1.0):
            g.warn("unsupported:normal", f"a constant normal {n} is not supported and is ignored")
        normal = None
    # Warned when connected, or (displacement, occlusion) authored away from the fallback.
    for unsupported, what, neutral in (
        ("displacement", "displacement", 0.0),
        ("occlusion", "occlusion", 1.0),
    ):
        inp = shader.GetInput(unsupported)
        authored = inp and neutral is not None and inp.GetAttr().HasAuthoredValue() and inp.Get(reader.time) not in (None, neutral)
        if inp and (inp.HasConnectedSource() or authored):
            g.warn(f"unsupported:{unsupported}", f"{what} ({unsupported}) are not supported yet and are ignored")
    threshold = values["opacityThreshold"]
    if isinstance(threshold, Link):
        g.warn("threshold", "a connected opacityThreshold is not supported; 0 is used")
        threshold = Const(0.0)
    thr = float(threshold.value if not isinstance(threshold.value, tuple) else threshold.value[0])
    varying = normal is not None or any(isinstance(v, Link) for v in values.values())
    if not varying and thr <= 0.0:
        return None, {k: v.value for k, v in values.items()}

    inputs: dict[str, Any] = {}
    for usd_name, socket in SOCKETS.items():
        kind = INPUTS[usd_name][0]
        inputs[socket] = g.socket(values[usd_name], kind)
    emissive = values["emissiveColor"]
    if isinstance(emissive, Link) or max(_triple(emissive.value)) > 0.0:
        inputs["Emission Color"] = g.socket(emissive, "color")
        inputs["Emission Strength"] = 1.0
    spec_wf = values["useSpecularWorkflow"]
    if isinstance(spec_wf, Const) and float(spec_wf.value if not isinstance(spec_wf.value, tuple) else spec_wf.value[0]) >= 0.5:
        # Specular workflow: F0 = specularColor, no metal. Principled's F0 is
        # ((n−1)/(n+1))² × tint, so n is chosen from the brightest channel and the tint
        # carries the colour; a textured specularColor tints the F0 of `ior`.
        inputs["Metallic"] = 0.0
        sc = values["specularColor"]
        if isinstance(sc, Link):
            g.warn("specular", "a textured specularColor tints the Fresnel of ior (approximated)")
            inputs["Specular Tint"] = g.socket(sc, "color")
        else:
            c = [min(max(float(x), 0.0), 1.0) for x in _triple(sc.value)]
            m = max(c)
            if m <= 0.0:
                inputs["Specular IOR Level"] = 0.0
            else:
                s = math.sqrt(min(m, 0.999))
                inputs["IOR"] = (1.0 + s) / (1.0 - s)
                inputs["Specular Tint"] = [x / m for x in c]
    opacity = values["opacity"]
    if thr > 0.0:
        # Cut-out: fragments with opacity < opacityThreshold are discarded, the rest opaque.
        if isinstance(opacity, Link):
            lt = g.add(
                "ShaderNodeMath", "opacity < threshold", {"operation": "LESS_THAN"}, {"Value": g.socket(opacity, "float"), "Value_001": thr}
            )
            keep = g.add("ShaderNodeMath", "kept", {"operation": "SUBTRACT"}, {"Value": 1.0, "Value_001": {"link": [lt, "Value"]}})
            inputs["Alpha"] = {"link": [keep, "Value"]}
        else:
            inputs["Alpha"] = 0.0 if float(g.socket(opacity, "float")) < thr else 1.0
    elif isinstance(opacity, Link):
        # Partial coverage, as Blender's USD importer reads it (Principled Alpha).
        inputs["Alpha"] = g.socket(opacity, "float")
    elif float(g.socket(opacity, "float")) < 1.0:
        # Spec: a transparent surface still has its specular response (clear glass).
        inputs["Transmission Weight"] = 1.0 - float(g.socket(opacity, "float"))
    tangent_uv = None
    if normal is not None:
        # The spec's normal is tangent space in [-1, 1]³ (after the texture's scale and
        # bias), +X along increasing s, +Y along increasing t, +Z the surface normal: the
        # Normal Map node's tangent space (Cycles svm_node_normal_map), whose Color is
        # in [0, 1] (n = 2·(c − ½)), so c = ½·n + ½. The tangents are those of the UV set
        # the texture reads. The normal perturbs the coat too (one surface normal).
        tangent_uv = g.uv_set_of(normal)
        c = g.add(
            "ShaderNodeVectorMath",
            "normal to colour",
            {"operation": "MULTIPLY_ADD"},
            {"Vector": g.socket(normal, "vector"), "Vector_001": [0.5, 0.5, 0.5], "Vector_002": [0.5, 0.5, 0.5]},
        )
        nm = g.add(
            "ShaderNodeNormalMap",
            f"{shader.GetPath()} normal",
            {"space": "TANGENT", "uv_map": tangent_uv},
            {"Strength": 1.0, "Color": {"link": [c, "Vector"]}},
        )
        inputs["Normal"] = {"link": [nm, "Normal"]}
        inputs["Coat Normal"] = {"link": [nm, "Normal"]}
    principled = g.add("ShaderNodeBsdfPrincipled", str(shader.GetPath()), {}, inputs)
    material = NodeMaterial(name, g.nodes, {"surface": [principled, "BSDF"]})
    material.usd_primvar_reads = frozenset(g.reads)  # checked against each bound mesh
    material.usd_primvar_fallbacks = dict(g.fallbacks)  # what a mesh without one reads
    material.usd_tangent_uv = tangent_uv  # None: no normal map; "": the mesh's default UV set
    return material, None
