"""Drawing BTF materials: reflectance fields with view interpolation on the GPU.

A material with a stored BTF (``btf_storage``) is drawn by ``glsl/btf/btf_frag.glsl``
through :class:`BTFMaterial`: the records as an RGBA32F 2D-array texture (tiled within
the GPU's layer and size limits, :class:`~spectral_materials.core.btf.render.TileLayout`),
the view-lookup tables (cells, candidate lists and triangles of
:class:`~spectral_materials.core.btf.container.HemisphereTriangulation`) and a light texture with
the lights' XYZ weights on the material's albedo basis. Textures are rebuilt only when
the stored BTF changes (its image's name and size and the metadata are the key); the
light texture when the lights change. The drawer registers with the viewport's registry at
import and claims every material with a stored BTF, ahead of the factor-pack drawer.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...core.btf.container import HemisphereTriangulation
from ...core.btf.render import EDGE_BLEND, KINDS, DrawableBTF, TileLayout
from ...core.lights import SpectralLight
from ..gpu import shaders
from ..gpu.context import ensure_gpu
from ..gpu.display import DisplaySettings, display_matrices, std140_mat4
from ..gpu.outputs import BTF_REQUESTS, output_defines
from ..gpu.shaders import MAX_LIGHTS, glsl_source, light_type_bits
from ..gpu.std140 import glsl_block
from ..gpu.textures import array_texture, float_texture
from ..viewport import registry
from . import storage as btf_storage

#: ``SmBtfParams`` as glsl/btf/btf_params.glsl declares it: the packer's one spec.
PARAMS = glsl_block("btf/btf_params.glsl", "SmBtfParams")
PARAMS_BYTES = PARAMS.size
#: ``SM_BTF_KIND`` per reflectance-field kind (core/btf/render.py KINDS); the GLSL compares
#: against the generated names ``SM_BTF_KIND_<KIND>``.
KIND_CODES = {kind: code for code, kind in enumerate(KINDS)}
FRAGMENT_LIBRARY = ("common/common.glsl", "common/light_rows.glsl", "common/lights.glsl",
                    "common/frame.glsl", "common/colour_pipeline.glsl", "btf/btf_views.glsl",
                    "btf/btf_frag.glsl")

_MATERIALS: dict[str, BTFMaterial] = {}
#: BTF materials that could not be drawn: name → reason.
FAILED: dict[str, str] = {}


@dataclass(frozen=True)
class BTFShaderKey:
    kind: str
    lobes: int
    coefficients: int
    lights: int
    light_types: frozenset
    output: str = "XYZ"
    #: Texel-edge blend band (``render.EDGE_BLEND``), in the key so that a variant
    #: compiled with another band is never served from the cache.
    edge: float = EDGE_BLEND

    def defines(self) -> dict[str, str]:
        return {"SM_BTF_KIND": str(KIND_CODES[self.kind]), "SM_BTF_LOBES": str(self.lobes),
                **{f"SM_BTF_KIND_{kind}": str(code) for kind, code in KIND_CODES.items()},
                "SM_BTF_COEFFS": str(self.coefficients),
                "SM_BTF_EDGE": repr(float(self.edge)),
                "SM_BTF_ALBEDO_RECORDS": str(-(-self.coefficients // 4)),
                "SM_BTF_LIST_WIDTH": str(HemisphereTriangulation.LIST_WIDTH),
                "SM_LIGHTS": str(self.lights),
                "SM_LIGHT_TYPES": str(light_type_bits(self.light_types)),
                "SM_LIGHT_STRIDE": "0",         # light rows in light_tex (light_rows.glsl)
                **output_defines(BTF_REQUESTS[self.output])}

    def validate(self) -> None:
        if self.kind not in KIND_CODES:
            raise ValueError(f"no BTF shader for {self.kind!r}")
        if not 1 <= self.lights <= MAX_LIGHTS:
            raise ValueError(f"{self.lights} lights reach the scene; the BTF shader draws "
                             f"1..{MAX_LIGHTS}: hide or disable some lights")
        if self.output not in BTF_REQUESTS:
            raise ValueError(f"unknown output {self.output!r}")


def create_info(key: BTFShaderKey):
    import gpu

    key.validate()
    info = gpu.types.GPUShaderCreateInfo()
    for name, value in key.defines().items():
        info.define(name, value)
    info.typedef_source(glsl_source("btf/btf_params.glsl"))
    info.uniform_buf(0, "SmBtfParams", "sm")
    info.sampler(0, "FLOAT_2D_ARRAY", "record_tex")
    info.sampler(1, "FLOAT_2D", "cell_tex")
    info.sampler(2, "FLOAT_2D", "triangle_tex")
    info.sampler(3, "FLOAT_2D", "light_tex")
    info.sampler(4, "FLOAT_2D", "candidate_tex")
    info.push_constant("MAT4", "model_matrix")
    info.push_constant("MAT4", "normal_matrix")
    info.vertex_in(0, "VEC3", "position")
    info.vertex_in(1, "VEC3", "normal")
    info.vertex_in(2, "VEC4", "tangent")
    info.vertex_in(3, "VEC2", "uv")
    interface = gpu.types.GPUStageInterfaceInfo("sm_btf_interface")
    for name in ("world_position", "world_normal", "world_tangent"):
        interface.smooth("VEC3", name)
    interface.smooth("VEC2", "tex_uv")
    info.vertex_out(interface)
    info.vertex_source(glsl_source("btf/btf_vert.glsl"))
    info.fragment_out(0, "VEC4", "frag_colour")
    info.fragment_source("\n".join(glsl_source(n) for n in FRAGMENT_LIBRARY))
    return info


def get_shader(key: BTFShaderKey):
    return shaders.get_shader(key, create_info)


def gpu_limits() -> tuple[int, int]:
    """(array layers, texture size) the GPU allows."""
    import gpu

    ensure_gpu()
    caps = gpu.capabilities
    return int(caps.max_texture_layers_get()), int(caps.max_texture_size_get())




class BTFMaterial:
    """GPU resources of one BTF material."""

    def __init__(self, drawable: DrawableBTF, uv_scale=(1.0, 1.0), *,
                 limits: tuple[int, int] | None = None):
        self.drawable = drawable
        self.uv_scale = tuple(float(s) for s in uv_scale)
        max_layers, max_size = limits or gpu_limits()
        h, w = drawable.texels
        self.layout = TileLayout.plan(w, h, drawable.records, max_layers=max_layers,
                                      max_size=max_size)
        self.record_texture = array_texture(drawable.layer_images(self.layout))
        tri = drawable.triangulation
        tables = (tri.cell_table(), tri.triangle_table(), tri.candidate_table())
        self.cell_texture, self.triangle_texture, self.candidate_texture = \
            (float_texture(table) for table in tables)
        self.grid = tri.grid
        self.nbytes = int(self.layout.layers * self.layout.size[0] * self.layout.size[1] * 16
                          + sum(table.nbytes for table in tables))
        self._light_texture: tuple | None = None

    def key(self, lights: list[SpectralLight], output: str = "XYZ") -> BTFShaderKey:
        d = self.drawable
        return BTFShaderKey(d.kind, d.lobes, d.coefficients.shape[2], len(lights),
                            frozenset(light.kind for light in lights), output,
                            edge=EDGE_BLEND)    # read now: tests and benchmarks vary it

    def light_texture(self, lights: list[SpectralLight], lights_key=None):
        if lights_key is not None and self._light_texture is not None \
                and self._light_texture[0] == lights_key:
            return self._light_texture[1]
        texture = float_texture(self.drawable.light_texels(lights))
        if lights_key is not None:
            self._light_texture = (lights_key, texture)
        return texture

    def params_block(self, display: DisplaySettings, view_origin,
                     view_projection: np.ndarray) -> bytes:
        """The std140 bytes of ``SmBtfParams`` (glsl/btf/btf_params.glsl)."""
        adapt, to_rgb, _ = display_matrices(tuple(display.scene_white))
        lay = self.layout
        return PARAMS.pack(
            view_projection=std140_mat4(view_projection), adaptation=adapt,
            xyz_to_rgb=to_rgb, display=(display.exposure, display.tone_white, 0.0, 0.0),
            view_origin=view_origin, uv_scale=(*self.uv_scale, 0.0, 0.0),
            tiles=(lay.width, lay.height, lay.tiles_per_layer, lay.columns),
            counts=(self.drawable.albedo_records, self.drawable.records_per_view,
                    self.grid, 0))

    def params(self, display: DisplaySettings, view_origin, view_projection: np.ndarray):
        import gpu

        return gpu.types.GPUUniformBuf(self.params_block(display, view_origin,
                                                         view_projection))

    def bind(self, shader, light_texture, params) -> None:
        shader.bind()
        shader.uniform_block("sm", params)
        shader.uniform_sampler("record_tex", self.record_texture)
        shader.uniform_sampler("cell_tex", self.cell_texture)
        shader.uniform_sampler("triangle_tex", self.triangle_texture)
        shader.uniform_sampler("light_tex", light_texture)
        shader.uniform_sampler("candidate_tex", self.candidate_texture)


def _material_key(material) -> tuple:
    """Changes whenever a BTF is stored again (each store draws a new token)."""
    meta = material[btf_storage.PROPERTY]
    image = btf_storage.btf_image(material)
    return (meta.get("token", ""), meta.get("image", ""),
            tuple(image.size) if image is not None else ())


def btf_material(material) -> BTFMaterial | None:
    """The cached GPU resources of a BTF material, or None (no BTF, or it failed: the
    reason is in :data:`FAILED`)."""
    if not btf_storage.has_btf(material):
        return None
    key = _material_key(material)
    cached = _MATERIALS.get(material.name)
    if cached is not None and getattr(cached, "cache_key", None) == key:
        cached.uv_scale = btf_storage.uv_scale(material)      # a live setting
        return cached
    try:
        resource = BTFMaterial(btf_storage.load_btf(material), btf_storage.uv_scale(material))
    except ValueError as exc:
        FAILED[material.name] = str(exc)
        _MATERIALS.pop(material.name, None)
        return None
    FAILED.pop(material.name, None)
    resource.cache_key = key
    _MATERIALS[material.name] = resource
    return resource


def bind(resource: BTFMaterial, frame: registry.DrawFrame) -> registry.BoundSlot:
    """Bind the BTF variant of ``resource`` for one draw."""
    key = resource.key(frame.lights, output=frame.output)
    shader = get_shader(key)
    # Held until the draw: a freed uniform buffer leaves the block unbound.
    params = resource.params(frame.display, frame.view.uniform(), frame.view_projection)
    resource.bind(shader, resource.light_texture(frame.lights, frame.lights_key), params)
    return registry.BoundSlot(key, shader, params)


def clear_cache() -> None:
    _MATERIALS.clear()
    FAILED.clear()


DRAWER = registry.MaterialDrawer(
    name="BTF", order=10, claims=btf_storage.has_btf, resource=btf_material, bind=bind,
    clear_cache=clear_cache, failures=lambda: FAILED)
registry.register(DRAWER)
