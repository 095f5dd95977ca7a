"""Spectral Materials: spectral BRDFs as factor packs, rendered in Blender.

``spectral_materials.core`` is pure NumPy/SciPy/colour-science and never imports
``bpy``; ``spectral_materials.blender`` holds the Blender adapters.
"""

__version__ = "0.1.0"
