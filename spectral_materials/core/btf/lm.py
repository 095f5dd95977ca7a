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

The solver and the bounds live in :mod:`.lm_solver`, the kernels in :mod:`.lm_rfnl` and
:mod:`.lm_lafortune`; this module re-exports their names.
"""

from __future__ import annotations

from .lm_lafortune import (
    LafortuneGeometry,
    lafortune_lm,
    lafortune_lobes,
    lafortune_project,
    lafortune_residuals,
)
from .lm_rfnl import (
    rfnl_cost,
    rfnl_join,
    rfnl_lm,
    rfnl_project,
    rfnl_residuals,
    rfnl_scipy,
    rfnl_split,
    rfnl_state_size,
    rfnl_step_size,
)
from .lm_solver import (
    A_MAX,
    A_MIN,
    LOG_A_MAX,
    LOG_A_MIN,
    LOG_N_MAX,
    LOG_N_MIN,
    N_MAX,
    N_MIN,
    LMResult,
    ResidualFn,
    RetractFn,
    batched_lm,
    normalise,
    tangent_frames,
)

__all__ = [
    "A_MAX", "A_MIN", "LOG_A_MAX", "LOG_A_MIN", "LOG_N_MAX", "LOG_N_MIN", "N_MAX", "N_MIN",
    "LMResult", "ResidualFn", "RetractFn", "batched_lm", "normalise", "tangent_frames",
    "rfnl_state_size", "rfnl_step_size", "rfnl_split", "rfnl_join", "rfnl_residuals",
    "rfnl_project", "rfnl_lm", "rfnl_scipy", "rfnl_cost",
    "LafortuneGeometry", "lafortune_lobes", "lafortune_residuals", "lafortune_project",
    "lafortune_lm",
]
