"""Cycles' ray visibility (Object > Visibility > Ray Visibility) → the ``visibility`` of
polychrome instances.

Cycles (intern/cycles/blender/object.cpp ``object_ray_visibility``, light.cpp): an object
is seen by camera, shadow, diffuse, glossy and transmission rays as its ``visible_*``
flags say. For lights, ``visible_camera`` (off by default) decides whether the camera sees
them (an area light's polygon, a sphere light, a sun's disk). Cycles' lights never block shadow rays (measured with Cycles 4.5: an area light
between a sun and a floor casts no shadow, whatever ``visible_shadow`` says), and neither
does Polychrome's area light: it is a one-sided emitter (``pc.Emitter(one_sided=True)``)
that shadow rays do not see. A light's ``visible_diffuse``/``glossy``/``transmission`` drop it from that kind of
bounce in Cycles, next-event estimation included (closures of an excluded kind are left
out of the light's evaluation): Polychrome's rays scattered by a lobe of that kind do not
see it, and next-event estimation skips it at surfaces whose lobes are all of excluded
kinds (a diffuse floor under a light invisible to diffuse rays); at a surface that mixes
diffuse and glossy lobes it still lights every lobe (warning).
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
            f"object '{name}': diffuse/glossy/transmission ray visibility is honoured by the kind of lobe that scatters a ray "
            "or is lit by its emission; at a surface mixing diffuse and glossy lobes (Principled, Mix) a rough reflection "
            "counts as both",
        )
    return None if all(vis.values()) else vis


def _light_bounce_visibility(ob, name, warnings):
    vis = {k: bool(getattr(ob, f"visible_{k}", True)) for k in ("diffuse", "glossy", "transmission")}
    if not all(vis.values()):
        warnings.add(
            ("vis-light", name),
            f"light '{name}': diffuse/glossy/transmission ray visibility is honoured for rays of those kinds and for "
            "surfaces whose lobes are all of them; at a surface mixing diffuse and glossy lobes (Principled, Mix) it "
            "still lights every lobe, and FORWARD/BIDIRECTIONAL light paths still start from it",
        )
    return vis


def light_visibility(ob, name, warnings):
    """The visibility of an area light's emitter: seen by the camera as
    ``visible_camera`` says, never by shadow rays (Cycles' lights cast no shadow), by
    diffuse, glossy and transmission rays as ``visible_*`` say."""
    return {"camera": bool(getattr(ob, "visible_camera", False)), "shadow": False, **_light_bounce_visibility(ob, name, warnings)}


def point_light_visibility(ob, name, warnings):
    """The rays that see a point, spot or sun light and the bounces it lights: the camera
    (a sphere light or a sun's disk) as ``visible_camera`` says (off by default), diffuse,
    glossy and transmission as ``visible_*`` say; None when that is the default (camera
    off, the rest on)."""
    vis = {"camera": bool(getattr(ob, "visible_camera", False)), **_light_bounce_visibility(ob, name, warnings)}
    return None if not vis["camera"] and all(vis[k] for k in ("diffuse", "glossy", "transmission")) else vis
