"""The ``tensor_file`` container of RGL ``.bsdf`` files: its field table checked before any
data is read (magic, version, counts, dtypes, offsets inside the file, no overlaps, the byte
limit), the fields read straight into their arrays, and the writer."""

from __future__ import annotations

import math
import struct
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .._files import atomic_write, read_errors

MAGIC = b"tensor_file\x00"
VERSION = (1, 0)
#: dtype code → NumPy dtype (little-endian), as the reference's ``Tensor::Type``.
DTYPE_CODES: dict[int, np.dtype] = {
    1: np.dtype("u1"), 2: np.dtype("i1"), 3: np.dtype("<u2"), 4: np.dtype("<i2"),
    5: np.dtype("<u4"), 6: np.dtype("<i4"), 7: np.dtype("<u8"), 8: np.dtype("<i8"),
    9: np.dtype("<f2"), 10: np.dtype("<f4"), 11: np.dtype("<f8"),
}
_CODE_OF = {dt.newbyteorder("<").str: code for code, dt in DTYPE_CODES.items()}
_CODE_NAMES = {1: "u8", 2: "i8", 3: "u16", 4: "i16", 5: "u32", 6: "i32", 7: "u64",
               8: "i64", 9: "f16", 10: "f32", 11: "f64"}
#: Refuse tensor files whose fields add up to more than this many bytes.
MAX_TENSOR_BYTES = 4 << 30
#: Largest ``ndim`` accepted for one field.
MAX_NDIM = 32
#: Most fields accepted in one file. Material files have about ten; each field costs the
#: reader a few hundred bytes of Python objects whatever its size, so without a cap a file
#: of empty fields would cost ten times its size.
MAX_FIELDS = 4096


_HEADER = 12 + 2 + 4
_FIELD_MIN = 2 + 2 + 1 + 8  # an entry with an empty name and ndim = 0


class _Invalid(ValueError):
    """Internal: a parsing problem, re-raised as InvalidBRDFData with the path (a ValueError
    so that an :class:`RGLBSDF` built from bad arrays by hand says what is wrong too)."""


# --------------------------------------------------------------------------- container


def _parse_table(stream, size: int, max_bytes: int) -> list[tuple[str, int, int, tuple]]:
    """Field table → [(name, dtype code, offset, shape)], checked against ``size``."""
    head = stream.read(_HEADER)
    if len(head) != _HEADER:
        raise _Invalid("the header could not be read in full")
    if head[:12] != MAGIC:
        raise _Invalid(f"bad magic {head[:12]!r}, expected {MAGIC!r}: not a tensor_file")
    version = (head[12], head[13])
    if version != VERSION:
        raise _Invalid(f"unsupported tensor_file version {version[0]}.{version[1]} "
                       f"(this reader knows {VERSION[0]}.{VERSION[1]})")
    (n_fields,) = struct.unpack_from("<I", head, 14)
    if n_fields > MAX_FIELDS:
        raise _Invalid(f"{n_fields:,} fields declared; at most {MAX_FIELDS:,} are accepted "
                       "(a material file has about ten)")
    if n_fields * _FIELD_MIN > size - _HEADER:
        raise _Invalid(f"{n_fields:,} fields declared, but only {size - _HEADER:,} bytes follow "
                       "the header: truncated or damaged")
    fields: list[tuple[str, int, int, tuple]] = []
    names: set[str] = set()
    total = 0

    def take(n: int, what: str) -> bytes:
        pos = stream.tell()
        out = stream.read(n) if pos + n <= size else b""
        if len(out) != n:
            raise _Invalid(f"field table ends early (reading {what} at byte {pos:,} of "
                           f"{size:,}): truncated")
        return out

    for i in range(n_fields):
        (name_len,) = struct.unpack("<H", take(2, f"the name length of field {i}"))
        raw = take(name_len, f"the name of field {i}")
        try:
            name = raw.decode("utf-8")
        except UnicodeDecodeError:
            raise _Invalid(f"field {i} has a name that is not UTF-8: {raw[:40]!r}") from None
        ndim, code, offset = struct.unpack("<HBQ", take(11, f"the header of field {name!r}"))
        if code not in DTYPE_CODES:
            raise _Invalid(f"field {name!r} has unknown dtype code {code} (known: 1..11)")
        if ndim > MAX_NDIM:
            raise _Invalid(f"field {name!r} declares {ndim} dimensions (at most {MAX_NDIM})")
        shape = struct.unpack(f"<{ndim}Q", take(8 * ndim, f"the shape of field {name!r}"))
        if any(s > size for s in shape):  # also with a zero elsewhere: no such data
            raise _Invalid(f"field {name!r} declares shape {list(shape)}, a dimension larger "
                           f"than the {size:,}-byte file")
        if name in names:
            raise _Invalid(f"field {name!r} appears twice")
        names.add(name)
        nbytes = DTYPE_CODES[code].itemsize * math.prod(shape)
        # An empty field reads nothing: its offset does not matter (Mitsuba's writer
        # aligns it, which can put it just past the end).
        if nbytes and (offset > size or nbytes > size - offset):
            raise _Invalid(f"field {name!r} ({_CODE_NAMES[code]}{list(shape)}, {nbytes:,} bytes "
                           f"at offset {offset:,}) lies past the end of the {size:,}-byte file")
        total += nbytes
        if total > max_bytes:
            raise _Invalid(f"fields need {total:,} bytes, more than the limit of "
                           f"{max_bytes:,} (max_bytes)")
        fields.append((name, code, offset, tuple(int(s) for s in shape)))
    _check_layout(fields, stream.tell())
    return fields


