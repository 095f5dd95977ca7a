"""Factor packs on float image datablocks, metadata on the material's property group.

Image layout (one image per material, ``SM factors <material>``, RGBA float32,
``is_data``, full float, packed into the .blend, fake user). With ``G = ⌈R / 4⌉``
texel groups for ``R`` rank-one terms (one factor pack of 4 terms = one group):

* row ``k·G + g`` (k = 0 … n_axes−1 the angular axes, then k = n_axes the spectral
  axis): texel ``x`` holds terms ``4g … 4g+3`` of factor ``k`` at sample ``x``
  (zero-padded past the factor's length and past ``R``);
* the next ``⌈m / 4⌉`` rows hold the spectral basis Ψ (L × m): texel ``x`` of row
  ``j`` is basis vectors ``4j … 4j+3`` at wavelength sample ``x``.

Width is the longest of the axes, the spectral size and L. Row 0 is the image's
bottom row (Blender's pixel order). The wavelengths (float64) are an ID property
of the result group, and so are an analytic lobe's exponents and spectra
(``lobe_exponents``, ``lobe_spectral``: float32 values held as float64, exact), and
the measured cells a model is drawn in (``cells``: three counts, empty when smooth);
everything else the :class:`FactoredBRDF` needs is a plain property there. Because
images are full float and packed as lossless EXR, a stored model loads back
bit-identical to the float32 model that was stored.
"""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np

from ...core.brdf.factored import FactoredBRDF, json_default
from ...core.brdf.lobe import SpecularLobe
from ..images import (
    new_float_image as new_float_image,  # served from here too (BTF, PRT)
    remove_image as remove_image,
)

IMAGE_PREFIX = "SM factors "
PLOT_PREFIX = "SM plot "
CHANNELS = 4


class StorageError(ValueError):
    """Stored factors are missing or inconsistent; the message names the material."""


def as_stored(model: FactoredBRDF) -> FactoredBRDF:
    """The float32 model that storage keeps (what :func:`load_factored` returns)."""
    if model.form != "cp":
        raise StorageError("only CP factor packs are stored on materials")
    lobe = model.lobe
    if lobe is not None:
        lobe = replace(lobe, nu=float(np.float32(lobe.nu)), nv=float(np.float32(lobe.nv)),
                       spectral=np.ascontiguousarray(lobe.spectral, dtype=np.float32))
    return replace(
        model,
        lobe=lobe,
        factors=[np.ascontiguousarray(f, dtype=np.float32) for f in model.factors],
        spectral=np.ascontiguousarray(model.spectral, dtype=np.float32),
        basis=None if model.basis is None else np.ascontiguousarray(model.basis, np.float32),
        wavelengths=np.asarray(model.wavelengths, dtype=np.float64),
    )


