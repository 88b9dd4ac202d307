"""Blender materials → polychrome materials.

Supported: Principled BSDF → ``polychrome.Principled`` (base colour or image texture,
metallic, roughness, IOR — or a Polychrome Dispersion node linked to IOR —, transmission,
specular tint, thin film, emission colour × strength), Mix Shader and Add Shader of
supported shaders → ``polychrome.Mix`` / ``polychrome.Add`` (nested), Diffuse, Glossy,
Glass BSDF, Emission (colour or Blackbody), Image Texture on a colour, Polychrome's own
nodes (see ``nodes.py``). Anything else becomes a grey diffuse with one warning naming
material and node. With a polychrome that lacks ``Principled`` the older mapping is used
(metallic ≥ 0.5 → Glossy, transmission ≥ 0.5 → Dielectric, else Diffuse).
"""

GREY = (0.8, 0.8, 0.8)


def _rgb(value):
    return tuple(float(c) for c in tuple(value)[:3])


def _surface_node(mat):
    if not mat.use_nodes or mat.node_tree is None:
        return None
    out = mat.node_tree.get_output_node("ALL") or mat.node_tree.get_output_node("CYCLES")
    if out is None:
        return None
    sock = out.inputs.get("Surface")
    node = None
    while sock is not None and sock.is_linked:
        node = sock.links[0].from_node
        if node.type == "REROUTE":
            sock = node.inputs[0]
            node = None
            continue
        break
    return node


_TEXTURES = {}


def _input_colour(mat, node, name, warnings, pc, allow_texture=False):
    """A constant colour input. A linked Image Texture gives a ``polychrome.Texture``
    where ``allow_texture`` and the installed polychrome has textures, else its mean colour."""
    sock = node.inputs[name]
    if not sock.is_linked:
        return _rgb(sock.default_value)
    src = sock.links[0].from_node
    if src.type == "TEX_IMAGE" and src.image is not None and allow_texture and hasattr(pc, "Texture"):
        from .textures import blender_texture

        if src.inputs["Vector"].is_linked:
            warnings.add(
                ("vec", mat.name, src.name),
                f"material '{mat.name}': the Vector input of '{src.name}' is ignored (the active UV map is used)",
            )
        tex = blender_texture(pc, src, f"material '{mat.name}'", warnings, _TEXTURES)
        if tex is not None:
            return tex
        return _rgb(sock.default_value)
    if src.type == "TEX_IMAGE" and src.image is not None:
        import numpy as np

        img = src.image
        w, h = img.size
        if w * h > 0:
            buf = np.empty(w * h * img.channels, np.float32)
            img.pixels.foreach_get(buf)
            mean = buf.reshape(-1, img.channels)[:, :3].mean(axis=0)
            warnings.add(
                ("tex", mat.name, src.name),
                f"material '{mat.name}': image texture '{src.name}' is rendered as its mean colour (textures are not supported yet)",
            )
            return tuple(float(c) for c in np.nan_to_num(mean))
    if src.type == "RGB":
        return _rgb(src.outputs[0].default_value)
    warnings.add(
        ("link", mat.name, src.name),
        f"material '{mat.name}': node '{src.name}' ({src.bl_idname}) driving '{name}' is not supported; its default value is used",
    )
    return _rgb(sock.default_value)


def _emission_spectrum(pc, mat, node, name, warnings):
    """An emission colour input as a spectrum: a linked Blackbody node gives Planck's law
    at its temperature (luminance 1, as Cycles normalises it), else RGB."""
    sock = node.inputs[name]
    if sock.is_linked and sock.links[0].from_node.type == "BLACKBODY":
        bb = sock.links[0].from_node
        from .lights import blackbody_white

        return blackbody_white(pc, float(bb.inputs["Temperature"].default_value))
    return pc.spectra.rgb(*_input_colour(mat, node, name, warnings, pc))


def _input_value(node, name):
    return float(node.inputs[name].default_value)


def _ior(node, mat):
    n = _input_value(node, "IOR")
    if not (n >= 1.0 and n < 1e3):
        raise ValueError(f"material '{mat.name}': IOR {n} of '{node.name}' must be at least 1")
    return n


def _linked_node(sock):
    """The node feeding ``sock`` through reroutes, or None."""
    while sock is not None and sock.is_linked:
        node = sock.links[0].from_node
        if node.type != "REROUTE":
            return node
        sock = node.inputs[0]
    return None


def _clamp01(v):
    return min(max(float(v), 0.0), 1.0)


