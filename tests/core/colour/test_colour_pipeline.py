"""Tests of spectral_materials.core.colour.pipeline (normalisation, CIELAB, ΔE94, display).

Every display stage is checked against colour-science's own implementation.
"""

from __future__ import annotations

import colour
import numpy as np
import pytest

from spectral_materials.core.colour import spectra
from spectral_materials.core.colour.pipeline import (
    DISPLAY_WHITE_XYZ,
    bradford_adapt,
    delta_e94,
    illuminant_spd,
    srgb_encode,
    tonemap_sigmoid,
    white_xyz,
    xyz_to_display,
    xyz_to_lab,
    xyz_to_linear_srgb,
    xyz_weights,
)

WL = spectra.WAVELENGTHS_REFERENCE
WL10 = np.arange(380.0, 781.0, 10.0)
CCS = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]


def lambertian_white_xyz(weights: np.ndarray) -> np.ndarray:
    """XYZ of f = 1/π (albedo 1) at normal incidence (cos θi = 1): Σ_λ f·cos·W."""
    f = np.full(weights.shape[0], 1.0 / np.pi)
    return (f * 1.0) @ weights


def raw_weights(name: str, observer: str) -> np.ndarray:
    """E·cmf·Δλ from colour-science's own tables (un-normalised)."""
    cmf = colour.MSDS_CMFS[observer]
    index = np.searchsorted(cmf.wavelengths, WL)
    return spectra.illuminant(name, WL)[:, None] * cmf.values[index] * 5.0


def cie94_by_hand(lab_1, lab_2) -> float:
    """CIE 1994 colour difference, graphic-arts weights, written out (CIE 116-1995).

    kL = kC = kH = 1, K1 = 0.045, K2 = 0.015, SL = 1, SC = 1 + K1·C1, SH = 1 + K2·C1,
    with C1 the chroma of the *reference* (first) colour.
    """
    l1, a1, b1 = lab_1
    l2, a2, b2 = lab_2
    c1 = np.hypot(a1, b1)
    c2 = np.hypot(a2, b2)
    d_l = l1 - l2
    d_c = c1 - c2
    d_h2 = (a1 - a2) ** 2 + (b1 - b2) ** 2 - d_c**2
    s_l, s_c, s_h = 1.0, 1.0 + 0.045 * c1, 1.0 + 0.015 * c1
    return float(np.sqrt((d_l / s_l) ** 2 + (d_c / s_c) ** 2 + d_h2 / s_h**2))


def lab_to_xyz(lab, white) -> np.ndarray:
    """Inverse of :func:`xyz_to_lab` (via colour-science), for building test inputs."""
    white = np.asarray(white, dtype=float)
    return colour.Lab_to_XYZ(np.asarray(lab, dtype=float), colour.XYZ_to_xy(white)) * white[1]


class TestIlluminantSpd:
    """:func:`illuminant_spd`."""

    def test_name_and_array(self):
        np.testing.assert_array_equal(illuminant_spd("D65", WL), spectra.illuminant("D65", WL))
        spd = np.linspace(1.0, 2.0, WL.size)
        np.testing.assert_array_equal(illuminant_spd(spd, WL), spd)

    @pytest.mark.parametrize(
        "spd", [np.ones(10), -np.ones(WL.size), np.r_[np.nan, np.ones(WL.size - 1)],
                np.r_[np.inf, np.ones(WL.size - 1)]]
    )
    def test_invalid(self, spd):
        with pytest.raises(ValueError):
            illuminant_spd(spd, WL)


