"""The albedo's texture basis (core/prt/albedo_basis.py) against the R̃ layers it replaces:
exact for Smits-uplifted RGB images, within its stated error for the ColorChecker chart,
filtering that commutes with the basis, the packing the shader reads, bad input."""

from __future__ import annotations

import numpy as np
import pytest
from albedo_charts import chart_texture

from spectral_materials.core.prt import albedo as core_albedo
from spectral_materials.core.prt.albedo_basis import (
    albedo_to_basis,
    choose_albedo_basis,
    colour_error,
    saves_fetches,
)

WL = np.arange(400.0, 701.0, 10.0)


def _chart(patch: int = 4) -> np.ndarray:
    return chart_texture(WL, patch)


def _basis(m: int) -> np.ndarray:
    return core_albedo.prt_basis(_chart(1).reshape(-1, WL.size), ["FL4"], WL, m)


def _relative_error(basis, layers) -> float:
    return float(np.abs(basis.layers() - layers).max() / np.abs(layers).max())


def test_an_uplifted_rgb_image_is_reproduced_exactly_in_two_layers():
    # Smits mixes 7 spectra: every texel's R̃ lies in a 7-dimensional subspace.
    rgb = np.random.default_rng(3).random((24, 40, 3))
    layers = core_albedo.albedo_layers_from_rgb(rgb, WL, _basis(8)).layers
    basis = albedo_to_basis(layers)
    assert basis.rank == 8 and basis.weight_layers == 2
    assert _relative_error(basis, layers) < 1e-6
    # The stated error is the float64 one; layers() rounds to float32 on top.
    assert basis.error == pytest.approx(_relative_error(basis, layers), abs=1e-7)
    assert saves_fetches(basis, 8)


def test_the_chart_keeps_twelve_weights_within_the_tolerance_at_m8():
    layers = core_albedo.albedo_layers_from_spectra(_chart(), WL, _basis(8)).layers
    basis = albedo_to_basis(layers)
    assert basis.rank == 12 and basis.weight_layers == 3
    # Measured 3.4e-5 of the largest value (the tolerance bounds the Frobenius share).
    assert 0 < _relative_error(basis, layers) < 1e-4
    assert saves_fetches(basis, 8)


def test_error_grows_and_rank_falls_as_the_tolerance_grows():
    layers = core_albedo.albedo_layers_from_spectra(_chart(), WL, _basis(8)).layers
    fits = [albedo_to_basis(layers, tol) for tol in (0.0, 1e-5, 1e-4, 1e-3, 1e-2)]
    ranks = [b.rank for b in fits]
    errors = [_relative_error(b, layers) for b in fits]
    assert ranks == sorted(ranks, reverse=True) and ranks[0] > ranks[-1]
    assert all(a <= b * 1.0001 for a, b in zip(errors, errors[1:], strict=False)), errors
    assert all(r % 4 == 0 or r == 3 * 8 for r in ranks), ranks


def test_filtering_the_weights_equals_filtering_the_layers_they_draw():
    """The premise of the drawn path: the GPU filters the weights and mixes them, the
    pixel test's mirror filters the layers they make."""
    layers = core_albedo.albedo_layers_from_spectra(_chart(), WL, _basis(5)).layers
    basis = albedo_to_basis(layers)
    uv = np.random.default_rng(0).uniform(-1.3, 2.2, (500, 2))          # wraps, too
    filtered_layers = core_albedo.sample_layers(basis.layers(), uv)      # (P, m, 3)
    weights3 = np.repeat(basis.weights[..., None], 3, axis=-1)
    filtered_weights = core_albedo.sample_layers(weights3, uv)[..., 0]   # (P, r)
    via_weights = np.einsum("pk,kjc->pjc", filtered_weights, basis.mixing.astype(np.float64))
    np.testing.assert_allclose(via_weights, filtered_layers, rtol=0, atol=1e-6)


