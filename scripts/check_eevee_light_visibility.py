#!/usr/bin/env python3
"""Whether an EEVEE node tree can see one light's shadow apart from the others'.

The EEVEE path's spectral lights reach their material as an Emission, which EEVEE does
not shadow (docs/eevee.md). To keep EEVEE's own shadow for such a light, a node tree
needs that light's visibility alone, and the one handle EEVEE gives per light and
closure is the light's diffuse, specular, transmission and volume factors. This script
asks which closure that an opaque Principled BSDF does not use is lit by a *probe* light
that lights nothing else: a light-linked twin of strength 1000, red, with its diffuse,
specular and volume factors 0 and transmission 1, beside an ordinary white sun. A plane
with one closure through Shader to RGB is rendered at 64²; the table gives the red and
green of a pixel outside any shadow. Where red is green, the probe reached nothing.

The Refraction BSDF rows are the probe ``blender/eevee/shadow_nodes.py`` builds on: IOR
1.5, roughness 0.5, its normal −N (the probe's lobe then faces the lights above the
plane); "thin" sets the material output's thickness to 0.

Run with a ``bpy`` Python (``VK_ICD_FILENAMES=/nonexistent.json`` for OpenGL)::

    .venvs/5.0/bin/python scripts/check_eevee_light_visibility.py
"""

from __future__ import annotations

import math
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

#: (label, closure node, sign of its normal (−2: the shadow path's probe, −3: the same,
#: thin), the probe light's diffuse factor).
CLOSURES = (("Diffuse BSDF", "ShaderNodeBsdfDiffuse", +1, 0.0),
            ("Diffuse BSDF, probe's diffuse factor 1", "ShaderNodeBsdfDiffuse", +1, 1.0),
            ("Translucent BSDF, normal −N", "ShaderNodeBsdfTranslucent", -1, 0.0),
            ("Translucent BSDF, normal +N", "ShaderNodeBsdfTranslucent", +1, 0.0),
            ("Translucent BSDF, probe's diffuse factor 1", "ShaderNodeBsdfTranslucent", -1, 1.0),
            ("Refraction BSDF (IOR 1, roughness 1)", "ShaderNodeBsdfRefraction", +1, 0.0),
            ("Refraction BSDF (IOR 1.5, roughness 0.5), normal −N", "ShaderNodeBsdfRefraction",
             -2, 0.0),
            ("Refraction BSDF (IOR 1.5, roughness 0.5), normal −N, thin",
             "ShaderNodeBsdfRefraction", -3, 0.0))


def _probe_material(bpy, kind: str, sign: int):
    from spectral_materials.blender import compat

    material = bpy.data.materials.new("probe")
    compat.ensure_node_tree(material)
    tree = material.node_tree
    tree.nodes.clear()
    closure = tree.nodes.new(kind)
    if kind == "ShaderNodeBsdfRefraction":
        closure.inputs["IOR"].default_value = 1.0 if abs(sign) == 1 else 1.5
        closure.inputs["Roughness"].default_value = 1.0 if abs(sign) == 1 else 0.5
    if kind != "ShaderNodeBsdfDiffuse":
        normal = tree.nodes.new("ShaderNodeVectorMath")
        normal.operation = "SCALE"
        normal.inputs["Scale"].default_value = 1.0 if sign > 0 else -1.0
        tree.links.new(tree.nodes.new("ShaderNodeNewGeometry").outputs["Normal"],
                       normal.inputs[0])
        tree.links.new(normal.outputs[0], closure.inputs["Normal"])
    to_rgb = tree.nodes.new("ShaderNodeShaderToRGB")
    emission = tree.nodes.new("ShaderNodeEmission")
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    tree.links.new(closure.outputs[0], to_rgb.inputs[0])
    tree.links.new(to_rgb.outputs[0], emission.inputs[0])
    tree.links.new(emission.outputs[0], output.inputs["Surface"])
    if sign == -3:
        thickness = tree.nodes.new("ShaderNodeValue")
        thickness.outputs[0].default_value = 0.0
        tree.links.new(thickness.outputs[0], output.inputs["Thickness"])
    return material


def _render(bpy, kind: str, sign: int, diffuse_factor: float) -> tuple[float, float]:
    import numpy as np

    from spectral_materials.blender import compat
    from spectral_materials.blender.eevee.render import black_world
    from spectral_materials.core.formats.exr import read_exr

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_plane_add(size=4.0)
    plane = bpy.context.active_object
    plane.data.materials.append(_probe_material(bpy, kind, sign))
    sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
    sun.rotation_euler = (math.radians(20.0), 0.0, 0.0)
    probe_light = bpy.data.lights.new("probe", "SUN")
    probe_light.energy, probe_light.color = 1000.0, (1.0, 0.0, 0.0)
    probe_light.diffuse_factor = diffuse_factor
    probe_light.specular_factor = probe_light.volume_factor = 0.0
    probe_light.transmission_factor = 1.0
    probe = bpy.data.objects.new("probe", probe_light)
    probe.rotation_euler = (0.0, math.radians(-30.0), 0.0)
    for obj in (sun, probe):
        scene.collection.objects.link(obj)
    probe.light_linking.receiver_collection = bpy.data.collections.new("probe receivers")
    probe.light_linking.receiver_collection.objects.link(plane)
    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    camera.data.type, camera.data.ortho_scale, camera.location = "ORTHO", 4.0, (0, 0, 5)
    scene.collection.objects.link(camera)
    scene.camera, scene.world = camera, black_world("black")
    render = scene.render
    render.engine = compat.EEVEE_ENGINE
    render.resolution_x = render.resolution_y = 64
    render.image_settings.file_format, render.image_settings.color_depth = "OPEN_EXR", "32"
    scene.eevee.taa_render_samples = 1
    scene.view_settings.view_transform = "Standard"
    with tempfile.TemporaryDirectory() as folder:
        render.filepath = str(Path(folder) / "probe.exr")
        bpy.ops.render.render(write_still=True)
        channels, _ = read_exr(Path(folder) / "probe.exr")
    return float(np.asarray(channels["R"])[8, 8]), float(np.asarray(channels["G"])[8, 8])


def main() -> int:
    import bpy

    from spectral_materials.blender.gpu.context import ensure_gpu

    ensure_gpu()
    print(f"Blender {bpy.app.version_string}: a pixel outside any shadow, Shader to RGB")
    print("| closure | red | green | the probe light reaches it |")
    print("|---|---|---|---|")
    for label, kind, sign, diffuse in CLOSURES:
        red, green = _render(bpy, kind, sign, diffuse)
        print(f"| {label} | {red:.4g} | {green:.4g} | {'yes' if red > 2 * green else 'no'} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