def _principled_full(pc, mat, node, warnings, base, emission):
    """Principled BSDF → ``polychrome.Principled`` with every lobe it has."""
    ior = _ior(node, mat)
    src = _linked_node(node.inputs["IOR"])
    if src is not None and hasattr(src, "polychrome_ior"):
        src.polychrome_export(pc, mat, warnings)  # validates the index over 380–780 nm
        ior = src.polychrome_ior(pc)
    elif src is not None:
        warnings.add(
            ("link", mat.name, src.name),
            f"material '{mat.name}': node '{src.name}' ({src.bl_idname}) driving 'IOR' is not supported; its default value is used",
        )
    for name, value in (
        ("Coat Weight", 0.0),
        ("Sheen Weight", 0.0),
        ("Subsurface Weight", 0.0),
        ("Diffuse Roughness", 0.0),
        ("Alpha", 1.0),
        ("Anisotropic", 0.0),
    ):
        sock = node.inputs.get(name)
        if sock is not None and (sock.is_linked or float(sock.default_value) != value):
            warnings.add(
                ("principled-lobe", mat.name, name), f"material '{mat.name}': '{node.name}' {name} is not supported yet and is ignored"
            )
    for name in ("Metallic", "Roughness", "Transmission Weight", "Thin Film Thickness", "Thin Film IOR", "Emission Strength"):
        sock = node.inputs.get(name)
        src = _linked_node(sock) if sock is not None else None
        if src is not None:
            warnings.add(
                ("link", mat.name, src.name, name),
                f"material '{mat.name}': node '{src.name}' ({src.bl_idname}) driving '{name}' is not supported; its default value is used",
            )
    level = node.inputs.get("Specular IOR Level")
    extra = {}
    if level is not None:
        if level.is_linked:
            warnings.add(
                ("link", mat.name, node.name, "level"),
                f"material '{mat.name}': a node driving 'Specular IOR Level' of '{node.name}' is not supported; its default value is used",
            )
        if abs(float(level.default_value) - 0.5) > 1e-6:
            extra["specular_ior_level"] = _clamp01(level.default_value)
    tint = None
    if node.inputs.get("Specular Tint") is not None:
        t = _input_colour(mat, node, "Specular Tint", warnings, pc)
        if t != (1.0, 1.0, 1.0):
            tint = tuple(_clamp01(c) for c in t)
    film_d = float(node.inputs["Thin Film Thickness"].default_value) if node.inputs.get("Thin Film Thickness") else 0.0
    film_n = float(node.inputs["Thin Film IOR"].default_value) if node.inputs.get("Thin Film IOR") else 1.33
    if film_d > 0.0 and film_n < 1.0:
        warnings.add(("film-ior", mat.name), f"material '{mat.name}': Thin Film IOR {film_n:.3g} below 1 is raised to 1")
        film_n = 1.0
    if isinstance(base, tuple):
        base = tuple(_clamp01(c) for c in base)
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
        name=mat.name,
        **extra,
    )


def _principled(pc, mat, node, warnings):
    base = _input_colour(mat, node, "Base Color", warnings, pc, allow_texture=True)
    emission = None
    strength = _input_value(node, "Emission Strength")
    if strength > 0.0:
        espec = _emission_spectrum(pc, mat, node, "Emission Color", warnings)
        if espec.kind != "rgb" or max(espec.params["rgb"]) > 0.0:
            emission = espec * strength
    if hasattr(pc, "Principled"):
        return _principled_full(pc, mat, node, warnings, base, emission)
    metallic = _input_value(node, "Metallic")
    transmission = _input_value(node, "Transmission Weight")
    roughness = min(max(_input_value(node, "Roughness"), 0.0), 1.0)
    if 0.0 < metallic < 1.0 or 0.0 < transmission < 1.0:
        warnings.add(
            ("principled", mat.name),
            f"material '{mat.name}': '{node.name}' mixes metallic/transmission partially; rendered as the dominant lobe (threshold 0.5)",
        )
    if transmission >= 0.5 and hasattr(pc, "Dielectric"):
        return pc.Dielectric(_ior(node, mat), roughness=roughness, name=mat.name)
    if metallic >= 0.5 and hasattr(pc, "Glossy"):
        if isinstance(base, tuple):
            return pc.Glossy(base, roughness=roughness, name=mat.name)
        warnings.add(("metal-tex", mat.name), f"material '{mat.name}': a textured metallic colour is not supported; diffuse is used")
    elif transmission >= 0.5 or metallic >= 0.5:
        warnings.add(
            ("principled-missing", mat.name),
            f"material '{mat.name}': metallic/transmission of '{node.name}' are not supported by this polychrome; rendered as diffuse",
        )
    return pc.Diffuse(base, emission=emission, name=mat.name)


def export_material(pc, mat, warnings):
    """One Blender material (or None) → a polychrome material."""
    if mat is None:
        return pc.Diffuse(GREY, name="default")
    node = _surface_node(mat)
    if node is None:
        if mat.use_nodes:
            return pc.Diffuse((0.0, 0.0, 0.0), name=mat.name)  # nothing connected: black, as Cycles
        return pc.Diffuse(_rgb(mat.diffuse_color), name=mat.name)
    return _export_node(pc, mat, node, warnings)


