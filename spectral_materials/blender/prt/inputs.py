"""What the PRT modules share: the error, the wavelengths, which objects are PRT objects,
the cache of everything derived from the scene (keyed by its inputs) and the readers of
files and images the environment and the albedo start from."""

from __future__ import annotations

import hashlib
import os

import bpy
import numpy as np

from ..lights.spd import WAVELENGTHS as WAVELENGTHS  # the PRT modules' wavelengths too
from ..lights.visibility import renders

#: Albedo spectra per object that enter the basis (a regular subsample of the texture).
BASIS_SAMPLES = 256

_CACHE: dict[str, tuple] = {}


class PRTError(ValueError):
    """A PRT input that cannot be used, said plainly."""


def prt_objects(scene, view_layer=None) -> list:
    """Visible mesh objects marked for spectral PRT."""
    view_layer = view_layer or scene.view_layers[0]
    return [o for o in scene.objects if o.type == "MESH" and o.spectral_prt.enabled
            and renders(o, view_layer)]


def cached(name: str, key, build):
    """The value cached under ``name`` if it was built from ``key``, else ``build()``."""
    entry = _CACHE.get(name)
    if entry is not None and entry[0] == key:
        return entry[1]
    value = build()
    _CACHE[name] = (key, value)
    return value


def forget(name: str) -> None:
    """Drop one cached value (it is built again when next asked for)."""
    _CACHE.pop(name, None)


def clear_cache() -> None:
    _CACHE.clear()


def digest(*arrays) -> str:
    h = hashlib.sha256()
    for a in arrays:
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()[:16]


def file_key(path: str) -> tuple:
    path = bpy.path.abspath(path)
    try:
        stat = os.stat(path)
    except OSError:
        raise PRTError(f"cannot read '{path}': no such file") from None
    return (path, stat.st_mtime_ns, stat.st_size)


def image_rgb(image, what: str) -> np.ndarray:
    """Linear RGB (H, W, 3) of an image datablock, row 0 at the bottom."""
    if image is None:
        raise PRTError(f"{what}: no image chosen")
    width, height = image.size
    if width == 0 or height == 0:
        raise PRTError(f"{what}: image '{image.name}' has no pixels (file missing?)")
    pixels = np.empty(width * height * image.channels, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    rgb = pixels.reshape(height, width, image.channels)[..., :3].astype(np.float64)
    if image.channels < 3:
        rgb = np.repeat(pixels.reshape(height, width, image.channels)[..., :1], 3, axis=2)
    if not image.is_float and image.colorspace_settings.name == "sRGB":
        # Byte images come back encoded; the uplift wants linear reflectance/radiance.
        rgb = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
    bad = ~np.isfinite(rgb)
    if bad.any():
        raise PRTError(f"{what}: image '{image.name}' has {int(bad.sum())} non-finite values")
    return rgb

