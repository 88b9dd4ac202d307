"""Blender materials → polychrome materials.

Node materials are exported as their node graph (export/node_graph.py →
``polychrome.NodeMaterial``, docs/shading.md); a Principled Hair BSDF on the Surface keeps
the approximation below (:meth:`MaterialExport.hair`). Emission that varies over the
surface is evaluated per hit by the core (docs/shading.md) like every other input.

The fixed-pattern export: Principled BSDF → ``polychrome.Principled`` (base colour or image texture,
metallic, roughness, IOR — or a Polychrome Dispersion node linked to IOR —, transmission,
specular tint, thin film, emission colour × strength), Mix Shader and Add Shader of
supported shaders → ``polychrome.Mix`` / ``polychrome.Add`` (nested), Diffuse, Glossy,
Glass BSDF, Emission (colour or Blackbody), Image Texture on a colour, Polychrome's own
nodes (see ``nodes.py``). Anything else becomes a grey diffuse with one warning naming
material and node.

One :class:`MaterialExport` exports one Blender material; the :class:`~.exporter.Exporter`
keeps the result (and its warnings) until the material changes.
"""

import math

import numpy as np
import polychrome as pc

from .lights import blackbody_white
from .textures import MISSING_RGBA
from .volumes import export_volume
from .warnings import Warnings
from .node_graph import GraphExport

#: Export node materials as graphs (tests set it False to exercise the fixed patterns).
GRAPHS = True

GREY = (0.8, 0.8, 0.8)
#: Mix/Add shaders nested deeper than this are not followed (a cycle guard).
MAX_MIX_DEPTH = 16


def _rgb(value):
    return tuple(float(c) for c in tuple(value)[:3])


def _input_value(node, name):
    return float(node.inputs[name].default_value)


def _clamp01(v):
    return min(max(float(v), 0.0), 1.0)


def _linked_node(sock):
    """The node feeding ``sock`` through reroutes, or None."""
    while sock is not None and sock.is_linked:
        node = sock.links[0].from_node
        if node.type != "REROUTE":
            return node
        sock = node.inputs[0]
    return None


def surface_node(mat):
    """The shader node on the active Material Output's Surface input, or None."""
    if not mat.use_nodes or mat.node_tree is None:
        return None
    out = mat.node_tree.get_output_node("ALL") or mat.node_tree.get_output_node("CYCLES")
    if out is None:
        return None
    return _linked_node(out.inputs.get("Surface"))


def hair_colour(node):
    """The RGB colour a Principled Hair BSDF (or Hair BSDF) node stands for (see
    :meth:`MaterialExport.hair`)."""
    if node.type == "BSDF_HAIR":
        return _rgb(node.inputs["Color"].default_value)
    radial = node.inputs.get("Radial Roughness")  # the Chiang model's; Huang's has none
    beta_n = float(radial.default_value) if radial is not None else 0.3
    scale = (((((0.245 * beta_n) + 5.574) * beta_n - 10.73) * beta_n + 2.532) * beta_n - 0.215) * beta_n + 5.969
    mode = node.parametrization
    if mode == "COLOR":
        return _rgb(node.inputs["Color"].default_value)
    if mode == "MELANIN":
        melanin = -np.log(max(1.0 - float(node.inputs["Melanin"].default_value), 1e-4))
        redness = float(node.inputs["Melanin Redness"].default_value)
        sigma = melanin * (1.0 - redness) * np.array([0.506, 0.841, 1.653]) + melanin * redness * np.array([0.343, 0.733, 1.924])
        tint = np.clip(np.array(_rgb(node.inputs["Tint"].default_value)), 1e-6, 1.0)
        sigma = sigma + (np.log(tint) / scale) ** 2
    else:  # ABSORPTION
        sigma = np.maximum(np.array(node.inputs["Absorption Coefficient"].default_value[:3], dtype=float), 0.0)
    return tuple(float(c) for c in np.exp(-np.sqrt(sigma) * scale))


