"""The real SH basis (conventions in :mod:`.sh`): band checks, the basis by recurrence,
evaluation of coefficient arrays, and the sphere quadrature to project onto it."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

DEFAULT_BANDS = 5
"""Bands used by spectral PRT (l = 0 … 4, 25 coefficients)."""

MAX_BANDS = 32
"""Largest supported band count (l ≤ 31, 1024 coefficients)."""

_FOUR_PI = 4.0 * math.pi
_SQRT2 = math.sqrt(2.0)


# --------------------------------------------------------------------------- validation


def _check_bands(bands, name: str = "bands") -> int:
    if isinstance(bands, bool) or not isinstance(bands, int | np.integer):
        raise ValueError(f"{name} must be an integer in 1..{MAX_BANDS}, got {bands!r}")
    bands = int(bands)
    if not 1 <= bands <= MAX_BANDS:
        raise ValueError(f"{name} must be in 1..{MAX_BANDS}, got {bands}")
    return bands


def _bands_of(count: int, what: str) -> int:
    bands = math.isqrt(count)
    if bands * bands != count or not 1 <= bands <= MAX_BANDS:
        raise ValueError(
            f"{what} last axis must hold bands² coefficients with bands in 1..{MAX_BANDS}, "
            f"got {count}")
    return bands


def _unit_directions(directions, name: str = "directions") -> np.ndarray:
    d = np.asarray(directions, dtype=np.float64)
    if d.ndim == 0 or d.shape[-1] != 3:
        raise ValueError(f"{name} must have shape (..., 3), got {d.shape}")
    if d.size == 0:
        return d.copy()
    bad = ~np.isfinite(d).all(axis=-1)
    if bad.any():
        raise ValueError(
            f"{name} contain {int(bad.sum())} non-finite (NaN/inf) vector(s) of {bad.size}")
    scale = np.abs(d).max(axis=-1, keepdims=True)
    zero = scale[..., 0] == 0.0
    if zero.any():
        raise ValueError(f"{name} contain {int(zero.sum())} zero vector(s) of {zero.size}")
    d = d / scale
    return d / np.sqrt(np.sum(d * d, axis=-1, keepdims=True))


def _per_band(bands: int) -> np.ndarray:
    """Degree ``l`` of every coefficient index, shape ``(bands²,)``."""
    return np.repeat(np.arange(bands), 2 * np.arange(bands) + 1)


# --------------------------------------------------------------------------- basis


def sh_count(bands: int = DEFAULT_BANDS) -> int:
    """Number of coefficients of ``bands`` SH bands, ``bands²``.

    Raises
    ------
    ValueError
        If ``bands`` is not an integer in ``1..MAX_BANDS``.
    """
    bands = _check_bands(bands)
    return bands * bands


def sh_indices(bands: int = DEFAULT_BANDS) -> tuple[np.ndarray, np.ndarray]:
    """Degree ``l`` and order ``m`` of each coefficient index (``i = l² + l + m``)."""
    bands = _check_bands(bands)
    l = _per_band(bands)
    m = np.arange(bands * bands) - l * l - l
    return l, m


def sh_basis(directions, bands: int = DEFAULT_BANDS) -> np.ndarray:
    """Real orthonormal SH ``Y_i(d)`` for ``i < bands²`` (see module conventions).

    Parameters
    ----------
    directions : array_like, shape (..., 3)
        Directions (normalised here; need not be unit length).
    bands : int
        Number of bands ``L``, 1..:data:`MAX_BANDS`.

    Returns
    -------
    ndarray, shape (..., bands²)
        ``out[..., l*l + l + m] = Y_lm(d)``.

    Raises
    ------
    ValueError
        Wrong shape, bands out of range, zero vectors or NaN/inf components
        (the message gives how many).

    Notes
    -----
    Stable recurrences (e.g. Green 2003; Sloan 2013, "Efficient spherical
    harmonic evaluation")::

        N_m^m   = N_{m−1}^{m−1} √((2m+1)/(2m)),        N_0^0 = 1/√(4π)
        N_{m+1}^m = √(2m+3) z N_m^m
        N_l^m   = a_lm (z N_{l−1}^m − b_lm N_{l−2}^m),
        a_lm = √((4l²−1)/(l²−m²)),  b_lm = √(((l−1)²−m²)/(4(l−1)²−1))

    for ``N_l^m P̄_l^m(z)``, times ``Re/Im (x + iy)^m`` built by complex
    multiplication.
    """
    bands = _check_bands(bands)
    d = _unit_directions(directions)
    lead = d.shape[:-1]
    out = np.empty(lead + (bands * bands,), dtype=np.float64)
    if d.size == 0:
        return out
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    c = np.ones(lead)
    s = np.zeros(lead)
    nmm = 1.0 / math.sqrt(_FOUR_PI)  # N_m^m P̄_m^m(z) is a constant
    for m in range(bands):
        if m > 0:
            c, s = x * c - y * s, x * s + y * c
            nmm *= math.sqrt((2 * m + 1) / (2 * m))
        p_prev2 = None
        p_prev = np.full(lead, nmm)
        for l in range(m, bands):
            if l == m:
                p = p_prev
            elif l == m + 1:
                p = math.sqrt(2 * m + 3) * z * p_prev
            else:
                a = math.sqrt((4 * l * l - 1) / (l * l - m * m))
                b = math.sqrt(((l - 1) ** 2 - m * m) / (4 * (l - 1) ** 2 - 1))
                p = a * (z * p_prev - b * p_prev2)
            if l > m:
                p_prev2, p_prev = p_prev, p
            centre = l * l + l
            if m == 0:
                out[..., centre] = p
            else:
                out[..., centre + m] = _SQRT2 * p * c
                out[..., centre - m] = _SQRT2 * p * s
    return out


def evaluate(coeffs, directions) -> np.ndarray:
    """Reconstruct ``Σ_i c_i Y_i(d)``.

    ``coeffs`` has shape ``(..., bands²)`` (the SH axis last); directions
    ``(..., 3)``. The result has shape ``directions.shape[:-1] + coeffs.shape[:-1]``.
    """
    coeffs = np.asarray(coeffs, dtype=np.float64)
    if coeffs.ndim == 0:
        raise ValueError("coeffs must have at least one axis (the SH axis)")
    bands = _bands_of(coeffs.shape[-1], "coeffs")
    basis = sh_basis(directions, bands)
    return np.tensordot(basis, coeffs, axes=([-1], [-1]))


# --------------------------------------------------------------------------- quadrature


def sphere_quadrature(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Product Gauss–Legendre (in ``cos θ``) × uniform (in φ) rule on the sphere.

    Parameters
    ----------
    n : int
        Gauss–Legendre nodes in ``z = cos θ`` (1..4096); ``2n`` equally spaced
        azimuths ``φ_k = 2π (k + ½) / (2n)``.

    Returns
    -------
    directions : ndarray, shape (2n², 3)
        Unit vectors (none at the poles).
    weights : ndarray, shape (2n²,)
        Positive, summing to 4π.

    Notes
    -----
    Exact for every spherical polynomial of degree ≤ ``2n − 1`` (Gauss–Legendre
    is exact for degree ``2n − 1`` in ``z``, the trapezoid rule for azimuthal
    frequencies ``< 2n``). Products ``Y_i Y_j`` of ``L`` bands have degree
    ``2L − 2``, so ``n ≥ L`` integrates the Gram matrix exactly.
    """
    if isinstance(n, bool) or not isinstance(n, int | np.integer) or not 1 <= n <= 4096:
        raise ValueError(f"quadrature order n must be an integer in 1..4096, got {n!r}")
    n = int(n)
    z, wz = np.polynomial.legendre.leggauss(n)
    phi = (np.arange(2 * n) + 0.5) * (math.pi / n)
    r = np.sqrt(np.clip(1.0 - z * z, 0.0, None))
    dirs = np.stack(np.broadcast_arrays(r[:, None] * np.cos(phi)[None, :],
                                        r[:, None] * np.sin(phi)[None, :],
                                        z[:, None]), axis=-1).reshape(-1, 3)
    weights = np.repeat(wz * (math.pi / n), 2 * n)
    return dirs, weights


def project(values, basis, weights) -> np.ndarray:
    """Project sampled values onto SH: ``c_i = Σ_q w_q f(d_q) Y_i(d_q)``.

    Parameters
    ----------
    values : array_like, shape (Q,) or (Q, *channels)
        ``f`` at the quadrature directions (quadrature axis first, e.g. a
        spectrum per direction).
    basis : array_like, shape (Q, K)
        ``sh_basis(directions, bands)``.
    weights : array_like, shape (Q,)
        Quadrature weights (e.g. from :func:`sphere_quadrature`).

    Returns
    -------
    ndarray, shape (*channels, K)
        Coefficients, SH axis last.
    """
    values = np.asarray(values, dtype=np.float64)
    basis = np.asarray(basis, dtype=np.float64)
    weights = np.asarray(weights, dtype=np.float64)
    if basis.ndim != 2:
        raise ValueError(f"basis must have shape (Q, K), got {basis.shape}")
    q = basis.shape[0]
    if weights.shape != (q,):
        raise ValueError(f"weights must have shape ({q},), got {weights.shape}")
    if values.ndim == 0 or values.shape[0] != q:
        raise ValueError(f"values must have shape ({q}, ...), got {values.shape}")
    if not np.isfinite(values).all():
        bad = int(np.count_nonzero(~np.isfinite(values)))
        raise ValueError(f"values contain {bad} non-finite (NaN/inf) entries")
    weighted = basis * weights[:, None]
    return np.tensordot(values, weighted, axes=([0], [0]))


def project_function(f: Callable[[np.ndarray], np.ndarray], bands: int = DEFAULT_BANDS,
                     n: int | None = None) -> np.ndarray:
    """SH coefficients of ``f`` by :func:`sphere_quadrature` of order ``n``.

    Parameters
    ----------
    f : callable
        ``f(directions (Q, 3)) -> (Q,)`` or ``(Q, *channels)``.
    bands : int
        Bands to keep.
    n : int, optional
        Quadrature order; default ``max(2 * bands, 16)``. Exact (up to
        rounding) when ``f`` is a spherical polynomial of degree
        ``≤ 2n − bands``; for non-smooth ``f`` (caps, clamped cosines) raise it.

    Returns
    -------
    ndarray, shape (*channels, bands²)
    """
    bands = _check_bands(bands)
    if n is None:
        n = max(2 * bands, 16)
    dirs, weights = sphere_quadrature(n)
    return project(f(dirs), sh_basis(dirs, bands), weights)
