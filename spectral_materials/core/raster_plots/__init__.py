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

The package's modules: :mod:`.canvas` (colours, font, :class:`PlotLayout`, the
anti-aliasing canvas), :mod:`.error_plot` and :mod:`.spectrum_plot`; every public name is
re-exported here.
"""

from __future__ import annotations

from .canvas import (
    AXIS,
    BACKGROUND,
    CURVE_COLOUR,
    GRID_MAJOR,
    GRID_MINOR,
    MAX_SIDE,
    MEAN_COLOUR,
    MIN_SIZE,
    P95_COLOUR,
    PLOT_BACKGROUND,
    TARGET_COLOUR,
    TEXT,
    PlotLayout,
)
from .error_plot import error_plot_layout, plot_error_against_packs
from .spectrum_plot import plot_spectrum, spectrum_plot_layout, wavelength_colours

__all__ = [
    "AXIS",
    "BACKGROUND",
    "CURVE_COLOUR",
    "GRID_MAJOR",
    "GRID_MINOR",
    "MAX_SIDE",
    "MEAN_COLOUR",
    "MIN_SIZE",
    "P95_COLOUR",
    "PLOT_BACKGROUND",
    "TARGET_COLOUR",
    "TEXT",
    "PlotLayout",
    "error_plot_layout",
    "plot_error_against_packs",
    "plot_spectrum",
    "spectrum_plot_layout",
    "wavelength_colours",
]
