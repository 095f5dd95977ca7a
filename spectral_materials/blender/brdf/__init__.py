"""Factor-pack materials in Blender: the material's settings, operators and panels,
sources, scene analysis, jobs, storage on images, the GPU material and the 5 nm
reference image."""

from __future__ import annotations

import bpy
from bpy.props import PointerProperty

from . import operators, panels, properties

#: Registered by ``blender.register()`` in this order, before :func:`register` runs.
CLASSES = properties.CLASSES + operators.CLASSES + panels.CLASSES


def register() -> None:
    """Give every material its spectral BRDF settings."""
    bpy.types.Material.spectral = PointerProperty(type=properties.SPECTRAL_PG_material)


def unregister() -> None:
    del bpy.types.Material.spectral
