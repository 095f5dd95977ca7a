"""The BRDF files under a library build's sources, and where each sits in the catalogs."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from ..formats.brdf_files import READERS
from .layout import INDEX_FILE


@dataclass(frozen=True)
class SourceFile:
    """One input: its path, its catalog (the source folder's name, then the folders
    below it) and a display name (the file's stem)."""

    path: Path
    catalog: str
    name: str


def find_sources(sources: list[str | Path]) -> list[SourceFile]:
    """Every file with a suffix of ``brdf_files.READERS`` under ``sources`` (files or
    folders, searched recursively), sorted, each once. FileNotFoundError names a source
    that does not exist; ValueError a file of an unknown type named directly."""
    found: dict[Path, SourceFile] = {}
    for source in sources:
        root = Path(source)
        if not root.exists():
            raise FileNotFoundError(f"{root}: no such file or folder")
        if root.is_file():
            if root.suffix.lower() not in READERS:
                raise ValueError(f"{root}: not a BRDF file ({', '.join(READERS)})")
            candidates, base = [root], root.parent
        else:
            # Libraries under a source (one built into a folder it reads) are not read
            # back, nor hidden files and folders.
            libraries = {index.parent for index in root.rglob(INDEX_FILE)}
            candidates = sorted(
                p for p in root.rglob("*")
                if p.is_file() and p.suffix.lower() in READERS
                and not any(part.startswith(".") for part in p.relative_to(root).parts)
                and not libraries.intersection(p.parents))
            base = root
        top = base.resolve().name or "sources"
        for path in candidates:
            parts = path.parent.relative_to(base).parts
            resolved = path.resolve()
            found.setdefault(resolved, SourceFile(resolved, "/".join((top, *parts)),
                                                  path.stem))
    return sorted(found.values(), key=lambda s: (s.catalog, s.name, str(s.path)))


def slug(text: str) -> str:
    """A file-system-safe lower-case name: letters, digits and single dashes."""
    out = re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-")
    return out[:48] or "material"
