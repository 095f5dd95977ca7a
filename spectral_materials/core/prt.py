"""Precomputed radiance transfer: the per-vertex transfer vector from visibility samples.

The spectral PRT paper (Schwenk et al.) renders diffuse, self-shadowed objects under
distant light by splitting the transfer into an achromatic part per vertex,
``T(ω) = V(ω) max(n·ω, 0)`` projected onto spherical harmonics, and a spectral
albedo. This module computes ``T̃`` from visibility samples along a fixed set of
directions shared by every vertex, so that the SH basis is evaluated once:

    T̃_k = Σ_r V(ω_r) max(n·ω_r, 0) Y_k(ω_r) · 4π / R.

Directions are a spherical Fibonacci set (deterministic, nearly uniform), in the
object's own frame: the environment is rotated into that frame at draw time.

References
----------
Sloan, P.-P., Kautz, J., Snyder, J. (2002). Precomputed radiance transfer for real-time
rendering in dynamic, low-frequency lighting environments. SIGGRAPH 2002.
Swinbank, R., Purser, R. J. (2006). Fibonacci grids. Q. J. R. Meteorol. Soc. 132.
"""

from __future__ import annotations

import numpy as np

MAX_RAYS = 1 << 20


def fibonacci_directions(count: int) -> np.ndarray:
    """``count`` unit vectors (count, 3) spread evenly over the sphere (spherical Fibonacci)."""
    count = int(count)
    if not 1 <= count <= MAX_RAYS:
        raise ValueError(f"ray count must be 1..{MAX_RAYS}, got {count}")
    i = np.arange(count, dtype=np.float64) + 0.5
    z = 1.0 - 2.0 * i / count
    r = np.sqrt(np.clip(1.0 - z * z, 0.0, None))
    phi = np.pi * (3.0 - np.sqrt(5.0)) * i
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=-1)


def transfer_from_visibility(normals: np.ndarray, directions: np.ndarray,
                             visible: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """Transfer vectors (V, K) from visibility (V, R) along ``directions`` (R, 3).

    ``basis`` (R, K) holds the SH functions at the directions. Each direction carries
    the weight 4π/R; directions below a vertex's horizon contribute nothing.
    """
    normals = np.asarray(normals, dtype=np.float64)
    directions = np.asarray(directions, dtype=np.float64)
    visible = np.asarray(visible, dtype=bool)
    basis = np.asarray(basis, dtype=np.float64)
    if visible.shape != (len(normals), len(directions)) or len(basis) != len(directions):
        raise ValueError(f"shapes disagree: normals {normals.shape}, directions "
                         f"{directions.shape}, visible {visible.shape}, basis {basis.shape}")
    cosine = np.clip(normals @ directions.T, 0.0, None) * visible
    return cosine @ basis * (4.0 * np.pi / len(directions))
