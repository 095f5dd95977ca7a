"""Sampling a BRDF callable onto a grid in a parameterisation, and looking tables up.

Grids are cell-centred: axis ``k`` with ``n`` cells samples ``Axis.centres(n)``,
so no sample sits exactly on a pole, on the horizon or on a φ seam. Lookups
interpolate linearly per axis (``axes.axis_lookup``): φ axes wrap, and
beyond the first or last centre of a θ axis the table is extrapolated linearly
(``edge="linear"``, the default, measured better than holding the end value
for ``f·cosθi``, which goes to 0 at the horizon) or held (``edge="clamp"``);
``edge="horizon"`` takes a cosine-weighted table to 0 at θi = 90° (``axes``), the
rule new factor packs use; ``edge="horizons"`` at θo = 90° as well, where the add-on's
Automatic measures it better (``grazing.choose_edge``).

The tabulated quantity is ``f·cosθi`` by default, as in Schwenk et al. (2010)
§4: it is what a point light reflects, bounded at grazing angles, and it is
what the protocol's colour error weighs.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..colour import pipeline as colour_pipeline, spectra
from ..colour.basis import LinearModelBasis
from ..errors import InvalidBRDFData
from ..progress import ProgressCallback, report
from .axes import holds_horizon
from .lobe import SpecularLobe
from .params import Parameterization, axis_lookup, horizon_scale

#: Refuse grids beyond this many samples (angular × spectral): a clear error
#: instead of an out-of-memory crash.
MAX_TABLE_ENTRIES = 1_500_000_000
CHUNK_POINTS = 16384


@dataclass(frozen=True)
class Grid:
    """A cell-centred grid over a parameterisation's axes."""

    parameterization: Parameterization
    resolution: tuple[int, ...]

    def __post_init__(self) -> None:
        axes = self.parameterization.axes
        if len(self.resolution) != len(axes):
            names = ", ".join(a.name for a in axes)
            raise ValueError(
                f"{self.parameterization.name} has {len(axes)} axes ({names}); "
                f"resolution {self.resolution} has {len(self.resolution)} entries"
            )
        for axis, n in zip(axes, self.resolution):
            if int(n) != n or n < 1 or n > 100_000:
                raise ValueError(f"resolution of axis {axis.name} must be 1..100000, got {n}")

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(int(n) for n in self.resolution)

    @property
    def size(self) -> int:
        return int(np.prod(self.shape))

    def axis_values(self) -> list[np.ndarray]:
        return [a.centres(n) for a, n in zip(self.parameterization.axes, self.shape)]

    def coords(self, flat_index: np.ndarray) -> np.ndarray:
        """Coordinates (N, d) of grid points given by flat C-order indices."""
        idx = np.unravel_index(np.asarray(flat_index), self.shape)
        values = self.axis_values()
        return np.stack([values[k][i] for k, i in enumerate(idx)], axis=-1)

    def lookup(self, coords: np.ndarray, edge: str = "linear") -> list[tuple]:
        """Per-axis ``(i0, i1, w)`` linear-interpolation lookups for coords (N, d)."""
        coords = np.asarray(coords, dtype=np.float64)
        return [axis_lookup(a, n, coords[:, k], edge=edge)
                for k, (a, n) in enumerate(zip(self.parameterization.axes, self.shape))]

    def edge_scale(self, coords: np.ndarray, edge: str = "linear") -> np.ndarray | None:
        """The ``"horizon"``/``"horizons"`` rule's scale (N,) of a lookup at coords (N, d):
        the product of :func:`.axes.horizon_scale` over the axes the rule holds; None
        where it holds none (nothing to scale)."""
        axes = self.parameterization.axes
        if not any(holds_horizon(a, edge) for a in axes):
            return None
        coords = np.asarray(coords, dtype=np.float64)
        scale = np.ones(coords.shape[0])
        for k, (a, n) in enumerate(zip(axes, self.shape)):
            if holds_horizon(a, edge):
                scale *= horizon_scale(a, n, coords[:, k], edge)
        return scale

    def describe(self) -> dict:
        return {
            "parameterization": self.parameterization.name,
            "resolution": list(self.shape),
            "axes": [
                {"name": a.name, "lo": a.lo, "hi": a.hi, "periodic": a.periodic, "warp": a.warp,
                 "unit": "rad"}
                for a in self.parameterization.axes
            ],
        }