def test_weights_pack_four_to_a_layer_with_zero_padding():
    layers = core_albedo.albedo_layers_from_spectra(_chart(2), WL, _basis(3)).layers
    basis = albedo_to_basis(layers, 0.0)
    rgba = basis.weights_rgba()
    assert rgba.shape == (basis.weight_layers, 8, 12, 4)
    for k in range(basis.rank):
        np.testing.assert_array_equal(rgba[k // 4, ..., k % 4], basis.weights[k])
    for k in range(basis.rank, 4 * basis.weight_layers):
        assert not rgba[k // 4, ..., k % 4].any()


def test_a_uniform_texture_is_one_direction_and_a_black_one_is_zero():
    one = core_albedo.albedo_layers_from_spectra(np.full((3, 5, WL.size), 0.4), WL,
                                                 _basis(8)).layers
    basis = albedo_to_basis(one)
    assert _relative_error(basis, one) < 1e-6
    assert np.count_nonzero(np.abs(basis.weights).max(axis=(1, 2)) > 1e-9) == 1
    black = albedo_to_basis(np.zeros((8, 2, 2, 3), np.float32))
    assert black.error == 0.0 and not black.layers().any()


def test_the_rank_is_capped_by_the_values_per_texel():
    noise = np.random.default_rng(1).random((2, 6, 7, 3)).astype(np.float32)
    basis = albedo_to_basis(noise, 0.0)
    assert basis.rank == 6 and _relative_error(basis, noise) < 1e-6
    assert not saves_fetches(basis, 2)           # 6 values fit 2 layers either way


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_layers_are_refused(bad):
    layers = np.ones((4, 3, 3, 3), np.float32)
    layers[2, 1, 1, 0] = bad
    with pytest.raises(ValueError, match="non-finite"):
        albedo_to_basis(layers)


@pytest.mark.parametrize("shape", [(3, 4, 4), (2, 4, 4, 4), (0, 4, 4, 3)])
def test_misshapen_layers_are_refused(shape):
    with pytest.raises(ValueError, match="must be"):
        albedo_to_basis(np.zeros(shape, np.float32))


@pytest.mark.parametrize("tolerance", [-1e-3, 1.0, np.nan])
def test_absurd_tolerances_are_refused(tolerance):
    with pytest.raises(ValueError, match="tolerance"):
        albedo_to_basis(np.ones((2, 2, 2, 3), np.float32), tolerance)


def _clamped_bilinear(texels: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """A texture unit's LINEAR filter with CLAMP_TO_EDGE on (L, H, W, 4) texels: an
    independent reference for the wrap padding."""
    _, h, w, _ = texels.shape
    s, t = uv[:, 0] * w - 0.5, uv[:, 1] * h - 0.5
    i0, j0 = np.floor(s).astype(int), np.floor(t).astype(int)
    fs, ft = (s - i0)[:, None, None], (t - j0)[:, None, None]

    def at(j, i):
        return texels[:, np.clip(j, 0, h - 1), np.clip(i, 0, w - 1)].transpose(1, 0, 2)
    return ((1 - fs) * (1 - ft) * at(j0, i0) + fs * (1 - ft) * at(j0, i0 + 1)
            + (1 - fs) * ft * at(j0 + 1, i0) + fs * ft * at(j0 + 1, i0 + 1))


def test_wrap_padding_makes_a_clamped_filter_repeat():
    layers = core_albedo.albedo_layers_from_spectra(_chart(2), WL, _basis(8)).layers
    basis = albedo_to_basis(layers)
    padded = basis.weights_padded()
    r, h, w = basis.weights.shape
    assert padded.shape == (basis.weight_layers, h + 2, w + 2, 4)
    np.testing.assert_array_equal(padded[:, 0, 1:-1], basis.weights_rgba()[:, -1])
    np.testing.assert_array_equal(padded[:, 1:-1, -1], basis.weights_rgba()[:, :, 0])
    # Near the wrap in u and v, and across it (prt_frag.glsl's coordinate mapping).
    uv = np.concatenate([np.random.default_rng(2).uniform(-0.02, 0.02, (200, 2)),
                         np.random.default_rng(3).uniform(0.98, 1.02, (200, 2)),
                         np.random.default_rng(4).uniform(-3.0, 3.0, (200, 2))])
    mapped = (np.mod(uv, 1.0) * (w, h) + 1.0) / (w + 2, h + 2)
    hardware = _clamped_bilinear(padded, mapped).reshape(len(uv), -1)[:, :r]
    weights3 = np.repeat(basis.weights[..., None], 3, axis=-1)
    repeat = core_albedo.sample_layers(weights3, uv)[..., 0]
    np.testing.assert_allclose(hardware, repeat, rtol=0, atol=1e-6)


@pytest.mark.parametrize("bits", [0, 24, True])
def test_absurd_filter_weight_bits_are_refused(bits):
    with pytest.raises(ValueError, match="weight_bits"):
        core_albedo.sample_layers(np.zeros((1, 2, 2, 3)), np.zeros((1, 2)), weight_bits=bits)


def test_eight_bit_filter_weights_round_the_fractions():
    layers = np.zeros((1, 1, 2, 3))
    layers[0, 0, 1] = 1.0                                  # 0 then 1 along u
    # s = u·2 − ½ = 0.3 → the weight of texel 1 is 0.3, rounded to 77/256 with 8 bits.
    uv = np.array([[0.4, 0.5]])
    exact = core_albedo.sample_layers(layers, uv)[0, 0, 0]
    eight = core_albedo.sample_layers(layers, uv, weight_bits=8)[0, 0, 0]
    assert exact == pytest.approx(0.3) and eight == pytest.approx(77 / 256)


def test_one_ulp_across_texel_edges_moves_the_filtered_albedo_by_almost_nothing():
    """Issue 19, stable across GPUs: the PRT albedo is filtered, so two GPUs whose
    interpolated UVs differ by rounding draw nearly the same colour on a texel edge (no
    jump between the chart's patches, which differ by up to 0.9 in reflectance)."""
    layers = core_albedo.albedo_layers_from_spectra(_chart(2), WL, _basis(8)).layers
    m, h, w, _ = layers.shape
    edges = np.float32(np.arange(1, w) / w)                  # texel edges in u
    centres = np.float32(np.arange(w) / w + 0.5 / w)         # texel centres (filter seams)
    for u in np.concatenate([edges, centres]):
        below = np.nextafter(u, np.float32(0)).astype(np.float64)
        above = np.nextafter(u, np.float32(1)).astype(np.float64)
        uv = np.array([[below, 0.3], [above, 0.3]])
        exact = core_albedo.sample_layers(layers, uv)
        assert np.abs(exact[1] - exact[0]).max() < 1e-5 * np.abs(layers).max()
        # A texture unit's 8-bit weights step by 1/256 of the neighbours' difference.
        eight = core_albedo.sample_layers(layers, uv, weight_bits=8)
        assert np.abs(eight[1] - eight[0]).max() <= np.abs(layers).max() / 256 + 1e-9


def test_the_drawn_basis_grows_until_its_colours_are_within_the_bound():
    albedo = core_albedo.albedo_layers_from_spectra(_chart(), WL, _basis(8))
    chosen = choose_albedo_basis(albedo)
    assert chosen.rank == 12 and chosen.delta_e94 <= 0.05
    # 8 weights (tolerance 1e-2) move a patch by ΔE94 ~0.4: one more layer is taken.
    eight = albedo_to_basis(albedo.layers, 1e-2)
    assert eight.rank == 8 and colour_error(albedo, eight) > 0.05
    grown = choose_albedo_basis(albedo, tolerance=1e-2)
    assert grown.rank == 12 and grown.delta_e94 <= 0.05
    # No basis of fewer layers than the packed R̃ meets an impossible bound.
    assert choose_albedo_basis(albedo, bound=1e-9) is None


def test_colour_error_is_zero_for_the_full_rank_and_grows_as_weights_go():
    albedo = core_albedo.albedo_layers_from_spectra(_chart(), WL, _basis(5))
    errors = [colour_error(albedo, albedo_to_basis(albedo.layers, 0.99, rank=r))
              for r in (15, 12, 8, 4)]
    assert errors[0] < 1e-3
    assert errors == sorted(errors) and errors[-1] > 1.0


@pytest.mark.parametrize("rank", [0, 25, True])
def test_absurd_ranks_are_refused(rank):
    with pytest.raises(ValueError, match="rank"):
        albedo_to_basis(np.ones((8, 2, 2, 3), np.float32), rank=rank)
