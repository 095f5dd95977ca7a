"""The spectrum plot: a curve of a spectrum over wavelength, filled below with the colour
of each wavelength."""

from __future__ import annotations

import math
from collections.abc import Sequence

import colour
import numpy as np
from numpy.typing import ArrayLike

from ..colour import spectra
from .canvas import (
    _ALL,
    _FONT_HEIGHT,
    AXIS,
    BACKGROUND,
    CURVE_COLOUR,
    GRID_MAJOR,
    PLOT_BACKGROUND,
    TEXT,
    PlotLayout,
    _Canvas,
    _check_size,
    _font_scale,
    _series,
)


def wavelength_colours(wavelengths: ArrayLike) -> np.ndarray:
    """Display colour of monochromatic light at each wavelength → linear sRGB (L, 3).

    XYZ of the unit stimulus is the CIE 1931 2° CMFs at λ (zero outside 360–830 nm);
    ``colour.XYZ_to_RGB`` to linear sRGB without adaptation; negative (out-of-gamut)
    channels clipped to 0; each colour divided by its largest channel, as
    ``colour.plotting`` does. Then, so that the ends of the spectrum fade out as the eye
    sees them instead of staying at full brightness, each colour is scaled by
    ``min(1, (X + Y + Z) / 0.6)^½``: 1 over roughly 420–650 nm, about 0.37 at 400 nm and
    0.16 at 700 nm, 0 where the observer sees nothing.
    """
    wl = spectra.check_wavelengths(wavelengths)
    xyz = spectra.cmfs(wl)
    rgb = np.clip(colour.XYZ_to_RGB(xyz, "sRGB", apply_cctf_encoding=False), 0.0, None)
    peak = rgb.max(axis=-1, keepdims=True)
    rgb = np.divide(rgb, peak, out=np.zeros_like(rgb), where=peak > 0)
    return rgb * np.sqrt(np.clip(xyz.sum(axis=-1, keepdims=True) / 0.6, 0.0, 1.0))


def spectrum_plot_layout(wavelengths: ArrayLike, values: ArrayLike, *,
                         size: Sequence[int] = (320, 120)) -> PlotLayout:
    """The axis mapping :func:`plot_spectrum` uses for these data (normalised values).

    Margins, with ``s = max(1, min(W // 320, H // 180))``: ``left = 6 s``,
    ``right = W − 6 s``, ``bottom = 11 s``, ``top = H − 5 s``. x:
    ``[min(380, λ₀), max(780, λ_last)]`` nm. y: ``[min(0, min v̂), 1]`` for the
    normalised values ``v̂`` (see :func:`plot_spectrum`; ``[-1, 0]`` when none is
    positive, ``[0, 1]`` when all are zero).
    """
    width, height = _check_size(size)
    wl, normalised = _spectrum_data(wavelengths, values)
    s = _font_scale(width, height)
    low = min(0.0, float(normalised.min()))
    high = 1.0 if normalised.max() > 0 else 0.0
    if high == low:
        low, high = 0.0, 1.0
    return PlotLayout(width=width, height=height, left=6 * s, right=width - 6 * s,
                      bottom=11 * s, top=height - 5 * s,
                      x_range=(min(380.0, float(wl[0])), max(780.0, float(wl[-1]))),
                      y_range=(low, high), scale=s)


def _spectrum_data(wavelengths, values) -> tuple[np.ndarray, np.ndarray]:
    wl = _series(wavelengths, "wavelengths")
    v = _series(values, "values")
    if v.size != wl.size:
        raise ValueError(f"values has {v.size} entries but wavelengths has {wl.size}")
    wl = spectra.check_wavelengths(wl)
    peak = v.max()
    scale = peak if peak > 0 else np.abs(v).max()
    return wl, (v / scale if scale > 0 else v.copy())