@dataclass
class Table:
    """A tabulated spectral BRDF.

    Attributes
    ----------
    values : ndarray (*grid.shape, S) float32
        ``f·cosθi`` (or ``f``) per grid point; the last axis holds wavelength
        samples, or basis coefficients when ``basis`` is set. Zero where invalid.
    valid : ndarray (*grid.shape) bool
        Grid points that map to a physical configuration above the horizon.
    basis_error_sq : float
        ``Σ ‖s − ΨΨᵀs‖²`` of the spectra lost by the basis projection (0 without one).
    norm_sq : float
        ``Σ ‖s‖²`` of the unprojected spectra (float64).
    lobe : SpecularLobe or None
        The analytic lobe taken out of the BRDF before tabulating (``values`` is then the
        residual), set by ``factor.prepare_table``.
    cells : tuple or None
        The measured table's (θh, θd, φd) cells the models are drawn in
        (:mod:`.measured_cells`), set by ``factor.prepare_table``.
    """

    values: np.ndarray
    valid: np.ndarray
    grid: Grid
    wavelengths: np.ndarray
    basis: LinearModelBasis | None
    cosine_weighted: bool
    basis_error_sq: float
    norm_sq: float
    seconds: float
    lobe: SpecularLobe | None = None
    lobe_report: dict = field(default_factory=dict)
    cells: tuple[int, int, int] | None = None

    def xyz(self, wi: np.ndarray, wo: np.ndarray, illuminant: str | np.ndarray = "D65",
            chunk: int = 8192) -> np.ndarray:
        """Linear XYZ (N, 3) of the table itself, looked up as the factors are (the error floor),
        with its lobe's part where it carries one."""
        weights = colour_pipeline.xyz_weights(
            illuminant, self.wavelengths, None if self.basis is None else self.basis.vectors)
        param = self.grid.parameterization
        out = np.empty((wi.shape[0], 3))
        for begin in range(0, wi.shape[0], chunk):
            sl = slice(begin, begin + chunk)
            values = interpolate(self.values, self.grid, param.forward(wi[sl], wo[sl]))
            if not self.cosine_weighted:
                values = values * np.clip(wi[sl, 2:3], 0.0, None)
            if self.lobe is not None:
                values = values + self.lobe.coefficients(wi[sl], wo[sl], cosine_weighted=True)
            lit = (wi[sl, 2] > 0) & (wo[sl, 2] > 0)
            out[sl] = (values * lit[:, None]) @ weights
        return out


def _describe_bad(grid: Grid, flat: np.ndarray, wavelengths: np.ndarray, bad: np.ndarray) -> str:
    """Where the first bad samples sit, in degrees and nm."""
    rows, cols = np.nonzero(bad)
    parts = []
    for r, c in list(zip(rows, cols))[:3]:
        coords = grid.coords(flat[r : r + 1])[0]
        where = ", ".join(f"{a.name}={np.degrees(v):.2f}°"
                          for a, v in zip(grid.parameterization.axes, coords))
        parts.append(f"({where}, λ={wavelengths[c]:.1f} nm)")
    return "; ".join(parts)


def _table_depth(grid: Grid, wl: np.ndarray, basis: LinearModelBasis | None) -> int:
    """Entries per grid point (wavelengths, or basis coefficients), the table size checked."""
    if basis is not None and (basis.wavelengths.shape != wl.shape
                              or not np.allclose(basis.wavelengths, wl)):
        raise ValueError("the spectral basis is defined on other wavelengths than the table")
    depth = wl.size if basis is None else basis.size
    if grid.size * depth > MAX_TABLE_ENTRIES:
        raise ValueError(
            f"a {grid.shape} × {depth} table has {grid.size * depth:,} entries, over the "
            f"{MAX_TABLE_ENTRIES:,} limit; lower the resolution or use a spectral basis"
        )
    return depth


def _sample_chunk(brdf, grid: Grid, flat: np.ndarray, wl: np.ndarray, cosine_weighted: bool,
                  counts: dict, *, locate: bool, signed: bool = False
                  ) -> tuple[np.ndarray | None, np.ndarray, str | None]:
    """The BRDF at the grid points ``flat`` where both directions are above the horizon.

    Returns (samples (lit points, L) or None if none is lit, the lit mask, None). Where
    the BRDF returns NaN, inf or (unless ``signed``) negative values they are added to
    ``counts`` and the result is (None, mask, where the first sit if ``locate`` else "").
    """
    wi, wo, ok = grid.parameterization.inverse(grid.coords(flat))
    ok = ok & (wi[:, 2] > 0) & (wo[:, 2] > 0)
    if not ok.any():
        return None, ok, None
    f = np.asarray(brdf(wi[ok], wo[ok], wl), dtype=np.float64)
    if f.shape != (int(ok.sum()), wl.size):
        expected = (int(ok.sum()), wl.size)
        raise ValueError(f"BRDF returned shape {f.shape}, expected {expected}")
    bad = ~np.isfinite(f) if signed else ~np.isfinite(f) | (f < 0)
    if bad.any():
        counts["nan"] += int(np.isnan(f).sum())
        counts["inf"] += int(np.isinf(f).sum())
        counts["neg"] += 0 if signed else int((f < 0).sum())
        return None, ok, _describe_bad(grid, flat[ok], wl, bad) if locate else ""
    if cosine_weighted:
        f = f * wi[ok, 2:3]  # never in place: the array may be the caller's
    if np.abs(f).max(initial=0.0) > np.finfo(np.float32).max:
        raise InvalidBRDFData(
            f"the BRDF exceeds the float32 range ({np.abs(f).max():.3g}) near "
            f"{_describe_bad(grid, flat[ok], wl, np.abs(f) > np.finfo(np.float32).max)}")
    return f, ok, None


