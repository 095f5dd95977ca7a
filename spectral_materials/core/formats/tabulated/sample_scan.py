"""Scanning samples for NaN, inf and negative values, chunk by chunk, and naming the first
one found by its grid cell and wavelength."""

from __future__ import annotations

import numpy as np

from ...brdf.tabulate import Grid
from .limits import _SCAN_ENTRIES


def _counts_text(counts: dict, total: int) -> str:
    return (f"{counts['nan']} NaN, {counts['inf']} inf and {counts['negative']} negative "
            f"samples of {total:,}")


def _describe_location(grid: Grid, row: int, wavelength: float) -> str:
    """A grid cell in the parameterisation's coordinates and as directions, in degrees."""
    param = grid.parameterization
    index = np.unravel_index(row, grid.shape)
    coords = grid.coords(np.array([row]))
    angular = param.name != "gs"
    parts = []
    for axis, i, v in zip(param.axes, index, coords[0], strict=True):
        shown = f"{np.degrees(v):.2f}°" if angular else f"{v:.4f}"
        parts.append(f"{axis.name}={shown} [{int(i)}]")
    wi, wo, _ = param.inverse(coords)
    angles = []
    for label, w in (("i", wi[0]), ("o", wo[0])):
        theta = np.degrees(np.arctan2(np.hypot(w[0], w[1]), w[2]))
        phi = np.degrees(np.arctan2(w[1], w[0])) % 360.0
        angles.append(f"θ{label}={theta:.2f}° φ{label}={phi:.2f}°")
    return f"{', '.join(parts)} ({', '.join(angles)}), λ={wavelength:.1f} nm"


def _scan(values: np.ndarray, grid: Grid, wavelengths: np.ndarray, clamp: bool
          ) -> tuple[dict, str]:
    """Count NaN/inf/negative samples chunk by chunk; with ``clamp`` set them to 0 in place."""
    flat = values.reshape(-1, values.shape[-1])
    counts = {"nan": 0, "inf": 0, "negative": 0}
    first = ""
    rows = max(1, _SCAN_ENTRIES // max(1, flat.shape[1]))
    for begin in range(0, flat.shape[0], rows):
        chunk = flat[begin : begin + rows]
        nan = np.isnan(chunk)
        inf = np.isinf(chunk)
        neg = chunk < 0
        bad = nan | inf | neg
        if not bad.any():
            continue
        counts["nan"] += int(nan.sum())
        counts["inf"] += int(inf.sum())
        counts["negative"] += int(neg.sum())
        if not first:
            r, c = (int(i[0]) for i in np.nonzero(bad))
            first = _describe_location(grid, begin + r, float(wavelengths[c]))
        if clamp:
            chunk[bad] = 0.0
    return counts, first
