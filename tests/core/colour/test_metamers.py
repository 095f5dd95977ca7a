"""Tests of spectral_materials.core.colour.metamers (metameric blacks, D65/A metamers).

Conventions: XYZ of a reflectance r is Σ r · xyz_weights / π (white Y = 1), ΔE94
via core.colour_pipeline against the white under the illuminant in question.
"""

from __future__ import annotations

import numpy as np
import pytest

from spectral_materials.core.colour import metamers, pipeline as colour_pipeline, spectra

WL = spectra.WAVELENGTHS_REFERENCE
GREY = 22  # "neutral 5 (.70 D)"
PATCHES = (2, 13, GREY)


def xyz(r: np.ndarray, illuminant) -> np.ndarray:
    return r @ colour_pipeline.xyz_weights(illuminant, WL) / np.pi


@pytest.fixture(scope="module")
def results() -> dict[int, metamers.Metamer]:
    return metamers.colorchecker_metamers(PATCHES, "D65", "A", WL)


# -- metameric blacks -------------------------------------------------------------------------

@pytest.mark.parametrize("illuminant", ["D65", "A", "FL2"])
def test_black_basis_is_orthonormal_null_space_of_weights(illuminant):
    basis = metamers.metameric_black_basis(illuminant, WL)
    weights = colour_pipeline.xyz_weights(illuminant, WL)
    assert basis.shape == (WL.size, WL.size - 3)
    assert np.abs(weights.T @ basis).max() < 1e-12 * np.abs(weights).max()
    np.testing.assert_allclose(basis.T @ basis, np.eye(WL.size - 3), atol=1e-12)


def test_fundamental_metamer_plus_black_is_original():
    r = spectra.colorchecker(13, WL)
    fundamental, black = metamers.fundamental_metamer(r, "D65", WL)
    np.testing.assert_allclose(fundamental + black, r, atol=1e-15)
    np.testing.assert_allclose(xyz(fundamental, "D65"), xyz(r, "D65"), atol=1e-13)
    np.testing.assert_allclose(xyz(black, "D65"), 0.0, atol=1e-13)
    # R is a projector: the fundamental is its own fundamental, and the black lies
    # in the span of the metameric-black basis.
    again, zero = metamers.fundamental_metamer(fundamental, "D65", WL)
    np.testing.assert_allclose(again, fundamental, atol=1e-13)
    np.testing.assert_allclose(zero, 0.0, atol=1e-13)
    basis = metamers.metameric_black_basis("D65", WL)
    np.testing.assert_allclose(basis @ (basis.T @ black), black, atol=1e-13)


# -- metamers ---------------------------------------------------------------------------------

@pytest.mark.parametrize("patch", PATCHES)
def test_metamer_matches_under_d65(results, patch):
    m = results[patch]
    r = spectra.colorchecker(patch, WL)
    np.testing.assert_array_equal(m.original, r)
    assert np.abs(xyz(m.spectrum, "D65") - xyz(r, "D65")).max() <= 1e-10
    np.testing.assert_allclose(m.xyz_match_metamer, xyz(m.spectrum, "D65"), atol=1e-15)
    assert m.delta_e94_match <= 1e-6
    assert (m.match, m.differ) == ("D65", "A")


@pytest.mark.parametrize("patch, floor", [(2, 10.0), (13, 10.0), (GREY, 20.0)])
def test_metamer_differs_under_a(results, patch, floor):
    # Achieved with the defaults: patch 2 ≈ 19.9, patch 13 ≈ 15.0, grey 22 ≈ 33.5.
    m = results[patch]
    r = spectra.colorchecker(patch, WL)
    white = colour_pipeline.white_xyz("A", WL)
    de = float(colour_pipeline.delta_e94(xyz(r, "A"), xyz(m.spectrum, "A"), white))
    assert de == pytest.approx(m.delta_e94_differ, abs=1e-9)
    assert m.delta_e94_differ >= floor >= 2.0
    np.testing.assert_allclose(m.xyz_differ_original, xyz(r, "A"), atol=1e-15)
    np.testing.assert_allclose(m.xyz_differ_metamer, xyz(m.spectrum, "A"), atol=1e-15)


@pytest.mark.parametrize("patch", PATCHES)
def test_metamer_is_bounded_and_smooth(results, patch):
    m = results[patch]
    assert m.spectrum.shape == WL.shape and np.isfinite(m.spectrum).all()
    assert m.spectrum.min() >= 0.0 and m.spectrum.max() <= 1.0
    # ColorChecker patches reach max |Δ²r| = 0.04 per 5 nm; the metamers stay close.
    assert np.abs(np.diff(m.spectrum, 2)).max() <= 0.1
    # The change is a smooth black: in the 11-cosine span, nothing left over.
    phi = metamers.cosine_basis(WL, m.basis_size)
    step = m.spectrum - m.original
    np.testing.assert_allclose(phi @ (phi.T @ step), step, atol=1e-9)
    assert m.basis_size == 11 and m.success and m.status == 0


