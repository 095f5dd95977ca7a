"""The interpolants of an RGL ``.bsdf`` evaluation: the (θ, φ) → unit-square maps, the
incident-grid corners and bilinear lookups, and the VNDF warp (``Marginal2D``) inverted at
the half vector."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .tensor_file import _Invalid

#: Elements per block when the warp tables are built (float64 temporaries of a few MB).
CHUNK_ELEMENTS = 1 << 18

# --------------------------------------------------------------------------- interpolants


def _theta2u(theta):
    return np.sqrt(np.maximum(theta, 0.0) * (2.0 / math.pi))


def _phi2u(phi):
    return (phi + math.pi) / (2.0 * math.pi)


def _elevation(d: np.ndarray) -> np.ndarray:
    """acos(d.z), robustly: 2·asin(|d − ẑ| / 2) as the reference."""
    dist = np.sqrt(d[:, 0] ** 2 + d[:, 1] ** 2 + (d[:, 2] - 1.0) ** 2)
    return 2.0 * np.arcsin(np.clip(0.5 * dist, -1.0, 1.0))


def _param_weights(values: np.ndarray, q: np.ndarray):
    """Lower index, upper index and weight of the upper one (``find_interval`` + clamp)."""
    n = values.size
    if n == 1:
        zero = np.zeros(q.shape, dtype=np.int64)
        return zero, zero, np.zeros(q.shape)
    i = np.clip(np.searchsorted(values, q, side="right") - 1, 0, n - 2)
    p0 = values[i]
    p1 = values[i + 1]
    w = np.clip((q - p0) / (p1 - p0), 0.0, 1.0)
    return i, i + 1, w


def _corners(phi_grid, theta_grid, phi, theta):
    """The 4 (φi, θi) slice corners: list of (iφ, iθ, weight)."""
    a0, a1, wa = _param_weights(phi_grid, phi)
    b0, b1, wb = _param_weights(theta_grid, theta)
    return [(a0, b0, (1 - wa) * (1 - wb)), (a0, b1, (1 - wa) * wb),
            (a1, b0, wa * (1 - wb)), (a1, b1, wa * wb)]


def _cell(u: np.ndarray, n: int):
    """Cell index (clamped to n − 2) and fraction of unit-square coordinates on n nodes."""
    s = u * (n - 1)
    i = np.minimum(np.floor(s), n - 2).astype(np.int64)
    i = np.maximum(i, 0)
    return i, s - i


def _bilinear(table: np.ndarray, u: np.ndarray) -> np.ndarray:
    """``Marginal2D<0>::eval`` without normalisation: table [ny, nx], u (N, 2) = (x, y)."""
    ny, nx = table.shape
    ix, fx = _cell(u[:, 0], nx)
    iy, fy = _cell(u[:, 1], ny)
    return ((1 - fy) * ((1 - fx) * table[iy, ix] + fx * table[iy, ix + 1])
            + fy * ((1 - fx) * table[iy + 1, ix] + fx * table[iy + 1, ix + 1]))


def _cumulative_trapezoid(src: np.ndarray, out: np.ndarray,
                          block: int = CHUNK_ELEMENTS) -> None:
    """``out[:, j] = Σ_{k<j} ½ (src[:, k] + src[:, k + 1])`` for 2-D ``src`` and ``out``.

    Summed in float64 over blocks of at most ``block`` elements, carrying each row's
    running sum across column blocks, so that no temporary grows with the table (one
    slice, or one row, may be the whole of it).
    """
    m, n = src.shape
    cols = min(n, max(1, block))
    rows = max(1, block // cols)
    for r0 in range(0, m, rows):
        r1 = min(m, r0 + rows)
        carry = np.zeros((r1 - r0, 1))
        last = None  # the previous block's last column
        for c0 in range(0, n, cols):
            piece = src[r0:r1, c0 : c0 + cols].astype(np.float64)
            if last is None:
                steps = 0.5 * (piece[:, 1:] + piece[:, :-1])
                part = np.concatenate([np.zeros((r1 - r0, 1)), np.cumsum(steps, axis=1)], 1)
            else:
                ext = np.concatenate([last, piece], axis=1)
                part = np.cumsum(0.5 * (ext[:, 1:] + ext[:, :-1]), axis=1)
            part += carry
            out[r0:r1, c0 : c0 + cols] = part
            carry, last = part[:, -1:], piece[:, -1:]


@dataclass
class _Warp:
    """``Marginal2D<2>`` (build_cdf) per (φi, θi) slice, in one float32 table beside the data.

    ``cumulative[..., y, x]`` for x ≥ 1 is the conditional CDF along x of row y (at x = 0
    it is 0, so that column is free) and ``cumulative[..., y, 0]`` the marginal CDF along
    y: one float32 per vndf sample in all. Neither is normalised: 1 / ``totals`` (each
    slice's integral) rides on the corner weights, so ``data`` is the vndf itself, not a
    normalised copy. float32 as the references store these tables (powitacq's and
    Mitsuba's ``Marginal2D`` hold ``float``); the sums are taken in float64.
    """

    data: np.ndarray  # [φ, θ, ny, nx], the vndf
    cumulative: np.ndarray  # [φ, θ, ny, nx] float32
    totals: np.ndarray  # [φ, θ] float64

    @classmethod
    def build(cls, vndf: np.ndarray) -> _Warp:
        """Raises a ValueError for a grid under 2 × 2 or a slice without a positive finite
        integral (its warp would be undefined)."""
        phis, thetas, ny, nx = vndf.shape
        if ny < 2 or nx < 2:
            raise _Invalid(f"vndf has a grid of {[ny, nx]}: at least 2 × 2 needed")
        cumulative = np.empty(vndf.shape, np.float32)
        _cumulative_trapezoid(vndf.reshape(-1, nx), cumulative.reshape(-1, nx))
        slices = cumulative.reshape(-1, ny, nx)
        _cumulative_trapezoid(slices[:, :, nx - 1], slices[:, :, 0])
        totals = slices[:, ny - 1, 0].astype(np.float64).reshape(phis, thetas)
        bad = ~(totals > 0) | ~np.isfinite(totals)
        if bad.any():
            j, k = np.argwhere(bad)[0]
            raise _Invalid(f"vndf slice (phi_i[{j}], theta_i[{k}]) has no positive finite "
                           "integral: its warp is undefined")
        return cls(vndf, cumulative, totals)

    def invert(self, u: np.ndarray, corners) -> np.ndarray:
        """``Marginal2D::invert``: density-space u (N, 2) → unit-square sample (N, 2)."""
        ny, nx = self.data.shape[2:]
        ix, fx = _cell(u[:, 0], nx)
        iy, fy = _cell(u[:, 1], ny)
        normalised = [(a, b, w / self.totals[a, b]) for a, b, w in corners]

        def look(arr, y, x):
            return sum(w * arr[a, b, y, x] for a, b, w in normalised)

        cum = self.cumulative
        v00, v10 = look(self.data, iy, ix), look(self.data, iy, ix + 1)
        v01, v11 = look(self.data, iy + 1, ix), look(self.data, iy + 1, ix + 1)
        c0 = (1 - fy) * v00 + fy * v01
        c1 = (1 - fy) * v10 + fy * v11
        x = fx * (c0 + 0.5 * fx * (c1 - c0))
        before = (1 - fy) * look(cum, iy, ix) + fy * look(cum, iy + 1, ix)
        x += np.where(ix > 0, before, 0.0)  # column 0 holds the marginal, not the CDF's 0
        r0 = look(cum, iy, nx - 1)
        r1 = look(cum, iy + 1, nx - 1)
        with np.errstate(divide="ignore", invalid="ignore"):
            x = x / ((1 - fy) * r0 + fy * r1)
        y = fy * (r0 + 0.5 * fy * (r1 - r0))
        y += look(cum, iy, 0)
        out = np.stack([x, y], axis=-1)
        return np.clip(np.nan_to_num(out, nan=0.0, posinf=1.0, neginf=0.0), 0.0, 1.0)