def _no_closure(pc, mat):
    """An unconnected shader input: no scattering, no emission (as Cycles)."""
    m = pc.Emitter((0.0, 0.0, 0.0), name=mat.name)
    m.emission = None
    return m


def _mix_shader(pc, mat, node, warnings, depth):
    """Mix Shader / Add Shader of supported shaders → ``polychrome.Mix`` / ``polychrome.Add``."""
    shaders = [sock for sock in node.inputs if sock.type == "SHADER"]
    if len(shaders) != 2 or depth > 16:
        warnings.add(
            ("node", mat.name, node.name),
            f"material '{mat.name}': node '{node.name}' ({node.bl_idname}) is not supported; rendered as grey diffuse",
        )
        return pc.Diffuse(GREY, name=mat.name)
    parts = []
    for sock in shaders:
        child = _linked_node(sock)
        parts.append(_no_closure(pc, mat) if child is None else _export_node(pc, mat, child, warnings, depth + 1))
    if node.type == "ADD_SHADER":
        return pc.Add(parts[0], parts[1], name=mat.name)
    return pc.Mix(parts[0], parts[1], _mix_factor(pc, mat, node, warnings), name=mat.name)


def _mix_factor(pc, mat, node, warnings):
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
    if src is not None and hasattr(pc, "Fresnel"):
        if src.inputs.get("Normal") is not None and src.inputs["Normal"].is_linked:
            warnings.add(
                ("fac-normal", mat.name, src.name),
                f"material '{mat.name}': the Normal input of '{src.name}' is ignored (the shading normal is used)",
            )
        if src.type == "FRESNEL" and not src.inputs["IOR"].is_linked:
            return pc.Fresnel(float(src.inputs["IOR"].default_value))
        if src.type == "LAYER_WEIGHT" and not src.inputs["Blend"].is_linked:
            return pc.LayerWeight(
                _clamp01(src.inputs["Blend"].default_value), "FACING" if out is not None and out.name == "Facing" else "FRESNEL"
            )
    warnings.add(
        ("link", mat.name, node.name),
        f"material '{mat.name}': node '{src.name if src else '?'}' driving the factor of '{node.name}' is not supported; "
        f"its value {value:.3g} is used",
    )
    return value


def _export_node(pc, mat, node, warnings, depth=0):
    """One shader node (on the Surface output or inside a Mix/Add) → a polychrome material."""
    t = node.type
    if t in ("MIX_SHADER", "ADD_SHADER") and hasattr(pc, "Mix"):
        return _mix_shader(pc, mat, node, warnings, depth)
    if t == "BSDF_PRINCIPLED":
        return _principled(pc, mat, node, warnings)
    if t == "BSDF_DIFFUSE":
        return pc.Diffuse(_input_colour(mat, node, "Color", warnings, pc, allow_texture=True), name=mat.name)
    if t == "BSDF_GLOSSY" and hasattr(pc, "Glossy"):
        roughness = min(max(_input_value(node, "Roughness"), 0.0), 1.0)
        return pc.Glossy(_input_colour(mat, node, "Color", warnings, pc), roughness=roughness, name=mat.name)
    if t == "BSDF_GLASS" and hasattr(pc, "Dielectric"):
        if _input_colour(mat, node, "Color", warnings, pc) != (1.0, 1.0, 1.0):
            warnings.add(("glass-tint", mat.name), f"material '{mat.name}': the colour of '{node.name}' is ignored (clear glass)")
        roughness = min(max(_input_value(node, "Roughness"), 0.0), 1.0)
        return pc.Dielectric(_ior(node, mat), roughness=roughness, name=mat.name)
    if t == "EMISSION":
        spec = _emission_spectrum(pc, mat, node, "Color", warnings)
        return pc.Emitter(spec, strength=_input_value(node, "Strength"), name=mat.name)
    export_custom = getattr(node, "polychrome_export", None)
    if export_custom is not None:
        return export_custom(pc, mat, warnings)
    warnings.add(
        ("node", mat.name, node.name),
        f"material '{mat.name}': node '{node.name}' ({node.bl_idname}) is not supported; rendered as grey diffuse",
    )
    return pc.Diffuse(GREY, name=mat.name)


class MaterialTable:
    """Blender materials → scene material indices, each exported once."""

    def __init__(self, pc, scene, warnings):
        self.pc, self.scene, self.warnings = pc, scene, warnings
        self.index = {}
        _TEXTURES.clear()  # images are converted once per export

    def __call__(self, ob, slot):
        mat = None
        if slot is not None and slot < len(ob.material_slots):
            mat = ob.material_slots[slot].material
        key = None if mat is None else mat.original.name
        if key not in self.index:
            self.index[key] = self.scene.add_material(export_material(self.pc, mat, self.warnings))
        return self.index[key]
