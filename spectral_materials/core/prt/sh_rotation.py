"""Rotation of SH coefficient vectors: the block-diagonal ``M(R)`` by the Ivanic–Ruedenberg
recursion (convention in :mod:`.sh`)."""

from __future__ import annotations

import numpy as np

from .sh_functions import DEFAULT_BANDS, _bands_of, _check_bands

# --------------------------------------------------------------------------- rotation


def _check_rotation(rotation) -> np.ndarray:
    r = np.asarray(rotation, dtype=np.float64)
    if r.shape != (3, 3):
        raise ValueError(f"rotation must have shape (3, 3), got {r.shape}")
    if not np.isfinite(r).all():
        raise ValueError("rotation contains non-finite (NaN/inf) values")
    err = float(np.abs(r.T @ r - np.eye(3)).max())
    if err > 1e-6:
        raise ValueError(f"rotation is not orthogonal (max |RᵀR − I| = {err:.3g} > 1e-6)")
    return r


def _band_p(i: int, a: np.ndarray, b: np.ndarray, l: int, r1: np.ndarray,
            prev: np.ndarray) -> np.ndarray:
    """Ivanic–Ruedenberg ``P(i, l, a, b)`` (1998 errata), vectorised over (a, b).

    Out-of-range ``a`` are clipped; every such term has a zero coefficient.
    """
    lp = l - 1
    ai = np.clip(a, -lp, lp) + lp
    bi = np.clip(b, -lp, lp) + lp
    row = r1[i + 1]
    top = row[2] * prev[ai, 2 * lp] - row[0] * prev[ai, 0]
    bottom = row[2] * prev[ai, 0] + row[0] * prev[ai, 2 * lp]
    middle = row[1] * prev[ai, bi]
    return np.where(b == l, top, np.where(b == -l, bottom, middle))


def _next_band(l: int, r1: np.ndarray, prev: np.ndarray) -> np.ndarray:
    m, n = np.meshgrid(np.arange(-l, l + 1), np.arange(-l, l + 1), indexing="ij")
    am = np.abs(m)
    m0 = (m == 0).astype(np.float64)
    denom = np.where(np.abs(n) == l, 2 * l * (2 * l - 1), (l + n) * (l - n)).astype(np.float64)
    u = np.sqrt((l + m) * (l - m) / denom)
    v = 0.5 * np.sqrt((1.0 + m0) * (l + am - 1) * (l + am) / denom) * (1.0 - 2.0 * m0)
    w = -0.5 * np.sqrt((l - am - 1) * (l - am) / denom) * (1.0 - m0)

    big_u = _band_p(0, m, n, l, r1, prev)

    d1 = (m == 1).astype(np.float64)
    dm1 = (m == -1).astype(np.float64)
    v_zero = _band_p(1, np.ones_like(m), n, l, r1, prev) + \
        _band_p(-1, -np.ones_like(m), n, l, r1, prev)
    v_pos = _band_p(1, m - 1, n, l, r1, prev) * np.sqrt(1.0 + d1) - \
        _band_p(-1, -m + 1, n, l, r1, prev) * (1.0 - d1)
    v_neg = _band_p(1, m + 1, n, l, r1, prev) * (1.0 - dm1) + \
        _band_p(-1, -m - 1, n, l, r1, prev) * np.sqrt(1.0 + dm1)
    big_v = np.where(m == 0, v_zero, np.where(m > 0, v_pos, v_neg))

    w_pos = _band_p(1, m + 1, n, l, r1, prev) + _band_p(-1, -m - 1, n, l, r1, prev)
    w_neg = _band_p(1, m - 1, n, l, r1, prev) - _band_p(-1, -m + 1, n, l, r1, prev)
    big_w = np.where(m > 0, w_pos, np.where(m < 0, w_neg, 0.0))

    return u * big_u + v * big_v + w * big_w


def rotation_matrix_sh(rotation, bands: int = DEFAULT_BANDS) -> np.ndarray:
    """Block-diagonal SH rotation matrix ``M(R)``, shape ``(bands², bands²)``.

    Convention: ``sh_basis(d @ R.T, L) == sh_basis(d, L) @ M.T`` (``y(R d) = M y(d)``);
    the coefficients of ``f`` rotated by ``R`` are ``M @ c`` (see :func:`rotate`);
    ``M(R1 @ R2) = M(R1) @ M(R2)``; ``M`` is orthogonal.

    Parameters
    ----------
    rotation : array_like, shape (3, 3)
        Orthogonal matrix (``|RᵀR − I| ≤ 1e-6``). Proper rotations give
        ``det M = 1``; improper ones (reflections) are accepted too and act on
        band ``l`` as the O(3) representation (inversion ``−I`` gives ``(−1)^l``).
    bands : int

    Returns
    -------
    ndarray, shape (bands², bands²)

    Notes
    -----
    Band 1 is ``R`` permuted to the (y, z, x) ordering; band ``l`` follows from
    bands 1 and ``l − 1`` by the recurrence of Ivanic & Ruedenberg (1996) with
    the corrections of their 1998 erratum: ``M^l_mn = u U + v V + w W``. No
    re-projection or trigonometry; cost ``O(L³)``.
    """
    bands = _check_bands(bands)
    r = _check_rotation(rotation)
    size = bands * bands
    out = np.zeros((size, size))
    out[0, 0] = 1.0
    if bands == 1:
        return out
    perm = [1, 2, 0]
    r1 = r[np.ix_(perm, perm)]
    out[1:4, 1:4] = r1
    prev = r1
    for l in range(2, bands):
        block = _next_band(l, r1, prev)
        out[l * l:(l + 1) ** 2, l * l:(l + 1) ** 2] = block
        prev = block
    return out


def rotate(coeffs, rotation) -> np.ndarray:
    """Coefficients of ``f`` rotated by ``R``: ``g(d) = f(Rᵀ d)``, i.e. ``c @ M(R).T``.

    ``coeffs`` has shape ``(..., bands²)``.
    """
    coeffs = np.asarray(coeffs, dtype=np.float64)
    if coeffs.ndim == 0:
        raise ValueError("coeffs must have at least one axis (the SH axis)")
    bands = _bands_of(coeffs.shape[-1], "coeffs")
    return coeffs @ rotation_matrix_sh(rotation, bands).T
