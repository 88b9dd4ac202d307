"""MaterialX shading networks in USD → the shading graph of docs/shading.md.

Stages from Houdini/Solaris, Omniverse and MaterialX's own USD examples bind materials
whose surface (``outputs:surface`` or ``outputs:mtlx:surface``) is a UsdShade Shader with
a MaterialX node id: ``ND_standard_surface_surfaceshader`` (Autodesk Standard Surface),
``ND_open_pbr_surface_surfaceshader`` (OpenPBR Surface) or ``ND_gltf_pbr_surfaceshader``,
fed by MaterialX pattern nodes (``ND_image_color3``, ``ND_texcoord_vector2``,
``ND_multiply_color3``...). Each becomes one Principled BSDF of the graph the Blender
add-on writes, fed by Blender's nodes, so the core compiles these networks with the
same compiler as UsdPreviewSurface networks (``preview.py``, whose texture, primvar and
normal-map machinery this reuses) and Blender node trees.

Parameter correspondences follow Blender's own MaterialX export of the Principled BSDF
(``node_shader_bsdf_principled.cc``, which writes a standard_surface: base_color ← Base
Color with base 1, metalness ← Metallic, specular_roughness ← Roughness, specular_IOR ←
IOR, specular_color ← Specular Tint, transmission ← Transmission Weight, coat / coat_color
/ coat_roughness / coat_IOR ← Coat Weight / Tint / Roughness / IOR, sheen / sheen_color /
sheen_roughness ← Sheen Weight / Tint / Roughness, emission / emission_color ← Emission
Strength / Color, opacity ← Alpha), read in reverse; the nodes' defaults and meanings are
MaterialX 1.38/1.39's (libraries/stdlib/stdlib_defs.mtlx, stdlib_ng.mtlx,
libraries/bxdf/standard_surface.mtlx, open_pbr_surface.mtlx, gltf_pbr.mtlx).
Every parameter the core cannot render is one warning naming the prim and the parameter.
"""

from __future__ import annotations

import math
from typing import Any

from . import preview
from .preview import Const, Link

SURFACES = (
    "ND_standard_surface_surfaceshader",
    "ND_standard_surface_surfaceshader_100",
    "ND_open_pbr_surface_surfaceshader",
    "ND_gltf_pbr_surfaceshader",
)

_WIDTH = {"float": 1, "integer": 1, "boolean": 1, "vector2": 2, "vector3": 3, "color3": 3, "vector4": 4, "color4": 4}
_MX_WRAP = {"periodic": "repeat", "mirror": "mirror", "clamp": "clamp", "constant": "black"}
_BINARY = {
    "add": "ADD",
    "subtract": "SUBTRACT",
    "multiply": "MULTIPLY",
    "divide": "DIVIDE",
    "min": "MINIMUM",
    "max": "MAXIMUM",
    "power": "POWER",
}
_PY = {
    "ADD": lambda a, b: a + b,
    "SUBTRACT": lambda a, b: a - b,
    "MULTIPLY": lambda a, b: a * b,
    "DIVIDE": lambda a, b: a / b if b != 0 else 0.0,  # Cycles' safe division
    "MINIMUM": min,
    "MAXIMUM": max,
    "POWER": lambda a, b: a**b if a > 0 or float(b).is_integer() else 0.0,  # Cycles' safe power
}
#: MaterialX's luminance uses the working space's luma coefficients (the spec lets
#: applications take them from it): Polychrome's is linear Rec.709.
REC709_LUMA = (0.2126, 0.7152, 0.0722)


def is_materialx(shader_id: str) -> bool:
    return shader_id in SURFACES


def translates(shader_id: str) -> bool:
    """A surface the reader translates: these, or MaterialX's UsdPreviewSurface."""
    return shader_id in SURFACES or shader_id == "ND_UsdPreviewSurface_surfaceshader"


def parse_id(sid: str) -> tuple[str, list[str]]:
    """("multiply", ["color3FA"]) from "ND_multiply_color3FA"; ("convert", ["float", "color3"]) ..."""
    parts = sid[3:].split("_")
    return parts[0], parts[1:]


def _tuple(v) -> tuple[float, ...]:
    return tuple(float(c) for c in v) if isinstance(v, tuple) else (float(v),)


