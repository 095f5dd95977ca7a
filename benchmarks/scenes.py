"""Scenes the benchmarks, the demos and the checks in scripts/ start from."""

from __future__ import annotations


def factory_scene(keep: tuple[str, ...] = ("CAMERA",), *, materials: bool = True):
    """Load Blender's factory start-up file and delete every object whose type is not in
    ``keep`` (the camera, by default; ``keep=()`` deletes them all), and every material
    when ``materials`` is False. Returns the scene."""
    import bpy

    bpy.ops.wm.read_homefile(use_factory_startup=True)
    for obj in list(bpy.data.objects):
        if obj.type not in keep:
            bpy.data.objects.remove(obj)
    if not materials:
        for material in list(bpy.data.materials):
            bpy.data.materials.remove(material)
    return bpy.context.scene
