"""A spectral material library (core/library) in Blender: an Asset Library .blend whose
materials carry their stored factors (``asset_library``), and the operator that writes one
from File > Import (``operators``)."""

from __future__ import annotations

import bpy

from .operators import CLASSES, SPECTRAL_OT_import_library


def _menu(self, context) -> None:
    self.layout.operator(SPECTRAL_OT_import_library.bl_idname,
                         text="Spectral Material Library (as assets)")


def register() -> None:
    bpy.types.TOPBAR_MT_file_import.append(_menu)


def unregister() -> None:
    bpy.types.TOPBAR_MT_file_import.remove(_menu)


__all__ = ["CLASSES", "register", "unregister"]
