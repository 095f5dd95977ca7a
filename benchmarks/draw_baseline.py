"""The draw benchmark's RGB baseline: a Blinn–Phong shader (``glsl/brdf/baseline_blinn_phong_*``)
with as many lights as the spectral row, drawing the same batch to the same target. The
demo's frame time (``demos.gpu_draw``) uses it too."""

from __future__ import annotations

import numpy as np

from spectral_materials.blender.gpu import shaders
from spectral_materials.core.brdf import prefilter
from spectral_materials.core.colour import pipeline as colour_pipeline
from spectral_materials.core.lights import SpectralLight

VIEW_ORIGIN = (0.0, 0.0, 1.0, 0.0)       # orthographic, looking down −z

#: The baseline's parameter block (std140), packed by :func:`baseline_params`.
BASELINE_MAX_LIGHTS = 8
BASELINE_PARAMS = f"""
struct BpParams {{
  mat4 view_projection;
  vec4 view_origin;                              /* as SmParams.view_origin */
  vec4 diffuse;                                  /* rgb: albedo, w: exposure */
  vec4 specular;                                 /* rgb: ks, w: Blinn-Phong exponent */
  vec4 light_position[{BASELINE_MAX_LIGHTS}];    /* w = 0: sun (xyz toward it), 1: point */
  vec4 light_colour[{BASELINE_MAX_LIGHTS}];      /* rgb: linear sRGB x strength */
}};
"""
BASELINE_BYTES = 64 + 3 * 16 + 2 * 16 * BASELINE_MAX_LIGHTS

class Baseline:
    """The RGB Blinn–Phong shader for ``count`` lights, with the same lights' colours."""

    _shaders: dict = {}

    def __init__(self, lights: list[SpectralLight], vp: np.ndarray):
        import gpu

        count = len(lights)
        if count > BASELINE_MAX_LIGHTS:
            raise ValueError(f"the baseline draws at most {BASELINE_MAX_LIGHTS} lights")
        shader = self._shaders.get(count)
        if shader is None:
            shader = gpu.shader.create_from_info(self.create_info(count))
            self._shaders[count] = shader
        self.shader = shader
        self.params = gpu.types.GPUUniformBuf(baseline_params(lights, vp))

    @staticmethod
    def create_info(count: int):
        import gpu

        info = gpu.types.GPUShaderCreateInfo()
        info.define("BP_LIGHTS", str(count))
        info.typedef_source(BASELINE_PARAMS)
        info.uniform_buf(0, "BpParams", "bp")
        info.push_constant("MAT4", "model_matrix")
        info.push_constant("MAT4", "normal_matrix")
        info.vertex_in(0, "VEC3", "position")
        info.vertex_in(1, "VEC3", "normal")
        interface = gpu.types.GPUStageInterfaceInfo("bp_surface_interface")
        interface.smooth("VEC3", "world_position")
        interface.smooth("VEC3", "world_normal")
        info.vertex_out(interface)
        info.vertex_source(shaders.glsl_source("brdf/baseline_blinn_phong_vert.glsl"))
        info.fragment_out(0, "VEC4", "frag_colour")
        info.fragment_source(shaders.glsl_source("brdf/baseline_blinn_phong_frag.glsl"))
        return info

    def bind(self) -> None:
        self.shader.bind()
        self.shader.uniform_block("bp", self.params)


def baseline_params(lights: list[SpectralLight], vp: np.ndarray) -> bytes:
    """The std140 bytes of ``BpParams``; matrices column-major."""
    positions = np.zeros((BASELINE_MAX_LIGHTS, 4))
    colours = np.zeros((BASELINE_MAX_LIGHTS, 4))
    for i, light in enumerate(lights):
        if light.kind == "SUN":
            positions[i] = (*(-np.asarray(light.axis)), 0.0)
        else:                      # spot and area lights are drawn as point lights
            positions[i] = (*light.position, 1.0)
        colours[i, :3] = prefilter.light_rgb(
            light, colour_pipeline.xyz_to_linear_srgb_matrix()) * light.strength
    parts = [np.asarray(vp, dtype=np.float64).T, np.asarray(VIEW_ORIGIN),
             np.array([0.6, 0.5, 0.4, 1.0]), np.array([0.04, 0.04, 0.04, 64.0]),
             positions, colours]
    data = b"".join(np.ascontiguousarray(p, dtype=np.float32).tobytes() for p in parts)
    assert len(data) == BASELINE_BYTES
    return data


