"""The demo's PNG writers (8-bit, row 0 of the array at the bottom, as Blender reads)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from spectral_materials.core.colour import pipeline as colour_pipeline


def write_linear_png(pixels_bottom_up: np.ndarray, path: Path) -> None:
    """Linear RGB(A) pixels, clipped to [0, 1] and sRGB-encoded (the panel's plot)."""
    import imageio.v3 as iio

    rgb = colour_pipeline.srgb_encode(np.clip(pixels_bottom_up[::-1, :, :3], 0.0, 1.0))
    iio.imwrite(path, (np.clip(rgb, 0, 1) * 255 + 0.5).astype(np.uint8))


def write_display_png(display_bottom_up: np.ndarray, path: Path) -> None:
    """Display-encoded pixels as they are (NaN, where nothing was drawn, as white)."""
    import imageio.v2 as imageio

    rgb = np.nan_to_num(display_bottom_up[::-1, :, :3], nan=1.0)
    imageio.imwrite(path, (np.clip(rgb, 0, 1) * 255 + 0.5).astype(np.uint8))
