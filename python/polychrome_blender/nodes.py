"""Polychrome's own shader nodes, usable in the standard Shader Editor (plain custom
nodes registered on the standard ShaderNodeTree; their properties are saved in the .blend):

* **Spectral Reflectance** (BSDF): a diffuse surface with a measured reflectance, either
  32 curve samples over 380-780 nm or a named ColorChecker Classic patch.
* **Dispersion** (BSDF): a dispersive dielectric given by Cauchy, Sellmeier, a named
  catalogue glass or Blender-style IOR + Abbe number; shows n at the F, d and C lines
  (486.1327 / 587.5618 / 656.2725 nm), evaluated by the core.
* **Spectral Emission** (Emission): blackbody, D65, A, E or a narrow band, times strength.

Cycles and EEVEE ignore these nodes. Export: ``node.polychrome_export(mat, warnings)``.
"""

import math

import bpy
import polychrome as pc
from bpy.props import EnumProperty, FloatProperty, FloatVectorProperty

from .colorchecker import PATCHES
from .colorchecker import WAVELENGTHS as CC_WAVELENGTHS

CURVE_SAMPLES = 32
CURVE_WAVELENGTHS = tuple(380.0 + 400.0 * i / (CURVE_SAMPLES - 1) for i in range(CURVE_SAMPLES))
PATCH_ITEMS = [(f"P{i + 1:02d}", name.title(), f"ColorChecker patch {i + 1}: {name}") for i, name in enumerate(PATCHES)]
PATCH_NAMES = list(PATCHES)

#: The core's glass catalogue (material/catalogue.rs, with its sources).
CATALOGUE = pc.ior.GLASSES
NAMED_ITEMS = [(k.upper().replace(" ", "_").replace("-", "_"), k, f"{k} (Sellmeier)") for k in CATALOGUE]
#: The F, d and C lines the node shows the index at (the core's, see polychrome.ior).
LINE_F, LINE_D, LINE_C = pc.ior.LAMBDA_F, pc.ior.LAMBDA_D, pc.ior.LAMBDA_C


def _tree_poll(cls, ntree):
    return ntree.bl_idname == "ShaderNodeTree"


class PolychromeSpectralReflectanceNode(bpy.types.Node):
    """Diffuse reflectance given as a spectrum"""

    bl_idname = "PolychromeSpectralReflectanceNode"
    bl_label = "Spectral Reflectance"
    bl_icon = "COLOR"
    bl_width_default = 220

    mode: EnumProperty(
        name="Mode",
        items=[("CURVE", "Curve", "32 samples from 380 to 780 nm"), ("COLORCHECKER", "ColorChecker", "A ColorChecker Classic patch")],
        default="CURVE",
    )
    curve: FloatVectorProperty(
        name="Reflectance",
        size=CURVE_SAMPLES,
        min=0.0,
        max=1.0,
        default=[0.5] * CURVE_SAMPLES,
        description="Reflectance at 32 evenly spaced wavelengths, 380 to 780 nm",
    )
    patch: EnumProperty(name="Patch", items=PATCH_ITEMS, default="P01")

    poll = classmethod(_tree_poll)

    def init(self, context):
        self.outputs.new("NodeSocketShader", "BSDF")

    def draw_buttons(self, context, layout):
        layout.prop(self, "mode", text="")
        if self.mode == "COLORCHECKER":
            layout.prop(self, "patch", text="")
        else:
            col = layout.column(align=True)
            for i in range(0, CURVE_SAMPLES, 4):
                row = col.row(align=True)
                for k in range(i, min(i + 4, CURVE_SAMPLES)):
                    row.prop(self, "curve", index=k, text=f"{CURVE_WAVELENGTHS[k]:.0f}")

    def spectrum(self):
        if self.mode == "COLORCHECKER":
            index = [p[0] for p in PATCH_ITEMS].index(self.patch)
            return pc.spectra.tabulated(CC_WAVELENGTHS, PATCHES[PATCH_NAMES[index]])
        return pc.spectra.tabulated(CURVE_WAVELENGTHS, list(self.curve))

    def polychrome_export(self, mat, warnings):
        return pc.Diffuse(self.spectrum(), name=mat.name)


