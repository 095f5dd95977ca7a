"""Where the RFNL fit starts: lobe axes from the paper's high-pass principal directions
(§4.1) and exponents from a coarse scan, the cheapest candidate per texel."""

from __future__ import annotations

import numpy as np

from . import lm as btf_lm
from .fit_models import rfp_basis
from .lm import A_MAX, A_MIN, N_MAX, N_MIN

#: Exponents tried for each lobe at the start (a coarse, geometric "peak width" scan).
RFNL_EXPONENT_GRID = (1.5, 4.0, 12.0, 40.0, 150.0, 600.0)


def _rfnl_init(lights: np.ndarray, y: np.ndarray, lobes: int, separation_deg: float,
               initial_exponent: float | None) -> np.ndarray:
    """Start states ``[ρd, log a, t̂, log n]`` (n, 1 + 5k) for luminance ``y (P, n)`` over
    present ``lights (P, 3)``.

    Axes — the paper's principal-direction detection (§4.1): high-pass = data − its
    biquadratic (RFP) low-pass over the lights; lobe 1's axis is the light with the largest
    high-pass value, each further lobe's the largest among lights more than
    ``separation_deg`` from the earlier axes. Because the data include the foreshortening
    (a broad lobe about the normal that a high-pass filter removes), three more axis sets
    are tried: lobe 1 at the brightest light instead, and each of the two with its last
    lobe on the normal (0, 0, 1).

    Candidates — the paper-style start (:func:`_rfnl_paper_start`: peak heights, peak
    widths, ρd at a low percentile) on the high-pass axes; and for each axis set, each
    lobe's exponent chosen from :data:`RFNL_EXPONENT_GRID` by one coordinate-descent pass
    (or fixed at ``initial_exponent``), every candidate scored after solving (ρd, a_j) by
    linear least squares (amplitudes clipped at 0). The cheapest candidate per texel (by
    its cost before LM) is returned.

    Why not the paper's start alone: on synthetic diffuse + specular texels LM from the
    high-pass axes alone stops in local minima ~100× costlier than from the best of these
    candidates; the scan costs about as much as a few LM iterations.
    """
    p_count, n = y.shape
    k = lobes
    basis = rfp_basis(lights)
    high = y - basis @ np.linalg.lstsq(basis, y, rcond=None)[0]
    cos_light = np.clip(lights @ lights.T, -1.0, 1.0)
    cos_sep = np.cos(np.radians(separation_deg))
    scale = np.maximum(np.abs(y).max(axis=0), 1e-12)
    best_state = best_cost = None

    def peak_axes(first_raw: bool) -> tuple[np.ndarray, np.ndarray]:
        blocked = np.zeros((p_count, n), dtype=bool)
        axes = np.zeros((n, k, 3))
        peaks = np.zeros((n, k), dtype=np.int64)
        for j in range(k):
            source = y if (j == 0 and first_raw) else high
            score = np.where(blocked, -np.inf, source)
            score = np.where(blocked.all(axis=0)[None], source, score)  # too few lights
            peaks[:, j] = np.argmax(score, axis=0)
            axes[:, j] = lights[peaks[:, j]]
            blocked |= cos_light[peaks[:, j]].T > cos_sep
        return axes, peaks

    axis_sets = []
    for first_raw in (False, True):
        axes, peaks = peak_axes(first_raw)
        if not first_raw:
            best_state, best_cost = _rfnl_paper_start(y, lights, cos_light, peaks, cos_sep,
                                                      initial_exponent)
        axis_sets.append(axes)
        normal = axes.copy()
        normal[:, -1] = (0.0, 0.0, 1.0)
        axis_sets.append(normal)
    grid = RFNL_EXPONENT_GRID if initial_exponent is None else ()
    start_n = 8.0 if initial_exponent is None else float(np.clip(initial_exponent, N_MIN, N_MAX))
    for axes in axis_sets:
        shapes_of = np.einsum("nkc,pc->npk", axes, lights)                # (n, P, k)
        expo = np.full((n, k), start_n)
        current = _rfnl_linear(y, shapes_of, expo)
        for j in range(k):
            for g in grid:
                trial_n = expo.copy()
                trial_n[:, j] = g
                trial = _rfnl_linear(y, shapes_of, trial_n)
                better = trial[2] < current[2]
                expo = np.where(better[:, None], trial_n, expo)
                current = (np.where(better, trial[0], current[0]),
                           np.where(better[:, None], trial[1], current[1]),
                           np.where(better, trial[2], current[2]))
        rho, amp, cost = current
        # A lobe the linear fit did not want starts small but alive (LM may revive it).
        amp = np.clip(np.where(amp > 0, amp, 1e-3 * scale[:, None]), A_MIN, A_MAX)
        state = btf_lm.rfnl_join(rho, np.log(amp), axes, np.log(expo))
        better = cost < best_cost
        best_state = np.where(better[:, None], state, best_state)
        best_cost = np.minimum(cost, best_cost)
    return best_state


