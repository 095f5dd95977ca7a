"""OpenEXR images of named float channels, through the OpenEXR package.

Arrays are (height, width) per channel with row 0 at the **bottom** (the GPU's
and Blender's order); files store rows top first, so rows are flipped on the way
in and out. Channels are written as 32-bit float (half float would clip XYZ
above 65504 and round to 11 bits), ZIP-compressed. Extra header attributes are
strings.

Reading checks the file before any pixel is decoded
----------------------------------------------------
The headers are parsed here (:func:`read_layout`: parts, channels with their
pixel types and sampling, data windows, compression), and the bytes the pixels
take as stored (``UINT``/``FLOAT`` 4, ``HALF`` 2 per sample) are checked against
the file's size (:func:`check_decoded_size`):

* an uncompressed part cannot hold more pixel bytes than the file has;
* compressed parts may declare at most :data:`MAX_COMPRESSION_RATIO` times the
  file's size, unless they declare at most :data:`RATIO_FREE_BYTES` in all;
* at most :data:`MAX_PIXELS` pixels.

So decoding allocates in proportion to the file (OpenEXR's buffers plus the
float32 copies returned: at most about twice the decoded size). Every failure,
including OpenEXR's own errors, is an :class:`InvalidEXRFile` (a ``ValueError``)
naming the file. Paths are handed to OpenEXR as bytes, so any file name the
operating system accepts can be read.
"""

from __future__ import annotations

import math
import os
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

#: Refuse images larger than this many pixels before reading their channels.
MAX_PIXELS = 1 << 28
#: Refuse compressed pixels declaring more than this many times the file's size. Measured
#: on 41 real EXRs (Blender's studio lights and matcaps, colour-science's test images;
#: ZIP, ZIPS, DWAA, DWAB): 0.01–120:1, the highest being lossy DWAA matcaps with black
#: corners. ZIP reaches about 1000:1 on constant pixels, which is how a 1 MB file
#: declares a gigabyte.
MAX_COMPRESSION_RATIO = 256
#: Compressed pixels up to this many bytes (a 2048² RGBA float frame) are accepted
#: whatever their ratio: an almost empty render compresses far beyond any ratio rule.
RATIO_FREE_BYTES = 64 << 20

_MAGIC = b"\x76\x2f\x31\x01"
_MULTIPART = 0x1000
_DEEP = 0x800
_PIXEL_BYTES = {0: 4, 1: 2, 2: 4}  # UINT, HALF, FLOAT
_NO_COMPRESSION = 0
_MAX_NAME = 256


class InvalidEXRFile(ValueError):
    """An OpenEXR file is unusable; the message names the file and the problem."""


class EXRFileNotFound(InvalidEXRFile, FileNotFoundError):
    """The file does not exist (both a ValueError and a FileNotFoundError)."""


@dataclass(frozen=True)
class EXRPart:
    """What one part's header declares about its pixels."""

    channels: tuple[tuple[str, int, int, int], ...]  # name, pixel type, x and y sampling
    width: int
    height: int
    compression: int
    storage: str

    @property
    def stored_bytes(self) -> int:
        """Bytes of the pixels as stored (before compression)."""
        return sum(math.ceil(self.width / xs) * math.ceil(self.height / ys) * _PIXEL_BYTES[t]
                   for _, t, xs, ys in self.channels)


class _Header:
    """Bounds-checked reads of a header from an open file of known size."""

    def __init__(self, stream, size: int) -> None:
        self.stream, self.size = stream, size

    def take(self, n: int, what: str) -> bytes:
        if n < 0 or self.stream.tell() + n > self.size:
            raise ValueError(f"truncated header ({what})")
        return self.stream.read(n)

    def skip(self, n: int, what: str) -> None:
        if n < 0 or self.stream.tell() + n > self.size:
            raise ValueError(f"truncated header ({what})")
        self.stream.seek(n, os.SEEK_CUR)

    def text(self, what: str) -> str:
        raw = bytearray()
        while (byte := self.take(1, what)) != b"\0":
            raw += byte
            if len(raw) > _MAX_NAME:
                raise ValueError(f"{what} longer than {_MAX_NAME} bytes")
        return raw.decode("utf-8", errors="replace")


def _channels(data: bytes) -> tuple[tuple[str, int, int, int], ...]:
    """The entries of a ``chlist`` attribute."""
    out, at = [], 0
    while at < len(data) and data[at] != 0:
        end = data.index(b"\0", at)
        name = data[at:end].decode("utf-8", errors="replace")
        if end + 17 > len(data):
            raise ValueError("truncated channel list")
        kind, _, xs, ys = struct.unpack_from("<iB3xii", data, end + 1)
        if kind not in _PIXEL_BYTES or xs < 1 or ys < 1:
            raise ValueError(f"channel {name!r} has pixel type {kind} and sampling {xs}×{ys}")
        out.append((name, kind, xs, ys))
        at = end + 17
    return tuple(out)


def _part(header: _Header) -> EXRPart | None:
    """One header's pixel description; None at the empty header ending a multi-part list."""
    fields: dict[str, bytes] = {}
    wanted = {"channels", "dataWindow", "compression", "type"}
    while name := header.text("attribute name"):
        header.text("attribute type")
        size = struct.unpack("<i", header.take(4, "attribute size"))[0]
        if name in wanted:
            fields[name] = header.take(size, name)
        else:
            header.skip(size, name)
    if not fields:
        return None
    missing = {"channels", "dataWindow"} - fields.keys()
    if missing:
        raise ValueError(f"header without {', '.join(sorted(missing))}")
    x0, y0, x1, y1 = struct.unpack("<iiii", fields["dataWindow"])
    if x1 < x0 or y1 < y0:
        raise ValueError(f"empty dataWindow ({x0}, {y0})–({x1}, {y1})")
    compression = fields.get("compression", b"\0")[:1] or b"\0"
    storage = fields.get("type", b"scanlineimage").split(b"\0")[0].decode("ascii", "replace")
    return EXRPart(_channels(fields["channels"]), x1 - x0 + 1, y1 - y0 + 1, compression[0],
                   storage)


