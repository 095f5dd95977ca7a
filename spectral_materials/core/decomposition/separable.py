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
"""

from __future__ import annotations

import math
import operator
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike

from ..errors import Cancelled, InvalidBRDFData
from ..progress import ProgressCallback, report

__all__ = [
    "Cancelled",
    "SeparableFactors",
    "matrix_view",
    "normalized_decomposition",
    "separable_svd",
]

Split = tuple[Sequence[int], Sequence[int]]

# Working budget for one row block of the ND passes (float64 bytes).
_ND_BLOCK_BYTES = 32 * 2**20


@dataclass(frozen=True)
class SeparableFactors:
    """A separable expansion ``M ≈ g @ h.T`` of a reshaped BRDF tensor.

    Attributes
    ----------
    row_axes, col_axes : tuple of int
        The angular axes of the original tensor that index the rows (``x``)
        and the columns (``y``) of the matrix.
    row_shape, col_shape : tuple of int
        Angular shapes of the two groups, in the order of ``row_axes`` and
        ``col_axes``.
    spectral_size : int
        Length ``m`` of the spectral axis (last axis of the tensor, always
        part of the columns).
    g : ndarray (prod(row_shape), K), float32
        Row factors ``g_k(x)``. For the SVD the singular values are folded in.
    h : ndarray (prod(col_shape) · m, K), float32
        Column factors ``h_k(y, λ)``, ``λ`` varying fastest.
    method : str
        ``"svd"`` or ``"nd"``.
    """

    row_axes: tuple[int, ...]
    col_axes: tuple[int, ...]
    row_shape: tuple[int, ...]
    col_shape: tuple[int, ...]
    spectral_size: int
    g: np.ndarray
    h: np.ndarray
    method: str

    def __post_init__(self) -> None:
        rows = math.prod(self.row_shape)
        cols = math.prod(self.col_shape) * int(self.spectral_size)
        if len(self.row_axes) != len(self.row_shape) or len(self.col_axes) != len(self.col_shape):
            raise ValueError("row/col axes and shapes have different lengths")
        if self.g.ndim != 2 or self.h.ndim != 2 or self.g.shape[1] != self.h.shape[1]:
            raise ValueError(f"factor shapes {self.g.shape} and {self.h.shape} do not match")
        if self.g.shape[0] != rows or self.h.shape[0] != cols:
            raise ValueError(
                f"factors {self.g.shape}, {self.h.shape} do not fit a {rows} × {cols} matrix"
            )

    @property
    def terms(self) -> int:
        """Number of separable terms ``K``."""
        return int(self.g.shape[1])

    @property
    def nbytes(self) -> int:
        """Storage of the two factor matrices in bytes."""
        return int(self.g.nbytes + self.h.nbytes)

    @property
    def shape(self) -> tuple[int, ...]:
        """Shape of the reconstructed tensor, in the original axis order."""
        angular = dict(zip(self.row_axes, self.row_shape, strict=True))
        angular.update(zip(self.col_axes, self.col_shape, strict=True))
        return tuple(angular[a] for a in range(len(angular))) + (int(self.spectral_size),)

    def reconstruct(self, terms: int | None = None) -> np.ndarray:
        """The approximated tensor ``(n_0, …, n_{d-1}, m)`` in the original axis order.

        Parameters
        ----------
        terms : int, optional
            Use only the first ``terms`` terms (default: all).

        Returns
        -------
        ndarray, float32, C-contiguous.
        """
        k = self.terms if terms is None else int(terms)
        if not 0 <= k <= self.terms:
            raise ValueError(f"terms must be 0..{self.terms}, got {terms}")
        g = np.asarray(self.g[:, :k], dtype=np.float32)
        h = np.asarray(self.h[:, :k], dtype=np.float32)
        matrix = g @ h.T
        grouped = matrix.reshape(self.row_shape + self.col_shape + (int(self.spectral_size),))
        perm = self.row_axes + self.col_axes
        inverse = np.argsort(perm).tolist() + [len(perm)]
        return np.ascontiguousarray(grouped.transpose(inverse))


# ---------------------------------------------------------------------------
# Validation and the 2-D reshaping
# ---------------------------------------------------------------------------


@dataclass(frozen=True)
class _Layout:
    """How the tensor maps onto the matrix."""

    row_axes: tuple[int, ...]
    col_axes: tuple[int, ...]
    row_shape: tuple[int, ...]
    col_shape: tuple[int, ...]
    spectral_size: int

    @property
    def perm(self) -> tuple[int, ...]:
        return self.row_axes + self.col_axes + (len(self.row_axes) + len(self.col_axes),)

    @property
    def n_rows(self) -> int:
        return math.prod(self.row_shape)

    @property
    def n_cols(self) -> int:
        return math.prod(self.col_shape) * self.spectral_size

    def factors(self, g: np.ndarray, h: np.ndarray, method: str) -> SeparableFactors:
        return SeparableFactors(
            row_axes=self.row_axes,
            col_axes=self.col_axes,
            row_shape=self.row_shape,
            col_shape=self.col_shape,
            spectral_size=self.spectral_size,
            g=np.ascontiguousarray(g, dtype=np.float32),
            h=np.ascontiguousarray(h, dtype=np.float32),
            method=method,
        )


def _as_table(table: ArrayLike) -> np.ndarray:
    arr = np.asarray(table)
    if arr.dtype.kind not in "fiub":
        raise ValueError(f"table must be a real float array, got dtype {arr.dtype}")
    if arr.dtype.kind != "f":
        arr = arr.astype(np.float64)
    if arr.ndim < 2:
        raise ValueError(
            f"table needs at least one angular axis and a spectral axis, got shape {arr.shape}"
        )
    if arr.size == 0:
        raise ValueError(f"table is empty, shape {arr.shape}")
    return arr


def _axes(group: Iterable[int], name: str) -> tuple[int, ...]:
    try:
        return tuple(operator.index(a) for a in group)
    except TypeError as exc:
        raise ValueError(f"split {name} axes must be integers, got {group!r}") from exc


def _layout(table: np.ndarray, split: Split) -> _Layout:
    try:
        rows_in, cols_in = split
    except (TypeError, ValueError) as exc:
        raise ValueError(f"split must be a pair (row_axes, col_axes), got {split!r}") from exc
    rows, cols = _axes(rows_in, "row"), _axes(cols_in, "col")
    d = table.ndim - 1
    if not rows:
        raise ValueError("split has no row axes")
    given = rows + cols
    bad = [a for a in given if not 0 <= a < d]
    if bad:
        raise ValueError(f"split axes {bad} out of range: the table has angular axes 0..{d - 1}")
    duplicated = sorted({a for a in given if given.count(a) > 1})
    if duplicated:
        raise ValueError(f"split axes {duplicated} appear more than once")
    missing = sorted(set(range(d)) - set(given))
    if missing:
        raise ValueError(f"split misses angular axes {missing}")
    return _Layout(
        row_axes=rows,
        col_axes=cols,
        row_shape=tuple(table.shape[a] for a in rows),
        col_shape=tuple(table.shape[a] for a in cols),
        spectral_size=int(table.shape[-1]),
    )


def _check_terms(terms: int, layout: _Layout) -> int:
    k = operator.index(terms)
    limit = min(layout.n_rows, layout.n_cols)
    if not 1 <= k <= limit:
        raise ValueError(
            f"terms must be 1..{limit} for a {layout.n_rows} × {layout.n_cols} matrix, got {terms}"
        )
    return k


def _check_finite(table: np.ndarray, weights: np.ndarray | None = None) -> None:
    """Raise if ``table`` has non-finite values (where ``weights`` ≠ 0, if given)."""
    per_slice = max(1, table[0].size)
    step = max(1, (16 * 2**20) // per_slice)
    bad = 0
    for i in range(0, table.shape[0], step):
        finite = np.isfinite(table[i : i + step])
        if weights is not None:
            finite |= (weights[i : i + step] == 0)[..., None]
        bad += int(finite.size - np.count_nonzero(finite))
    if bad:
        where = " where the weights are non-zero" if weights is not None else ""
        raise InvalidBRDFData(f"table has {bad} non-finite values (NaN or inf){where}")


def matrix_view(table: ArrayLike, split: Split) -> np.ndarray:
    """The 2-D reshaping ``M[x, (y, λ)]`` of ``table`` for ``split``.

    Rows are the flattened ``row_axes`` (C order), columns the flattened
    ``col_axes`` followed by the spectral axis (C order). A view where the axis
    order allows it, otherwise a copy. The dtype is kept.
    """
    arr = _as_table(table)
    layout = _layout(arr, split)
    return arr.transpose(layout.perm).reshape(layout.n_rows, layout.n_cols)


class _RowBlocks:
    """Float64 row blocks of the matrix of a tensor, without copying the whole tensor."""

    def __init__(
        self,
        table: np.ndarray,
        layout: _Layout,
        block_bytes: int,
        weights: np.ndarray | None = None,
    ) -> None:
        self.layout = layout
        self.grouped = table.transpose(layout.perm)
        self.contiguous = self.grouped.flags.c_contiguous
        # Angular weights grouped as row_shape + col_shape (a broadcast view, no copy).
        self.weights = None if weights is None else weights.transpose(layout.perm[:-1])
        per_row = 8 * layout.n_cols * (3 if weights is None else 5)
        self.block_rows = int(min(layout.n_rows, max(1, block_bytes // per_row)))

    def _gather(self, arr: np.ndarray, start: int, stop: int) -> np.ndarray:
        shape = self.layout.row_shape
        if len(shape) == 1:
            return arr[start:stop]
        index = np.unravel_index(np.arange(start, stop), shape)
        return arr[index]

    def __iter__(self) -> Iterator[tuple[int, int, np.ndarray, np.ndarray | None]]:
        lay = self.layout
        flat = self.grouped.reshape(lay.n_rows, lay.n_cols) if self.contiguous else None
        for start in range(0, lay.n_rows, self.block_rows):
            stop = min(start + self.block_rows, lay.n_rows)
            if flat is not None:
                raw = flat[start:stop]
            else:
                raw = self._gather(self.grouped, start, stop)
            block = np.asarray(raw, dtype=np.float64).reshape(stop - start, lay.n_cols)
            wblock = None
            if self.weights is not None:
                w = self._gather(self.weights, start, stop).reshape(stop - start, -1)
                wblock = np.repeat(np.asarray(w, dtype=np.float64), lay.spectral_size, axis=1)
                block = np.where(wblock > 0, block, 0.0)
            yield start, stop, block, wblock


# ---------------------------------------------------------------------------
# SVD
# ---------------------------------------------------------------------------


def _fix_signs(u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Flip term signs so the largest-magnitude entry of each column of ``v`` is positive."""
    if v.shape[1] == 0:
        return u, v
    pivots = v[np.abs(v).argmax(axis=0), np.arange(v.shape[1])]
    signs = np.where(pivots < 0, -1.0, 1.0)
    return u * signs, v * signs


