"""Scene builders and a state snapshot shared by the bpy tests."""

from __future__ import annotations

import bpy


def spectral_material(name: str = "Paint", *, model: str = "OREN_NAYAR", patch: str = "9",
                      theta_cells: int = 8, packs: int = 2, obj=None):
    """A spectral material on ``obj`` (default: the start-up cube), made active."""
    material = bpy.data.materials.new(name)
    s = material.spectral
    s.enabled = True
    s.model = model
    s.diffuse.kind = "COLORCHECKER"
    s.diffuse.patch = patch
    s.theta_cells = theta_cells
    s.packs = packs
    obj = obj or bpy.data.objects["Cube"]
    obj.data.materials.append(material)
    obj.active_material_index = len(obj.data.materials) - 1
    bpy.context.view_layer.objects.active = obj
    return material


def cube_material(model, name: str = "Paint", *, node_tree: bool = False):
    """The start-up cube's only slot gets a material with ``model`` stored as its factors
    (with a Principled BSDF tree where ``node_tree``)."""
    from spectral_materials.blender import compat
    from spectral_materials.blender.brdf import storage

    material = bpy.data.materials.new(name)
    if node_tree:
        compat.ensure_node_tree(material)
    material.spectral.enabled = True
    mesh = bpy.data.objects["Cube"].data
    mesh.materials.clear()
    mesh.materials.append(material)
    storage.store_factored(material, model)
    return material


def add_sphere(name: str, location=(0.0, 0.0, 0.0)):
    bpy.ops.mesh.primitive_uv_sphere_add(segments=16, ring_count=8, location=location)
    obj = bpy.context.active_object
    obj.name = name
    return obj


def snapshot(scene) -> dict:
    """What a failed job must leave unchanged: datablocks and every spectral property."""
    def group(g):
        out = {}
        for prop in g.bl_rna.properties:
            if prop.identifier == "rna_type":
                continue
            value = getattr(g, prop.identifier)
            if isinstance(value, bpy.types.PropertyGroup):
                value = group(value)
            elif isinstance(value, bpy.types.ID):
                value = value.name
            elif prop.type in {"FLOAT", "INT", "BOOLEAN"} and getattr(prop, "is_array", False):
                value = list(value)
            if isinstance(value, float) and value != value:
                value = "nan"
            out[prop.identifier] = value
        registered = {p.identifier for p in g.bl_rna.properties}
        out["_id_props"] = {k: list(g[k]) if hasattr(g[k], "__len__") else g[k]
                            for k in g.keys() if k not in registered}
        return out

    return {
        "images": sorted(i.name for i in bpy.data.images),
        "materials": {m.name: group(m.spectral) for m in bpy.data.materials},
        "scene": group(scene.spectral),
        "lights": {light.name: group(light.spectral) for light in bpy.data.lights},
    }


def ledge_mesh(subdivisions: int = 12):
    """Everything but the camera removed, then a floor grid with a box standing on it,
    joined into one mesh (the box shadows the floor), UV mapped; made active."""
    for obj in list(bpy.data.objects):
        if obj.type != "CAMERA":
            bpy.data.objects.remove(obj)
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=subdivisions, y_subdivisions=subdivisions,
                                    size=4.0)
    floor = bpy.context.active_object
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0.3, 0.2, 0.55))
    box = bpy.context.active_object
    bpy.ops.object.select_all(action="DESELECT")
    floor.select_set(True)
    box.select_set(True)
    bpy.context.view_layer.objects.active = floor
    bpy.ops.object.join()
    return bpy.context.active_object
