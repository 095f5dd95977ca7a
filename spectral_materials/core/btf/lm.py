"""Batched Levenberg–Marquardt and the lobe models fitted with it (RFNL and Lafortune).

Meseth, Müller and Klein (2003, §4.1) fit their non-linear reflectance-field model (eq. 1)
to every texel of every view with a Levenberg–Marquardt (LM) solver — one small problem
per (view, texel), tens of thousands of them. Solving them one by one (MINPACK through
:func:`scipy.optimize.least_squares`) spends nearly all its time in Python call overhead.
:func:`batched_lm` runs many independent problems at once: each step forms every problem's
normal equations ``(JᵀJ + μ D) δ = −Jᵀr`` with one batched matrix product, solves them with
one :func:`numpy.linalg.solve` call, and accepts or rejects each problem's step on its own
(per-problem damping μ and Nielsen's update rule). Converged problems leave the active set,
so late iterations only touch the few stragglers.

The lobe kernels return residuals and analytic Jacobians for a batch:

:func:`rfnl_residuals`
    ``Y(l) = ρd + Σ_j a_j · max(t̂_j · l, 0)^{n_j}`` with unit lobe axes ``t̂_j``, amplitudes
    ``a_j = exp(α_j)`` and exponents ``n_j = exp(ν_j)``; the axes move in the tangent plane
    of a reference axis (two angles per lobe, the gnomonic chart ``t̂ = (t₀ + τ₁e₁ +
    τ₂e₂)/‖·‖``). The batched solver recentres the chart on the current axis after every
    step (so it never meets the chart's singularity); the SciPy reference keeps it fixed at
    the initial axis. Same model, same unknowns, same initial point.
:func:`lafortune_residuals`
    Isotropic generalised cosine lobes (Lafortune et al. 1997) times the foreshortening
    ``l_z`` that the measured data include: ``Y = (ρd + Σ_j max(C_xy,j (l_x v_x + l_y v_y) +
    C_z,j l_z v_z, 0)^{n_j}) · l_z``.

Everything here is float64; storage precision is the caller's business.

References
----------
Meseth, J., Müller, G., Klein, R. (2003). Reflectance field based real-time, high quality
rendering of bidirectional texture functions. Computers & Graphics 28(1), 105–112.
Lafortune, E. P. F., Foo, S.-C., Torrance, K. E., Greenberg, D. P. (1997). Non-linear
approximation of reflectance functions. SIGGRAPH '97, 117–126.
Madsen, K., Nielsen, H. B., Tingleff, O. (2004). Methods for non-linear least squares
problems, 2nd ed., IMM DTU, §3.2 (damping update, gain ratio).
Moré, J. J. (1978). The Levenberg–Marquardt algorithm: implementation and theory.
Numerical Analysis, LNM 630, 105–116 (diagonal scaling D = diag JᵀJ).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

#: Largest lobe amplitude a_j: below float16's 65504, so a stored amplitude and a single
#: lobe's value ``a · (t̂·l)^n ≤ a`` stay finite even in a half-float texture.
A_MAX = 60000.0
#: The fit's floor for a_j (it works with log a_j); amplitudes at the floor are stored as 0.
A_MIN = 1e-10
#: Exponent range: n ≥ 0.5 keeps the lobe's slope finite where it meets the horizon of
#: t̂ (n < 1 has an unbounded derivative there); n ≤ 1e4 is sharper than any light spacing
#: of a measured BTF can resolve (cos 1° ^ 1e4 ≈ 2e-7) and is exact in float16.
N_MIN, N_MAX = 0.5, 10000.0
LOG_A_MIN, LOG_A_MAX = float(np.log(A_MIN)), float(np.log(A_MAX))
LOG_N_MIN, LOG_N_MAX = float(np.log(N_MIN)), float(np.log(N_MAX))

#: Lafortune exponents are clamped to the same range as the RFNL exponents.
_EXP_LIMIT = 700.0   # exp(700) ≈ 1e304: largest exponent evaluated in float64
_S_FLOOR = 1e-9      # s^(n−1) for n < 1 is evaluated at s ≥ this (finite Jacobian)


# ---------------------------------------------------------------------------- solver


@dataclass
class LMResult:
    """Outcome of :func:`batched_lm`.

    Attributes
    ----------
    x : ndarray (N, S)
        Final state of every problem (the start state where no step was ever accepted).
    cost : ndarray (N,)
        ``½ Σ r²`` at ``x``; inf where even the start state was not finite.
    iterations : ndarray (N,) int
        LM iterations each problem took part in.
    converged : ndarray (N,) bool
        Stopped by a tolerance rather than by the iteration limit.
    history : ndarray (T + 1,)
        Total cost ``Σ_problems ½ Σ r²`` before the first iteration and after each one
        (finite problems only); T ≤ ``iterations`` (it stops once every problem has
        converged). Steps are accepted only when they lower a problem's cost, so this
        never increases.
    """

    x: np.ndarray
    cost: np.ndarray
    iterations: np.ndarray
    converged: np.ndarray
    history: np.ndarray


ResidualFn = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]  # r, Jᵀ
RetractFn = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]


def batched_lm(fun: ResidualFn, x0: np.ndarray, retract: RetractFn, *, iterations: int = 100,
               ftol: float = 1e-10, gtol: float = 1e-14, mu0: float = 1e-3,
               mu_max: float = 1e12,
               callback: Callable[[int, np.ndarray], None] | None = None) -> LMResult:
    """Levenberg–Marquardt on N independent least-squares problems at once.

    Parameters
    ----------
    fun : callable
        ``fun(x_rows (n, S), rows (n,) int) -> (r (n, M), Jᵀ (n, P, M))``: residuals and
        their Jacobian with respect to a P-dimensional *local* step at ``x_rows``, stored
        transposed (parameter-major: each row a contiguous vector over the M residuals,
        so that ``JᵀJ`` is one batched matrix product without copies); ``rows`` index the
        problems (so the closure can pick their data).
    x0 : ndarray (N, S)
        Start states. S may differ from P (a state may hold unit vectors that steps move
        in a tangent chart).
    retract : callable
        ``retract(x_rows, delta (n, P), rows) -> x_new``: apply a step, including any
        projection onto bounds.
    iterations : int
        Largest number of LM iterations.
    ftol : float
        A problem stops when an accepted step lowers its cost by less than ``ftol·cost``.
    gtol : float
        … or when ``max |Jᵀr| ≤ gtol · (1 + cost)`` (a stationary point).
    mu0 : float
        Initial damping, relative to the Marquardt scaling ``D = diag(JᵀJ)``.
    mu_max : float
        … or when repeated rejections push μ above this (no descent step is left).
    callback : callable, optional
        ``callback(iteration, history_so_far)`` after each iteration.

    Returns
    -------
    LMResult

    Notes
    -----
    The step solves ``(JᵀJ + μ D) δ = −Jᵀr`` with ``D = max(diag JᵀJ, 1e-12·max diag)``
    (Moré 1978: invariant to the unknowns' scales; the floor keeps a column that lost its
    influence — a lobe whose amplitude went to zero — from making the system singular).
    A step is accepted only when the true cost decreases; μ then shrinks by Nielsen's
    factor ``max(1/3, 1 − (2ρ − 1)³)`` with ρ the gain ratio, otherwise μ grows by ν and ν
    doubles (Madsen, Nielsen, Tingleff 2004, eq. 3.14).
    """
    x = np.array(x0, dtype=np.float64, copy=True)
    n_prob = len(x)
    cost = np.full(n_prob, np.inf)
    its = np.zeros(n_prob, dtype=np.int64)
    converged = np.zeros(n_prob, dtype=bool)
    if n_prob == 0:
        return LMResult(x, cost, its, converged, np.zeros(1))
    with np.errstate(over="ignore", invalid="ignore"):
        # Trial points far from the data may overflow; they get inf/NaN cost and are
        # rejected below, so the floating-point flags carry no information here.
        return _batched_lm(fun, x, retract, iterations, ftol, gtol, mu0, mu_max, callback,
                           cost, its, converged)


def _batched_lm(fun, x, retract, iterations, ftol, gtol, mu0, mu_max, callback, cost, its,
                converged) -> LMResult:
    n_prob = len(x)
    rows = np.arange(n_prob)
    r, jac = fun(x, rows)
    c0 = 0.5 * np.einsum("nm,nm->n", r, r)
    ok0 = np.isfinite(c0) & np.isfinite(jac).reshape(n_prob, -1).all(axis=1)
    cost[ok0] = c0[ok0]
    act = rows[ok0]
    r, jac = r[ok0], jac[ok0]
    mu = np.full(len(act), float(mu0))
    nu = np.full(len(act), 2.0)
    history = [float(cost[ok0].sum())]
    for it in range(iterations):
        if len(act) == 0:
            break
        a = np.matmul(jac, jac.transpose(0, 2, 1))              # JᵀJ (n, P, P)
        g = np.matmul(jac, r[:, :, None])[:, :, 0]              # Jᵀr (n, P)
        diag = np.diagonal(a, axis1=1, axis2=2)
        d = np.maximum(diag, 1e-12 * diag.max(axis=1, keepdims=True))
        d = np.maximum(d, 1e-300)
        lhs = a + (mu[:, None] * d)[:, :, None] * np.eye(a.shape[1])
        delta = _solve_spd(lhs, -g)
        x_try = retract(x[act], delta, act)
        r_try, j_try = fun(x_try, act)
        c_try = 0.5 * np.einsum("nm,nm->n", r_try, r_try)
        c_old = cost[act]
        # Predicted decrease of the linear model: ½ δᵀ(μ D δ − g) > 0.
        pred = 0.5 * np.einsum("np,np->n", delta, mu[:, None] * d * delta - g)
        finite = np.isfinite(c_try) & np.isfinite(j_try).reshape(len(act), -1).all(axis=1)
        accept = finite & (c_try < c_old)
        rho = np.where(accept, (c_old - c_try) / np.maximum(pred, 1e-300), 0.0)
        # Accepted: move, shrink μ. Rejected: keep, grow μ (ν doubles each time in a row).
        idx = act[accept]
        x[idx] = x_try[accept]
        cost[idx] = c_try[accept]
        r[accept] = r_try[accept]
        jac[accept] = j_try[accept]
        mu = np.where(accept, mu * np.maximum(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3),
                      mu * nu)
        nu = np.where(accept, 2.0, nu * 2.0)
        its[act] += 1
        gmax = np.abs(g).max(axis=1)
        done = ((accept & (c_old - c_try <= ftol * c_old)) | (gmax <= gtol * (1.0 + c_old))
                | (mu > mu_max) | (cost[act] == 0.0))
        converged[act[done]] = True
        keep = ~done
        act, r, jac, mu, nu = act[keep], r[keep], jac[keep], mu[keep], nu[keep]
        history.append(float(cost[ok0].sum()))
        if callback is not None:
            callback(it, np.asarray(history))
    return LMResult(x, cost, its, converged, np.asarray(history))


def _solve_spd(lhs: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Solve a batch of small symmetric positive definite systems ``lhs (n, P, P) x = rhs
    (n, P)``.

    A Cholesky factorisation written column by column and vectorised over the batch: for
    P ≈ 10 and thousands of systems it is ~15× faster than :func:`numpy.linalg.solve`,
    which calls LAPACK once per matrix. The damping makes every system definite; one
    that round-off made indefinite is solved by LAPACK instead (a zero step if singular).
    """
    n, p, _ = lhs.shape
    a = np.ascontiguousarray(lhs.transpose(1, 2, 0))          # (P, P, n): rows of n
    low = np.zeros_like(a)
    ok = np.ones(n, dtype=bool)
    for j in range(p):
        d = a[j, j] - np.einsum("kn,kn->n", low[j, :j], low[j, :j])
        ok &= d > 0.0
        dj = np.sqrt(np.where(d > 0.0, d, 1.0))
        low[j, j] = dj
        if j + 1 < p:
            low[j + 1:, j] = (a[j + 1:, j]
                              - np.einsum("ikn,kn->in", low[j + 1:, :j], low[j, :j])) / dj
    b = np.ascontiguousarray(rhs.T)
    y = np.empty_like(b)
    for i in range(p):
        y[i] = (b[i] - np.einsum("kn,kn->n", low[i, :i], y[:i])) / low[i, i]
    x = np.empty_like(b)
    for i in range(p - 1, -1, -1):
        x[i] = (y[i] - np.einsum("kn,kn->n", low[i + 1:, i], x[i + 1:])) / low[i, i]
    x = x.T
    for i in np.nonzero(~ok)[0]:
        try:
            x[i] = np.linalg.solve(lhs[i], rhs[i])
        except np.linalg.LinAlgError:
            x[i] = 0.0
    return x


