"""The RFNL kernel: residuals and analytic Jacobian of eq. (1) in the stable form, its
solver states, and the batched and SciPy solves (see :mod:`.lm`)."""

from __future__ import annotations

import numpy as np

from .lm_solver import (
    _EXP_LIMIT,
    _S_FLOOR,
    A_MAX,
    LOG_A_MAX,
    LOG_A_MIN,
    LOG_N_MAX,
    LOG_N_MIN,
    LMResult,
    batched_lm,
    normalise,
    tangent_frames,
)


def rfnl_state_size(lobes: int) -> int:
    """Width of an RFNL solver state: ``[ρd, α_1..α_k, t̂_1 (3) .. t̂_k (3), ν_1..ν_k]``."""
    return 1 + 5 * lobes


def rfnl_step_size(lobes: int) -> int:
    """Unknowns of an RFNL problem: ``[ρd, α_1..α_k, (τ₁, τ₂)_1..(τ₁, τ₂)_k, ν_1..ν_k]``."""
    return 1 + 4 * lobes


def rfnl_split(state: np.ndarray, lobes: int):
    """``(ρd (n,), α (n, k), t̂ (n, k, 3), ν (n, k))`` views of solver states."""
    k = lobes
    return (state[:, 0], state[:, 1:1 + k], state[:, 1 + k:1 + 4 * k].reshape(-1, k, 3),
            state[:, 1 + 4 * k:1 + 5 * k])


def rfnl_join(rho_d, log_a, axes, log_n) -> np.ndarray:
    """Inverse of :func:`rfnl_split`."""
    n = len(rho_d)
    return np.concatenate([np.asarray(rho_d, np.float64)[:, None], log_a,
                           np.asarray(axes).reshape(n, -1), log_n], axis=1)


def rfnl_residuals(unknowns: np.ndarray, base_axes: np.ndarray, lights: np.ndarray,
                   data: np.ndarray, mask: np.ndarray | None, *, jacobian: bool = True
                   ) -> tuple[np.ndarray, np.ndarray | None]:
    """Residuals ``model − data`` of eq. (1) in the stable form, with the analytic Jacobian.

    Parameters
    ----------
    unknowns : ndarray (n, 1 + 4k)
        ``[ρd, α_1..α_k, (τ₁, τ₂)_1..(τ₁, τ₂)_k, ν_1..ν_k]``: ``a_j = e^{α_j}``,
        ``n_j = e^{ν_j}``, ``t̂_j = normalise(t₀_j + τ₁ e₁ + τ₂ e₂)``.
    base_axes : ndarray (n, k, 3)
        The chart centres ``t₀_j`` (unit vectors); ``e₁, e₂`` from :func:`tangent_frames`.
    lights : ndarray (L, 3)
        Unit light directions (shared by the batch).
    data : ndarray (n, L)
        Luminance samples; anything where ``mask`` is False.
    mask : ndarray (n, L) bool or None
        Present samples; missing ones get residual 0 and a zero Jacobian row.

    Returns
    -------
    r : ndarray (n, L)
    Jt : ndarray (n, 1 + 4k, L) or None
        The Jacobian, transposed (see :func:`batched_lm`).
    """
    n, p = unknowns.shape
    k = (p - 1) // 4
    rho_d = unknowns[:, 0]
    log_a = unknowns[:, 1:1 + k]
    tau = unknowns[:, 1 + k:1 + 3 * k].reshape(n, k, 2)
    log_n = unknowns[:, 1 + 3 * k:1 + 4 * k]
    e1, e2 = tangent_frames(base_axes)
    u = base_axes + tau[..., 0:1] * e1 + tau[..., 1:2] * e2          # (n, k, 3)
    u_norm = np.linalg.norm(u, axis=-1, keepdims=True)
    t = u / u_norm
    a = np.exp(np.clip(log_a, None, _EXP_LIMIT))[:, :, None]          # (n, k, 1)
    expo = np.exp(np.clip(log_n, None, _EXP_LIMIT))[:, :, None]
    s = np.matmul(t, lights.T)                                         # (n, k, L)
    pos = s > 0.0
    log_s = np.log(np.where(pos, s, 1.0))
    term = np.where(pos, a * np.exp(np.minimum(expo * log_s, _EXP_LIMIT)), 0.0)
    r = rho_d[:, None] + term.sum(axis=1) - data
    if mask is not None:
        r = np.where(mask, r, 0.0)
    if not jacobian:
        return r, None
    jac = np.empty((n, p, lights.shape[0]))                            # Jᵀ
    jac[:, 0] = 1.0
    jac[:, 1:1 + k] = term
    # d/dτ_i = a n s^(n−1) (∂t̂/∂τ_i · l) with ∂t̂/∂τ_i = (e_i − t̂ (t̂·e_i)) / ‖u‖;
    # a n s^(n−1) = term · n / s, with s floored so that n < 1 keeps a finite slope.
    slope = term * expo / np.maximum(s, _S_FLOOR)
    for i, e in enumerate((e1, e2)):
        dt = (e - t * np.sum(t * e, axis=-1, keepdims=True)) / u_norm  # (n, k, 3)
        jac[:, 1 + k + i:1 + 3 * k:2] = slope * np.matmul(dt, lights.T)
    jac[:, 1 + 3 * k:] = term * expo * log_s
    if mask is not None:
        jac *= mask[:, None, :]
    return r, jac