class TestXyzWeights:
    """:func:`xyz_weights` and :func:`white_xyz`: the protocol normalisation."""

    @pytest.mark.parametrize("name", ["D65", "A", "FL2", "FL11", "D50"])
    @pytest.mark.parametrize("wavelengths", [WL, WL10], ids=["5nm", "10nm"])
    def test_white_lambertian_y_is_1(self, name, wavelengths):
        weights = xyz_weights(name, wavelengths)
        assert weights.shape == (wavelengths.size, 3)
        xyz = lambertian_white_xyz(weights)
        assert xyz[1] == pytest.approx(1.0, abs=1e-12)
        np.testing.assert_allclose(white_xyz(name, wavelengths), xyz, rtol=1e-12)

    def test_definition(self):
        # W = k·E·cmf·Δλ: proportional to the un-normalised product.
        raw = (spectra.illuminant("FL2", WL)[:, None] * spectra.cmfs(WL) * 5.0)
        weights = xyz_weights("FL2", WL)
        k = weights / raw
        np.testing.assert_allclose(k[np.isfinite(k)], k[np.isfinite(k)].flat[0], rtol=1e-12)

    def test_scale_invariant(self):
        spd = spectra.illuminant("A", WL)
        np.testing.assert_allclose(xyz_weights(spd * 1e-3, WL), xyz_weights("A", WL),
                                   rtol=1e-12)

    def test_equal_energy(self):
        # Illuminant E: white chromaticity (1/3, 1/3) to within the CMF table's balance.
        xyz = white_xyz(np.ones(WL.size), WL)
        np.testing.assert_allclose(colour.XYZ_to_xy(xyz), [1 / 3, 1 / 3], atol=1e-3)

    @pytest.mark.parametrize("name", ["D65", "A", "FL2", "FL11"])
    def test_white_chromaticity(self, name):
        # Against colour's tabulated CIE 1931 2° chromaticities of the illuminants.
        xy = colour.XYZ_to_xy(white_xyz(name, WL))
        np.testing.assert_allclose(xy, CCS[name], atol=1e-3)

    def test_white_d65(self):
        xyz = white_xyz("D65", WL)
        np.testing.assert_allclose(colour.XYZ_to_xy(xyz), [0.3127, 0.3290], atol=1e-3)
        np.testing.assert_allclose(xyz, colour.xy_to_XYZ(CCS["D65"]), atol=1e-3)
        np.testing.assert_allclose(xyz, DISPLAY_WHITE_XYZ, atol=1e-3)

    @pytest.mark.parametrize("name", ["D65", "A", "FL2", "FL11"])
    def test_white_chromaticity_1964(self, name):
        # The 10° observer: Y₁₀ = 1 and colour's tabulated 1964 10° chromaticities.
        observer = "CIE 1964 10 Degree Standard Observer"
        weights = xyz_weights(name, WL, observer=observer)
        xyz = white_xyz(name, WL, observer="1964")
        assert xyz[1] == pytest.approx(1.0, abs=1e-12)
        np.testing.assert_allclose(lambertian_white_xyz(weights), xyz, rtol=1e-12)
        np.testing.assert_allclose(colour.XYZ_to_xy(xyz),
                                   colour.CCS_ILLUMINANTS[observer][name], atol=1e-3)
        raw = raw_weights(name, observer)
        k = weights[raw > 0] / raw[raw > 0]
        np.testing.assert_allclose(k, k[0], rtol=1e-12)

    def test_observer_default_unchanged(self):
        np.testing.assert_array_equal(
            xyz_weights("FL2", WL), xyz_weights("FL2", WL, observer=spectra.OBSERVER))
        np.testing.assert_array_equal(white_xyz("A", WL), white_xyz("A", WL, observer="1931"))
        assert not np.allclose(white_xyz("A", WL), white_xyz("A", WL, observer="1964"))
        basis = np.linalg.qr(np.random.default_rng(0).normal(size=(WL.size, 5)))[0]
        np.testing.assert_allclose(xyz_weights("D65", WL, basis, observer="1964"),
                                   basis.T @ xyz_weights("D65", WL, observer="1964"),
                                   rtol=1e-12)

    def test_unknown_observer(self):
        with pytest.raises(ValueError, match="unknown observer.*1964"):
            xyz_weights("D65", WL, observer="CIE 2015 2 Degree Standard Observer")
        with pytest.raises(ValueError, match="unknown observer"):
            white_xyz("D65", WL, observer="10")

    def test_no_luminance(self):
        with pytest.raises(ValueError, match="no luminance"):
            xyz_weights(np.zeros(WL.size), WL)

    def test_bad_wavelengths(self):
        with pytest.raises(ValueError):
            xyz_weights("D65", WL[::-1])


