"""CANDECOMP/PARAFAC factor packs by alternating least squares.

A tensor ``T`` (any order d) is approximated by a sum of rank-one terms
``Σ_r A_0[:, r] ∘ A_1[:, r] ∘ … ∘ A_{d-1}[:, r]``. Terms come in *packs* of
``pack_size`` (4 by default: one RGBA texel per pack, Schwenk et al. 2010 §3.3).

Two ways to grow the model pack by pack:

``"greedy"``
    The paper's method: each new pack is fitted jointly (ALS over its 4 terms)
    to the residual of the packs before it, which stay fixed.
``"joint"``
    Each new pack is first fitted to the residual as above, then every term of
    every pack is refined together by ALS. Errors are never worse than greedy's
    for the same term count (the refinement starts from the greedy state and is
    only kept when it lowers the exact error).

Neither method forms the residual tensor: the residual's MTTKRP is the
tensor's minus the fixed terms' contribution, computed from small Gram matrices.

Numerics
--------
* Large contractions run in the tensor's dtype (float32 BLAS); every norm,
  inner product and error is accumulated in float64. Sweep-level stopping uses
  the float64 Kruskal norm of the change of the model, not the float32
  ``‖T‖² − 2⟨T, X⟩ + ‖X‖²`` formula, which cancels catastrophically.
* Degeneracy (diverging, cancelling components) is held off by a ridge term
  that is raised tenfold whenever a sweep would give any term a weight above
  ``weight_bound · ‖T‖``; such a sweep is rejected. So every accepted state
  satisfies ``max_r w_r ≤ weight_bound · ‖T‖_F`` (documented bound, tested).
* A pack that would raise the exact error is dropped, so errors never increase
  from pack to pack.

References
----------
Kolda, T. G., Bader, B. W. (2009). Tensor decompositions and applications.
SIAM Review 51(3), 455–500 (CP-ALS, MTTKRP, HOSVD).
Schwenk, K., Kuijper, A., Bockholt, U. (2010). Modeling wavelength-dependent
BRDFs as factored tensors for real-time spectral rendering. GRAPP 2010.

The tensor algebra lives in :mod:`.tensor_ops` and the Tucker compression in
:mod:`.tucker`; both are re-exported here.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from ..progress import ProgressCallback, report
from .tensor_ops import (  # noqa: F401  (re-exported: importable from here as before)
    CHUNK_BYTES,
    Factors,
    balance,
    chunk_slices,
    khatri_rao,
    kruskal_inner,
    mode_gram,
    mttkrp,
    reconstruct,
    tensor_norm_sq,
    term_weights,
)
from .tucker import TuckerCompression, _multi_mode_product, tucker_compress  # noqa: F401

# --------------------------------------------------------------------------- ALS


@dataclass
class ALSSettings:
    """Knobs of the ALS solver; the defaults are what the benchmark uses."""

    max_sweeps: int = 60
    tolerance: float = 1e-6      # stop when ‖ΔX‖ / ‖T‖ falls below this
    ridge: float = 1e-12         # initial Tikhonov weight, relative to the Gram scale
    weight_bound: float = 10.0   # accepted states keep every term weight ≤ this · ‖T‖
    refine_sweeps: int = 8       # joint refinement sweeps after each new pack
    chunk_bytes: int = CHUNK_BYTES


@dataclass
class PackHistory:
    """Error after each pack: squared residual norms in float64."""

    error_sq: list[float] = field(default_factory=list)
    sweeps: list[int] = field(default_factory=list)
    ridge: list[float] = field(default_factory=list)


def _last_mode_partial(tensor: np.ndarray, last: np.ndarray) -> np.ndarray:
    """``P[r, …] = Σ_λ T[…, λ] E[λ, r]`` as (R, n_0, …, n_{d-2}), one BLAS pass over T."""
    flat = tensor.reshape(-1, tensor.shape[-1])
    out = np.dot(last.T.astype(tensor.dtype), flat.T)
    return out.reshape((last.shape[1],) + tensor.shape[:-1])


def _mttkrp_from_partial(partial: np.ndarray, factors: Sequence[np.ndarray],
                         mode: int) -> np.ndarray:
    """MTTKRP for an angular ``mode`` from :func:`_last_mode_partial` (one GEMV pass per term)."""
    shape = partial.shape[1:]
    left_size = int(np.prod(shape[:mode]))
    right_size = int(np.prod(shape[mode + 1:]))
    out = np.empty((shape[mode], partial.shape[0]))
    dtype = partial.dtype
    for r in range(partial.shape[0]):
        # One term's Kronecker vectors, built per term: small and contiguous.
        column = [f[:, r: r + 1] for f in factors]
        block = partial[r].reshape(left_size, shape[mode] * right_size)
        if left_size > 1:
            block = khatri_rao(column[:mode], dtype, 1)[:, 0] @ block
        right = khatri_rao(column[mode + 1: len(shape)], dtype, 1)[:, 0]
        out[:, r] = block.reshape(shape[mode], right_size) @ right
    return out


def _mttkrp_last(tensor: np.ndarray, factors: Sequence[np.ndarray], chunk_bytes: int
                 ) -> np.ndarray:
    """MTTKRP for the last mode: per row of axis 0, ``T[a]ᵀ · KR(A_1 … A_{d-2})`` batched.

    The Khatri–Rao rows of the middle modes are formed once and stay in cache;
    each slab of T is read once by a batched GEMM, then weighted by ``A_0``.
    """
    rank = factors[0].shape[1]
    kr_rest = khatri_rao(factors[1:-1], tensor.dtype, rank)
    first = factors[0].astype(np.float64)
    depth = tensor.shape[-1]
    slabs = tensor.reshape(tensor.shape[0], -1, depth)
    out = np.zeros((depth, rank))
    for sl in chunk_slices(tensor.shape[0], tensor[0].nbytes, chunk_bytes):
        z = np.matmul(slabs[sl].transpose(0, 2, 1), kr_rest)  # (rows, depth, rank)
        out += np.einsum("alr,ar->lr", z.astype(np.float64), first[sl])
    return out


def sweep_mttkrps(tensor: np.ndarray, factors: Factors, update, chunk_bytes: int = CHUNK_BYTES
                  ) -> None:
    """One ALS sweep over modes 0…d−1, calling ``update(mode, mttkrp)`` for each.

    Where it fits in memory, ``P = T ×_{d-1} A_{d-1}`` is formed once (one pass
    over T) and serves every other mode, since the last factor only changes at
    the sweep's end; the last mode takes one more pass. Otherwise each mode
    walks T once through :func:`mttkrp`.
    """
    d = tensor.ndim
    rank = factors[0].shape[1]
    partial_bytes = tensor.nbytes // tensor.shape[-1] * rank
    kr_bytes = tensor.nbytes // (tensor.shape[0] * tensor.shape[-1]) * rank
    if d >= 3 and partial_bytes <= max(tensor.nbytes, chunk_bytes) and kr_bytes <= chunk_bytes:
        partial = _last_mode_partial(tensor, factors[-1])
        for mode in range(d - 1):
            update(mode, _mttkrp_from_partial(partial, factors, mode))
        del partial
        update(d - 1, _mttkrp_last(tensor, factors, chunk_bytes))
        return
    for mode in range(d):
        update(mode, mttkrp(tensor, factors, mode, chunk_bytes))


def _als_update(tensor, fixed, free, mode, ridge, settings, m=None):
    """Least-squares update of ``free[mode]`` against ``T − X_fixed``."""
    if m is None:
        m = mttkrp(tensor, free, mode, settings.chunk_bytes)
    if fixed is not None and fixed[0].shape[1] > 0:
        cross = np.ones((fixed[0].shape[1], free[0].shape[1]))
        for k, (ff, fr) in enumerate(zip(fixed, free)):
            if k != mode:
                cross *= ff.T @ fr
        m -= fixed[mode] @ cross
    gram = np.ones((free[0].shape[1],) * 2)
    for k, f in enumerate(free):
        if k != mode:
            gram *= f.T @ f
    scale = max(float(np.trace(gram)) / gram.shape[0], np.finfo(float).tiny)
    lhs = gram + ridge * scale * np.eye(gram.shape[0])
    try:
        return np.linalg.solve(lhs, m.T).T
    except np.linalg.LinAlgError:
        return np.linalg.lstsq(lhs, m.T, rcond=None)[0].T


def als(tensor: np.ndarray, init: Factors, *, fixed: Factors | None = None,
        norm_sq: float | None = None, settings: ALSSettings | None = None,
        sweeps: int | None = None) -> tuple[Factors, int, float]:
    """Run ALS sweeps on the terms ``init`` against ``T − X_fixed``.

    Returns the factors, the number of sweeps run and the final ridge. Sweeps
    run over modes 0…d−1 (a new pack starts with a zero mode 0, so its first
    update can only lower the error).
    """
    settings = settings or ALSSettings()
    norm_sq = tensor_norm_sq(tensor) if norm_sq is None else norm_sq
    norm = np.sqrt(norm_sq)
    if norm == 0:
        return [np.zeros_like(f) for f in init], 0, settings.ridge
    bound = settings.weight_bound * norm
    factors = [f.astype(np.float64).copy() for f in init]
    ridge = settings.ridge
    max_sweeps = settings.max_sweeps if sweeps is None else sweeps
    done = 0
    while done < max_sweeps:
        trial = [f.copy() for f in factors]

        def update(mode, m, trial=trial, ridge=ridge):
            trial[mode] = _als_update(tensor, fixed, trial, mode, ridge, settings, m)

        sweep_mttkrps(tensor, trial, update, settings.chunk_bytes)
        trial = balance(trial)
        if not all(np.isfinite(f).all() for f in trial) or term_weights(trial).max() > bound:
            if ridge >= 1e2:
                break
            ridge = max(ridge * 10.0, 1e-8)
            continue
        change_sq = (kruskal_inner(trial, trial) + kruskal_inner(factors, factors)
                     - 2.0 * kruskal_inner(trial, factors))
        factors = trial
        done += 1
        if np.sqrt(max(change_sq, 0.0)) <= settings.tolerance * norm:
            break
    return factors, done, ridge


def residual_norm_sq(tensor: np.ndarray, factors: Sequence[np.ndarray], norm_sq: float,
                     chunk_bytes: int = CHUNK_BYTES) -> float:
    """‖T − X‖² = ‖T‖² − 2⟨T, X⟩ + ‖X‖² with ⟨T, X⟩ from a float64 MTTKRP.

    The inner product is accumulated in float64 from a chunked float64
    contraction (not the float32 MTTKRP), so the difference keeps ~1e-12
    relative accuracy, enough for errors down to ~1e-6 ‖T‖.
    """
    if factors[0].shape[1] == 0:
        return norm_sq
    inner = 0.0
    d = tensor.ndim
    rows = tensor.shape[0]
    for sl in chunk_slices(rows, 16 * tensor[0].size):
        block = tensor[sl].astype(np.float64)
        part = [factors[0][sl].astype(np.float64)] + [f.astype(np.float64) for f in factors[1:]]
        m = mttkrp(block, part, d - 1, chunk_bytes=chunk_bytes)
        inner += float(np.sum(m * part[-1]))
    return max(norm_sq - 2.0 * inner + kruskal_inner(factors, factors), 0.0)


def default_error_floor(dtype) -> float:
    """The relative error below which another pack fits only round-off: 1e-7 for float64
    tensors; for float32 ones 8 ε₃₂ ≈ 9.5e-7, since float32 contractions leave a few ε of
    round-off that depends on the BLAS kernel the CPU selects (an exact rank-1 float32
    tensor fits to 2.5e-8 on one machine and 1.8e-7 on an AMD EPYC with OpenBLAS 0.3.23)."""
    if np.dtype(dtype) == np.float32:
        return 8.0 * float(np.finfo(np.float32).eps)
    return 1e-7


def fit_packs(
    tensor: np.ndarray,
    max_packs: int,
    *,
    pack_size: int = 4,
    method: str = "joint",
    settings: ALSSettings | None = None,
    seed: int = 0,
    on_pack: Callable[[int, Factors, float], bool] | None = None,
    callback: ProgressCallback | None = None,
    error_floor: float | None = None,
) -> tuple[Factors, PackHistory]:
    """Grow a CP model pack by pack (see the module docstring for the methods).

    Parameters
    ----------
    tensor : ndarray
        Any order ≥ 2; float32 or float64.
    max_packs : int
        Upper bound on packs.
    on_pack : callable, optional
        ``on_pack(packs, factors, error_sq) -> stop?`` after each pack (for
        snapshots and colour-error stopping rules).
    error_floor : float, optional
        Stop early once ``‖T − X‖ ≤ error_floor · ‖T‖`` (a rank-1 tensor asked for
        8 packs gets 1): further packs would only fit round-off. Default
        :func:`default_error_floor` of the tensor's dtype.

    Returns
    -------
    factors, history
    """
    if method not in ("joint", "greedy"):
        raise ValueError(f"method must be 'joint' or 'greedy', got {method!r}")
    if max_packs < 1 or pack_size < 1:
        raise ValueError(f"need max_packs ≥ 1 and pack_size ≥ 1, got {max_packs}, {pack_size}")
    settings = settings or ALSSettings()
    if error_floor is None:
        error_floor = default_error_floor(tensor.dtype)
    rng = np.random.default_rng(seed)
    norm_sq = tensor_norm_sq(tensor)
    factors: Factors = [np.zeros((n, 0)) for n in tensor.shape]
    history = PackHistory()
    error_sq = norm_sq
    for pack in range(1, max_packs + 1):
        report(callback, (pack - 1) / max_packs, f"pack {pack}/{max_packs}")
        if norm_sq == 0 or error_sq <= (error_floor**2) * norm_sq:
            break
        # New pack: random unit directions, zero first mode, so its first update
        # is an exact least-squares step from "no new pack".
        init = [rng.standard_normal((n, pack_size)) for n in tensor.shape]
        init = [f / np.linalg.norm(f, axis=0) for f in init]
        init[0][:] = 0.0
        new, sweeps, ridge = als(tensor, init, fixed=factors, norm_sq=norm_sq,
                                 settings=settings)
        candidate = [np.concatenate([f, g], axis=1) for f, g in zip(factors, new)]
        candidate_err = residual_norm_sq(tensor, candidate, norm_sq, settings.chunk_bytes)
        if method == "joint" and settings.refine_sweeps > 0:
            refined, more, ridge = als(tensor, candidate, norm_sq=norm_sq, settings=settings,
                                       sweeps=settings.refine_sweeps)
            refined_err = residual_norm_sq(tensor, refined, norm_sq, settings.chunk_bytes)
            if refined_err < candidate_err:
                candidate, candidate_err, sweeps = refined, refined_err, sweeps + more
        if candidate_err > error_sq:
            break  # this pack would not help: keep the error monotone
        factors, error_sq = candidate, candidate_err
        history.error_sq.append(error_sq)
        history.sweeps.append(sweeps)
        history.ridge.append(ridge)
        if on_pack is not None and on_pack(pack, factors, error_sq):
            break
    return factors, history
