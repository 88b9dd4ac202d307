"""Render Properties panel for ``scene.polychrome``, and POLYCHROME added to the
built-in panels that work for any engine (format, output, colour management, lights,
materials, world), as BlendLuxCore does."""

import bpy

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
        col = layout.column()
        col.prop(props, "quality")
        col.prop(props, "method")
        col.prop(props, "direction")
        if props.method == "POLYCHROMATIC":
            col.prop(props, "dispersion_splitting")
        col.prop(props, "wavelength_count")
        col.prop(props, "uplift")
        col.prop(props, "spectral_output")
        col = layout.column()
        col.prop(props, "samples")
        col.prop(props, "noise_threshold")
        col.prop(props, "time_limit")
        col.prop(props, "max_bounces")
        col.prop(props, "seed")
        col.prop(props, "threads")
        col = layout.column(heading="Viewport")
        col.prop(props, "viewport_samples", text="Samples")
        col.prop(props, "viewport_pixel_size", text="Pixel Size")


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
