"""Polychrome's custom shader nodes (placeholder until the nodes land)."""

classes = ()


def register():
    import bpy

    for c in classes:
        bpy.utils.register_class(c)


def unregister():
    import bpy

    for c in reversed(classes):
        bpy.utils.unregister_class(c)
