"""Writing tabulated BRDF files, and sampling a BRDF straight into one."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ...brdf.params import get_parameterization
from ...brdf.tabulate import Grid, tabulate
from ...colour import spectra
from ...errors import InvalidBRDFData
from ...progress import ProgressCallback
from .._files import atomic_write
from .limits import FORMAT, FORMAT_VERSION, MAX_ENTRIES
from .sample_scan import _counts_text, _scan


def _meta_bytes(parameterization: str, resolution: tuple[int, ...], description: str) -> np.ndarray:
    meta = {
        "format": FORMAT,
        "version": FORMAT_VERSION,
        "parameterization": parameterization,
        "resolution": [int(n) for n in resolution],
        "description": str(description),
    }
    return np.frombuffer(json.dumps(meta).encode("utf-8"), dtype=np.uint8)


def write_tabulated(
    path: str | Path,
    values: np.ndarray,
    wavelengths: np.ndarray,
    parameterization: str,
    description: str = "",
    *,
    allow_invalid: bool = False,
) -> Path:
    """Write a tabulated BRDF file (see the module docstring for the format).

    Parameters
    ----------
    values : array (*resolution, L)
        ``f`` (not cosine-weighted) at the grid's cell centres; stored as float32.
    wavelengths : array (L,)
        nm, strictly increasing.
    parameterization : str
        A key of :data:`params.PARAMETERIZATIONS` (``"io_iso"``, ``"hd"``, ...).
    allow_invalid : bool
        Write NaN/inf/negative samples instead of raising (for testing readers).

    The file is written to a temporary name beside ``path`` and renamed, so a
    failed write never leaves a partial file under ``path``.
    """
    path = Path(path)
    param = get_parameterization(parameterization)
    if param.name != str(parameterization).strip().lower():
        raise ValueError(f"unknown parameterisation {parameterization!r}")
    wl = spectra.check_wavelengths(wavelengths)
    values = np.asarray(values)
    if values.ndim != param.ndim + 1:
        raise ValueError(f"{param.name} has {param.ndim} axes: values need {param.ndim + 1} "
                         f"dimensions (*resolution, L), got shape {values.shape}")
    grid = Grid(param, tuple(int(n) for n in values.shape[:-1]))
    if values.shape[-1] != wl.size:
        raise ValueError(f"values have {values.shape[-1]} spectral samples for {wl.size} "
                         "wavelengths")
    if values.size > MAX_ENTRIES:
        raise ValueError(f"{values.size:,} samples exceed the {MAX_ENTRIES:,} limit")
    stored = np.ascontiguousarray(values, dtype=np.float32)
    if not allow_invalid:
        counts, first = _scan(stored, grid, wl, clamp=False)
        if any(counts.values()):
            raise InvalidBRDFData(f"{path}: refusing to write {_counts_text(counts, stored.size)}"
                                  f"; first at {first}")
    arrays = {
        "values": stored,
        "wavelengths": wl.astype(np.float64),
        "meta": _meta_bytes(param.name, grid.shape, description),
    }
    atomic_write(path, lambda handle: np.savez(handle, **arrays))
    return path


def tabulate_to_file(
    brdf,
    path: str | Path,
    parameterization: str,
    resolution=None,
    wavelengths: np.ndarray | None = None,
    *,
    description: str | None = None,
    callback: ProgressCallback | None = None,
) -> Path:
    """Sample ``brdf(wi, wo, wavelengths)`` on a grid and write it with :func:`write_tabulated`.

    ``resolution`` defaults to the parameterisation's, ``wavelengths`` to
    380–780 nm every 5 nm; ``description`` defaults to the JSON of
    ``brdf.describe()`` when the BRDF has one.
    """
    param = get_parameterization(parameterization)
    grid = Grid(param, tuple(resolution) if resolution is not None else param.default_resolution)
    table = tabulate(brdf, grid, wavelengths, cosine_weighted=False, callback=callback)
    if description is None:
        describe = getattr(brdf, "describe", None)
        description = json.dumps(describe()) if callable(describe) else ""
    return write_tabulated(path, table.values, table.wavelengths, param.name, description)
