"""Peercy's linear-model spectral basis.

An orthonormal basis Ψ (L × m) found by an SVD over the spectra a scene needs:
reflectance spectra of its materials and its light spectra premultiplied by the
colour matching functions. The reflected colour ``∫ R(λ) I(λ) dλ`` then becomes
the dot product of the two coefficient vectors (Schwenk et al. 2010, eq. 9).

Orthonormality is with respect to the plain sum over the wavelength samples:
``Ψᵀ Ψ = I``. Every input spectrum is scaled to unit norm before the SVD, so
that dim, spiky light × CMF products weigh as much as bright reflectances.

References
----------
Peercy, M. S. (1993). Linear color representations for full speed spectral
rendering. SIGGRAPH '93, 191–198.
Schwenk, K., Kuijper, A., Bockholt, U. (2010). Modeling wavelength-dependent
BRDFs as factored tensors for real-time spectral rendering. GRAPP 2010, §3.5.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from . import spectra


@dataclass(frozen=True)
class LinearModelBasis:
    """An orthonormal spectral basis on a wavelength grid.

    Attributes
    ----------
    wavelengths : ndarray (L,)
        nm.
    vectors : ndarray (L, m)
        Orthonormal columns, ``vectors.T @ vectors == I``.
    singular_values : ndarray (K,)
        All singular values of the (column-normalised) input matrix, for
        choosing another size later.
    """

    wavelengths: np.ndarray
    vectors: np.ndarray
    singular_values: np.ndarray

    @property
    def size(self) -> int:
        return int(self.vectors.shape[1])

    def project(self, values: np.ndarray) -> np.ndarray:
        """Coefficients of spectra ``(..., L)`` → ``(..., m)``."""
        values = np.asarray(values)
        if values.shape[-1] != self.wavelengths.size:
            raise ValueError(
                f"spectra have {values.shape[-1]} samples, the basis has {self.wavelengths.size}"
            )
        dtype = np.float32 if values.dtype == np.float32 else np.float64
        return values @ self.vectors.astype(dtype)

    def reconstruct(self, coefficients: np.ndarray) -> np.ndarray:
        """Spectra ``(..., L)`` from coefficients ``(..., m)``."""
        return np.asarray(coefficients) @ self.vectors.T

    def relative_error(self, values: np.ndarray) -> np.ndarray:
        """Relative L2 projection error of each spectrum in ``values (..., L)``."""
        values = np.asarray(values, dtype=np.float64)
        residual = values - self.reconstruct(self.project(values))
        norm = np.linalg.norm(values, axis=-1)
        return np.linalg.norm(residual, axis=-1) / np.where(norm > 0, norm, 1.0)


def light_cmf_spectra(
    illuminants: Iterable[str | np.ndarray], wavelengths: np.ndarray, *,
    observer: str = spectra.OBSERVER,
) -> np.ndarray:
    """Light × CMF products for each illuminant (name or SPD array) → (3·n, L).

    Rows ``3i, 3i+1, 3i+2`` are illuminant ``i`` times x̄, ȳ, z̄ of ``observer``
    (see :func:`spectra.cmfs`; the protocol's 1931 2° by default).
    """
    from .pipeline import illuminant_spd

    wl = spectra.check_wavelengths(wavelengths)
    cmf = spectra.cmfs(wl, observer)
    rows = []
    for light in illuminants:
        spd = illuminant_spd(light, wl)
        rows.extend((spd * cmf[:, c]) for c in range(3))
    return np.asarray(rows)


def linear_model_basis(
    wavelengths: np.ndarray,
    reflectances: np.ndarray,
    light_cmf: np.ndarray | None = None,
    *,
    count: int | None = None,
    tolerance: float | None = None,
) -> LinearModelBasis:
    """Peercy's linear model: the SVD basis of reflectances and light × CMF spectra.

    Parameters
    ----------
    wavelengths : ndarray (L,)
    reflectances : ndarray (K, L)
        Reflectance spectra of the materials (e.g. BRDF spectra sampled every 10°).
    light_cmf : ndarray (J, L), optional
        Light SPD × CMF products (see :func:`light_cmf_spectra`).
    count : int, optional
        Number of basis vectors.
    tolerance : float, optional
        Otherwise: the smallest basis whose worst relative projection error over
        all input spectra is ≤ ``tolerance``. If neither is given, 1e-3.

    Returns
    -------
    LinearModelBasis
    """
    wl = spectra.check_wavelengths(wavelengths)
    blocks = [np.atleast_2d(np.asarray(reflectances, dtype=np.float64))]
    if light_cmf is not None:
        blocks.append(np.atleast_2d(np.asarray(light_cmf, dtype=np.float64)))
    matrix = np.concatenate(blocks, axis=0)
    if matrix.shape[1] != wl.size:
        raise ValueError(f"spectra have {matrix.shape[1]} samples, wavelengths {wl.size}")
    if not np.isfinite(matrix).all():
        bad = int((~np.isfinite(matrix)).sum())
        raise ValueError(f"basis input has {bad} non-finite values")
    norms = np.linalg.norm(matrix, axis=1)
    matrix = matrix[norms > 0] / norms[norms > 0, None]
    if matrix.shape[0] == 0:
        raise ValueError("basis input spectra are all zero")
    # Columns of the SVD matrix are spectra, as in Peercy: U spans wavelength space.
    u, s, _ = np.linalg.svd(matrix.T, full_matrices=False)
    rank_limit = int(np.sum(s > s[0] * 1e-12))
    if count is not None:
        # At most min(L, number of nonzero input spectra) singular vectors exist.
        if not 1 <= count <= u.shape[1]:
            raise ValueError(f"basis count must be 1..{u.shape[1]}, got {count}")
        m = int(count)
    else:
        tol = 1e-3 if tolerance is None else float(tolerance)
        if not 0 < tol < 1:
            raise ValueError(f"basis tolerance must be in (0, 1), got {tolerance}")
        m = rank_limit
        for k in range(1, rank_limit + 1):
            residual = matrix - (matrix @ u[:, :k]) @ u[:, :k].T
            if np.linalg.norm(residual, axis=1).max() <= tol:
                m = k
                break
    vectors = u[:, :m]
    # Sign convention: the first sample of largest magnitude positive, so bases are reproducible.
    signs = np.sign(vectors[np.abs(vectors).argmax(axis=0), np.arange(m)])
    vectors = vectors * np.where(signs == 0, 1.0, signs)
    return LinearModelBasis(wavelengths=wl.copy(), vectors=vectors, singular_values=s)