def plot_spectrum(wavelengths: ArrayLike, values: ArrayLike, *,
                  size: Sequence[int] = (320, 120), fill: bool = True) -> np.ndarray:
    """Plot a spectrum, normalised to its maximum, over the visible range.

    The curve is ``values / max(values)`` (by ``max |values|`` if none is positive),
    evaluated as the project evaluates spectra: piecewise linear between the samples,
    constant beyond them (so a single sample is a flat line). With ``fill`` the area
    between the curve and zero is filled, column by column, with the colour of that
    wavelength (:func:`wavelength_colours`), on a dark background; vertical grid lines
    every 100 nm (labelled), horizontal ones at 0.5 and 1 and a baseline at 0.
    The axis mapping is :func:`spectrum_plot_layout`.

    Parameters
    ----------
    wavelengths
        Wavelengths in nm: finite, strictly increasing, within 200–2000 nm.
    values
        The spectrum at those wavelengths (finite).
    size
        ``(width, height)`` in pixels.
    fill
        Fill under the curve with the spectral colours.

    Returns
    -------
    numpy.ndarray
        float32 RGBA ``(height, width, 4)``, linear, row 0 at the bottom.

    Raises
    ------
    ValueError
        Empty or mismatched inputs, NaN/inf (naming ``wavelengths`` or ``values``),
        invalid wavelengths, or a bad size.
    """
    layout = spectrum_plot_layout(wavelengths, values, size=size)
    wl, normalised = _spectrum_data(wavelengths, values)
    s = layout.scale
    canvas = _Canvas(layout.width, layout.height, BACKGROUND)
    left, right, bottom, top = layout.left, layout.right, layout.bottom, layout.top
    canvas.rect(left, right, bottom, top, PLOT_BACKGROUND)
    (x0, x1), (y0, _) = layout.x_range, layout.y_range

    def column_wavelength(col: np.ndarray) -> np.ndarray:
        return x0 + (col + 0.5 - left) / (right - left) * (x1 - x0)

    grid_nm = np.arange(math.ceil(x0 / 100.0) * 100.0, x1 + 1e-9, 100.0)
    for level in (0.5, 1.0):
        if layout.y_range[0] <= level <= layout.y_range[1]:
            row = int(layout.to_pixel(x0, level)[0])
            canvas.rect(left, right, min(row, top - 1), min(row, top - 1) + 1, GRID_MAJOR)
    for nm in grid_nm:
        col = int(layout.to_pixel(nm, y0)[1])
        canvas.rect(col, col + 1, bottom, top, GRID_MAJOR)

    cols = np.arange(left, right)
    col_wl = column_wavelength(cols)
    if fill:
        curve_y = layout.to_canvas(col_wl, np.interp(col_wl, wl, normalised))[1]
        base_y = float(layout.to_canvas(x0, 0.0)[1])
        lo, hi = np.minimum(curve_y, base_y), np.maximum(curve_y, base_y)
        rows = np.arange(layout.height)[:, None]
        coverage = np.clip(np.minimum(hi, rows + 1.0) - np.maximum(lo, rows), 0.0, 1.0)
        fill_rgb = 0.8 * wavelength_colours(col_wl)
        canvas.blend(coverage, fill_rgb[None, :, :], _ALL, slice(left, right))
        for nm in grid_nm:  # grid lines show faintly through the fill
            col = int(layout.to_pixel(nm, y0)[1])
            if left <= col < right:
                canvas.blend(0.35 * coverage[:, col - left:col - left + 1], BACKGROUND, _ALL,
                             slice(col, col + 1))

    # Baseline, labels, then the curve on top.
    base_row = int(np.clip(layout.to_pixel(x0, 0.0)[0], bottom, top - 1))
    canvas.rect(left, right, base_row - (s - 1), base_row + 1, AXIS)
    for nm in grid_nm:
        col = int(layout.to_pixel(nm, y0)[1])
        canvas.rect(col, col + s, bottom - 2 * s, bottom, AXIS)
        canvas.text(str(int(nm)), col + s // 2, bottom - 3 * s - _FONT_HEIGHT * s, TEXT, s,
                    anchor="centre")
    inside = (wl > x0) & (wl < x1)
    xs = np.concatenate([[x0], col_wl, wl[inside], [x1]])
    xs = np.unique(xs)
    cx, cy = layout.to_canvas(xs, np.interp(xs, wl, normalised))
    canvas.polyline(cx, cy, 1.3 * s, CURVE_COLOUR)
    return canvas.rgba()
