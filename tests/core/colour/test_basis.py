"""Tests of spectral_materials.core.colour.basis (Peercy's linear-model spectral basis)."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_materials.core.colour import pipeline as colour_pipeline, spectra
from spectral_materials.core.colour.basis import (
    LinearModelBasis,
    light_cmf_spectra,
    linear_model_basis,
)

WL = spectra.WAVELENGTHS_REFERENCE
LIGHTS = ("D65", "A", "FL2", "FL11")


@pytest.fixture(scope="module")
def reflectances() -> np.ndarray:
    """The 24 ColorChecker N Ohta reflectances, (24, 81)."""
    return np.stack([spectra.colorchecker(i) for i in range(1, 25)])


@pytest.fixture(scope="module")
def lights() -> np.ndarray:
    """D65, A, FL2, FL11 × (x̄, ȳ, z̄), (12, 81)."""
    return light_cmf_spectra(LIGHTS, WL)


@pytest.fixture(scope="module")
def inputs(reflectances, lights) -> np.ndarray:
    return np.concatenate([reflectances, lights])


class TestLightCmfSpectra:
    """:func:`light_cmf_spectra`."""

    def test_values(self, lights):
        assert lights.shape == (12, 81)
        cmf = spectra.cmfs(WL)
        for i, name in enumerate(LIGHTS):
            spd = spectra.illuminant(name, WL)
            for c in range(3):
                np.testing.assert_array_equal(lights[3 * i + c], spd * cmf[:, c])

    def test_spd_array(self):
        spd = np.linspace(1.0, 2.0, WL.size)
        out = light_cmf_spectra([spd], WL)
        np.testing.assert_array_equal(out, (spd[:, None] * spectra.cmfs(WL)).T)

    def test_observer(self, lights):
        np.testing.assert_array_equal(light_cmf_spectra(LIGHTS, WL, observer="1931"), lights)
        out = light_cmf_spectra(["FL2"], WL, observer="1964")
        cmf = spectra.cmfs(WL, observer="CIE 1964 10 Degree Standard Observer")
        np.testing.assert_array_equal(out, (spectra.illuminant("FL2", WL)[:, None] * cmf).T)
        with pytest.raises(ValueError, match="unknown observer"):
            light_cmf_spectra(["FL2"], WL, observer="2015")

    def test_bad_input(self):
        with pytest.raises(ValueError, match="unknown illuminant"):
            light_cmf_spectra(["D75"], WL)
        with pytest.raises(ValueError, match="shape"):
            light_cmf_spectra([np.ones(10)], WL)


class TestLinearModelBasis:
    """:func:`linear_model_basis`: orthonormality, sizing, projection."""

    @pytest.mark.parametrize("count", [1, 4, 8, 16, 36])
    def test_orthonormal(self, reflectances, lights, count):
        b = linear_model_basis(WL, reflectances, lights, count=count)
        assert isinstance(b, LinearModelBasis)
        assert b.size == count
        assert b.vectors.shape == (81, count)
        np.testing.assert_allclose(b.vectors.T @ b.vectors, np.eye(count), atol=1e-12)
        np.testing.assert_array_equal(b.wavelengths, WL)

    def test_singular_values(self, reflectances, lights):
        b = linear_model_basis(WL, reflectances, lights, count=8)
        s = b.singular_values
        assert s.shape == (36,)
        assert np.all(np.diff(s) <= 0) and s[-1] >= 0
        # Inputs are scaled to unit norm, so Σ s² is the number of spectra.
        assert np.sum(s**2) == pytest.approx(36.0, rel=1e-12)

    def test_sign_convention_and_reproducibility(self, inputs):
        a = linear_model_basis(WL, inputs, count=10)
        b = linear_model_basis(WL, inputs[::-1].copy(), count=10)
        peak = a.vectors[np.abs(a.vectors).argmax(axis=0), np.arange(10)]
        assert np.all(peak > 0)
        np.testing.assert_allclose(a.vectors, b.vectors, atol=1e-10)

    def test_scale_invariance(self, reflectances, lights):
        # Each input is normalised first: scaling one spectrum changes nothing.
        a = linear_model_basis(WL, reflectances, lights, count=8)
        b = linear_model_basis(WL, reflectances * 1e3, lights * 1e-4, count=8)
        np.testing.assert_allclose(a.vectors, b.vectors, atol=1e-10)

    def test_light_cmf_optional(self, reflectances):
        b = linear_model_basis(WL, reflectances, count=5)
        assert b.size == 5
        assert b.singular_values.shape == (24,)

    @pytest.mark.parametrize("tolerance", [0.3, 0.1, 0.05, 0.02, 0.01, 1e-3])
    def test_tolerance_picks_smallest_size(self, inputs, tolerance):
        b = linear_model_basis(WL, inputs, tolerance=tolerance)
        m = b.size
        assert b.relative_error(inputs).max() <= tolerance
        if m > 1:
            smaller = linear_model_basis(WL, inputs, count=m - 1)
            assert smaller.relative_error(inputs).max() > tolerance

    def test_tolerance_monotone(self, inputs):
        tolerances = [0.5, 0.3, 0.1, 0.05, 0.02, 0.01, 1e-3, 1e-4]
        sizes = [linear_model_basis(WL, inputs, tolerance=t).size for t in tolerances]
        assert sizes == sorted(sizes)
        assert sizes[0] < sizes[-1]
        # Measured with colour-science 0.4.6: 0.3 → 6, 0.1 → 11, 1e-3 → 34 vectors.
        assert sizes[1] == 6 and sizes[2] == 11 and sizes[6] == 34

    def test_default_tolerance(self, inputs):
        assert linear_model_basis(WL, inputs).size == linear_model_basis(
            WL, inputs, tolerance=1e-3).size

    def test_tolerance_beyond_rank(self):
        # Three spectra can be matched exactly by 3 vectors whatever the tolerance.
        x = np.stack([spectra.colorchecker(i) for i in (1, 2, 3)])
        b = linear_model_basis(WL, x, tolerance=1e-9)
        assert b.size == 3
        np.testing.assert_allclose(b.relative_error(x), 0.0, atol=1e-12)

    def test_rank_deficient_input(self):
        # Repeated and proportional spectra: the rank is 2, the tolerance search stops there.
        a, b = spectra.colorchecker(1), spectra.colorchecker(13)
        x = np.stack([a, 2 * a, b, 0.5 * b, a])
        basis = linear_model_basis(WL, x, tolerance=1e-6)
        assert basis.size == 2

    @pytest.mark.parametrize("tolerance", [0.0, 1.0, -0.1, 2.0, np.nan])
    def test_invalid_tolerance(self, inputs, tolerance):
        with pytest.raises(ValueError, match="tolerance"):
            linear_model_basis(WL, inputs, tolerance=tolerance)

    @pytest.mark.parametrize("count", [0, -1, 37, 82])
    def test_invalid_count(self, reflectances, lights, count):
        # 36 spectra span at most 36 dimensions: a larger count is an error, not a crash.
        with pytest.raises(ValueError, match=r"1\.\.36"):
            linear_model_basis(WL, reflectances, lights, count=count)

    def test_count_bounded_by_wavelengths(self):
        rng = np.random.default_rng(3)
        x = rng.uniform(0.0, 1.0, (100, WL.size))
        assert linear_model_basis(WL, x, count=81).size == 81
        with pytest.raises(ValueError, match=r"1\.\.81"):
            linear_model_basis(WL, x, count=82)

    @pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
    def test_non_finite_input(self, reflectances, lights, bad):
        x = reflectances.copy()
        x[3, 40] = bad
        with pytest.raises(ValueError, match="non-finite"):
            linear_model_basis(WL, x, lights, count=4)
        y = lights.copy()
        y[0, 0] = bad
        with pytest.raises(ValueError, match="non-finite"):
            linear_model_basis(WL, reflectances, y, count=4)

    def test_zero_input(self, reflectances):
        with pytest.raises(ValueError, match="all zero"):
            linear_model_basis(WL, np.zeros((5, WL.size)), count=2)
        with pytest.raises(ValueError, match="all zero"):
            linear_model_basis(WL, np.zeros((5, WL.size)), np.zeros((3, WL.size)))
        # Zero spectra among others are dropped.
        x = np.concatenate([reflectances, np.zeros((2, WL.size))])
        a = linear_model_basis(WL, x, count=6)
        b = linear_model_basis(WL, reflectances, count=6)
        np.testing.assert_allclose(a.vectors, b.vectors, atol=1e-10)

    def test_wrong_length(self, reflectances):
        with pytest.raises(ValueError, match="samples"):
            linear_model_basis(WL, reflectances[:, :-1], count=4)
        with pytest.raises(ValueError):
            linear_model_basis(WL[::-1], reflectances, count=4)

    def test_single_spectrum(self):
        x = spectra.colorchecker(7)
        b = linear_model_basis(WL, x, count=1)
        np.testing.assert_allclose(b.vectors[:, 0], x / np.linalg.norm(x), atol=1e-12)


# Module-level (pytest 9 deprecates class-scoped fixtures defined as instance methods).
@pytest.fixture(scope="module")
def basis8(reflectances, lights):
    return linear_model_basis(WL, reflectances, lights, count=8)


class TestProjection:
    """``project`` / ``reconstruct`` / ``relative_error``."""

    def test_exact_inside_span(self, basis8):
        rng = np.random.default_rng(0)
        coefficients = rng.normal(size=(10, 8))
        x = basis8.reconstruct(coefficients)
        np.testing.assert_allclose(basis8.project(x), coefficients, atol=1e-12)
        np.testing.assert_allclose(basis8.reconstruct(basis8.project(x)), x, atol=1e-12)
        np.testing.assert_allclose(basis8.relative_error(x), 0.0, atol=1e-12)

    def test_full_basis_reproduces_inputs(self, inputs):
        b = linear_model_basis(WL, inputs, count=36)
        np.testing.assert_allclose(b.reconstruct(b.project(inputs)), inputs,
                                   atol=1e-12 * np.abs(inputs).max())

    def test_projection_is_orthogonal(self, basis8, reflectances):
        residual = reflectances - basis8.reconstruct(basis8.project(reflectances))
        np.testing.assert_allclose(basis8.project(residual), 0.0, atol=1e-12)

    def test_relative_error(self, basis8, reflectances):
        err = basis8.relative_error(reflectances)
        assert err.shape == (24,)
        assert np.all((err >= 0) & (err < 1))
        residual = reflectances - basis8.reconstruct(basis8.project(reflectances))
        np.testing.assert_allclose(
            err, np.linalg.norm(residual, axis=1) / np.linalg.norm(reflectances, axis=1))
        assert basis8.relative_error(np.zeros(WL.size)) == 0.0
        # Scale invariant.
        np.testing.assert_allclose(basis8.relative_error(reflectances * 7.0), err)

    def test_n_dimensional(self, basis8, reflectances):
        x = reflectances[:20].reshape(4, 5, 81)
        c = basis8.project(x)
        assert c.shape == (4, 5, 8)
        np.testing.assert_allclose(c.reshape(20, 8), basis8.project(reflectances[:20]),
                                   atol=1e-14)
        np.testing.assert_allclose(c[2, 3], basis8.project(x[2, 3]), atol=1e-14)
        y = basis8.reconstruct(c)
        assert y.shape == (4, 5, 81)
        np.testing.assert_allclose(y.reshape(20, 81),
                                   basis8.reconstruct(basis8.project(reflectances[:20])),
                                   atol=1e-14)
        assert basis8.relative_error(x).shape == (4, 5)
        assert basis8.project(x[0, 0]).shape == (8,)

    def test_dtypes(self, basis8, reflectances):
        assert basis8.project(reflectances.astype(np.float32)).dtype == np.float32
        assert basis8.project(reflectances).dtype == np.float64
        assert basis8.project(np.ones((2, 81), dtype=np.int64)).dtype == np.float64

    def test_wrong_length(self, basis8):
        with pytest.raises(ValueError, match="81"):
            basis8.project(np.ones((3, 80)))


def _coefficient_xyz_de94(reflectances, lights, count):
    """ΔE94 (per light, per patch) between coefficient-dot-product XYZ and the 5 nm sum.

    A Lambertian of albedo R(λ) (f = R/π) at normal incidence: XYZ = Σ_λ R W / π with the
    protocol-normalised W = k·E·cmf·Δλ. With the basis: XYZ_c = Σ_j R̃_j W̃_cj / π.
    """
    b = linear_model_basis(WL, reflectances, lights, count=count)
    out = {}
    for name in LIGHTS:
        w = colour_pipeline.xyz_weights(name, WL)
        reference = reflectances @ w / np.pi
        dotted = b.project(reflectances) @ b.project(w.T).T / np.pi
        out[name] = colour_pipeline.delta_e94(reference, dotted,
                                              colour_pipeline.white_xyz(name, WL))
    return out


class TestCoefficientColour:
    """Peercy / Schwenk et al. (2010) eq. 9: colour as a dot product of coefficients.

    Measured with colour-science 0.4.6, the 24 ColorChecker N Ohta patches, basis from
    those + D65/A/FL2/FL11 × CMF (36 spectra), ΔE94 mean / max per illuminant:

        m   D65        A          FL2        FL11        all (96)
        4   2.75/6.55  3.46/10.25 3.42/8.59  6.61/21.77  4.06/21.77
        6   1.52/3.61  1.43/4.35  2.04/5.09  2.49/9.17   1.87/9.17
        8   0.43/1.10  0.45/1.82  0.98/2.35  3.29/9.19   1.29/9.19
        10  0.12/0.35  0.24/0.78  0.31/1.07  0.49/1.50   0.29/1.50
        12  0.03/0.08  0.06/0.20  0.16/0.50  0.08/0.28   0.08/0.50
        16  0.01/0.02  0.01/0.04  0.02/0.07  0.01/0.05   0.01/0.07

    So m = 8 is "almost unseeable" (mean < 1) under D65, A and FL2, but the tri-band FL11
    needs m ≈ 10 for that; m = 12 is below 1 everywhere.
    """

    def test_exact_when_light_in_span(self, reflectances, lights):
        # With every input in the span the dot product is the 5 nm sum to rounding.
        de = _coefficient_xyz_de94(reflectances, lights, 36)
        for name in LIGHTS:
            np.testing.assert_allclose(de[name], 0.0, atol=1e-8)

    def test_identity(self, reflectances, lights):
        # Σ_j R̃_j Ĩ_j equals Σ_λ (P R)(λ) I(λ) with P = ΨΨᵀ, exactly.
        b = linear_model_basis(WL, reflectances, lights, count=8)
        w = colour_pipeline.xyz_weights("FL2", WL)
        projected = b.reconstruct(b.project(reflectances))
        np.testing.assert_allclose(b.project(reflectances) @ b.project(w.T).T,
                                   projected @ b.reconstruct(b.project(w.T)).T, rtol=1e-12)

    @pytest.mark.parametrize(
        "name, mean_bound, max_bound",
        [("D65", 0.6, 1.5), ("A", 0.6, 2.5), ("FL2", 1.2, 3.0), ("FL11", 4.0, 10.0)],
    )
    def test_m8_bound(self, reflectances, lights, name, mean_bound, max_bound):
        de = _coefficient_xyz_de94(reflectances, lights, 8)[name]
        assert de.shape == (24,)
        assert de.mean() < mean_bound
        assert de.max() < max_bound

    def test_m12_invisible(self, reflectances, lights):
        de = np.concatenate(list(_coefficient_xyz_de94(reflectances, lights, 12).values()))
        assert de.max() < 1.0
        assert de.mean() < 0.15

    def test_improves_with_m(self, reflectances, lights):
        stats = {}
        for m in (4, 6, 8, 10, 12, 16):
            de = np.concatenate(list(_coefficient_xyz_de94(reflectances, lights, m).values()))
            stats[m] = (de.mean(), de.max())
        means = [stats[m][0] for m in sorted(stats)]
        assert all(a > b for a, b in zip(means, means[1:], strict=False))
        # The worst case is not strictly monotone (6 → 8 is flat on FL11), but it falls overall.
        maxima = [stats[m][1] for m in (4, 8, 12, 16)]
        assert all(a > b for a, b in zip(maxima, maxima[1:], strict=False))
        assert stats[16][1] < 0.1
