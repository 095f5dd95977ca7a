"""Differences between the Blender versions the add-on is tested on (4.5 LTS, 5.0, 5.2, 5.3).

- EEVEE's engine identifier: ``BLENDER_EEVEE_NEXT`` in 4.2-4.5, ``BLENDER_EEVEE`` from 5.0.
- ``Material.use_nodes``: a material has a node tree only after ``use_nodes = True`` in 4.x;
  from 5.0 every new material has one and setting the property is deprecated (5.0 raises the
  DeprecationWarning; 5.2 and 5.3 leave it pending, so that a later unrelated call fails as
  ``SystemError``/``MemoryError`` where warnings are errors).
- The file's working colour space (``bpy.data.colorspace.working_space`` and the operator
  ``wm.set_working_color_space``) exists from 5.0; 4.x always renders in Linear Rec.709.
"""

from __future__ import annotations

import bpy

#: Blender 5.0 and later (a file's working colour space, node trees on every material).
BLENDER_5 = bpy.app.version >= (5, 0, 0)
#: The render engine identifier of EEVEE in this Blender.
EEVEE_ENGINE = "BLENDER_EEVEE" if BLENDER_5 else "BLENDER_EEVEE_NEXT"
#: The scene-linear space of Blender 4.x (not selectable there).
FIXED_WORKING_SPACE = "Linear Rec.709"


def ensure_node_tree(material) -> None:
    """Give ``material`` its node tree (4.x: ``use_nodes``; 5.x: it always has one)."""
    if not BLENDER_5 and not material.use_nodes:
        material.use_nodes = True


def working_space() -> str:
    """The file's scene-linear working colour space (Blender 4.x: always Linear Rec.709)."""
    colorspace = getattr(bpy.data, "colorspace", None)
    return colorspace.working_space if colorspace is not None else FIXED_WORKING_SPACE


def can_set_working_space() -> bool:
    """Whether this Blender has ``wm.set_working_color_space`` (5.0 and later)."""
    return hasattr(bpy.data, "colorspace")
