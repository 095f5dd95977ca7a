"""Direction-pair helpers shared by the parameterisations (:mod:`.params`): checks,
spherical angles, the half vector, and the tolerances they use.

The conventions (local frame, angle ranges) are those in :mod:`.params`'s docstring."""

from __future__ import annotations

import math

import numpy as np

TWO_PI = 2.0 * math.pi
HALF_PI = 0.5 * math.pi

#: |wi + wo| at or below this: the half vector is undefined and taken to be n.
HALF_VECTOR_EPS = 1e-12
#: Below this |v.xy| an azimuth is rounding noise and taken as 0 (θ < 1e-12 rad).
POLE_RHO = 1e-12


def _wrap_2pi(angle: np.ndarray) -> np.ndarray:
    """Wrap angles into [0, 2π) (never returns 2π itself)."""
    a = np.mod(angle, TWO_PI)
    return np.where(a >= TWO_PI, 0.0, a)


def _normalize(v: np.ndarray, fallback: np.ndarray | None = None, eps: float = 0.0):
    """Normalise rows of ``v (N, 3)``; rows with norm <= eps become ``fallback`` (or stay)."""
    norm = np.sqrt(np.einsum("...i,...i->...", v, v))
    small = norm <= eps
    out = v / np.where(small, 1.0, norm)[..., None]
    if fallback is not None:
        out = np.where(small[..., None], fallback, out)
    return out, small


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("...i,...i->...", a, b)


def check_direction_pairs(wi, wo) -> tuple[np.ndarray, np.ndarray]:
    """``wi``, ``wo`` as float64 (N, 3) arrays of the same shape and finite; ValueError else."""
    wi = np.asarray(wi, dtype=np.float64)
    wo = np.asarray(wo, dtype=np.float64)
    if wi.ndim != 2 or wi.shape[1] != 3 or wi.shape != wo.shape:
        raise ValueError(f"wi and wo must both be (N, 3), got {wi.shape} and {wo.shape}")
    if not (np.isfinite(wi).all() and np.isfinite(wo).all()):
        raise ValueError("wi/wo contain NaN or inf")
    return wi, wo


def spherical(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Polar angle θ ∈ [0, π] and azimuth φ ∈ [0, 2π) of vectors ``v (..., 3)``.

    θ = atan2(√(x² + y²), z), which is accurate near the poles and needs no
    clipping for |z| slightly above 1. φ = 0 where √(x² + y²) ≤ :data:`POLE_RHO`:
    there the azimuth is rounding noise (e.g. the difference vector when wi = wo
    exactly), and a fixed value keeps evaluation deterministic (the GLSL mirror
    does the same at its float32 noise level).
    """
    v = np.asarray(v, dtype=np.float64)
    # Contiguous copies: NumPy's SIMD loops on strided views round the last bit
    # differently depending on memory alignment, so results varied between runs.
    x, y, z = (np.ascontiguousarray(v[..., k]) for k in range(3))
    rho = np.hypot(x, y)
    theta = np.arctan2(rho, z)
    phi = np.where(rho > POLE_RHO, _wrap_2pi(np.arctan2(y, x)), 0.0)
    return theta, phi


def from_spherical(theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """Unit vectors ``(..., 3)`` from θ and φ (broadcast together)."""
    theta, phi = np.broadcast_arrays(
        np.asarray(theta, dtype=np.float64), np.asarray(phi, dtype=np.float64)
    )
    st = np.sin(theta)
    return np.stack([st * np.cos(phi), st * np.sin(phi), np.cos(theta)], axis=-1)


def _half_vector(wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
    """norm(wi + wo), with h = n where wi ≈ −wo."""
    n = np.array([0.0, 0.0, 1.0])
    h, _ = _normalize(wi + wo, fallback=n, eps=HALF_VECTOR_EPS)
    return h
