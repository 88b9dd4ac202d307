"""Blender world → the scene's world: Background colour × strength (uniform radiance),
or an Environment Texture (equirectangular HDRI, Z rotation of a Mapping node), and the
world's Volume output as a medium filling all space (``export/volumes.py``)."""

import numpy as np
import polychrome as pc

from .textures import MISSING_RGBA
from .volumes import export_world_volume


def _hdri(scene, world, env, strength, warnings, textures):
    """Environment Texture → ``scene.set_world(texture=...)``; False if its image has no pixels."""
    tex = textures.texture(env, f"world '{world.name}'", warnings, user=("WORLD", world.original.name))
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


def export_world(depsgraph, scene, warnings, textures):
    """Sets ``scene``'s world from the depsgraph's; images come from ``textures`` (a
    :class:`~.textures.TextureCache`)."""
    world = depsgraph.scene.world
    scene.world_volume = None
    if world is None:
        return
    scene.world_volume = export_world_volume(world, warnings)
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
            if src.type == "TEX_ENVIRONMENT":
                if src.image is not None and _hdri(scene, world, src, strength, warnings, textures):
                    return
                # No image, or one without pixels (its warning said so): Cycles' missing-image
                # magenta (EnvironmentTextureNode::compile), as the Image Texture's.
                colour = MISSING_RGBA[:3]
            else:
                warnings.add(("world", src.name), f"world '{world.name}': node '{src.name}' is not supported; its default colour is used")
    if strength > 0.0 and max(colour) > 0.0:
        if not all(np.isfinite(colour)) or not np.isfinite(strength):
            raise ValueError(f"world '{world.name}': colour or strength is not finite")
        scene.set_world(pc.spectra.rgb(*colour) * strength)
