"""Cycles' ray visibility (Object > Visibility > Ray Visibility) → the ``visibility`` of
polychrome instances.

Cycles (intern/cycles/blender/object.cpp ``object_ray_visibility``, light.cpp): an object
is seen by camera, shadow, diffuse, glossy and transmission rays as its ``visible_*``
flags say. For lights, ``visible_camera`` (off by default) decides whether the camera sees
them. Cycles' lights never block shadow rays (measured with Cycles 4.5: an area light
between a sun and a floor casts no shadow, whatever ``visible_shadow`` says), and neither
does Polychrome's area light: it is a one-sided emitter (``pc.Emitter(one_sided=True)``)
that shadow rays do not see. A light's ``visible_diffuse``/``glossy``/``transmission``
drop it from that kind of bounce in Cycles, next-event estimation included, which
Polychrome does not do (warning).
"""

KINDS = ("camera", "shadow", "diffuse", "glossy", "transmission")


def object_visibility(ob, name, warnings):
    """The visibility of a mesh object's instances, or None when every ray sees it."""
    vis = {k: bool(getattr(ob, f"visible_{k}", True)) for k in KINDS}
    if not getattr(ob, "visible_volume_scatter", True):
        warnings.add(("vis-volume", name), f"object '{name}': volume scatter ray visibility is not supported and is ignored")
    if not all(vis[k] for k in ("diffuse", "glossy", "transmission")):
        warnings.add(
            ("vis-bounce", name),
            f"object '{name}': diffuse/glossy/transmission ray visibility is honoured for rays a surface scatters "
            "(a rough reflection counts as both diffuse and glossy); if it emits, lights sampled towards it still see it",
        )
    return None if all(vis.values()) else vis


def light_visibility(ob, name, warnings):
    """The visibility of an area light's emitter: seen by the camera as
    ``visible_camera`` says, never by shadow rays (Cycles' lights cast no shadow), by
    every other ray."""
    if not all(getattr(ob, f"visible_{k}", True) for k in ("diffuse", "glossy", "transmission")):
        warnings.add(
            ("vis-light", name), f"light '{name}': diffuse/glossy/transmission ray visibility of lights is not supported and is ignored"
        )
    return {"camera": bool(getattr(ob, "visible_camera", False)), "shadow": False}