# ---------------------------------------------------------------------- unit vectors


def tangent_frames(axes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Orthonormal tangents ``(e₁, e₂)`` of unit vectors ``axes (..., 3)``.

    Deterministic in the axis (the batched solver rebuilds them at every step): e₁ is
    ``helper × t̂`` normalised, with helper ``z`` unless t̂ is within ~25° of ±z, then ``x``.
    """
    t = np.asarray(axes, dtype=np.float64)
    near_pole = np.abs(t[..., 2]) > 0.9
    helper = np.zeros_like(t)
    helper[..., 2] = np.where(near_pole, 0.0, 1.0)
    helper[..., 0] = np.where(near_pole, 1.0, 0.0)
    e1 = np.cross(helper, t)
    e1 /= np.linalg.norm(e1, axis=-1, keepdims=True)
    e2 = np.cross(t, e1)
    return e1, e2


def normalise(v: np.ndarray) -> np.ndarray:
    """Unit vectors along ``v (..., 3)``; a zero vector becomes +z."""
    norm = np.linalg.norm(v, axis=-1, keepdims=True)
    safe = np.where(norm > 1e-300, norm, 1.0)
    out = v / safe
    return np.where(norm > 1e-300, out, np.array([0.0, 0.0, 1.0]))


# ------------------------------------------------------------------------ RFNL kernel


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


# ------------------------------------------------------------------- Lafortune kernel


@dataclass(frozen=True)
class LafortuneGeometry:
    """Per-sample geometry of the Lafortune model for M (view, light) pairs:
    ``u = l_x v_x + l_y v_y``, ``w = l_z v_z`` and the foreshortening ``l_z``."""

    u: np.ndarray
    w: np.ndarray
    lz: np.ndarray

    @classmethod
    def of(cls, lights: np.ndarray, views: np.ndarray) -> LafortuneGeometry:
        """Geometry of paired ``lights (M, 3)`` and ``views (M, 3)``."""
        lights = np.asarray(lights, np.float64)
        views = np.asarray(views, np.float64)
        return cls(lights[:, 0] * views[:, 0] + lights[:, 1] * views[:, 1],
                   lights[:, 2] * views[:, 2], np.maximum(lights[:, 2], 0.0))


def lafortune_lobes(params: np.ndarray, geometry: LafortuneGeometry
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(s (n, k, M), positive mask, log s, lobe values s^n)`` of parameter rows
    ``[ρd, C_xy,1, C_z,1, ν_1, …]`` (ν = log n)."""
    k = (params.shape[1] - 1) // 3
    lobes = params[:, 1:].reshape(-1, k, 3)
    s = (lobes[:, :, 0:1] * geometry.u[None, None, :]
         + lobes[:, :, 1:2] * geometry.w[None, None, :])
    pos = s > 0.0
    log_s = np.log(np.where(pos, s, 1.0))
    expo = np.exp(np.clip(lobes[:, :, 2:3], None, _EXP_LIMIT))
    value = np.where(pos, np.exp(np.minimum(expo * log_s, _EXP_LIMIT)), 0.0)
    return s, pos, log_s, value


def lafortune_residuals(params: np.ndarray, geometry: LafortuneGeometry, data: np.ndarray,
                        *, jacobian: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
    """Residuals ``model − data (n, M)`` of the Lafortune model and the analytic Jacobian
    with respect to ``[ρd, C_xy,j, C_z,j, ν_j]``, transposed: (n, 1 + 3k, M).

    ``s^n`` is evaluated as ``exp(min(n log s, 700))``: with the bound of
    :func:`lafortune_project` it never gets there, but a caller's wild point gives a huge
    finite cost instead of inf.
    """
    n_rows, p = params.shape
    s, pos, log_s, value = lafortune_lobes(params, geometry)
    lz = geometry.lz
    r = (params[:, :1] + value.sum(axis=1)) * lz[None, :] - data
    if not jacobian:
        return r, None
    expo = np.exp(np.clip(params[:, 3::3], None, _EXP_LIMIT))[:, :, None]   # (n, k, 1)
    slope = value * expo / np.maximum(s, _S_FLOOR) * lz                 # n s^(n−1) l_z
    jac = np.empty((n_rows, p, len(lz)))                               # Jᵀ
    jac[:, 0] = lz
    jac[:, 1::3] = slope * geometry.u
    jac[:, 2::3] = slope * geometry.w
    jac[:, 3::3] = value * expo * log_s * lz
    return r, jac


def lafortune_project(params: np.ndarray) -> np.ndarray:
    """Clamp Lafortune rows: ρd ∈ [0, A_MAX], n ∈ [N_MIN, N_MAX] (ν = log n), and
    ``‖(C_xy, C_z)‖ ≤ A_MAX^(1/n)``.

    Why the norm: for unit l and v, ``(l_x v_x + l_y v_y)² + (l_z v_z)² ≤ 1``, so by
    Cauchy–Schwarz ``s ≤ ‖(C_xy, C_z)‖`` and every lobe value ``s^n ≤ A_MAX`` — the
    Lafortune form cannot overflow float32 (or float16) either.
    """
    out = params.copy()
    np.clip(out[:, 0], 0.0, A_MAX, out=out[:, 0])
    np.clip(out[:, 3::3], LOG_N_MIN, LOG_N_MAX, out=out[:, 3::3])
    c_max = np.exp(LOG_A_MAX / np.exp(out[:, 3::3]))
    norm = np.hypot(out[:, 1::3], out[:, 2::3])
    scale = np.where(norm > c_max, c_max / np.maximum(norm, 1e-300), 1.0)
    out[:, 1::3] *= scale
    out[:, 2::3] *= scale
    return out


def lafortune_lm(params: np.ndarray, geometry: LafortuneGeometry, data: np.ndarray,
                 **options) -> LMResult:
    """Fit the Lafortune model to every row of ``data (N, M)`` by :func:`batched_lm`."""

    def fun(x, rows):
        return lafortune_residuals(x, geometry, data[rows])

    def retract(x, delta, rows):
        return lafortune_project(x + delta)

    return batched_lm(fun, lafortune_project(np.asarray(params, np.float64)), retract,
                      **options)
