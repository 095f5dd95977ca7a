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


def array_texture(layers: np.ndarray):
    """An RGBA32F 2D-array texture from (layers, H, W, 3|4), zero-padded to RGBA."""
    import gpu

    ensure_gpu()
    m, h, w = layers.shape[:3]
    texels = np.zeros((m, h, w, 4), dtype=np.float32)
    texels[..., : layers.shape[3]] = layers
    buffer = gpu.types.Buffer("FLOAT", texels.size, texels.ravel())
    return gpu.types.GPUTexture((w, h), layers=m, format="RGBA32F", data=buffer)
