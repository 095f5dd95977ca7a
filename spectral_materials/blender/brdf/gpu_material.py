"""What a shader variant needs to draw one factored material: textures and uniforms.

The factor texture is the material's factor image as stored (``storage.pack_pixels``:
one RGBA texel per sample and pack of 4 terms), uploaded as RGBA32F. Float32 is
required there and in the light texture: factors of glossy lobes exceed half
float's 65504 and its 11-bit mantissa would cost ~1e-3 relative error per
factor, compounded over 4 axes and 48 packs. The light texture comes from
``core.shading.light_texels``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from ...core.brdf.factored import FactoredBRDF
from ...core.brdf.shading import light_texels
from ...core.colour import pipeline as colour_pipeline
from ...core.lights import SpectralLight
from ..gpu.context import ensure_gpu
from ..gpu.shaders import ShaderKey
from . import storage


def float_texture(texels: np.ndarray):
    """An RGBA32F texture from (height, width, 4) texels, row 0 first."""
    import gpu

    ensure_gpu()
    texels = np.ascontiguousarray(texels, dtype=np.float32)
    height, width = texels.shape[:2]
    buffer = gpu.types.Buffer("FLOAT", texels.size, texels.ravel())
    return gpu.types.GPUTexture((width, height), format="RGBA32F", data=buffer)


def array_texture(layers: np.ndarray):
    """An RGBA32F 2D-array texture from (layers, H, W, 3|4), zero-padded to RGBA."""
    import gpu

    ensure_gpu()
    m, h, w = layers.shape[:3]
    texels = np.zeros((m, h, w, 4), dtype=np.float32)
    texels[..., : layers.shape[3]] = layers
    buffer = gpu.types.Buffer("FLOAT", texels.size, texels.ravel())
    return gpu.types.GPUTexture((w, h), layers=m, format="RGBA32F", data=buffer)


@dataclass
class MaterialUniforms:
    """Per-axis lookup uniforms (padded to 4 axes) of a factored model."""

    axis_lo: tuple
    axis_span: tuple
    axis_flags: tuple
    axis_cells: tuple
    edge_clamp: int
    pack_rows: int

    @classmethod
    def of(cls, model: FactoredBRDF) -> MaterialUniforms:
        axes = model.grid.parameterization.axes
        pad = 4 - len(axes)
        return cls(
            axis_lo=tuple(float(a.lo) for a in axes) + (0.0,) * pad,
            axis_span=tuple(float(a.span) for a in axes) + (1.0,) * pad,
            axis_flags=tuple(int(a.periodic) | (2 if a.warp == "sqrt" else 0) for a in axes)
            + (0,) * pad,
            axis_cells=tuple(int(n) for n in model.grid.shape) + (1,) * pad,
            edge_clamp=int(model.edge == "clamp"),
            pack_rows=-(-model.terms // 4),
        )


@dataclass
class DisplaySettings:
    """The display pipeline's uniforms: scene white (XYZ), exposure, tone-map white."""

    scene_white: tuple = tuple(colour_pipeline.DISPLAY_WHITE_XYZ)
    exposure: float = 1.0
    tone_white: float = 4.0


def check_drawable(model: FactoredBRDF) -> None:
    """ValueError naming what the GPU path cannot draw."""
    if model.form != "cp":
        raise ValueError("the GPU path draws CP factor packs; this model is separable")
    if model.grid.parameterization.name not in ("io", "io_iso", "hd", "hd_iso", "gs", "ea"):
        raise ValueError(f"no shader for parameterisation {model.parameterization!r}")


class GPUMaterial:
    """A model's factor texture and uniforms, and light textures per light set."""

    def __init__(self, model: FactoredBRDF):
        check_drawable(model)
        self.model = model
        self.uniforms = MaterialUniforms.of(model)
        pixels = storage.pack_pixels(model)
        self.factor_texture = float_texture(pixels)
        self.nbytes = int(pixels.nbytes)
        self._light_textures: dict = {}

    @property
    def groups(self) -> int:
        return self.uniforms.pack_rows

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
                         output=output, sphere=sphere)

    def light_texture(self, lights: list[SpectralLight], precontract: bool, lights_key=None):
        """The light texture for ``lights`` (cached under ``lights_key`` when given)."""
        cache_key = (lights_key, precontract)
        if lights_key is not None and cache_key in self._light_textures:
            return self._light_textures[cache_key]
        texture = float_texture(light_texels(self.model, lights, precontract=precontract))
        if lights_key is not None:
            self._light_textures = {cache_key: texture}
        return texture

    def bind(self, shader, light_texture, params) -> None:
        """Bind the shader, its two textures and the parameter block ``params``."""
        shader.bind()
        shader.uniform_block("sm", params)
        shader.uniform_sampler("factor_tex", self.factor_texture)
        shader.uniform_sampler("light_tex", light_texture)

    def params(self, display: DisplaySettings, *, view_origin=(0.0, 0.0, 1.0, 0.0),
               view_projection: np.ndarray | None = None, target_size=(0.0, 0.0)):
        """A uniform buffer with this material's parameter block."""
        import gpu

        return gpu.types.GPUUniformBuf(params_block(self.uniforms, display, view_origin,
                                                    view_projection, target_size))


PARAMS_BYTES = 7 * 16 + 3 * 64


@functools.lru_cache(maxsize=16)
def display_matrices(scene_white: tuple) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """std140 mat4s of the display pipeline for a scene white: Bradford (white → D65),
    XYZ → linear sRGB and its inverse. Cached: every draw of every material asks, and
    colour-science's Bradford costs a fraction of a millisecond each time."""
    to_rgb = colour_pipeline.xyz_to_linear_srgb_matrix()
    out = (std140_mat4(colour_pipeline.bradford_matrix(np.asarray(scene_white))),
           std140_mat4(to_rgb), std140_mat4(np.linalg.inv(to_rgb)))
    for matrix in out:
        matrix.setflags(write=False)
    return out


def std140_mat4(matrix) -> np.ndarray:
    """A 3 × 3 or 4 × 4 matrix as a std140 mat4 (float32, column-major, padded with the
    identity)."""
    m = np.eye(4)
    a = np.asarray(matrix, dtype=np.float64)
    m[: a.shape[0], : a.shape[1]] = a
    return m.T.astype(np.float32)


def params_block(u: MaterialUniforms, display: DisplaySettings, view_origin=(0, 0, 1, 0),
                 view_projection: np.ndarray | None = None, target_size=(0.0, 0.0)) -> bytes:
    """The std140 bytes of ``SmParams`` (glsl/params.glsl); matrices column-major."""
    adapt, rgb, _ = display_matrices(tuple(display.scene_white))
    vp = np.eye(4) if view_projection is None else np.asarray(view_projection)
    parts = [
        np.asarray(u.axis_lo, np.float32), np.asarray(u.axis_span, np.float32),
        np.asarray(u.axis_flags, np.int32), np.asarray(u.axis_cells, np.int32),
        np.asarray((u.edge_clamp, u.pack_rows, 0, 0), np.int32),
        np.asarray((display.exposure, display.tone_white, *target_size), np.float32),
        np.asarray(view_origin, np.float32), adapt, rgb, std140_mat4(vp),
    ]
    data = b"".join(np.ascontiguousarray(p).tobytes() for p in parts)
    assert len(data) == PARAMS_BYTES
    return data
