"""The operator that writes a library folder as an Asset Library .blend (a thin wrapper of
:func:`asset_library.write_asset_library`, which scripts call too)."""

from __future__ import annotations

import bpy
from bpy.props import BoolProperty, StringProperty

from ...core.errors import InvalidBRDFData
from .asset_library import register_asset_library, write_asset_library


class SPECTRAL_OT_import_library(bpy.types.Operator):
    """Write a spectral material library folder as an Asset Library .blend beside it"""

    bl_idname = "spectral.import_library"
    bl_label = "Import Spectral Library"
    bl_options = {"REGISTER"}

    directory: StringProperty(name="Library folder", subtype="DIR_PATH")
    register: BoolProperty(name="Add to Asset Libraries", default=True,
                           description="Add the folder to Preferences > File Paths > Asset "
                                       "Libraries, so its materials show in the Asset Browser")

    def invoke(self, context, event):
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}

    def execute(self, context):
        try:
            out = write_asset_library(self.directory)
        except (InvalidBRDFData, OSError, ValueError) as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        if self.register:
            library = register_asset_library(out.blend.parent)
            self.report({"INFO"}, f"Wrote {out.blend} ({out.materials} materials); it is the "
                                  f"asset library '{library.name}'")
        else:
            self.report({"INFO"}, f"Wrote {out.blend} ({out.materials} materials); add its "
                                  "folder under Preferences > File Paths > Asset Libraries")
        return {"FINISHED"}


CLASSES = (SPECTRAL_OT_import_library,)
