"""Tests of spectral_materials.core.raster_plots (NumPy-only panel pictures).

Expected pixel positions are computed here from the axis mapping documented in
:func:`error_plot_layout` / :func:`spectrum_plot_layout` (margins, ranges, linear or
log10 mapping, row 0 at the bottom), not taken from the module.
"""

from __future__ import annotations

import math

import colour
import numpy as np
import pytest

from spectral_materials.core import raster_plots as rp
from spectral_materials.core.colour import spectra
from spectral_materials.core.raster_plots import (
    error_plot_layout,
    plot_error_against_packs,
    plot_spectrum,
    spectrum_plot_layout,
    wavelength_colours,
)

PACKS = [1, 2, 3, 4, 6, 8, 12, 16]
MEAN = [8.1, 4.2, 2.3, 1.5, 0.9, 0.61, 0.42, 0.35]
P95 = [15.0, 9.0, 5.5, 3.2, 2.1, 1.5, 1.1, 0.95]


def rgb_at(image, row, col):
    return image[int(row), int(col), :3].astype(np.float64)


def close_to(image, row, col, colour_, tol=0.12):
    return bool(np.all(np.abs(rgb_at(image, row, col) - np.asarray(colour_)) <= tol))


def check_image(image, width, height):
    assert image.shape == (height, width, 4)
    assert image.dtype == np.float32
    assert np.isfinite(image).all()
    assert image.min() >= 0.0 and image.max() <= 1.0
    np.testing.assert_array_equal(image[..., 3], 1.0)


