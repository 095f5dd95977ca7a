"""The Lafortune kernel: isotropic generalised cosine lobes times the foreshortening, their
residuals and analytic Jacobian, and the batched solve (see :mod:`.lm`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .lm_solver import (
    _EXP_LIMIT,
    _S_FLOOR,
    A_MAX,
    LOG_A_MAX,
    LOG_N_MAX,
    LOG_N_MIN,
    LMResult,
    batched_lm,
)


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
