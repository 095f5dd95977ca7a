"""Rendering with the EEVEE path: the protocol sphere through a material's node group,
and EEVEE's scene-linear radiance back to protocol XYZ.

Everything a render builds lives in a throw-away scene (:class:`_Scratch`) and is
removed afterwards; the file's working colour space is restored.
"""

from __future__ import annotations

import math

import bpy
import numpy as np

from ...core.brdf import prefilter
from ...core.colour import pipeline as colour_pipeline
from .. import compat
from ..brdf import sources, storage
from .apply import apply_eevee, remove_eevee, working_space


def scene_linear_to_xyz(rgb: np.ndarray, adaptation_white: str = "D65",
                        space: str | None = None) -> np.ndarray:
    """Protocol XYZ from EEVEE's scene-linear radiance (the inverse of the group's colour
    step, times π: a white Lambertian facing a unit sun renders 1/π in Blender)."""
    white = colour_pipeline.white_xyz(adaptation_white, sources.WAVELENGTHS)
    inverse = np.linalg.inv(prefilter.scene_linear_matrix(white, space or working_space()))
    return math.pi * np.asarray(rgb, dtype=np.float64) @ inverse.T


#: The protocol renders in Rec.2020: saturated reflectances under spiky lights have
#: negative Rec.709 components, which EEVEE clamps (measured in docs/eevee.md).
PROTOCOL_WORKING_SPACE = "Linear Rec.2020"
#: Segments of the protocol's UV sphere (rings: half): its normals are within ~1e-4 rad
#: of the analytic sphere's.
SPHERE_SEGMENTS = 256


def new_scene(name: str):
    """A new scene with EEVEE's Shadows on, as the startup file's scene has them: Blender
    4.5 makes a new scene with them off, where no light casts a shadow."""
    scene = bpy.data.scenes.new(name)
    scene.eevee.use_shadows = True
    return scene


def black_world(name: str):
    world = bpy.data.worlds.new(name)
    world.color = (0.0, 0.0, 0.0)
    if world.node_tree is not None:
        for node in world.node_tree.nodes:
            if node.type == "BACKGROUND":
                node.inputs["Strength"].default_value = 0.0
    return world


class _Scratch:
    """Datablocks made for one render, removed afterwards (newest first)."""

    def __init__(self):
        self.blocks: list[tuple[str, object]] = []

    def add(self, kind: str, block):
        self.blocks.append((kind, block))
        return block

    def remove_all(self) -> None:
        for kind, block in reversed(self.blocks):
            collection = getattr(bpy.data, kind)
            try:
                if block.name in collection and collection[block.name] == block:
                    collection.remove(block)
            except ReferenceError:     # already freed with its owner
                pass
        self.blocks.clear()


