"""A model evaluated as a measured table's readers look the table up: in its cells.

MERL's readers (Matusik's ``BRDFRead.cpp``, wdas/brdf) return the sample of the cell a
pair's Rusinkiewicz angles (θh, θd, φd) fall in, and so does
:class:`~spectral_materials.core.formats.merl.MERLBRDF`, the protocol's reference for
measured data. A smooth model of such a table (the factor packs and the lobe, or the
analytic model the table was written from) differs from the reader by the table's own
binning: for Ashikhmin–Shirley 32/32 written as MERL, the analytic model measures ΔE94
0.515 / 1.728 / 30.2 (mean / p95 / max) against the table read back
(``docs/bench_measured.md``, the "binning" row), more than the goals of issue 18 allow
any method.

A model drawn *in cells* is evaluated at the centre of the pair's cell, and that BRDF
value is weighted by the pair's own cosθi: what the reader returns for a table sampled
at its cell centres (as ``merl.merl_table_from_brdf`` writes one).

Cells whose centre lies below the horizon hold no measurement (the −1 markers), and the
reader fills them from their valid face neighbours (``core/formats/merl_fill.py``, first
pass: the plain mean). In cells, such a cell takes the mean of the model at those of its
six face neighbours' centres that lie above the horizon, or the model at the pair itself
where none does (cells two or more steps below the horizon, which pairs above it reach
only within a fraction of a degree of grazing).

The grid is MERL's: θh in ``n_h`` cells with square-root spacing, θd in ``n_d`` linear
cells over [0, π/2], φd folded into [0, π) by reciprocity in ``n_p`` cells. A pair is
evaluated at its cell's centre on its own half of the φd circle, which a reciprocal BRDF
allows (the reader folds; a model that is not reciprocal would differ on the upper half).
``glsl/brdf/measured_cells.glsl`` mirrors :func:`in_cells`.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from .params import _hd_forward, _hd_inverse

#: (θh, θd, φd) cells of a MERL file.
MERL_SHAPE = (90, 90, 180)
#: Most cells along one axis a model may name (a hostile file's count stays a small int).
MAX_CELLS = 4096
#: Smallest cosθi a cell centre's f·cosθi is divided by (a centre within 0.006° of the
#: horizon), as ``FactoredBRDF.evaluate`` divides.
MIN_CENTRE_COSINE = 1e-4
_HALF_PI = 0.5 * math.pi
#: The six face neighbours (Δθh, Δθd, Δφd) of a cell.
NEIGHBOUR_STEPS = ((-1, 0, 0), (1, 0, 0), (0, -1, 0), (0, 1, 0), (0, 0, -1), (0, 0, 1))


def cell_indices(theta_h: np.ndarray, theta_d: np.ndarray, phi_d: np.ndarray,
                 shape: tuple[int, int, int] = MERL_SHAPE
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(θh, θd, φd) indices of the cells the angles (radians) fall in.

    θh index = ⌊√(θh/(π/2))·n_h⌋ (0 for θh ≤ 0), θd index = ⌊θd/(π/2)·n_d⌋, both clamped;
    φd anywhere in [0, 2π) or (−π, π] is folded by reciprocity ((π, 2π) → (0, π), π itself
    kept and clamped to the last cell, as the reference adds π to a negative ``atan2``).
    Non-finite angles count as 0.
    """
    n_h, n_d, n_p = (int(n) for n in shape)
    th, td, pd = (np.nan_to_num(np.asarray(a, dtype=np.float64), nan=0.0, posinf=0.0,
                                neginf=0.0) for a in (theta_h, theta_d, phi_d))
    ih = np.floor(np.sqrt(np.maximum(th, 0.0) / _HALF_PI) * n_h)
    ih = np.clip(ih, 0, n_h - 1).astype(np.int64)
    idd = np.clip(np.floor(td / _HALF_PI * n_d), 0, n_d - 1).astype(np.int64)
    pd = np.mod(pd, 2.0 * math.pi)
    pd = np.where(pd > math.pi, pd - math.pi, pd)
    ip = np.clip(np.floor(pd / math.pi * n_p), 0, n_p - 1).astype(np.int64)
    return ih, idd, ip