class TestXyzToLab:
    """:func:`xyz_to_lab`."""

    @pytest.mark.parametrize("name", ["D65", "A", "FL2"])
    def test_white(self, name):
        white = white_xyz(name, WL)
        np.testing.assert_allclose(xyz_to_lab(white, white), [100.0, 0.0, 0.0], atol=1e-10)
        # Any scaled white: only its Y is the reference, its xy the white point.
        np.testing.assert_allclose(xyz_to_lab(white * 0.5, white * 0.5), [100.0, 0.0, 0.0],
                                   atol=1e-10)

    def test_by_hand(self):
        white = white_xyz("D65", WL)
        xyz = np.array([0.2, 0.15, 0.4])

        def f(t):
            d = 6.0 / 29.0
            return np.where(t > d**3, np.cbrt(t), t / (3 * d * d) + 4.0 / 29.0)

        fx, fy, fz = f(xyz / white)
        expected = [116 * fy - 16, 500 * (fx - fy), 200 * (fy - fz)]
        np.testing.assert_allclose(xyz_to_lab(xyz, white), expected, atol=1e-10)
        # Dark colours use the linear segment.
        dark = np.array([1e-4, 1e-4, 1e-4])
        assert xyz_to_lab(dark, white)[0] == pytest.approx(903.2963 * 1e-4, rel=1e-4)

    def test_n_dimensional(self):
        white = white_xyz("A", WL)
        xyz = np.array([0.2, 0.15, 0.4])
        lab = xyz_to_lab(xyz, white)
        out = xyz_to_lab(np.tile(xyz, (2, 3, 4, 1)), white)
        assert out.shape == (2, 3, 4, 3)
        np.testing.assert_allclose(out, np.tile(lab, (2, 3, 4, 1)), atol=1e-12)


# Module-level (pytest 9 deprecates class-scoped fixtures defined as instance methods).
@pytest.fixture(scope="module")
def white():
    return white_xyz("D65", WL)


