"""What both separable algorithms share: the :class:`SeparableFactors` they return, the
checks of their inputs, the tensor's reshaping into a matrix (:func:`matrix_view`) and the
float64 row blocks they stream the table through."""

from __future__ import annotations

import math
import operator
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from ..errors import InvalidBRDFData

Split = tuple[Sequence[int], Sequence[int]]

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
