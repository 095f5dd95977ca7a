"""Separable BRDF approximations: truncated SVD and normalized decomposition.

A tabulated BRDF tensor ``table`` of shape ``(n_0, …, n_{d-1}, m)`` (``d``
angular axes, then a spectral axis of ``m`` wavelengths or spectral-basis
coefficients) is reshaped into a matrix ``M[x, (y, λ)]``: the rows are the
flattened *row* angular axes, the columns the flattened *column* angular axes
followed by the spectral axis (both in C order). A separable expansion

    M(x, (y, λ)) ≈ Σ_k g_k(x) · h_k(y, λ)

is then found with one of the two algorithms of Kautz & McCool (1999), §4:

* :func:`separable_svd` — the truncated singular value decomposition, the
  optimal rank-K approximation in the Frobenius (RMS) norm (Eckart–Young).
  Small matrices go through LAPACK directly; matrices whose float64 copy would
  exceed ``max_bytes`` go through a randomized SVD (Halko, Martinsson & Tropp
  2011, Algorithms 4.4 and 5.1) whose products with ``M`` are formed block by
  block from the input table, so the full matrix is never copied.
* :func:`normalized_decomposition` — the normalized decomposition (ND): the
  first factor is the p-norm of each row, the second the average normalized
  row profile; further terms approximate the sequential residuals. It streams
  through the table in row blocks and keeps only the output factors.

References
----------
Kautz, J., McCool, M. D. (1999). Interactive rendering with arbitrary BRDFs
using separable approximations. Eurographics Workshop on Rendering, §4.
Halko, N., Martinsson, P. G., Tropp, J. A. (2011). Finding structure with
randomness: probabilistic algorithms for constructing approximate matrix
decompositions. SIAM Review 53(2), 217–288.
Eckart, C., Young, G. (1936). The approximation of one matrix by another of
lower rank. Psychometrika 1(3), 211–218.

The algorithms live in :mod:`.truncated_svd` and :mod:`.normalized`, what they share in
:mod:`.separable_layout`; this module re-exports their public names.
"""

from __future__ import annotations

from ..errors import Cancelled
from .normalized import normalized_decomposition
from .separable_layout import SeparableFactors, Split, matrix_view  # noqa: F401 (Split)
from .truncated_svd import separable_svd

__all__ = [
    "Cancelled",
    "SeparableFactors",
    "matrix_view",
    "normalized_decomposition",
    "separable_svd",
]