class PolychromeDispersionNode(bpy.types.Node):
    """A dispersive dielectric: index of refraction that depends on wavelength"""

    bl_idname = "PolychromeDispersionNode"
    bl_label = "Dispersion"
    bl_icon = "LIGHT_SUN"
    bl_width_default = 220

    model: EnumProperty(
        name="Model",
        items=[
            ("CAUCHY", "Cauchy", "n = A + B/λ² + C/λ⁴ (λ in µm)"),
            ("SELLMEIER", "Sellmeier", "n² = 1 + Σ Bk λ²/(λ² − Ck) (λ in µm)"),
            ("NAMED", "Named Glass", "A catalogue material"),
            ("ABBE", "IOR + Abbe", "nd and Abbe number Vd, as Blender gives them"),
        ],
        default="NAMED",
    )
    cauchy_a: FloatProperty(name="A", default=1.5046, min=1.0, soft_max=3.0, precision=5)
    cauchy_b: FloatProperty(name="B (µm²)", default=0.0042, precision=6)
    cauchy_c: FloatProperty(name="C (µm⁴)", default=0.0, precision=6)
    sellmeier_b: FloatVectorProperty(name="B", size=3, default=CATALOGUE["N-BK7"]["b"], precision=6)
    sellmeier_c: FloatVectorProperty(name="C (µm²)", size=3, default=CATALOGUE["N-BK7"]["c"], precision=6)
    named: EnumProperty(name="Material", items=NAMED_ITEMS, default="N_BK7")
    abbe_nd: FloatProperty(name="IOR (nd)", default=1.5168, min=1.0, soft_max=3.0, precision=4)
    abbe_vd: FloatProperty(name="Abbe (Vd)", default=64.17, min=1.0, soft_max=100.0, precision=2)
    roughness: FloatProperty(name="Roughness", default=0.0, min=0.0, max=1.0, subtype="FACTOR")

    poll = classmethod(_tree_poll)

    def init(self, context):
        self.outputs.new("NodeSocketShader", "BSDF")

    def named_material(self):
        return {k: name for k, name, _ in NAMED_ITEMS}[self.named]

    def ior(self, lam_nm):
        """Index of refraction at ``lam_nm`` nanometres as the core evaluates the node's
        model (NaN where it is undefined or the values are invalid)."""
        try:
            return self.polychrome_ior().index_at(lam_nm)
        except ValueError:
            return float("nan")

    def draw_buttons(self, context, layout):
        layout.prop(self, "model", text="")
        col = layout.column(align=True)
        if self.model == "CAUCHY":
            col.prop(self, "cauchy_a")
            col.prop(self, "cauchy_b")
            col.prop(self, "cauchy_c")  # noqa: E702
        elif self.model == "SELLMEIER":
            col.prop(self, "sellmeier_b")
            col.prop(self, "sellmeier_c")  # noqa: E702
        elif self.model == "NAMED":
            col.prop(self, "named", text="")
        else:
            col.prop(self, "abbe_nd")
            col.prop(self, "abbe_vd")  # noqa: E702
        layout.prop(self, "roughness")
        box = layout.box().column(align=True)
        for label, lam in (("F 486", LINE_F), ("d 588", LINE_D), ("C 656", LINE_C)):
            box.label(text=f"n({label} nm) = {self.ior(lam):.5f}")

    def polychrome_ior(self):
        if self.model == "CAUCHY":
            return pc.ior.cauchy(self.cauchy_a, self.cauchy_b, self.cauchy_c)
        if self.model == "SELLMEIER":
            return pc.ior.sellmeier(list(self.sellmeier_b), list(self.sellmeier_c))
        if self.model == "NAMED":
            return pc.ior.named(self.named_material())
        return pc.ior.abbe(self.abbe_nd, self.abbe_vd)

    def dispersion_dict(self):
        if self.model == "CAUCHY":
            return {"type": "cauchy", "a": self.cauchy_a, "b": self.cauchy_b, "c": self.cauchy_c}
        if self.model == "SELLMEIER":
            return {"type": "sellmeier", "b": list(self.sellmeier_b), "c": list(self.sellmeier_c)}
        if self.model == "NAMED":
            return {"type": "named", "name": self.named_material()}
        return {"type": "abbe", "nd": self.abbe_nd, "vd": self.abbe_vd}

    def polychrome_export(self, mat, warnings):
        for lam in range(380, 781, 5):
            n = self.ior(float(lam))
            if not (math.isfinite(n) and n >= 1.0):
                raise ValueError(
                    f"material '{mat.name}': Dispersion node '{self.name}' gives index {n:.4g} at {lam} nm "
                    "(below 1, near a Sellmeier pole or undefined)"
                )
        return pc.Dielectric(self.polychrome_ior(), roughness=self.roughness, name=mat.name)


