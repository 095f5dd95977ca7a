"""What every reader and writer does with files: atomic writes, read-error translation, and
zip members read with their declared sizes checked and inflated under a running cap."""

from __future__ import annotations

import contextlib
import io
import os
import struct
import tempfile
import zipfile
import zlib
from collections.abc import Callable, Iterator
from pathlib import Path

from ..errors import InvalidBRDFData


@contextlib.contextmanager
def atomic_path(path: str | Path, suffix: str = ".tmp") -> Iterator[Path]:
    """A temporary name beside ``path``, renamed to it when the block succeeds.

    A writer that fails half-way leaves neither a partial file nor a changed original.
    """
    path = Path(path)
    handle = tempfile.NamedTemporaryFile("wb", dir=path.parent if str(path.parent) else ".",
                                         prefix=f".{path.name}.", suffix=suffix, delete=False)
    handle.close()
    try:
        yield Path(handle.name)
        os.replace(handle.name, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(handle.name)
        raise


def atomic_write(path: str | Path, write: Callable, suffix: str = ".tmp") -> Path:
    """``write(binary_file)`` into a temporary file, then rename it to ``path``."""
    with atomic_path(path, suffix) as temporary, open(temporary, "wb") as handle:
        write(handle)
    return Path(path)


@contextlib.contextmanager
def read_errors(path: Path, invalid: type[Exception], what: str = "samples",
                error: type[ValueError] = InvalidBRDFData) -> Iterator[None]:
    """Turn a reader's internal ``invalid`` exceptions, memory and I/O errors into ``error``
    naming the file (permission errors pass through: the file is fine, access is not)."""
    try:
        yield
    except invalid as exc:
        raise error(f"{path}: {exc}") from None
    except MemoryError:
        raise error(f"{path}: not enough memory to load its {what}") from None
    except PermissionError:
        raise
    except OSError as exc:
        raise error(f"{path}: unreadable ({exc})") from None


# --------------------------------------------------------------------------- zip members

#: A compressed member may declare this many bytes whatever its compression ratio: the
#: ratio rule is for members big enough to matter, and small headers and tables of a few
#: values legitimately compress far better than data.
RATIO_FREE_BYTES = 1 << 20
#: Bytes inflated per step of :class:`ZipMemberReader`: what one call can add to memory.
_STEP = 1 << 16
_LOCAL_HEADER = struct.Struct("<IHHHHHIIIHH")
_LOCAL_SIGNATURE = 0x04034B50
_METHODS = {zipfile.ZIP_STORED: "stored", zipfile.ZIP_DEFLATED: "deflate",
            zipfile.ZIP_BZIP2: "bzip2", zipfile.ZIP_LZMA: "LZMA"}


def check_zip_member(path: Path, info: zipfile.ZipInfo, archive_size: int, *,
                     max_bytes: int, max_ratio: float,
                     error: type[ValueError] = InvalidBRDFData) -> None:
    """Refuse a member whose declared sizes the archive cannot back, before reading it.

    A stored member must declare as many bytes uncompressed as compressed; the compressed
    bytes must lie inside the archive (``archive_size`` bytes); a compressed member may not
    declare more than ``max_ratio`` times its compressed size (unless it declares at most
    :data:`RATIO_FREE_BYTES`), nor anyone more than ``max_bytes``.
    Raises ``error`` naming the file and the member.
    """
    where = f"{path}: member {info.filename!r}"
    if info.flag_bits & 0x1:
        raise error(f"{where} is encrypted")
    if info.compress_type not in _METHODS:
        raise error(f"{where} uses compression method {info.compress_type}; "
                    f"{', '.join(_METHODS.values())} expected")
    if info.compress_type == zipfile.ZIP_STORED and info.compress_size != info.file_size:
        raise error(f"{where} is stored but declares {info.file_size:,} bytes in "
                    f"{info.compress_size:,}")
    # The name's bytes are left out: the central directory's encoding may differ from
    # the local header's, and this is a bound, not the exact offset.
    end = info.header_offset + _LOCAL_HEADER.size + info.compress_size
    if end > archive_size:
        raise error(f"{where} declares {info.compress_size:,} bytes of data from offset "
                    f"{info.header_offset:,}, past the end of the {archive_size:,}-byte archive")
    if info.file_size > max_bytes:
        raise error(f"{where} declares {info.file_size:,} uncompressed bytes, over the "
                    f"{max_bytes:,}-byte limit")
    if info.compress_type != zipfile.ZIP_STORED and info.file_size > RATIO_FREE_BYTES \
            and info.file_size > max_ratio * info.compress_size:
        raise error(f"{where} declares {info.file_size:,} bytes from {info.compress_size:,} "
                    f"compressed ({info.file_size / max(info.compress_size, 1):,.0f}:1; at "
                    f"most {max_ratio:g}:1 is accepted)")


def _lzma_decompressor(header: bytes):
    """A raw LZMA1 decompressor from a zip LZMA member's 4-byte header and properties."""
    import lzma

    if len(header) < 9:
        raise zipfile.BadZipFile("LZMA properties missing")
    props = header[4:9]
    pb, rest = divmod(props[0], 45)
    lp, lc = divmod(rest, 9)
    dict_size = struct.unpack("<I", props[1:5])[0]
    return lzma.LZMADecompressor(lzma.FORMAT_RAW, filters=[{
        "id": lzma.FILTER_LZMA1, "dict_size": dict_size, "lc": lc, "lp": lp, "pb": pb}])


class ZipMemberReader(io.RawIOBase):
    """The uncompressed bytes of one zip member, inflated step by step under a running cap.

    The sizes come from the central directory (check them first with
    :func:`check_zip_member`); the member's data start after its local header. At most
    :data:`_STEP` bytes are inflated per step whatever the method, so a member cannot
    allocate more than it has produced; producing more than its declared size, ending
    early or failing its CRC raises ``error`` naming the file and the member. Seeking
    backwards starts the member again (as :class:`zipfile.ZipExtFile` does).
    """

    def __init__(self, path: Path, info: zipfile.ZipInfo,
                 error: type[ValueError] = InvalidBRDFData) -> None:
        super().__init__()
        self._path, self._info, self._error = Path(path), info, error
        self._file = open(path, "rb")
        try:
            self._start()
        except BaseException:
            self._file.close()
            raise

    def _fail(self, problem: str) -> ValueError:
        return self._error(f"{self._path}: member {self._info.filename!r} {problem}")

    def _start(self) -> None:
        info = self._info
        self._file.seek(info.header_offset)
        fixed = self._file.read(_LOCAL_HEADER.size)
        if len(fixed) != _LOCAL_HEADER.size or _LOCAL_HEADER.unpack(fixed)[0] != _LOCAL_SIGNATURE:
            raise self._fail("has no local header where the central directory says")
        name_length, extra_length = _LOCAL_HEADER.unpack(fixed)[-2:]
        self._file.seek(name_length + extra_length, io.SEEK_CUR)
        self._compressed_left = info.compress_size
        self._position = 0
        self._crc = 0
        self._inflate = None
        if info.compress_type == zipfile.ZIP_DEFLATED:
            self._inflate = zlib.decompressobj(-15)
        elif info.compress_type == zipfile.ZIP_BZIP2:
            import bz2

            self._inflate = bz2.BZ2Decompressor()
        elif info.compress_type == zipfile.ZIP_LZMA:
            self._inflate = _lzma_decompressor(self._take(9))

    def _take(self, n: int) -> bytes:
        """Up to ``n`` more compressed bytes of the member."""
        data = self._file.read(min(n, self._compressed_left))
        self._compressed_left -= len(data)
        if n and self._compressed_left and not data:
            raise self._fail("is truncated")
        return data

    def _produce(self, limit: int) -> bytes:
        """At most ``limit`` more uncompressed bytes (empty at the member's end)."""
        if self._inflate is None:
            return self._take(limit)
        inflate = self._inflate
        while not inflate.eof:
            if hasattr(inflate, "unconsumed_tail"):  # zlib keeps what it did not use
                data = inflate.decompress(inflate.unconsumed_tail or self._take(_STEP), limit)
                ended = inflate.eof or (not self._compressed_left and not inflate.unconsumed_tail)
            else:  # bz2/lzma buffer it themselves and say when they need more
                more = self._take(_STEP) if inflate.needs_input else b""
                data = inflate.decompress(more, limit)
                ended = inflate.eof or (not self._compressed_left and inflate.needs_input)
            if data or ended:
                return data
        return b""

    def readinto(self, buffer) -> int:
        view = memoryview(buffer).cast("B")
        want = min(len(view), _STEP)
        try:
            data = self._produce(want) if want else b""
        except self._error:
            raise
        except Exception as exc:  # zlib.error, OSError (bz2), LZMAError, EOFError...
            raise self._fail(f"is damaged ({type(exc).__name__}: {exc})") from None
        declared = self._info.file_size
        if self._position + len(data) > declared:
            raise self._fail(f"inflates past its declared {declared:,} bytes")
        if want and not data and self._position < declared:
            raise self._fail(f"ends after {self._position:,} of its declared {declared:,} bytes")
        view[: len(data)] = data
        self._position += len(data)
        self._crc = zlib.crc32(data, self._crc)
        if data and self._position == declared and self._crc != self._info.CRC:
            raise self._fail("is damaged (CRC mismatch)")
        return len(data)

    def readable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return True

    def tell(self) -> int:
        return self._position

    def seek(self, offset: int, whence: int = io.SEEK_SET) -> int:
        target = {io.SEEK_SET: 0, io.SEEK_CUR: self._position,
                  io.SEEK_END: self._info.file_size}[whence] + offset
        if target < 0:
            raise ValueError(f"negative seek position {target}")
        if target < self._position:
            self._start()
        while self._position < target:
            if not self.read(min(target - self._position, _STEP)):
                break
        return self._position

    def close(self) -> None:
        file = getattr(self, "_file", None)  # absent when opening the archive failed
        if file is not None:
            file.close()
        super().close()


def open_zip_member(path: Path, info: zipfile.ZipInfo, *, max_bytes: int, max_ratio: float,
                    error: type[ValueError] = InvalidBRDFData) -> io.BufferedReader:
    """A buffered, seekable stream of a member's bytes after :func:`check_zip_member`;
    decompression is streamed under a running cap (:class:`ZipMemberReader`)."""
    check_zip_member(path, info, os.path.getsize(path), max_bytes=max_bytes,
                     max_ratio=max_ratio, error=error)
    return io.BufferedReader(ZipMemberReader(path, info, error), buffer_size=_STEP)
