"""A tabulated BRDF as a callable: multilinear over the grid, linear in wavelength."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...brdf.params import Parameterization, check_direction_pairs
from ...brdf.tabulate import Grid, interpolate
from ...colour import spectra
from .limits import CHUNK_POINTS, FORMAT
from .writer import write_tabulated


@dataclass
class TabulatedBRDF:
    """A BRDF sampled on a cell-centred grid; callable as ``f(wi, wo, wavelengths)``.

    Attributes
    ----------
    grid : Grid
        Parameterisation and resolution of the samples.
    values : ndarray (*grid.shape, L) float32
        ``f`` (not cosine-weighted) at the cell centres.
    wavelengths : ndarray (L,) float64
        nm.
    description : str
        Free text from the file.
    defects : dict
        ``{"nan": n, "inf": n, "negative": n}`` samples found (and set to 0 by
        ``on_invalid="clamp"``), with ``"first"``: where the first one was.
    path : Path or None
        The file it was read from.
    """

    grid: Grid
    values: np.ndarray
    wavelengths: np.ndarray
    description: str = ""
    defects: dict = field(default_factory=dict)
    path: Path | None = None

    def __post_init__(self) -> None:
        self.wavelengths = spectra.check_wavelengths(self.wavelengths)
        expected = self.grid.shape + (self.wavelengths.size,)
        if self.values.shape != expected:
            raise ValueError(f"values have shape {self.values.shape}, the grid and wavelengths "
                             f"need {expected}")
        self._resamplers: dict[tuple, np.ndarray | None] = {}

    @property
    def parameterization(self) -> Parameterization:
        return self.grid.parameterization

    @property
    def resolution(self) -> tuple[int, ...]:
        return self.grid.shape

    @property
    def isotropic(self) -> bool:
        return bool(self.grid.parameterization.isotropic)

    def _resampler(self, wavelengths: np.ndarray) -> np.ndarray | None:
        """Matrix M (L_file, L) with spectra(wavelengths) = spectra(file) @ M; None if equal."""
        key = tuple(wavelengths.tolist())
        if key in self._resamplers:
            return self._resamplers[key]
        own = self.wavelengths
        if own.size == wavelengths.size and np.array_equal(own, wavelengths):
            matrix = None
        else:
            eye = np.eye(own.size)
            matrix = np.stack([np.interp(wavelengths, own, row) for row in eye])
        if len(self._resamplers) >= 16:
            self._resamplers.pop(next(iter(self._resamplers)))
        self._resamplers[key] = matrix
        return matrix

    def __call__(self, wi: np.ndarray, wo: np.ndarray, wavelengths: np.ndarray) -> np.ndarray:
        """The BRDF ``f`` (N, L) at ``wavelengths`` (nm); 0 at or below the horizon."""
        wi, wo = check_direction_pairs(wi, wo)
        wl = spectra.check_wavelengths(wavelengths)
        matrix = self._resampler(wl)
        out = np.zeros((wi.shape[0], wl.size))
        lit = np.nonzero((wi[:, 2] > 0) & (wo[:, 2] > 0))[0]
        param = self.grid.parameterization
        for begin in range(0, lit.size, CHUNK_POINTS):
            rows = lit[begin : begin + CHUNK_POINTS]
            coords = param.forward(wi[rows], wo[rows])
            f = interpolate(self.values, self.grid, coords, edge="linear")
            if matrix is not None:
                f = f @ matrix
            out[rows] = np.maximum(f, 0.0)
        return out

    def describe(self) -> dict:
        """JSON-serialisable summary (no sample values)."""
        return {
            "format": FORMAT,
            "path": None if self.path is None else str(self.path),
            "parameterization": self.grid.parameterization.name,
            "resolution": list(self.grid.shape),
            "wavelengths": [float(self.wavelengths[0]), float(self.wavelengths[-1]),
                            int(self.wavelengths.size)],
            "description": self.description,
            "defects": dict(self.defects),
        }

    def save(self, path: str | Path) -> Path:
        """Write these samples with :func:`write_tabulated`."""
        return write_tabulated(path, self.values, self.wavelengths,
                               self.grid.parameterization.name, self.description)
