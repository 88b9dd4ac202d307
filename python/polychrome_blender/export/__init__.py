"""Export from Blender's evaluated depsgraph to a :class:`polychrome.Scene`.

``export_scene(polychrome, depsgraph)`` returns ``(scene, warnings)``; every problem
with user data raises ``ValueError`` naming the object, which the engine reports.
"""

from .scene import export_scene

__all__ = ["export_scene"]
