"""Spectra the UI makes or receives: blackbody SPDs, the checks of reflectances and SPDs,
and resampling onto the project's wavelength grid."""

from __future__ import annotations

import math

import numpy as np
from colour.colorimetry import planck_law
from numpy.typing import ArrayLike

from . import spectra

#: Blackbody temperatures accepted by :func:`blackbody_spd`, in K.
BLACKBODY_LIMITS_K = (500.0, 1.0e6)

#: :func:`blackbody_spd` is 1 at this wavelength (nm).
BLACKBODY_NORMALISATION_NM = 560.0


def blackbody_spd(temperature_k: float,
                  wavelengths: ArrayLike = spectra.WAVELENGTHS_REFERENCE) -> np.ndarray:
    """Relative SPD of a blackbody (Planck's law), 1 at 560 nm → array (L,).

    Computed with ``colour.colorimetry.planck_law`` (CIE 015:2018 constants,
    c₂ = 1.4388 × 10⁻² m·K, refractive index 1) and divided by its value at
    :data:`BLACKBODY_NORMALISATION_NM`.

    Parameters
    ----------
    temperature_k
        Temperature in kelvin, finite and within :data:`BLACKBODY_LIMITS_K`
        (500 K to 10⁶ K).
    wavelengths
        Wavelengths in nm (1-D, strictly increasing, 200–2000 nm); the protocol's
        5 nm grid by default.

    Raises
    ------
    ValueError
        The temperature is not a finite number in [500, 10⁶] K, or the wavelengths are
        invalid.
    """
    if isinstance(temperature_k, bool) or not isinstance(
            temperature_k, int | float | np.integer | np.floating):
        raise ValueError(f"blackbody temperature must be a number, got "
                         f"{type(temperature_k).__name__}")
    t = float(temperature_k)
    low, high = BLACKBODY_LIMITS_K
    if not (math.isfinite(t) and low <= t <= high):
        raise ValueError(f"blackbody temperature must be finite and within {low:g}–{high:g} K, "
                         f"got {temperature_k}")
    wl = spectra.check_wavelengths(wavelengths)
    radiance = np.atleast_1d(planck_law(wl * 1e-9, t))
    reference = float(planck_law(BLACKBODY_NORMALISATION_NM * 1e-9, t))
    return np.asarray(radiance / reference, dtype=np.float64)


def _finite_1d(values: ArrayLike, name: str, wavelengths: ArrayLike | None) -> tuple:
    try:
        arr = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: values are not numbers ({exc})") from exc
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"{name}: expected a non-empty 1-D array of values, "
                         f"got shape {arr.shape}")
    wl = None
    if wavelengths is not None:
        wl = np.asarray(wavelengths, dtype=np.float64)
        if wl.shape != arr.shape:
            raise ValueError(f"{name}: {arr.size} values but wavelengths of shape {wl.shape}")
    return arr, wl


def _report(arr: np.ndarray, bad: np.ndarray, wl: np.ndarray | None, name: str,
            problem: str) -> None:
    if not bad.any():
        return
    i = int(np.flatnonzero(bad)[0])
    at = f"{wl[i]:g} nm" if wl is not None else f"sample {i}"
    raise ValueError(f"{name}: {int(bad.sum())} of {arr.size} values {problem}; "
                     f"the first is {arr[i]:g} at {at}")


def check_reflectance(values: ArrayLike, name: str,
                      wavelengths: ArrayLike | None = None) -> np.ndarray:
    """Check that a reflectance is finite and within [0, 1] → the values as float64.

    Parameters
    ----------
    values
        The reflectance samples, 1-D.
    name
        What to call the spectrum in the error message (e.g. ``"diffuse reflectance"``).
    wavelengths
        Optional wavelengths (nm) of the samples, so the message can say where the first
        offending value is; without them it gives the sample index.

    Raises
    ------
    ValueError
        Any value non-finite or outside [0, 1]; the message counts them and names the
        first one's wavelength (or index).
    """
    arr, wl = _finite_1d(values, name, wavelengths)
    _report(arr, ~np.isfinite(arr), wl, name, "are NaN or inf")
    _report(arr, (arr < 0.0) | (arr > 1.0), wl, name, "are outside the reflectance range [0, 1]")
    return arr


def check_spd(values: ArrayLike, name: str, wavelengths: ArrayLike | None = None) -> np.ndarray:
    """Check that a spectral power distribution is finite, ≥ 0 and not all zero → float64.

    Parameters are as for :func:`check_reflectance`.

    Raises
    ------
    ValueError
        Any value non-finite or negative (counted, the first one located), or every
        value zero.
    """
    arr, wl = _finite_1d(values, name, wavelengths)
    _report(arr, ~np.isfinite(arr), wl, name, "are NaN or inf")
    _report(arr, arr < 0.0, wl, name, "are negative")
    if not np.any(arr > 0.0):
        raise ValueError(f"{name}: every value is zero; a light needs some power")
    return arr


def spectrum_to_grid(wavelengths: ArrayLike, values: ArrayLike,
                     grid: ArrayLike = spectra.WAVELENGTHS_REFERENCE) -> np.ndarray:
    """Resample a ``(wavelengths, values)`` spectrum onto ``grid`` → array (len(grid),).

    Delegates to :func:`spectra.spectrum_values`: piecewise-linear interpolation, exact
    at the input's own samples. **Extrapolation** is constant: grid wavelengths below
    the first sample take the first value, those above the last take the last value
    (so a one-sample spectrum becomes a constant). Nothing is clipped or range-checked
    beyond finiteness.

    Parameters
    ----------
    wavelengths, values
        The spectrum: 1-D arrays of equal length, wavelengths in nm strictly increasing.
    grid
        Target wavelengths in nm (1-D, strictly increasing, 200–2000 nm); the protocol's
        5 nm grid from 380 to 780 nm by default.

    Raises
    ------
    ValueError
        Mismatched or non-1-D inputs, wavelengths not strictly increasing, non-finite
        values, or an invalid grid.
    """
    wl = np.asarray(wavelengths, dtype=np.float64)
    vals = np.asarray(values, dtype=np.float64)
    if wl.ndim != 1 or wl.size == 0 or wl.shape != vals.shape:
        raise ValueError(f"a spectrum needs 1-D wavelengths and values of equal, non-zero "
                         f"length; got shapes {wl.shape} and {vals.shape}")
    if not (np.isfinite(wl).all() and np.isfinite(vals).all()):
        raise ValueError("spectrum wavelengths and values must be finite")
    return spectra.spectrum_values((wl, vals), np.asarray(grid, dtype=np.float64))