def read_layout(path: str | Path, error: type[ValueError] = InvalidEXRFile) -> list[EXRPart]:
    """The parts an EXR file's headers declare, read without OpenEXR or any pixel.

    Raises ``error`` naming the file for anything but a single- or multi-part image of
    flat (not deep) parts with well-formed headers.
    """
    path = Path(path)
    size = path.stat().st_size
    with open(path, "rb") as stream:
        if stream.read(4) != _MAGIC:
            raise error(f"{path}: not an OpenEXR file (bad magic number)")
        if size < 8:
            raise error(f"{path}: damaged or truncated OpenEXR header ({size} bytes)")
        flags = struct.unpack("<I", stream.read(4))[0]
        if flags & _DEEP:
            raise error(f"{path}: deep images are not read")
        header = _Header(stream, size)
        parts: list[EXRPart] = []
        try:
            while (part := _part(header)) is not None:
                parts.append(part)
                if not flags & _MULTIPART:
                    break
        except (ValueError, struct.error) as exc:
            raise error(f"{path}: damaged or truncated OpenEXR header ({exc})") from None
    if not parts:
        raise error(f"{path}: no image part in the header")
    deep = [p.storage for p in parts if p.storage.startswith("deep")]
    if deep:
        raise error(f"{path}: {deep[0]} parts are not read")
    return parts


def check_decoded_size(path: str | Path, parts: list[EXRPart], *, max_pixels: int = MAX_PIXELS,
                       error: type[ValueError] = InvalidEXRFile) -> None:
    """Refuse pixels the file's bytes cannot hold (see the module docstring)."""
    path = Path(path)
    size = path.stat().st_size
    pixels = sum(p.width * p.height for p in parts)
    if pixels > max_pixels:
        shown = " + ".join(f"{p.width}×{p.height}" for p in parts[:4])
        raise error(f"{path}: image of {shown} pixels, over the {max_pixels:,}-pixel limit "
                    "of this reader")
    raw = sum(p.stored_bytes for p in parts if p.compression == _NO_COMPRESSION)
    if raw > size:
        raise error(f"{path}: its uncompressed pixels need {raw:,} bytes; the file has "
                    f"{size:,} (truncated or a forged dataWindow)")
    packed = sum(p.stored_bytes for p in parts if p.compression != _NO_COMPRESSION)
    if packed > RATIO_FREE_BYTES and packed > MAX_COMPRESSION_RATIO * size:
        raise error(f"{path}: declares {packed:,} bytes of compressed pixels in a "
                    f"{size:,}-byte file ({packed / size:,.0f}:1; at most "
                    f"{MAX_COMPRESSION_RATIO}:1 is accepted)")


def open_exr(path: Path, **options):
    """``OpenEXR.File`` of ``path`` given as bytes: any name the OS accepts, UTF-8 or not
    (as ``str``, a name with undecodable bytes cannot cross into the library)."""
    import OpenEXR

    return OpenEXR.File(os.fsencode(path), **options)


def write_exr(path: str | Path, channels: dict[str, np.ndarray],
              attributes: dict[str, str] | None = None) -> Path:
    """Write ``channels`` (name → (H, W) array) as a float32 scanline EXR."""
    import OpenEXR

    path = Path(path)
    if not channels:
        raise ValueError(f"{path}: no channels to write")
    shapes = {np.shape(a) for a in channels.values()}
    if len(shapes) != 1 or len(next(iter(shapes))) != 2:
        raise ValueError(f"{path}: channels must share one (height, width) shape, got {shapes}")
    data = {name: np.ascontiguousarray(np.asarray(a, dtype=np.float32)[::-1])
            for name, a in channels.items()}
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    for key, value in (attributes or {}).items():
        header[key] = str(value)
    with OpenEXR.File(header, data) as handle:
        handle.write(os.fsencode(path))
    return path


def _decode(path: Path) -> tuple[dict[str, np.ndarray], dict]:
    check_decoded_size(path, read_layout(path))
    with open_exr(path, separate_channels=True) as handle:
        header = dict(handle.header())
        channels = {name: np.asarray(c.pixels, dtype=np.float32)[::-1].copy()
                    for name, c in handle.channels().items()}
    return channels, header


def read_exr(path: str | Path) -> tuple[dict[str, np.ndarray], dict]:
    """(channels name → (H, W) float32 with row 0 at the bottom, header) of an EXR file.

    Multi-part files give their first part. Raises :class:`EXRFileNotFound` for a missing
    file and :class:`InvalidEXRFile` (a ``ValueError``) naming the file for anything
    else: sizes the file cannot hold (see the module docstring), damage, not enough memory.
    """
    path = Path(path)
    if not path.exists():
        raise EXRFileNotFound(f"{path}: no such file")
    if not path.is_file():
        raise InvalidEXRFile(f"{path}: not a regular file")
    try:
        return _decode(path)
    except InvalidEXRFile:
        raise
    except MemoryError:
        raise InvalidEXRFile(f"{path}: not enough memory to read its pixels") from None
    except PermissionError:
        raise
    except Exception as exc:  # OpenEXR's RuntimeError, ValueError, UnicodeDecodeError...
        raise InvalidEXRFile(f"{path}: not a readable OpenEXR file ({type(exc).__name__}: "
                             f"{exc})") from None
