"""Tests for the Kautz–McCool separable decompositions (SVD and ND)."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_materials.core.decomposition.separable import (
    SeparableFactors,
    matrix_view,
    normalized_decomposition,
    separable_svd,
)
from spectral_materials.core.errors import Cancelled

SHAPE = (6, 5, 4, 7, 3)  # four angular axes, three spectral samples
SPLIT = ((0, 1), (2, 3))


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    a64, b64 = np.asarray(a, np.float64), np.asarray(b, np.float64)
    return float(np.linalg.norm(a64 - b64) / np.linalg.norm(b64))


def _low_rank(rank: int, *, positive: bool = False, seed: int = 1) -> np.ndarray:
    rng = np.random.default_rng(seed)
    rows, cols = SHAPE[0] * SHAPE[1], SHAPE[2] * SHAPE[3] * SHAPE[4]
    if positive:
        g = rng.uniform(0.5, 2.0, (rows, rank))
        h = rng.uniform(0.1, 1.0, (cols, rank))
    else:
        g = rng.standard_normal((rows, rank))
        h = rng.standard_normal((cols, rank))
    return (g @ h.T).reshape(SHAPE)


def _smooth_table() -> np.ndarray:
    """A positive, smooth but not separable tensor (a lobe in coupled angles)."""
    axes = [np.linspace(0.0, 1.0, n) for n in SHAPE[:4]]
    a, b, c, d = np.meshgrid(*axes, indexing="ij")
    lam = np.linspace(0.0, 1.0, SHAPE[4])
    lobe = np.exp(-4.0 * ((a - c) ** 2 + (b - d) ** 2))[..., None]
    return 0.2 + lobe * (1.0 + 0.5 * lam) + 0.1 * (a * d)[..., None] * lam


def _decaying(rows: int = 64, cols: int = 96, seed: int = 3) -> np.ndarray:
    rng = np.random.default_rng(seed)
    u, _ = np.linalg.qr(rng.standard_normal((rows, rows)))
    v, _ = np.linalg.qr(rng.standard_normal((cols, rows)))
    sigma = 0.7 ** np.arange(rows)
    return ((u * sigma) @ v.T).reshape(8, 8, 4, 8, 3)


# ---------------------------------------------------------------------------
# Layout
# ---------------------------------------------------------------------------


def test_matrix_view_layout() -> None:
    table = np.arange(np.prod(SHAPE), dtype=np.float32).reshape(SHAPE)
    m = matrix_view(table, SPLIT)
    assert m.shape == (30, 84)
    assert m.dtype == np.float32
    assert np.shares_memory(m, table)  # contiguous split: no copy
    m2 = matrix_view(table, ((0, 2), (1, 3)))
    # Row (x0, x2), column (x1, x3, λ), all C order.
    assert m2[2 * 4 + 3, (1 * 7 + 5) * 3 + 2] == table[2, 1, 3, 5, 2]


def test_reconstruct_restores_axis_order_non_contiguous_split() -> None:
    # Rank 3 in the grouping (x0, x2) × (x1, x3, λ), built grouped and moved back.
    rng = np.random.default_rng(5)
    grouped = (rng.standard_normal((6 * 4, 3)) @ rng.standard_normal((3, 5 * 7 * 3))).reshape(
        6, 4, 5, 7, 3
    )
    table = grouped.transpose(0, 2, 1, 3, 4).astype(np.float32)
    assert table.shape == SHAPE
    split = ((0, 2), (1, 3))
    f = separable_svd(table, split, 3)
    assert f.row_shape == (6, 4) and f.col_shape == (5, 7) and f.spectral_size == 3
    rec = f.reconstruct()
    assert rec.shape == table.shape and rec.dtype == np.float32
    assert _rel(rec, table) < 1e-5
    nd = normalized_decomposition(table, ((3, 1), (0, 2)), 2)
    assert nd.reconstruct().shape == table.shape
    assert nd.shape == table.shape


# ---------------------------------------------------------------------------
# SVD
# ---------------------------------------------------------------------------


def test_svd_exact_rank_two() -> None:
    table = _low_rank(2)
    f = separable_svd(table, SPLIT, 2)
    assert isinstance(f, SeparableFactors)
    assert f.method == "svd" and f.terms == 2
    assert f.g.dtype == np.float32 and f.h.dtype == np.float32
    assert f.g.shape == (30, 2) and f.h.shape == (84, 2)
    assert f.nbytes == f.g.nbytes + f.h.nbytes
    assert _rel(f.reconstruct(), table) < 1e-5
    # h columns orthonormal, sign convention: largest |h| entry positive.
    np.testing.assert_allclose(f.h.T @ f.h, np.eye(2), atol=1e-5)
    pivots = f.h[np.abs(f.h).argmax(axis=0), [0, 1]]
    assert (pivots > 0).all()


@pytest.mark.parametrize(
    "split",
    [SPLIT, ((0,), (1, 2, 3)), ((0, 1, 2), (3,))],
    ids=["30x84", "6x420-wide", "120x21-tall"],
)
def test_svd_eckart_young_and_monotone(split) -> None:
    table = np.random.default_rng(7).standard_normal(SHAPE)
    m = matrix_view(table, split)
    sigma = np.linalg.svd(m, compute_uv=False)
    errors = []
    for k in range(1, 6):
        f = separable_svd(table, split, k)
        err = np.linalg.norm(f.reconstruct().astype(np.float64) - table)
        bound = np.sqrt(np.sum(sigma[k:] ** 2))
        assert err == pytest.approx(bound, rel=1e-4)
        np.testing.assert_allclose(np.linalg.norm(f.g, axis=0), sigma[:k], rtol=1e-5)
        errors.append(err)
    assert (np.diff(errors) < 0).all()


def test_svd_randomized_blockwise_matches_exact_and_is_reproducible() -> None:
    table = _decaying().astype(np.float32)
    exact = separable_svd(table, SPLIT, 5)
    messages: list[str] = []

    def record(fraction: float, message: str) -> bool:
        assert 0.0 <= fraction <= 1.0
        messages.append(message)
        return False

    # The float64 matrix is 64 × 96 × 8 B = 48 KiB; 8 KiB forces several row blocks.
    kwargs = dict(max_bytes=8 * 1024, seed=11)
    approx = separable_svd(table, SPLIT, 5, callback=record, **kwargs)
    assert any("randomized" in msg for msg in messages)
    assert sum("range finder, rows" in msg for msg in messages) > 1  # several blocks
    err_exact = np.linalg.norm(exact.reconstruct().astype(np.float64) - table)
    err_approx = np.linalg.norm(approx.reconstruct().astype(np.float64) - table)
    assert err_approx <= err_exact * 1.01
    again = separable_svd(table, SPLIT, 5, **kwargs)
    np.testing.assert_array_equal(again.g, approx.g)
    np.testing.assert_array_equal(again.h, approx.h)
    # Non-contiguous split goes through the gathering path.
    exact_nc = separable_svd(table, ((0, 2), (1, 3)), 5)
    approx_nc = separable_svd(table, ((0, 2), (1, 3)), 5, **kwargs)
    err_nc = np.linalg.norm(approx_nc.reconstruct().astype(np.float64) - table)
    err_nc_exact = np.linalg.norm(exact_nc.reconstruct().astype(np.float64) - table)
    assert err_nc <= err_nc_exact * 1.01


# ---------------------------------------------------------------------------
# Normalized decomposition
# ---------------------------------------------------------------------------


def test_nd_exact_rank_one_positive() -> None:
    table = _low_rank(1, positive=True).astype(np.float32)
    for p in (1.0, 2.0, 4.0):
        f = normalized_decomposition(table, SPLIT, 1, p=p)
        assert f.method == "nd" and f.terms == 1
        assert _rel(f.reconstruct(), table) < 1e-5
        assert (f.g > 0).all() and (f.h > 0).all()


@pytest.mark.parametrize("p", [1.0, 2.0, 4.0])
def test_nd_pnorm_first_term_finite_positive(p: float) -> None:
    table = _smooth_table()
    f = normalized_decomposition(table, SPLIT, 1, p=p)
    assert np.isfinite(f.g).all() and np.isfinite(f.h).all()
    assert (f.g > 0).all() and (f.h > 0).all()
    svd_error = _rel(separable_svd(table, SPLIT, 1).reconstruct(), table)
    assert _rel(f.reconstruct(), table) < 1.1 * svd_error
    # Definition check of the unscaled first term: g ∝ row p-norm, h ∝ mean profile.
    m = matrix_view(table, SPLIT)
    norms = np.sum(np.abs(m) ** p, axis=1) ** (1.0 / p)
    np.testing.assert_allclose(f.g[:, 0] / f.g[0, 0], norms / norms[0], rtol=1e-5)
    profile = (m / norms[:, None]).mean(axis=0)
    np.testing.assert_allclose(f.h[:, 0], profile, rtol=1e-5)


def test_nd_residual_terms_reduce_error() -> None:
    table = _smooth_table()
    f = normalized_decomposition(table, SPLIT, 5)
    errors = [_rel(f.reconstruct(k), table) for k in range(1, 6)]
    assert (np.diff(errors) <= 1e-9).all()
    assert errors[-1] < 0.6 * errors[0]
    assert (f.h[:, 1:] < 0).any()  # residual terms carry signs
    # Same result with tiny row blocks (streaming) as in one block.
    small = normalized_decomposition(table, SPLIT, 5, block_bytes=1)
    np.testing.assert_allclose(small.g, f.g, rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(small.h, f.h, rtol=1e-5, atol=1e-7)


def test_nd_zero_rows_are_skipped() -> None:
    table = _low_rank(1, positive=True)
    table[2, 3] = 0.0
    f = normalized_decomposition(table, SPLIT, 2)
    assert np.isfinite(f.g).all() and np.isfinite(f.h).all()
    assert _rel(f.reconstruct(), table) < 1e-5


def test_nd_weights_mask_undefined_entries() -> None:
    table = _low_rank(1, positive=True)
    mask = np.ones(SHAPE[:4])
    mask[:, :, 0, :3] = 0.0
    table[:, :, 0, :3] = np.nan  # undefined where masked
    f = normalized_decomposition(table, SPLIT, 1, weights=mask)
    clean = _low_rank(1, positive=True)
    rec = f.reconstruct()
    valid = mask.astype(bool)
    np.testing.assert_allclose(rec[valid], clean[valid], rtol=1e-5)
    leaky = mask.copy()
    leaky[0, 0, 0, :3] = 0.5  # 3 angular samples × 3 spectral NaNs now count
    with pytest.raises(ValueError, match="9 non-finite values"):
        normalized_decomposition(table, SPLIT, 1, weights=leaky)
    with pytest.raises(ValueError, match="broadcast"):
        normalized_decomposition(table, SPLIT, 1, weights=np.ones(5))
    with pytest.raises(ValueError, match="non-negative"):
        normalized_decomposition(table, SPLIT, 1, weights=-mask)


# ---------------------------------------------------------------------------
# Validation and cancellation
# ---------------------------------------------------------------------------


def test_nan_raises_with_count() -> None:
    table = _smooth_table()
    table[0, 0, 0, 0, 0] = np.nan
    table[1, 2, 3, 4, 1] = np.inf
    table[5, 4, 3, 6, 2] = np.nan
    with pytest.raises(ValueError, match="3 non-finite"):
        separable_svd(table, SPLIT, 1)
    with pytest.raises(ValueError, match="3 non-finite"):
        normalized_decomposition(table, SPLIT, 1)


@pytest.mark.parametrize(
    "split",
    [((0, 1), (2,)), ((0, 1), (1, 2, 3)), ((0, 1), (2, 4)), ((), (0, 1, 2, 3)), ((0, -1), (1, 2))],
)
def test_bad_split_raises(split) -> None:
    with pytest.raises(ValueError):
        separable_svd(_smooth_table(), split, 1)
    with pytest.raises(ValueError):
        normalized_decomposition(_smooth_table(), split, 1)


@pytest.mark.parametrize("terms", [0, -1, 31])
def test_bad_terms_raise(terms: int) -> None:
    with pytest.raises(ValueError, match="terms"):
        separable_svd(_smooth_table(), SPLIT, terms)  # matrix is 30 × 84
    with pytest.raises(ValueError, match="terms"):
        normalized_decomposition(_smooth_table(), SPLIT, terms)


@pytest.mark.parametrize(
    ("run", "cancel_at"),
    [
        (lambda t, cb: separable_svd(t, SPLIT, 2, callback=cb), 2),
        (lambda t, cb: separable_svd(t, SPLIT, 2, max_bytes=4096, callback=cb), 3),
        (lambda t, cb: normalized_decomposition(t, SPLIT, 2, callback=cb), 3),
    ],
    ids=["svd", "randomized", "nd"],
)
def test_callback_cancels(run, cancel_at: int) -> None:
    table = _smooth_table()
    with pytest.raises(Cancelled):
        run(table, lambda fraction, message: True)
    calls: list[float] = []

    def later(fraction: float, message: str) -> bool:
        calls.append(fraction)
        return len(calls) >= cancel_at

    with pytest.raises(Cancelled):
        run(table, later)
    assert len(calls) == cancel_at
    fractions: list[float] = []
    run(table, lambda fraction, message: fractions.append(fraction) or False)
    assert fractions == sorted(fractions) and fractions[-1] == 1.0
