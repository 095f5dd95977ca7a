"""What every reader and writer does with files: atomic writes and read-error translation."""

from __future__ import annotations

import contextlib
import os
import tempfile
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
