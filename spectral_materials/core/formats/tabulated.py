"""The project's tabulated spectral BRDF file (``.npz``) and a callable reading it.

File format (``spectral_materials.tabulated_brdf``, version 1)
-------------------------------------------------------------
A NumPy ``.npz`` archive (zip; stored or deflated members) with three arrays:

``values``
    float32, shape ``(*resolution, L)``: the BRDF ``f`` in sr⁻¹ (*not*
    multiplied by cos θi) at the cell centres of a grid over the axes of the
    parameterisation: axis ``k`` with ``n`` cells is sampled at
    ``Axis.centres(n)`` = ``from_unit((i + 0.5) / n)`` (see
    :mod:`spectral_materials.core.brdf.params`; θh of ``hd``/``hd_iso`` is
    square-root warped). C order: the last angular axis varies fastest, then
    wavelength is the innermost axis. Grid points that map to no physical
    configuration (below the horizon, outside the unit discs of ``gs``) hold 0.
``wavelengths``
    float64, shape ``(L,)``: strictly increasing, in nm (200–2000).
``meta``
    uint8, the UTF-8 bytes of a JSON object::

        {"format": "spectral_materials.tabulated_brdf", "version": 1,
         "parameterization": "io_iso",      # a key of params.PARAMETERIZATIONS
         "resolution": [90, 180, 90],       # == values.shape[:-1]
         "description": "free text"}

Every sample must be finite and non-negative.

Reading
-------
:func:`read_tabulated` validates ``meta`` and the ``.npy`` headers of the
members (shape, dtype, and that the member's size matches the header) before it
allocates anything, refuses more than :data:`MAX_ENTRIES` samples, and turns
every sort of damage (truncation, flipped bytes caught by the zip CRCs, missing
entries, a file that is not a zip) into :class:`InvalidBRDFData` (a
``ValueError``) naming the file and the problem. Declared sizes are checked
against the bytes present: a stored member must hold its declared bytes inside
the archive, a compressed one may declare at most :data:`MAX_DEFLATE_RATIO`
times its compressed size, and members are inflated step by step under a
running cap at their declared size, so memory stays in proportion to the file.
Non-finite or negative samples raise by default; ``on_invalid="clamp"`` sets
them to 0 and records their counts in :attr:`TabulatedBRDF.defects`.

Evaluating
----------
:class:`TabulatedBRDF` is a BRDF callable ``f(wi, wo, wavelengths) -> (N, L)``:
multilinear interpolation over the grid (φ axes wrap, θ ends extrapolate
linearly, as :func:`tabulate.interpolate` with ``edge="linear"``), then linear
interpolation in wavelength (held constant outside the file's range); negative
values from the extrapolation are clamped to 0, and the result is 0 wherever
either direction is at or below the horizon.
"""

from __future__ import annotations

import json
import math
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..brdf.params import (
    PARAMETERIZATIONS,
    Parameterization,
    check_direction_pairs,
    get_parameterization,
)
from ..brdf.tabulate import Grid, interpolate, tabulate
from ..colour import spectra
from ..errors import InvalidBRDFData
from ..progress import ProgressCallback
from ._files import atomic_write, open_zip_member

FORMAT = "spectral_materials.tabulated_brdf"
FORMAT_VERSION = 1
#: Refuse files with more samples than this (angular cells × wavelengths).
MAX_ENTRIES = 2_000_000_000
#: Refuse ``meta`` entries longer than this many bytes.
MAX_META_BYTES = 1 << 20
#: Refuse wavelength axes longer than this.
MAX_WAVELENGTHS = 100_000
#: Direction pairs evaluated per chunk in :meth:`TabulatedBRDF.__call__`.
CHUNK_POINTS = 16384
#: Refuse a compressed member that declares more than this many times its compressed
#: bytes (beyond its first MiB, :data:`._files.RATIO_FREE_BYTES`). Measured with
#: ``np.savez_compressed`` on tables of this module: Oren–Nayar 2.6:1, GGX on a metal
#: 31:1, spectrally flat GGX 82:1, spectrally flat tables with large zero regions (Lambert
#: in ``gs``, a no-diffuse Ashikhmin–Shirley lobe of exponent 10⁴) 295–317:1. Deflate
#: cannot exceed about 1030:1, which a table of zeros reaches: that is how a 1 MB file
#: claims a gigabyte. (This module's writer stores members uncompressed: 1:1.)
MAX_DEFLATE_RATIO = 512
#: Samples scanned per chunk for NaN/inf/negatives.
_SCAN_ENTRIES = 1 << 22
#: The most any member can declare: MAX_ENTRIES float64 samples and a .npy header.
_MAX_MEMBER_BYTES = MAX_ENTRIES * 8 + (1 << 16)

