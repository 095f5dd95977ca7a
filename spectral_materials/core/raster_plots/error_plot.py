"""The error plot: an error (e.g. mean ΔE94) against the number of factor packs, with its
95th percentile and a target."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .canvas import (
    _FONT_HEIGHT,
    AXIS,
    BACKGROUND,
    GRID_MAJOR,
    GRID_MINOR,
    MEAN_COLOUR,
    P95_COLOUR,
    PLOT_BACKGROUND,
    TARGET_COLOUR,
    TEXT,
    PlotLayout,
    _Canvas,
    _check_size,
    _font_scale,
    _format_decade,
    _format_number,
    _integer_step,
    _nice_ceiling,
    _series,
    _text_width,
)


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



def _error_ticks(layout: PlotLayout, log_y: bool) -> tuple[np.ndarray, list, list, list]:
    """(x ticks at integer packs; major and minor y grid values; y labels as (value,
    text)): decades on a log axis (2–9 × 10ᵏ minor), nice steps on a linear one."""
    s = layout.scale
    x0, x1 = layout.x_range
    step = _integer_step(x1 - x0, layout.right - layout.left,
                         _text_width(str(int(x1)), s) + 5 * s)
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
    return x_ticks, major, minor, labels


def _draw_grid(canvas: _Canvas, layout: PlotLayout, x_ticks: np.ndarray, major: list,
               minor: list) -> None:
    """Grid: x at integer packs; y at decades (log) or nice steps (linear)."""
    left, right, bottom, top = layout.left, layout.right, layout.bottom, layout.top
    x0 = layout.x_range[0]
    y0 = layout.y_range[0]
    for value in minor:
        row = int(layout.to_pixel(x0, value)[0])
        canvas.rect(left, right, row, row + 1, GRID_MINOR)
    for value in major:
        row = int(layout.to_pixel(x0, value)[0])
        canvas.rect(left, right, row, row + 1, GRID_MAJOR)
    for value in x_ticks:
        col = int(layout.to_pixel(value, 10.0**y0 if layout.log_y else y0)[1])
        canvas.rect(col, col + 1, bottom, top, GRID_MAJOR)


def _draw_axes(canvas: _Canvas, layout: PlotLayout, x_ticks: np.ndarray, major: list,
               minor: list, labels: list) -> None:
    """Axes just outside the plot rectangle, tick marks and labels outside them."""
    s = layout.scale
    left, right, bottom, top = layout.left, layout.right, layout.bottom, layout.top
    x0 = layout.x_range[0]
    y0 = layout.y_range[0]
    canvas.rect(left - s, left, bottom - s, top, AXIS)
    canvas.rect(left - s, right, bottom - s, bottom, AXIS)
    tick_len = 3 * s
    for value in x_ticks:
        col = int(layout.to_pixel(value, 10.0**y0 if layout.log_y else y0)[1])
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


def _draw_series(canvas: _Canvas, layout: PlotLayout, x: np.ndarray, mean_arr: np.ndarray,
                 p95_arr: np.ndarray | None, target_arr: np.ndarray | None) -> None:
    """Data: target (dashed), p95, mean on top."""
    s = layout.scale
    left, right = layout.left, layout.right
    if target_arr is not None:
        _, ty = layout.to_canvas(layout.x_range[0], target_arr[0])
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
    canvas = _Canvas(layout.width, layout.height, BACKGROUND)
    canvas.rect(layout.left, layout.right, layout.bottom, layout.top, PLOT_BACKGROUND)
    x_ticks, major, minor, labels = _error_ticks(layout, log_y)
    _draw_grid(canvas, layout, x_ticks, major, minor)
    _draw_axes(canvas, layout, x_ticks, major, minor, labels)
    _draw_series(canvas, layout, x, mean_arr, p95_arr, target_arr)
    return canvas.rgba()
