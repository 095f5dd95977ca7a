"""Applying the EEVEE node group to a material, removing it, and rendering with it.

``apply_eevee(material, scene, lights=N)`` adds, beside the user's nodes (which are never
changed), a frame holding the group node of ``eevee_nodes.build_group``, an Emission
(the N spectral lights — the key light and the next brightest — reconstructed
spectrally) and a Principled BSDF (a Lambert + GGX fit of the factors, for the other
lights and the world), and links them to the material output. The output's previous
link is remembered on the material, so ``remove_eevee`` restores the original tree
exactly. The spectral lights light the object through the Emission only: light linking
excludes the material's objects from them (restored on removal); their shadows on it
are read through twin lights (``shadow_twins.py``, ``shadow_nodes.py``).
"""

from __future__ import annotations

import json

import bpy
import numpy as np

from ..._moved import forward_names
from ...core.brdf import prefilter
from ...core.colour import pipeline as colour_pipeline
from .. import compat
from ..brdf import sources, storage
from ..lights import scene_lights
from . import nodes as eevee_nodes, shadow_nodes, shadow_twins

# Served from here for one release: they moved to .render with the rendering helpers.
__getattr__ = forward_names(__name__, dict.fromkeys(
    ("render_sphere_eevee", "scene_linear_to_xyz", "black_world", "PROTOCOL_WORKING_SPACE",
     "SPHERE_SEGMENTS"), "blender.eevee.render"))

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


MAX_SPECTRAL_LIGHTS = eevee_nodes.MAX_SPECTRAL_LIGHTS


def spectral_lights(scene, material, count: int = 1, key=None,
                    irradiances: list | None = None) -> list:
    """The light objects the node group evaluates spectrally: ``key`` (default: the
    brightest at the material's objects), then the next brightest, ``count`` in all
    (fewer if fewer lights reach the material). ``irradiances``: :func:`_irradiances`
    when the caller has it already."""
    if not 1 <= int(count) <= MAX_SPECTRAL_LIGHTS:
        raise EEVEEError(f"Material '{material.name}': spectral lights must be 1 to "
                         f"{MAX_SPECTRAL_LIGHTS}, got {count}")
    if irradiances is None:
        irradiances = _irradiances(scene, material)
    key = key or _brightest(scene, material, irradiances)
    others = sorted(((irradiance, obj.name, obj) for obj, _, irradiance in irradiances
                     if obj != key and irradiance > 0), key=lambda item: (-item[0], item[1]))
    return [key] + [obj for _, _, obj in others[: int(count) - 1]]


def key_light(scene, material):
    """The light object that brings the most irradiance to the material's objects."""
    return _brightest(scene, material, _irradiances(scene, material))


def _brightest(scene, material, irradiances: list):
    best, best_e = None, 0.0
    for obj, _, irradiance in irradiances:
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


