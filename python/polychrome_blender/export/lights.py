"""Blender lights → polychrome lights, in Cycles' units.

Sources: Cycles ``intern/cycles/blender/light.cpp`` (strength = colour × temperature
colour × energy × 2^exposure; ``normalize`` from ``LA_UNNORMALIZED``) and
``intern/cycles/scene/light.cpp`` (``Light::area`` and ``device_update_lights``: with
*Normalize* on, the emission is divided by the light's area; off, it is not).

* Point / spot: ``energy`` P watts → radiant intensity ``colour × P / 4π``. Cycles' area of
  a point or spot light is 4πr² (r = ``shadow_soft_size``), or 4 when r = 0; with
  Normalize off the power is therefore multiplied by 4πr² (4 when r = 0). The radius
  makes it a sphere light (soft shadows).
* Area: a one-sided Lambertian emitter of radiance ``colour × P / (π A)``, A its
  world-space area (Cycles: |X axis|·size_x × |Y axis|·size_y, × π/4 for disks and
  ellipses, so object scale counts); with Normalize off ``colour × P / π``. Exported as an
  emissive quad/disk (ellipse: a 32-gon, its radiance scaled so its power is Cycles') that
  emits from its −Z face only and that rays pass through after gathering its emission
  (``pc.Emitter(one_sided=True, see_through=True)``): as in Cycles, where a light is a
  transparent bounce, it casts no shadow and its back shows what lies behind it. The
  camera sees it only with the object's ``visible_camera`` (off by default)
  (``visibility.py``).
* Spot: ``polychrome.SpotLight``, cone ``spot_size`` and ``spot_blend`` as Blender's.
* Sun: ``polychrome.SunLight`` of irradiance ``colour × strength`` W/m² (Normalize on);
  with Normalize off Cycles' sun disk has radiance = strength, so the irradiance is
  ``strength × π sin²(angle/2)`` (angle 0: strength). The angle is the sun disk's
  angular diameter (soft shadows, as Cycles'; the disk shows in mirrors and its caustics
  through glass, MIS-weighted as Cycles' ``distant_light_intersect``).
* Point and spot lights with a radius are spheres that BSDF rays hit too (Cycles'
  ``point_light_intersect``). Sphere lights and sun disks are seen by the camera only
  with the object's ``visible_camera`` (off by default).
* Temperature (``use_temperature``): a blackbody spectrum normalised to the luminance of
  white, filtered by the colour tint (``polychrome.spectra.tinted``), as Cycles multiplies
  the colour by the temperature colour.
"""

import math

import numpy as np
import polychrome as pc

from .visibility import light_visibility, point_light_visibility

DISK_SEGMENTS = 32


def _ybar(lam):
    """CIE 1931 ȳ, Wyman, Sloan & Shirley (2013) multi-lobe fit (for a luminance ratio)."""
    t1 = (lam - 568.8) * np.where(lam < 568.8, 0.0213, 0.0247)
    t2 = (lam - 530.9) * np.where(lam < 530.9, 0.0613, 0.0322)
    return 0.821 * np.exp(-0.5 * t1 * t1) + 0.286 * np.exp(-0.5 * t2 * t2)


def blackbody_white(temperature):
    """Planck's law at ``temperature`` K (the core's ``blackbody``: 1 at Wien's peak) scaled
    to luminance 1, as Cycles normalises its Blackbody colour."""
    lam = np.linspace(380.0, 780.0, 401)
    x = lam * 1e-9
    planck = 1.0 / (x**5 * (np.exp(1.4387769e-2 / (x * temperature)) - 1.0))
    peak_lam = 2.897771955e-3 / temperature  # Wien: the core normalises at the true peak
    peak = 1.0 / (peak_lam**5 * (math.exp(1.4387769e-2 / (peak_lam * temperature)) - 1.0))
    y = _ybar(lam)
    lum = float(np.trapz(y * planck / peak, lam) / np.trapz(y, lam))
    return pc.spectra.blackbody(float(temperature), 1.0 / lum)


