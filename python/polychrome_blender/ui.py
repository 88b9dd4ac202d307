"""Render Properties panel for ``scene.polychrome`` (its rows generated from the settings
schema, grouped as the schema groups them), and POLYCHROME added to the
built-in panels that work for any engine (format, output, colour management, lights,
materials, world), as BlendLuxCore does."""

import bpy
from polychrome.settings import SETTINGS

ENGINE = "POLYCHROME"

# Built-in panels whose settings polychrome reads.
EXTRA_PANELS = (
    "RENDER_PT_color_management",
    "RENDER_PT_format",
    "RENDER_PT_frame_range",
    "RENDER_PT_output",
    "DATA_PT_context_light",
    "DATA_PT_light",
    "DATA_PT_EEVEE_light",
    "NODE_DATA_PT_EEVEE_light",
    "VIEWLAYER_PT_eevee_next_layer_passes_data",
    "VIEWLAYER_PT_layer_passes",
    "DATA_PT_camera",
    "DATA_PT_lens",
    "DATA_PT_camera_display",
    "EEVEE_MATERIAL_PT_context_material",
    "EEVEE_MATERIAL_PT_surface",
    "EEVEE_WORLD_PT_surface",
    "WORLD_PT_context_world",
)
_added = []


class RENDER_PT_polychrome(bpy.types.Panel):
    bl_label = "Polychrome"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"
    COMPAT_ENGINES = {ENGINE}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        props = context.scene.polychrome
        for group, names in panel_groups():
            col = layout.column(heading=group)
            for name in names:
                row = col.row()
                cond = SETTINGS[name]["applies_when"]
                if cond is not None:
                    row.active = getattr(props, cond["setting"]) == cond["value"]
                row.prop(props, name)
        col = layout.column(heading="Viewport")
        col.prop(props, "viewport_samples", text="Samples")
        col.prop(props, "viewport_pixel_size", text="Pixel Size")


def panel_groups():
    """[(group, [setting names])] of the settings that are properties, in the schema's
    order: the panel's columns and rows."""
    groups = {}
    for name, spec in SETTINGS.items():
        if spec["blender"]["property"]:
            groups.setdefault(spec["group"], []).append(name)
    return list(groups.items())


classes = (RENDER_PT_polychrome,)


def register():
    for c in classes:
        bpy.utils.register_class(c)
    for name in EXTRA_PANELS:
        panel = getattr(bpy.types, name, None)
        engines = getattr(panel, "COMPAT_ENGINES", None)
        if isinstance(engines, set) and ENGINE not in engines:
            engines.add(ENGINE)
            _added.append(engines)


def unregister():
    while _added:
        _added.pop().discard(ENGINE)
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
