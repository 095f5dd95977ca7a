"""A library entry's thumbnail: the protocol sphere under D65 and under FL2, side by side."""

from __future__ import annotations

import io

import numpy as np

from ..brdf.factored import FactoredBRDF
from ..brdf.shading import sphere_xyz
from ..colour import pipeline, spectra

#: The illuminants of a thumbnail, left to right: daylight and a spiky shop fluorescent.
THUMBNAIL_ILLUMINANTS = ("D65", "FL2")
#: The protocol light's incidence in the thumbnails (degrees).
THUMBNAIL_INCIDENCE = 30.0
BACKGROUND = 0.18


def thumbnail_rgb(model: FactoredBRDF, size: int) -> np.ndarray:
    """(size, 2·size, 3) uint8, row 0 at the top: each illuminant's sphere, displayed with
    the white of that illuminant (a white Lambertian is white under both)."""
    halves = []
    for illuminant in THUMBNAIL_ILLUMINANTS:
        xyz, mask = sphere_xyz(model, THUMBNAIL_INCIDENCE, illuminant, size)
        white = pipeline.white_xyz(illuminant, spectra.WAVELENGTHS_REFERENCE)
        display = pipeline.xyz_to_display(xyz.reshape(-1, 3), white).reshape(xyz.shape)
        display[~mask] = BACKGROUND
        halves.append(display[::-1])                    # row 0 at the top
    return np.round(np.concatenate(halves, axis=1) * 255).astype(np.uint8)


def thumbnail_png(model: FactoredBRDF, size: int) -> bytes:
    return png_bytes(thumbnail_rgb(model, size))


def png_bytes(rgb8: np.ndarray) -> bytes:
    """An (H, W, 3) uint8 image (row 0 at the top) as PNG bytes."""
    from PIL import Image

    buffer = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(rgb8), "RGB").save(buffer, format="PNG")
    return buffer.getvalue()
