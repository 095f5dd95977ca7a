"""The batched Levenberg–Marquardt solver (see :mod:`.lm`), the lobe bounds both kernels
share, and the unit-vector helpers of the lobe axes."""

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