class MxGraph(preview.Graph):
    """A material's graph from its MaterialX network (pattern nodes by id)."""

    def __init__(self, reader, material_prim, shader):
        super().__init__(reader, material_prim, shader)
        self.alpha: dict[tuple, Any] = {}  # (node, output) of a 4-wide value → its 4th component
        self.tangent_uv = None

    # -- dispatch ----------------------------------------------------------------------
    def _output(self, shader, name: str, kind: str, consumer):
        sid = str(shader.GetShaderId() or "")
        usd_ids = {"ND_UsdUVTexture": "UsdUVTexture", "ND_UsdTransform2d": "UsdTransform2d"}
        if sid in usd_ids or sid.startswith("ND_UsdPrimvarReader_"):
            # MaterialX's definitions of the UsdPreviewSurface nodes (usd_preview_surface.mtlx).
            plain = usd_ids.get(sid) or "UsdPrimvarReader_" + sid.rsplit("_", 1)[1].replace("vector", "float").replace("color3", "float3")
            if plain == "UsdUVTexture":
                return self.texture_output(shader, name, kind)
            if plain == "UsdTransform2d":
                return self.transform2d(shader)
            return self.primvar_reader(shader, plain[len("UsdPrimvarReader_") :], kind)
        if not sid.startswith("ND_"):
            return super()._output(shader, name, kind, consumer)
        node, types = parse_id(sid)
        handler = getattr(self, f"mx_{node}", None)
        if handler is None:
            return self.unknown(shader, sid, consumer)
        return handler(shader, name, types, kind)

    def unknown(self, shader, sid, consumer):
        path = shader.GetPath()
        self.r.warn(
            f"node:{path}",
            f"prim {path}: MaterialX node '{sid}' driving {consumer.GetAttr().GetPath()} is not supported; the input's default value is used",
        )
        return None

    # -- helpers -----------------------------------------------------------------------
    def inp(self, shader, name: str, default, kind: str = "vector"):
        """An input's Const or Link; ``default`` (MaterialX's nodedef value) when unauthored."""
        v = self.value(shader.GetInput(name), "float" if not isinstance(default, tuple) else kind)
        return Const(default) if v is None else v

    def alpha_of(self, v):
        """The 4th component of a 4-wide value (1 when it has none)."""
        if isinstance(v, Link):
            return self.alpha.get((v.node, v.output), Const(1.0))
        t = _tuple(v.value)
        return Const(t[3] if len(t) > 3 else 1.0)

    def with_alpha(self, rgb, a):
        if isinstance(rgb, Const):
            if isinstance(a, Const):
                return Const(_tuple(rgb.value)[:3] + (float(_tuple(a.value)[0]),))
            rgb = Link(
                self.add("ShaderNodeCombineXYZ", "rgba", inputs={k: c for k, c in zip("XYZ", (_tuple(rgb.value) * 3)[:3])}), "Vector"
            )
        self.alpha[(rgb.node, rgb.output)] = a
        return rgb

    def math(self, op: str, a, b):
        if isinstance(a, Const) and isinstance(b, Const):
            return Const(_PY[op](_tuple(a.value)[0], _tuple(b.value)[0]))
        n = self.add(
            "ShaderNodeMath", op.lower(), {"operation": op}, {"Value": self.socket(a, "float"), "Value_001": self.socket(b, "float")}
        )
        return Link(n, "Value")

    def vmath(self, op: str, a, b):
        if isinstance(a, Const) and isinstance(b, Const):
            x, y = _tuple(a.value), _tuple(b.value)
            n = max(len(x), len(y))
            x, y = (x * n)[:n] if len(x) == 1 else x, (y * n)[:n] if len(y) == 1 else y
            return Const(tuple(_PY[op](p, q) for p, q in zip(x, y)))
        n = self.add(
            "ShaderNodeVectorMath",
            op.lower(),
            {"operation": op},
            {"Vector": self.socket(a, "vector"), "Vector_001": self.socket(b, "vector")},
        )
        return Link(n, "Vector")

    def lerp(self, a, b, t):
        """(1 − t)·a + t·b of colours (t a float)."""
        if all(isinstance(v, Const) for v in (a, b, t)):
            x, y, f = _tuple(a.value), _tuple(b.value), _tuple(t.value)[0]
            x, y = (x * 3)[:3] if len(x) == 1 else x, (y * 3)[:3] if len(y) == 1 else y
            return Const(tuple((1 - f) * p + f * q for p, q in zip(x, y)))
        inputs = {"Factor_Float": self.socket(t, "float"), "A_Vector": self.socket(a, "vector"), "B_Vector": self.socket(b, "vector")}
        return Link(self.add("ShaderNodeMix", "lerp", {"data_type": "VECTOR", "clamp_factor": True}, inputs), "Result_Vector")

    def op(self, op: str, a, b, width: int):
        if width == 1:
            return self.math(op, a, b)
        out = self.vmath(op, a, b)
        if width == 4:
            out = self.with_alpha(out, self.math(op, self.alpha_of(a), self.alpha_of(b)))
        return out

    @staticmethod
    def width(types: list[str]) -> int:
        t = types[0] if types else "float"
        return _WIDTH.get(t.removesuffix("FA").removesuffix("I"), 3)

    def zero(self, width: int, value: float = 0.0):
        return Const(value if width == 1 else (value,) * width)

    # -- math and plumbing nodes ---------------------------------------------------------
    def mx_constant(self, shader, name, types, kind):
        return self.inp(shader, "value", self.zero(self.width(types)).value)

    def mx_dot(self, shader, name, types, kind):
        return self.inp(shader, "in", self.zero(self.width(types)).value)

    def _binary(self, shader, node, types):
        w = self.width(types)
        fa = bool(types) and types[0].endswith("FA")
        d2 = 1.0 if node in ("multiply", "divide", "power") else 0.0
        a = self.inp(shader, "in1", self.zero(w).value)
        b = self.inp(shader, "in2", d2 if fa else self.zero(w, d2).value)
        return self.op(_BINARY[node], a, b, w)

    def mx_add(self, shader, name, types, kind):
        return self._binary(shader, "add", types)

    def mx_subtract(self, shader, name, types, kind):
        return self._binary(shader, "subtract", types)

    def mx_multiply(self, shader, name, types, kind):
        return self._binary(shader, "multiply", types)

    def mx_divide(self, shader, name, types, kind):
        return self._binary(shader, "divide", types)

    def mx_min(self, shader, name, types, kind):
        return self._binary(shader, "min", types)

    def mx_max(self, shader, name, types, kind):
        return self._binary(shader, "max", types)

    def unary(self, math_op: str, vector_op: str | None, x, w: int, py):
        if isinstance(x, Const):
            t = tuple(py(c) for c in _tuple(x.value))
            return Const(t[0] if w == 1 else t)
        if w == 1:
            return Link(self.add("ShaderNodeMath", math_op.lower(), {"operation": math_op}, {"Value": self.socket(x, "float")}), "Value")
        if vector_op:
            out = Link(
                self.add("ShaderNodeVectorMath", vector_op.lower(), {"operation": vector_op}, {"Vector": self.socket(x, "vector")}),
                "Vector",
            )
        else:  # per component
            parts = [self.unary(math_op, None, self.component(x, i), 1, py) for i in range(min(w, 3))]
            parts += [Const(0.0)] * (3 - len(parts))
            out = Link(
                self.add("ShaderNodeCombineXYZ", math_op.lower(), inputs={k: self.socket(p, "float") for k, p in zip("XYZ", parts)}),
                "Vector",
            )
        if w == 4:
            out = self.with_alpha(out, self.unary(math_op, None, self.alpha_of(x), 1, py))
        return out

    def _unary(self, shader, types, math_op, vector_op, py):
        w = self.width(types)
        return self.unary(math_op, vector_op, self.inp(shader, "in", self.zero(w).value), w, py)

    def mx_absval(self, shader, name, types, kind):
        return self._unary(shader, types, "ABSOLUTE", "ABSOLUTE", abs)

    def mx_floor(self, shader, name, types, kind):
        return self._unary(shader, types, "FLOOR", "FLOOR", math.floor)

    def mx_ceil(self, shader, name, types, kind):
        return self._unary(shader, types, "CEIL", "CEIL", math.ceil)

    def mx_sign(self, shader, name, types, kind):
        return self._unary(shader, types, "SIGN", "SIGN", lambda c: float((c > 0) - (c < 0)))

    def mx_sin(self, shader, name, types, kind):
        return self._unary(shader, types, "SINE", "SINE", math.sin)

    def mx_cos(self, shader, name, types, kind):
        return self._unary(shader, types, "COSINE", "COSINE", math.cos)

    def mx_sqrt(self, shader, name, types, kind):
        return self._unary(shader, types, "SQRT", None, lambda c: math.sqrt(c) if c > 0 else 0.0)

    def mx_exp(self, shader, name, types, kind):
        return self._unary(shader, types, "EXPONENT", None, math.exp)

    def mx_modulo(self, shader, name, types, kind):
        """in1 − in2·floor(in1 / in2) (mx_mod: floored), per component (in2 default 1)."""
        w = self.width(types)
        fa = types[0].endswith("FA")
        a = self.inp(shader, "in1", self.zero(w).value)
        b = self.inp(shader, "in2", 1.0 if fa else self.zero(w, 1.0).value)

        def one(x, y):
            if isinstance(x, Const) and isinstance(y, Const):
                p, q = _tuple(x.value)[0], _tuple(y.value)[0]
                return Const(p - q * math.floor(p / q) if q != 0 else 0.0)
            inputs = {"Value": self.socket(x, "float"), "Value_001": self.socket(y, "float")}
            return Link(self.add("ShaderNodeMath", "modulo", {"operation": "FLOORED_MODULO"}, inputs), "Value")

        if w == 1:
            return one(a, b)
        parts = [one(self.component(a, i), self.component(b, i) if not fa else b) for i in range(min(w, 3))]
        parts += [Const(0.0)] * (3 - len(parts))
        if all(isinstance(p, Const) for p in parts):
            return Const(tuple(float(_tuple(p.value)[0]) for p in parts)[:w])
        return Link(self.add("ShaderNodeCombineXYZ", "modulo", inputs={k: self.socket(p, "float") for k, p in zip("XYZ", parts)}), "Vector")

    def mx_normalize(self, shader, name, types, kind):
        x = self.inp(shader, "in", (0.0, 0.0, 0.0))
        return Link(
            self.add("ShaderNodeVectorMath", "normalize", {"operation": "NORMALIZE"}, {"Vector": self.socket(x, "vector")}), "Vector"
        )

    def mx_magnitude(self, shader, name, types, kind):
        x = self.inp(shader, "in", (0.0, 0.0, 0.0))
        return Link(self.add("ShaderNodeVectorMath", "length", {"operation": "LENGTH"}, {"Vector": self.socket(x, "vector")}), "Value")

    def mx_dotproduct(self, shader, name, types, kind):
        a, b = self.inp(shader, "in1", (0.0, 0.0, 0.0)), self.inp(shader, "in2", (0.0, 0.0, 0.0))
        inputs = {"Vector": self.socket(a, "vector"), "Vector_001": self.socket(b, "vector")}
        return Link(self.add("ShaderNodeVectorMath", "dot", {"operation": "DOT_PRODUCT"}, inputs), "Value")

    def mx_crossproduct(self, shader, name, types, kind):
        a, b = self.inp(shader, "in1", (0.0, 0.0, 0.0)), self.inp(shader, "in2", (0.0, 0.0, 0.0))
        inputs = {"Vector": self.socket(a, "vector"), "Vector_001": self.socket(b, "vector")}
        return Link(self.add("ShaderNodeVectorMath", "cross", {"operation": "CROSS_PRODUCT"}, inputs), "Vector")

    def _if(self, shader, types, op: str):
        """value1 > value2 (GREATER_THAN) or ≥ (1 − LESS_THAN) ? in1 : in2."""
        w = self.width(types)
        v1, v2 = self.inp(shader, "value1", 1.0), self.inp(shader, "value2", 0.0)
        in1, in2 = self.inp(shader, "in1", self.zero(w).value), self.inp(shader, "in2", self.zero(w).value)
        t = self.math("GREATER_THAN" if op == ">" else "LESS_THAN", v1, v2) if not all(isinstance(v, Const) for v in (v1, v2)) else None
        if t is None:
            p, q = _tuple(v1.value)[0], _tuple(v2.value)[0]
            return in1 if (p > q if op == ">" else p >= q) else in2
        if op == ">=":
            t = self.math("SUBTRACT", Const(1.0), t)
        if w == 1:
            return self.math("ADD", self.math("MULTIPLY", in1, t), self.math("MULTIPLY", in2, self.math("SUBTRACT", Const(1.0), t)))
        return self.lerp(in2, in1, t)

    def mx_ifgreater(self, shader, name, types, kind):
        return self._if(shader, types, ">")

    def mx_ifgreatereq(self, shader, name, types, kind):
        return self._if(shader, types, ">=")

    def mx_power(self, shader, name, types, kind):
        return self._binary(shader, "power", types)

    def mx_invert(self, shader, name, types, kind):
        """amount − in (amount 1)."""
        w = self.width(types)
        fa = types[0].endswith("FA")
        x = self.inp(shader, "in", self.zero(w).value)
        amount = self.inp(shader, "amount", 1.0 if fa else self.zero(w, 1.0).value)
        return self.op("SUBTRACT", amount, x, w)

    def mx_luminance(self, shader, name, types, kind):
        """dot(in, lumacoeffs) in every channel (alpha kept)."""
        w = self.width(types)
        x = self.inp(shader, "in", self.zero(w).value)
        coeffs = self.inp(shader, "lumacoeffs", REC709_LUMA)
        if isinstance(x, Const) and isinstance(coeffs, Const):
            y = sum(a * b for a, b in zip(_tuple(x.value), _tuple(coeffs.value)))
            out: Any = Const((y, y, y))
        else:
            n = self.add(
                "ShaderNodeVectorMath",
                "luminance",
                {"operation": "DOT_PRODUCT"},
                {"Vector": self.socket(x, "vector"), "Vector_001": self.socket(coeffs, "vector")},
            )
            out = Link(self.add("ShaderNodeCombineXYZ", "luminance", inputs={k: {"link": [n, "Value"]} for k in "XYZ"}), "Vector")
        return self.with_alpha(out, self.alpha_of(x)) if w == 4 else out

    def mx_swizzle(self, shader, name, types, kind):
        """MaterialX 1.38's swizzle: `channels` picks components (r/x, g/y, b/z, a/w, 0, 1)."""
        w_in = _WIDTH.get(types[0], 3) if types else 3
        x = self.inp(shader, "in", self.zero(w_in).value)
        channels = str(self.raw(shader.GetInput("channels")) or "")
        pick = {"r": 0, "x": 0, "g": 1, "y": 1, "b": 2, "z": 2, "a": 3, "w": 3}
        parts = []
        for ch in channels:
            if ch in "01":
                parts.append(Const(float(ch)))
            elif ch in pick:
                parts.append(self.component(x, min(pick[ch], w_in - 1) if pick[ch] < 3 else 3))
            else:
                self.warn(f"swizzle:{shader.GetPath()}", f"{shader.GetPath()}: swizzle channel '{ch}' is not known; 0 is used")
                parts.append(Const(0.0))
        if len(parts) <= 1:
            return parts[0] if parts else Const(0.0)
        rgb = (parts + [Const(0.0)] * 3)[:3]
        if all(isinstance(p, Const) for p in rgb):
            out: Any = Const(tuple(float(_tuple(p.value)[0]) for p in rgb))
        else:
            out = Link(
                self.add("ShaderNodeCombineXYZ", "swizzle", inputs={k: self.socket(p, "float") for k, p in zip("XYZ", rgb)}), "Vector"
            )
        return self.with_alpha(out, parts[3]) if len(parts) == 4 else out

    def mx_colorcorrect(self, shader, name, types, kind):
        """Passed through when its parameters are MaterialX's defaults (the identity); else
        one warning, and `in` passes through uncorrected."""
        neutral = {
            "hue": 0.0,
            "saturation": 1.0,
            "gamma": 1.0,
            "lift": 0.0,
            "gain": 1.0,
            "contrast": 1.0,
            "contrastpivot": 0.5,
            "exposure": 0.0,
        }
        changed = []
        for n, d in neutral.items():
            v = self.value(shader.GetInput(n), "float")
            if v is not None and not (isinstance(v, Const) and _tuple(v.value)[0] == d):
                changed.append(n)
        if changed:
            self.warn(
                f"colorcorrect:{shader.GetPath()}",
                f"{shader.GetPath()}: colorcorrect {', '.join(changed)} are not supported; its input passes through uncorrected",
            )
        return self.inp(shader, "in", self.zero(self.width(types)).value)

    def mx_clamp(self, shader, name, types, kind):
        w = self.width(types)
        fa = types[0].endswith("FA")
        x = self.inp(shader, "in", self.zero(w).value)
        lo = self.inp(shader, "low", 0.0 if fa else self.zero(w).value)
        hi = self.inp(shader, "high", 1.0 if fa else self.zero(w, 1.0).value)
        return self.op("MINIMUM", self.op("MAXIMUM", x, lo, w), hi, w)

    def mx_mix(self, shader, name, types, kind):
        """out = mix·fg + (1 − mix)·bg (no clamping of mix): Blender's Mix A = bg, B = fg."""
        w = self.width(types)
        fg, bg = self.inp(shader, "fg", self.zero(w).value), self.inp(shader, "bg", self.zero(w).value)
        non_uniform = len(types) > 1 and types[1] != "float"
        f = self.inp(shader, "mix", self.zero(w).value if non_uniform else 0.0)
        if all(isinstance(v, Const) for v in (fg, bg, f)):
            x, y, t = _tuple(fg.value), _tuple(bg.value), _tuple(f.value)
            t = t * len(x) if len(t) == 1 else t
            out = tuple(t[i] * x[i] + (1 - t[i]) * y[i] for i in range(len(x)))
            return Const(out if w > 1 else out[0])
        if w == 1:
            props = {"data_type": "FLOAT", "clamp_factor": False}
            n = self.add(
                "ShaderNodeMix",
                "mix",
                props,
                {"Factor_Float": self.socket(f, "float"), "A_Float": self.socket(bg, "float"), "B_Float": self.socket(fg, "float")},
            )
            return Link(n, "Result_Float")
        props = {"data_type": "VECTOR", "clamp_factor": False, "factor_mode": "NON_UNIFORM" if non_uniform else "UNIFORM"}
        inputs = {"A_Vector": self.socket(bg, "vector"), "B_Vector": self.socket(fg, "vector")}
        inputs["Factor_Vector" if non_uniform else "Factor_Float"] = self.socket(f, "vector" if non_uniform else "float")
        out = Link(self.add("ShaderNodeMix", "mix", props, inputs), "Result_Vector")
        if w == 4:
            a = self.math(
                "ADD",
                self.math("MULTIPLY", self.alpha_of(fg), f),
                self.math("MULTIPLY", self.alpha_of(bg), self.math("SUBTRACT", Const(1.0), f)),
            )
            out = self.with_alpha(out, a)
        return out

    def component(self, v, i: int):
        if i == 3:
            return self.alpha_of(v)
        if isinstance(v, Const):
            t = _tuple(v.value)
            return Const(t[i] if i < len(t) else 0.0)
        key = ("separate", v.node, v.output)
        if key not in self.memo:
            self.memo[key] = self.add("ShaderNodeSeparateXYZ", "separate", inputs={"Vector": self.socket(v, "vector")})
        return Link(self.memo[key], "XYZ"[i])

    def mx_extract(self, shader, name, types, kind):
        w = self.width(types)
        idx = self.raw(shader.GetInput("index"))
        idx = 0 if idx is None else int(idx)
        return self.component(self.inp(shader, "in", self.zero(w).value), min(max(idx, 0), w - 1))

    def _separate(self, shader, name, types):
        w = self.width(types)
        v = self.inp(shader, "in", self.zero(w).value)
        i = {"x": 0, "y": 1, "z": 2, "w": 3, "r": 0, "g": 1, "b": 2, "a": 3}.get(name[-1:], 0)
        return self.component(v, i)

    def mx_separate2(self, shader, name, types, kind):
        return self._separate(shader, name, types)

    def mx_separate3(self, shader, name, types, kind):
        return self._separate(shader, name, types)

    def mx_separate4(self, shader, name, types, kind):
        return self._separate(shader, name, types)

    def _combine(self, shader, n):
        parts = [self.inp(shader, f"in{k + 1}", 0.0) for k in range(n)]
        rgb = parts[:3] + [Const(0.0)] * (3 - min(n, 3))
        if all(isinstance(p, Const) for p in rgb):
            out: Any = Const(tuple(float(_tuple(p.value)[0]) for p in rgb))
        else:
            out = Link(
                self.add("ShaderNodeCombineXYZ", "combine", inputs={k: self.socket(p, "float") for k, p in zip("XYZ", rgb)}), "Vector"
            )
        return self.with_alpha(out, parts[3]) if n == 4 else out

    def mx_combine2(self, shader, name, types, kind):
        return self._combine(shader, 2)

    def mx_combine3(self, shader, name, types, kind):
        return self._combine(shader, 3)

    def mx_combine4(self, shader, name, types, kind):
        return self._combine(shader, 4)

    def mx_convert(self, shader, name, types, kind):
        src = types[0] if types else "float"
        dst = types[1] if len(types) > 1 else "color3"
        v = self.inp(shader, "in", self.zero(_WIDTH.get(src, 3)).value)
        if _WIDTH.get(src) == 1 and isinstance(v, Const) and _WIDTH.get(dst, 3) > 1:
            return Const((float(_tuple(v.value)[0]),) * _WIDTH.get(dst, 3))
        return v  # the core broadcasts a float into a vector socket; wider → narrower drops components

    # -- geometry ------------------------------------------------------------------------
    def uv_map(self, name: str, path: str):
        self.r.uv_names.add(name) if name else None
        if name:
            self.reads.add(("uv", name))
            self.fallbacks.setdefault(("uv", name), (path, (0.0, 0.0)))
        return Link(self.add("ShaderNodeUVMap", path, {"uv_map": name}), "UV")

    def mx_texcoord(self, shader, name, types, kind):
        idx = self.raw(shader.GetInput("index"))
        if idx not in (None, 0):
            self.warn(
                f"texcoord:{shader.GetPath()}", f"{shader.GetPath()}: texcoord index {idx} is not supported; the default UV set is used"
            )
        return self.uv_map("", str(shader.GetPath()))

    def mx_geompropvalue(self, shader, name, types, kind):
        prop = self.raw(shader.GetInput("geomprop"))
        w = self.width(types)
        if not prop:
            return self.inp(shader, "default", self.zero(w).value)
        prop, path = str(prop), str(shader.GetPath())
        if w == 2:
            return self.uv_map(prop, path)
        self.r.attribute_names.add(prop)
        self.reads.add(("attr", prop))
        self.fallbacks.setdefault(("attr", prop), (path, _tuple(self.zero(w).value)))
        node = self.add("ShaderNodeAttribute", path, {"attribute_name": prop, "attribute_type": "GEOMETRY"})
        return Link(node, "Fac" if w == 1 else "Color" if kind == "color" else "Vector")

    def mx_place2d(self, shader, name, types, kind):
        """NG_place2d_vector2: SRT (operationorder 0) = ((st − pivot) / scale, rotated by
        mx_rotate_vector2 — clockwise for a positive angle in degrees — minus offset) + pivot;
        TRS (1) = rotate(st − pivot − offset) / scale + pivot. As chains of Mapping nodes
        (Point: R·(S·v) + T, R counter-clockwise, so the angle is negated)."""
        st = self.value(shader.GetInput("texcoord"), "vector") or self.uv_map("", str(shader.GetPath()))
        pivot = _tuple(self.const(shader.GetInput("pivot"), (0.0, 0.0)))
        scale = _tuple(self.const(shader.GetInput("scale"), (1.0, 1.0)))
        rot = -math.radians(float(_tuple(self.const(shader.GetInput("rotate"), 0.0))[0]))
        offset = _tuple(self.const(shader.GetInput("offset"), (0.0, 0.0)))
        order = self.raw(shader.GetInput("operationorder"))
        inv = [1.0 / s if s != 0 else 0.0 for s in scale[:2]]

        def mapping(v, loc=(0.0, 0.0), rz=0.0, sc=(1.0, 1.0)):
            inputs = {
                "Vector": self.socket(v, "vector"),
                "Location": [loc[0], loc[1], 0.0],
                "Rotation": [0.0, 0.0, rz],
                "Scale": [sc[0], sc[1], 1.0],
            }
            return Link(self.add("ShaderNodeMapping", str(shader.GetPath()), {"vector_type": "POINT"}, inputs), "Vector")

        if order in (None, 0):
            v = mapping(st, loc=(-pivot[0], -pivot[1]))
            return mapping(v, loc=(pivot[0] - offset[0], pivot[1] - offset[1]), rz=rot, sc=inv)
        v = mapping(st, loc=(-pivot[0] - offset[0], -pivot[1] - offset[1]), rz=0.0)
        v = mapping(v, rz=rot)
        return mapping(v, loc=pivot, sc=inv)

    def mx_normalmap(self, shader, name, types, kind):
        """mx_normalmap: v = 2·in − 1, v.xy ×= scale, N' = normalize(T·v.x + B·v.y + N·v.z)
        (B = N × T, T along increasing u): the Normal Map node (Tangent) of Color
        in·(s, s, 1) + (½ − ½s, ½ − ½s, 0), strength 1, so the scale is exact."""
        space = self.raw(shader.GetInput("space"))
        if space not in (None, "tangent"):
            self.warn(f"nmspace:{shader.GetPath()}", f"{shader.GetPath()}: normalmap space '{space}' is not supported; read as tangent")
        c = self.inp(shader, "in", (0.5, 0.5, 1.0))
        s = _tuple(self.const(shader.GetInput("scale"), 1.0))
        sx, sy = (s[0], s[0]) if len(s) == 1 else s[:2]
        if (sx, sy) != (1.0, 1.0):
            n = self.add(
                "ShaderNodeVectorMath",
                "normal scale",
                {"operation": "MULTIPLY_ADD"},
                {"Vector": self.socket(c, "vector"), "Vector_001": [sx, sy, 1.0], "Vector_002": [0.5 - 0.5 * sx, 0.5 - 0.5 * sy, 0.0]},
            )
            c = Link(n, "Vector")
        self.tangent_uv = self.uv_set_of(c)
        nm = self.add(
            "ShaderNodeNormalMap",
            str(shader.GetPath()),
            {"space": "TANGENT", "uv_map": self.tangent_uv},
            {"Strength": 1.0, "Color": self.socket(c, "color")},
        )
        return Link(nm, "Normal")

    # -- images ----------------------------------------------------------------------------
    def colour_space(self, shader) -> str:
        """MaterialX's ``colorspace`` on the file (USD ``colorSpace`` metadata): srgb_texture
        → sRGB; linear spaces and none → raw (the document's working space, lin_rec709, is
        MaterialX's default); "auto" as UsdUVTexture's."""
        inp = shader.GetInput("file")
        # On the input, else on the interface input it is connected to (which holds the file).
        attrs = ([inp.GetAttr()] + list(inp.GetValueProducingAttributes())) if inp else []
        cs = next((str(a.GetColorSpace()) for a in attrs if a.HasColorSpace()), "")
        low = cs.lower()
        if low in ("srgb_texture", "srgb", "srgb_rec709", "g22_rec709"):
            return "sRGB"
        if low in ("", "raw", "lin_rec709", "lin_srgb", "linear", "scene_linear", "data"):
            return "raw"
        if low == "auto":
            return "auto"
        self.r.warn(f"colorspace:{shader.GetPath()}", f"prim {shader.GetPath()}: colorspace '{cs}' is not supported; read as raw")
        return "raw"

    def interpolation(self, shader) -> str:
        filt = self.raw(shader.GetInput("filtertype"))
        if filt == "closest":
            return "Closest"
        if filt not in (None, "linear"):
            self.warn(f"filter:{shader.GetPath()}", f"{shader.GetPath()}: filtertype '{filt}' is not supported; linear is used")
        return "Linear"

    def wraps(self, shader) -> tuple[str, str]:
        out = []
        for which in ("uaddressmode", "vaddressmode"):
            w = self.raw(shader.GetInput(which))
            w = "periodic" if w is None else str(w)
            if w not in _MX_WRAP:
                self.r.warn(f"wrap:{shader.GetPath()}", f"prim {shader.GetPath()}: {which} '{w}' is not known; periodic is used")
                w = "periodic"
            out.append(_MX_WRAP[w])
        return out[0], out[1]

    def texture_coordinates(self, shader):
        st = self.value(shader.GetInput("texcoord"), "vector")
        if str(shader.GetShaderId()).startswith("ND_tiledimage_"):
            # NG_tiledimage: (texcoord·uvtiling − uvoffset) / realworldimagesize · realworldtilesize.
            tiling = _tuple(self.const(shader.GetInput("uvtiling"), (1.0, 1.0)))
            offset = _tuple(self.const(shader.GetInput("uvoffset"), (0.0, 0.0)))
            image = _tuple(self.const(shader.GetInput("realworldimagesize"), (1.0, 1.0)))
            tile = _tuple(self.const(shader.GetInput("realworldtilesize"), (1.0, 1.0)))
            k = [tile[i] / image[i] if image[i] != 0 else 0.0 for i in range(2)]
            if st is None:
                st = self.uv_map("", str(shader.GetPath()))
            inputs = {
                "Vector": self.socket(st, "vector"),
                "Scale": [tiling[0] * k[0], tiling[1] * k[1], 1.0],
                "Location": [-offset[0] * k[0], -offset[1] * k[1], 0.0],
            }
            st = Link(self.add("ShaderNodeMapping", f"{shader.GetPath()} tiling", {"vector_type": "POINT"}, inputs), "Vector")
        return st

    def mx_image(self, shader, name, types, kind):
        w = self.width(types)
        if self.texture_node(shader) is None:  # missing or unreadable: MaterialX's `default`
            return self.inp(shader, "default", self.zero(w).value)
        if w == 1:
            return self.texture_output(shader, "r", kind)
        rgb = self.texture_output(shader, "rgb", kind)
        if w == 4:
            rgb = self.with_alpha(rgb, self.texture_output(shader, "a", kind))
        return rgb

    def mx_tiledimage(self, shader, name, types, kind):
        return self.mx_image(shader, name, types, kind)


