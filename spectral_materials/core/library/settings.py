"""What a library entry is factored with, and the key that says whether it is current."""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass
from pathlib import Path

#: Bump when the entry's content changes meaning: every entry is then factored again.
ENTRY_VERSION = 1
_CHUNK = 1 << 20


@dataclass(frozen=True)
class LibrarySettings:
    """Factorisation settings of every entry (the CLI's options).

    ``theta_cells`` scales the parameterisation's default grid so that θ has that
    many cells; ``basis`` is the spectral basis size per material (None: wavelengths).
    """

    packs: int = 4
    theta_cells: int = 32
    basis: int | None = 8
    parameterization: str = "io"
    thumbnail_size: int = 96

    def __post_init__(self) -> None:
        if not 1 <= self.packs <= 64:
            raise ValueError(f"packs must be 1..64, got {self.packs}")
        if not 2 <= self.theta_cells <= 90:
            raise ValueError(f"theta cells must be 2..90, got {self.theta_cells}")
        if self.basis is not None and not 1 <= self.basis <= 81:
            raise ValueError(f"basis must be 1..81 or none, got {self.basis}")
        if not 16 <= self.thumbnail_size <= 1024:
            raise ValueError(f"thumbnail size must be 16..1024, got {self.thumbnail_size}")

    def as_dict(self) -> dict:
        return asdict(self)


def file_digest(path: str | Path) -> str:
    """SHA-256 of a file's bytes, read in chunks (memory stays flat for any size)."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        while chunk := handle.read(_CHUNK):
            digest.update(chunk)
    return digest.hexdigest()


def entry_key(digest: str, settings: LibrarySettings) -> str:
    """The key of an entry: its input's digest and the settings (and ENTRY_VERSION). An
    entry on disk with the same key is current and is not factored again."""
    text = json.dumps({"input": digest, "settings": settings.as_dict(),
                       "version": ENTRY_VERSION}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()
