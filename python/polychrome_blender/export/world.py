"""Blender world → uniform world radiance (``scene.set_world``).

Background colour × strength, or an Environment Texture (equirectangular HDRI, Z rotation
of a Mapping node) when polychrome has HDRI worlds; otherwise its mean colour, with a
warning."""

import numpy as np


def _hdri(pc, scene, world, bg, env, strength, warnings):
    """Environment Texture → ``scene.set_world(texture=...)`` when polychrome has HDRIs."""
    import inspect

    if not hasattr(pc, "Texture") or "texture" not in inspect.signature(scene.set_world).parameters:
        return False
    from .textures import blender_texture

    tex = blender_texture(pc, env, f"world '{world.name}'", warnings, {})
    if tex is None:
        return False
    rotation = 0.0
    vec = env.inputs["Vector"]
    if vec.is_linked:
        m = vec.links[0].from_node
        if m.type == "MAPPING" and not m.inputs["Rotation"].is_linked:
            rot = m.inputs["Rotation"].default_value
            rotation = float(rot[2])
            if abs(rot[0]) > 1e-6 or abs(rot[1]) > 1e-6:
                warnings.add(("world", "rot"), f"world '{world.name}': only the Z rotation of '{m.name}' is used")
        else:
            warnings.add(("world", "vec"), f"world '{world.name}': the Vector input of '{env.name}' is ignored")
    if env.projection != "EQUIRECTANGULAR":
        warnings.add(("world", "proj"), f"world '{world.name}': {env.projection} projection is not supported; equirectangular is used")
    scene.set_world(texture=tex, strength=strength, rotation=rotation)
    return True


def export_world(pc, depsgraph, scene, warnings):
    world = depsgraph.scene.world
    if world is None:
        return
    colour = tuple(float(c) for c in world.color[:3])
    strength = 1.0
    if world.use_nodes and world.node_tree is not None:
        out = world.node_tree.get_output_node("ALL") or world.node_tree.get_output_node("CYCLES")
        sock = None if out is None else out.inputs.get("Surface")
        if sock is None or not sock.is_linked:
            return
        bg = sock.links[0].from_node
        if bg.type != "BACKGROUND":
            warnings.add(("world", bg.name), f"world '{world.name}': node '{bg.name}' is not supported; world is black")
            return
        strength = float(bg.inputs["Strength"].default_value)
        csock = bg.inputs["Color"]
        colour = tuple(float(c) for c in csock.default_value[:3])
        if csock.is_linked:
            src = csock.links[0].from_node
            if src.type == "TEX_ENVIRONMENT" and src.image is not None and _hdri(pc, scene, world, bg, src, strength, warnings):
                return
            if src.type == "TEX_ENVIRONMENT" and src.image is not None and src.image.size[0] > 0:
                img = src.image
                buf = np.empty(img.size[0] * img.size[1] * img.channels, np.float32)
                img.pixels.foreach_get(buf)
                colour = tuple(float(c) for c in np.nan_to_num(buf.reshape(-1, img.channels)[:, :3].mean(axis=0)))
                warnings.add(
                    ("world", "env"), f"world '{world.name}': environment texture rendered as its mean colour (HDRI not supported yet)"
                )
            else:
                warnings.add(("world", src.name), f"world '{world.name}': node '{src.name}' is not supported; its default colour is used")
    if strength > 0.0 and max(colour) > 0.0:
        if not all(np.isfinite(colour)) or not np.isfinite(strength):
            raise ValueError(f"world '{world.name}': colour or strength is not finite")
        scene.set_world(pc.spectra.rgb(*colour) * strength)
