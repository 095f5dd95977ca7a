"""Spectral lights in Blender: a light's SPD (its settings, reading and plot), which lights
reach the scene and what the shaders see of them."""

from __future__ import annotations

import bpy
from bpy.props import PointerProperty

from . import panels, properties

#: Registered by ``blender.register()`` in this order, before :func:`register` runs.
CLASSES = properties.CLASSES + panels.CLASSES


def register() -> None:
    """Give every light its spectral settings."""
    bpy.types.Light.spectral = PointerProperty(type=properties.SPECTRAL_PG_light)


def unregister() -> None:
    del bpy.types.Light.spectral