class PolychromeSpectralEmissionNode(bpy.types.Node):
    """Light emission with a named spectrum"""

    bl_idname = "PolychromeSpectralEmissionNode"
    bl_label = "Spectral Emission"
    bl_icon = "LIGHT"

    kind: EnumProperty(
        name="Spectrum",
        items=[
            ("BLACKBODY", "Blackbody", "Planck's law (peak normalised to 1)"),
            ("D65", "D65", "CIE daylight D65 (1 at 560 nm)"),
            ("A", "A", "CIE incandescent A (1 at 560 nm)"),
            ("E", "E", "Equal energy (1 everywhere)"),
            ("NARROW_BAND", "Narrow Band", "Gaussian band of peak 1"),
        ],
        default="BLACKBODY",
    )
    temperature: FloatProperty(name="Temperature (K)", default=6500.0, min=100.0, soft_max=20000.0)
    center: FloatProperty(name="Centre (nm)", default=650.0, min=300.0, max=900.0)
    width: FloatProperty(name="Width (nm)", description="Full width at half maximum", default=10.0, min=0.1, max=400.0)
    strength: FloatProperty(
        name="Strength", description="Radiance scale (W·sr⁻¹·m⁻²·nm⁻¹ at the normalisation point)", default=1.0, min=0.0
    )

    poll = classmethod(_tree_poll)

    def init(self, context):
        self.outputs.new("NodeSocketShader", "Emission")

    def draw_buttons(self, context, layout):
        layout.prop(self, "kind", text="")
        if self.kind == "BLACKBODY":
            layout.prop(self, "temperature")
        elif self.kind == "NARROW_BAND":
            layout.prop(self, "center")
            layout.prop(self, "width")  # noqa: E702
        layout.prop(self, "strength")

    def spectrum(self):
        s = pc.spectra
        if self.kind == "BLACKBODY":
            return s.blackbody(self.temperature)
        if self.kind == "D65":
            return s.d65()
        if self.kind == "A":
            return s.illuminant_a()
        if self.kind == "E":
            return s.equal_energy()
        return s.narrow_band(self.center, self.width)

    def polychrome_export(self, mat, warnings):
        return pc.Emitter(self.spectrum(), strength=self.strength, name=mat.name)


classes = (PolychromeSpectralReflectanceNode, PolychromeDispersionNode, PolychromeSpectralEmissionNode)


def _menu(self, context):
    if context.engine != "POLYCHROME":
        return
    layout = self.layout
    layout.separator()
    layout.label(text="Polychrome")
    for c in classes:
        op = layout.operator("node.add_node", text=c.bl_label)
        op.type = c.bl_idname
        op.use_transform = True


_MENUS = ("NODE_MT_shader_node_add_all", "NODE_MT_add")
_menus_added = []


def register():
    for c in classes:
        bpy.utils.register_class(c)
    for name in _MENUS:
        menu = getattr(bpy.types, name, None)
        if menu is not None:
            menu.append(_menu)
            _menus_added.append(menu)
            break


def unregister():
    while _menus_added:
        _menus_added.pop().remove(_menu)
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