class TestErrorPlot:
    def test_shape_dtype_range(self):
        check_image(plot_error_against_packs(PACKS, MEAN, P95, target=1.0), 320, 180)
        check_image(plot_error_against_packs(PACKS, MEAN, size=(200, 90)), 200, 90)
        check_image(plot_error_against_packs(PACKS, MEAN, size=(640, 360)), 640, 360)

    def test_documented_layout(self):
        layout = error_plot_layout([2, 10], [0.5, 20.0], size=(320, 180))
        assert (layout.left, layout.right, layout.bottom, layout.top) == (26, 312, 12, 172)
        assert layout.x_range == (1.5, 10.5)
        assert layout.y_range == (-1.0, 2.0)  # floor(log10 0.5 − .05), ceil(log10 20 + .05)
        big = error_plot_layout([2, 10], [0.5, 20.0], size=(640, 360))
        assert (big.left, big.right, big.bottom, big.top) == (52, 624, 24, 344)

    def test_line_passes_through_expected_pixel(self):
        """Between (2, 0.5) and (10, 20) the line is straight in (x, log y)."""
        image = plot_error_against_packs([2, 10], [0.5, 20.0])
        left, right, bottom, top = 26, 312, 12, 172
        for pack in (3.0, 6.0, 8.5):
            log_y = math.log10(0.5) + (pack - 2) / 8 * (math.log10(20) - math.log10(0.5))
            cx = left + (pack - 1.5) / 9.0 * (right - left)
            cy = bottom + (log_y + 1.0) / 3.0 * (top - bottom)
            row, col = math.floor(cy), math.floor(cx)
            assert close_to(image, row, col, rp.MEAN_COLOUR, tol=0.3), (pack, rgb_at(image, row,
                                                                                     col))
            # Six rows above or below the line is not orange.
            for off in (-6, 6):
                assert not close_to(image, row + off, col, rp.MEAN_COLOUR, tol=0.3)

    def test_dots_at_data_and_layout_to_pixel(self):
        image = plot_error_against_packs(PACKS, MEAN, P95)
        layout = error_plot_layout(PACKS, MEAN, P95)
        rows, cols = layout.to_pixel(PACKS, MEAN)
        for row, col in zip(rows, cols):
            assert close_to(image, row, col, rp.MEAN_COLOUR, tol=0.02)
        rows, cols = layout.to_pixel(PACKS, P95)
        for row, col in zip(rows, cols):
            assert close_to(image, row, col, rp.P95_COLOUR, tol=0.02)

    def test_row_zero_is_bottom(self):
        """A rising series ends higher up the array: larger row index."""
        image = plot_error_against_packs([1, 2], [0.1, 10.0])
        layout = error_plot_layout([1, 2], [0.1, 10.0])
        (r0, r1), _ = layout.to_pixel([1, 2], [0.1, 10.0])
        assert r1 > r0
        assert close_to(image, r1, layout.to_pixel(2, 10.0)[1], rp.MEAN_COLOUR, tol=0.02)

    def test_gridlines_at_decades_and_integer_packs(self):
        image = plot_error_against_packs([1, 2, 3], [0.05, 0.5, 5.0])
        layout = error_plot_layout([1, 2, 3], [0.05, 0.5, 5.0])
        assert layout.y_range == (-2.0, 1.0)
        col = layout.left + 3  # left of the first data point: background and grid only
        for decade in (0.01, 0.1, 1.0):
            row = math.floor(layout.bottom + (math.log10(decade) + 2) / 3
                             * (layout.top - layout.bottom))
            assert close_to(image, row, col, rp.GRID_MAJOR, tol=1e-6)
        mid_row = math.floor(layout.bottom + (math.log10(0.015) + 2) / 3
                             * (layout.top - layout.bottom))
        assert close_to(image, mid_row, col, rp.PLOT_BACKGROUND, tol=1e-6)
        row = layout.top - 4  # above the data
        for pack in (1, 2, 3):
            col = math.floor(layout.left + (pack - 0.5) / 3 * (layout.right - layout.left))
            assert close_to(image, row, col, rp.GRID_MAJOR, tol=1e-6)

    def test_axes_and_labels_drawn(self):
        image = plot_error_against_packs(PACKS, MEAN)
        layout = error_plot_layout(PACKS, MEAN)
        assert close_to(image, layout.bottom - 1, layout.left + 50, rp.AXIS, tol=1e-6)
        assert close_to(image, layout.bottom + 50, layout.left - 1, rp.AXIS, tol=1e-6)
        below = image[: layout.bottom - 4, layout.left:, :3]
        left_of = image[layout.bottom:, : layout.left - 4, :3]
        for region in (below, left_of):  # digits in the margins
            assert np.any(np.all(np.abs(region - np.asarray(rp.TEXT)) < 1e-6, axis=-1))

    def test_target_dashed(self):
        image = plot_error_against_packs([1, 2], [5.0, 4.0], target=0.2)
        layout = error_plot_layout([1, 2], [5.0, 4.0], target=0.2)
        assert layout.y_range[0] == -1.0  # the target is inside the range
        row = int(layout.to_pixel(1, 0.2)[0])
        line = image[row, layout.left:layout.right, :3]
        green = (line[:, 1] > 0.3) & (line[:, 1] > 3 * line[:, 0]) & (line[:, 1] > 3 * line[:, 2])
        assert 0.4 < green.mean() < 0.75  # dashes: about 6 on, 4 off
        assert np.any(np.diff(green.astype(int)) != 0)

    def test_single_point(self):
        image = plot_error_against_packs([5], [0.7])
        layout = error_plot_layout([5], [0.7])
        assert layout.x_range == (4.5, 5.5) and layout.y_range == (-1.0, 0.0)
        check_image(image, 320, 180)
        assert close_to(image, *layout.to_pixel(5, 0.7), rp.MEAN_COLOUR, tol=0.02)

    def test_all_equal_and_zero_values(self):
        image = plot_error_against_packs([1, 2, 3], [2.0, 2.0, 2.0])
        layout = error_plot_layout([1, 2, 3], [2.0, 2.0, 2.0])
        assert layout.y_range == (0.0, 1.0)
        row, col = layout.to_pixel(2.5, 2.0)
        assert close_to(image, row, col, rp.MEAN_COLOUR, tol=0.2)
        # Zeros on a log axis sit on the bottom edge.
        zero = plot_error_against_packs([1, 2], [0.0, 0.0])
        layout = error_plot_layout([1, 2], [0.0, 0.0])
        assert layout.to_canvas(1, 0.0)[1] == layout.bottom
        check_image(zero, 320, 180)

    def test_linear_axis(self):
        layout = error_plot_layout([1, 2, 3], [3.2, 1.1, 0.4], log_y=False)
        assert layout.y_range == (0.0, 5.0)
        image = plot_error_against_packs([1, 2, 3], [3.2, 1.1, 0.4], log_y=False)
        cy = layout.bottom + 1.1 / 5.0 * (layout.top - layout.bottom)
        cx = layout.left + 1.5 / 3.0 * (layout.right - layout.left)
        assert close_to(image, math.floor(cy), math.floor(cx), rp.MEAN_COLOUR, tol=0.02)

    def test_deterministic(self):
        a = plot_error_against_packs(PACKS, MEAN, P95, target=1.0)
        b = plot_error_against_packs(PACKS, MEAN, P95, target=1.0)
        np.testing.assert_array_equal(a, b)

    @pytest.mark.parametrize("kwargs, name", [
        ({"packs": [1, 2], "mean": [1.0, np.nan]}, "mean"),
        ({"packs": [1, 2], "mean": [1.0, 2.0], "p95": [np.inf, 2.0]}, "p95"),
        ({"packs": [1, np.nan], "mean": [1.0, 2.0]}, "packs"),
        ({"packs": [1, 2], "mean": [1.0, 2.0], "target": np.nan}, "target"),
    ])
    def test_nan_names_series(self, kwargs, name):
        with pytest.raises(ValueError, match=rf"^{name} has 1 NaN/inf value\(s\)"):
            plot_error_against_packs(**kwargs)

    @pytest.mark.parametrize("packs, mean, p95, match", [
        ([], [], None, "packs must be a non-empty"),
        ([1, 2], [], None, "mean must be a non-empty"),
        ([1, 2], [1.0], None, "mean has 1 values but packs has 2"),
        ([1, 2], [1.0, 2.0], [1.0], "p95 has 1 values"),
        ([2, 1], [1.0, 2.0], None, "strictly increasing"),
        ([1, 1], [1.0, 2.0], None, "strictly increasing"),
        ([1, 2], [1.0, -2.0], None, "mean has negative values"),
        ([1, 2], ["a", "b"], None, "mean must be a sequence of numbers"),
    ])
    def test_bad_series(self, packs, mean, p95, match):
        with pytest.raises(ValueError, match=match):
            plot_error_against_packs(packs, mean, p95)

    @pytest.mark.parametrize("size", [(10, 10), (320,), (320.5, 180), (5000, 180), "big"])
    def test_bad_size(self, size):
        with pytest.raises(ValueError, match="size"):
            plot_error_against_packs([1], [1.0], size=size)