def test_metamer_is_deterministic(results):
    again = metamers.metamer(spectra.colorchecker(13, WL), "D65", "A", WL)
    np.testing.assert_array_equal(again.spectrum, results[13].spectrum)
    assert again.delta_e94_differ == results[13].delta_e94_differ


def test_custom_bounds_spd_and_smoothness():
    r = spectra.colorchecker(2, WL)
    # Patch 2 peaks at 0.801: the original itself lies outside these bounds.
    tight = metamers.metamer(r, "D65", "A", WL, bounds=(0.05, 0.8))
    assert tight.spectrum.min() >= 0.05 and tight.spectrum.max() <= 0.8
    assert np.abs(tight.xyz_match_metamer - tight.xyz_match_original).max() <= 1e-10
    # Illuminants as SPD arrays give the same answer as by name.
    custom = metamers.metamer(r, spectra.illuminant("D65", WL), spectra.illuminant("A", WL), WL)
    assert (custom.match, custom.differ) == ("custom", "custom")
    assert custom.delta_e94_differ == pytest.approx(
        metamers.metamer(r, "D65", "A", WL).delta_e94_differ, rel=1e-6)
    # A richer basis (a superset of the default's cosines) reaches at least as far.
    rough = metamers.metamer(r, "D65", "A", WL, smoothness=20.0)
    assert rough.basis_size == 21
    assert rough.delta_e94_differ >= custom.delta_e94_differ - 1e-6


def test_colorchecker_metamers_keys(results):
    assert list(results) == list(PATCHES)
    assert all(isinstance(m, metamers.Metamer) for m in results.values())


# -- errors -----------------------------------------------------------------------------------

@pytest.mark.parametrize("value", [0.0, 1.0])
def test_single_point_metamer_set_raises(value):
    with pytest.raises(ValueError, match="single point"):
        metamers.metamer(np.full(WL.size, value), "D65", "A", WL)


def test_infeasible_bounds_raise():
    dark = spectra.colorchecker(24, WL)  # ≈ 3 % reflectance: no metamer above 0.3
    with pytest.raises(ValueError, match="infeasible"):
        metamers.metamer(dark, "D65", "A", WL, bounds=(0.3, 1.0))


@pytest.mark.parametrize("reflectance, message", [
    (np.full(WL.size, np.nan), "non-finite"),
    (np.full(WL.size - 1, 0.5), "samples"),
    (np.full((2, WL.size), 0.5), "1-D"),
    (np.full(WL.size, 1.5), r"\[0, 1\]"),
    (np.full(WL.size, -0.1), r"\[0, 1\]"),
])
def test_bad_reflectance_raises(reflectance, message):
    with pytest.raises(ValueError, match=message):
        metamers.metamer(reflectance, "D65", "A", WL)


@pytest.mark.parametrize("kwargs, message", [
    ({"match": "D66"}, "unknown illuminant"),
    ({"differ": "Z"}, "unknown illuminant"),
    ({"differ": "d65"}, "same illuminant"),
    ({"differ": np.ones(3)}, "shape"),
    ({"bounds": (0.5, 0.2)}, "bounds"),
    ({"bounds": (-0.1, 1.0)}, "bounds"),
    ({"bounds": 0.5}, "bounds"),
    ({"smoothness": 0.0}, "smoothness"),
    ({"smoothness": np.nan}, "smoothness"),
    ({"smoothness": 200.0}, "cosines"),
])
def test_bad_arguments_raise(kwargs, message):
    r = spectra.colorchecker(2, WL)
    with pytest.raises(ValueError, match=message):
        metamers.metamer(r, wavelengths=WL, **kwargs)


def test_bad_inputs_to_basis_helpers_raise():
    with pytest.raises(ValueError, match="unknown illuminant"):
        metamers.metameric_black_basis("X", WL)
    with pytest.raises(ValueError, match="1-D"):
        metamers.fundamental_metamer(np.zeros((3, WL.size)), "D65", WL)
    with pytest.raises(ValueError, match="non-finite"):
        metamers.fundamental_metamer(np.full(WL.size, np.inf), "D65", WL)
    with pytest.raises(ValueError, match="cosine basis size"):
        metamers.cosine_basis(WL, 0)
