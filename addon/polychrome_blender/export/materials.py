"""Blender materials → polychrome materials.

Supported: Principled BSDF (base colour, emission colour × strength), Diffuse BSDF,
Emission, Polychrome's own nodes (see ``nodes.py``). Metallic / transmission use
``polychrome.Conductor`` / ``polychrome.Dielectric`` when the installed polychrome has
them. Anything else becomes a grey diffuse with one warning naming material and node.
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
            warnings.add(("vec", mat.name, src.name),
                         f"material '{mat.name}': the Vector input of '{src.name}' is ignored (the active UV map is used)")
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
            warnings.add(("tex", mat.name, src.name),
                         f"material '{mat.name}': image texture '{src.name}' is rendered as its mean colour (textures are not supported yet)")
            return tuple(float(c) for c in np.nan_to_num(mean))
    if src.type == "RGB":
        return _rgb(src.outputs[0].default_value)
    warnings.add(("link", mat.name, src.name),
                 f"material '{mat.name}': node '{src.name}' ({src.bl_idname}) driving '{name}' is not supported; its default value is used")
    return _rgb(sock.default_value)


def _input_value(node, name):
    return float(node.inputs[name].default_value)


def _principled(pc, mat, node, warnings):
    base = _input_colour(mat, node, "Base Color", warnings, pc, allow_texture=True)
    emission = None
    strength = _input_value(node, "Emission Strength")
    ecol = _input_colour(mat, node, "Emission Color", warnings, pc)
    if strength > 0.0 and max(ecol) > 0.0:
        emission = pc.spectra.rgb(*ecol) * strength
    metallic = _input_value(node, "Metallic")
    transmission = _input_value(node, "Transmission Weight")
    if transmission > 0.5 and hasattr(pc, "Dielectric"):
        try:
            return pc.Dielectric(ior=_input_value(node, "IOR"), name=mat.name)
        except TypeError:
            pass
    if metallic > 0.5 and hasattr(pc, "Conductor"):
        try:
            return pc.Conductor(base, roughness=_input_value(node, "Roughness"), name=mat.name)
        except TypeError:
            pass
    if transmission > 0.0 or metallic > 0.0:
        warnings.add(("principled", mat.name),
                     f"material '{mat.name}': metallic/transmission of '{node.name}' are not supported yet; rendered as diffuse")
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
    t = node.type
    if t == "BSDF_PRINCIPLED":
        return _principled(pc, mat, node, warnings)
    if t == "BSDF_DIFFUSE":
        return pc.Diffuse(_input_colour(mat, node, "Color", warnings, pc, allow_texture=True), name=mat.name)
    if t == "EMISSION":
        col = _input_colour(mat, node, "Color", warnings, pc)
        return pc.Emitter(pc.spectra.rgb(*col), strength=_input_value(node, "Strength"), name=mat.name)
    export_custom = getattr(node, "polychrome_export", None)
    if export_custom is not None:
        return export_custom(pc, mat, warnings)
    warnings.add(("node", mat.name, node.name),
                 f"material '{mat.name}': node '{node.name}' ({node.bl_idname}) is not supported; rendered as grey diffuse")
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
