"""Blender adapters (everything that imports ``bpy``); filled in by the extension issue."""
