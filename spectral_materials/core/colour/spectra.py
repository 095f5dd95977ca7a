"""Spectral data: wavelength grid, CIE 1931 2° / 1964 10° CMFs, illuminants, reflectances.

Everything comes from colour-science and is resampled onto the caller's
wavelength grid by piecewise-linear interpolation (exact at the datasets' own
5 nm / 1 nm samples, no ringing on the spiky FL lines), constant beyond the
dataset's range.

References
----------
CIE 015:2018 Colorimetry, 4th ed. Tables of the 1931 2° and 1964 10° observers
and the standard illuminants, as shipped by colour-science 0.4.6.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import lru_cache
from typing import Union

import colour
import numpy as np

#: The protocol's reference grid: 5 nm from 380 to 780 nm (81 samples).
WAVELENGTHS_REFERENCE = np.arange(380.0, 781.0, 5.0)

#: Sample spacing of :data:`WAVELENGTHS_REFERENCE` in nm.
DELTA_LAMBDA_REFERENCE = 5.0

ILLUMINANT_NAMES = ("A", "D50", "D65") + tuple(f"FL{i}" for i in range(1, 13))

#: The protocol's observer, the default everywhere.
OBSERVER = "CIE 1931 2 Degree Standard Observer"

#: The supplementary (large-field) observer.
OBSERVER_1964 = "CIE 1964 10 Degree Standard Observer"

#: The observers :func:`cmfs` knows, by their colour-science names.
OBSERVER_NAMES = (OBSERVER, OBSERVER_1964)

#: Short aliases (lower case) of :data:`OBSERVER_NAMES`.
OBSERVER_ALIASES = {"1931": OBSERVER, "1964": OBSERVER_1964}

COLORCHECKER = "ColorChecker N Ohta"

#: A spectrum given by the user: a constant, a colour-science distribution, a
#: callable ``wavelengths -> values``, or a ``(wavelengths, values)`` pair.
SpectrumLike = Union[
    float,
    "colour.SpectralDistribution",
    Callable[[np.ndarray], np.ndarray],
    tuple,
]


def wavelength_grid(start: float = 380.0, stop: float = 780.0, step: float = 5.0) -> np.ndarray:
    """Return an inclusive, uniform wavelength grid in nm."""
    if not (np.isfinite([start, stop, step]).all() and step > 0 and stop >= start):
        raise ValueError(f"invalid wavelength grid: start={start}, stop={stop}, step={step}")
    count = int(np.floor((stop - start) / step + 1e-9)) + 1  # never past ``stop``
    return start + step * np.arange(count, dtype=np.float64)


def check_wavelengths(wavelengths: np.ndarray) -> np.ndarray:
    """Validate a wavelength array (1-D, finite, strictly increasing, nm)."""
    wl = np.asarray(wavelengths, dtype=np.float64)
    if wl.ndim != 1 or wl.size == 0:
        raise ValueError(f"wavelengths must be a non-empty 1-D array, got shape {wl.shape}")
    if not np.isfinite(wl).all():
        raise ValueError("wavelengths contain NaN or inf")
    if wl.size > 1 and np.any(np.diff(wl) <= 0):
        raise ValueError("wavelengths must be strictly increasing")
    if wl[0] < 200 or wl[-1] > 2000:
        raise ValueError(f"wavelengths {wl[0]}..{wl[-1]} nm are outside 200..2000 nm")
    return wl


def sample_weights(wavelengths: np.ndarray) -> np.ndarray:
    """Riemann-sum weights Δλ per sample (trapezoid-free, as the protocol sums)."""
    wl = check_wavelengths(wavelengths)
    if wl.size == 1:
        return np.ones(1)
    edges = np.concatenate([[wl[0] - (wl[1] - wl[0]) / 2], (wl[1:] + wl[:-1]) / 2,
                            [wl[-1] + (wl[-1] - wl[-2]) / 2]])
    return np.diff(edges)


def _resample(domain: np.ndarray, values: np.ndarray, wavelengths: np.ndarray,
              outside: float | None = None) -> np.ndarray:
    """Linear resampling; beyond the data, the end values (``outside=None``) or ``outside``."""
    values = np.asarray(values, dtype=np.float64)
    if values.ndim == 1:
        return np.interp(wavelengths, domain, values, left=outside, right=outside)
    return np.stack([np.interp(wavelengths, domain, v, left=outside, right=outside)
                     for v in values.T], axis=-1)


def spectrum_values(spectrum: SpectrumLike, wavelengths: np.ndarray) -> np.ndarray:
    """Evaluate a :data:`SpectrumLike` at ``wavelengths`` (nm) → array (L,)."""
    wl = check_wavelengths(wavelengths)
    if isinstance(spectrum, int | float | np.floating | np.integer):
        out = np.full(wl.shape, float(spectrum))
    elif isinstance(spectrum, colour.SpectralDistribution):
        out = _resample(spectrum.wavelengths, spectrum.values, wl)
    elif isinstance(spectrum, tuple) and len(spectrum) == 2:
        domain, values = (np.asarray(a, dtype=np.float64) for a in spectrum)
        if domain.shape != values.shape or domain.ndim != 1 or not np.all(np.diff(domain) > 0):
            raise ValueError("a (wavelengths, values) spectrum needs two 1-D arrays of equal "
                             "length, wavelengths strictly increasing")
        out = _resample(domain, values, wl)
    elif callable(spectrum):
        out = np.asarray(spectrum(wl), dtype=np.float64)
        if out.shape != wl.shape:
            out = np.broadcast_to(out, wl.shape).copy()
    else:
        raise TypeError(f"cannot interpret {type(spectrum).__name__} as a spectrum")
    if not np.isfinite(out).all():
        raise ValueError(f"spectrum has {int((~np.isfinite(out)).sum())} non-finite values")
    return out


def observer_name(observer: str = OBSERVER) -> str:
    """The colour-science name of an observer given by name or short alias.

    Accepts :data:`OBSERVER_NAMES` (case-insensitive) and the aliases ``"1931"``
    and ``"1964"``; anything else raises a ValueError listing the choices.
    """
    key = str(observer).strip().lower() if isinstance(observer, str) else None
    for name in OBSERVER_NAMES:
        if key == name.lower():
            return name
    if key in OBSERVER_ALIASES:
        return OBSERVER_ALIASES[key]
    choices = ", ".join(repr(n) for n in (*OBSERVER_NAMES, *OBSERVER_ALIASES))
    raise ValueError(f"unknown observer {observer!r}; choose one of {choices}")


@lru_cache(maxsize=32)
def _cmfs_cached(key: tuple, observer: str) -> np.ndarray:
    cmfs = colour.MSDS_CMFS[observer]
    # The observer sees nothing outside its tabulated 360–830 nm.
    out = _resample(cmfs.wavelengths, cmfs.values, np.asarray(key), outside=0.0)
    out.setflags(write=False)
    return out


def cmfs(wavelengths: np.ndarray = WAVELENGTHS_REFERENCE, observer: str = OBSERVER) -> np.ndarray:
    """Colour matching functions x̄, ȳ, z̄ at ``wavelengths`` → (L, 3), read-only.

    Parameters
    ----------
    wavelengths : ndarray (L,)
        nm.
    observer : str
        ``"CIE 1931 2 Degree Standard Observer"`` (the protocol's, default) or
        ``"CIE 1964 10 Degree Standard Observer"``; also ``"1931"``, ``"1964"``.

    Returns
    -------
    ndarray (L, 3)
        Cached per grid and observer: do not modify (it is marked read-only).
    """
    return _cmfs_cached(tuple(check_wavelengths(wavelengths).tolist()), observer_name(observer))


def illuminant(name: str, wavelengths: np.ndarray = WAVELENGTHS_REFERENCE) -> np.ndarray:
    """Relative SPD of a CIE illuminant (``A``, ``D50``, ``D65``, ``FL1``–``FL12``) → (L,)."""
    key = str(name).upper()
    if key not in ILLUMINANT_NAMES:
        names = ", ".join(ILLUMINANT_NAMES)
        raise ValueError(f"unknown illuminant {name!r}; choose one of {names}")
    return spectrum_values(colour.SDS_ILLUMINANTS[key], wavelengths)


def colorchecker_names() -> list[str]:
    """Names of the 24 ColorChecker N Ohta patches, in chart order (patch 1 first)."""
    return list(colour.SDS_COLOURCHECKERS[COLORCHECKER].keys())


def colorchecker(patch: int | str, wavelengths: np.ndarray = WAVELENGTHS_REFERENCE) -> np.ndarray:
    """Reflectance of a ColorChecker N Ohta patch, by 1-based number or by name → (L,)."""
    patches = colour.SDS_COLOURCHECKERS[COLORCHECKER]
    names = list(patches.keys())
    if isinstance(patch, int | np.integer):
        if not 1 <= patch <= len(names):
            raise ValueError(f"ColorChecker patch must be 1..{len(names)}, got {patch}")
        name = names[int(patch) - 1]
    else:
        if patch not in patches:
            raise ValueError(f"unknown ColorChecker patch {patch!r}")
        name = patch
    return spectrum_values(patches[name], wavelengths)


def colorchecker_spectrum(patch: int | str) -> tuple[np.ndarray, np.ndarray]:
    """A patch as a ``(wavelengths, values)`` :data:`SpectrumLike` on its native 5 nm grid."""
    return WAVELENGTHS_REFERENCE.copy(), colorchecker(patch, WAVELENGTHS_REFERENCE)