class TestSpectrumPlot:
    def test_shape_dtype_range(self):
        check_image(plot_spectrum(spectra.WAVELENGTHS_REFERENCE, spectra.illuminant("FL2")),
                    320, 120)
        check_image(plot_spectrum([400, 700], [1, 2], size=(100, 50), fill=False), 100, 50)

    def test_documented_layout(self):
        layout = spectrum_plot_layout([380.0, 780.0], [0.0, 2.0])
        assert (layout.left, layout.right, layout.bottom, layout.top) == (6, 314, 11, 115)
        assert layout.x_range == (380.0, 780.0) and layout.y_range == (0.0, 1.0)
        wide = spectrum_plot_layout([300.0, 900.0], [-1.0, 4.0])
        assert wide.x_range == (300.0, 900.0) and wide.y_range == (-0.25, 1.0)

    def test_curve_passes_through_expected_pixel(self):
        """A ramp 0 → 2 over 380–780 nm, normalised to 0 → 1: at 580 nm it is 0.5."""
        image = plot_spectrum([380.0, 780.0], [0.0, 2.0], fill=False)
        left, right, bottom, top = 6, 314, 11, 115
        for nm in (450.0, 580.0, 700.0):
            value = (nm - 380.0) / 400.0
            cx = left + (nm - 380.0) / 400.0 * (right - left)
            cy = bottom + value * (top - bottom)
            assert close_to(image, math.floor(cy), math.floor(cx), rp.CURVE_COLOUR, tol=0.3)
            assert not close_to(image, math.floor(cy) + 5, math.floor(cx), rp.CURVE_COLOUR,
                                tol=0.3)

    def test_fill_colours(self):
        image = plot_spectrum([380.0, 780.0], [1.0, 1.0])
        layout = spectrum_plot_layout([380.0, 780.0], [1.0, 1.0])
        row, col = layout.to_pixel(450.0, 0.5)
        r, g, b = rgb_at(image, row, col)
        assert b > 0.3 and b > 2 * r and b > 2 * g  # bluish
        row, col = layout.to_pixel(620.0, 0.5)
        r, g, b = rgb_at(image, row, col)
        assert r > 0.3 and r > 2 * g and r > 2 * b  # reddish
        row, col = layout.to_pixel(530.0, 0.5)
        r, g, b = rgb_at(image, row, col)
        assert g > r and g > b  # greenish

    def test_no_fill_leaves_background(self):
        image = plot_spectrum([380.0, 780.0], [1.0, 1.0], fill=False)
        layout = spectrum_plot_layout([380.0, 780.0], [1.0, 1.0])
        row, col = layout.to_pixel(450.0, 0.3)
        assert close_to(image, row, col, rp.PLOT_BACKGROUND, tol=1e-6)

    def test_gridlines_every_100_nm(self):
        image = plot_spectrum([380.0, 780.0], [0.0, 1.0])
        layout = spectrum_plot_layout([380.0, 780.0], [0.0, 1.0])
        for nm in (400.0, 500.0, 600.0, 700.0):
            row, col = layout.to_pixel(nm, 0.95)  # above the ramp
            assert close_to(image, row, col, rp.GRID_MAJOR, tol=1e-6), nm
            assert close_to(image, row, col + 2, rp.PLOT_BACKGROUND, tol=1e-6), nm

    def test_single_point_and_all_equal(self):
        single = plot_spectrum([550.0], [0.3])
        flat = plot_spectrum([380.0, 500.0, 780.0], [0.3, 0.3, 0.3])
        np.testing.assert_array_equal(single, flat)  # both constant over the range
        layout = spectrum_plot_layout([550.0], [0.3])
        row, col = layout.to_pixel(600.0, 0.5)
        r, g, b = rgb_at(single, row, col)
        assert r > g and r > b  # filled

    def test_all_zero_and_negative(self):
        check_image(plot_spectrum([400.0, 700.0], [0.0, 0.0]), 320, 120)
        layout = spectrum_plot_layout([400.0, 700.0], [-2.0, -1.0])
        assert layout.y_range == (-1.0, 0.0)
        check_image(plot_spectrum([400.0, 700.0], [-2.0, -1.0]), 320, 120)

    def test_spiky_line_reaches_its_peak(self):
        wl = spectra.WAVELENGTHS_REFERENCE
        spd = spectra.illuminant("FL2", wl)
        image = plot_spectrum(wl, spd, fill=False)
        layout = spectrum_plot_layout(wl, spd)
        peak = wl[np.argmax(spd)]
        row, col = layout.to_pixel(peak, 1.0)
        assert close_to(image, min(row, layout.top - 1), col, rp.CURVE_COLOUR, tol=0.35)

    @pytest.mark.parametrize("wl, values, match", [
        ([400.0, 500.0], [1.0, np.nan], r"^values has 1 NaN/inf"),
        ([400.0, np.nan], [1.0, 2.0], r"^wavelengths has 1 NaN/inf"),
        ([], [], "wavelengths must be a non-empty"),
        ([400.0], [], "values must be a non-empty"),
        ([400.0, 500.0], [1.0], "values has 1 entries but wavelengths has 2"),
        ([500.0, 400.0], [1.0, 2.0], "strictly increasing"),
        ([100.0, 400.0], [1.0, 2.0], "outside 200..2000 nm"),
    ])
    def test_bad_input(self, wl, values, match):
        with pytest.raises(ValueError, match=match):
            plot_spectrum(wl, values)


