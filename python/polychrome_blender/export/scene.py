"""The whole export: camera, materials, meshes, lights, world."""

from .camera import export_camera
from .lights import export_lights
from .materials import MaterialTable
from .meshes import export_meshes
from .warnings import Warnings
from .world import export_world


def export_scene(pc, depsgraph, camera=None):
    """Returns ``(polychrome.Scene, [warning messages])``. ``camera`` (a
    ``polychrome.Camera``, e.g. the viewport's) replaces the scene camera."""
    warnings = Warnings()
    scene = pc.Scene()
    scene.camera = export_camera(pc, depsgraph, warnings) if camera is None else camera
    materials = MaterialTable(pc, scene, warnings)
    export_meshes(pc, depsgraph, scene, materials, warnings)
    export_lights(pc, depsgraph, scene, warnings)
    export_world(pc, depsgraph, scene, warnings)
    return scene, warnings.messages