# -- surfaces ----------------------------------------------------------------------------------

# Principled socket ← (Standard Surface input, OpenPBR input, glTF PBR input); None: not there.
# Defaults: standard_surface.mtlx 1.0.1 (base 1, base_color 0.8), open_pbr_surface.mtlx 1.1,
# gltf_pbr.mtlx.
_DEFAULTS = {
    "standard": {
        "base": 1.0, "base_color": (0.8, 0.8, 0.8), "diffuse_roughness": 0.0, "metalness": 0.0, "specular": 1.0,
        "specular_color": (1.0, 1.0, 1.0), "specular_roughness": 0.2, "specular_IOR": 1.5, "transmission": 0.0,
        "coat": 0.0, "coat_color": (1.0, 1.0, 1.0), "coat_roughness": 0.1, "coat_IOR": 1.5, "sheen": 0.0,
        "sheen_color": (1.0, 1.0, 1.0), "sheen_roughness": 0.3, "thin_film_thickness": 0.0, "thin_film_IOR": 1.5,
        "emission": 0.0, "emission_color": (1.0, 1.0, 1.0), "opacity": (1.0, 1.0, 1.0), "transmission_dispersion": 0.0,
        "subsurface": 0.0, "subsurface_color": (1.0, 1.0, 1.0), "transmission_color": (1.0, 1.0, 1.0),
    },
    "openpbr": {
        "base_weight": 1.0, "base_color": (0.8, 0.8, 0.8), "base_diffuse_roughness": 0.0, "base_metalness": 0.0,
        "specular_weight": 1.0, "specular_color": (1.0, 1.0, 1.0), "specular_roughness": 0.3, "specular_ior": 1.5,
        "transmission_weight": 0.0, "coat_weight": 0.0, "coat_color": (1.0, 1.0, 1.0), "coat_roughness": 0.0,
        "coat_ior": 1.6, "fuzz_weight": 0.0, "fuzz_color": (1.0, 1.0, 1.0), "fuzz_roughness": 0.5,
        "thin_film_weight": 0.0, "thin_film_thickness": 0.5, "thin_film_ior": 1.4, "emission_luminance": 0.0,
        "emission_color": (1.0, 1.0, 1.0), "geometry_opacity": 1.0, "transmission_dispersion_scale": 0.0,
        "transmission_dispersion_abbe_number": 20.0, "subsurface_weight": 0.0, "subsurface_color": (0.8, 0.8, 0.8),
        "transmission_color": (1.0, 1.0, 1.0),
    },
    "gltf": {
        "base_color": (1.0, 1.0, 1.0), "metallic": 1.0, "roughness": 1.0, "specular": 1.0, "specular_color": (1.0, 1.0, 1.0),
        "ior": 1.5, "transmission": 0.0, "clearcoat": 0.0, "clearcoat_roughness": 0.0, "sheen_color": (0.0, 0.0, 0.0),
        "sheen_roughness": 0.0, "emissive": (0.0, 0.0, 0.0), "emissive_strength": 1.0, "alpha": 1.0, "alpha_mode": 0,
        "alpha_cutoff": 0.5, "iridescence": 0.0, "iridescence_ior": 1.3, "iridescence_thickness": 100.0,
    },
}  # fmt: skip

