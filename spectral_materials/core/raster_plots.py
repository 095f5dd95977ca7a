"""Small raster plots for Blender panels, drawn with NumPy alone (no matplotlib).

Every plot is a float32 RGBA array of shape ``(H, W, 4)``: *linear* RGB in [0, 1],
alpha 1, and **row 0 at the bottom** (Blender's image pixel order), so the add-on can
write it with ``image.pixels.foreach_set(arr.ravel())``. To save a PNG, flip the rows
and sRGB-encode (``colour_pipeline.srgb_encode``).

Geometry
--------
Canvas coordinates are in pixels with the origin at the bottom-left corner of the
image and y upwards; pixel ``(row j, column i)`` covers ``[i, i+1] × [j, j+1]``, its
centre at ``(i + 0.5, j + 0.5)``. Each plot maps data into its plot rectangle
``[left, right] × [bottom, top]`` linearly (after ``log10`` on a log axis); the exact
mapping is the :class:`PlotLayout` returned by :func:`error_plot_layout` and
:func:`spectrum_plot_layout`, and the data point ``(x, y)`` is drawn centred on the
canvas point :meth:`PlotLayout.to_canvas` ``(x, y)``, i.e. in pixel
:meth:`PlotLayout.to_pixel` ``(x, y)``. Curves are anti-aliased by coverage: a line of
width ``w`` covers a pixel by ``clip(w/2 + 1/2 − d, 0, 1)``, ``d`` the distance from the
pixel centre to the segment; dots likewise with the distance to their centre. Grid
lines, axes and text are snapped to whole pixels so that they stay crisp.

Labels use a built-in 3 × 5 pixel font of the characters ``0-9 . - e``.

References
----------
CIE 015:2018 Colorimetry, 4th ed. (CIE 1931 2° observer). IEC 61966-2-1:1999 (sRGB
primaries), via ``colour.XYZ_to_RGB`` in colour-science 0.4.6; the per-wavelength
normalisation follows ``colour.plotting.plot_single_sd``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import colour
import numpy as np
from numpy.typing import ArrayLike

from .colour import spectra

#: Colours, linear RGB.
BACKGROUND = (0.010, 0.010, 0.012)
PLOT_BACKGROUND = (0.018, 0.018, 0.022)
GRID_MAJOR = (0.060, 0.060, 0.066)
GRID_MINOR = (0.030, 0.030, 0.034)
AXIS = (0.42, 0.42, 0.42)
TEXT = (0.55, 0.55, 0.55)
MEAN_COLOUR = (1.00, 0.36, 0.04)  # orange: mean ΔE94
P95_COLOUR = (0.10, 0.38, 1.00)  # blue: 95th percentile
TARGET_COLOUR = (0.08, 0.70, 0.12)  # green, dashed: the target
CURVE_COLOUR = (0.90, 0.90, 0.90)

#: Smallest and largest image sides accepted, in pixels.
MIN_SIZE = (64, 40)
MAX_SIDE = 4096

# The 3 × 5 font, top row first; "#" is ink.
_GLYPHS = {
    "0": ("###", "#.#", "#.#", "#.#", "###"),
    "1": (".#.", "##.", ".#.", ".#.", "###"),
    "2": ("###", "..#", "###", "#..", "###"),
    "3": ("###", "..#", ".##", "..#", "###"),
    "4": ("#.#", "#.#", "###", "..#", "..#"),
    "5": ("###", "#..", "###", "..#", "###"),
    "6": ("###", "#..", "###", "#.#", "###"),
    "7": ("###", "..#", "..#", ".#.", ".#."),
    "8": ("###", "#.#", "###", "#.#", "###"),
    "9": ("###", "#.#", "###", "..#", "###"),
    ".": (".", ".", ".", ".", "#"),
    "-": ("...", "...", "###", "...", "..."),
    "e": (".##", "#.#", "###", "#..", ".##"),
}
_FONT = {c: np.array([[ch == "#" for ch in row] for row in rows[::-1]])  # row 0 = bottom
         for c, rows in _GLYPHS.items()}
_FONT_HEIGHT = 5
_ALL = slice(None)


@dataclass(frozen=True)
class PlotLayout:
    """Where a plot's data land on its canvas (see the module's *Geometry*).

    ``left``, ``right``, ``bottom``, ``top`` bound the plot rectangle in canvas pixels
    (y upwards). ``x_range`` maps onto ``[left, right]`` and ``y_range`` onto
    ``[bottom, top]``, both linearly; with ``log_y`` the y range is in decades
    (``log10`` of the data).
    """

    width: int
    height: int
    left: int
    right: int
    bottom: int
    top: int
    x_range: tuple[float, float]
    y_range: tuple[float, float]
    log_y: bool = False
    scale: int = 1

    def to_canvas(self, x: ArrayLike, y: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Canvas coordinates ``(cx, cy)`` of data ``(x, y)``.

        ``cx = left + (x − x0) / (x1 − x0) · (right − left)`` and
        ``cy = bottom + (Y − y0) / (y1 − y0) · (top − bottom)`` with ``Y = log10(y)`` on
        a log axis (``y ≤ 0`` is drawn at the bottom edge), else ``Y = y``.
        """
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        if self.log_y:
            floor = 10.0 ** self.y_range[0]
            y = np.log10(np.maximum(y, floor))
        (x0, x1), (y0, y1) = self.x_range, self.y_range
        cx = self.left + (x - x0) / (x1 - x0) * (self.right - self.left)
        cy = self.bottom + (y - y0) / (y1 - y0) * (self.top - self.bottom)
        return cx, cy

    def to_pixel(self, x: ArrayLike, y: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Array indices ``(row, column)`` of the pixel that contains data ``(x, y)``."""
        cx, cy = self.to_canvas(x, y)
        return np.floor(cy).astype(int), np.floor(cx).astype(int)


class _Canvas:
    """An RGB canvas, row 0 at the bottom, with coverage-blended primitives."""

    def __init__(self, width: int, height: int, background: Sequence[float]):
        self.width, self.height = width, height
        self.rgb = np.empty((height, width, 3), dtype=np.float64)
        self.rgb[:] = background

    def blend(self, coverage: np.ndarray, colour_: ArrayLike, rows: slice = _ALL,
              cols: slice = _ALL) -> None:
        """Mix ``colour_`` (RGB, or per-pixel RGB) in by ``coverage`` over a window."""
        cov = np.clip(coverage, 0.0, 1.0)[..., None]
        window = self.rgb[rows, cols]
        window += cov * (np.asarray(colour_, dtype=np.float64) - window)

    def rect(self, x0: int, x1: int, y0: int, y1: int, colour_: ArrayLike,
             alpha: float = 1.0) -> None:
        """Fill whole pixels ``[x0, x1) × [y0, y1)`` (clipped to the canvas)."""
        x0, x1 = max(x0, 0), min(x1, self.width)
        y0, y1 = max(y0, 0), min(y1, self.height)
        if x0 < x1 and y0 < y1:
            self.blend(np.full((y1 - y0, x1 - x0), alpha), colour_, slice(y0, y1),
                       slice(x0, x1))

    def _window(self, x0: float, x1: float, y0: float, y1: float):
        c0, c1 = max(int(math.floor(x0)), 0), min(int(math.ceil(x1)) + 1, self.width)
        r0, r1 = max(int(math.floor(y0)), 0), min(int(math.ceil(y1)) + 1, self.height)
        if c0 >= c1 or r0 >= r1:
            return None
        px = np.arange(c0, c1) + 0.5
        py = np.arange(r0, r1)[:, None] + 0.5
        return slice(r0, r1), slice(c0, c1), px, py

    def polyline_coverage(self, xs: np.ndarray, ys: np.ndarray, width: float) -> np.ndarray:
        """Coverage (H, W) of a polyline of ``width`` px through canvas points (round joins)."""
        cov = np.zeros((self.height, self.width))
        half = width / 2.0 + 0.5
        if len(xs) == 1:
            xs, ys = np.repeat(xs, 2), np.repeat(ys, 2)
        for ax, ay, bx, by in zip(xs[:-1], ys[:-1], xs[1:], ys[1:]):
            win = self._window(min(ax, bx) - half, max(ax, bx) + half,
                               min(ay, by) - half, max(ay, by) + half)
            if win is None:
                continue
            rows, cols, px, py = win
            dx, dy = bx - ax, by - ay
            length2 = dx * dx + dy * dy
            t = 0.0 if length2 == 0 else np.clip(((px - ax) * dx + (py - ay) * dy) / length2,
                                                  0.0, 1.0)
            dist = np.hypot(px - (ax + t * dx), py - (ay + t * dy))
            np.maximum(cov[rows, cols], half - dist, out=cov[rows, cols])
        return cov

    def polyline(self, xs: np.ndarray, ys: np.ndarray, width: float, colour_: ArrayLike) -> None:
        self.blend(self.polyline_coverage(np.asarray(xs, float), np.asarray(ys, float), width),
                   colour_)

    def dots(self, xs: np.ndarray, ys: np.ndarray, radius: float, colour_: ArrayLike) -> None:
        for cx, cy in zip(np.atleast_1d(xs), np.atleast_1d(ys)):
            win = self._window(cx - radius - 1, cx + radius + 1, cy - radius - 1, cy + radius + 1)
            if win is not None:
                rows, cols, px, py = win
                self.blend(radius + 0.5 - np.hypot(px - cx, py - cy), colour_, rows, cols)

    def text(self, string: str, x: int, y: int, colour_: ArrayLike, scale: int = 1,
             anchor: str = "left") -> None:
        """Draw ``string`` with its bottom-left (or right end / centre) at pixel ``(x, y)``.

        A label that would not fit on the canvas entirely is left out, not cut.
        """
        glyphs = [_FONT[c] for c in string]
        total = _text_width(string, scale)
        if anchor == "right":
            x -= total
        elif anchor == "centre":
            x -= total // 2
        if x < 0 or y < 0 or x + total > self.width or y + _FONT_HEIGHT * scale > self.height:
            return
        for glyph in glyphs:
            ink = np.kron(glyph, np.ones((scale, scale), dtype=bool))
            rows, cols = np.nonzero(ink)
            self.rgb[y + rows, x + cols] = colour_
            x += (glyph.shape[1] + 1) * scale

    def rgba(self) -> np.ndarray:
        out = np.ones((self.height, self.width, 4), dtype=np.float32)
        out[..., :3] = np.clip(self.rgb, 0.0, 1.0)
        return out


def _text_width(string: str, scale: int = 1) -> int:
    return (sum(_FONT[c].shape[1] for c in string) + max(len(string) - 1, 0)) * scale


def _check_size(size: Sequence[int]) -> tuple[int, int]:
    try:
        width, height = (int(s) for s in size)
        exact = all(float(s) == int(s) for s in size)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"size must be (width, height) in pixels, got {size!r}") from exc
    if not exact or not (MIN_SIZE[0] <= width <= MAX_SIDE and MIN_SIZE[1] <= height <= MAX_SIDE):
        raise ValueError(f"size must be whole pixels with width {MIN_SIZE[0]}–{MAX_SIDE} and "
                         f"height {MIN_SIZE[1]}–{MAX_SIDE}, got {size!r}")
    return width, height


def _series(values: ArrayLike | None, name: str, length: int | None = None) -> np.ndarray:
    """A finite, non-empty 1-D float64 series (of ``length`` if given)."""
    try:
        arr = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a sequence of numbers ({exc})") from exc
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"{name} must be a non-empty 1-D sequence, got shape {arr.shape}")
    if length is not None and arr.size != length:
        raise ValueError(f"{name} has {arr.size} values but packs has {length}")
    bad = ~np.isfinite(arr)
    if bad.any():
        raise ValueError(f"{name} has {int(bad.sum())} NaN/inf value(s), the first at "
                         f"index {int(np.flatnonzero(bad)[0])}")
    return arr


def _font_scale(width: int, height: int) -> int:
    return max(1, min(width // 320, height // 180))


def _format_decade(exponent: int) -> str:
    if 0 <= exponent <= 4:
        return "1" + "0" * exponent
    if -3 <= exponent < 0:
        return "0." + "0" * (-exponent - 1) + "1"
    return f"1e{exponent}"


def _format_number(value: float) -> str:
    text = f"{value:.6g}"
    return text if "e" not in text else f"{value:.0e}".replace("e+0", "e").replace("e-0", "e-")


def _integer_step(span: float, pixels: float, min_gap: float) -> int:
    """Smallest of 1, 2, 5, 10, 20, … whose ticks are at least ``min_gap`` px apart."""
    for exponent in range(0, 12):
        for mantissa in (1, 2, 5):
            step = mantissa * 10**exponent
            if pixels * step / span >= min_gap:
                return step
    return 10**12


def _nice_ceiling(value: float) -> tuple[float, float]:
    """A 1-2-5 upper bound ≥ ``value`` and a tick step giving 4–5 intervals."""
    exponent = math.floor(math.log10(value))
    for mantissa in (1.0, 2.0, 2.5, 5.0, 10.0):
        top = mantissa * 10.0**exponent
        if top >= value * (1 - 1e-12):
            break
    return top, top / (5 if mantissa in (1.0, 5.0, 10.0) else 4)


def error_plot_layout(packs: Sequence[int], mean: Sequence[float],
                      p95: Sequence[float] | None = None, *, target: float | None = None,
                      size: Sequence[int] = (320, 180), log_y: bool = True) -> PlotLayout:
    """The axis mapping :func:`plot_error_against_packs` uses for these data.

    Margins, with ``s = max(1, min(W // 320, H // 180))`` the font scale:
    ``left = 26 s``, ``right = W − 8 s``, ``bottom = 12 s``, ``top = H − 8 s``.

    x: ``[min(packs) − 0.5, max(packs) + 0.5]``. y on a log axis, in decades:
    ``[floor(log10(m) − 0.05), ceil(log10(M) + 0.05)]`` with ``m``/``M`` the smallest
    positive / the largest of mean, p95 and target (``[-2, 0]`` if none is positive);
    on a linear axis ``[0, T]`` with ``T`` the 1-2-2.5-5 ceiling of ``1.05 M``
    (1 if ``M = 0``).

    Raises
    ------
    ValueError
        As :func:`plot_error_against_packs`.
    """
    width, height = _check_size(size)
    x, series = _error_data(packs, mean, p95, target)
    values = np.concatenate([s for s in series if s is not None])
    s = _font_scale(width, height)
    if log_y:
        positive = values[values > 0]
        if positive.size:
            y_range = (float(math.floor(np.log10(positive.min()) - 0.05)),
                       float(math.ceil(np.log10(positive.max()) + 0.05)))
        else:
            y_range = (-2.0, 0.0)
    else:
        y_range = (0.0, _nice_ceiling(1.05 * values.max())[0] if values.max() > 0 else 1.0)
    return PlotLayout(width=width, height=height, left=26 * s, right=width - 8 * s,
                      bottom=12 * s, top=height - 8 * s,
                      x_range=(float(x.min()) - 0.5, float(x.max()) + 0.5),
                      y_range=y_range, log_y=bool(log_y), scale=s)


def _error_data(packs, mean, p95, target):
    x = _series(packs, "packs")
    if np.any(np.diff(x) <= 0):
        raise ValueError("packs must be strictly increasing")
    mean_arr = _series(mean, "mean", x.size)
    p95_arr = None if p95 is None else _series(p95, "p95", x.size)
    target_arr = None if target is None else _series([target], "target")
    for name, arr in (("mean", mean_arr), ("p95", p95_arr), ("target", target_arr)):
        if arr is not None and np.any(arr < 0):
            raise ValueError(f"{name} has negative values; errors are ≥ 0")
    return x, (mean_arr, p95_arr, target_arr)


def plot_error_against_packs(packs: Sequence[int], mean: Sequence[float],
                             p95: Sequence[float] | None = None, *,
                             target: float | None = None, size: Sequence[int] = (320, 180),
                             log_y: bool = True) -> np.ndarray:
    """Line chart of an error (e.g. mean ΔE94) against the number of factor packs.

    Draws the ``mean`` series in orange (:data:`MEAN_COLOUR`) and, if given, ``p95`` in
    blue (:data:`P95_COLOUR`), as anti-aliased lines with dots at the data; ``target``
    as a dashed green line (:data:`TARGET_COLOUR`); axes with tick marks and labels;
    grid lines at integer packs (every 1, 2, 5, 10, … so that labels fit) and, on the
    default log-y axis, at powers of ten (fainter ones at 2–9 × 10ᵏ). Zero errors sit
    on the bottom edge of a log axis. The axis mapping is :func:`error_plot_layout`.

    Parameters
    ----------
    packs
        Number of packs per point, strictly increasing.
    mean, p95
        The errors at each pack count (same length as ``packs``), finite and ≥ 0.
    target
        Optional target error, finite and ≥ 0.
    size
        ``(width, height)`` in pixels.
    log_y
        Logarithmic y axis (default) or linear from 0.

    Returns
    -------
    numpy.ndarray
        float32 RGBA ``(height, width, 4)``, linear, row 0 at the bottom.

    Raises
    ------
    ValueError
        Empty or mismatched series, NaN/inf (naming the series), negative errors,
        packs not strictly increasing, or a bad size.
    """
    layout = error_plot_layout(packs, mean, p95, target=target, size=size, log_y=log_y)
    x, (mean_arr, p95_arr, target_arr) = _error_data(packs, mean, p95, target)
    s = layout.scale
    canvas = _Canvas(layout.width, layout.height, BACKGROUND)
    left, right, bottom, top = layout.left, layout.right, layout.bottom, layout.top
    canvas.rect(left, right, bottom, top, PLOT_BACKGROUND)

    # Grid: x at integer packs; y at decades (log) or nice steps (linear).
    x0, x1 = layout.x_range
    step = _integer_step(x1 - x0, right - left, _text_width(str(int(x1)), s) + 5 * s)
    x_ticks = np.arange(math.ceil(x0 / step) * step, x1 + 1e-9, step)
    y0, y1 = layout.y_range
    if log_y:
        major = [10.0**k for k in range(int(y0), int(y1) + 1)]
        minor = [m * 10.0**k for k in range(int(y0), int(y1)) for m in range(2, 10)]
        labels = [(v, _format_decade(k)) for k, v in zip(range(int(y0), int(y1) + 1), major)]
        if y1 - y0 == 1:  # one decade: label 2 and 5 as well
            labels += [(m * 10.0**y0, _format_number(m * 10.0**y0)) for m in (2, 5)]
    else:
        tick = _nice_ceiling(y1)[1]
        major = list(np.arange(0.0, y1 + tick / 2, tick))
        minor = []
        labels = [(v, _format_number(v)) for v in major]
    for value in minor:
        row = int(layout.to_pixel(x0, value)[0])
        canvas.rect(left, right, row, row + 1, GRID_MINOR)
    for value in major:
        row = int(layout.to_pixel(x0, value)[0])
        canvas.rect(left, right, row, row + 1, GRID_MAJOR)
    for value in x_ticks:
        col = int(layout.to_pixel(value, 10.0**y0 if log_y else y0)[1])
        canvas.rect(col, col + 1, bottom, top, GRID_MAJOR)

    # Axes just outside the plot rectangle, tick marks and labels outside them.
    canvas.rect(left - s, left, bottom - s, top, AXIS)
    canvas.rect(left - s, right, bottom - s, bottom, AXIS)
    tick_len = 3 * s
    for value in x_ticks:
        col = int(layout.to_pixel(value, 10.0**y0 if log_y else y0)[1])
        canvas.rect(col, col + s, bottom - s - tick_len, bottom - s, AXIS)
        canvas.text(str(int(round(value))), col + s // 2, bottom - s - tick_len - s
                    - _FONT_HEIGHT * s, TEXT, s, anchor="centre")
    for value in minor:
        row = int(layout.to_pixel(x0, value)[0])
        canvas.rect(left - s - 2 * s, left - s, row, row + 1, AXIS)
    for value in major:
        row = int(layout.to_pixel(x0, value)[0])
        canvas.rect(left - s - tick_len, left - s, row, row + s, AXIS)
    for value, label in labels:
        row = int(layout.to_pixel(x0, value)[0])
        canvas.text(label, left - s - tick_len - s, row - (_FONT_HEIGHT * s) // 2, TEXT, s,
                    anchor="right")

    # Data: target (dashed), p95, mean on top.
    if target_arr is not None:
        _, ty = layout.to_canvas(x0, target_arr[0])
        dash, gap = 6.0 * s, 4.0 * s
        starts = np.arange(left, right, dash + gap)
        cov = np.zeros((layout.height, layout.width))
        for start in starts:
            end = min(start + dash, right)
            cov = np.maximum(cov, canvas.polyline_coverage(
                np.array([start + 0.5, end - 0.5]), np.array([ty, ty]), 1.2 * s))
        canvas.blend(cov, TARGET_COLOUR)
    for arr, colour_, width, radius in ((p95_arr, P95_COLOUR, 1.2 * s, 1.8 * s),
                                        (mean_arr, MEAN_COLOUR, 1.6 * s, 2.4 * s)):
        if arr is None:
            continue
        cx, cy = layout.to_canvas(x, arr)
        canvas.polyline(cx, cy, width, colour_)
        canvas.dots(cx, cy, radius, colour_)
    return canvas.rgba()


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