def _rfnl_paper_start(y, lights, cos_light, peaks, cos_sep, initial_exponent):
    """The paper-style start for the high-pass axes ``lights[peaks]`` and its cost:
    ρd = 10th percentile of the data; lobe by lobe, a = the peak's height above ρd and the
    earlier lobes, n from the peak's width (least squares of ``log(y/peak) = n log cos δ``
    over the lights within the separation angle; 8 where that is undetermined)."""
    n, k = peaks.shape
    col = np.arange(n)
    scale = np.maximum(np.abs(y).max(axis=0), 1e-12)
    rho0 = np.clip(np.percentile(y, 10.0, axis=0), 0.0, A_MAX)
    remaining = y - rho0
    amp, expo = np.zeros((n, k)), np.zeros((n, k))
    for j in range(k):
        c = cos_light[peaks[:, j]].T                                  # (P, n)
        peak = remaining[peaks[:, j], col]
        if initial_exponent is None:
            near = (c > cos_sep) & (c < 1.0 - 1e-9)
            ratio = np.clip(remaining / np.where(peak > 0, peak, 1.0)[None], 1e-6, 1.0)
            log_c = np.log(np.where(near, c, 1.0))
            den = np.sum(log_c * log_c, axis=0)
            width = np.sum(np.where(near, np.log(ratio) * log_c, 0.0), axis=0) / \
                np.where(den > 0, den, 1.0)
            expo[:, j] = np.clip(np.where((den > 0) & (peak > 0), width, 8.0), 1.0, 1000.0)
        else:
            expo[:, j] = np.clip(initial_exponent, N_MIN, N_MAX)
        amp[:, j] = np.clip(np.where(peak > 0, peak, 1e-3 * scale), A_MIN, A_MAX)
        remaining = remaining - amp[:, j] * _lobe_shape(c, expo[:, j])
    cost = 0.5 * np.sum(remaining * remaining, axis=0)
    return btf_lm.rfnl_join(rho0, np.log(amp), lights[peaks], np.log(expo)), cost


def _rfnl_linear(y: np.ndarray, cosines: np.ndarray, expo: np.ndarray):
    """``(ρd (n,), a (n, k), cost (n,))``: least squares for (ρd, a) with fixed lobe shapes
    ``max(cos, 0)^n`` (batched normal equations), negative amplitudes clipped to 0 and ρd
    re-fitted (≥ 0) for the clipped lobes."""
    n, p_count, k = cosines.shape
    shapes = _lobe_shape(cosines, expo[:, None, :])
    design = np.concatenate([np.ones((n, p_count, 1)), shapes], axis=2)
    gram = np.matmul(design.transpose(0, 2, 1), design)
    gram += 1e-10 * np.trace(gram, axis1=1, axis2=2)[:, None, None] * np.eye(1 + k)
    rhs = np.einsum("npq,pn->nq", design, y)
    coef = np.linalg.solve(gram, rhs[:, :, None])[:, :, 0]
    amp = np.clip(coef[:, 1:], 0.0, A_MAX)
    lobes = np.einsum("npk,nk->np", shapes, amp)
    rho = np.clip((y.T - lobes).mean(axis=1), 0.0, A_MAX)
    r = rho[:, None] + lobes - y.T
    return rho, amp, 0.5 * np.sum(r * r, axis=1)


def _lobe_shape(c: np.ndarray, n: np.ndarray) -> np.ndarray:
    """``max(c, 0)^n`` without warnings."""
    pos = c > 0
    return np.where(pos, np.exp(n * np.log(np.where(pos, c, 1.0))), 0.0)