def _groups(count: int) -> int:
    return -(-count // CHANNELS)


def pack_pixels(model: FactoredBRDF) -> np.ndarray:
    """The image's pixels (height, width, 4) float32 for a CP model (see module doc)."""
    model = as_stored(model)
    arrays = model.factors + [model.spectral]
    terms = model.terms
    groups = _groups(terms)
    basis_rows = 0 if model.basis is None else _groups(model.basis.shape[1])
    width = max([a.shape[0] for a in arrays] + [model.wavelengths.size])
    pixels = np.zeros((len(arrays) * groups + basis_rows, width, CHANNELS), dtype=np.float32)
    for k, array in enumerate(arrays):
        padded = np.zeros((array.shape[0], groups * CHANNELS), dtype=np.float32)
        padded[:, :terms] = array
        pixels[k * groups:(k + 1) * groups, : array.shape[0]] = \
            padded.reshape(array.shape[0], groups, CHANNELS).transpose(1, 0, 2)
    if basis_rows:
        m = model.basis.shape[1]
        padded = np.zeros((model.basis.shape[0], basis_rows * CHANNELS), dtype=np.float32)
        padded[:, :m] = model.basis
        pixels[len(arrays) * groups:, : model.basis.shape[0]] = \
            padded.reshape(-1, basis_rows, CHANNELS).transpose(1, 0, 2)
    return pixels


def unpack_pixels(pixels: np.ndarray, lengths: list[int], terms: int,
                  basis_shape: tuple[int, int] | None
                  ) -> tuple[list[np.ndarray], np.ndarray | None]:
    """Inverse of :func:`pack_pixels`: per-axis factors (spectral last) and the basis."""
    groups = _groups(terms)
    arrays = []
    for k, n in enumerate(lengths):
        block = pixels[k * groups:(k + 1) * groups, :n]           # (G, n, 4)
        arrays.append(np.ascontiguousarray(block.transpose(1, 0, 2).reshape(n, -1)[:, :terms]))
    basis = None
    if basis_shape is not None:
        rows, m = basis_shape
        block = pixels[len(lengths) * groups:, :rows]
        basis = np.ascontiguousarray(block.transpose(1, 0, 2).reshape(rows, -1)[:, :m])
    return arrays, basis


def _figures(model: FactoredBRDF) -> dict:
    stats = model.report.get("de94", {}) if isinstance(model.report, dict) else {}
    return {
        "de94_mean": float(stats.get("mean", float("nan"))),
        "de94_p95": float(stats.get("p95", float("nan"))),
        "de94_max": float(stats.get("max", float("nan"))),
    }


def prepare_images(material_name: str, stored: FactoredBRDF,
                   plot_pixels: np.ndarray | None = None) -> tuple:
    """Create (factor image, plot image or None) for a stored model; nothing else changes."""
    image = plot = None
    try:
        image = new_float_image(IMAGE_PREFIX + material_name, pack_pixels(stored))
        if plot_pixels is not None:
            plot = new_float_image(PLOT_PREFIX + material_name, plot_pixels, data=False)
    except Exception:
        remove_image(image)
        remove_image(plot)
        raise
    return image, plot


def apply_factored(material, stored: FactoredBRDF, images: tuple, input_hash: str) -> None:
    """Point ``material`` at prepared images and write the metadata; drops the old images."""
    result = material.spectral.result
    old_image, old_plot = result.image, result.plot
    figures = _figures(stored)
    result.image, result.plot = images
    result.parameterization = stored.parameterization
    result.resolution = "x".join(str(n) for n in stored.resolution)
    result.terms = stored.terms
    result.packs = stored.packs
    result.pack_size = stored.pack_size
    result.spectral_size = stored.spectral_size
    result.cosine_weighted = stored.cosine_weighted
    result.edge = stored.edge
    result.de94_mean = figures["de94_mean"]
    result.de94_p95 = figures["de94_p95"]
    result.de94_max = figures["de94_max"]
    result.seconds = float(stored.report.get("seconds", 0.0))
    result.nbytes = int(stored.nbytes)
    result.input_hash = input_hash
    result.report_json = json.dumps(stored.report, default=json_default)
    result["wavelengths"] = [float(w) for w in stored.wavelengths]
    result["basis_shape"] = [] if stored.basis is None else list(stored.basis.shape)
    lobe = stored.lobe
    result.lobe = "" if lobe is None else lobe.family
    result["lobe_exponents"] = [] if lobe is None else [lobe.nu, lobe.nv]
    result["lobe_spectral"] = [] if lobe is None else \
        [float(v) for v in np.asarray(lobe.spectral, np.float64).ravel()]
    result["cells"] = [] if stored.cells is None else [int(n) for n in stored.cells]
    material.spectral.enabled = True
    # Memfile undo re-reads only IDs tagged as changed; property writes alone do not tag.
    material.update_tag()
    remove_image(old_image)
    remove_image(old_plot)


def store_factored(material, model: FactoredBRDF, *, input_hash: str = "",
                   plot_pixels: np.ndarray | None = None) -> FactoredBRDF:
    """Write ``model`` onto ``material``, replacing what was there; returns the stored model.

    New images are made first; only when they exist are the properties switched
    over and the old images removed, so a failure leaves the material as it was.
    """
    stored = as_stored(model)
    stored.validate()
    images = prepare_images(material.name, stored, plot_pixels)
    apply_factored(material, stored, images, input_hash)
    return stored


def has_factors(material) -> bool:
    return material is not None and material.spectral.result.image is not None


def load_factored(material) -> FactoredBRDF:
    """The :class:`FactoredBRDF` stored on ``material`` (bit-identical to what was stored)."""
    result = material.spectral.result
    name = f"Material '{material.name}'"
    image = result.image
    if image is None:
        raise StorageError(f"{name} has no stored factors; factor it first")
    try:
        resolution = tuple(int(n) for n in result.resolution.split("x"))
        wavelengths = np.asarray(result["wavelengths"], dtype=np.float64)
        basis_shape = tuple(int(n) for n in result.get("basis_shape", []))
        lobe = None
        if result.lobe:
            nu, nv = (float(v) for v in result["lobe_exponents"])
            spectral = np.asarray(result["lobe_spectral"], dtype=np.float64)
            lobe = SpecularLobe(result.lobe, nu, nv,
                                spectral.astype(np.float32).reshape(-1, 2))
        cells = tuple(int(n) for n in result.get("cells", [])) or None
    except (KeyError, ValueError, TypeError) as exc:
        raise StorageError(f"{name}: stored factor metadata is incomplete ({exc})") from None
    width, height = image.size
    pixels = np.empty(width * height * CHANNELS, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    pixels = pixels.reshape(height, width, CHANNELS)
    spectral_size = result.spectral_size
    lengths = list(resolution) + [spectral_size]
    needed_rows = len(lengths) * _groups(result.terms) + (
        _groups(basis_shape[1]) if basis_shape else 0)
    if height != needed_rows or width < max(lengths + [wavelengths.size]):
        raise StorageError(f"{name}: factor image '{image.name}' is {width}×{height}, the "
                           f"metadata needs {needed_rows} rows; refactor the material")
    arrays, basis = unpack_pixels(pixels, lengths, result.terms,
                                  basis_shape if basis_shape else None)
    model = FactoredBRDF(
        parameterization=result.parameterization, resolution=resolution,
        wavelengths=wavelengths, basis=basis, cosine_weighted=result.cosine_weighted,
        form="cp", factors=arrays[:-1], spectral=arrays[-1], pack_size=result.pack_size,
        edge=result.edge or "linear", report=json.loads(result.report_json or "{}"),
        lobe=lobe, cells=cells,
    )
    try:
        model.validate()
    except ValueError as exc:
        raise StorageError(f"{name}: stored factors are invalid ({exc})") from None
    return model


def clear_factored(material) -> bool:
    """Remove a material's stored factors and their images; True if there were any."""
    result = material.spectral.result
    had = result.image is not None
    image, plot = result.image, result.plot
    # Every stored field back to its default, the ID properties (wavelengths, …) too.
    for key in list(result.keys()):
        del result[key]
    material.update_tag()
    remove_image(image)
    remove_image(plot)
    return had
