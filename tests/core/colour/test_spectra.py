"""Tests of spectral_materials.core.colour.spectra (grid, CMFs, illuminants, reflectances).

Reference values come from colour-science itself (``colour.MSDS_CMFS``,
``colour.SDS_ILLUMINANTS``, ``colour.SDS_COLOURCHECKERS``): the module must hand
them over unchanged at the datasets' own samples.
"""

from __future__ import annotations

import colour
import numpy as np
import pytest

from spectral_materials.core.colour import spectra
from spectral_materials.core.colour.spectra import (
    DELTA_LAMBDA_REFERENCE,
    ILLUMINANT_NAMES,
    WAVELENGTHS_REFERENCE,
    check_wavelengths,
    cmfs,
    colorchecker,
    colorchecker_names,
    colorchecker_spectrum,
    illuminant,
    sample_weights,
    spectrum_values,
    wavelength_grid,
)

OBSERVER = "CIE 1931 2 Degree Standard Observer"
OBSERVER_1964 = "CIE 1964 10 Degree Standard Observer"
COLORCHECKER = "ColorChecker N Ohta"
WL10 = np.arange(380.0, 781.0, 10.0)


def table(sd, wavelengths) -> np.ndarray:
    """Raw dataset values of a colour-science (multi-)spectral distribution at its own samples.

    (Indexing ``sd[w]`` goes through colour's interpolator, which is only ULP-exact at the
    nodes; the raw table is the reference.)
    """
    index = np.searchsorted(sd.wavelengths, wavelengths)
    np.testing.assert_array_equal(sd.wavelengths[index], wavelengths)
    return sd.values[index]


class TestWavelengthGrid:
    """:func:`wavelength_grid` and the reference grid constants."""

    def test_reference_grid(self):
        grid = wavelength_grid(380, 780, 5)
        assert grid.shape == (81,)
        assert grid[0] == 380.0 and grid[-1] == 780.0
        np.testing.assert_array_equal(np.diff(grid), 5.0)
        np.testing.assert_array_equal(grid, WAVELENGTHS_REFERENCE)
        assert WAVELENGTHS_REFERENCE.shape == (81,)
        assert DELTA_LAMBDA_REFERENCE == 5.0

    def test_default_is_reference(self):
        np.testing.assert_array_equal(wavelength_grid(), WAVELENGTHS_REFERENCE)

    def test_other_grids(self):
        np.testing.assert_array_equal(wavelength_grid(380, 780, 10), WL10)
        assert wavelength_grid(555, 555, 5).tolist() == [555.0]
        # Samples are start + k·step, not accumulated sums: no drift at the end.
        grid = wavelength_grid(380, 780, 0.1)
        assert grid.size == 4001
        assert grid[-1] == pytest.approx(780.0, abs=1e-9)

    @pytest.mark.parametrize(
        "args",
        [(380, 780, 0), (380, 780, -5), (780, 380, 5), (np.nan, 780, 5), (380, np.inf, 5),
         (380, 780, np.nan)],
    )
    def test_invalid(self, args):
        with pytest.raises(ValueError, match="invalid wavelength grid"):
            wavelength_grid(*args)


class TestCheckWavelengths:
    """:func:`check_wavelengths`."""

    def test_valid(self):
        out = check_wavelengths([400, 500, 600])
        assert out.dtype == np.float64
        np.testing.assert_array_equal(out, [400.0, 500.0, 600.0])
        assert check_wavelengths([555]).shape == (1,)

    @pytest.mark.parametrize("wl", [[400, 400, 500], [500, 450, 600], [600, 500, 400]])
    def test_not_strictly_increasing(self, wl):
        with pytest.raises(ValueError, match="strictly increasing"):
            check_wavelengths(wl)

    @pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
    def test_non_finite(self, bad):
        with pytest.raises(ValueError, match="NaN or inf"):
            check_wavelengths([400.0, bad, 600.0])

    @pytest.mark.parametrize("wl", [np.zeros((2, 3)) + [400, 500, 600], np.array(500.0), []])
    def test_shape(self, wl):
        with pytest.raises(ValueError, match="non-empty 1-D"):
            check_wavelengths(wl)

    @pytest.mark.parametrize("wl", [[100.0, 500.0], [500.0, 2500.0]])
    def test_range(self, wl):
        with pytest.raises(ValueError, match="outside"):
            check_wavelengths(wl)