class TestDeltaE94:
    """:func:`delta_e94`: CIE 1994 (graphic arts) on the protocol's CIELAB."""

    # A hand-checked pair: C1 = 50, C2 = √1850 = 43.0116, ΔL = 5, ΔC = 6.9884,
    # ΔH² = 5² + 5² − ΔC² = 1.1620, SC = 3.25, SH = 1.75:
    # ΔE94 = √(25 + (6.9884/3.25)² + 1.1620/1.75²) = √(25 + 4.6237 + 0.3794) = 5.4775.
    LAB_1 = np.array([50.0, 30.0, 40.0])
    LAB_2 = np.array([45.0, 25.0, 35.0])
    REFERENCE = 5.47752603

    def test_by_hand(self, white):
        assert cie94_by_hand(self.LAB_1, self.LAB_2) == pytest.approx(self.REFERENCE, abs=1e-8)
        xyz_1, xyz_2 = lab_to_xyz(self.LAB_1, white), lab_to_xyz(self.LAB_2, white)
        assert float(delta_e94(xyz_1, xyz_2, white)) == pytest.approx(self.REFERENCE, abs=1e-8)

    def test_colour_reference_value(self):
        # colour-science's own test value for delta_E_CIE1994 (Lab inputs).
        lab_1 = np.array([100.00000000, 21.57210357, 272.22819350])
        lab_2 = np.array([100.00000000, 426.67945353, 72.39590835])
        assert cie94_by_hand(lab_1, lab_2) == pytest.approx(83.779225500887094, abs=1e-7)

    def test_against_colour(self, white):
        rng = np.random.default_rng(7)
        xyz_1 = rng.uniform(0.01, 1.0, (50, 3))
        xyz_2 = xyz_1 * rng.uniform(0.8, 1.2, (50, 3))
        ours = delta_e94(xyz_1, xyz_2, white)
        theirs = colour.difference.delta_E_CIE1994(xyz_to_lab(xyz_1, white),
                                                   xyz_to_lab(xyz_2, white))
        np.testing.assert_allclose(ours, theirs, rtol=1e-12)
        via_delta_e = colour.delta_E(xyz_to_lab(xyz_1, white), xyz_to_lab(xyz_2, white),
                                     method="CIE 1994")
        np.testing.assert_allclose(ours, via_delta_e, rtol=1e-12)
        by_hand = [cie94_by_hand(a, b) for a, b in
                   zip(xyz_to_lab(xyz_1, white), xyz_to_lab(xyz_2, white), strict=True)]
        np.testing.assert_allclose(ours, by_hand, rtol=1e-10)

    def test_not_symmetric(self, white):
        # CIE94 weights chroma and hue by the chroma of the first argument: the reference
        # goes first. Swapping the pair changes the value (5.4775 vs 5.5765 here).
        xyz_1, xyz_2 = lab_to_xyz(self.LAB_1, white), lab_to_xyz(self.LAB_2, white)
        forward = float(delta_e94(xyz_1, xyz_2, white))
        backward = float(delta_e94(xyz_2, xyz_1, white))
        assert backward == pytest.approx(cie94_by_hand(self.LAB_2, self.LAB_1), abs=1e-8)
        assert backward == pytest.approx(5.57646129, abs=1e-7)
        assert abs(forward - backward) > 0.05
        # Lightness-only differences are symmetric.
        grey_1 = lab_to_xyz([40.0, 0.0, 0.0], white)
        grey_2 = lab_to_xyz([60.0, 0.0, 0.0], white)
        assert float(delta_e94(grey_1, grey_2, white)) == pytest.approx(20.0, abs=1e-9)
        assert float(delta_e94(grey_2, grey_1, white)) == pytest.approx(20.0, abs=1e-9)

    def test_identical_is_zero(self, white):
        xyz = np.random.default_rng(1).uniform(0.0, 1.0, (4, 5, 3))
        np.testing.assert_allclose(delta_e94(xyz, xyz, white), 0.0, atol=1e-12)

    def test_n_dimensional(self, white):
        xyz_1, xyz_2 = lab_to_xyz(self.LAB_1, white), lab_to_xyz(self.LAB_2, white)
        out = delta_e94(np.tile(xyz_1, (2, 3, 1)), np.tile(xyz_2, (2, 3, 1)), white)
        assert out.shape == (2, 3)
        np.testing.assert_allclose(out, self.REFERENCE, atol=1e-8)
        # Broadcasting a single reference against many tests.
        assert delta_e94(xyz_1, np.tile(xyz_2, (5, 1)), white).shape == (5,)

    @pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
    def test_non_finite(self, white, bad):
        good = np.array([[0.2, 0.3, 0.4], [0.1, 0.1, 0.1]])
        broken = good.copy()
        broken[1, 2] = bad
        with pytest.raises(ValueError, match="reference XYZ has 1 non-finite"):
            delta_e94(broken, good, white)
        with pytest.raises(ValueError, match="test XYZ has 1 non-finite"):
            delta_e94(good, broken, white)


class TestBradfordAdapt:
    """:func:`bradford_adapt` against colour-science's von Kries / Bradford."""

    def test_against_colour(self):
        rng = np.random.default_rng(2)
        xyz = rng.uniform(0.0, 1.0, (10, 3))
        source = white_xyz("A", WL)
        target = white_xyz("D65", WL)
        expected = colour.adaptation.chromatic_adaptation_VonKries(xyz, source, target,
                                                                   transform="Bradford")
        np.testing.assert_allclose(bradford_adapt(xyz, source, target), expected, rtol=1e-12)

    def test_default_target_is_display_white(self):
        xyz = np.array([0.3, 0.4, 0.2])
        source = white_xyz("FL2", WL)
        np.testing.assert_allclose(bradford_adapt(xyz, source),
                                   bradford_adapt(xyz, source, DISPLAY_WHITE_XYZ), rtol=1e-15)
        np.testing.assert_allclose(DISPLAY_WHITE_XYZ, colour.xy_to_XYZ(CCS["D65"]), rtol=1e-12)

    def test_identity(self):
        xyz = np.random.default_rng(3).uniform(0.0, 1.0, (3, 4, 3))
        for name in ("D65", "A", "FL11"):
            white = white_xyz(name, WL)
            np.testing.assert_allclose(bradford_adapt(xyz, white, white), xyz, atol=1e-12)

    def test_white_to_white(self):
        source = white_xyz("A", WL)
        np.testing.assert_allclose(bradford_adapt(source, source), DISPLAY_WHITE_XYZ,
                                   atol=1e-12)

    def test_n_dimensional(self):
        xyz = np.array([0.3, 0.4, 0.2])
        source = white_xyz("A", WL)
        out = bradford_adapt(np.tile(xyz, (2, 3, 1)), source)
        assert out.shape == (2, 3, 3)
        np.testing.assert_allclose(out, np.tile(bradford_adapt(xyz, source), (2, 3, 1)),
                                   rtol=1e-12)


