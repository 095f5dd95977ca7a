"""BTF materials in Blender: fitting what a material names, storage on image datablocks,
and the GPU drawer.

Until the next release, ``spectral_materials.blender.btf.<name>`` also serves the names of
the old ``blender/btf.py`` (now :mod:`.fit`), with a DeprecationWarning."""

from ..._moved import forward_to

__getattr__ = forward_to(__name__, "fit")
