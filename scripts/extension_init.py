"""Spectral Materials as a Blender extension: the package root Blender imports.

scripts/build_extension copies this file to the root ``__init__.py`` of the staged
extension (build/extension/), next to ``spectral_materials/``; the checkout itself has no
root ``__init__.py``. Installed, the extension is ``bl_ext.<repo>.spectral_materials`` and
the project package below it, which imports itself only relatively, follows along.
"""

from .spectral_materials.blender import register, unregister

__all__ = ["register", "unregister"]
