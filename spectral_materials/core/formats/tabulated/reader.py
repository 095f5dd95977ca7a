"""Reading tabulated BRDF files: the metadata and the members' headers checked before the
samples are read, the samples scanned for NaN, inf and negative values."""

from __future__ import annotations

import json
import math
import zipfile
from pathlib import Path

import numpy as np

from ...brdf.params import PARAMETERIZATIONS
from ...brdf.tabulate import Grid
from ...colour import spectra
from ...errors import InvalidBRDFData
from .._files import open_zip_member
from .limits import (
    _MAX_MEMBER_BYTES,
    FORMAT,
    FORMAT_VERSION,
    MAX_DEFLATE_RATIO,
    MAX_ENTRIES,
    MAX_META_BYTES,
    MAX_WAVELENGTHS,
)
from .sample_scan import _counts_text, _scan
from .table import TabulatedBRDF


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
