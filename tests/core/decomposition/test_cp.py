"""CP-ALS engine: MTTKRP, Tucker compression, pack fitting, degeneracy, float64 errors."""

import numpy as np
import pytest

from spectral_materials.core.decomposition import cp
from spectral_materials.core.errors import Cancelled


def random_kruskal(shape, rank, seed=0):
    rng = np.random.default_rng(seed)
    return [rng.standard_normal((n, rank)) for n in shape]


@pytest.mark.parametrize("shape", [(6, 5), (7, 9, 5, 4), (3, 4, 5, 2, 3)])
def test_mttkrp_matches_einsum_for_every_mode_and_chunking(shape):
    factors = random_kruskal(shape, 3)
    tensor = np.random.default_rng(1).standard_normal(shape).astype(np.float32)
    letters = "abcde"[: len(shape)]
    for mode in range(len(shape)):
        operands = [f"{letters[k]}r" for k in range(len(shape)) if k != mode]
        expr = f"{letters},{','.join(operands)}->{letters[mode]}r"
        ref = np.einsum(expr, tensor.astype(np.float64),
                        *[factors[k] for k in range(len(shape)) if k != mode])
        for chunk_bytes in (64, cp.CHUNK_BYTES):
            got = cp.mttkrp(tensor, factors, mode, chunk_bytes=chunk_bytes)
            np.testing.assert_allclose(got, ref, rtol=1e-5, atol=1e-5 * np.abs(ref).max())


def test_reconstruct_and_kruskal_inner_agree():
    factors = random_kruskal((4, 5, 6), 2)
    full = cp.reconstruct(factors)
    assert np.isclose(cp.kruskal_inner(factors, factors), np.sum(full * full))
    assert np.isclose(cp.tensor_norm_sq(full.astype(np.float32)), np.sum(full * full), rtol=1e-6)


def test_residual_norm_is_accurate_where_float32_formula_cancels():
    # Relative error 1e-5: ‖R‖²/‖T‖² = 1e-10, far below float32 epsilon.
    factors = random_kruskal((20, 30, 10), 2, seed=3)
    exact = cp.reconstruct(factors)
    noise = np.random.default_rng(4).standard_normal(exact.shape)
    tensor64 = exact + 1e-5 * np.linalg.norm(exact) / np.linalg.norm(noise) * noise
    direct = float(np.sum((tensor64 - exact) ** 2))
    got = cp.residual_norm_sq(tensor64, factors, cp.tensor_norm_sq(tensor64))
    assert got == pytest.approx(direct, rel=1e-3)


def test_balance_keeps_tensor_and_equalises_norms():
    factors = random_kruskal((4, 5, 6), 3, seed=5)
    factors[0] *= 1e3
    balanced = cp.balance(factors)
    np.testing.assert_allclose(cp.reconstruct(balanced), cp.reconstruct(factors), rtol=1e-10)
    norms = np.stack([np.linalg.norm(f, axis=0) for f in balanced])
    np.testing.assert_allclose(norms, norms[0:1].repeat(3, axis=0), rtol=1e-10)


def test_tucker_error_is_exact_by_orthogonality():
    tensor = cp.reconstruct(random_kruskal((12, 14, 9, 5), 6)).astype(np.float32)
    tensor += 1e-3 * np.random.default_rng(2).standard_normal(tensor.shape).astype(np.float32)
    tucker = cp.tucker_compress(tensor, tolerance=1e-2)
    approx = tucker.core
    for k, u in enumerate(tucker.bases):
        approx = np.moveaxis(np.tensordot(u, approx, axes=([1], [k])), 0, k)
    direct = float(np.sum((tensor.astype(np.float64) - approx) ** 2))
    assert tucker.error_sq == pytest.approx(direct, rel=1e-4, abs=1e-9)
    assert np.sqrt(tucker.error_sq / tucker.tensor_norm_sq) <= 1e-2
    assert all(u.shape[1] <= n for u, n in zip(tucker.bases, tensor.shape))


@pytest.mark.parametrize("method", ["joint", "greedy"])
def test_error_never_increases_pack_to_pack(method):
    tensor = cp.reconstruct(random_kruskal((15, 12, 10, 4), 12, seed=7)).astype(np.float32)
    _, history = cp.fit_packs(tensor, 5, pack_size=2, method=method, seed=1)
    errors = np.array(history.error_sq)
    assert len(errors) >= 3
    assert np.all(np.diff(errors) <= 1e-9 * errors[0])