def light_colour(ld, name, warnings):
    """The light's colour as a spectrum: RGB, or a blackbody filtered by the colour when
    ``use_temperature`` (Cycles: colour × temperature colour)."""
    col = tuple(float(c) for c in ld.color[:3])
    if getattr(ld, "use_temperature", False):  # Blender 4.5+
        return pc.spectra.tinted(blackbody_white(float(ld.temperature)), *col)
    return pc.spectra.rgb(*col)


def light_nodes(ld, name, warnings):
    """What a point or spot light's node tree (Cycles' light shader) changes:
    ``(colour, strength, profile)`` — the Emission node's Color as RGB (or a
    Blackbody's temperature, as a float) multiplying the light's colour, its Strength
    multiplying the power, and an IES Texture on that Strength as a
    :class:`polychrome.ies.IESProfile` (its own Strength folded into the profile's).
    ``(None, 1.0, None)`` without nodes; anything else warns once and is left out."""
    nt = ld.node_tree if getattr(ld, "use_nodes", False) else None
    if nt is None:
        return None, 1.0, None
    out = nt.get_output_node("CYCLES") or nt.get_output_node("ALL")
    sock = None if out is None else out.inputs.get("Surface")
    if sock is None or not sock.is_linked:
        return None, 1.0, None
    em = sock.links[0].from_node
    if em.type != "EMISSION":
        warnings.add(
            ("light-node", name),
            f"light '{name}': node '{em.name}' on its Surface is not supported; the light's own colour and power are used",
        )
        return None, 1.0, None
    colour, strength, profile = None, 1.0, None
    c = em.inputs["Color"]
    if not c.is_linked:
        colour = tuple(float(x) for x in c.default_value[:3])
    else:
        src = c.links[0].from_node
        if src.type == "BLACKBODY" and not src.inputs["Temperature"].is_linked:
            colour = float(src.inputs["Temperature"].default_value)
        else:
            warnings.add(
                ("light-node", name, src.name), f"light '{name}': node '{src.name}' on the Emission Color is not supported; white is used"
            )
    st = em.inputs["Strength"]
    if not st.is_linked:
        strength = float(st.default_value)
    else:
        src = st.links[0].from_node
        if src.type == "TEX_IES":
            profile = _ies_profile(src, name, warnings)
        else:
            warnings.add(
                ("light-node", name, src.name), f"light '{name}': node '{src.name}' on the Emission Strength is not supported; 1 is used"
            )
    if not math.isfinite(strength) or (isinstance(colour, tuple) and not all(map(math.isfinite, colour))):
        raise ValueError(f"light '{name}': its Emission node's colour or strength is not finite")
    return colour, strength, profile


def _ies_profile(node, name, warnings):
    """The IES Texture node's profile (internal text or external file) × its Strength."""
    import bpy
    from polychrome import ies

    if node.inputs["Vector"].is_linked:
        warnings.add(
            ("light-ies", name), f"light '{name}': the Vector input of '{node.name}' is ignored (the light's own direction is used)"
        )
    if node.inputs["Strength"].is_linked:
        warnings.add(("light-ies-s", name), f"light '{name}': the linked Strength of '{node.name}' is ignored (1 is used)")
    try:
        if node.mode == "INTERNAL":
            if node.ies is None:
                raise ValueError("no text block")
            profile = ies.parse(node.ies.as_string(), name=node.ies.name)
        else:
            profile = ies.read(bpy.path.abspath(node.filepath))
    except ValueError as e:
        # One warning; the light keeps its colour and power, without the profile.
        warnings.add(("light-ies-bad", name), f"light '{name}': IES Texture '{node.name}': {e}; the light is left without its profile")
        return None
    if not node.inputs["Strength"].is_linked:
        profile.values = profile.values * float(node.inputs["Strength"].default_value)
    return profile


def _with_node_colour(spec, colour, ld, name, warnings):
    """The light's spectrum ``spec`` times its Emission node's colour (RGB, or a
    blackbody temperature)."""
    if colour is None:
        return spec
    base = tuple(float(c) for c in ld.color[:3])
    if isinstance(colour, float):
        if getattr(ld, "use_temperature", False):
            warnings.add(("light-bb", name), f"light '{name}': both its temperature and a Blackbody node colour it; the node's is used")
        return pc.spectra.tinted(blackbody_white(colour), *base)
    rgb = tuple(a * b for a, b in zip(base, colour))
    if getattr(ld, "use_temperature", False):
        return pc.spectra.tinted(blackbody_white(float(ld.temperature)), *rgb)
    return pc.spectra.rgb(*rgb)


