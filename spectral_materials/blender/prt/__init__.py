"""Spectral PRT in Blender: the scene's environment and albedo, the transfer bake, the GPU
drawer and the per-pixel evaluation used by tests and demos.

Until the next release, ``spectral_materials.blender.prt.<name>`` also serves the names of
the old ``blender/prt.py`` (now :mod:`.scene`), with a DeprecationWarning."""

from ..._moved import forward_to

__getattr__ = forward_to(__name__, "scene")
