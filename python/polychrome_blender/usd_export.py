"""File → Export → Polychrome USD: the scene as Polychrome renders it (spectral
materials, lights, camera, render settings), written by :func:`polychrome.usd.write_stage`.

The stage keeps the spectral data in ``polychrome:`` attributes beside standard
UsdGeom / UsdPreviewSurface / UsdLux values (docs/usd.md), so other tools open it too.
"""

import bpy
from bpy.props import StringProperty
from bpy_extras.io_utils import ExportHelper

from .engine import settings_from_scene
from .export import export_scene
from .export.camera import render_size


class POLYCHROME_OT_export_usd(bpy.types.Operator, ExportHelper):
    """Export the scene as a USD stage that keeps Polychrome's spectral data"""

    bl_idname = "export_scene.polychrome_usd"
    bl_label = "Export Polychrome USD"
    bl_options = {"REGISTER"}

    filename_ext = ".usda"
    filter_glob: StringProperty(default="*.usd;*.usda;*.usdc", options={"HIDDEN"})

    def execute(self, context):
        try:
            from polychrome import usd  # needs usd-core (polychrome[usd])

            depsgraph = context.evaluated_depsgraph_get()
            scene, messages = export_scene(depsgraph)
            width, height = render_size(depsgraph.scene)
            settings = settings_from_scene(depsgraph.scene.polychrome, width, height)
            path = usd.write_stage(scene, self.filepath, settings)
        except (ImportError, OSError, ValueError) as e:
            self.report({"ERROR"}, f"Polychrome USD export failed: {e}")
            return {"CANCELLED"}
        for message in messages:
            self.report({"WARNING"}, message)
        self.report({"INFO"}, f"Polychrome USD written to {path}")
        return {"FINISHED"}


def menu_export(self, context):
    self.layout.operator(POLYCHROME_OT_export_usd.bl_idname, text="Polychrome USD (.usd/.usda/.usdc)")


def register():
    bpy.utils.register_class(POLYCHROME_OT_export_usd)
    bpy.types.TOPBAR_MT_file_export.append(menu_export)


def unregister():
    bpy.types.TOPBAR_MT_file_export.remove(menu_export)
    if POLYCHROME_OT_export_usd.is_registered:
        bpy.utils.unregister_class(POLYCHROME_OT_export_usd)
