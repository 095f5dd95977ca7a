"""Reading an RGL ``.bsdf`` file: its material fields checked (shapes, axes, ranges,
non-finite and implausible samples) and cleaned, then built into an :class:`RGLBSDF`."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ...errors import InvalidBRDFData
from ...sample_limits import WAVELENGTH_LIMITS_NM, describe_extreme
from .bsdf import RGLBSDF
from .tensor_file import MAX_TENSOR_BYTES, _Invalid, read_tensor_file

#: Longest ``description`` accepted, in bytes (real ones are a line of text; decoded, a
#: description can take four times its bytes).
MAX_DESCRIPTION_BYTES = 1 << 20
#: Slack on the incident-angle ranges for float32 rounding (radians).
_ANGLE_SLACK = 1e-4

_DENSITIES = ("ndf", "sigma", "vndf", "luminance")


def _field(fields, name, ndim, dtype=np.float32) -> np.ndarray:
    if name not in fields:
        raise _Invalid(f"required field {name!r} is missing (fields: {sorted(fields)})")
    arr = fields[name]
    if arr.dtype != np.dtype(dtype):
        raise _Invalid(f"field {name!r} has dtype {arr.dtype}, the format needs "
                       f"{np.dtype(dtype)}")
    if arr.ndim != ndim:
        raise _Invalid(f"field {name!r} has {arr.ndim} dimensions {list(arr.shape)}, "
                       f"the format needs {ndim}")
    return arr


def _axis(arr: np.ndarray, name: str) -> np.ndarray:
    if arr.size == 0:
        raise _Invalid(f"{name} is empty")
    if not np.isfinite(arr).all():
        raise _Invalid(f"{name} holds NaN/inf")
    # Compared in the file's float32: the same order as in float64, without a copy.
    if arr.size > 1 and np.any(arr[1:] <= arr[:-1]):
        raise _Invalid(f"{name} is not strictly increasing: {arr[:8].tolist()}...")
    return arr


def _within(axis: np.ndarray, name: str, low: float, high: float, unit: str) -> np.ndarray:
    """An increasing axis whose ends lie in [low, high]."""
    if axis[0] < low or axis[-1] > high:
        raise _Invalid(f"{name} runs from {float(axis[0]):g} to {float(axis[-1]):g} {unit}, "
                       f"outside {low:g}..{high:g} {unit}: not a plausible measurement")
    return axis


def _description(fields) -> str:
    raw = _field(fields, "description", 1, np.uint8)
    if raw.size > MAX_DESCRIPTION_BYTES:
        raise _Invalid(f"field 'description' holds {raw.size:,} bytes, more than the "
                       f"{MAX_DESCRIPTION_BYTES:,} accepted for a line of text")
    return raw.tobytes().decode("utf-8", errors="replace")


def _incident_axes(fields) -> tuple[np.ndarray, np.ndarray]:
    theta_i = _axis(_field(fields, "theta_i", 1), "theta_i")
    phi_i = _axis(_field(fields, "phi_i", 1), "phi_i")
    _within(theta_i, "theta_i", -_ANGLE_SLACK, 0.5 * math.pi + _ANGLE_SLACK, "rad")
    _within(phi_i, "phi_i", -2 * math.pi - _ANGLE_SLACK, 2 * math.pi + _ANGLE_SLACK, "rad")
    return theta_i, phi_i


def _wavelengths(fields) -> np.ndarray:
    wavelengths = _axis(_field(fields, "wavelengths", 1), "wavelengths")
    return _within(wavelengths, "wavelengths", *WAVELENGTH_LIMITS_NM, "nm")


def _check_shapes(phi_i, theta_i, ndf, sigma, vndf, lum, values, vname, n_channels) -> None:
    npi, nti = phi_i.size, theta_i.size
    for name, arr in (("vndf", vndf), ("luminance", lum), (vname, values)):
        if arr.shape[:2] != (npi, nti):
            raise _Invalid(f"field {name!r} has shape {list(arr.shape)}; its first axes must "
                           f"be (phi_i, theta_i) = ({npi}, {nti})")
    if values.shape[2] != n_channels:
        raise _Invalid(f"field {vname!r} has {values.shape[2]} channels on axis 2, expected "
                       f"{n_channels}" + (" (the size of 'wavelengths')"
                                          if vname == "spectra" else ""))
    if values.shape[3] != values.shape[4] or lum.shape[2:] != values.shape[3:]:
        raise _Invalid(f"{vname!r} {list(values.shape)} and 'luminance' {list(lum.shape)} "
                       "need the same square n × n grid on their last two axes")
    for name, shp in (("ndf", ndf.shape), ("sigma", sigma.shape), ("vndf", vndf.shape[2:]),
                      (vname, values.shape[3:])):
        if min(shp) < 2:
            raise _Invalid(f"field {name!r} has a grid of {list(shp)}: at least 2 × 2 needed")
    if not (npi <= 2):
        red = int(np.rint(2 * math.pi / (float(phi_i[-1]) - float(phi_i[0]))))
        if red not in (1, 2, 4):
            raise _Invalid(f"phi_i spans {float(phi_i[-1] - phi_i[0]):.4g} rad: symmetry "
                           f"reduction {red} is not 1, 2 or 4")


def _clean(arrays: dict[str, np.ndarray], on_invalid: str) -> dict:
    """Count and repair defects *in place* (the arrays are the reader's own): no copies."""
    counts = {"nan": 0, "inf": 0, "negative": 0}
    per: dict[str, dict] = {}
    for name, arr in arrays.items():
        nan = int(np.isnan(arr).sum())
        inf = int(np.isinf(arr).sum())
        neg = int((arr < 0).sum())
        if nan or inf or neg:
            per[name] = {"nan": nan, "inf": inf, "negative": neg}
            counts["nan"] += nan
            counts["inf"] += inf
            counts["negative"] += neg
        if (nan or inf) and on_invalid != "clamp":
            raise _Invalid(f"field {name!r} holds {nan} NaN and {inf} inf samples of "
                           f"{arr.size:,} (read with on_invalid='clamp' to set them to 0)")
        extreme = describe_extreme(arr, f"field {name!r}")
        if extreme:
            raise _Invalid(extreme)
        if nan or inf:
            arr[~np.isfinite(arr)] = 0.0
        if neg and name in _DENSITIES:
            arr[arr < 0] = 0.0
    defects: dict = dict(counts)
    defects["fields"] = per
    return defects


def _build(fields: dict[str, np.ndarray], on_invalid: str) -> dict:
    description = _description(fields)
    jacobian = _field(fields, "jacobian", 1, np.uint8)
    if jacobian.shape != (1,):
        raise _Invalid(f"field 'jacobian' has shape {list(jacobian.shape)}, expected [1]")
    theta_i, phi_i = _incident_axes(fields)
    spectral = "wavelengths" in fields or "spectra" in fields or "rgb" not in fields
    if spectral:
        wavelengths = _wavelengths(fields)
        values = _field(fields, "spectra", 5)
        n_channels, vname = wavelengths.size, "spectra"
    else:
        wavelengths = None
        values = _field(fields, "rgb", 5)
        n_channels, vname = 3, "rgb"
    ndf = _field(fields, "ndf", 2)
    sigma = _field(fields, "sigma", 2)
    vndf = _field(fields, "vndf", 4)
    lum = _field(fields, "luminance", 4)
    _check_shapes(phi_i, theta_i, ndf, sigma, vndf, lum, values, vname, n_channels)
    arrays = {"ndf": ndf, "sigma": sigma, "vndf": vndf, "luminance": lum, vname: values}
    defects = _clean(arrays, on_invalid)
    if not np.any(values):
        raise _Invalid(f"field {vname!r} is all zero: no measurement")
    return {
        "theta_i": theta_i, "phi_i": phi_i, "ndf": ndf, "sigma": sigma, "vndf": vndf,
        "luminance": lum, "values": values,
        "wavelengths": None if wavelengths is None else wavelengths.astype(np.float64),
        "jacobian": bool(jacobian[0]), "description": description, "defects": defects,
    }


def read_rgl_bsdf(path, *, on_invalid: str = "raise",
                  max_bytes: int = MAX_TENSOR_BYTES) -> RGLBSDF:
    """Read an RGL ``.bsdf`` file (spectral or RGB), validating it; see the module notes.

    Parameters
    ----------
    on_invalid : {"raise", "clamp"}
        NaN/inf samples: raise :class:`InvalidBRDFData` naming the field and counts, or
        set them to 0 and count them in ``defects``.
    max_bytes : int
        Refuse files whose fields add up to more than this (checked before reading).

    Raises
    ------
    InvalidBRDFData
        (a ``ValueError``) naming the file, for any damage to the container (fields past
        the end, overlapping or too many), a missing / mis-shaped / mis-typed field,
        non-monotonic axes, angles or wavelengths out of range, non-finite samples (unless
        clamped), samples beyond ±10³⁰, all-zero spectra or degenerate vndf slices.
    """
    if on_invalid not in ("raise", "clamp"):
        raise ValueError(f"on_invalid must be 'raise' or 'clamp', got {on_invalid!r}")
    path = Path(path)
    fields = read_tensor_file(path, max_bytes=max_bytes)
    try:
        with np.errstate(all="ignore"):
            parts = _build(fields, on_invalid)
            return RGLBSDF(**parts, path=path)
    except _Invalid as exc:
        raise InvalidBRDFData(f"{path}: {exc}") from None
    except MemoryError:
        raise InvalidBRDFData(f"{path}: not enough memory to prepare its tables") from None