# Inputs the core cannot render: name → the value at which it has no effect (None: any
# connection or authored value warns).
_UNSUPPORTED = {
    "standard": {
        "specular_anisotropy": 0.0, "transmission_depth": 0.0, "transmission_scatter": (0.0, 0.0, 0.0),
        "transmission_scatter_anisotropy": 0.0, "transmission_extra_roughness": 0.0,
        "coat_anisotropy": 0.0, "coat_affect_color": 0.0,
        "coat_affect_roughness": 0.0, "thin_walled": 0, "tangent": None,
    },
    "openpbr": {
        "specular_roughness_anisotropy": 0.0, "transmission_depth": 0.0,
        "transmission_scatter": (0.0, 0.0, 0.0), "transmission_scatter_anisotropy": 0.0,
        "coat_roughness_anisotropy": 0.0,
        "coat_darkening": 1.0, "geometry_thin_walled": 0, "geometry_tangent": None, "geometry_coat_tangent": None,
    },
    "gltf": {
        "occlusion": 1.0, "thickness": 0.0, "anisotropy_strength": 0.0, "attenuation_color": (1.0, 1.0, 1.0),
        "tangent": None,
    },
}  # fmt: skip


# Parameters read above, or that act only through one warned about (subsurface colour with
# subsurface weight 0, ...), or that name the geometry's own normal.
_IMPLIED = {
    "standard": {
        "normal", "coat_normal", "specular_rotation", "coat_rotation", "subsurface_color", "subsurface_radius",
        "subsurface_scale", "subsurface_anisotropy", "subsurface_type",
    },
    "openpbr": {
        "geometry_normal", "geometry_coat_normal", "specular_roughness_anisotropy", "subsurface_color",
        "subsurface_radius", "subsurface_radius_scale", "subsurface_scatter_anisotropy",
    },
    "gltf": {"normal", "clearcoat_normal", "anisotropy_rotation", "attenuation_distance"},
}  # fmt: skip


