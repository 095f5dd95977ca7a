"""Tensor algebra for CP factor packs, in bounded memory: Kruskal tensors (norms, inner
products, term weights, balancing, Khatri–Rao products, reconstruction) and the
matricised-tensor times Khatri–Rao product (MTTKRP), contracted chunk by chunk."""

from __future__ import annotations

import string
from collections.abc import Sequence

import numpy as np

#: Working-set size of one chunk of a large contraction.
CHUNK_BYTES = 48 * 2**20

Factors = list[np.ndarray]


# --------------------------------------------------------------------------- basics


def chunk_slices(length: int, bytes_per_item: int, chunk_bytes: int = CHUNK_BYTES) -> list[slice]:
    step = max(1, int(chunk_bytes // max(bytes_per_item, 1)))
    return [slice(i, min(i + step, length)) for i in range(0, length, step)]


def tensor_norm_sq(tensor: np.ndarray) -> float:
    """‖T‖² accumulated in float64, chunk by chunk."""
    flat = tensor.reshape(-1)
    total = 0.0
    for sl in chunk_slices(flat.size, 8):
        chunk = flat[sl].astype(np.float64)
        total += float(chunk @ chunk)
    return total


def kruskal_inner(a: Sequence[np.ndarray], b: Sequence[np.ndarray]) -> float:
    """⟨X_a, X_b⟩ of two Kruskal tensors, in float64."""
    prod = np.ones((a[0].shape[1], b[0].shape[1]))
    for fa, fb in zip(a, b):
        prod *= fa.astype(np.float64).T @ fb.astype(np.float64)
    return float(prod.sum())


def term_weights(factors: Sequence[np.ndarray]) -> np.ndarray:
    """The weight of each rank-one term: the product of its column norms."""
    weights = np.ones(factors[0].shape[1])
    for f in factors:
        weights *= np.linalg.norm(f, axis=0)
    return weights


def balance(factors: Factors) -> Factors:
    """Rescale each term's columns to equal norms (w^(1/d)); the tensor is unchanged."""
    d = len(factors)
    norms = np.stack([np.linalg.norm(f, axis=0) for f in factors])
    weights = norms.prod(axis=0)
    target = weights ** (1.0 / d)
    out = []
    for f, n in zip(factors, norms):
        scale = np.divide(target, n, out=np.zeros_like(n), where=n > 0)
        out.append(f * scale)
    return out


def khatri_rao(factors: Sequence[np.ndarray], dtype=np.float64, rank: int | None = None
               ) -> np.ndarray:
    """Column-wise Kronecker product (Π n_k, R), first factor slowest (C order).

    An empty list gives a row of ones; pass ``rank`` for its width.
    """
    rank = factors[0].shape[1] if factors else (1 if rank is None else rank)
    out = np.ones((1, rank), dtype=dtype)
    for f in factors:
        out = (out[:, None, :] * np.asarray(f, dtype=dtype)[None, :, :]).reshape(-1, rank)
    return out


def reconstruct(factors: Sequence[np.ndarray], dtype=np.float64) -> np.ndarray:
    """The full tensor of a Kruskal model (small tensors and tests only)."""
    shape = tuple(f.shape[0] for f in factors)
    rank = factors[0].shape[1]
    return (khatri_rao(factors[:-1], dtype, rank) @ factors[-1].astype(dtype).T).reshape(shape)


# --------------------------------------------------------------------------- MTTKRP


def mttkrp(tensor: np.ndarray, factors: Sequence[np.ndarray], mode: int,
           chunk_bytes: int = CHUNK_BYTES) -> np.ndarray:
    """Matricised tensor times Khatri–Rao product for ``mode`` → (n_mode, R) float64.

    ``M[i, r] = Σ T[…, i, …] Π_{k≠mode} A_k[i_k, r]``. The tensor is walked in
    chunks along one axis other than ``mode``; in each chunk the largest other
    axis is contracted first by BLAS (tensordot), the rest by einsum.
    """
    d = tensor.ndim
    if d == 1:
        return tensor.astype(np.float64)[:, None] * np.ones((1, factors[0].shape[1]))
    rank = factors[0].shape[1]
    work = [np.ascontiguousarray(f, dtype=tensor.dtype) for f in factors]
    chunk_axis = 0 if mode != 0 else 1
    others = [k for k in range(d) if k not in (mode,)]
    first = max((k for k in others if k != chunk_axis), key=lambda k: tensor.shape[k], default=None)
    if first is None:
        first = chunk_axis
    slab = tensor.nbytes // tensor.shape[chunk_axis]
    per_item = slab * max(1, rank // 2)
    out = np.zeros((tensor.shape[mode], rank))
    letters = string.ascii_letters
    for sl in chunk_slices(tensor.shape[chunk_axis], per_item, chunk_bytes):
        index = [slice(None)] * d
        index[chunk_axis] = sl
        sub = tensor[tuple(index)]
        sub_factors = list(work)
        sub_factors[chunk_axis] = work[chunk_axis][sl]
        z = np.tensordot(sub, sub_factors[first], axes=([first], [0]))
        axes = [k for k in range(d) if k != first]  # axes of z, then the rank axis
        for k in sorted((k for k in axes if k != mode), key=lambda k: -z.shape[axes.index(k)]):
            pos = axes.index(k)
            src = "".join(letters[i] for i in range(len(axes))) + "Z"
            dst = src[:pos] + src[pos + 1:]
            z = np.einsum(f"{src},{letters[pos]}Z->{dst}", z, sub_factors[k], optimize=False)
            axes.pop(pos)
        out += z.astype(np.float64)
    return out


def mode_gram(tensor: np.ndarray, mode: int) -> np.ndarray:
    """T_(mode) T_(mode)ᵀ in float64, chunked (for HOSVD and initialisation)."""
    n = tensor.shape[mode]
    gram = np.zeros((n, n))
    if mode == 0:
        flat = tensor.reshape(n, -1)
        for sl in chunk_slices(flat.shape[1], n * 8):
            block = flat[:, sl].astype(np.float64)
            gram += block @ block.T
        return gram
    for sl in chunk_slices(tensor.shape[0], 8 * tensor[0].size):
        moved = np.moveaxis(tensor[sl].astype(np.float64), mode, 0).reshape(n, -1)
        gram += moved @ moved.T
    return gram