class TestSampleWeights:
    """:func:`sample_weights`: Riemann weights whose sum is span + step."""

    def test_reference_grid(self):
        w = sample_weights(WAVELENGTHS_REFERENCE)
        assert w.shape == (81,)
        np.testing.assert_allclose(w, 5.0, atol=1e-12)
        assert w.sum() == pytest.approx((780 - 380) + 5)

    def test_coarse_grid(self):
        w = sample_weights(WL10)
        np.testing.assert_allclose(w, 10.0, atol=1e-12)
        assert w.sum() == pytest.approx(400 + 10)

    def test_non_uniform(self):
        # Cells run between midpoints, the end cells mirror their inner half.
        w = sample_weights([400.0, 410.0, 440.0])
        np.testing.assert_allclose(w, [10.0, 20.0, 30.0])
        assert w.sum() == pytest.approx(40 + 0.5 * 10 + 0.5 * 30)

    def test_single_sample(self):
        np.testing.assert_array_equal(sample_weights([555.0]), [1.0])

    def test_invalid(self):
        with pytest.raises(ValueError):
            sample_weights([500.0, np.nan])


class TestCmfs:
    """:func:`cmfs`: the CIE 1931 2° observer of colour-science."""

    def test_reference_values(self):
        reference = colour.MSDS_CMFS[OBSERVER]
        expected = table(reference, WAVELENGTHS_REFERENCE)
        out = cmfs(WAVELENGTHS_REFERENCE)
        assert out.shape == (81, 3)
        np.testing.assert_array_equal(out, expected)
        np.testing.assert_array_equal(cmfs(), expected)
        # colour's own lookup agrees to rounding.
        np.testing.assert_allclose(
            out, np.stack([reference[w] for w in WAVELENGTHS_REFERENCE]), rtol=1e-12, atol=1e-15
        )

    def test_y_bar_at_555(self):
        # CIE 1931: ȳ(555 nm) = 1.0000 (V(λ) peak); x̄, z̄ there from the 1 nm table.
        np.testing.assert_allclose(cmfs([555.0])[0], [0.5121, 1.0, 0.00575], atol=1e-4)
        assert cmfs()[35, 1] == pytest.approx(1.0, abs=1e-3)  # 555 nm is index 35

    def test_integer_wavelengths_exact(self):
        # The dataset is 1 nm; any integer wavelength is an exact table sample.
        wl = np.array([360.0, 401.0, 532.0, 699.0, 830.0])
        np.testing.assert_array_equal(cmfs(wl), table(colour.MSDS_CMFS[OBSERVER], wl))

    def test_read_only_cache(self):
        out = cmfs(WL10)
        assert not out.flags.writeable
        assert cmfs(WL10) is out

    def test_interpolation_and_extrapolation(self):
        reference = colour.MSDS_CMFS[OBSERVER]
        mid = cmfs([555.5])[0]
        np.testing.assert_allclose(mid, table(reference, [555.0, 556.0]).mean(axis=0),
                                   rtol=1e-12)
        # The observer sees nothing beyond the dataset's 360..830 nm.
        np.testing.assert_array_equal(cmfs([300.0, 900.0]), np.zeros((2, 3)))


class TestObservers:
    """:func:`cmfs` with ``observer``: the 1931 2° (default) and 1964 10° observers."""

    def test_1964_y_bar_at_555(self):
        reference = colour.MSDS_CMFS[OBSERVER_1964]
        expected = table(reference, [555.0])[0]
        out = cmfs([555.0], observer=OBSERVER_1964)[0]
        np.testing.assert_array_equal(out, expected)
        # CIE 1964 10°: ȳ₁₀(555 nm) = 0.99911, x̄₁₀ = 0.61605 (CIE 015 table).
        assert out[1] == pytest.approx(0.99911, abs=1e-6)
        assert out[0] == pytest.approx(0.616053, abs=1e-6)

    def test_1964_reference_grid(self):
        expected = table(colour.MSDS_CMFS[OBSERVER_1964], WAVELENGTHS_REFERENCE)
        np.testing.assert_array_equal(cmfs(WAVELENGTHS_REFERENCE, OBSERVER_1964), expected)
        assert not np.array_equal(expected, cmfs())

    @pytest.mark.parametrize(
        ("alias", "name"),
        [("1931", OBSERVER), ("1964", OBSERVER_1964), (OBSERVER.upper(), OBSERVER),
         (f" {OBSERVER_1964.lower()} ", OBSERVER_1964)],
    )
    def test_aliases(self, alias, name):
        assert spectra.observer_name(alias) == name
        # Aliases share the cache entry of the full name.
        assert cmfs(WL10, observer=alias) is cmfs(WL10, observer=name)

    def test_default_unchanged(self):
        assert spectra.observer_name() == OBSERVER
        np.testing.assert_array_equal(cmfs(), table(colour.MSDS_CMFS[OBSERVER],
                                                    WAVELENGTHS_REFERENCE))
        assert cmfs() is cmfs(observer=OBSERVER)
        assert spectra.OBSERVER_NAMES == (OBSERVER, OBSERVER_1964)

    def test_cache_per_observer(self):
        a = cmfs(WL10, observer="1964")
        assert not a.flags.writeable
        assert cmfs(WL10, observer="1964") is a
        assert cmfs(WL10) is not a

    @pytest.mark.parametrize("bad", ["CIE 2015 2 Degree Standard Observer", "2", "", None, 1931])
    def test_unknown(self, bad):
        with pytest.raises(ValueError, match="unknown observer") as info:
            cmfs(WL10, observer=bad)
        for choice in (OBSERVER, OBSERVER_1964, "'1931'", "'1964'"):
            assert choice in str(info.value)