__all__ = [
    "FORMAT",
    "FORMAT_VERSION",
    "MAX_ENTRIES",
    "TabulatedBRDF",
    "read_tabulated",
    "tabulate_to_file",
    "write_tabulated",
]


# --------------------------------------------------------------------------- callable


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


# --------------------------------------------------------------------------- writing


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


# --------------------------------------------------------------------------- reading


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


class _Invalid(Exception):
    """Internal: a problem found while parsing, turned into InvalidBRDFData with the path."""


def _open_member(path: Path, archive: zipfile.ZipFile, info: zipfile.ZipInfo):
    """The member's bytes, its declared sizes checked against the archive first."""
    return open_zip_member(archive, info, path=path, max_bytes=_MAX_MEMBER_BYTES,
                           max_ratio=MAX_DEFLATE_RATIO)


def _member_header(path: Path, archive: zipfile.ZipFile, name: str
                   ) -> tuple[tuple[int, ...], np.dtype]:
    """Shape and dtype of ``name.npy`` from its header, checked against the member's size."""
    member = f"{name}.npy"
    try:
        info = archive.getinfo(member)
    except KeyError:
        raise _Invalid(f"no '{name}' entry (has: "
                       f"{', '.join(sorted(archive.namelist())) or 'nothing'})") from None
    with _open_member(path, archive, info) as stream:
        version = np.lib.format.read_magic(stream)
        if version == (1, 0):
            shape, _, dtype = np.lib.format.read_array_header_1_0(stream)
        elif version == (2, 0):
            shape, _, dtype = np.lib.format.read_array_header_2_0(stream)
        else:
            raise _Invalid(f"'{name}' uses .npy format version {version}; 1.0 or 2.0 expected")
        offset = stream.tell()
    if dtype.hasobject or dtype.shape != () or dtype.names is not None:
        raise _Invalid(f"'{name}' has dtype {dtype}, a plain numeric type is expected")
    if any(int(n) < 0 for n in shape):
        raise _Invalid(f"'{name}' header has a negative dimension {shape}")
    entries = math.prod(int(n) for n in shape)
    if entries > MAX_ENTRIES:
        raise _Invalid(f"'{name}' header claims shape {tuple(shape)}: {entries:,} entries, over "
                       f"the {MAX_ENTRIES:,} limit")
    expected = offset + entries * dtype.itemsize
    if info.file_size != expected:
        raise _Invalid(f"'{name}' holds {info.file_size:,} bytes but its header "
                       f"(shape {tuple(shape)}, {dtype}) needs {expected:,}")
    return tuple(int(n) for n in shape), dtype


