"""Spectral PRT: spherical harmonics, per-vertex transfer, the spectral environment, albedo
layers, the Monte Carlo reference and occlusion ray casting.

Until the next release, ``spectral_materials.core.prt.<name>`` also serves the names of the
old ``core/prt.py`` (now :mod:`.transfer`), with a DeprecationWarning."""

from ..._moved import forward_to

__getattr__ = forward_to(__name__, "transfer")
