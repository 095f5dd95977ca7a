"""Writing spectral OpenEXR files in the layout, with an optional sRGB preview."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ...sample_limits import MAX_SAMPLE, WAVELENGTH_LIMITS_NM, extreme_mask
from .._files import atomic_path
from .layout import (
    _RESERVED,
    _STRUCTURAL,
    EMISSIVE_UNITS,
    KINDS,
    LAYOUT_VERSION,
    MAX_SAMPLES,
    SpectralImage,
    channel_name,
    parse_channel_name,
)
from .rgb_preview import spectral_image_to_rgb


def _checked_wavelengths(wavelengths_nm) -> np.ndarray:
    """1-D, finite, positive, within the limits the reader accepts, strictly increasing."""
    wl = np.asarray(wavelengths_nm, dtype=np.float64)
    if wl.ndim != 1 or wl.size == 0:
        raise ValueError(f"wavelengths must be a non-empty 1-D array, got shape {wl.shape}")
    if not (np.isfinite(wl).all() and (wl > 0).all()):
        raise ValueError("wavelengths must be finite and positive")
    low, high = WAVELENGTH_LIMITS_NM
    if wl.min() < low or wl.max() > high:
        raise ValueError(f"wavelengths must lie within {low:g}–{high:g} nm (the reader "
                         f"refuses others), got {wl.min():g}–{wl.max():g}")
    if wl.size > 1 and np.any(np.diff(wl) <= 0):
        raise ValueError("wavelengths must be strictly increasing (no duplicates)")
    return wl


def _stored_values(path: Path, values, bands: int, allow_invalid: bool) -> np.ndarray:
    """(H, W, bands) as float32, refusing what the reader would refuse unless
    ``allow_invalid``: non-finite samples and magnitudes beyond ±MAX_SAMPLE."""
    data = np.asarray(values)
    if data.ndim != 3 or data.shape[-1] != bands or 0 in data.shape:
        raise ValueError(f"values must be (H, W, {bands}) with H, W ≥ 1, got {data.shape}")
    if data.size > MAX_SAMPLES:
        raise ValueError(f"{data.size:,} samples exceed the {MAX_SAMPLES:,} limit")
    with np.errstate(over="ignore", invalid="ignore"):
        stored = np.asarray(data, dtype=np.float32)
    if not allow_invalid and not np.isfinite(stored).all():
        bad = int((~np.isfinite(stored)).sum())
        raise ValueError(f"{path}: refusing to write {bad} non-finite samples (after "
                         "conversion to float32)")
    if not allow_invalid:  # all finite here: only the magnitude is left to check
        extreme = int(np.count_nonzero(extreme_mask(stored)))
        if extreme:
            raise ValueError(f"{path}: refusing to write {extreme} samples beyond "
                             f"±{MAX_SAMPLE:g} (the reader refuses them)")
    return stored


def _header_attributes(kind: str, units: str | None, attributes: dict | None) -> dict:
    """The layout's attributes and the caller's (checked: no reserved names, plain types)."""
    if kind == "reflective" and units is not None:
        raise ValueError("reflective spectra are unitless: pass units=None")
    header_extra: dict = {"spectralLayoutVersion": LAYOUT_VERSION, "EV": 0.0}
    if kind == "emissive":
        header_extra["emissiveUnits"] = EMISSIVE_UNITS if units is None else str(units)
    for key, value in (attributes or {}).items():
        if not isinstance(key, str) or not key:
            raise ValueError(f"attribute names must be non-empty strings, got {key!r}")
        if key in _RESERVED or key in _STRUCTURAL:
            raise ValueError(f"attribute {key!r} is set by the layout or by OpenEXR")
        if isinstance(value, bool) or not isinstance(value, str | int | float):
            raise ValueError(f"attribute {key!r}: only str, int and float values are written")
        header_extra[key] = value
    return header_extra


def _channels(kind: str, wl: np.ndarray, stored: np.ndarray, rgb_preview: bool) -> dict:
    """Channel name → (H, W) float32 pixels, top row first as OpenEXR stores them."""
    names = [channel_name(kind, w) for w in wl]
    parsed = [parse_channel_name(n) for n in names]
    if any(p is None or p[2] != w for p, w in zip(parsed, wl)):  # belt and braces
        raise ValueError("internal error: channel names do not give back the wavelengths")
    flipped = stored[::-1]
    channels = {name: np.ascontiguousarray(flipped[:, :, i]) for i, name in enumerate(names)}
    if rgb_preview:
        image = SpectralImage(wl, np.nan_to_num(stored, nan=0.0, posinf=0.0, neginf=0.0),
                              kind)
        rgb = spectral_image_to_rgb(image).astype(np.float32)[::-1]
        for c, name in enumerate("RGB"):
            channels[name] = np.ascontiguousarray(rgb[:, :, c])
    return channels


def write_spectral_exr(
    path: str | Path,
    wavelengths_nm,
    values,
    *,
    kind: str = "reflective",
    units: str | None = None,
    rgb_preview: bool = True,
    attributes: dict | None = None,
    allow_invalid: bool = False,
) -> Path:
    """Write an (H, W, L) spectral image (row 0 at the bottom) in the spectral layout.

    Parameters
    ----------
    wavelengths_nm : array (L,)
        Strictly increasing, within :data:`WAVELENGTH_LIMITS_NM` (nm).
    values : array (H, W, L)
        Stored as float32 (see the module docstring); emissive → ``S0`` channels,
        reflective → ``T`` channels.
    kind : {"reflective", "emissive"}
    units : str or None
        ``emissiveUnits`` of an emissive image; default :data:`EMISSIVE_UNITS`
        (the reference's value). Reflective spectra are unitless: must be None.
    rgb_preview : bool
        Also store ``R``, ``G``, ``B`` (:func:`spectral_image_to_rgb`; reflective
        spectra under D65), as the reference writer always does.
    attributes : dict or None
        Extra header attributes (str, int or float values); the layout's own
        (``spectralLayoutVersion``, ``emissiveUnits``, ``polarisationHandedness``,
        ``EV``) are written by this function and refused here.
    allow_invalid : bool
        Write NaN/inf samples and samples beyond ±:data:`MAX_SAMPLE` instead of raising
        (for testing readers).

    The file is written under a temporary name beside ``path`` and renamed.
    """
    import OpenEXR

    path = Path(path)
    if kind not in KINDS:
        raise ValueError(f"kind must be 'reflective' or 'emissive', got {kind!r}")
    wl = _checked_wavelengths(wavelengths_nm)
    stored = _stored_values(path, values, wl.size, allow_invalid)
    header_extra = _header_attributes(kind, units, attributes)
    channels = _channels(kind, wl, stored, rgb_preview)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    header.update(header_extra)
    with atomic_path(path, ".tmp.exr") as temporary, OpenEXR.File(header, channels) as exr:
        exr.write(os.fsencode(temporary))
    return path
