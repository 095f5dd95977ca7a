"""The EEVEE node group's per-light frames: the shading frame, and for each spectral
light its direction and irradiance, driven from the light object (as
``glsl/common/frame.glsl`` and ``glsl/common/lights.glsl``).

``g`` is the group's ``nodes.Graph`` (passed in, not imported: ``nodes`` imports this).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import bpy
import numpy as np

from .drivers import follow


@dataclass
class KeyLight:
    """What the group needs of one spectral light; its position or direction and its
    strength are driven from the light object."""

    object_name: str
    kind: str                     # SUN, POINT, SPOT, AREA
    weights: np.ndarray           # (terms, 3) RGB per unit irradiance (core.prefilter)
    lobe_weights: np.ndarray | None = None   # (2, 3) the analytic lobe's, if any


def _key_light_drivers(g, key: KeyLight, column: int):
    """Combine XYZ (toward-light direction for a sun, else position) and strength, driven."""
    vector = g.node("ShaderNodeCombineXYZ", column, "key light (driven)")
    strength = g.node("ShaderNodeValue", column, "key strength (driven)")
    light_object = bpy.data.objects[key.object_name]
    matrix_column = 2 if key.kind == "SUN" else 3      # +Z axis (toward the sun) / location
    for index in range(3):
        follow(vector.inputs[index], "default_value", light_object,
               f"matrix_world[{matrix_column}][{index}]")
    follow(strength.outputs[0], "default_value", light_object.data, "energy")
    return vector.outputs[0], strength.outputs[0]


def shading_frame(g, use_uv_tangent: bool):
    """(geometry node, t, b, n): the shading frame, as glsl/common/frame.glsl."""
    g.begin("Shading frame")
    geometry = g.node("ShaderNodeNewGeometry", 0, "Geometry")
    n = g.vmath("NORMALIZE", geometry.outputs["Normal"], column=1, label="n")
    # Two-sided as the draw handler's surface shader: an interpolated normal that faces
    # away from the viewer (on a front face of a concave smooth mesh, as in Suzanne's eye
    # sockets) is flipped, where EEVEE flips only back faces.
    facing = g.math("GREATER_THAN", g.vmath("DOT_PRODUCT", n, geometry.outputs["Incoming"],
                                            column=1), 0.0, column=1)
    n = g.vmath("SCALE", n, scale=g.math("MULTIPLY_ADD", facing, 2.0, -1.0, column=1),
                column=1, label="n, facing the viewer")
    generated = g.vmath("CROSS_PRODUCT", (0.0, 1.0, 0.0), n, column=1, label="ŷ × n")
    has_generated = g.math("GREATER_THAN", g.vmath("LENGTH", generated, column=2), 1e-12,
                           column=3)
    generated = g.select(has_generated, g.vmath("NORMALIZE", generated, column=3),
                         (1.0, 0.0, 0.0), column=4, vector=True, label="generated t")
    if use_uv_tangent:
        tangent = g.node("ShaderNodeTangent", 0, "UV tangent", direction_type="UV_MAP")
        raw = tangent.outputs[0]
        ortho = g.vmath("SUBTRACT", raw, g.vmath("SCALE", n, scale=g.vmath(
            "DOT_PRODUCT", n, raw, column=1), column=2), column=3)
        usable = g.math("GREATER_THAN", g.vmath("DOT_PRODUCT", ortho, ortho, column=4), 1e-8,
                        column=5)
        t = g.select(usable, g.vmath("NORMALIZE", ortho, column=5), generated, column=6,
                     vector=True, label="t")
    else:
        t = generated
    b = g.vmath("CROSS_PRODUCT", n, t, column=7, label="b = n × t")
    return geometry, t, b, n


def light_incidence(g, key: KeyLight, frame, label: str):
    """(wi, wo, irradiance, lit, wi in world space) of one spectral light, its position
    or direction and strength driven from the light object."""
    geometry, t, b, n = frame
    g.begin(label)
    vector, strength = _key_light_drivers(g, key, 0)
    if key.kind == "SUN":
        wi_world = g.vmath("NORMALIZE", vector, column=2, label="toward the sun")
        irradiance = strength
    else:
        d = g.vmath("SUBTRACT", vector, geometry.outputs["Position"], column=1)
        r2 = g.vmath("DOT_PRODUCT", d, d, column=2, label="r²")
        wi_world = g.vmath("NORMALIZE", d, column=2, label="toward the light")
        irradiance = g.math("DIVIDE", strength, g.math("MULTIPLY", r2, 4.0 * math.pi,
                                                       column=3), column=4,
                            label="P / (4π r²)")
    wo_world = geometry.outputs["Incoming"]

    def local(w, name):
        return g.combine(g.vmath("DOT_PRODUCT", t, w, column=8),
                         g.vmath("DOT_PRODUCT", b, w, column=8),
                         g.vmath("DOT_PRODUCT", n, w, column=8), column=9, label=name)

    wi, wo = local(wi_world, "wi (local)"), local(wo_world, "wo (local)")
    lit = g.math("MULTIPLY", g.math("GREATER_THAN", g.separate(wi, column=10)[2], 0.0,
                                    column=11),
                 g.math("GREATER_THAN", g.separate(wo, column=10)[2], 0.0, column=11),
                 column=12, label="lit")
    return wi, wo, irradiance, lit, wi_world