class MaterialExport:
    """The export of one Blender material (or None: the default grey): ``material()``
    returns the polychrome material; problems go to ``warnings``; image textures come
    from ``textures`` (a :class:`~.textures.TextureCache`)."""

    def __init__(self, mat, warnings, textures):
        self.mat, self.warnings, self.textures = mat, warnings, textures
        self.name = "default" if mat is None else mat.name
        self.owner = f"material '{self.name}'"
        self.needs = {}  # mesh data the material's graph reads (export/node_graph.py)

    def material(self):
        """The surface (below) with the medium of the Volume output inside it; a
        material with only a Volume output is a medium behind no surface."""
        medium = export_volume(self.mat, self.warnings)
        if medium is not None and surface_node(self.mat) is None:
            return pc.Volume(medium, name=self.mat.name)
        m = self.surface()
        if medium is not None:
            m.volume = medium
        return m

    def surface(self):
        mat = self.mat
        if mat is None:
            return pc.Diffuse(GREY, name="default")
        node = surface_node(mat)
        if node is None:
            if mat.use_nodes:
                return pc.Diffuse((0.0, 0.0, 0.0), name=mat.name)  # nothing connected: black, as Cycles
            return pc.Diffuse(_rgb(mat.diffuse_color), name=mat.name)
        if GRAPHS and node.type not in ("BSDF_HAIR_PRINCIPLED", "BSDF_HAIR"):
            graph = self.graph()
            if graph is not None:
                return graph
        return self.node(node)

    def graph(self):
        """The material as a ``polychrome.NodeMaterial``."""
        own = Warnings()
        g = GraphExport(self.mat, own, self.textures)
        got = g.export()
        g.convert_textures()
        self.warnings.extend(own.items)
        if got is None:
            return pc.Diffuse((0.0, 0.0, 0.0), name=self.name)  # e.g. only a muted closure: black
        self.needs = g.needs
        return pc.NodeMaterial(self.name, got[0], got[1])

    # -- inputs ------------------------------------------------------------------
    def colour(self, node, name, allow_texture=False):
        """A colour input: its value, a ``polychrome.Texture`` for a linked Image Texture
        where ``allow_texture``, else the image's mean colour (with a warning)."""
        sock = node.inputs[name]
        if not sock.is_linked:
            return _rgb(sock.default_value)
        src = sock.links[0].from_node
        if src.type == "TEX_IMAGE" and src.image is not None and allow_texture:
            if src.inputs["Vector"].is_linked:
                self.warnings.add(
                    ("vec", self.name, src.name),
                    f"{self.owner}: the Vector input of '{src.name}' is ignored (the active UV map is used)",
                )
            tex = self.textures.texture(src, self.owner, self.warnings, user=("MATERIAL", self.name))
            return _rgb(MISSING_RGBA) if tex is None else tex  # no pixels: as Cycles
        if src.type == "TEX_IMAGE" and src.image is not None:
            img = src.image
            w, h = img.size
            if w * h > 0:
                buf = np.empty(w * h * img.channels, np.float32)
                img.pixels.foreach_get(buf)
                mean = buf.reshape(-1, img.channels)[:, :3].mean(axis=0)
                self.warnings.add(
                    ("tex", self.name, src.name),
                    f"{self.owner}: image texture '{src.name}' is rendered as its mean colour (textures are not supported on '{name}')",
                )
                return tuple(float(c) for c in np.nan_to_num(mean))
        if src.type == "RGB":
            return _rgb(src.outputs[0].default_value)
        self.warnings.add(
            ("link", self.name, src.name),
            f"{self.owner}: node '{src.name}' ({src.bl_idname}) driving '{name}' is not supported; its default value is used",
        )
        return _rgb(sock.default_value)

    def emission_spectrum(self, node, name):
        """An emission colour input as a spectrum: a linked Blackbody node gives Planck's
        law at its temperature (luminance 1, as Cycles normalises it), else RGB."""
        sock = node.inputs[name]
        if sock.is_linked and sock.links[0].from_node.type == "BLACKBODY":
            bb = sock.links[0].from_node
            return blackbody_white(float(bb.inputs["Temperature"].default_value))
        return pc.spectra.rgb(*self.colour(node, name))

    def ior(self, node):
        n = _input_value(node, "IOR")
        if not (n >= 1.0 and n < 1e3):
            raise ValueError(f"{self.owner}: IOR {n} of '{node.name}' must be at least 1")
        return n

    # -- shader nodes --------------------------------------------------------------
    def node(self, node, depth=0):
        """One shader node (on the Surface output or inside a Mix/Add) → a polychrome material."""
        t = node.type
        name = self.name
        if t in ("MIX_SHADER", "ADD_SHADER"):
            return self.mix_shader(node, depth)
        if t == "BSDF_PRINCIPLED":
            return self.principled(node)
        if t == "BSDF_DIFFUSE":
            return pc.Diffuse(self.colour(node, "Color", allow_texture=True), name=name)
        if t == "BSDF_GLOSSY":
            roughness = _clamp01(_input_value(node, "Roughness"))
            return pc.Glossy(self.colour(node, "Color"), roughness=roughness, name=name)
        if t == "BSDF_GLASS":
            if self.colour(node, "Color") != (1.0, 1.0, 1.0):
                self.warnings.add(("glass-tint", name), f"{self.owner}: the colour of '{node.name}' is ignored (clear glass)")
            return pc.Dielectric(self.ior(node), roughness=_clamp01(_input_value(node, "Roughness")), name=name)
        if t in ("BSDF_HAIR_PRINCIPLED", "BSDF_HAIR"):
            return self.hair(node)
        if t == "EMISSION":
            return pc.Emitter(self.emission_spectrum(node, "Color"), strength=_input_value(node, "Strength"), name=name)
        export_custom = getattr(node, "polychrome_export", None)  # Polychrome's own nodes (nodes.py)
        if export_custom is not None:
            return export_custom(self.mat, self.warnings)
        self.warnings.add(
            ("node", name, node.name), f"{self.owner}: node '{node.name}' ({node.bl_idname}) is not supported; rendered as grey diffuse"
        )
        return pc.Diffuse(GREY, name=name)

    def principled(self, node):
        """Principled BSDF → ``polychrome.Principled`` with every lobe it has."""
        name, owner, warnings = self.name, self.owner, self.warnings
        base = self.colour(node, "Base Color", allow_texture=True)
        emission = None
        if _input_value(node, "Emission Strength") > 0.0:
            espec = self.emission_spectrum(node, "Emission Color")
            if espec.kind != "rgb" or max(espec.params["rgb"]) > 0.0:
                emission = espec * _input_value(node, "Emission Strength")
        ior = self.ior(node)
        src = _linked_node(node.inputs["IOR"])
        if src is not None and src.bl_idname == "PolychromeDispersionNode":
            src.polychrome_export(self.mat, warnings)  # validates the index over 380–780 nm
            ior = src.polychrome_ior()
        elif src is not None:
            warnings.add(
                ("link", name, src.name),
                f"{owner}: node '{src.name}' ({src.bl_idname}) driving 'IOR' is not supported; its default value is used",
            )
        # Sockets looked up with .get() are absent in some Blender versions the add-on
        # supports (Diffuse Roughness: 4.3+).
        for lobe, value in (
            ("Alpha", 1.0),
            ("Anisotropic", 0.0),
        ):
            sock = node.inputs.get(lobe)
            if sock is not None and (sock.is_linked or float(sock.default_value) != value):
                warnings.add(("principled-lobe", name, lobe), f"{owner}: '{node.name}' {lobe} is not supported yet and is ignored")
        for socket in (
            "Metallic",
            "Roughness",
            "Transmission Weight",
            "Thin Film Thickness",
            "Thin Film IOR",
            "Emission Strength",
            "Coat Weight",
            "Coat Roughness",
            "Coat IOR",
            "Coat Normal",
            "Sheen Weight",
            "Sheen Roughness",
            "Diffuse Roughness",
            "Subsurface Weight",
            "Subsurface Radius",
            "Subsurface Scale",
            "Subsurface IOR",
            "Subsurface Anisotropy",
        ):
            sock = node.inputs.get(socket)
            src = _linked_node(sock) if sock is not None else None
            if src is not None:
                warnings.add(
                    ("link", name, src.name, socket),
                    f"{owner}: node '{src.name}' ({src.bl_idname}) driving '{socket}' is not supported; its default value is used",
                )
        level = node.inputs["Specular IOR Level"]
        extra = {}
        if level.is_linked:
            warnings.add(
                ("link", name, node.name, "level"),
                f"{owner}: a node driving 'Specular IOR Level' of '{node.name}' is not supported; its default value is used",
            )
        if abs(float(level.default_value) - 0.5) > 1e-6:
            extra["specular_ior_level"] = _clamp01(level.default_value)
        tint = self.colour(node, "Specular Tint")
        tint = None if tint == (1.0, 1.0, 1.0) else tuple(_clamp01(c) for c in tint)
        film_d = float(node.inputs["Thin Film Thickness"].default_value)
        film_n = float(node.inputs["Thin Film IOR"].default_value)
        if film_d > 0.0 and film_n < 1.0:
            warnings.add(("film-ior", name), f"{owner}: Thin Film IOR {film_n:.3g} below 1 is raised to 1")
            film_n = 1.0
        if isinstance(base, tuple):
            base = tuple(_clamp01(c) for c in base)
        for lobe in ("Coat", "Sheen"):
            sock = node.inputs.get(f"{lobe} Weight")
            if sock is not None and float(sock.default_value) > 0.0:
                tint = tuple(_clamp01(c) for c in self.colour(node, f"{lobe} Tint"))
                extra[f"{lobe.lower()}_weight"] = _clamp01(sock.default_value)
                extra[f"{lobe.lower()}_roughness"] = _clamp01(_input_value(node, f"{lobe} Roughness"))
                extra[f"{lobe.lower()}_tint"] = None if tint == (1.0, 1.0, 1.0) else tint
        dr = node.inputs.get("Diffuse Roughness")
        if dr is not None and float(dr.default_value) > 0.0:
            extra["diffuse_roughness"] = _clamp01(dr.default_value)
        if "coat_weight" in extra:
            extra["coat_ior"] = min(max(_input_value(node, "Coat IOR"), 1.0), 10.0)
        extra.update(self.subsurface(node))
        return pc.Principled(
            base,
            metallic=_clamp01(_input_value(node, "Metallic")),
            roughness=_clamp01(_input_value(node, "Roughness")),
            ior=ior,
            transmission=_clamp01(_input_value(node, "Transmission Weight")),
            specular_tint=tint,
            thin_film_thickness=max(film_d, 0.0),
            thin_film_ior=film_n,
            emission=emission,
            name=name,
            **extra,
        )

    def subsurface(self, node):
        """The Principled's Subsurface inputs as ``polychrome.Principled`` keywords (none when
        its weight is 0): radius and scale clamped below at 0 as Cycles
        (``svm_node_closure_bsdf``), Christensen–Burley walked as Random Walk (warned)."""
        sock = node.inputs.get("Subsurface Weight")
        weight = _clamp01(sock.default_value) if sock is not None else 0.0
        if weight <= 0.0:
            return {}
        radius = tuple(float(c) for c in node.inputs["Subsurface Radius"].default_value)
        clean = tuple(c if math.isfinite(c) and c > 0.0 else 0.0 for c in radius)
        scale = float(_input_value(node, "Subsurface Scale"))
        if clean != radius or not (math.isfinite(scale) and scale >= 0.0):
            self.warnings.add(
                ("sss-radius", self.name),
                f"{self.owner}: '{node.name}' Subsurface Radius {radius} × Scale {scale:.3g} is clamped to values ≥ 0",
            )
            scale = scale if math.isfinite(scale) and scale > 0.0 else 0.0
        method = getattr(node, "subsurface_method", "RANDOM_WALK")
        if method not in ("RANDOM_WALK", "RANDOM_WALK_SKIN"):
            self.warnings.add(
                ("sss-method", self.name), f"{self.owner}: '{node.name}' Subsurface Method {method} is rendered as Random Walk"
            )
        anisotropy = float(_input_value(node, "Subsurface Anisotropy"))
        sior = float(_input_value(node, "Subsurface IOR"))
        return {
            "subsurface_weight": weight,
            "subsurface_radius": clean,
            "subsurface_scale": scale,
            "subsurface_ior": sior if math.isfinite(sior) else 1.4,
            "subsurface_anisotropy": anisotropy if math.isfinite(anisotropy) else 0.0,
            "subsurface_method": "random_walk_skin" if method == "RANDOM_WALK_SKIN" else "random_walk",
        }

    def hair(self, node):
        """Principled Hair BSDF (and the older Hair BSDF) → a Principled BSDF of the hair's
        colour, with a warning: hair scattering (Chiang 2016 / Huang 2022 lobes along the
        fibre) is not modelled. The colour is what Cycles' absorption σ stands for,
        inverting its ``bsdf_principled_hair_sigma_from_reflectance``:
        c = exp(−√σ · s(βn)), s the albedo/roughness polynomial of Chiang et al. 2016
        (intern/cycles/kernel/closure/bsdf_util.h)."""
        rgb = hair_colour(node)
        roughness = _clamp01(_input_value(node, "Roughness")) if "Roughness" in node.inputs else _clamp01(_input_value(node, "RoughnessU"))
        ior = _input_value(node, "IOR") if "IOR" in node.inputs else 1.55
        self.warnings.add(
            ("hair", self.name, node.name),
            f"{self.owner}: '{node.name}' ({node.bl_idname}) is approximated by a Principled BSDF of colour "
            f"({rgb[0]:.3g}, {rgb[1]:.3g}, {rgb[2]:.3g}); hair scattering is not modelled",
        )
        return pc.Principled(rgb, roughness=roughness, ior=max(float(ior), 1.0), name=self.name)

    def no_closure(self):
        """An unconnected shader input: no scattering, no emission (as Cycles)."""
        m = pc.Emitter((0.0, 0.0, 0.0), name=self.name)
        m.emission = None
        return m

    def mix_shader(self, node, depth):
        """Mix Shader / Add Shader of supported shaders → ``polychrome.Mix`` / ``polychrome.Add``."""
        shaders = [sock for sock in node.inputs if sock.type == "SHADER"]
        if len(shaders) != 2 or depth > MAX_MIX_DEPTH:
            self.warnings.add(
                ("node", self.name, node.name),
                f"{self.owner}: node '{node.name}' ({node.bl_idname}) is not supported; rendered as grey diffuse",
            )
            return pc.Diffuse(GREY, name=self.name)
        parts = []
        for sock in shaders:
            child = _linked_node(sock)
            parts.append(self.no_closure() if child is None else self.node(child, depth + 1))
        if node.type == "ADD_SHADER":
            return pc.Add(parts[0], parts[1], name=self.name)
        return pc.Mix(parts[0], parts[1], self.mix_factor(node), name=self.name)

    def mix_factor(self, node):
        """The Mix Shader's Fac: its value, or a Fresnel / Layer Weight node (view-dependent)."""
        fac = node.inputs[0]
        value = _clamp01(fac.default_value)
        if not fac.is_linked:
            return value
        sock = fac
        while sock.is_linked and sock.links[0].from_node.type == "REROUTE":
            sock = sock.links[0].from_node.inputs[0]
        src = sock.links[0].from_node if sock.is_linked else None
        out = sock.links[0].from_socket if sock.is_linked else None
        if src is not None:
            if src.inputs.get("Normal") is not None and src.inputs["Normal"].is_linked:
                self.warnings.add(
                    ("fac-normal", self.name, src.name),
                    f"{self.owner}: the Normal input of '{src.name}' is ignored (the shading normal is used)",
                )
            if src.type == "FRESNEL" and not src.inputs["IOR"].is_linked:
                return pc.Fresnel(float(src.inputs["IOR"].default_value))
            if src.type == "LAYER_WEIGHT" and not src.inputs["Blend"].is_linked:
                facing = out is not None and out.name == "Facing"
                return pc.LayerWeight(_clamp01(src.inputs["Blend"].default_value), "FACING" if facing else "FRESNEL")
        self.warnings.add(
            ("link", self.name, node.name),
            f"{self.owner}: node '{src.name if src else '?'}' driving the factor of '{node.name}' is not supported; "
            f"its value {value:.3g} is used",
        )
        return value