class TestXyzToLinearSrgb:
    """:func:`xyz_to_linear_srgb` against ``colour.XYZ_to_RGB`` (no adaptation)."""

    def test_against_colour(self):
        xyz = np.random.default_rng(4).uniform(0.0, 1.0, (2, 3, 3))
        # colour 0.4.6: XYZ_to_RGB(XYZ, colourspace, illuminant=None,
        # chromatic_adaptation_transform="CAT02", apply_cctf_encoding=False).
        expected = colour.XYZ_to_RGB(xyz, "sRGB", illuminant=None,
                                     chromatic_adaptation_transform=None,
                                     apply_cctf_encoding=False)
        np.testing.assert_allclose(xyz_to_linear_srgb(xyz), expected, rtol=1e-12, atol=1e-15)
        assert xyz_to_linear_srgb(xyz).shape == (2, 3, 3)

    def test_white(self):
        # The sRGB matrix is IEC's 4-decimal one: D65 white maps to 1 within ~2e-4.
        np.testing.assert_allclose(xyz_to_linear_srgb(DISPLAY_WHITE_XYZ), 1.0, atol=2e-4)

    def test_linear(self):
        a, b = np.array([0.1, 0.2, 0.3]), np.array([0.5, 0.1, 0.05])
        np.testing.assert_allclose(xyz_to_linear_srgb(2 * a + b),
                                   2 * xyz_to_linear_srgb(a) + xyz_to_linear_srgb(b),
                                   rtol=1e-12)


class TestTonemapSigmoid:
    """:func:`tonemap_sigmoid`: extended Reinhard."""

    def test_values(self):
        assert tonemap_sigmoid(0.0) == 0.0
        assert tonemap_sigmoid(4.0) == pytest.approx(1.0, abs=1e-15)
        assert tonemap_sigmoid(2.0, white=2.0) == pytest.approx(1.0, abs=1e-15)
        # x (1 + x/w²)/(1 + x) at x = 1, w = 4: 1.0625/2.
        assert tonemap_sigmoid(1.0) == pytest.approx(0.53125, abs=1e-15)

    def test_monotone(self):
        x = np.linspace(0.0, 10.0, 10001)
        y = tonemap_sigmoid(x)
        assert np.all(np.diff(y[x <= 4.0]) > 0)
        assert np.all(np.diff(y) >= 0)
        assert np.all((y >= 0) & (y <= 1))
        np.testing.assert_array_equal(y[x >= 4.0], 1.0)

    def test_derivative_at_zero(self):
        h = 1e-7
        assert (tonemap_sigmoid(h) - tonemap_sigmoid(0.0)) / h == pytest.approx(1.0, abs=1e-6)
        for white in (1.0, 4.0, 100.0):
            assert tonemap_sigmoid(h, white) / h == pytest.approx(1.0, abs=1e-6)

    def test_clamps_negative(self):
        np.testing.assert_array_equal(tonemap_sigmoid(np.array([-1.0, -1e-9, -np.inf])), 0.0)

    def test_n_dimensional(self):
        x = np.array([0.0, 0.5, 1.0, 4.0, 8.0])
        out = tonemap_sigmoid(np.tile(x, (2, 3, 1)))
        assert out.shape == (2, 3, 5)
        np.testing.assert_array_equal(out[1, 2], tonemap_sigmoid(x))

    @pytest.mark.parametrize("white", [0.0, -1.0, np.nan])
    def test_invalid_white(self, white):
        with pytest.raises(ValueError, match="white"):
            tonemap_sigmoid(1.0, white=white)


