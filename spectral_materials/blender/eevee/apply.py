"""Applying the EEVEE node group to a material, removing it, and rendering with it.

``apply_eevee(material, scene)`` adds, beside the user's nodes (which are never
changed), a frame holding the group node of ``eevee_nodes.build_group``, an Emission
(the key light, reconstructed spectrally) and a Principled BSDF (a Lambert + GGX fit
of the factors, for the other lights and the world), and links them to the material output. The
output's previous link is remembered on the material, so ``remove_eevee`` restores
the original tree exactly. The key light lights the object through the Emission
only: light linking excludes the material's objects from it (restored on removal).
"""

from __future__ import annotations

import json
import math

import bpy
import numpy as np

from ...core.brdf import prefilter
from ...core.colour import pipeline as colour_pipeline
from .. import compat
from ..brdf import sources, storage
from ..lights import scene_lights
from . import nodes as eevee_nodes

FRAME_NAME = "SM EEVEE"
ORIGINAL_KEY = "sm_eevee_original"
EXCLUSION_PREFIX = "SM EEVEE excluded from "
PREVIOUS_RECEIVERS = "sm_previous_receivers"


class EEVEEError(ValueError):
    """The EEVEE path cannot be applied; the message names the material and the fix."""


def _objects_using(scene, material) -> list:
    return [o for o in scene.objects
            if any(s.material == material for s in getattr(o, "material_slots", []))]


def _irradiances(scene, material) -> list[tuple]:
    """(light object, its SpectralLight, irradiance at the centre of the material's objects)
    for every light the spectral path draws."""
    objects = _objects_using(scene, material)
    if not objects:
        raise EEVEEError(f"Material '{material.name}': no object in scene '{scene.name}' uses it")
    centre = np.mean([np.array(o.matrix_world)[:3, 3] for o in objects], axis=0)
    lights, _ = scene_lights.scene_lights(scene)
    out = []
    for obj in lights:
        if obj.data.type not in scene_lights.DRAWN_TYPES:
            continue
        light = scene_lights.spectral_light(obj)
        out.append((obj, light, float(light.incidence(centre[None])[1][0])))
    return out


def key_light(scene, material):
    """The light object that brings the most irradiance to the material's objects."""
    best, best_e = None, 0.0
    for obj, _, irradiance in _irradiances(scene, material):
        if irradiance > best_e:
            best, best_e = obj, irradiance
    if best is None:
        raise EEVEEError(f"Scene '{scene.name}' has no light reaching '{material.name}': the "
                         "EEVEE path needs a key light (add a sun, point, spot or area light)")
    return best


