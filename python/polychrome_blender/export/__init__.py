"""Export from Blender's evaluated depsgraph to a :class:`polychrome.Scene`.

``Exporter().export(depsgraph)`` (or ``export_scene(depsgraph)``) returns
``(scene, warnings)``; every problem with user data raises ``ValueError`` naming the
object, which the engine reports. An :class:`Exporter` kept between exports re-exports
only what ``Exporter.update(depsgraph)`` was told changed (the viewport does this).
"""

from .exporter import Exporter, export_scene

__all__ = ["Exporter", "export_scene"]
