"""Reflectance-field BTFs on materials: a packed float image plus ID properties.

Image ``SM BTF <material>`` (RGBA float32, full float, packed, fake user): the
:meth:`DrawableBTF.record_images` records (albedo records, then each view's records),
each an H × W tile, laid out left to right, bottom to top in ``columns`` tile columns.
The material's ID property ``sm_btf`` holds everything else: kind, lobes, the view
directions, the albedo basis, the texel size and the fit figures (JSON). How often
the tile repeats is a live setting, ``material.spectral_btf.uv_scale``. Images are
packed as lossless EXR, so a stored BTF loads back bit-identical.
"""

from __future__ import annotations

import json
import math
import uuid

import numpy as np

from ...core.btf.render import WAVELENGTHS, DrawableBTF
from ..brdf.storage import StorageError, new_float_image, remove_image

IMAGE_PREFIX = "SM BTF "
PROPERTY = "sm_btf"


def has_btf(material) -> bool:
    return material is not None and PROPERTY in material.keys()


def _columns(records: int) -> int:
    return max(1, math.ceil(math.sqrt(records)))


def pack_records(drawable: DrawableBTF) -> tuple[np.ndarray, int]:
    """((rows·H, columns·W, 4) pixels, columns) of a drawable's records."""
    records = drawable.record_images()
    n, h, w, _ = records.shape
    columns = _columns(n)
    rows = -(-n // columns)
    pixels = np.zeros((rows * h, columns * w, 4), np.float32)
    for r, image in enumerate(records):
        y, x = divmod(r, columns)
        pixels[y * h:(y + 1) * h, x * w:(x + 1) * w] = image
    return pixels, columns


def store_btf(material, drawable: DrawableBTF, *, uv_scale=None,
              figures: dict | None = None) -> None:
    """Store ``drawable`` on ``material`` (replacing a previous BTF); ``uv_scale`` sets the
    material's tile repeats when given."""
    pixels, columns = pack_records(drawable)
    image = new_float_image(f"{IMAGE_PREFIX}{material.name}", pixels)
    try:
        meta = {
            "kind": drawable.kind, "lobes": int(drawable.lobes), "name": drawable.name,
            "views": drawable.views.astype(np.float64).ravel().tolist(),
            "basis": drawable.basis.astype(np.float64).ravel().tolist(),
            "coefficients": int(drawable.coefficients.shape[2]),
            "texels": list(drawable.texels), "columns": columns,
            "figures": json.dumps(figures or {}), "image": image.name,
            "token": uuid.uuid4().hex,
        }
    except Exception:
        remove_image(image)
        raise
    clear_btf(material)
    material[PROPERTY] = meta
    if uv_scale is not None:
        material.spectral_btf.uv_scale = (float(uv_scale[0]), float(uv_scale[1]))


def _meta(material) -> dict:
    if not has_btf(material):
        raise StorageError(f"Material '{material.name}' has no BTF; fit one first")
    return material[PROPERTY].to_dict()


def uv_scale(material) -> tuple[float, float]:
    """How often the BTF tile repeats across the UV square (u, v)."""
    return tuple(float(s) for s in material.spectral_btf.uv_scale)  # type: ignore[return-value]


def figures(material) -> dict:
    return json.loads(_meta(material).get("figures", "{}"))


def btf_image(material):
    import bpy

    return bpy.data.images.get(_meta(material).get("image", ""))


def load_btf(material) -> DrawableBTF:
    """The :class:`DrawableBTF` stored on ``material``."""
    name = f"Material '{material.name}'"
    meta = _meta(material)
    image = btf_image(material)
    if image is None:
        raise StorageError(f"{name}: its BTF image '{meta.get('image')}' is missing; fit the "
                           "BTF again")
    try:
        h, w = (int(n) for n in meta["texels"])
        views = np.asarray(meta["views"], dtype=np.float64).reshape(-1, 3)
        m = int(meta["coefficients"])
        basis = np.asarray(meta["basis"], dtype=np.float64).reshape(len(WAVELENGTHS), m)
        kind, lobes, columns = str(meta["kind"]), int(meta["lobes"]), int(meta["columns"])
    except (KeyError, ValueError) as exc:
        raise StorageError(f"{name}: stored BTF metadata is incomplete ({exc})") from None
    per_view = 2 if kind == "RFP" else 1 + lobes
    albedo_records = -(-m // 4)
    records = albedo_records + len(views) * per_view
    width, height = image.size
    rows = -(-records // columns)
    if (width, height) != (columns * w, rows * h):
        raise StorageError(f"{name}: BTF image '{image.name}' is {width}×{height}, the "
                           f"metadata needs {columns * w}×{rows * h}; fit the BTF again")
    pixels = np.empty(width * height * 4, np.float32)
    image.pixels.foreach_get(pixels)
    pixels = pixels.reshape(height, width, 4)
    images = np.empty((records, h, w, 4), np.float32)
    for r in range(records):
        y, x = divmod(r, columns)
        images[r] = pixels[y * h:(y + 1) * h, x * w:(x + 1) * w]
    coefficients = images[:albedo_records].transpose(1, 2, 0, 3).reshape(h, w, -1)[..., :m]
    params = images[albedo_records:].reshape(len(views), per_view, h, w, 4) \
        .transpose(0, 2, 3, 1, 4).reshape(len(views), h, w, 4 * per_view)
    try:
        return DrawableBTF(kind, lobes, views, params, coefficients, basis,
                           name=str(meta.get("name", material.name)))
    except ValueError as exc:
        raise StorageError(f"{name}: stored BTF is invalid ({exc})") from None


def clear_btf(material) -> bool:
    """Remove a material's BTF and its image; True if there was one."""
    if not has_btf(material):
        return False
    import bpy

    image = bpy.data.images.get(material[PROPERTY].get("image", ""))
    del material[PROPERTY]
    remove_image(image)
    return True