class TestWavelengthColours:
    def test_hues(self):
        rgb = wavelength_colours(np.array([450.0, 530.0, 620.0]))
        assert np.argmax(rgb[0]) == 2 and np.argmax(rgb[1]) == 1 and np.argmax(rgb[2]) == 0
        assert rgb.min() >= 0.0 and rgb.max() <= 1.0

    def test_against_colour(self):
        """Clipped, max-normalised linear sRGB of the CMFs (colour-science), then faded."""
        wl = np.array([450.0, 500.0, 580.0, 620.0, 700.0])
        cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
        xyz = np.array([cmfs.values[np.searchsorted(cmfs.wavelengths, w)] for w in wl])
        rgb = np.clip(xyz @ colour.RGB_COLOURSPACES["sRGB"].matrix_XYZ_to_RGB.T, 0, None)
        rgb /= rgb.max(axis=1, keepdims=True)
        fade = np.sqrt(np.minimum(xyz.sum(axis=1) / 0.6, 1.0))[:, None]
        np.testing.assert_allclose(wavelength_colours(wl), rgb * fade, rtol=1e-12, atol=1e-15)
        assert fade[0, 0] == 1.0 and fade[-1, 0] < 0.2  # full at 450 nm, dim at 700 nm

    def test_black_outside_the_observer(self):
        np.testing.assert_array_equal(wavelength_colours(np.array([300.0, 900.0])), 0.0)