class TestIlluminant:
    """:func:`illuminant`: CIE illuminants of colour-science on the caller's grid."""

    @pytest.mark.parametrize("name", ILLUMINANT_NAMES)
    def test_reference_values(self, name):
        expected = table(colour.SDS_ILLUMINANTS[name], WAVELENGTHS_REFERENCE)
        out = illuminant(name)
        assert out.shape == (81,)
        np.testing.assert_array_equal(out, expected)

    def test_names(self):
        assert ILLUMINANT_NAMES == ("A", "D50", "D65") + tuple(f"FL{i}" for i in range(1, 13))

    def test_d65_normalised_at_560(self):
        assert illuminant("D65", [560.0])[0] == pytest.approx(100.0, abs=1e-9)
        # CIE A is normalised to 100 at 560 nm as well.
        assert illuminant("A", [560.0])[0] == pytest.approx(100.0, abs=1e-9)

    def test_case_insensitive(self):
        np.testing.assert_array_equal(illuminant("d65"), illuminant("D65"))
        np.testing.assert_array_equal(illuminant("fl2"), illuminant("FL2"))

    def test_coarse_grid(self):
        np.testing.assert_array_equal(illuminant("FL11", WL10), illuminant("FL11")[::2])

    @pytest.mark.parametrize("name", ["D75", "F2", "FL13", ""])
    def test_unknown(self, name):
        with pytest.raises(ValueError, match="unknown illuminant") as info:
            illuminant(name)
        message = str(info.value)
        for known in ILLUMINANT_NAMES:
            assert known in message


class TestColorChecker:
    """:func:`colorchecker`: N Ohta reflectances, 1-based patch numbers."""

    @pytest.mark.parametrize(
        "number, name",
        [(1, "dark skin"), (6, "bluish green"), (9, "moderate red"), (12, "orange yellow"),
         (19, "white 9.5 (.05 D)"), (24, "black 2 (1.5 D)")],
    )
    def test_numbering(self, number, name):
        assert colorchecker_names()[number - 1] == name
        np.testing.assert_array_equal(colorchecker(number), colorchecker(name))
        sd = colour.SDS_COLOURCHECKERS[COLORCHECKER][name]
        np.testing.assert_array_equal(colorchecker(number), table(sd, WAVELENGTHS_REFERENCE))

    def test_all_patches(self):
        names = colorchecker_names()
        assert len(names) == 24
        values = np.stack([colorchecker(i) for i in range(1, 25)])
        assert values.shape == (24, 81)
        assert np.all((values > 0) & (values < 1))
        # The neutral row gets darker from white (19) to black (24).
        assert np.all(np.diff(values[18:].mean(axis=1)) < 0)

    def test_numpy_integer(self):
        np.testing.assert_array_equal(colorchecker(np.int64(9)), colorchecker(9))

    @pytest.mark.parametrize("patch", [0, 25, -1, 100])
    def test_bad_number(self, patch):
        with pytest.raises(ValueError, match=r"1\.\.24"):
            colorchecker(patch)

    def test_name_lookup_is_canonical(self):
        # colour's LazyCanonicalMapping matches names case-insensitively.
        np.testing.assert_array_equal(colorchecker("Dark Skin"), colorchecker(1))

    @pytest.mark.parametrize("patch", ["nope", "patch 1", 1.0])
    def test_bad_name(self, patch):
        with pytest.raises(ValueError, match="unknown ColorChecker patch"):
            colorchecker(patch)

    def test_spectrum_pair(self):
        wl, values = colorchecker_spectrum(12)
        np.testing.assert_array_equal(wl, WAVELENGTHS_REFERENCE)
        np.testing.assert_array_equal(values, colorchecker(12))
        np.testing.assert_array_equal(spectrum_values((wl, values), WL10), colorchecker(12, WL10))