def _lapack_svd(matrix: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    try:
        return scipy.linalg.svd(
            matrix, full_matrices=False, check_finite=False, lapack_driver="gesdd"
        )
    except np.linalg.LinAlgError:
        return scipy.linalg.svd(
            matrix, full_matrices=False, check_finite=False, lapack_driver="gesvd"
        )


def _truncated_svd(matrix: np.ndarray, terms: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Leading ``terms`` singular triplets ``U (rows, K), s (K,), V (cols, K)``.

    ``matrix`` is a private float64 array and is overwritten. LAPACK's divide and
    conquer is slow on strongly rectangular matrices (30 s vs 2 s for 1024 × 16384
    with OpenBLAS), so those are QR-reduced first, in place, and the SVD is taken of
    the small triangular factor; only the kept columns of the long factor are formed.
    """
    rows, cols = matrix.shape
    if cols >= 4 * rows:
        q, r = scipy.linalg.qr(matrix.T, mode="economic", check_finite=False, overwrite_a=True)
        w, s, zt = _lapack_svd(r.T)  # M = Rᵀ Qᵀ = W S (Q Z)ᵀ
        return w[:, :terms], s[:terms], q @ zt[:terms].T
    if rows >= 4 * cols:
        q, r = scipy.linalg.qr(matrix, mode="economic", check_finite=False, overwrite_a=True)
        w, s, vt = _lapack_svd(r)  # M = Q R = (Q W) S Vᵀ
        return q @ w[:, :terms], s[:terms], vt[:terms].T
    u, s, vt = _lapack_svd(matrix)
    return u[:, :terms], s[:terms], vt[:terms].T


def _randomized_svd(
    blocks: _RowBlocks,
    terms: int,
    oversample: int,
    power_iterations: int,
    seed: int,
    callback: ProgressCallback | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Halko et al. (2011) Alg. 4.4 (randomized subspace iteration) + Alg. 5.1.

    Every product with ``M`` or ``Mᵀ`` streams over the row blocks.
    """
    lay = blocks.layout
    n_rows, n_cols = lay.n_rows, lay.n_cols
    width = min(terms + max(0, int(oversample)), n_rows, n_cols)
    passes = 2 + 2 * max(0, int(power_iterations))
    done = 0

    def step(stop: int, what: str) -> None:
        report(
            callback,
            (done + stop / n_rows) / passes,
            f"randomized SVD ({width} columns): {what}, rows {stop}/{n_rows}",
        )

    def times(right: np.ndarray, what: str) -> np.ndarray:
        """M @ right, shape (n_rows, width)."""
        out = np.empty((n_rows, right.shape[1]))
        for start, stop, block, _ in blocks:
            out[start:stop] = block @ right
            step(stop, what)
        return out

    def transposed_times(left: np.ndarray, what: str) -> np.ndarray:
        """Mᵀ @ left, shape (n_cols, width)."""
        out = np.zeros((n_cols, left.shape[1]))
        for start, stop, block, _ in blocks:
            out += block.T @ left[start:stop]
            step(stop, what)
        return out

    rng = np.random.default_rng(seed)
    omega = rng.standard_normal((n_cols, width))
    report(callback, 0.0, f"randomized SVD ({width} columns): range finder")
    q, _ = np.linalg.qr(times(omega, "range finder"))
    done += 1
    del omega
    for it in range(max(0, int(power_iterations))):
        z, _ = np.linalg.qr(transposed_times(q, f"power iteration {it + 1}"))
        done += 1
        q, _ = np.linalg.qr(times(z, f"power iteration {it + 1}"))
        done += 1
        del z
    # B = Qᵀ M (width × n_cols), then the small SVD B = Ũ Σ Vᵀ, U = Q Ũ.
    b = transposed_times(q, "projection").T
    u_small, s, v = _truncated_svd(b, terms)
    return q @ u_small, s, v


def separable_svd(
    table: ArrayLike,
    split: Split,
    terms: int,
    *,
    max_bytes: int = 512 * 2**20,
    oversample: int = 10,
    power_iterations: int = 2,
    seed: int = 0,
    callback: ProgressCallback | None = None,
) -> SeparableFactors:
    """Truncated SVD of the reshaped tensor: ``g = U_K Σ_K``, ``h = V_K``.

    Parameters
    ----------
    table : ndarray (n_0, …, n_{d-1}, m)
        Tabulated BRDF, float32 or float64; must be finite.
    split : (row_axes, col_axes)
        A partition of the angular axes ``0..d-1``. The spectral axis goes with
        the columns.
    terms : int
        Number of terms K, ``1 ≤ K ≤ min(rows, cols)``.
    max_bytes : int
        If the float64 matrix fits in this many bytes it is decomposed exactly
        with LAPACK (peak about twice the matrix); otherwise a seeded randomized
        SVD is used whose products with the matrix are computed in row blocks
        of the input table (peak extra memory about ``max_bytes`` plus the
        ``(rows + cols) × (terms + oversample)`` work arrays).
    oversample, power_iterations, seed : int
        Randomized SVD parameters (Halko et al. 2011): extra sample columns,
        subspace iterations, and the seed of ``np.random.default_rng``.
    callback : callable(fraction, message) -> bool, optional
        Progress report; returning True raises :class:`Cancelled`.

    Returns
    -------
    SeparableFactors
        ``method="svd"``. Each term's sign is chosen so that the
        largest-magnitude entry of its ``h`` column is positive.
    """
    arr = _as_table(table)
    layout = _layout(arr, split)
    k = _check_terms(terms, layout)
    if int(max_bytes) <= 0:
        raise ValueError(f"max_bytes must be positive, got {max_bytes}")
    _check_finite(arr)
    n_rows, n_cols = layout.n_rows, layout.n_cols
    if 8 * n_rows * n_cols <= max_bytes:
        report(callback, 0.0, f"SVD of a {n_rows} × {n_cols} matrix")
        matrix = arr.transpose(layout.perm).reshape(n_rows, n_cols).astype(np.float64, copy=False)
        if np.shares_memory(matrix, arr):
            matrix = matrix.copy()  # _truncated_svd overwrites its input
        u, s, v = _truncated_svd(matrix, k)
        del matrix
    else:
        work = 8 * (k + max(0, int(oversample))) * (2 * n_cols + 2 * n_rows)
        blocks = _RowBlocks(arr, layout, max(int(max_bytes) - work, int(max_bytes) // 4))
        u, s, v = _randomized_svd(blocks, k, oversample, power_iterations, seed, callback)
    u, v = _fix_signs(u, v)
    report(callback, 1.0, f"SVD done: {k} terms, σ_1 = {s[0]:.6g}")
    return layout.factors(u * s, v, "svd")


# ---------------------------------------------------------------------------
# Normalized decomposition
# ---------------------------------------------------------------------------


def _row_pnorm(values: np.ndarray, weights: np.ndarray | None, p: float) -> np.ndarray:
    """Row p-norms ``(Σ_y |v|^p)^(1/p)``, or ``(Σ_y w |v|^p · C / Σ_y w)^(1/p)`` with weights."""
    mag = np.abs(values)
    if weights is not None:
        mag = np.where(weights > 0, mag, 0.0)
    peak = mag.max(axis=1)
    if math.isinf(p):
        return peak
    safe = np.where(peak > 0, peak, 1.0)
    scaled = mag / safe[:, None]  # avoids overflow/underflow of |v|^p
    if p == 2.0:
        powered = scaled * scaled
    elif p == 1.0:
        powered = scaled
    else:
        powered = scaled**p
    if weights is None:
        total = powered.sum(axis=1)
    else:
        wsum = weights.sum(axis=1)
        total = np.einsum("ij,ij->i", weights, powered) * (
            values.shape[1] / np.where(wsum > 0, wsum, 1.0)
        )
        total = np.where(wsum > 0, total, 0.0)
    return np.where(peak > 0, peak * total ** (1.0 / p), 0.0)


def normalized_decomposition(
    table: ArrayLike,
    split: Split,
    terms: int = 1,
    *,
    p: float = 2.0,
    weights: ArrayLike | None = None,
    block_bytes: int = _ND_BLOCK_BYTES,
    callback: ProgressCallback | None = None,
) -> SeparableFactors:
    """Kautz & McCool's normalized decomposition with sequential residual terms.

    For each term, on the residual ``R = M − Σ_{j<k} g_j h_jᵀ`` (``R = M`` for
    the first term):

    * ``g(x) = (Σ_y |R(x, y)|^p)^(1/p)`` — the discrete p-norm of each row,
      every column weighted equally;
    * ``h(y) = mean over rows x with g(x) > 0 of R(x, y) / g(x)`` — the
      average normalized profile (rows with ``g = 0`` are skipped);
    * the scalar ``s = ⟨R, g hᵀ⟩ / ‖g hᵀ‖²`` that best fits ``s·g hᵀ`` to
      ``R`` in least squares is folded into ``g``, so different ``p`` give
      comparable scales and each term can only lower the residual norm.

    Residuals have negative values (Kautz & McCool: "the additional terms
    will contain factors with negative values"), and rows whose profiles are
    opposite would cancel in the average. So when ``R`` has a negative entry,
    each row is given the sign of its correlation with a reference profile
    (that of the row of largest norm): ``g(x) = ±‖R(x, ·)‖_p`` and the mean is
    taken over the sign-aligned profiles. For a non-negative ``R`` (the first
    term of a BRDF) every sign is + and this is exactly the paper's ND.

    The table is streamed in float64 row blocks (two passes per term, three
    when signs are needed); only the factors and a few column-sized vectors are
    held in memory, never a float64 copy of the table.

    Parameters
    ----------
    table : ndarray (n_0, …, n_{d-1}, m)
        Tabulated BRDF, float32 or float64.
    split : (row_axes, col_axes)
        A partition of the angular axes; the spectral axis goes with the columns.
    terms : int
        Number of terms, ``1 ≤ terms ≤ min(rows, cols)``.
    p : float
        Norm exponent, ``p > 0`` (``np.inf`` for the max norm).
    weights : array_like, optional
        Non-negative weights broadcastable to the angular shape
        ``(n_0, …, n_{d-1})``, e.g. a validity mask (0 where the BRDF is
        undefined; the table may hold NaN there). Zero-weight entries are
        ignored; the row norm is rescaled by ``cols / Σ_y w`` so that partly
        masked rows are not penalised, ``h`` is a weighted mean, and the
        least-squares scale is weighted.
    block_bytes : int
        Approximate float64 working memory per row block.
    callback : callable(fraction, message) -> bool, optional
        Progress report; returning True raises :class:`Cancelled`.

    Returns
    -------
    SeparableFactors
        ``method="nd"``.
    """
    arr = _as_table(table)
    layout = _layout(arr, split)
    k_terms = _check_terms(terms, layout)
    p = float(p)
    if not (p > 0):
        raise ValueError(f"p must be positive, got {p}")
    w_angular = None
    if weights is not None:
        w = np.asarray(weights, dtype=np.float64)
        try:
            w_angular = np.broadcast_to(w, arr.shape[:-1])
        except ValueError as exc:
            raise ValueError(
                f"weights of shape {w.shape} do not broadcast to the angular shape "
                f"{arr.shape[:-1]}"
            ) from exc
        if not np.isfinite(w).all() or (w < 0).any():
            raise ValueError("weights must be finite and non-negative")
        if not (w > 0).any():
            raise ValueError("weights are all zero")
    if int(block_bytes) <= 0:
        raise ValueError(f"block_bytes must be positive, got {block_bytes}")
    _check_finite(arr, w_angular)

    n_rows, n_cols = layout.n_rows, layout.n_cols
    blocks = _RowBlocks(arr, layout, int(block_bytes), w_angular)
    g = np.zeros((n_rows, k_terms))
    h = np.zeros((n_cols, k_terms))
    # Passes per term: norms (+ profile if nothing is negative), signed profile, scale.
    passes = 3 * k_terms

    def residual(block: np.ndarray, start: int, stop: int, k: int) -> np.ndarray:
        if k == 0:
            return block
        return block - g[start:stop, :k] @ h[:, :k].T

    def progress(k: int, stage: int, stop: int, what: str) -> None:
        report(
            callback,
            (3 * k + stage + stop / n_rows) / passes,
            f"ND term {k + 1}/{k_terms}: {what}, rows {stop}/{n_rows}",
        )

    def accumulate(
        res: np.ndarray, wblock: np.ndarray | None, norms: np.ndarray, signs: np.ndarray | None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Σ_x w·R(x)/g(x) and Σ_x w over the rows with g > 0 (optionally sign-flipped)."""
        live = norms > 0
        scale = 1.0 / norms[live] if signs is None else signs[live] / norms[live]
        if wblock is None:
            return scale @ res[live], np.full(n_cols, float(np.count_nonzero(live)))
        wl = wblock[live]
        return scale @ (wl * res[live]), wl.sum(axis=0)

    for k in range(k_terms):
        # Pass 1: row norms g(x); the largest-norm row's profile is the sign reference.
        # If the residual has no negative entry, the profile average is taken right away.
        report(callback, 3 * k / passes, f"ND term {k + 1}/{k_terms}: norms")
        g_k = np.zeros(n_rows)
        h_sum = np.zeros(n_cols)
        h_count = np.zeros(n_cols)
        reference = np.zeros(n_cols)
        best = 0.0
        signed = False
        for start, stop, block, wblock in blocks:
            res = residual(block, start, stop, k)
            valid = res if wblock is None else np.where(wblock > 0, res, 0.0)
            norms = _row_pnorm(res, wblock, p)
            g_k[start:stop] = norms
            top = int(norms.argmax())
            if norms[top] > best:
                best = float(norms[top])
                reference = valid[top] / best
            if not signed and (valid < 0).any():
                signed = True
            if not signed:
                add, count = accumulate(res, wblock, norms, None)
                h_sum += add
                h_count += count
            progress(k, 0, stop, "norms")

        if signed:
            # Pass 2: a residual has rows of either sign, whose normalized profiles
            # would cancel in the average. Each row's g takes the sign of the row's
            # correlation with the reference profile, and the profile is flipped to match.
            h_sum[:] = 0.0
            h_count[:] = 0.0
            for start, stop, block, wblock in blocks:
                res = residual(block, start, stop, k)
                norms = g_k[start:stop]
                weighted = res if wblock is None else wblock * res
                signs = np.where(weighted @ reference < 0, -1.0, 1.0)
                add, count = accumulate(res, wblock, norms, signs)
                h_sum += add
                h_count += count
                g_k[start:stop] = norms * signs
                progress(k, 1, stop, "signed profile")
        h_k = np.divide(h_sum, h_count, out=np.zeros(n_cols), where=h_count > 0)

        # Pass 3: least-squares scale s = <R, g h> / ||g h||² (weighted if weights given).
        num = 0.0
        den = 0.0
        if blocks.weights is None:
            den = float(g_k @ g_k) * float(h_k @ h_k)
        h_sq = h_k * h_k
        for start, stop, block, wblock in blocks:
            res = residual(block, start, stop, k)
            gb = g_k[start:stop]
            if wblock is None:
                num += float(gb @ (res @ h_k))
            else:
                num += float(gb @ ((wblock * res) @ h_k))
                den += float((gb * gb) @ (wblock @ h_sq))
            progress(k, 2, stop, "scale")
        scale = num / den if den > 0 else 0.0
        g[:, k] = g_k * scale
        h[:, k] = h_k

    report(callback, 1.0, f"ND done: {k_terms} terms, p = {p:g}")
    return layout.factors(g, h, "nd")