def _check_uniform_block(material, model, group, lights: int = 1) -> None:
    """Remove the new ``group`` and raise if EEVEE could not link its node constants."""
    needed = eevee_nodes.uniform_bytes(group)
    if needed > eevee_nodes.UNIFORM_BLOCK_LIMIT:
        bpy.data.node_groups.remove(group)
        fits = max(1, int(model.packs * eevee_nodes.UNIFORM_BLOCK_LIMIT / needed))
        raise EEVEEError(
            f"Material '{material.name}': {model.packs} packs"
            + (f" for {lights} spectral lights" if lights > 1 else "")
            + f" need {needed} bytes of node constants, over EEVEE's "
            f"{eevee_nodes.UNIFORM_BLOCK_LIMIT} (it would render magenta): factor it with at "
            f"most {fits} packs"
            + (" or fewer spectral lights" if lights > 1 else "")
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
    original = _recorded_link(surface)
    frame = tree.nodes.new("NodeFrame")
    frame.name = frame.label = FRAME_NAME
    x, y = output.location.x, output.location.y - 400
    nodes = {}
    for kind, offset, label in (("ShaderNodeGroup", (-700, 0), "Spectral factors"),
                                ("ShaderNodeEmission", (-450, 60), "Spectral lights"),
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
    links.new(nodes["ShaderNodeGroup"].outputs["Spectral lights"],
              nodes["ShaderNodeEmission"].inputs[0])
    principled = nodes["ShaderNodeBsdfPrincipled"]
    for name in ("Base Color", "Roughness", "IOR"):
        links.new(nodes["ShaderNodeGroup"].outputs[name], principled.inputs[name])
    links.new(nodes["ShaderNodeEmission"].outputs[0], nodes["ShaderNodeAddShader"].inputs[0])
    links.new(principled.outputs[0], nodes["ShaderNodeAddShader"].inputs[1])
    links.new(nodes["ShaderNodeAddShader"].outputs[0], surface)
    return output, original


def apply_eevee(material, scene, *, light_object=None, lights: int = MAX_SPECTRAL_LIGHTS,
                measure: bool = False, shadows: bool = True) -> dict:
    """Add the EEVEE reconstruction to ``material``; returns node and sampler counts.

    ``lights``: at most how many lights are evaluated spectrally (:func:`spectral_lights`,
    the key light ``light_object`` or the brightest first); fewer where the node group
    would not fit EEVEE's node constants (``counts["lights_left_to_rgb"]`` names them).
    ``shadows``: their radiance on the material keeps EEVEE's own shadows, read through
    twin lights (:mod:`.shadow_twins`, :mod:`.shadow_nodes`; ``counts["shadows"]`` says
    whether it did); without, they cast none on it. The other
    lights keep EEVEE's shadows. ``measure``
    also computes the key-light term's ΔE94 against the 5 nm reference
    (``core.prefilter.key_light_error``; a fraction of a second), kept with the record.
    """
    if material.spectral.result.image is None:
        raise EEVEEError(f"Material '{material.name}' has no stored factors: factor it first")
    model = storage.load_factored(material)
    shadows = bool(shadows)
    irradiances = _irradiances(scene, material)
    chosen = spectral_lights(scene, material, lights, light_object, irradiances)
    spectral = {obj.name: light for obj, light, _ in irradiances}
    for obj in chosen:              # a key light passed in need not be one drawn here
        spectral.setdefault(obj.name, scene_lights.spectral_light(obj))
    white = colour_pipeline.white_xyz(scene.spectral.adaptation_white, sources.WAVELENGTHS)
    to_rgb = prefilter.scene_linear_matrix(white, working_space())
    objects = _objects_using(scene, material)
    image = material.spectral.result.image
    image.alpha_mode = "CHANNEL_PACKED"        # the 4th term must not divide the other 3
    build = _Build(material, model, image, spectral, irradiances, to_rgb,
                   use_uv=any(o.type == "MESH" and o.data.uv_layers.active is not None
                              for o in objects), shadows=shadows)
    group, fill, fit, used = build.fitting(chosen)
    remove_eevee(material, scene)                # re-applying replaces the previous nodes
    group.name = eevee_nodes.group_name(material)
    output, original = _add_frame(material, group)
    thickness = (_thin_probes(material, output) if shadows and shadow_nodes.thin_probes()
                 else None)
    previous_receivers = {obj.name: _exclude_from_light(obj, objects) for obj in used}
    sync_light_colours(scene, to_rgb)
    counts = eevee_nodes.node_count(group)
    counts["lights"] = [obj.name for obj in used]
    counts["lights_left_to_rgb"] = [obj.name for obj in chosen[len(used):]]
    counts["shadows"] = shadows
    counts["fit"] = {"base_color": [float(v) for v in fit["base_color"]],
                     "roughness": fit["roughness"], "specular": fit["specular"],
                     "relative_rms": fit["relative_rms"],
                     "under": "other lights" if fill is not None else "key light"}
    light = spectral[used[0].name]
    if measure:
        brdf = sources.material_inputs(material).brdf()
        counts["de94"] = prefilter.key_light_error(brdf, model, light, to_rgb)
    material[ORIGINAL_KEY] = json.dumps({
        "output": output.name, "link": original, "light": used[0].name,
        "receivers": previous_receivers, "shadows": bool(shadows), "thickness": thickness,
        "working_space": working_space(), **counts})
    if shadows:
        _make_twins(material, scene, used, objects)
    material.update_tag()
    return counts


class _Build:
    """The node group of one application, for a given set of spectral lights."""

    def __init__(self, material, model, image, spectral: dict, irradiances: list,
                 to_rgb: np.ndarray, use_uv: bool, shadows: bool):
        self.material, self.model, self.image = material, model, image
        self.spectral, self.irradiances, self.to_rgb = spectral, irradiances, to_rgb
        self.use_uv, self.shadows = use_uv, shadows

    def group(self, chosen: list) -> tuple:
        """(group under a scratch name, fill light, Principled fit) for ``chosen``."""
        # The Principled BSDF is what the other lights see: fitted under their spectrum.
        fill = prefilter.fill_light([(other, irradiance) for obj, other, irradiance
                                     in self.irradiances if obj not in chosen],
                                    sources.WAVELENGTHS)
        fit = prefilter.fit_principled(self.model, fill or self.spectral[chosen[0].name],
                                       self.to_rgb)
        keys = [eevee_nodes.KeyLight(
            obj.name, obj.data.type,
            prefilter.key_light_rgb_weights(self.model, self.spectral[obj.name], self.to_rgb),
            prefilter.key_light_lobe_rgb_weights(self.model, self.spectral[obj.name],
                                                 self.to_rgb))
            for obj in chosen]
        # Built under a scratch name and checked before anything of the material changes.
        group = eevee_nodes.build_group(self.material, self.model, self.image, keys, fit,
                                        use_uv_tangent=self.use_uv, shadows=self.shadows,
                                        to_rgb=self.to_rgb,
                                        name=eevee_nodes.group_name(self.material)
                                        + " (building)")
        return group, fill, fit

    def fitting(self, chosen: list) -> tuple:
        """The group of the most of ``chosen`` (in order) that fits EEVEE's node constants:
        (group, fill, fit, lights used); EEVEEError when not even the key light fits."""
        for count in range(len(chosen), 0, -1):
            group, fill, fit = self.group(chosen[:count])
            if count == 1 or eevee_nodes.uniform_bytes(group) <= \
                    eevee_nodes.UNIFORM_BLOCK_LIMIT:
                break
            bpy.data.node_groups.remove(group)
        _check_uniform_block(self.material, self.model, group, count)
        return group, fill, fit, chosen[:count]


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
        apply_eevee(material, scene, light_object=light,
                    lights=scene.spectral.eevee_spectral_lights, measure="de94" in record,
                    shadows=scene.spectral.eevee_spectral_shadows)
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
        for socket_name, key in (("Surface", "link"), ("Thickness", "thickness")):
            _relink(tree, output, socket_name, info.get(key))
        for name in _record_lights(info):
            light = bpy.data.objects.get(name)
            if light is not None:
                _include_again(light, material)
                if info.get("shadows"):
                    shadow_twins.release_twins(light, _objects_needing(light, material,
                                                                       "shadows"))
        shadow_twins.sweep_twins()
        del material[ORIGINAL_KEY]
        removed = True
    group = bpy.data.node_groups.get(eevee_nodes.group_name(material))
    if group is not None:
        bpy.data.node_groups.remove(group)
    material.update_tag()
    return removed


def _make_twins(material, scene, lights: list, objects: list) -> None:
    """The spectral lights' shadow twins (:mod:`.shadow_twins`); where Blender refuses
    one (a light in a linked library's collection), the material is restored and the
    error names the way out."""
    try:
        for obj in lights:
            shadow_twins.ensure_twins(obj, objects, scene)
    except (RuntimeError, TypeError, ValueError) as exc:
        remove_eevee(material, scene)
        raise EEVEEError(f"Material '{material.name}': the shadow twins of its spectral "
                         f"lights could not be made ({exc}); apply it with Shadows of "
                         "spectral lights off") from exc


def _recorded_link(socket) -> dict | None:
    """The node socket linked into ``socket``, as a record names it (:func:`_relink`)."""
    if not socket.is_linked:
        return None
    link = socket.links[0]
    return {"node": link.from_node.name, "socket": link.from_socket.identifier}


def _relink(tree, output, socket_name: str, link: dict | None) -> None:
    """Link the output's ``socket_name`` back to the node socket a record names."""
    if output is None or not link or link["node"] not in tree.nodes:
        return
    source = tree.nodes[link["node"]]
    socket = next(s for s in source.outputs if s.identifier == link["socket"])
    tree.links.new(socket, output.inputs[socket_name])


def _thin_probes(material, output) -> dict | None:
    """The output's thickness 0, so that the shadow probes are thin sheets
    (:mod:`.shadow_nodes`; it changes nothing the frame's opaque Principled BSDF shades).
    Returns the thickness's previous link, to restore on removal."""
    socket = output.inputs["Thickness"]
    previous = _recorded_link(socket)
    tree = material.node_tree
    zero = tree.nodes.new("ShaderNodeValue")
    zero.name = zero.label = f"{FRAME_NAME} thin shadow probes"
    zero.outputs[0].default_value = 0.0
    zero.parent = tree.nodes[FRAME_NAME]
    zero.location = (output.location.x - 220, output.location.y - 600)
    tree.links.new(zero.outputs[0], socket)
    return previous


def _objects_needing(light, material, flag: str | None = None) -> set[str]:
    """Objects of the other applied materials (with ``flag`` in their record) whose
    spectral lights include ``light``."""
    needed = set()
    for other in bpy.data.materials:
        record = applied(other) if other != material else None
        if record is not None and light.name in _record_lights(record) and \
                (flag is None or record.get(flag)):
            needed |= {o.name for o in bpy.data.objects
                       if any(s.material == other for s in o.material_slots)}
    return needed


def _record_lights(record: dict) -> list[str]:
    """The spectral lights an applied record names (records before several lights name
    only ``light``)."""
    return list(record.get("lights") or [record.get("light", "")])


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
    still_needed = _objects_needing(light, material)
    for obj in list(collection.objects):
        uses = any(s.material == material for s in obj.material_slots)
        if uses and obj.name not in still_needed:
            collection.objects.unlink(obj)
    if not still_needed:
        previous = collection.get(PREVIOUS_RECEIVERS, "")
        light.light_linking.receiver_collection = \
            bpy.data.collections.get(previous) if previous else None
        bpy.data.collections.remove(collection)