def _family(sid: str) -> str:
    return "openpbr" if "open_pbr" in sid else "gltf" if "gltf" in sid else "standard"


def build(reader, material_prim, shader, name: str):
    """The NodeMaterial of a MaterialX surface shader (one Principled BSDF)."""
    from ..scene import NodeMaterial

    sid = str(shader.GetShaderId())
    fam = _family(sid)
    g = MxGraph(reader, material_prim, shader)
    defaults = dict(_DEFAULTS[fam])
    if sid.endswith("_100"):  # Standard Surface 1.0.0's defaults
        defaults.update(base=0.8, base_color=(1.0, 1.0, 1.0))
    spath = shader.GetPath()

    def get(n):
        d = defaults[n]
        return g.inp(shader, n, d, "color" if isinstance(d, tuple) else "float")

    def unsupported(n, neutral):
        inp = shader.GetInput(n)
        if not inp:
            return
        if inp.HasConnectedSource() and neutral is not None:
            v = g.value(inp, "float" if not isinstance(neutral, tuple) else "color")
            off = not (isinstance(v, Const) and _tuple(v.value) == _tuple(neutral))
        elif neutral is None:
            off = inp.HasConnectedSource()
        else:
            v = inp.Get(reader.time)
            off = v is not None and _tuple(tuple(v) if hasattr(v, "__len__") else v) != _tuple(neutral)
        if off:
            reader.warn(f"mxparam:{spath}:{n}", f"prim {spath}: {sid} parameter '{n}' is not supported and is ignored")

    def warn(n, what):
        reader.warn(f"mxparam:{spath}:{n}", f"prim {spath}: {sid} parameter '{n}' {what}")

    for n, neutral in _UNSUPPORTED[fam].items():
        unsupported(n, neutral)
    known = set(defaults) | set(_UNSUPPORTED[fam]) | _IMPLIED[fam]
    for i in shader.GetInputs():
        n = str(i.GetBaseName())
        if n not in known and (i.HasConnectedSource() or i.GetAttr().HasAuthoredValue()):
            warn(n, "is not a parameter of this shader; ignored")

    inputs: dict[str, Any] = {}

    def put(socket, v, kind):
        inputs[socket] = g.socket(v, kind)

    if fam in ("standard", "openpbr"):
        o = fam == "openpbr"
        weight = get("base_weight" if o else "base")
        base = g.vmath("MULTIPLY", get("base_color"), weight)
        # No subsurface scattering yet: the subsurface lobe, which replaces the diffuse by
        # its weight, is rendered as a diffuse of subsurface_color (warned).
        sss = get("subsurface_weight" if o else "subsurface")
        if not (isinstance(sss, Const) and _tuple(sss.value)[0] == 0.0):
            base = g.lerp(base, get("subsurface_color"), sss)
            warn("subsurface_weight" if o else "subsurface", "is rendered as a diffuse of subsurface_color (no subsurface scattering yet)")
        # Principled tints transmission by Base Color (Blender's export writes
        # transmission_color = Base Color): a transmission of weight w blends it in.
        tw, tc = get("transmission_weight" if o else "transmission"), get("transmission_color")
        if not (isinstance(tw, Const) and _tuple(tw.value)[0] == 0.0) and not (
            isinstance(tc, Const) and _tuple(tc.value) == (1.0, 1.0, 1.0)
        ):
            base = g.lerp(base, tc, tw)
            if not (isinstance(tw, Const) and _tuple(tw.value)[0] == 1.0):
                warn("transmission_color", "with a partial transmission also tints the reflection (Principled has one colour)")
        put("Base Color", base, "color")
        put("Metallic", get("base_metalness" if o else "metalness"), "float")
        put("Diffuse Roughness", get("base_diffuse_roughness" if o else "diffuse_roughness"), "float")
        # standard_surface / OpenPBR scale the dielectric's Fresnel by the specular weight;
        # Principled's Specular IOR Level ℓ scales F0 by 2ℓ (Cycles' principled IOR-level
        # adjustment), so ℓ = weight / 2 — exact at normal incidence.
        put("Specular IOR Level", g.math("MULTIPLY", get("specular_weight" if o else "specular"), Const(0.5)), "float")
        put("Specular Tint", get("specular_color"), "color")
        put("Roughness", get("specular_roughness"), "float")
        ior = get("specular_ior" if o else "specular_IOR")
        put("IOR", ior, "float")
        # Dispersion: OpenPBR's Abbe number Vd = transmission_dispersion_abbe_number /
        # transmission_dispersion_scale, specular_ior being n at the d line; Standard
        # Surface's transmission_dispersion is Vd itself (Arnold's "Dispersion Abbe", 0 = off).
        # The core's Abbe model (two-term Cauchy through nd with nF − nC = (nd − 1)/Vd) on
        # the Principled IOR: reflection and refraction of one dispersive dielectric.
        if o:
            ds, dv = get("transmission_dispersion_scale"), get("transmission_dispersion_abbe_number")
            params = (ds, dv, ior)
        else:
            ds = dv = get("transmission_dispersion")
            params = (ds, ior)
        if not (isinstance(ds, Const) and _tuple(ds.value)[0] <= 0.0):
            name_d = "transmission_dispersion_scale" if o else "transmission_dispersion"
            if not all(isinstance(p, Const) for p in params):
                warn(name_d, "is connected, or with a connected IOR; dispersion needs constants and is ignored")
            else:
                vd = _tuple(dv.value)[0] / _tuple(ds.value)[0] if o else _tuple(ds.value)[0]
                nd = _tuple(ior.value)[0]
                if vd > 0.0 and math.isfinite(vd) and nd > 1.0:
                    inputs["IOR"] = {"ior": {"type": "abbe", "nd": nd, "vd": vd}}
                else:
                    warn(name_d, f"gives the Abbe number {vd:g} with IOR {nd:g}; dispersion is ignored")
        put("Transmission Weight", get("transmission_weight" if o else "transmission"), "float")
        put("Coat Weight", get("coat_weight" if o else "coat"), "float")
        put("Coat Tint", get("coat_color"), "color")
        put("Coat Roughness", get("coat_roughness"), "float")
        put("Coat IOR", get("coat_ior" if o else "coat_IOR"), "float")
        put("Sheen Weight", get("fuzz_weight" if o else "sheen"), "float")
        put("Sheen Tint", get("fuzz_color" if o else "sheen_color"), "color")
        put("Sheen Roughness", get("fuzz_roughness" if o else "sheen_roughness"), "float")
        emission = get("emission_luminance" if o else "emission")
        if not (isinstance(emission, Const) and _tuple(emission.value)[0] == 0.0):
            # OpenPBR's emission_luminance is in nits, as UsdLux intensities (which the reader
            # takes as radiance): open_pbr_surface.mtlx multiplies emission_color by it.
            put("Emission Strength", emission, "float")
            put("Emission Color", get("emission_color"), "color")
        if o:
            film_w = get("thin_film_weight")
            if not (isinstance(film_w, Const) and _tuple(film_w.value)[0] == 0.0):
                if not (isinstance(film_w, Const) and _tuple(film_w.value)[0] == 1.0):
                    warn("thin_film_weight", "other than 0 or 1 is rendered as 1 (a full film)")
                put("Thin Film Thickness", g.math("MULTIPLY", get("thin_film_thickness"), Const(1000.0)), "float")  # µm → nm
                put("Thin Film IOR", get("thin_film_ior"), "float")
            opacity = get("geometry_opacity")
        else:
            put("Thin Film Thickness", get("thin_film_thickness"), "float")  # nm, as Principled's
            put("Thin Film IOR", get("thin_film_IOR"), "float")
            opacity = get("opacity")
            if isinstance(opacity, Const):
                t = _tuple(opacity.value)
                if max(t) - min(t) > 1e-6:
                    warn("opacity", f"{t} is coloured; its mean is the coverage")
                opacity = Const(sum(t) / len(t))
        normal_names = ("geometry_normal", "geometry_coat_normal") if o else ("normal", "coat_normal")
    else:  # glTF PBR (gltf_pbr.mtlx; as Blender's glTF importer maps the same parameters)
        put("Base Color", get("base_color"), "color")
        put("Metallic", get("metallic"), "float")
        put("Roughness", get("roughness"), "float")
        put("IOR", get("ior"), "float")
        put("Specular IOR Level", g.math("MULTIPLY", get("specular"), Const(0.5)), "float")
        put("Specular Tint", get("specular_color"), "color")
        put("Transmission Weight", get("transmission"), "float")
        put("Coat Weight", get("clearcoat"), "float")
        put("Coat Roughness", get("clearcoat_roughness"), "float")
        sheen = get("sheen_color")
        if not (isinstance(sheen, Const) and max(_tuple(sheen.value)) == 0.0):
            put("Sheen Weight", Const(1.0), "float")
            put("Sheen Tint", sheen, "color")
            put("Sheen Roughness", get("sheen_roughness"), "float")
        emissive = get("emissive")
        if not (isinstance(emissive, Const) and max(_tuple(emissive.value)) == 0.0):
            put("Emission Color", emissive, "color")
            put("Emission Strength", get("emissive_strength"), "float")
        irid = get("iridescence")
        if not (isinstance(irid, Const) and _tuple(irid.value)[0] == 0.0):
            if not (isinstance(irid, Const) and _tuple(irid.value)[0] == 1.0):
                warn("iridescence", "other than 0 or 1 is rendered as 1")
            put("Thin Film Thickness", get("iridescence_thickness"), "float")
            put("Thin Film IOR", get("iridescence_ior"), "float")
        mode = g.raw(shader.GetInput("alpha_mode"))
        mode = 0 if mode is None else int(mode)
        alpha = get("alpha")
        if mode == 0:
            opacity = Const(1.0)
        elif mode == 1:  # MASK: alpha < cutoff is cut out, the rest opaque
            cutoff = get("alpha_cutoff")
            lt = g.add(
                "ShaderNodeMath",
                "alpha < cutoff",
                {"operation": "LESS_THAN"},
                {"Value": g.socket(alpha, "float"), "Value_001": g.socket(cutoff, "float")},
            )
            opacity = g.math("SUBTRACT", Const(1.0), Link(lt, "Value"))
        else:
            opacity = alpha
        normal_names = ("normal", "clearcoat_normal")
    if not (isinstance(opacity, Const) and _tuple(opacity.value)[0] >= 1.0):
        put("Alpha", opacity, "float")
    for socket, n in zip(("Normal", "Coat Normal"), normal_names):
        v = g.value(shader.GetInput(n), "vector")
        if isinstance(v, Link):
            inputs[socket] = g.socket(v, "vector")
        elif v is not None:
            warn(n, "is a constant; only a normal map is supported there, the geometric normal is used")
    # An unconnected coat_normal is Nworld, the geometric normal: Principled's implicit Coat Normal.
    principled = g.add("ShaderNodeBsdfPrincipled", str(spath), {}, inputs)
    material = NodeMaterial(name, g.nodes, {"surface": [principled, "BSDF"]})
    material.usd_primvar_reads = frozenset(g.reads)
    material.usd_primvar_fallbacks = dict(g.fallbacks)
    material.usd_tangent_uv = g.tangent_uv
    return material