class TestSrgbEncode:
    """:func:`srgb_encode` against ``colour.models.eotf_inverse_sRGB``."""

    def test_against_colour(self):
        x = np.linspace(0.0, 1.0, 1001)
        np.testing.assert_allclose(srgb_encode(x), colour.models.eotf_inverse_sRGB(x),
                                   rtol=1e-12, atol=1e-15)
        assert srgb_encode(0.0) == 0.0
        assert srgb_encode(1.0) == pytest.approx(1.0, abs=1e-12)
        assert srgb_encode(0.18) == pytest.approx(0.46135612950044164, abs=1e-9)

    def test_breakpoint(self):
        x0 = 0.0031308
        assert srgb_encode(x0) == pytest.approx(12.92 * x0, abs=1e-12)
        below = srgb_encode(x0 - 1e-12)
        above = srgb_encode(x0 + 1e-12)
        # The two IEC 61966-2-1 branches meet to within 3e-8 (the standard's rounding).
        assert abs(above - below) < 1e-7
        assert abs((1.055 * x0 ** (1 / 2.4) - 0.055) - 12.92 * x0) < 1e-7

    def test_clips(self):
        np.testing.assert_allclose(srgb_encode(np.array([-0.5, 1.5, 100.0])),
                                   [0.0, 1.0, 1.0], atol=1e-15)
        assert srgb_encode(-0.5) == 0.0

    def test_n_dimensional(self):
        x = np.random.default_rng(5).uniform(0.0, 1.0, (2, 3, 3))
        np.testing.assert_allclose(srgb_encode(x), colour.models.eotf_inverse_sRGB(x),
                                   rtol=1e-12)


class TestXyzToDisplay:
    """:func:`xyz_to_display`: the whole chain."""

    def test_composition(self):
        xyz = np.random.default_rng(6).uniform(0.0, 2.0, (2, 3, 3))
        scene_white = white_xyz("A", WL)
        expected = srgb_encode(tonemap_sigmoid(
            xyz_to_linear_srgb(bradford_adapt(xyz * 2.0, scene_white)), white=3.0))
        out = xyz_to_display(xyz, scene_white, exposure=2.0, tonemap_white=3.0)
        assert out.shape == (2, 3, 3)
        np.testing.assert_allclose(out, expected, rtol=1e-12)
        np.testing.assert_allclose(out[1, 2], xyz_to_display(xyz[1, 2], scene_white,
                                                             exposure=2.0, tonemap_white=3.0))

    def test_range(self):
        rng = np.random.default_rng(8)
        xyz = np.concatenate([rng.uniform(0.0, 50.0, (200, 3)),
                              rng.uniform(-1.0, 1.0, (200, 3))])
        for name in ("D65", "A", "FL2"):
            out = xyz_to_display(xyz, white_xyz(name, WL))
            assert np.all((out >= 0.0) & (out <= 1.0))

    @pytest.mark.parametrize("name", ["D65", "A", "FL2", "FL11"])
    def test_scene_white_is_neutral(self, name):
        # After adaptation the scene white is the display white: a neutral grey, the same
        # for every illuminant (tone map of Y = 1 with w = 4 is 0.53125 → sRGB 0.7556).
        white = white_xyz(name, WL)
        out = xyz_to_display(white, white)
        np.testing.assert_allclose(out, srgb_encode(0.53125), atol=2e-4)

    def test_black(self):
        np.testing.assert_array_equal(xyz_to_display(np.zeros(3), white_xyz("D65", WL)), 0.0)

    def test_exposure(self):
        xyz = np.array([0.2, 0.3, 0.1])
        white = white_xyz("D65", WL)
        np.testing.assert_allclose(xyz_to_display(xyz, white, exposure=4.0),
                                   xyz_to_display(4.0 * xyz, white), rtol=1e-12)
