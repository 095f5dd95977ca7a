"""Spectral lights in Blender: what the shaders see of the scene's lights, and SPD plots."""
