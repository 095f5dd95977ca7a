"""Reflectance-field fits, one per view and texel: the biquadratic RFP (Malzbender et al.
2001) and the non-linear RFNL of eq. (1) in the stable form, with its solvers and the
conversion from the paper's lobe parameters."""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from ..progress import ProgressCallback, report
from . import lm as btf_lm
from .container import BTF
from .fit_models import (
    RFNLModel,
    RFPModel,
    _base_fields,
    _sum_histories,
    rfp_basis,
    spectral_albedo,
)
from .fit_rfnl_start import _rfnl_init
from .lm import A_MAX, LOG_A_MIN, N_MAX, N_MIN

# -------------------------------------------------------------------------- RFP


def fit_rfp(btf: BTF, *, callback: ProgressCallback | None = None, seed: int = 0
            ) -> RFPModel:
    """Biquadratic reflectance fields (Malzbender et al. 2001; paper §4.1, "RFP").

    One linear least-squares solve per view with all texels as right-hand sides, over the
    view's present lights. A view with fewer than 6 present lights is dropped. When the
    present lights do not determine all six coefficients (e.g. all on one ring, where
    ``lu² + lv²`` is constant), ``lstsq`` returns the minimum-norm fit — still the best fit
    of the samples. ``seed`` is unused (the fit is deterministic); it is accepted so that
    every entry of :data:`METHODS` takes the same arguments.
    """
    del seed
    start = time.perf_counter()
    lum = btf.luminance()
    h, w = btf.texels
    basis = rfp_basis(btf.lights)
    kept, dropped, params = [], [], []
    for v in range(len(btf.views)):
        report(callback, v / len(btf.views), f"RFP view {v + 1}/{len(btf.views)}")
        present = btf.present[v]
        if present.sum() < 6:
            dropped.append(v)
            continue
        rhs = lum[v, present].reshape(int(present.sum()), -1).astype(np.float64)
        coef = np.linalg.lstsq(basis[present], rhs, rcond=None)[0]
        kept.append(v)
        params.append(coef.T.reshape(h, w, 6).astype(np.float32))
    fields = _base_fields(btf, kept, dropped)
    report(callback, 1.0, "RFP done")
    return RFPModel(kind="RFP", params=np.stack(params), albedo=spectral_albedo(btf),
                    fit_seconds=time.perf_counter() - start, **fields)


# -------------------------------------------------------------------------- RFNL


