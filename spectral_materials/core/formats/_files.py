"""What every reader and writer does with files: atomic writes, read-error translation, and
zip members read with their declared sizes checked and inflated under a running cap."""

from __future__ import annotations

import contextlib
import io
import os
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
#: Bytes asked of a member per read: what one call can add to memory.
_STEP = 1 << 16
#: A local file header's fixed part: signature, then the name's and extra field's lengths.
#: Bytes of a local file header before the member's name and extra field.
_LOCAL_HEADER_SIZE = 30
#: The methods read. ``zipfile`` inflates these in bounded steps but a bzip2 or LZMA
#: member in one call as large as the member, so those are refused; NumPy's ``savez`` and
#: ``savez_compressed`` write only stored and deflate members, and so do UBO2003 archives.
_METHODS = {zipfile.ZIP_STORED: "stored", zipfile.ZIP_DEFLATED: "deflate"}
_UNBOUNDED_METHODS = {zipfile.ZIP_BZIP2: "bzip2", zipfile.ZIP_LZMA: "LZMA"}


def check_zip_member(path: Path, info: zipfile.ZipInfo, archive_size: int, *,
                     max_bytes: int, max_ratio: float,
                     error: type[ValueError] = InvalidBRDFData) -> None:
    """Refuse a member whose declared sizes the archive cannot back, before reading it.

    Only stored and deflate members are read (bzip2 and LZMA are refused); a stored member
    must declare as many bytes uncompressed as compressed; the compressed bytes must lie
    inside the archive (``archive_size`` bytes); a compressed member may not declare more
    than ``max_ratio`` times its compressed size (unless it declares at most
    :data:`RATIO_FREE_BYTES`), nor anyone more than ``max_bytes``.
    Raises ``error`` naming the file and the member.
    """
    where = f"{path}: member {info.filename!r}"
    if info.flag_bits & 0x1:
        raise error(f"{where} is encrypted")
    if info.compress_type in _UNBOUNDED_METHODS:
        raise error(f"{where} is compressed with {_UNBOUNDED_METHODS[info.compress_type]}; "
                    f"only stored or deflate members are read")
    if info.compress_type not in _METHODS:
        raise error(f"{where} uses compression method {info.compress_type}; "
                    f"{' or '.join(_METHODS.values())} expected")
    if info.compress_type == zipfile.ZIP_STORED and info.compress_size != info.file_size:
        raise error(f"{where} is stored but declares {info.file_size:,} bytes in "
                    f"{info.compress_size:,}")
    # The name's bytes are left out: the central directory's encoding may differ from
    # the local header's, and this is a bound, not the exact offset.
    end = info.header_offset + _LOCAL_HEADER_SIZE + info.compress_size
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


#: What ``zipfile`` raises for damaged member data (``EOFError``: the data end early).
_DAMAGE = (zipfile.BadZipFile, zlib.error, EOFError, OSError)


class _ZipMember(io.RawIOBase):
    """A member's bytes through :class:`zipfile.ZipExtFile` (what :meth:`zipfile.ZipFile.open`
    returns), :data:`_STEP` bytes a call, held to its declared size; damage is ``error``
    naming the file and the member.

    ``ZipExtFile`` inflates a stored or deflate member in steps of the size asked for,
    stops at the declared size and checks the CRC there; asking for little at a time keeps
    every call small (its own forward seeks read 16 MiB at once). The running count turns
    a member that ends early, which ``ZipExtFile`` reports as a plain end of data, into an
    error.
    """

    def __init__(self, archive: zipfile.ZipFile, info: zipfile.ZipInfo, path: Path,
                 error: type[ValueError]) -> None:
        super().__init__()
        self._path, self._info, self._error = Path(path), info, error
        self._position = 0
        try:
            self._member = archive.open(info)
        except _DAMAGE as exc:  # a bad local header, say
            raise self._damaged(exc) from None

    def _fail(self, problem: str) -> ValueError:
        return self._error(f"{self._path}: member {self._info.filename!r} {problem}")

    def _damaged(self, exc: BaseException) -> ValueError:
        return self._fail(f"is damaged ({type(exc).__name__}: {exc})")

    def readinto(self, buffer) -> int:
        view = memoryview(buffer).cast("B")
        want = min(len(view), _STEP)
        try:
            data = self._member.read(want) if want else b""
        except _DAMAGE as exc:
            raise self._damaged(exc) from None
        declared = self._info.file_size
        # ZipExtFile cuts the data at the declared size itself; the bound should not rest
        # on that alone.
        if self._position + len(data) > declared:
            raise self._fail(f"inflates past its declared {declared:,} bytes")
        if want and not data and self._position < declared:
            raise self._fail(f"ends after {self._position:,} of its declared {declared:,} bytes")
        view[: len(data)] = data
        self._position += len(data)
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
            try:  # ZipExtFile starts the member again: nothing is read yet
                self._member.seek(0)
            except _DAMAGE as exc:
                raise self._damaged(exc) from None
            self._position = 0
        while self._position < target:
            if not self.read(min(target - self._position, _STEP)):
                break
        return self._position

    def close(self) -> None:
        member = getattr(self, "_member", None)  # absent when the constructor failed
        if member is not None:
            member.close()
        super().close()


def open_zip_member(archive: zipfile.ZipFile, info: zipfile.ZipInfo, *, path: Path,
                    max_bytes: int, max_ratio: float,
                    error: type[ValueError] = InvalidBRDFData) -> io.BufferedReader:
    """A buffered, seekable stream of a member of the open ``archive`` (read from ``path``)
    after :func:`check_zip_member`, inflated at most :data:`_STEP` bytes a call and held to
    its declared size."""
    check_zip_member(path, info, os.path.getsize(path), max_bytes=max_bytes,
                     max_ratio=max_ratio, error=error)
    return io.BufferedReader(_ZipMember(archive, info, path, error), buffer_size=_STEP)