def _check_layout(fields: list[tuple[str, int, int, tuple]], table_end: int) -> None:
    """No field's data may overlap the table or another field's data.

    The format lays fields out one after another; fields that share bytes would let a
    small file declare (and make the reader allocate) many times its size.
    """
    spans = sorted((offset, offset + DTYPE_CODES[code].itemsize * math.prod(shape), name)
                   for name, code, offset, shape in fields
                   if DTYPE_CODES[code].itemsize * math.prod(shape))
    previous_end, previous = table_end, "the field table"
    for begin, end, name in spans:
        if begin < previous_end:
            raise _Invalid(f"field {name!r} (bytes {begin:,}..{end:,}) overlaps {previous} "
                           f"(which ends at byte {previous_end:,}): fields must not share bytes")
        previous_end, previous = end, f"field {name!r}"


def _read_tensor(path: Path, max_bytes: int) -> dict[str, np.ndarray]:
    size = path.stat().st_size
    if size < _HEADER:
        raise _Invalid(f"{size} bytes: too short for the {_HEADER}-byte tensor_file header")
    with open(path, "rb") as stream:
        table = _parse_table(stream, size, max_bytes)
        out: dict[str, np.ndarray] = {}
        for name, code, offset, shape in table:
            dtype = DTYPE_CODES[code]
            count = math.prod(shape)
            # Straight into the array: no bytes object beside it.
            arr = np.empty(0, dtype) if count == 0 else _read_array(stream, offset, dtype, count)
            if arr.size != count:
                raise _Invalid(f"field {name!r} could not be read in full (file shrank?)")
            out[name] = arr.astype(dtype.newbyteorder("="), copy=False).reshape(shape)
    return out


def _read_array(stream, offset: int, dtype: np.dtype, count: int) -> np.ndarray:
    stream.seek(offset)
    return np.fromfile(stream, dtype=dtype, count=count)


def read_tensor_file(path, *, max_bytes: int = MAX_TENSOR_BYTES) -> dict[str, np.ndarray]:
    """Read every field of a ``tensor_file`` into ``{name: array}`` (native byte order).

    Raises :class:`InvalidBRDFData` naming the file for a wrong magic or version, more than
    :data:`MAX_FIELDS` fields, an unknown dtype code, a truncated field table, a field
    reaching past the end of the file, fields whose data overlap (each other or the table),
    or fields adding up to more than ``max_bytes`` (all checked before anything is read);
    OSError when the file cannot be opened. Memory: the fields' arrays, at most the file's
    size.
    """
    path = Path(path)
    if not path.is_file():
        if not path.exists():
            raise FileNotFoundError(f"{path}: no such file")
        raise IsADirectoryError(f"{path}: not a regular file")
    with read_errors(path, _Invalid, "fields"):
        return _read_tensor(path, int(max_bytes))


def write_tensor_file(path, fields: Mapping[str, np.ndarray], *,
                      version: tuple[int, int] = VERSION) -> Path:
    """Write ``fields`` (name → array of one of the 11 dtypes) as a ``tensor_file``.

    Data are written little-endian, each field 8-byte aligned, after the table. Written to
    a temporary name and renamed. ``version`` other than (1, 0) is for testing readers.
    """
    path = Path(path)
    arrays = []
    for name, value in fields.items():
        arr = np.asarray(value)
        if arr.dtype == np.bool_:
            arr = arr.astype(np.uint8)
        key = arr.dtype.newbyteorder("<").str
        if key not in _CODE_OF:
            raise ValueError(f"field {name!r}: dtype {arr.dtype} has no tensor_file code")
        arrays.append((name.encode("utf-8"), _CODE_OF[key],
                       np.require(arr.astype(arr.dtype.newbyteorder("<")), requirements="C")))
    table_bytes = _HEADER + sum(2 + len(n) + 11 + 8 * a.ndim for n, _, a in arrays)
    offset = (table_bytes + 7) // 8 * 8
    table = [MAGIC, bytes(version), struct.pack("<I", len(arrays))]
    blobs = []
    for name, code, arr in arrays:
        table.append(struct.pack("<H", len(name)) + name)
        table.append(struct.pack("<HBQ", arr.ndim, code, offset))
        table.append(struct.pack(f"<{arr.ndim}Q", *arr.shape))
        pad = (-arr.nbytes) % 8
        blobs.append(arr.tobytes() + b"\x00" * pad)
        offset += arr.nbytes + pad
    head = b"".join(table)
    head += b"\x00" * ((-len(head)) % 8)
    def write(handle) -> None:
        handle.write(head)
        for blob in blobs:
            handle.write(blob)

    return atomic_write(path, write)