def _output_node(tree):
    outputs = [n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial"]
    active = [n for n in outputs if n.is_active_output]
    return (active or outputs or [None])[0]


def _check_uniform_block(material, model, group) -> None:
    """Remove the new ``group`` and raise if EEVEE could not link its node constants."""
    needed = eevee_nodes.uniform_bytes(group)
    if needed > eevee_nodes.UNIFORM_BLOCK_LIMIT:
        bpy.data.node_groups.remove(group)
        fits = max(1, int(model.packs * eevee_nodes.UNIFORM_BLOCK_LIMIT / needed))
        raise EEVEEError(
            f"Material '{material.name}': {model.packs} packs need {needed} bytes of node "
            f"constants, over EEVEE's {eevee_nodes.UNIFORM_BLOCK_LIMIT} (it would render "
            f"magenta): factor it with at most {fits} packs"
            + (" or an isotropic (3-axis) parameterisation"
               if len(model.grid.shape) == 4 else ""))


def _add_frame(material, group) -> tuple:
    """Add the frame of the group node, Emission, Principled and Add Shader beside the
    user's nodes and link it to the material output; (output node, its previous link)."""
    compat.ensure_node_tree(material)
    tree = material.node_tree
    output = _output_node(tree)
    if output is None:
        output = tree.nodes.new("ShaderNodeOutputMaterial")
    surface = output.inputs["Surface"]
    original = None
    if surface.is_linked:
        link = surface.links[0]
        original = {"node": link.from_node.name, "socket": link.from_socket.identifier}
    frame = tree.nodes.new("NodeFrame")
    frame.name = frame.label = FRAME_NAME
    x, y = output.location.x, output.location.y - 400
    nodes = {}
    for kind, offset, label in (("ShaderNodeGroup", (-700, 0), "Spectral factors"),
                                ("ShaderNodeEmission", (-450, 60), "Key light (spectral)"),
                                ("ShaderNodeBsdfPrincipled", (-450, -160),
                                 "Other lights (RGB fit)"),
                                ("ShaderNodeAddShader", (-220, 0), "Spectral EEVEE")):
        node = tree.nodes.new(kind)
        node.name = f"{FRAME_NAME} {label}"
        node.label = label
        node.location = (x + offset[0], y + offset[1])
        node.parent = frame
        nodes[kind] = node
    nodes["ShaderNodeGroup"].node_tree = group
    nodes["ShaderNodeEmission"].inputs["Strength"].default_value = 1.0
    links = tree.links
    links.new(nodes["ShaderNodeGroup"].outputs["Key light"], nodes["ShaderNodeEmission"].inputs[0])
    principled = nodes["ShaderNodeBsdfPrincipled"]
    for name in ("Base Color", "Roughness", "IOR"):
        links.new(nodes["ShaderNodeGroup"].outputs[name], principled.inputs[name])
    links.new(nodes["ShaderNodeEmission"].outputs[0], nodes["ShaderNodeAddShader"].inputs[0])
    links.new(principled.outputs[0], nodes["ShaderNodeAddShader"].inputs[1])
    links.new(nodes["ShaderNodeAddShader"].outputs[0], surface)
    return output, original


def apply_eevee(material, scene, *, light_object=None, measure: bool = False) -> dict:
    """Add the EEVEE reconstruction to ``material``; returns node and sampler counts.

    ``measure`` also computes the key-light term's ΔE94 against the 5 nm reference
    (``core.prefilter.key_light_error``; a fraction of a second), kept with the record.
    """
    if material.spectral.result.image is None:
        raise EEVEEError(f"Material '{material.name}' has no stored factors: factor it first")
    model = storage.load_factored(material)
    light_object = light_object or key_light(scene, material)
    light = scene_lights.spectral_light(light_object)
    white = colour_pipeline.white_xyz(scene.spectral.adaptation_white, sources.WAVELENGTHS)
    to_rgb = prefilter.scene_linear_matrix(white, working_space())
    weights = prefilter.key_light_rgb_weights(model, light, to_rgb)
    # The Principled BSDF is what the other lights see: fitted under their spectrum.
    fill = prefilter.fill_light([(other, irradiance) for obj, other, irradiance
                                 in _irradiances(scene, material) if obj != light_object],
                                sources.WAVELENGTHS)
    fit = prefilter.fit_principled(model, fill or light, to_rgb)
    objects = _objects_using(scene, material)
    use_uv = any(o.type == "MESH" and o.data.uv_layers.active is not None for o in objects)
    image = material.spectral.result.image
    image.alpha_mode = "CHANNEL_PACKED"        # the 4th term must not divide the other 3
    key = eevee_nodes.KeyLight(light_object.name, light_object.data.type, weights, fit,
                               prefilter.key_light_lobe_rgb_weights(model, light, to_rgb))
    # Built under a scratch name and checked before anything of the material changes.
    scratch_name = eevee_nodes.group_name(material) + " (building)"
    group = eevee_nodes.build_group(material, model, image, key, use_uv_tangent=use_uv,
                                    name=scratch_name)
    _check_uniform_block(material, model, group)
    remove_eevee(material, scene)                # re-applying replaces the previous nodes
    group.name = eevee_nodes.group_name(material)
    output, original = _add_frame(material, group)
    previous_receivers = _exclude_from_light(light_object, objects)
    sync_light_colours(scene, to_rgb)
    counts = eevee_nodes.node_count(group)
    counts["fit"] = {"base_color": [float(v) for v in fit["base_color"]],
                     "roughness": fit["roughness"], "specular": fit["specular"],
                     "relative_rms": fit["relative_rms"]}
    if measure:
        brdf = sources.material_inputs(material).brdf()
        counts["de94"] = prefilter.key_light_error(brdf, model, light, to_rgb)
    material[ORIGINAL_KEY] = json.dumps({
        "output": output.name, "link": original, "light": light_object.name,
        "receivers": previous_receivers, "working_space": working_space(), **counts})
    material.update_tag()
    return counts


def applied(material) -> dict | None:
    """The record of an applied EEVEE path (key light, counts, ΔE94), or None."""
    record = material.get(ORIGINAL_KEY)
    return json.loads(record) if record is not None else None


def refresh(material, scene) -> str:
    """Rebuild an applied EEVEE path after the factors changed; '' or why it was removed."""
    record = applied(material)
    if record is None:
        return ""
    light = bpy.data.objects.get(record.get("light", ""))
    try:
        apply_eevee(material, scene, light_object=light, measure="de94" in record)
    except ValueError as exc:
        remove_eevee(material, scene)
        return f"EEVEE path of '{material.name}' removed: {exc}"
    return ""


def sync_light_colours(scene, to_rgb: np.ndarray) -> None:
    """Give every light reaching the scene the RGB colour of its spectral SPD.

    EEVEE (and Cycles) know a light only by its RGB colour; the spectral path by its
    SPD. With the SPD's colour (normalised to luminance 1, ``prefilter.light_rgb``),
    what EEVEE shades in RGB — the fitted Principled BSDF under the other lights —
    sees the light the spectral path sees.
    """
    objects, _ = scene_lights.scene_lights(scene)
    for obj in objects:
        if obj.data.type in scene_lights.DRAWN_TYPES:
            rgb = prefilter.light_rgb(scene_lights.spectral_light(obj), to_rgb)
            obj.data.color = tuple(float(v) for v in np.clip(rgb, 0.0, None))


def _exclude_from_light(light_object, objects) -> str | None:
    """Light linking: ``light_object`` no longer lights ``objects``; returns the previous
    receiver collection's name (None if it had none)."""
    linking = light_object.light_linking
    previous = linking.receiver_collection.name if linking.receiver_collection else None
    name = EXCLUSION_PREFIX + light_object.name
    collection = bpy.data.collections.get(name)
    if collection is None:
        collection = bpy.data.collections.new(name)
        # The user's own receiver collection, restored when the last material lets go.
        collection[PREVIOUS_RECEIVERS] = previous or ""
    if previous is not None and previous != name:
        for obj in bpy.data.collections[previous].all_objects:
            if obj.name not in collection.objects:
                collection.objects.link(obj)
    for obj in objects:
        if obj.name not in collection.objects:
            collection.objects.link(obj)
    # collection_objects lists the entries in the order of collection.objects.
    for obj, entry in zip(collection.objects, collection.collection_objects):
        if obj in objects:
            entry.light_linking.link_state = "EXCLUDE"
    linking.receiver_collection = collection
    return previous if previous != name else None


def remove_eevee(material, scene=None) -> bool:
    """Remove the EEVEE nodes and restore the original link and light linking."""
    record = material.get(ORIGINAL_KEY)
    tree = material.node_tree
    removed = False
    if tree is not None:
        for node in [n for n in tree.nodes if n.name.startswith(FRAME_NAME)]:
            tree.nodes.remove(node)
            removed = True
    if record is not None:
        info = json.loads(record)
        output = tree.nodes.get(info["output"]) if tree is not None else None
        link = info.get("link")
        if output is not None and link is not None and link["node"] in tree.nodes:
            source = tree.nodes[link["node"]]
            socket = next(s for s in source.outputs if s.identifier == link["socket"])
            tree.links.new(socket, output.inputs["Surface"])
        light = bpy.data.objects.get(info.get("light", ""))
        if light is not None:
            _include_again(light, material)
        del material[ORIGINAL_KEY]
        removed = True
    group = bpy.data.node_groups.get(eevee_nodes.group_name(material))
    if group is not None:
        bpy.data.node_groups.remove(group)
    material.update_tag()
    return removed


def working_space() -> str:
    """The file's scene-linear working colour space (Blender 5.0: Rec.709, Rec.2020, ACEScg;
    4.x: always Rec.709)."""
    return compat.working_space()


def _include_again(light, material) -> None:
    """Undo ``_exclude_from_light`` for this material's objects; once no applied material
    needs the exclusion collection, restore the light's previous receiver collection."""
    collection = bpy.data.collections.get(EXCLUSION_PREFIX + light.name)
    if collection is None:
        return
    still_needed = set()
    for other in bpy.data.materials:
        record = applied(other) if other != material else None
        if record is not None and record.get("light") == light.name:
            still_needed |= {o.name for o in bpy.data.objects
                             if any(s.material == other for s in o.material_slots)}
    for obj in list(collection.objects):
        uses = any(s.material == material for s in obj.material_slots)
        if uses and obj.name not in still_needed:
            collection.objects.unlink(obj)
    if not still_needed:
        previous = collection.get(PREVIOUS_RECEIVERS, "")
        light.light_linking.receiver_collection = \
            bpy.data.collections.get(previous) if previous else None
        bpy.data.collections.remove(collection)


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


def _add_sun_and_camera(scratch: _Scratch, incidence_deg: float, illuminant: str):
    """A sun of strength 1 in ``illuminant`` at ``incidence_deg`` from +z in the xz plane,
    and an orthographic camera down −z framing the unit sphere; (sun, camera)."""
    from mathutils import Vector

    light_data = scratch.add("lights", bpy.data.lights.new("SM EEVEE sun", "SUN"))
    light_data.energy = 1.0
    light_data.spectral.illuminant = illuminant
    sun = scratch.add("objects", bpy.data.objects.new("SM EEVEE sun", light_data))
    alpha = math.radians(float(incidence_deg))
    sun.rotation_euler = Vector((math.sin(alpha), 0.0, math.cos(alpha))).to_track_quat(
        "Z", "Y").to_euler()
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
                        size: int = 256, *, samples: int = 1) -> tuple[np.ndarray, dict]:
    """The protocol sphere rendered by EEVEE through the node group: (XYZ (size, size, 3)
    with row 0 at the bottom, protocol-normalised; facts about the render).

    Everything is built in a throw-away scene (a UV sphere without UVs, so the tangent
    field is the protocol's; an orthographic camera down −z; a sun of strength 1 in
    ``illuminant``; a black world) and removed afterwards; the file's working colour
    space is Rec.2020 during the render and restored after it.
    """
    from ..gpu.offscreen import check_size

    check_size(size, size)
    scratch = _Scratch()
    previous_space = working_space()
    scene = scratch.add("scenes", bpy.data.scenes.new("SM EEVEE sphere"))
    material = None
    try:
        sphere, material = _add_sphere(scratch, model)
        sun, camera = _add_sun_and_camera(scratch, incidence_deg, illuminant)
        for obj in (sphere, sun, camera):
            scene.collection.objects.link(obj)
        scene.camera = camera
        scene.world = scratch.add("worlds", black_world("SM EEVEE black"))
        # Blender 4.x renders in its one scene-linear space, which scene_linear_to_xyz
        # below then undoes instead of the protocol's.
        space = PROTOCOL_WORKING_SPACE if compat.can_set_working_space() else previous_space
        if previous_space != space:
            bpy.ops.wm.set_working_color_space(working_space=space, convert_colors=False)
        counts = apply_eevee(material, scene, light_object=sun)
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