def _parse_meta(raw: np.ndarray) -> dict:
    try:
        meta = json.loads(raw.tobytes().decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise _Invalid(f"corrupt 'meta' entry ({exc})") from None
    if not isinstance(meta, dict):
        raise _Invalid("'meta' is not a JSON object")
    if meta.get("format") != FORMAT:
        raise _Invalid(f"format {meta.get('format')!r} is not {FORMAT!r}")
    version = meta.get("version")
    if not isinstance(version, int) or isinstance(version, bool) or version != FORMAT_VERSION:
        raise _Invalid(f"version {version!r} is not supported (this reader reads "
                       f"{FORMAT_VERSION})")
    name = meta.get("parameterization")
    if not isinstance(name, str) or name not in PARAMETERIZATIONS:
        raise _Invalid(f"parameterization {name!r} is not one of "
                       f"{', '.join(sorted(PARAMETERIZATIONS))}")
    resolution = meta.get("resolution")
    if (not isinstance(resolution, list)
            or not all(isinstance(n, int) and not isinstance(n, bool) for n in resolution)):
        raise _Invalid(f"resolution {resolution!r} is not a list of integers")
    description = meta.get("description", "")
    if not isinstance(description, str):
        raise _Invalid("description is not a string")
    return meta


def _read_member(path: Path, archive: zipfile.ZipFile, name: str) -> np.ndarray:
    """The array of ``name.npy``, inflated under a running cap (after :func:`_member_header`
    checked its declared size: no more is allocated than the member really holds)."""
    with _open_member(path, archive, archive.getinfo(f"{name}.npy")) as stream:
        return np.lib.format.read_array(stream, allow_pickle=False)


def _read(path: Path, on_invalid: str) -> TabulatedBRDF:
    # 1. meta (small), 2. the headers of the big members, checked against it;
    # 3. only then the samples.
    with zipfile.ZipFile(path) as archive:
        meta_shape, meta_dtype = _member_header(path, archive, "meta")
        if meta_dtype != np.uint8 or len(meta_shape) != 1 or meta_shape[0] > MAX_META_BYTES:
            raise _Invalid(f"'meta' is {meta_dtype} of shape {meta_shape}; expected uint8 bytes "
                           f"(at most {MAX_META_BYTES:,})")
        meta = _parse_meta(_read_member(path, archive, "meta"))
        param = PARAMETERIZATIONS[meta["parameterization"]]
        resolution = tuple(meta["resolution"])
        try:
            grid = Grid(param, resolution)
        except ValueError as exc:
            raise _Invalid(str(exc)) from None
        wl_shape, wl_dtype = _member_header(path, archive, "wavelengths")
        if wl_dtype.kind not in "fiu" or len(wl_shape) != 1 or not 1 <= wl_shape[0] \
                <= MAX_WAVELENGTHS:
            raise _Invalid(f"'wavelengths' is {wl_dtype} of shape {wl_shape}; expected a 1-D "
                           f"float array of 1..{MAX_WAVELENGTHS}")
        values_shape, values_dtype = _member_header(path, archive, "values")
        expected = resolution + (wl_shape[0],)
        if values_shape != expected:
            raise _Invalid(f"'values' has shape {values_shape}; resolution {list(resolution)} "
                           f"and {wl_shape[0]} wavelengths need {expected}")
        if values_dtype.kind != "f" or values_dtype.itemsize > 8:
            raise _Invalid(f"'values' has dtype {values_dtype}; float32 expected")
        try:
            raw = _read_member(path, archive, "wavelengths").astype(np.float64)
            wavelengths = spectra.check_wavelengths(raw)
        except InvalidBRDFData:
            raise
        except ValueError as exc:
            raise _Invalid(f"bad wavelengths: {exc}") from None
        values = np.ascontiguousarray(_read_member(path, archive, "values"), dtype=np.float32)
    if values.shape != expected:  # the header check makes this unreachable; belt and braces
        raise _Invalid(f"'values' read with shape {values.shape}, expected {expected}")
    counts, first = _scan(values, grid, wavelengths, clamp=on_invalid == "clamp")
    defects: dict = dict(counts)
    if any(counts.values()):
        if on_invalid != "clamp":
            raise InvalidBRDFData(f"{path}: {_counts_text(counts, values.size)}; first at "
                                  f"{first} (read with on_invalid='clamp' to set them to 0)")
        defects["first"] = first
    return TabulatedBRDF(grid=grid, values=values, wavelengths=wavelengths,
                         description=meta.get("description", ""), defects=defects, path=path)


def read_tabulated(path: str | Path, *, on_invalid: str = "raise") -> TabulatedBRDF:
    """Read a tabulated BRDF file, validating it before loading the samples.

    Parameters
    ----------
    on_invalid : {"raise", "clamp"}
        What to do with NaN, inf or negative samples: raise
        :class:`InvalidBRDFData` with their counts and the first location, or set
        them to 0 and record the counts in ``defects``.

    Raises
    ------
    InvalidBRDFData
        (a ``ValueError``) for any malformed, truncated or corrupt file, naming
        the file and the problem.
    OSError
        If the file cannot be opened at all (missing, a directory, no permission).
    """
    if on_invalid not in ("raise", "clamp"):
        raise ValueError(f"on_invalid must be 'raise' or 'clamp', got {on_invalid!r}")
    path = Path(path)
    if not path.is_file():
        if not path.exists():
            raise FileNotFoundError(f"{path}: no such file")
        raise IsADirectoryError(f"{path}: not a regular file")
    size = path.stat().st_size
    if size == 0:
        raise InvalidBRDFData(f"{path}: empty file, not a tabulated BRDF (.npz)")
    try:
        return _read(path, on_invalid)
    except InvalidBRDFData:
        raise
    except _Invalid as exc:
        raise InvalidBRDFData(f"{path}: {exc}") from None
    except zipfile.BadZipFile as exc:
        raise InvalidBRDFData(f"{path}: not a valid .npz (zip) archive or damaged ({exc})") \
            from None
    except MemoryError:
        raise InvalidBRDFData(f"{path}: not enough memory to load its samples") from None
    except PermissionError:
        raise
    except Exception as exc:  # any other damage must surface as InvalidBRDFData too
        raise InvalidBRDFData(f"{path}: unreadable or damaged ({type(exc).__name__}: {exc})") \
            from None
