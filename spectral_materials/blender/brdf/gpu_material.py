"""What a shader variant needs to draw one factored material: textures and uniforms.

With the exact factors (the default), the factor texture is the material's factor
image as stored (``storage.pack_pixels``: one RGBA texel per sample and pack of 4
terms), uploaded as RGBA32F. The other precisions
(``core.brdf.filtered_factors.FACTOR_PRECISIONS``) upload 16-bit padded rows whose
columns are balanced into the spectral factor, so the light rows are built from that
balanced model (``drawn_model``). The light rows come from
``core.brdf.shading.light_texels``; ``gpu.textures`` uploads both.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...core.brdf.axes import EDGE_RULES, holds_horizon
from ...core.brdf.factored import FactoredBRDF
from ...core.brdf.filtered_factors import drawn_model
from ...core.brdf.lobe import family_code
from ...core.brdf.shading import LOBE_TEXELS, light_row_texels, light_texels, lobe_texel
from ...core.lights import SpectralLight
from ..gpu.display import DisplaySettings, display_matrices, std140_mat4
from ..gpu.shaders import MAX_LIGHT_BUFFER_TEXELS, PARAMETERIZATION_CODES, ShaderKey
from ..gpu.std140 import glsl_block
from ..gpu.textures import array_texture, float_texture, sixteen_bit_texture
from . import storage

# Served from here too (they lived here before the display uniforms and the textures
# moved down to ``gpu``): scripts and the GLSL tests import them from this module.
__all__ = ["DisplaySettings", "GPUMaterial", "MaterialUniforms", "PARAMS_BYTES",
           "array_texture", "check_drawable", "display_matrices", "float_texture",
           "params_block", "std140_mat4"]


@dataclass
class MaterialUniforms:
    """Per-axis lookup uniforms (padded to 4 axes) of a factored model; ``edge_rule`` is
    the index in ``axes.EDGE_RULES``, the GLSL's SM_EDGE_* codes."""

    axis_lo: tuple
    axis_span: tuple
    axis_flags: tuple
    axis_cells: tuple
    edge_rule: int
    pack_rows: int
    #: The analytic lobe's exponents (nu, nv, 0, 0); zeros without one.
    lobe: tuple = (0.0, 0.0, 0.0, 0.0)

    @classmethod
    def of(cls, model: FactoredBRDF) -> MaterialUniforms:
        axes = model.grid.parameterization.axes
        pad = 4 - len(axes)
        return cls(
            axis_lo=tuple(float(a.lo) for a in axes) + (0.0,) * pad,
            axis_span=tuple(float(a.span) for a in axes) + (1.0,) * pad,
            axis_flags=tuple(int(a.periodic) | (2 if a.warp == "sqrt" else 0)
                             | (4 if holds_horizon(a, model.edge) else 0)
                             for a in axes) + (0,) * pad,
            axis_cells=tuple(int(n) for n in model.grid.shape) + (1,) * pad,
            edge_rule=EDGE_RULES.index(model.edge),
            pack_rows=-(-model.terms // 4),
            lobe=(0.0,) * 4 if model.lobe is None else
            (float(model.lobe.nu), float(model.lobe.nv), 0.0, 0.0),
        )


def check_drawable(model: FactoredBRDF) -> None:
    """ValueError naming what the GPU path cannot draw."""
    if model.form != "cp":
        raise ValueError("the GPU path draws CP factor packs; this model is separable")
    if model.grid.parameterization.name not in PARAMETERIZATION_CODES:
        raise ValueError(f"no shader for parameterisation {model.parameterization!r}")


class GPUMaterial:
    """A model's factor texture and uniforms, and light textures per light set.

    ``precision`` (``filtered_factors.FACTOR_PRECISIONS``) says how the factors are
    stored and read; ``model`` is then what the GPU evaluates (``drawn_model``), the
    float64 mirror of its pixels."""

    def __init__(self, model: FactoredBRDF, precision: str = "exact"):
        check_drawable(model)
        self.precision = precision
        self.model = drawn_model(model, precision)
        self.uniforms = MaterialUniforms.of(model)
        if precision == "exact":
            pixels = storage.pack_pixels(model)
            self.factor_texture = float_texture(pixels)
            self.nbytes = int(pixels.nbytes)
        else:
            texels = self.model.texels()
            self.factor_texture = sixteen_bit_texture(texels, self.model.texture_format)
            self.nbytes = int(texels.size * 2)
        self._light_textures: dict = {}

    @property
    def groups(self) -> int:
        return self.uniforms.pack_rows

    def light_stride(self, lights: list[SpectralLight], precontract: bool) -> int:
        """Texels per light row when the rows go in the uniform buffer ``sm_lights``
        (glsl/common/light_rows.glsl); 0 when they exceed it and stay in a texture."""
        width = light_row_texels(self.groups, self.model.spectral_size, precontract)
        if self.model.lobe is not None:
            width += LOBE_TEXELS
        return width if len(lights) * width <= MAX_LIGHT_BUFFER_TEXELS else 0

    def key(self, lights: list[SpectralLight], *, packs: int | None = None,
            precontract: bool = True, output: str = "XYZ", sphere: bool = False) -> ShaderKey:
        """The variant drawing this material; ``packs`` limits the texel groups of 4 terms
        drawn (a model whose pack size is not 4 is truncated with ``truncated`` instead)."""
        model = self.model
        drawn = self.groups if packs is None else max(1, min(int(packs), self.groups))
        return ShaderKey(parameterization=model.grid.parameterization.name,
                         axes=len(model.grid.shape), packs=drawn,
                         coefficients=model.spectral_size, lights=len(lights),
                         light_types=frozenset(light.kind for light in lights),
                         cosine_weighted=bool(model.cosine_weighted), precontract=precontract,
                         output=output, sphere=sphere,
                         light_stride=self.light_stride(lights, precontract),
                         factors=self.precision,
                         lobe_texel=lobe_texel(self.model, precontract),
                         lobe_family=1 if model.lobe is None else family_code(model.lobe.family),
                         cells=tuple(model.cells or ()))

    def light_texture(self, lights: list[SpectralLight], precontract: bool, lights_key=None):
        """The light rows for ``lights``, cached under ``lights_key`` when given: a uniform
        buffer where :meth:`light_stride` says they fit (the variant of :meth:`key` reads
        them so), else a texture. :meth:`bind` binds either."""
        cache_key = (lights_key, precontract)
        if lights_key is not None and cache_key in self._light_textures:
            return self._light_textures[cache_key]
        texels = light_texels(self.model, lights, precontract=precontract)
        if self.light_stride(lights, precontract):
            import gpu

            texture = gpu.types.GPUUniformBuf(texels.astype(np.float32).tobytes())
        else:
            texture = float_texture(texels)
        if lights_key is not None:
            self._light_textures = {cache_key: texture}
        return texture

    def bind(self, shader, light_texture, params) -> None:
        """Bind the shader, the factor texture, the light rows (:meth:`light_texture`: a
        uniform buffer or a texture) and the parameter block ``params``."""
        import gpu

        shader.bind()
        shader.uniform_block("sm", params)
        shader.uniform_sampler("factor_tex", self.factor_texture)
        if isinstance(light_texture, gpu.types.GPUUniformBuf):
            shader.uniform_block("sm_lights", light_texture)
        else:
            shader.uniform_sampler("light_tex", light_texture)

    def params(self, display: DisplaySettings, *, view_origin=(0.0, 0.0, 1.0, 0.0),
               view_projection: np.ndarray | None = None, target_size=(0.0, 0.0)):
        """A uniform buffer with this material's parameter block."""
        import gpu

        return gpu.types.GPUUniformBuf(params_block(self.uniforms, display, view_origin,
                                                    view_projection, target_size))


#: ``SmParams`` as glsl/brdf/params.glsl declares it: the packer's one spec (gpu/std140.py).
PARAMS = glsl_block("brdf/params.glsl", "SmParams")
PARAMS_BYTES = PARAMS.size


def params_block(u: MaterialUniforms, display: DisplaySettings, view_origin=(0, 0, 1, 0),
                 view_projection: np.ndarray | None = None, target_size=(0.0, 0.0)) -> bytes:
    """The std140 bytes of ``SmParams`` (glsl/brdf/params.glsl); matrices column-major."""
    adapt, rgb, _ = display_matrices(tuple(display.scene_white))
    vp = np.eye(4) if view_projection is None else np.asarray(view_projection)
    return PARAMS.pack(
        axis_lo=u.axis_lo, axis_span=u.axis_span, axis_flags=u.axis_flags,
        axis_cells=u.axis_cells, misc=(u.edge_rule, u.pack_rows, 0, 0),
        display=(display.exposure, display.tone_white, *target_size),
        view_origin=view_origin, lobe=u.lobe, adaptation=adapt, xyz_to_rgb=rgb,
        view_projection=std140_mat4(vp))