def _orientation(m):
    """The light's local axes (columns, unit length) from its world matrix."""
    r = np.array(m[:3, :3], np.float64)
    n = np.linalg.norm(r, axis=0)
    return (r / np.where(n > 0, n, 1.0)).tolist()


def _normalized(ld):
    return bool(getattr(ld, "normalize", True))  # Blender 4.5+; normalised before


def _area_polygon(ld):
    """Outline in the light's local XY plane (it emits along local −Z)."""
    sx = float(ld.size)
    sy = float(ld.size_y) if ld.shape in ("RECTANGLE", "ELLIPSE") else sx
    if ld.shape in ("SQUARE", "RECTANGLE"):
        pts = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], np.float64) * [sx / 2, sy / 2]
    else:
        a = np.linspace(0.0, 2.0 * math.pi, DISK_SEGMENTS, endpoint=False)
        pts = np.stack([np.cos(a) * sx / 2, np.sin(a) * sy / 2], axis=1)
    n = len(pts)
    x, y = pts[:, 0], pts[:, 1]
    area = 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))
    tris = np.stack([np.zeros(n - 2, np.int64), np.arange(1, n - 1), np.arange(2, n)], axis=1)
    # Cycles' area of the shape (an ellipse is π/4 of its box; the 32-gon is a bit less)
    exact = sx * sy * (math.pi / 4 if ld.shape in ("DISK", "ELLIPSE") else 1.0)
    return pts, tris, area, exact, max(sx, sy)


def _power(ld, name):
    """Blender's power (or sun strength) times 2^exposure (Blender 4.4+), as Cycles uses it."""
    p = float(ld.energy) * 2.0 ** float(getattr(ld, "exposure", 0.0))  # exposure: Blender 4.4+
    if not math.isfinite(p) or p < 0.0:
        raise ValueError(f"light '{name}': power {p} W must be finite and non-negative")
    return p


def export_area(scene, ld, name, matrix, warnings, visibility=None, motion=None):
    power = _power(ld, name)
    pts, tris, area, exact, size = _area_polygon(ld)
    # Cycles scales the size by the lengths of the object's X and Y axes (scene/light.cpp).
    stretch = float(np.linalg.norm(matrix[:3, 0]) * np.linalg.norm(matrix[:3, 1]))
    if not area * stretch > 0.0 or power == 0.0:
        return
    if ld.spread < math.pi - 1e-4:
        warnings.add(("spread", name), f"light '{name}': area light spread is not supported; rendered as 180°")
    spec = light_colour(ld, name, warnings)
    # Normalize on: P is the power of the whole light (radiance P/(πA), A in world space);
    # off: the radiance is P/π. Either way the polygon emits Cycles' power.
    if _normalized(ld):
        radiance = spec * (power / (math.pi * area * stretch))
    else:
        radiance = spec * (power * exact / (math.pi * area))
    emitter = pc.Emitter(radiance, one_sided=True, see_through=True, name=f"{name} (area light)")
    verts = np.concatenate([pts, np.zeros((len(pts), 1))], axis=1).astype(np.float32)
    # Wound clockwise seen from +Z: the front (emitting) face looks along local −Z.
    m = scene.add_mesh(f"{name}", verts, tris[:, ::-1].copy(), material=emitter, place=False)
    scene.add_instance(m, matrix, name, visibility=visibility, motion=motion)


def _axis(m, name):
    """The lamp's −Z axis in world space (where spot and sun lights point)."""
    d = -m[:3, 2]
    n = float(np.linalg.norm(d))
    if not n > 0.0:
        raise ValueError(f"light '{name}': its transform is degenerate")
    return (d / n).tolist()


