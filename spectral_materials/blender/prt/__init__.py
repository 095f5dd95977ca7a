"""Spectral PRT in Blender: the environment and object settings, operators and panels, the
scene's environment and albedo, the transfer bake, the GPU drawer and the per-pixel
evaluation used by tests and demos.

Until the next release, ``spectral_materials.blender.prt.<name>`` also serves the names of
the old ``blender/prt.py`` (now :mod:`.scene`), with a DeprecationWarning."""

from __future__ import annotations

import bpy
from bpy.props import PointerProperty

from ..._moved import forward_to
from . import operators, panels, properties

__getattr__ = forward_to(__name__, "scene")

#: Registered by ``blender.register()`` in this order, before :func:`register` runs. The
#: environment group is the target of ``Scene.spectral.environment`` (``scene_properties``).
CLASSES = properties.CLASSES + operators.CLASSES + panels.CLASSES


def register() -> None:
    """Give every object its PRT settings."""
    bpy.types.Object.spectral_prt = PointerProperty(type=properties.SPECTRAL_PG_prt_object)


def unregister() -> None:
    del bpy.types.Object.spectral_prt
