"""Zonal harmonics (functions symmetric about +z): the clamped-cosine and spherical-cap
kernels, their rotation to any axis, and convolution by Funk–Hecke."""

from __future__ import annotations

import math

import numpy as np

from .sh_functions import (
    _FOUR_PI,
    DEFAULT_BANDS,
    _bands_of,
    _check_bands,
    _per_band,
    sh_basis,
)

# --------------------------------------------------------------------------- zonal kernels


def clamped_cosine_zonal(bands: int = DEFAULT_BANDS) -> np.ndarray:
    """Zonal coefficients ``z_l`` of ``max(cos θ, 0)`` about +z.

    ``z_l = 2π √((2l+1)/(4π)) ∫_0^1 t P_l(t) dt`` with ::

        ∫_0^1 t P_l dt = 1/2                                   l = 0
                         1/3                                   l = 1
                         0                                     l odd > 1
                         (−1)^(l/2+1) C(l, l/2) / (2^l (l−1)(l+2))  l even ≥ 2

    giving ``√π/2, √(π/3), √(5π)/8, 0, −√π/16, 0, √(13π)/128, …``
    (Ramamoorthi & Hanrahan 2001).

    Returns
    -------
    ndarray, shape (bands,)
    """
    bands = _check_bands(bands)
    out = np.zeros(bands)
    for l in range(bands):
        if l == 0:
            moment = 0.5
        elif l == 1:
            moment = 1.0 / 3.0
        elif l % 2:
            moment = 0.0
        else:
            sign = -1.0 if (l // 2) % 2 == 0 else 1.0
            moment = sign * math.comb(l, l // 2) / (2.0**l * (l - 1) * (l + 2))
        out[l] = 2.0 * math.pi * math.sqrt((2 * l + 1) / _FOUR_PI) * moment
    return out


def cap_zonal(bands: int, half_angle: float) -> np.ndarray:
    """Zonal coefficients of the indicator of a spherical cap about +z.

    The cap is ``{θ ≤ half_angle}`` (e.g. a sun of angular radius 0.27°):
    ``z_0 = 2π N_0 (1 − cos α)``, ``z_l = 2π N_l (P_{l−1}(cos α) − P_{l+1}(cos α))
    / (2l+1)``, ``N_l = √((2l+1)/(4π))``. Scale by the radiance to get a disc light.

    Returns
    -------
    ndarray, shape (bands,)
    """
    bands = _check_bands(bands)
    alpha = float(half_angle)
    if not 0.0 <= alpha <= math.pi:
        raise ValueError(f"half_angle must be in [0, π] radians, got {half_angle!r}")
    t = math.cos(alpha)
    legendre = [1.0, t]  # P_0 … P_bands at t
    for k in range(2, bands + 1):
        legendre.append(((2 * k - 1) * t * legendre[-1] - (k - 1) * legendre[-2]) / k)
    out = np.empty(bands)
    out[0] = 2.0 * math.pi * (1.0 - t) / math.sqrt(_FOUR_PI)
    for l in range(1, bands):
        integral = (legendre[l - 1] - legendre[l + 1]) / (2 * l + 1)
        out[l] = 2.0 * math.pi * math.sqrt((2 * l + 1) / _FOUR_PI) * integral
    return out


def _funk_hecke(bands: int) -> np.ndarray:
    l = np.arange(bands)
    return np.sqrt(_FOUR_PI / (2 * l + 1))


def zonal_to_sh(zonal, axis) -> np.ndarray:
    """Rotate a zonal function (symmetric about +z) to symmetry axis ``axis``.

    ``c_lm = √(4π/(2l+1)) z_l Y_lm(axis)`` (addition theorem), so that
    ``evaluate(zonal_to_sh(z, a), d) = Σ_l z_l Y_l0(a·d)``.

    Parameters
    ----------
    zonal : array_like, shape (..., bands)
    axis : array_like, shape (..., 3)
        Normalised here; leading shapes broadcast with ``zonal``'s.

    Returns
    -------
    ndarray, shape (..., bands²)
    """
    zonal = np.asarray(zonal, dtype=np.float64)
    if zonal.ndim == 0:
        raise ValueError("zonal must have shape (..., bands)")
    bands = _check_bands(zonal.shape[-1], "zonal length (bands)")
    if not np.isfinite(zonal).all():
        raise ValueError("zonal contains non-finite (NaN/inf) values")
    basis = sh_basis(axis, bands)
    scaled = zonal * _funk_hecke(bands)
    return scaled[..., _per_band(bands)] * basis


def convolve_zonal(coeffs, zonal) -> np.ndarray:
    """Convolve SH coefficients with a zonal kernel (Funk–Hecke).

    ``out_lm = √(4π/(2l+1)) z_l c_lm`` is the projection of
    ``g(n) = ∫ f(ω) k(n·ω) dω`` where ``k`` has zonal coefficients ``z_l``.
    With :func:`clamped_cosine_zonal` this turns radiance into irradiance
    (Ramamoorthi & Hanrahan 2001).

    Parameters
    ----------
    coeffs : array_like, shape (..., bands²)
    zonal : array_like, shape (..., bands)
        Per-band kernel coefficients; leading shapes broadcast.

    Returns
    -------
    ndarray, broadcast shape, SH axis last.
    """
    coeffs = np.asarray(coeffs, dtype=np.float64)
    zonal = np.asarray(zonal, dtype=np.float64)
    if coeffs.ndim == 0 or zonal.ndim == 0:
        raise ValueError("coeffs and zonal need at least one axis")
    bands = _bands_of(coeffs.shape[-1], "coeffs")
    if zonal.shape[-1] != bands:
        raise ValueError(
            f"zonal has {zonal.shape[-1]} bands but coeffs have {bands} ({bands * bands} "
            "coefficients)")
    return coeffs * (zonal * _funk_hecke(bands))[..., _per_band(bands)]