def _point_power(ld, name):
    """Power of a point or spot light: with Normalize off Cycles does not divide by its
    area 4πr² (4 when r = 0), which multiplies the normalised power by that area."""
    p = _power(ld, name)
    if _normalized(ld):
        return p
    r = float(ld.shadow_soft_size)
    return p * (4.0 * math.pi * r * r if r > 0.0 else 4.0)


def _radius(ld, name, warnings):
    """The sphere radius of a point or spot light (``shadow_soft_size``)."""
    r = float(ld.shadow_soft_size)
    if not (math.isfinite(r) and r >= 0.0):
        raise ValueError(f"light '{name}': radius {r} must be finite and non-negative")
    if r > 0.0 and getattr(ld, "use_soft_falloff", False):  # Blender 4.0+
        warnings.add(
            ("soft_falloff", name),
            f"light '{name}': Soft Falloff is not supported (it changes the light only near the sphere); rendered as a sphere light",
        )
    return r


def _sun_strength(ld, name):
    """Irradiance of a sun: with Normalize off its disk of angular diameter ``angle`` has
    radiance = strength, i.e. irradiance strength·π·sin²(angle/2) (Cycles' sun area)."""
    s = _power(ld, name)
    half = 0.5 * float(ld.angle)
    if _normalized(ld) or not half > 0.0:
        return s
    return s * math.pi * math.sin(half) ** 2


def export_lights(depsgraph, scene, warnings, motion=None):
    """Adds every visible light to ``scene``; returns how many. ``motion`` (export/motion.py's
    Motion, with motion blur on): point, spot and area lights move over the shutter."""
    count = 0
    for inst in depsgraph.object_instances:
        ob = inst.object
        if ob.type != "LIGHT":
            continue
        ld = ob.data
        name = ob.original.name
        m = np.array(inst.matrix_world, dtype=np.float64)
        if not np.all(np.isfinite(m)):
            raise ValueError(f"light '{name}': its transform is not finite")
        pos = m[:3, 3]
        keys = None if motion is None else motion.instance_motion(inst)
        if ld.type in ("POINT", "SPOT"):
            colour, node_strength, profile = light_nodes(ld, name, warnings)
        elif getattr(ld, "use_nodes", False):
            warnings.add(
                ("light-nodes", name),
                f"light '{name}': the node tree of a {ld.type.lower()} light is not supported; its own colour and power are used",
            )
        if ld.type == "POINT":
            spec = _with_node_colour(light_colour(ld, name, warnings), colour, ld, name, warnings)
            radius = _radius(ld, name, warnings)
            scene.add_light(
                pc.PointLight(
                    pos.tolist(),
                    _point_power(ld, name) * node_strength,
                    spec,
                    name=name,
                    radius=radius,
                    visibility=point_light_visibility(ob, name, warnings),
                    profile=profile,
                    orientation=_orientation(m),
                    motion=keys,
                )
            )
        elif ld.type == "AREA":
            export_area(scene, ld, name, m, warnings, light_visibility(ob, name, warnings), keys)
        elif ld.type == "SPOT":
            spec = _with_node_colour(light_colour(ld, name, warnings), colour, ld, name, warnings)
            scene.add_light(
                pc.SpotLight(
                    pos.tolist(),
                    _axis(m, name),
                    power=_point_power(ld, name) * node_strength,
                    profile=profile,
                    orientation=_orientation(m),
                    color=spec,
                    spot_size=float(ld.spot_size),
                    spot_blend=float(ld.spot_blend),
                    name=name,
                    radius=_radius(ld, name, warnings),
                    visibility=point_light_visibility(ob, name, warnings),
                    motion=keys,
                )
            )
        elif ld.type == "SUN":
            spec = light_colour(ld, name, warnings)
            angle = min(max(float(ld.angle), 0.0), math.pi)
            scene.add_light(
                pc.SunLight(
                    _axis(m, name),
                    strength=_sun_strength(ld, name),
                    color=spec,
                    name=name,
                    angle=angle,
                    visibility=point_light_visibility(ob, name, warnings),
                    motion=keys,
                )
            )
        else:
            warnings.add(("light", ld.type), f"light '{name}': {ld.type.lower()} lights are not supported yet and are skipped")
            continue
        count += 1
    return count
