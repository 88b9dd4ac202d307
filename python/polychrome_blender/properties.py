"""``scene.polychrome``: one property per render setting, generated from the core's
settings schema (:mod:`polychrome.settings`) — the names, defaults, ranges, enum items
and descriptions of :class:`polychrome.RenderSettings` and the CLI flags — plus the
viewport's own two settings. Settings Blender takes from elsewhere (the resolution) or
cannot hold (a list) have no property; the schema says which."""

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty, StringProperty
from polychrome.settings import SETTINGS

#: Blender's integer properties are 32-bit.
INT_MIN, INT_MAX = -(2**31), 2**31 - 1
#: Schema units Blender can display.
UNITS = {"s": "TIME_ABSOLUTE"}


def property_for(spec):
    """The bpy property of a setting (None: it is not a property), from its schema entry."""
    b = spec["blender"]
    if not b["property"]:
        return None
    kind, t = spec["kind"], spec["kind"]["type"]
    common = dict(name=spec["label"], description=spec["help"], default=b["default"])
    if t == "int":
        ranges = dict(min=max(kind["min"], INT_MIN), max=min(kind["max"], INT_MAX))
        for k in ("soft_min", "soft_max"):
            if kind.get(k) is not None:
                ranges[k] = kind[k]
        return IntProperty(**common, **ranges)
    if t == "float":
        ranges = dict(min=kind["min"])
        for k in ("max", "soft_min", "soft_max"):
            if kind.get(k) is not None:
                ranges[k] = kind[k]
        unit = UNITS.get(kind.get("unit"))
        return FloatProperty(**common, **ranges, **({"unit": unit} if unit else {}))
    if t == "bool":
        return BoolProperty(**common)
    if t == "enum":
        return EnumProperty(items=[(i["name"], i["label"], i["description"]) for i in kind["items"]], **common)
    if t == "string":
        return StringProperty(**common)
    raise ValueError(
        f"setting '{spec['name']}': a {t} setting cannot be a Blender property; the schema must say where Blender takes it from"
    )


def settings_properties():
    """{name: property} of the settings that are properties, in the schema's order."""
    props = {name: property_for(spec) for name, spec in SETTINGS.items()}
    return {name: p for name, p in props.items() if p is not None}


#: Settings of the interactive viewport only (not render settings, so not in the schema).
VIEWPORT_PROPERTIES = {
    "viewport_samples": IntProperty(
        name="Viewport Samples",
        description="Samples per pixel of the interactive viewport render (it refines up to this many, "
        "restarting on every edit or view change)",
        default=256,
        min=1,
        soft_max=4096,
    ),
    "viewport_pixel_size": IntProperty(
        name="Viewport Pixel Size",
        description="Screen pixels per rendered pixel in the viewport (larger: faster, blockier)",
        default=2,
        min=1,
        max=16,
    ),
}

PolychromeRenderSettings = type(
    "PolychromeRenderSettings",
    (bpy.types.PropertyGroup,),
    {
        "__doc__": "Polychrome render settings (generated from the settings schema)",
        "__annotations__": {**settings_properties(), **VIEWPORT_PROPERTIES},
    },
)

classes = (PolychromeRenderSettings,)


def register():
    for c in classes:
        bpy.utils.register_class(c)
    bpy.types.Scene.polychrome = PointerProperty(type=PolychromeRenderSettings)


def unregister():
    if hasattr(bpy.types.Scene, "polychrome"):
        del bpy.types.Scene.polychrome
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
