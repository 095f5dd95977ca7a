"""The demo scene: spheres and a Suzanne with ColorChecker materials, a D65 sun and an FL2
point light, a hidden cube and an unused material that the analysis must leave out."""

from __future__ import annotations

import bpy

from benchmarks.scenes import factory_scene
from spectral_materials.blender.eevee import render as eevee_render

from .sizes import DemoSizes

# name: (model, scalar parameters, diffuse patch, specular constant, packs)
MATERIALS = {
    "Red clay": ("OREN_NAYAR", {"sigma": 0.52}, "15", None, 2),
    "Blue felt": ("OREN_NAYAR", {"sigma": 0.3}, "13", None, 2),
    "Orange gloss": ("ASHIKHMIN_SHIRLEY", {"nu": 32.0, "nv": 32.0}, "12", 0.05, 8),
    "Teal brushed": ("ASHIKHMIN_SHIRLEY", {"nu": 8.0, "nv": 64.0}, "6", 0.05, 16),
}


def build_scene(sizes: DemoSizes) -> None:
    """Spheres and a Suzanne with ColorChecker materials, a D65 sun and an FL2 point light."""
    factory_scene(keep=(), materials=False)
    placements = {"Red clay": (-3.0, 0.0, 1.0), "Blue felt": (-1.0, 0.0, 1.0),
                  "Orange gloss": (1.0, 0.0, 1.0), "Teal brushed": (3.2, 0.0, 1.0)}
    for name, (model, scalars, patch, specular, packs) in MATERIALS.items():
        if name == "Teal brushed":
            bpy.ops.mesh.primitive_monkey_add(location=placements[name])
        else:
            bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24,
                                                 location=placements[name], radius=0.9)
        bpy.ops.object.shade_smooth()
        obj = bpy.context.active_object
        obj.name = name.split()[1].capitalize() if name != "Teal brushed" else "Suzanne"
        if sizes.max_packs is not None:
            packs = min(packs, sizes.max_packs)
        obj.data.materials.append(_material(name, model, scalars, patch, specular, packs,
                                            sizes.theta_cells))
    # Left out on purpose: a hidden object and a material nobody uses.
    bpy.ops.mesh.primitive_cube_add(location=(0.0, 3.0, 1.0))
    spare = bpy.context.active_object
    spare.name = "Spare cube"
    spare.data.materials.append(_material("Spare", "LAMBERT", {}, "2", None, 1,
                                         sizes.theta_cells))
    spare.hide_render = True
    spare.hide_set(True)
    _material("Unused swatch", "LAMBERT", {}, "7", None, 1, sizes.theta_cells)
    bpy.ops.mesh.primitive_plane_add(size=20.0)
    sun = bpy.data.lights.new("Sun D65", "SUN")
    sun.energy = 3.0
    sun.spectral.illuminant = "D65"
    sun_obj = bpy.data.objects.new("Sun D65", sun)
    sun_obj.rotation_euler = (0.7, 0.2, 0.5)
    shop = bpy.data.lights.new("Shop FL2", "POINT")
    shop.energy = 500.0
    shop.spectral.illuminant = "FL2"
    shop_obj = bpy.data.objects.new("Shop FL2", shop)
    shop_obj.location = (2.0, -3.0, 4.0)
    for obj in (sun_obj, shop_obj):
        bpy.context.scene.collection.objects.link(obj)
    # Only the two lights: the reference, the draw handler and EEVEE then see the same light.
    bpy.context.scene.world = eevee_render.black_world("Black")
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location = (0.0, -11.0, 3.5)
    camera.rotation_euler = (1.33, 0.0, 0.0)
    bpy.context.scene.collection.objects.link(camera)
    bpy.context.scene.camera = camera


def _material(name, model, scalars, patch, specular, packs, theta_cells):
    material = bpy.data.materials.new(name)
    s = material.spectral
    s.enabled = True
    s.model = model
    for key, value in scalars.items():
        setattr(s, key, value)
    s.diffuse.kind = "COLORCHECKER"
    s.diffuse.patch = patch
    if specular is not None:
        s.specular.kind = "CONSTANT"
        s.specular.constant = specular
    s.packs = packs
    s.theta_cells = theta_cells
    return material