def test_joint_beats_greedy_per_term_on_a_low_rank_tensor():
    tensor = cp.reconstruct(random_kruskal((15, 12, 10, 4), 8, seed=11)).astype(np.float32)
    _, joint = cp.fit_packs(tensor, 2, pack_size=4, method="joint", seed=0)
    _, greedy = cp.fit_packs(tensor, 2, pack_size=4, method="greedy", seed=0)
    assert joint.error_sq[-1] <= greedy.error_sq[-1]
    # An exactly rank-8 tensor is recovered by two jointly fitted packs.
    assert joint.error_sq[-1] <= 1e-6 * cp.tensor_norm_sq(tensor)


def test_fit_is_reproducible_with_a_seed():
    tensor = cp.reconstruct(random_kruskal((8, 9, 7), 5, seed=2)).astype(np.float32)
    a, _ = cp.fit_packs(tensor, 2, seed=42)
    b, _ = cp.fit_packs(tensor, 2, seed=42)
    for fa, fb in zip(a, b):
        np.testing.assert_array_equal(fa, fb)


def test_rank_one_tensor_asked_for_eight_packs_stays_bounded():
    factors = random_kruskal((10, 12, 8, 5), 1, seed=9)
    tensor = cp.reconstruct(factors).astype(np.float32)
    norm = np.sqrt(cp.tensor_norm_sq(tensor))
    fitted, history = cp.fit_packs(tensor, 8, pack_size=4, seed=0)
    assert len(history.error_sq) <= 2  # stops at the float32 floor
    assert np.sqrt(history.error_sq[-1]) <= 1e-6 * norm
    assert cp.term_weights(fitted).max() <= cp.ALSSettings().weight_bound * norm


def test_degenerate_tensor_keeps_factor_norms_within_the_documented_bound():
    # Kruskal's border-rank example: rank 3, border rank 2. Unregularised rank-2 ALS
    # drives two components to diverge while cancelling.
    rng = np.random.default_rng(0)
    a, b = (v / np.linalg.norm(v) for v in rng.standard_normal((2, 6)))
    tensor = (np.einsum("i,j,k->ijk", a, a, b) + np.einsum("i,j,k->ijk", a, b, a)
              + np.einsum("i,j,k->ijk", b, a, a))
    norm = np.linalg.norm(tensor)
    settings = cp.ALSSettings(max_sweeps=500, tolerance=0.0)
    fitted, history = cp.fit_packs(tensor, 3, pack_size=2, settings=settings, seed=0)
    weights = cp.term_weights(fitted)
    assert np.isfinite(weights).all()
    assert weights.max() <= settings.weight_bound * norm
    assert np.all(np.diff(history.error_sq) <= 0)


def test_zero_tensor_gives_no_packs_and_no_nan():
    fitted, history = cp.fit_packs(np.zeros((4, 5, 3), np.float32), 3)
    assert history.error_sq == []
    assert all(np.isfinite(f).all() for f in fitted)


def test_huge_dynamic_range_tensor_stays_finite():
    rng = np.random.default_rng(5)
    scales = np.logspace(-4, 4, 20)  # values spanning 1e8
    factors = [scales[:, None] * rng.uniform(0.5, 1, (20, 3)), rng.uniform(0.5, 1, (9, 3)),
               rng.uniform(0.5, 1, (6, 3))]
    tensor = cp.reconstruct(factors).astype(np.float32)
    fitted, history = cp.fit_packs(tensor, 3, seed=0)
    assert all(np.isfinite(f).all() for f in fitted)
    assert np.all(np.diff(history.error_sq) <= 0)
    assert history.error_sq[-1] < 1e-4 * cp.tensor_norm_sq(tensor)


def test_callback_can_cancel():
    tensor = cp.reconstruct(random_kruskal((6, 7, 5), 4)).astype(np.float32)
    with pytest.raises(Cancelled):
        cp.fit_packs(tensor, 4, callback=lambda fraction, message: fraction >= 0.25)


def test_bad_arguments_are_refused():
    tensor = np.ones((3, 4, 5), np.float32)
    with pytest.raises(ValueError, match="method"):
        cp.fit_packs(tensor, 2, method="magic")
    with pytest.raises(ValueError, match="max_packs"):
        cp.fit_packs(tensor, 0)


def test_default_error_floor_sits_above_the_dtype_round_off():
    assert cp.default_error_floor(np.float64) == 1e-7
    assert cp.default_error_floor(np.float32) == pytest.approx(9.5367e-7, rel=1e-4)
    # An exact rank-1 float32 tensor is already at its floor after one pack, whatever
    # BLAS kernel this CPU selects.
    factors = random_kruskal((6, 7, 5), 1, seed=3)
    tensor = cp.reconstruct(factors).astype(np.float32)
    _, history = cp.fit_packs(tensor, 4, pack_size=2, seed=0)
    assert len(history.error_sq) == 1
