"""Kautz & McCool's normalized decomposition (ND) with sequential residual terms, streamed
through the table in float64 row blocks (see :func:`normalized_decomposition`)."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from ..progress import ProgressCallback, report
from .separable_layout import (
    SeparableFactors,
    Split,
    _as_table,
    _check_finite,
    _check_terms,
    _layout,
    _RowBlocks,
)

# Working budget for one row block of the ND passes (float64 bytes).
_ND_BLOCK_BYTES = 32 * 2**20


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



def _angular_weights(weights: ArrayLike | None, arr: np.ndarray) -> np.ndarray | None:
    """``weights`` broadcast to the angular shape, checked (finite, ≥ 0, not all 0)."""
    if weights is None:
        return None
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
    return w_angular


class _NDPasses:
    """The streaming passes of one ND term over the residual of the earlier terms: row
    norms (and the profile when nothing is negative), the signed profile, the scale."""

    def __init__(self, blocks: _RowBlocks, n_rows: int, n_cols: int, k_terms: int, p: float,
                 callback: ProgressCallback | None) -> None:
        self.blocks = blocks
        self.n_rows, self.n_cols = n_rows, n_cols
        self.k_terms, self.p = k_terms, p
        self.callback = callback
        self.g = np.zeros((n_rows, k_terms))
        self.h = np.zeros((n_cols, k_terms))
        # Passes per term: norms (+ profile if nothing is negative), signed profile, scale.
        self.passes = 3 * k_terms

    def residual(self, block: np.ndarray, start: int, stop: int, k: int) -> np.ndarray:
        if k == 0:
            return block
        return block - self.g[start:stop, :k] @ self.h[:, :k].T

    def progress(self, k: int, stage: int, stop: int, what: str) -> None:
        report(
            self.callback,
            (3 * k + stage + stop / self.n_rows) / self.passes,
            f"ND term {k + 1}/{self.k_terms}: {what}, rows {stop}/{self.n_rows}",
        )

    def accumulate(
        self, res: np.ndarray, wblock: np.ndarray | None, norms: np.ndarray,
        signs: np.ndarray | None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Σ_x w·R(x)/g(x) and Σ_x w over the rows with g > 0 (optionally sign-flipped)."""
        live = norms > 0
        scale = 1.0 / norms[live] if signs is None else signs[live] / norms[live]
        if wblock is None:
            return scale @ res[live], np.full(self.n_cols, float(np.count_nonzero(live)))
        wl = wblock[live]
        return scale @ (wl * res[live]), wl.sum(axis=0)

    def norms(self, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, bool]:
        """Pass 1: row norms g(x); the largest-norm row's profile is the sign reference.
        If the residual has no negative entry, the profile average is taken right away.
        Returns (g, Σ profile, Σ weight, reference, whether signs are needed)."""
        report(self.callback, 3 * k / self.passes, f"ND term {k + 1}/{self.k_terms}: norms")
        g_k = np.zeros(self.n_rows)
        h_sum = np.zeros(self.n_cols)
        h_count = np.zeros(self.n_cols)
        reference = np.zeros(self.n_cols)
        best = 0.0
        signed = False
        for start, stop, block, wblock in self.blocks:
            res = self.residual(block, start, stop, k)
            valid = res if wblock is None else np.where(wblock > 0, res, 0.0)
            norms = _row_pnorm(res, wblock, self.p)
            g_k[start:stop] = norms
            top = int(norms.argmax())
            if norms[top] > best:
                best = float(norms[top])
                reference = valid[top] / best
            if not signed and (valid < 0).any():
                signed = True
            if not signed:
                add, count = self.accumulate(res, wblock, norms, None)
                h_sum += add
                h_count += count
            self.progress(k, 0, stop, "norms")
        return g_k, h_sum, h_count, reference, signed

    def signed_profile(self, k: int, g_k: np.ndarray, h_sum: np.ndarray, h_count: np.ndarray,
                       reference: np.ndarray) -> None:
        """Pass 2: a residual has rows of either sign, whose normalized profiles would
        cancel in the average. Each row's g takes the sign of the row's correlation with
        the reference profile, and the profile is flipped to match (all in place)."""
        h_sum[:] = 0.0
        h_count[:] = 0.0
        for start, stop, block, wblock in self.blocks:
            res = self.residual(block, start, stop, k)
            norms = g_k[start:stop]
            weighted = res if wblock is None else wblock * res
            signs = np.where(weighted @ reference < 0, -1.0, 1.0)
            add, count = self.accumulate(res, wblock, norms, signs)
            h_sum += add
            h_count += count
            g_k[start:stop] = norms * signs
            self.progress(k, 1, stop, "signed profile")

    def scale(self, k: int, g_k: np.ndarray, h_k: np.ndarray) -> float:
        """Pass 3: least-squares scale s = <R, g h> / ||g h||² (weighted if weights given)."""
        num = 0.0
        den = 0.0
        if self.blocks.weights is None:
            den = float(g_k @ g_k) * float(h_k @ h_k)
        h_sq = h_k * h_k
        for start, stop, block, wblock in self.blocks:
            res = self.residual(block, start, stop, k)
            gb = g_k[start:stop]
            if wblock is None:
                num += float(gb @ (res @ h_k))
            else:
                num += float(gb @ ((wblock * res) @ h_k))
                den += float((gb * gb) @ (wblock @ h_sq))
            self.progress(k, 2, stop, "scale")
        return num / den if den > 0 else 0.0

    def term(self, k: int) -> None:
        """Term ``k`` of the residual of terms ``0 … k-1``, stored in ``g``, ``h``."""
        g_k, h_sum, h_count, reference, signed = self.norms(k)
        if signed:
            self.signed_profile(k, g_k, h_sum, h_count, reference)
        h_k = np.divide(h_sum, h_count, out=np.zeros(self.n_cols), where=h_count > 0)
        scale = self.scale(k, g_k, h_k)
        self.g[:, k] = g_k * scale
        self.h[:, k] = h_k


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
    w_angular = _angular_weights(weights, arr)
    if int(block_bytes) <= 0:
        raise ValueError(f"block_bytes must be positive, got {block_bytes}")
    _check_finite(arr, w_angular)

    blocks = _RowBlocks(arr, layout, int(block_bytes), w_angular)
    nd = _NDPasses(blocks, layout.n_rows, layout.n_cols, k_terms, p, callback)
    for k in range(k_terms):
        nd.term(k)
    report(callback, 1.0, f"ND done: {k_terms} terms, p = {p:g}")
    return layout.factors(nd.g, nd.h, "nd")
