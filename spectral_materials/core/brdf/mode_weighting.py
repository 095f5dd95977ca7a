"""Perceptual weighting of a BRDF table's angular modes before a CP fit: each index
weighted by how much of the table it carries, so that dim regions are not fitted at the
expense of the highlights alone."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..decomposition import cp


def mode_weights(tensor: np.ndarray, exponent: float, limit: float = 1e3) -> list[np.ndarray]:
    """Perceptual per-index weights of each angular mode: ``(rms_k(i) / max rms_k)^(−exponent)``.

    ``rms_k(i)`` is the RMS of the table over every other axis at index ``i`` of
    axis ``k``. Weights are clipped to ``[1, limit]`` (slices of zeros get 1).
    """
    d = tensor.ndim - 1
    sums = [np.zeros(n) for n in tensor.shape[:-1]]
    for sl in cp.chunk_slices(tensor.shape[0], 8 * tensor[0].size):
        sq = tensor[sl].astype(np.float64) ** 2
        for k in range(d):
            axes = tuple(j for j in range(tensor.ndim) if j != k)
            if k == 0:
                sums[0][sl] += sq.sum(axis=axes)
            else:
                sums[k] += sq.sum(axis=axes)
    weights = []
    for total in sums:
        rms = np.sqrt(total)
        peak = rms.max()
        w = np.ones_like(rms)
        if peak > 0 and exponent > 0:
            positive = rms > 0
            w[positive] = (rms[positive] / peak) ** (-exponent)
        weights.append(np.clip(w, 1.0, limit))
    return weights


def scale_modes(tensor: np.ndarray, weights: Sequence[np.ndarray]) -> np.ndarray:
    """A float32 copy of ``tensor`` with axis ``k`` multiplied by ``weights[k]``."""
    out = np.empty_like(tensor)
    inner = np.ones(tensor.shape[1:], dtype=np.float32)
    for k, w in enumerate(weights[1:], start=1):
        shape = [1] * (tensor.ndim - 1)
        shape[k - 1] = -1
        inner = inner * w.astype(np.float32).reshape(shape)
    for sl in cp.chunk_slices(tensor.shape[0], 4 * tensor[0].size):
        np.multiply(tensor[sl], inner, out=out[sl])
        out[sl] *= weights[0][sl].astype(np.float32).reshape((-1,) + (1,) * (tensor.ndim - 1))
    return out
