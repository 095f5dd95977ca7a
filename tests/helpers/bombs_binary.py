"""Hostile files for the binary BRDF readers (RGL ``.bsdf``, MERL ``.binary``) and the
spectrum CSV reader, each with the reader call whose peak memory it tests.

Importable without pytest: ``test_reader_memory_binary.py`` runs every bomb through
:func:`peak_memory.peak_run`, and a script can reuse :data:`BOMBS` the same way::

    from bombs_binary import BOMBS
    for name, bomb in BOMBS.items():
        path = bomb.make(directory)
        print(name, peak_run(bomb.setup, bomb.call, path))

``decoded_bytes`` is what the file can really hold once decoded: for a tensor file its bytes
(fields that do not overlap cannot hold more), for MERL the samples present (at most the
format's 3 × 1,458,000 doubles), for a CSV 16 bytes (two float64) per row present. The
memory bound under test is ``2 × decoded_bytes + 100 MB``.
"""

from __future__ import annotations

import math
import os
import struct
from collections.abc import Callable
from pathlib import Path

import numpy as np
from peak_memory import MB, Bomb

KB = 1 << 10


# --------------------------------------------------------------------------- RGL .bsdf

_RGL_SETUP = "from spectral_materials.core.formats import rgl_bsdf"
_RGL_CALL = "rgl_bsdf.read_rgl_bsdf(PATH)"
_CODES = {np.dtype("u1"): 1, np.dtype("<f4"): 10}
_HEADER = b"tensor_file\x00" + bytes((1, 0))


def _entry(name: str, code: int, offset: int, shape: tuple[int, ...]) -> bytes:
    raw = name.encode("utf-8")
    return (struct.pack("<H", len(raw)) + raw + struct.pack("<HBQ", len(shape), code, offset)
            + struct.pack(f"<{len(shape)}Q", *shape))


def _entry_size(name: str, ndim: int) -> int:
    return 2 + len(name.encode("utf-8")) + 11 + 8 * ndim


def _material(vndf: tuple[int, int] = (2, 2)) -> dict[str, np.ndarray]:
    """A tiny well-formed spectral material: 1 φi, 2 θi, 4 wavelengths, 2 × 2 grids."""
    f32 = np.float32
    return {
        "description": np.frombuffer(b"bomb", np.uint8),
        "jacobian": np.array([1], np.uint8),
        "theta_i": np.array([0.0, 0.5], f32),
        "phi_i": np.array([0.0], f32),
        "ndf": np.ones((2, 2), f32),
        "sigma": np.ones((2, 2), f32),
        "vndf": np.ones((1, 2) + vndf, f32),
        "luminance": np.ones((1, 2, 2, 2), f32),
        "wavelengths": np.array([400.0, 500.0, 600.0, 700.0], f32),
        "spectra": np.full((1, 2, 4, 2, 2), 0.5, f32),
    }