class TestSpectrumValues:
    """:func:`spectrum_values` for each :data:`SpectrumLike` form."""

    def test_float(self):
        np.testing.assert_array_equal(spectrum_values(0.25, WL10), np.full(41, 0.25))
        np.testing.assert_array_equal(spectrum_values(2, WL10), np.full(41, 2.0))
        np.testing.assert_array_equal(spectrum_values(np.float32(0.5), WL10), np.full(41, 0.5))

    def test_spectral_distribution(self):
        sd = colour.SDS_ILLUMINANTS["FL2"]
        np.testing.assert_array_equal(spectrum_values(sd, WAVELENGTHS_REFERENCE),
                                      sd.values)

    def test_tuple(self):
        out = spectrum_values(([400.0, 600.0], [0.2, 0.6]), [400.0, 450.0, 500.0, 600.0, 700.0])
        # Linear in between, constant beyond.
        np.testing.assert_allclose(out, [0.2, 0.3, 0.4, 0.6, 0.6], rtol=1e-12)

    def test_callable(self):
        out = spectrum_values(lambda wl: wl / 1000.0, WL10)
        np.testing.assert_allclose(out, WL10 / 1000.0)
        # A callable may return a scalar: it is broadcast over the grid.
        np.testing.assert_array_equal(spectrum_values(lambda wl: 0.5, WL10), np.full(41, 0.5))

    def test_callable_wrong_shape(self):
        with pytest.raises(ValueError):
            spectrum_values(lambda wl: np.ones(3), WL10)

    @pytest.mark.parametrize(
        "spectrum",
        [np.nan, np.inf, lambda wl: np.where(wl > 500, np.nan, 1.0),
         (np.array([380.0, 780.0]), np.array([1.0, np.nan]))],
    )
    def test_non_finite(self, spectrum):
        with pytest.raises(ValueError, match="non-finite"):
            spectrum_values(spectrum, WAVELENGTHS_REFERENCE)

    @pytest.mark.parametrize(
        "spectrum",
        [([400.0, 500.0, 600.0], [1.0, 2.0]),
         (np.ones((2, 3)), np.ones((2, 3))),
         ([700.0, 500.0, 400.0], [1.0, 2.0, 3.0]),
         ([400.0, np.nan, 600.0], [1.0, 2.0, 3.0])],
    )
    def test_bad_tuple(self, spectrum):
        with pytest.raises(ValueError, match="wavelengths, values"):
            spectrum_values(spectrum, WL10)

    @pytest.mark.parametrize("spectrum", ["D65", None, [1.0, 2.0], (1.0, 2.0, 3.0)])
    def test_type_error(self, spectrum):
        with pytest.raises(TypeError):
            spectrum_values(spectrum, WL10)

    def test_bad_wavelengths(self):
        with pytest.raises(ValueError):
            spectrum_values(1.0, [500.0, 400.0])


class TestResampling:
    """Piecewise-linear resampling is exact at shared samples."""

    @pytest.mark.parametrize("name", ["A", "D65", "FL2", "FL11"])
    def test_illuminant_10nm(self, name):
        np.testing.assert_array_equal(illuminant(name, WL10), illuminant(name)[::2])

    def test_cmfs_10nm(self):
        np.testing.assert_array_equal(cmfs(WL10), cmfs()[::2])

    def test_colorchecker_10nm(self):
        for patch in (1, 6, 9, 12):
            np.testing.assert_array_equal(colorchecker(patch, WL10), colorchecker(patch)[::2])

    def test_midpoint(self):
        fine = illuminant("FL2")
        mid = illuminant("FL2", WAVELENGTHS_REFERENCE[:-1] + 2.5)
        np.testing.assert_allclose(mid, (fine[1:] + fine[:-1]) / 2, rtol=1e-12)

    def test_module_constants(self):
        assert spectra.OBSERVER == OBSERVER
        assert spectra.COLORCHECKER == COLORCHECKER