def centre_angles(ih: np.ndarray, idd: np.ndarray, ip: np.ndarray,
                  shape: tuple[int, int, int] = MERL_SHAPE
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(θh, θd, φd) at the centres of cells (ih, idd, ip): θh = ((i + ½)/n_h)²·π/2,
    θd = (j + ½)/n_d·π/2, φd = (k + ½)/n_p·π (k may step outside [0, n_p): the angle
    continues across the seam)."""
    n_h, n_d, n_p = (int(n) for n in shape)
    th = ((np.asarray(ih, dtype=np.float64) + 0.5) / n_h) ** 2 * _HALF_PI
    td = (np.asarray(idd, dtype=np.float64) + 0.5) / n_d * _HALF_PI
    pd = (np.asarray(ip, dtype=np.float64) + 0.5) / n_p * math.pi
    return th, td, pd


def _centre_pairs(ih, idd, ip, phi_h, upper, shape) -> tuple[np.ndarray, np.ndarray]:
    """The directions at cells' centres, about each pair's own φh and on its own half of
    the φd circle (``upper``: φd folded from (π, 2π))."""
    th, td, pd = centre_angles(ih, idd, ip, shape)
    return _hd_inverse(th, phi_h, td, pd + np.where(upper, math.pi, 0.0))


def _lit(wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
    return (wi[:, 2] > 0.0) & (wo[:, 2] > 0.0)


def in_cells(stored: Callable[[np.ndarray, np.ndarray], np.ndarray], wi: np.ndarray,
             wo: np.ndarray, cosine_weighted: bool,
             shape: tuple[int, int, int] = MERL_SHAPE) -> np.ndarray:
    """``stored`` evaluated in cells (module docstring) at pairs (N, 3), (N, 3).

    ``stored(wi, wo) -> (N, S)`` is the model's stored quantity: ``f·cosθi`` when
    ``cosine_weighted``, else ``f``. Returns the same quantity for the pairs: the cell's
    ``f`` times the pair's cosθi (or the cell's ``f``). Pairs below the horizon get
    whatever their cell gives; callers zero them.
    """
    wi = np.asarray(wi, dtype=np.float64)
    wo = np.asarray(wo, dtype=np.float64)
    th, ph, td, pd = _hd_forward(wi, wo)
    ih, idd, ip = cell_indices(th, td, pd, shape)
    upper = np.mod(np.nan_to_num(pd), 2.0 * math.pi) > math.pi

    def brdf(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        values = stored(a, b)
        if cosine_weighted:
            values = values / np.maximum(a[:, 2:3], MIN_CENTRE_COSINE)
        return values

    wi_c, wo_c = _centre_pairs(ih, idd, ip, ph, upper, shape)
    valid = _lit(wi_c, wo_c)
    if valid.all():
        out = brdf(wi_c, wo_c)
    else:
        centres = brdf(wi_c[valid], wo_c[valid])
        out = np.zeros((wi.shape[0], centres.shape[1]))
        out[valid] = centres
        hidden = np.nonzero(~valid)[0]
        out[hidden] = _filled(brdf, wi[hidden], wo[hidden], (ih[hidden], idd[hidden],
                              ip[hidden]), ph[hidden], upper[hidden], shape,
                              centres.shape[1])
    if cosine_weighted:
        out = out * np.clip(wi[:, 2:3], 0.0, None)
    return out


def _filled(brdf, wi, wo, cells, phi_h, upper, shape, columns: int) -> np.ndarray:
    """The fill's first pass for cells whose centre is below the horizon: the mean of the
    BRDF at the face neighbours' centres above it, or at the pair itself where none is."""
    ih, idd, ip = cells
    n_h, n_d, _ = shape
    total = np.zeros((wi.shape[0], columns))
    count = np.zeros(wi.shape[0])
    for dh, dd, dp in NEIGHBOUR_STEPS:
        jh, jd = ih + dh, idd + dd
        inside = (jh >= 0) & (jh < n_h) & (jd >= 0) & (jd < n_d)
        a, b = _centre_pairs(np.clip(jh, 0, n_h - 1), np.clip(jd, 0, n_d - 1), ip + dp,
                             phi_h, upper, shape)
        take = inside & _lit(a, b)
        if take.any():
            total[take] += brdf(a[take], b[take])
            count[take] += 1
    out = total / np.maximum(count, 1)[:, None]
    alone = count == 0
    if alone.any():
        out[alone] = brdf(wi[alone], wo[alone])
    return out
