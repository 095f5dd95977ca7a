"""Float textures from NumPy texels (RGBA32F: factors of glossy lobes exceed half float's
65504, and its 11-bit mantissa would cost ~1e-3 relative error per factor)."""

from __future__ import annotations

import numpy as np

from .context import ensure_gpu


def float_texture(texels: np.ndarray):
    """An RGBA32F texture from (height, width, 4) texels, row 0 first."""
    import gpu

    ensure_gpu()
    texels = np.ascontiguousarray(texels, dtype=np.float32)
    height, width = texels.shape[:2]
    buffer = gpu.types.Buffer("FLOAT", texels.size, texels.ravel())
    return gpu.types.GPUTexture((width, height), format="RGBA32F", data=buffer)


def array_texture(layers: np.ndarray, filtered: bool = False,
                  texture_format: str = "RGBA32F"):
    """A 2D-array texture from (layers, H, W, 3|4), zero-padded to RGBA; ``filtered``:
    sampled with linear filtering (else only ``texelFetch`` reads it). For ``RGBA16`` the
    values should be exact in unorm16 (``core.prt.albedo_forms.unorm16_texels``), so that
    the upload's conversion cannot round them differently from the mirror."""
    import gpu

    if texture_format not in ("RGBA32F", "RGBA16"):
        raise ValueError(f"no array texture of format {texture_format!r}")
    ensure_gpu()
    m, h, w = layers.shape[:3]
    texels = np.zeros((m, h, w, 4), dtype=np.float32)
    texels[..., : layers.shape[3]] = layers
    buffer = gpu.types.Buffer("FLOAT", texels.size, texels.ravel())
    texture = gpu.types.GPUTexture((w, h), layers=m, format=texture_format, data=buffer)
    if filtered:
        _filter_linearly(texture)
    return texture


def _filter_linearly(texture) -> None:
    if hasattr(texture, "filter_mode"):
        # Blender 4.5 and 5.0 have no sampler API: their Python textures filter linearly
        # (tests/blender/brdf/test_factor_precision_gpu.py and the PRT albedo-basis pixel
        # test pass on both legs).
        texture.filter_mode(True)


def sixteen_bit_texture(texels: np.ndarray, texture_format: str):
    """A linearly filtered RGBA16F or RGBA16 texture from (height, width, 4) float texels
    that are exact in that format (``FilteredFactorsBRDF.texels``), so the driver's
    conversion from float cannot round them differently from the mirror."""
    import gpu

    if texture_format not in ("RGBA16F", "RGBA16"):
        raise ValueError(f"not a 16-bit format: {texture_format!r}")
    ensure_gpu()
    texels = np.ascontiguousarray(texels, dtype=np.float32)
    height, width = texels.shape[:2]
    buffer = gpu.types.Buffer("FLOAT", texels.size, texels.ravel())
    texture = gpu.types.GPUTexture((width, height), format=texture_format, data=buffer)
    _filter_linearly(texture)
    return texture
