"""Float image datablocks that the add-on creates (factor packs, BTF tiles, PRT albedo
layers, plots) and removes."""

from __future__ import annotations

import bpy
import numpy as np


def new_float_image(name: str, pixels: np.ndarray, *, data: bool = True):
    """A packed full-float RGBA image with a fake user holding ``pixels`` (h, w, 4)."""
    height, width = pixels.shape[:2]
    image = bpy.data.images.new(name, width=width, height=height, alpha=True,
                                float_buffer=True, is_data=data)
    try:
        image.use_half_precision = False
        image.pixels.foreach_set(np.ascontiguousarray(pixels, dtype=np.float32).ravel())
        image.pack()
        image.use_fake_user = True
    except Exception:
        bpy.data.images.remove(image)
        raise
    return image


def remove_image(image) -> None:
    """Remove ``image`` if it is still this file's image of that name (None: nothing)."""
    if image is not None and image.name in bpy.data.images and \
            bpy.data.images[image.name] == image:
        bpy.data.images.remove(image)
