"""Blender adapters (everything that imports ``bpy``): thin layers over :mod:`..core`.

``register()`` / ``unregister()`` add and remove, in order, the property groups, the
operators, the panels and the draw handlers; explicit class lists live in each module.
"""

from __future__ import annotations

import bpy

from . import draw, operators, panels, properties


def register() -> None:
    properties.register()
    for cls in operators.CLASSES + panels.CLASSES:
        bpy.utils.register_class(cls)
    draw.register()


def unregister() -> None:
    draw.unregister()
    for cls in reversed(operators.CLASSES + panels.CLASSES):
        bpy.utils.unregister_class(cls)
    properties.unregister()
