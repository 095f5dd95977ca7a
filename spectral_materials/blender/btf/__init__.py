"""BTF materials in Blender: the material's BTF settings, operators and panel, fitting what
a material names, storage on image datablocks, and the GPU drawer.

Until the next release, ``spectral_materials.blender.btf.<name>`` also serves the names of
the old ``blender/btf.py`` (now :mod:`.fit`), with a DeprecationWarning."""

from __future__ import annotations

import bpy
from bpy.props import PointerProperty

from ..._moved import forward_to
from . import operators, panels, properties

__getattr__ = forward_to(__name__, "fit")

#: Registered by ``blender.register()`` in this order, before :func:`register` runs.
CLASSES = properties.CLASSES + operators.CLASSES + panels.CLASSES


def register() -> None:
    """Give every material its BTF settings."""
    bpy.types.Material.spectral_btf = PointerProperty(type=properties.SPECTRAL_PG_btf)


def unregister() -> None:
    del bpy.types.Material.spectral_btf
