"""Tucker compression by truncated HOSVD, contracted chunk by chunk so that peak
memory stays near one chunk plus the core."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..progress import ProgressCallback, report
from .tensor_ops import Factors, chunk_slices, mode_gram, tensor_norm_sq


@dataclass
class TuckerCompression:
    """``T ≈ core ×_0 U_0 ×_1 U_1 …`` with orthonormal ``U_k``; see :func:`tucker_compress`."""

    core: np.ndarray
    bases: list[np.ndarray]
    tensor_norm_sq: float
    core_norm_sq: float

    @property
    def error_sq(self) -> float:
        """‖T − core ×U‖², exact by orthogonality."""
        return max(self.tensor_norm_sq - self.core_norm_sq, 0.0)

    def lift(self, core_factors: Sequence[np.ndarray]) -> Factors:
        return [u @ f for u, f in zip(self.bases, core_factors)]


def tucker_compress(tensor: np.ndarray, tolerance: float = 3e-4, max_rank: int | None = None,
                    callback: ProgressCallback | None = None) -> TuckerCompression:
    """Truncated HOSVD keeping ``‖T − T̂‖ ≤ tolerance·‖T‖`` (split evenly over modes).

    Mode ranks come from the eigenvalues of each mode's Gram matrix; the core is
    ``T ×_k U_kᵀ``, contracted chunk by chunk so peak memory stays near one
    chunk plus the core.
    """
    d = tensor.ndim
    norm_sq = tensor_norm_sq(tensor)
    bases = []
    for mode in range(d):
        report(callback, mode / (d + 1), f"HOSVD mode {mode + 1}/{d}")
        gram = mode_gram(tensor, mode)
        evals, evecs = np.linalg.eigh(gram)
        evals, evecs = evals[::-1].clip(min=0), evecs[:, ::-1]
        tail = np.concatenate([np.cumsum(evals[::-1])[::-1][1:], [0.0]])
        allowed = (tolerance**2) * norm_sq / d
        rank = int(np.argmax(tail <= allowed)) + 1 if norm_sq > 0 else 1
        if max_rank is not None:
            rank = min(rank, max_rank)
        bases.append(evecs[:, :rank])
    report(callback, d / (d + 1), "HOSVD core")
    core = _multi_mode_product(tensor, [u.T for u in bases])
    return TuckerCompression(core, bases, norm_sq, float(np.sum(core * core)))


def _multi_mode_product(tensor: np.ndarray, matrices: Sequence[np.ndarray]) -> np.ndarray:
    """``T ×_0 M_0 ×_1 M_1 …`` in float64, chunked along axis 0."""
    d = tensor.ndim
    shape = tuple(m.shape[0] for m in matrices)
    out = np.zeros(shape)
    for sl in chunk_slices(tensor.shape[0], 8 * tensor[0].size):
        block = tensor[sl].astype(np.float64)
        for k in range(d - 1, 0, -1):
            block = np.moveaxis(np.tensordot(block, matrices[k], axes=([k], [1])), -1, k)
        out += np.tensordot(matrices[0][:, sl], block, axes=([1], [0]))
    return out