def tabulate(
    brdf,
    grid: Grid,
    wavelengths: np.ndarray | None = None,
    *,
    cosine_weighted: bool = True,
    basis: LinearModelBasis | None = None,
    callback: ProgressCallback | None = None,
    chunk_points: int = CHUNK_POINTS,
    signed: bool = False,
) -> Table:
    """Sample ``brdf(wi, wo, wavelengths)`` at every grid point.

    ``signed`` accepts negative samples: a residual beside an analytic lobe
    (:class:`.lobe.LobeResidual`) is one; a BRDF is not.

    Raises
    ------
    InvalidBRDFData
        If the BRDF returns NaN, inf or (unless ``signed``) negative values; the message gives their
        counts and the first locations (angles in degrees, wavelength in nm).
    ValueError
        For a grid too large to hold, or a BRDF returning the wrong shape.
    """
    start = time.perf_counter()
    wl = spectra.check_wavelengths(
        spectra.WAVELENGTHS_REFERENCE if wavelengths is None else wavelengths)
    depth = _table_depth(grid, wl, basis)
    values = np.zeros((grid.size, depth), dtype=np.float32)
    valid = np.zeros(grid.size, dtype=bool)
    vectors = None if basis is None else basis.vectors
    counts = {"nan": 0, "inf": 0, "neg": 0}
    first_bad = ""
    norm_sq = 0.0
    kept_sq = 0.0
    for begin in range(0, grid.size, chunk_points):
        flat = np.arange(begin, min(begin + chunk_points, grid.size))
        f, ok, where = _sample_chunk(brdf, grid, flat, wl, cosine_weighted, counts,
                                     locate=not first_bad, signed=signed)
        if where is not None:  # bad samples: counted, the chunk left out
            first_bad = first_bad or where
            continue
        if f is not None:
            norm_sq += float(np.sum(f * f))
            if vectors is not None:
                f = f @ vectors
                kept_sq += float(np.sum(f * f))
            values[flat[ok]] = f
            valid[flat[ok]] = True
        report(callback, min(begin + chunk_points, grid.size) / grid.size, "tabulating")
    if any(counts.values()):
        raise InvalidBRDFData(
            f"the BRDF returned {counts['nan']} NaN, {counts['inf']} inf and {counts['neg']} "
            f"negative values on a {grid.parameterization.name} grid {grid.shape}; "
            f"first at {first_bad}"
        )
    return Table(
        values=values.reshape(grid.shape + (depth,)),
        valid=valid.reshape(grid.shape),
        grid=grid,
        wavelengths=wl,
        basis=basis,
        cosine_weighted=cosine_weighted,
        basis_error_sq=max(norm_sq - kept_sq, 0.0) if vectors is not None else 0.0,
        norm_sq=norm_sq,
        seconds=time.perf_counter() - start,
    )


def multilinear(flat: np.ndarray, shape: tuple[int, ...], lookups: list[tuple]) -> np.ndarray:
    """Multilinear lookup in ``flat`` (prod(shape), …) with per-axis ``(i0, i1, w)`` → (N, …).

    The 2^d corners of each cell are gathered and weighted; trailing axes of
    ``flat`` (spectra, terms) come along unchanged.
    """
    strides = np.cumprod((tuple(shape[1:]) + (1,))[::-1])[::-1]
    n = lookups[0][0].shape[0]
    out = np.zeros((n,) + flat.shape[1:])
    trailing = (slice(None),) + (None,) * (flat.ndim - 1)
    for corner in range(2 ** len(lookups)):
        index = np.zeros(n, dtype=np.int64)
        weight = np.ones(n)
        for k, (i0, i1, w) in enumerate(lookups):
            upper = (corner >> k) & 1
            index += (i1 if upper else i0) * strides[k]
            weight *= w if upper else (1.0 - w)
        out += weight[trailing] * flat[index]
    return out


def interpolate(values: np.ndarray, grid: Grid, coords: np.ndarray,
                edge: str = "linear") -> np.ndarray:
    """Multilinear lookup of a full table ``values (*grid.shape, S)`` at coords (N, d) → (N, S)."""
    out = multilinear(values.reshape(-1, values.shape[-1]), grid.shape, grid.lookup(coords, edge))
    scale = grid.edge_scale(coords, edge)
    return out if scale is None else out * scale[:, None]