def _tensor_bytes(arrays: dict[str, np.ndarray],
                  extra: list[tuple[str, int, int, tuple[int, ...]]] = (),
                  size: int | None = None, packed: tuple[int, bytes] = (0, b"")) -> bytes:
    """``arrays`` laid out after the table as the reference writer does (8-byte aligned),
    then ``extra`` entries ``(name, code, offset, shape)`` pointing wherever they say and
    ``packed`` = (count, bytes) entries ready-made; the file is zero-padded to ``size``."""
    names = list(arrays) + [e[0] for e in extra]
    table_end = len(_HEADER) + 4 + sum(_entry_size(n, arrays[n].ndim) for n in arrays) \
        + sum(_entry_size(name, len(shape)) for name, _, _, shape in extra) + len(packed[1])
    offset = -(-table_end // 8) * 8
    entries, blobs = [], []
    for name, arr in arrays.items():
        entries.append(_entry(name, _CODES[arr.dtype], offset, arr.shape))
        blob = arr.astype(arr.dtype.newbyteorder("<")).tobytes()
        blobs.append(blob + b"\0" * (-len(blob) % 8))
        offset += len(blobs[-1])
    entries += [_entry(*e) for e in extra] + [packed[1]]
    head = _HEADER + struct.pack("<I", len(names) + packed[0]) + b"".join(entries)
    data = head + b"\0" * (-len(head) % 8) + b"".join(blobs)
    if size is not None:
        if len(data) > size:
            raise ValueError(f"{len(data)} bytes do not fit in {size}")
        data += b"\0" * (size - len(data))
    return data


def _rgl_overlapping(size: int, fields: int | None = None) -> Callable[[Path], Path]:
    """A valid material plus extra u8 fields, each declaring the whole file from offset 0:
    every field lies inside the file, so only their overlap (or their number) gives them
    away. As many as fit with short names, or ``fields`` of them with names padded to fill
    the file."""
    def make(directory: Path) -> Path:
        base = _material()
        used = len(_tensor_bytes(base))
        if fields is None:
            count, width = (size - used - 8) // _entry_size("x00000", 1), 5
        else:
            count = fields
            width = (size - used - 8) // count - _entry_size("x", 1)
        extra = [(f"x{i:0{width}d}", 1, 0, (size,)) for i in range(count)]
        path = directory / f"overlap_{size // KB}k_{count}.bsdf"
        path.write_bytes(_tensor_bytes(base, extra, size))
        return path

    return make


def _empty_entries(count: int) -> bytes:
    """``count`` table entries of empty f32 fields named by 5 hex digits, all at once."""
    entry = np.dtype([("name_len", "<u2"), ("name", "S5"), ("ndim", "<u2"), ("code", "u1"),
                      ("offset", "<u8"), ("shape", "<u8")])  # packed: 26 bytes
    table = np.zeros(count, entry)
    table["name_len"], table["ndim"], table["code"] = 5, 1, 10
    table["name"] = np.char.encode(np.char.mod("%05x", np.arange(count)), "ascii")
    return table.tobytes()


def _rgl_empty_fields(size: int) -> Callable[[Path], Path]:
    """A valid material plus one empty f32 field per 26 bytes: no data, yet each field
    costs the reader Python objects (name, shape, array) worth far more than 26 bytes."""
    def make(directory: Path) -> Path:
        base = _material()
        count = (size - len(_tensor_bytes(base)) - 8) // 26
        path = directory / f"empty_fields_{size // MB}m.bsdf"
        path.write_bytes(_tensor_bytes(base, size=size, packed=(count, _empty_entries(count))))
        return path

    return make


def _rgl_declared_past_end(directory: Path) -> Path:
    """``spectra`` declares 2⁴⁰ × 64 bytes in a file of a few hundred."""
    base = _material()
    spectra = base.pop("spectra")
    data = _tensor_bytes(base, [("spectra", 10, 64, (1 << 40,) + spectra.shape[1:])])
    path = directory / "declared_past_end.bsdf"
    path.write_bytes(data)
    return path


_VNDF_GRID = (2048, 2048)


def _rgl_big_vndf(directory: Path) -> Path:
    """A *valid* material whose vndf (2 slices of 2048², 32 MB) dwarfs the rest: the warp
    tables derived from it are what grows."""
    path = directory / "big_vndf.bsdf"
    path.write_bytes(_tensor_bytes(_material(_VNDF_GRID)))
    return path


def _rgl_big_description(directory: Path) -> Path:
    """A valid material with a 40 MB description: one 4-byte UTF-8 character, then bytes
    that are not UTF-8 (each decodes to U+FFFD, stored in 4 bytes after that character)."""
    base = _material()
    text = "\U0001F600".encode() + b"\xff" * (40 * MB)
    base["description"] = np.frombuffer(text, np.uint8)
    path = directory / "big_description.bsdf"
    path.write_bytes(_tensor_bytes(base))
    return path


def _rgl_big_theta(directory: Path) -> Path:
    """``theta_i`` of 8M entries (32 MB) that the axis checks used to copy to float64."""
    base = _material()
    base["theta_i"] = np.linspace(0.0, 1.5, 8 * MB, dtype=np.float32)
    path = directory / "big_theta.bsdf"
    path.write_bytes(_tensor_bytes(base))
    return path


# --------------------------------------------------------------------------- MERL .binary

_MERL_SETUP = "from spectral_materials.core.formats import merl"
_MERL_CALL = "merl.read_merl(PATH)"
_MERL_SAMPLES = 3 * 90 * 90 * 180


def _sparse(path: Path, head: bytes, size: int) -> Path:
    """``head`` then zeros up to ``size`` bytes, without writing them (a sparse file)."""
    with open(path, "wb") as handle:
        handle.write(head)
        handle.truncate(size)
    return path


def _merl_dims_beyond_body(directory: Path) -> Path:
    """The header declares 900 × 900 × 1800 cells (≈ 35 GB); 1 MB of body follows."""
    head = np.asarray((900, 900, 1800), "<i4").tobytes()
    return _sparse(directory / "dims_beyond_body.binary", head, 12 + MB)


def _merl_truncated(directory: Path) -> Path:
    """The right header, 8 MB of the 35 MB body."""
    head = np.asarray((90, 90, 180), "<i4").tobytes()
    return _sparse(directory / "truncated.binary", head, 12 + 8 * MB)


def _merl_trailing(directory: Path) -> Path:
    """The right header and body, then 4 GB more (sparse)."""
    head = np.asarray((90, 90, 180), "<i4").tobytes()
    return _sparse(directory / "trailing.binary", head, 12 + 8 * _MERL_SAMPLES + (4 << 30))


def _merl_valid(directory: Path) -> Path:
    """A full-size file of zeros: valid, the baseline of what reading one costs."""
    head = np.asarray((90, 90, 180), "<i4").tobytes()
    return _sparse(directory / "zeros.binary", head, 12 + 8 * _MERL_SAMPLES)


# --------------------------------------------------------------------------- spectrum CSV

# The second path is the layout before issue 17, for benchmarks.reader_memory --tree runs on
# older commits.
_CSV_SETUP = ("try:\n    from spectral_materials.core.colour import spectrum_library\n"
              "except ImportError:\n    from spectral_materials.core import spectrum_library")
_CSV_CALL = "spectrum_library.read_spectrum_csv(PATH)"
_CSV_LIMIT = 10 * MB  # spectrum_library.MAX_CSV_BYTES: the bombs sit just below it
_ROW = b"1,1\n"


def _csv_huge(directory: Path) -> Path:
    """1 GB (sparse, NUL bytes): refused by size before a byte is read."""
    return _sparse(directory / "huge.csv", b"400,1\n", 1 << 30)


def _csv_rows(directory: Path) -> Path:
    """2.6 million four-byte rows just under the size limit."""
    path = directory / "rows.csv"
    path.write_bytes(_ROW * ((_CSV_LIMIT - 16) // len(_ROW)))
    return path


def _csv_long_line(directory: Path) -> Path:
    """One line of 10 MB: a wavelength and a 10-million-digit value."""
    path = directory / "long_line.csv"
    path.write_bytes(b"400," + b"9" * (_CSV_LIMIT - 16))
    return path


def _csv_long_token(directory: Path) -> Path:
    """A value of 40,000 digits and a letter: a number pattern that can split a run of
    digits two ways backtracks quadratically before it says "not a number"."""
    path = directory / "long_token.csv"
    path.write_bytes(b"400,0.5\n500," + b"9" * 40_000 + b"x\n")
    return path


def _csv_many_fields(directory: Path) -> Path:
    """One line of 3.3 million short comma-separated fields."""
    path = directory / "many_fields.csv"
    path.write_bytes(b"400" + b",12" * ((_CSV_LIMIT - 16) // 3))
    return path


def _csv_utf16_rows(directory: Path) -> Path:
    """UTF-16 with a BOM (the add-on decodes it): 1.3 million rows in 10 MB."""
    path = directory / "rows_utf16.csv"
    rows = (_CSV_LIMIT - 16) // (2 * len(_ROW))
    path.write_bytes(("1,1\n" * rows).encode("utf-16"))
    return path


# --------------------------------------------------------------------------- registry


def _rgl(make: Callable[[Path], Path], decoded: int) -> Bomb:
    return Bomb(make, _RGL_SETUP, _RGL_CALL, decoded)


BOMBS: dict[str, Bomb] = {
    "rgl_overlap_120k": _rgl(_rgl_overlapping(120 * KB), 120 * KB),
    "rgl_overlap_250k": _rgl(_rgl_overlapping(250 * KB), 250 * KB),
    "rgl_overlap_512k_4000_fields": _rgl(_rgl_overlapping(512 * KB, 4000), 512 * KB),
    "rgl_empty_fields_16m": _rgl(_rgl_empty_fields(16 * MB), 16 * MB),
    "rgl_declared_past_end": _rgl(_rgl_declared_past_end, 1 * KB),
    "rgl_big_vndf": _rgl(_rgl_big_vndf, 2 * 4 * math.prod(_VNDF_GRID) + 1 * KB),
    "rgl_big_description": _rgl(_rgl_big_description, 40 * MB + 1 * KB),
    "rgl_big_theta": _rgl(_rgl_big_theta, 32 * MB + 1 * KB),
    "merl_dims_beyond_body": Bomb(_merl_dims_beyond_body, _MERL_SETUP, _MERL_CALL, MB),
    "merl_truncated": Bomb(_merl_truncated, _MERL_SETUP, _MERL_CALL, 8 * MB),
    "merl_trailing_4g": Bomb(_merl_trailing, _MERL_SETUP, _MERL_CALL, 8 * _MERL_SAMPLES),
    "merl_valid_zeros": Bomb(_merl_valid, _MERL_SETUP, _MERL_CALL, 8 * _MERL_SAMPLES),
    "csv_huge_1g": Bomb(_csv_huge, _CSV_SETUP, _CSV_CALL, 16),
    "csv_rows_10m": Bomb(_csv_rows, _CSV_SETUP, _CSV_CALL,
                         16 * ((_CSV_LIMIT - 16) // len(_ROW))),
    "csv_rows_utf16": Bomb(_csv_utf16_rows, _CSV_SETUP, _CSV_CALL,
                           16 * ((_CSV_LIMIT - 16) // (2 * len(_ROW)))),
    "csv_long_line": Bomb(_csv_long_line, _CSV_SETUP, _CSV_CALL, 16),
    "csv_many_fields": Bomb(_csv_many_fields, _CSV_SETUP, _CSV_CALL, 16),
    "csv_long_token": Bomb(_csv_long_token, _CSV_SETUP, _CSV_CALL, 32),
}


def file_size(path: Path) -> int:
    """Apparent size of a crafted file (sparse ones included)."""
    return os.stat(path).st_size
