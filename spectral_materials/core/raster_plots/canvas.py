"""The drawing surface of the raster plots: colours, the 3 × 5 pixel font, the data →
canvas mapping (:class:`PlotLayout`), an anti-aliasing canvas, and the checks and tick
arithmetic both plots share."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

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
