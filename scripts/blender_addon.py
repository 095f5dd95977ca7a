"""The registered add-on for headless scripts: an installed extension, or this checkout."""

from __future__ import annotations

import importlib
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent


def addon():
    """The registered add-on's ``blender`` package (registering this repo's if none is)."""
    import bpy

    if hasattr(bpy.types, "SPECTRAL_OT_factor_scene"):
        module = bpy.types.SPECTRAL_OT_factor_scene.__module__     # …blender.<package>.operators
        return importlib.import_module(module[: module.rindex(".blender.") + len(".blender")])
    sys.path.insert(0, str(REPO))
    from spectral_materials import blender

    blender.register()
    return blender