def rfnl_project(state: np.ndarray, lobes: int) -> np.ndarray:
    """Clamp states onto the stable ranges: ρd ∈ [0, A_MAX], a ∈ [A_MIN, A_MAX],
    n ∈ [N_MIN, N_MAX], unit t̂."""
    out = state.copy()
    rho_d, log_a, axes, log_n = rfnl_split(out, lobes)
    np.clip(rho_d, 0.0, A_MAX, out=rho_d)
    np.clip(log_a, LOG_A_MIN, LOG_A_MAX, out=log_a)
    np.clip(log_n, LOG_N_MIN, LOG_N_MAX, out=log_n)
    out[:, 1 + lobes:1 + 4 * lobes] = normalise(axes).reshape(len(out), -1)
    return out


def rfnl_lm(states: np.ndarray, lights: np.ndarray, data: np.ndarray,
            mask: np.ndarray | None, lobes: int, **options) -> LMResult:
    """Fit eq. (1) to every row of ``data (N, L)`` by :func:`batched_lm` from ``states``.

    The chart is recentred on the current axes at every evaluation (tangent coordinates
    are always 0 at the current point), so the two angles per lobe never meet a pole.
    """
    k = lobes

    def fun(x, rows):
        rho_d, log_a, axes, log_n = rfnl_split(x, k)
        unknowns = np.concatenate([x[:, :1], log_a, np.zeros((len(x), 2 * k)), log_n],
                                  axis=1)
        return rfnl_residuals(unknowns, axes, lights, data[rows],
                              None if mask is None else mask[rows])

    def retract(x, delta, rows):
        rho_d, log_a, axes, log_n = rfnl_split(x, k)
        e1, e2 = tangent_frames(axes)
        tau = delta[:, 1 + k:1 + 3 * k].reshape(-1, k, 2)
        new_axes = normalise(axes + tau[..., 0:1] * e1 + tau[..., 1:2] * e2)
        new = rfnl_join(rho_d + delta[:, 0], log_a + delta[:, 1:1 + k], new_axes,
                        log_n + delta[:, 1 + 3 * k:])
        return rfnl_project(new, k)

    return batched_lm(fun, rfnl_project(np.asarray(states, np.float64), k), retract,
                      **options)


def rfnl_scipy(states: np.ndarray, lights: np.ndarray, data: np.ndarray,
               mask: np.ndarray | None, lobes: int, *, max_nfev: int | None = None,
               ftol: float = 1e-10, xtol: float = 1e-10
               ) -> tuple[np.ndarray, np.ndarray]:
    """The reference: :func:`scipy.optimize.least_squares` (``method="lm"``, MINPACK) on
    each row separately, same unknowns and start as :func:`rfnl_lm` (the tangent chart
    stays centred on the start axes; ``"lm"`` takes no bounds, so the final state is
    clamped onto the stable ranges afterwards, as the batched solver does at every step).

    Returns
    -------
    states : ndarray (N, 1 + 5k)
    cost : ndarray (N,)
        ``½ Σ r²`` of the clamped states.
    """
    from scipy.optimize import least_squares

    k = lobes
    states = rfnl_project(np.asarray(states, np.float64), k)
    out = states.copy()
    for i in range(len(states)):
        rho_d, log_a, axes, log_n = rfnl_split(states[i:i + 1], k)
        sel = np.ones(lights.shape[0], bool) if mask is None else mask[i]
        li, yi = lights[sel], data[i, sel]

        def fun(p, axes=axes, li=li, yi=yi):
            return rfnl_residuals(p[None], axes, li, yi[None], None, jacobian=False)[0][0]

        def jac(p, axes=axes, li=li, yi=yi):
            return rfnl_residuals(p[None], axes, li, yi[None], None)[1][0].T

        x0 = np.concatenate([rho_d, log_a[0], np.zeros(2 * k), log_n[0]])
        with np.errstate(all="ignore"):     # MINPACK probes wild points; they are rejected
            try:
                sol = least_squares(fun, x0, jac=jac, method="lm", ftol=ftol, xtol=xtol,
                                    max_nfev=max_nfev)
                p = sol.x if np.all(np.isfinite(sol.x)) else x0
            except (ValueError, np.linalg.LinAlgError):
                p = x0
        e1, e2 = tangent_frames(axes)
        tau = p[1 + k:1 + 3 * k].reshape(1, k, 2)
        new_axes = normalise(axes + tau[..., 0:1] * e1 + tau[..., 1:2] * e2)
        out[i] = rfnl_join(p[:1], p[None, 1:1 + k], new_axes, p[None, 1 + 3 * k:])[0]
    out = rfnl_project(out, k)
    return out, rfnl_cost(out, lights, data, mask, k)


def rfnl_cost(states: np.ndarray, lights: np.ndarray, data: np.ndarray,
              mask: np.ndarray | None, lobes: int) -> np.ndarray:
    """``½ Σ r²`` of solver states (N,), evaluated in chunks."""
    cost = np.empty(len(states))
    for sl in _chunks(len(states), 4096):
        rho_d, log_a, axes, log_n = rfnl_split(states[sl], lobes)
        unknowns = np.concatenate([states[sl, :1], log_a, np.zeros((len(axes), 2 * lobes)),
                                   log_n], axis=1)
        r, _ = rfnl_residuals(unknowns, axes, lights, data[sl],
                              None if mask is None else mask[sl], jacobian=False)
        cost[sl] = 0.5 * np.einsum("nm,nm->n", r, r)
    return cost


def _chunks(length: int, step: int) -> list[slice]:
    return [slice(i, min(i + step, length)) for i in range(0, length, max(1, step))]