def lobes_from_paper(rho_s, t, n) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Convert the paper's lobe ``ρs (t·l)^n`` (t of any length) to the stable ``(a, t̂, n)``.

    ``a = ρs |t|^n`` is formed in log space, ``exp(min(n log|t| + log ρs, log A_MAX))``, so
    it never overflows (|t| = 3, n = 500 gives 3^500 ≈ 1e238 in the paper's form; here
    a = A_MAX). A lobe with ``ρs ≤ 0`` or ``t = 0`` gets ``a = 0``. ``n`` is clamped to
    ``[N_MIN, N_MAX]`` *after* a is formed from the given n (a is the lobe's peak value).

    Returns
    -------
    a : ndarray (...)
    t_hat : ndarray (..., 3)
        Unit axes (+z for t = 0).
    n : ndarray (...)
    """
    rho_s = np.asarray(rho_s, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)
    n = np.asarray(n, dtype=np.float64)
    norm = np.linalg.norm(t, axis=-1)
    valid = (norm > 0.0) & (rho_s > 0.0)
    log_a = n * np.log(np.where(valid, norm, 1.0)) + np.log(np.where(valid, rho_s, 1.0))
    # exp(log A_MAX) rounds above A_MAX: clamp after the exponential too.
    a = np.where(valid, np.minimum(np.exp(np.minimum(log_a, np.log(A_MAX))), A_MAX), 0.0)
    return a, btf_lm.normalise(t), np.clip(n, N_MIN, N_MAX)


def paper_overflows(rho_s, t, n, dtype=np.float32) -> np.ndarray:
    """Whether the paper's lobe overflows at its peak when evaluated in ``dtype``.

    Evaluates ``ρs · (t · l)^n`` as a shader would, in ``dtype``, at ``l = t̂`` (the lobe's
    maximum, ``t·l = |t|``); True where the result is inf or NaN (the white pixels of §5.3).
    """
    dtype = np.dtype(dtype)
    t = np.asarray(t, dtype=dtype)
    l_peak = btf_lm.normalise(t.astype(np.float64)).astype(dtype)
    with np.errstate(over="ignore", invalid="ignore"):
        dot = np.sum(t * l_peak, axis=-1, dtype=dtype)
        value = np.asarray(rho_s, dtype=dtype) * np.power(dot, np.asarray(n, dtype=dtype))
    return ~np.isfinite(value)


def _solve_batched(states, lights, data, mask, lobes, *, iterations, ftol):
    result = btf_lm.rfnl_lm(states, lights, data, mask, lobes, iterations=iterations,
                            ftol=ftol)
    return result.x, result.cost, result.history


def _solve_scipy(states, lights, data, mask, lobes, *, iterations, ftol):
    states = btf_lm.rfnl_project(states, lobes)
    start = btf_lm.rfnl_cost(states, lights, data, mask, lobes)
    x, cost = btf_lm.rfnl_scipy(states, lights, data, mask, lobes, ftol=ftol, xtol=ftol)
    # MINPACK ignores the bounds; where clamping its answer made it worse than the start,
    # keep the start (as LM never accepts a step that raises the cost).
    worse = ~(cost <= start)
    x = np.where(worse[:, None], states, x)
    cost = np.where(worse, start, cost)
    return x, cost, np.array([start.sum(), cost.sum()])


#: RFNL solvers: ``solver(states, lights, data, mask, lobes, *, iterations, ftol) ->
#: (states, cost, history)``. "batched": :func:`.btf_lm.rfnl_lm` (all texels at once);
#: "scipy": :func:`scipy.optimize.least_squares` (MINPACK LM) per texel — the reference.
RFNL_SOLVERS: dict[str, Callable] = {"batched": _solve_batched, "scipy": _solve_scipy}


def _row_blocks(n_views: int, per_view: int, chunk: int):
    """Blocks of at most ``chunk`` (view, texel) rows, view-major, as lists of
    ``(view_position, texel_start, texel_stop)`` segments."""
    total = n_views * per_view
    for r0 in range(0, total, chunk):
        r1 = min(r0 + chunk, total)
        segments = []
        for p in range(r0 // per_view, (r1 - 1) // per_view + 1):
            segments.append((p, max(r0, p * per_view) - p * per_view,
                             min(r1, (p + 1) * per_view) - p * per_view))
        yield segments


def fit_rfnl(btf: BTF, *, lobes: int = 2, solver: str = "batched", iterations: int = 60,
             ftol: float = 1e-10, separation_deg: float = 25.0,
             initial_exponent: float | None = None, chunk_size: int = 4096,
             callback: ProgressCallback | None = None, seed: int = 0) -> RFNLModel:
    """Non-linear reflectance fields, eq. (1) in the stable form (paper §4.1, "RFNL").

    Per view and texel ``Y(l) ≈ ρd + Σ_{j ≤ k} a_j max(t̂_j·l, 0)^{n_j}`` over the view's
    present lights; unknowns ``ρd, log a_j, two tangent-plane angles of t̂_j, log n_j``
    (1 + 4k), clamped to ``ρd ∈ [0, A_MAX]``, ``a ∈ [A_MIN, A_MAX]``, ``n ∈ [N_MIN,
    N_MAX]``. Start: :func:`_rfnl_init` (high-pass principal directions). Solver: see
    :data:`RFNL_SOLVERS`.

    Parameters
    ----------
    lobes : int
        k ≥ 1.
    solver : str
        Key of :data:`RFNL_SOLVERS`.
    iterations : int
        LM iteration limit of the batched solver (SciPy uses MINPACK's own limit).
    ftol : float
        Relative cost decrease below which a problem counts as converged.
    separation_deg : float
        Minimum angle between initial lobe axes.
    initial_exponent : float, optional
        Start every n here instead of estimating it from the peak width.
    chunk_size : int
        (view, texel) problems solved together (memory ≈ chunk · L · (1 + 4k) · 8 B).
    seed : int
        Unused (deterministic); accepted for a uniform interface.

    Returns
    -------
    RFNLModel
        ``history``: total ``½ Σ r²`` over all fitted (view, texel) problems per iteration
        (non-increasing). A problem whose fit is non-finite or worse than the safe state
        ``ρd = mean, no lobes`` stores the safe state instead.
    """
    del seed
    if lobes < 1:
        raise ValueError(f"lobes must be ≥ 1, got {lobes}")
    if solver not in RFNL_SOLVERS:
        raise ValueError(f"unknown RFNL solver {solver!r}; choose from {sorted(RFNL_SOLVERS)}")
    start = time.perf_counter()
    k = lobes
    lum = btf.luminance()
    h, w = btf.texels
    hw = h * w
    unknowns = btf_lm.rfnl_step_size(k)
    counts = btf.present.sum(axis=1)
    kept = [v for v in range(len(btf.views)) if counts[v] >= unknowns]
    dropped = [v for v in range(len(btf.views)) if counts[v] < unknowns]
    fields = _base_fields(btf, kept, dropped)
    lum_rows = lum.reshape(lum.shape[0], lum.shape[1], hw)
    header = -(-(1 + k) // 4)
    params = np.zeros((len(kept), hw, 4 * (header + k)), np.float32)
    histories = []
    blocks = list(_row_blocks(len(kept), hw, max(1, int(chunk_size))))
    for b, segments in enumerate(blocks):
        report(callback, b / len(blocks), f"RFNL block {b + 1}/{len(blocks)}")
        states, data, masks = [], [], []
        for pos, t0, t1 in segments:
            v = kept[pos]
            present = btf.present[v]
            y = lum_rows[v, :, t0:t1].astype(np.float64)          # (L, n)
            states.append(_rfnl_init(btf.lights[present], y[present], k, separation_deg,
                                     initial_exponent))
            data.append(np.nan_to_num(y.T))
            masks.append(np.broadcast_to(present, (t1 - t0, len(present))))
        states, data, mask = np.concatenate(states), np.concatenate(data), \
            np.concatenate(masks)
        mask = None if mask.all() else mask
        x, cost, history = RFNL_SOLVERS[solver](states, btf.lights, data, mask, k,
                                                iterations=iterations, ftol=ftol)
        x, cost = _rfnl_safe(x, cost, data, mask, k)
        histories.append(np.append(history, cost.sum()))
        packed = _rfnl_pack(x, k, header)
        r = 0
        for pos, t0, t1 in segments:
            params[pos, t0:t1] = packed[r:r + t1 - t0]
            r += t1 - t0
    report(callback, 1.0, "RFNL done")
    return RFNLModel(kind="RFNL", params=params.reshape(len(kept), h, w, -1), lobes=k,
                     solver=solver, albedo=spectral_albedo(btf), history=_sum_histories(
                         histories), fit_seconds=time.perf_counter() - start, **fields)


def _rfnl_safe(x, cost, data, mask, lobes):
    """Replace non-finite fits, or fits worse than ``ρd = mean, no lobes``, by that state
    (a = A_MIN there; :func:`_rfnl_pack` stores it as 0)."""
    weight = np.ones_like(data) if mask is None else mask.astype(np.float64)
    count = np.maximum(weight.sum(axis=1), 1.0)
    mean = (data * weight).sum(axis=1) / count
    safe_cost = 0.5 * (((data - mean[:, None]) ** 2) * weight).sum(axis=1)
    bad = ~np.isfinite(x).all(axis=1) | ~np.isfinite(cost) | (cost > safe_cost)
    if np.any(bad):
        n = int(bad.sum())
        axes = np.zeros((n, lobes, 3))
        axes[..., 2] = 1.0
        x = x.copy()
        x[bad] = btf_lm.rfnl_join(np.clip(mean[bad], 0.0, A_MAX),
                                  np.full((n, lobes), LOG_A_MIN), axes, np.zeros((n, lobes)))
        cost = np.where(bad, safe_cost, cost)
    return x, cost


def _rfnl_pack(x: np.ndarray, lobes: int, header: int) -> np.ndarray:
    """Solver states → the float32 RGBA layout (lobes sorted by decreasing a; a lobe at the
    amplitude floor is stored as a = 0, axis +z, n = 1)."""
    rho_d, log_a, axes, log_n = btf_lm.rfnl_split(x, lobes)
    absent = log_a <= LOG_A_MIN + 1e-6
    a = np.where(absent, 0.0, np.minimum(np.exp(np.minimum(log_a, np.log(A_MAX))), A_MAX))
    n = np.where(absent, 1.0, np.clip(np.exp(log_n), N_MIN, N_MAX))
    axes = np.where(absent[..., None], [0.0, 0.0, 1.0], axes)
    order = np.argsort(-a, axis=1, kind="stable")
    a = np.take_along_axis(a, order, axis=1)
    n = np.take_along_axis(n, order, axis=1)
    axes = np.take_along_axis(axes, order[..., None], axis=1)
    out = np.zeros((len(x), 4 * (header + lobes)), np.float32)
    out[:, 0] = np.clip(rho_d, 0.0, A_MAX)
    out[:, 1:1 + lobes] = a
    lobe_block = out[:, 4 * header:].reshape(len(x), lobes, 4)
    lobe_block[..., :3] = axes
    lobe_block[..., 3] = n
    return out
