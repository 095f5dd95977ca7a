"""The EEVEE approximation: the node group that rebuilds a material's factor packs for its
key light, applying and removing it, and EEVEE renders.

Until the next release, ``spectral_materials.blender.eevee.<name>`` also serves the names of
the old ``blender/eevee.py`` (now :mod:`.apply`), with a DeprecationWarning."""

from ..._moved import forward_to

__getattr__ = forward_to(__name__, "apply")
