"""Polychrome for Blender: the spectral path tracer as render engine ``POLYCHROME``.

``import polychrome_blender; polychrome_blender.register()`` in any process with ``bpy``
(or install the extension zip); ``unregister()`` undoes it. Both are idempotent.
Layout follows BlendLuxCore: ``engine``, ``properties``, ``ui``, ``export/``, ``nodes``,
``passes``.
"""

_registered = False


def register():
    global _registered
    if _registered:
        return
    from . import engine, nodes, properties, ui

    properties.register()
    nodes.register()
    engine.register()
    ui.register()
    from . import usd_export

    usd_export.register()
    _registered = True


def unregister():
    global _registered
    if not _registered:
        return
    from . import engine, nodes, properties, ui, usd_export

    for mod in (usd_export, ui, engine, nodes, properties):
        try:
            mod.unregister()
        except Exception as e:  # noqa: BLE001 - unregister everything we can
            print(f"polychrome_blender: unregistering {mod.__name__} failed: {e}")
    _registered = False
