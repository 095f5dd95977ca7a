"""Depth-only drawing of geometry no drawer shades, so that it hides what lies behind it."""

from __future__ import annotations

import numpy as np

from ..gpu.matrices import column_major

_SHADER = None


def occluder_shader():
    """The depth-only shader (compiled once; :func:`clear_cache` drops it)."""
    global _SHADER
    if _SHADER is None:
        import gpu

        info = gpu.types.GPUShaderCreateInfo()
        info.push_constant("MAT4", "mvp")
        info.vertex_in(0, "VEC3", "position")
        info.fragment_out(0, "VEC4", "frag_colour")
        info.vertex_source("void main() { gl_Position = mvp * vec4(position, 1.0); }")
        info.fragment_source("void main() { frag_colour = vec4(0.0); }")
        _SHADER = gpu.shader.create_from_info(info)
    return _SHADER


def draw_occluders(work: list, view_projection: np.ndarray) -> None:
    """Write the depth of every slot without a resource; ``work`` holds
    (object, mesh batches, {slot: (drawer, resource) or None})."""
    import gpu

    shader = occluder_shader()
    gpu.state.color_mask_set(False, False, False, False)
    try:
        for obj, batches, slots in work:
            shader.bind()
            shader.uniform_float("mvp", column_major(view_projection
                                                     @ np.array(obj.matrix_world)))
            for slot, batch in batches.batches.items():
                if slots.get(slot) is None:
                    batch.draw(shader)
    finally:
        gpu.state.color_mask_set(True, True, True, True)


def clear_cache() -> None:
    global _SHADER
    _SHADER = None