def _add_sphere(scratch: _Scratch, model):
    """A smooth UV sphere without UVs (so the tangent field is the protocol's) with a
    material holding ``model``'s factors; (object, material)."""
    import bmesh

    mesh = scratch.add("meshes", bpy.data.meshes.new("SM EEVEE sphere"))
    bm = bmesh.new()
    bmesh.ops.create_uvsphere(bm, u_segments=SPHERE_SEGMENTS,
                              v_segments=SPHERE_SEGMENTS // 2, radius=1.0, calc_uvs=False)
    bm.to_mesh(mesh)
    bm.free()
    mesh.shade_smooth()
    sphere = scratch.add("objects", bpy.data.objects.new("SM EEVEE sphere", mesh))
    material = scratch.add("materials", bpy.data.materials.new("SM EEVEE sphere"))
    material.spectral.enabled = True
    mesh.materials.append(material)
    storage.store_factored(material, model)
    scratch.add("images", material.spectral.result.image)
    if material.spectral.result.plot is not None:
        scratch.add("images", material.spectral.result.plot)
    return sphere, material


def new_sun(name: str, incidence_deg: float, illuminant: str, azimuth_deg: float = 0.0):
    """A sun object (not linked to a scene) of strength 1 in ``illuminant``, toward
    (sin α cos φ, sin α sin φ, cos α)."""
    from mathutils import Vector

    light_data = bpy.data.lights.new(name, "SUN")
    light_data.energy = 1.0
    light_data.spectral.illuminant = illuminant
    sun = bpy.data.objects.new(name, light_data)
    alpha, phi = math.radians(float(incidence_deg)), math.radians(float(azimuth_deg))
    toward = Vector((math.sin(alpha) * math.cos(phi), math.sin(alpha) * math.sin(phi),
                     math.cos(alpha)))
    sun.rotation_euler = toward.to_track_quat("Z", "Y").to_euler()
    return sun


def _add_sun(scratch: _Scratch, incidence_deg: float, illuminant: str,
             azimuth_deg: float = 0.0, name: str = "SM EEVEE sun"):
    """:func:`new_sun`, removed with ``scratch``."""
    sun = new_sun(name, incidence_deg, illuminant, azimuth_deg)
    scratch.add("lights", sun.data)
    return scratch.add("objects", sun)


def _add_sun_and_camera(scratch: _Scratch, incidence_deg: float, illuminant: str):
    """A sun of strength 1 in ``illuminant`` at ``incidence_deg`` from +z in the xz plane,
    and an orthographic camera down −z framing the unit sphere; (sun, camera)."""
    sun = _add_sun(scratch, incidence_deg, illuminant)
    camera_data = scratch.add("cameras", bpy.data.cameras.new("SM EEVEE camera"))
    camera_data.type = "ORTHO"
    camera_data.ortho_scale = 2.0
    camera = scratch.add("objects", bpy.data.objects.new("SM EEVEE camera", camera_data))
    camera.location = (0.0, 0.0, 5.0)
    return sun, camera


def _render_rgb(scene, size: int, samples: int) -> tuple[np.ndarray, float]:
    """Render ``scene`` with EEVEE (Standard view, no look) to a float EXR; (RGB, seconds)."""
    import tempfile
    import time
    from pathlib import Path

    from ...core.formats.exr import read_exr

    render = scene.render
    render.engine = compat.EEVEE_ENGINE
    render.resolution_x = render.resolution_y = size
    render.resolution_percentage = 100
    render.filter_size = 0.0
    scene.eevee.taa_render_samples = samples
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    render.image_settings.file_format = "OPEN_EXR"
    render.image_settings.color_depth = "32"
    with tempfile.TemporaryDirectory() as folder:
        render.filepath = str(Path(folder) / "sphere.exr")
        start = time.perf_counter()
        bpy.ops.render.render(write_still=True, scene=scene.name)
        seconds = time.perf_counter() - start
        channels, _ = read_exr(Path(folder) / "sphere.exr")
    return np.stack([channels[c] for c in "RGB"], axis=-1), seconds


def render_sphere_eevee(model, incidence_deg: float = 0.0, illuminant: str = "D65",
                        size: int = 256, *, samples: int = 1,
                        extra_suns: tuple = (), spectral_lights: int = 1,
                        shadows: bool = True) -> tuple[np.ndarray, dict]:
    """The protocol sphere rendered by EEVEE through the node group: (XYZ (size, size, 3)
    with row 0 at the bottom, protocol-normalised; facts about the render).

    Everything is built in a throw-away scene (a UV sphere without UVs, so the tangent
    field is the protocol's; an orthographic camera down −z; a sun of strength 1 in
    ``illuminant``, the key light; a black world) and removed afterwards; the file's
    working colour space is Rec.2020 during the render and restored after it.
    ``extra_suns``: more suns of strength 1, (incidence°, azimuth°, illuminant) each, of
    which the node group evaluates ``spectral_lights`` − 1 spectrally. ``shadows``: the
    spectral lights' EEVEE shadows (the add-on's default; on the sphere, its own shadow
    beyond the terminator, where the lit term is 0 anyway).
    """
    from ..gpu.offscreen import check_size

    check_size(size, size)
    scratch = _Scratch()
    previous_space = working_space()
    scene = scratch.add("scenes", new_scene("SM EEVEE sphere"))
    material = None
    try:
        sphere, material = _add_sphere(scratch, model)
        sun, camera = _add_sun_and_camera(scratch, incidence_deg, illuminant)
        extras = [_add_sun(scratch, incidence, extra_illuminant, azimuth,
                           name=f"SM EEVEE sun {i + 2}")
                  for i, (incidence, azimuth, extra_illuminant) in enumerate(extra_suns)]
        for obj in (sphere, sun, camera, *extras):
            scene.collection.objects.link(obj)
        scene.camera = camera
        scene.world = scratch.add("worlds", black_world("SM EEVEE black"))
        # Blender 4.x renders in its one scene-linear space, which scene_linear_to_xyz
        # below then undoes instead of the protocol's.
        space = PROTOCOL_WORKING_SPACE if compat.can_set_working_space() else previous_space
        if previous_space != space:
            bpy.ops.wm.set_working_color_space(working_space=space, convert_colors=False)
        counts = apply_eevee(material, scene, light_object=sun, lights=spectral_lights,
                             shadows=shadows)
        rgb, seconds = _render_rgb(scene, size, samples)
        xyz = scene_linear_to_xyz(rgb, scene.spectral.adaptation_white, space)
        return xyz, {"seconds": seconds, "working_space": space, **counts}
    finally:
        if working_space() != previous_space:
            bpy.ops.wm.set_working_color_space(working_space=previous_space,
                                               convert_colors=False)
        if material is not None:
            remove_eevee(material, scene)
        scratch.remove_all()
