"""Blender's asset catalog definition file (``blender_assets.cats.txt``) for a library.

Each catalog path gets a UUID derived from the path (uuid5), so the same library always
writes the same catalogs and a user's re-import keeps their assignments."""

from __future__ import annotations

import uuid
from pathlib import Path

CATALOG_FILE = "blender_assets.cats.txt"
_NAMESPACE = uuid.UUID("6f1d3c52-4f7e-4a0e-9a55-2b1c5d0e7a11")


def catalog_id(path: str) -> str:
    return str(uuid.uuid5(_NAMESPACE, path))


def catalog_paths(paths: set[str]) -> list[str]:
    """Every catalog path and its parents ("a/b" → "a", "a/b"), sorted."""
    out = set()
    for path in paths:
        parts = [p for p in path.split("/") if p]
        for depth in range(1, len(parts) + 1):
            out.add("/".join(parts[:depth]))
    return sorted(out)


def catalog_text(paths: set[str]) -> str:
    """The file's text (Blender's VERSION 1 format: ``UUID:path:simple name`` lines)."""
    lines = ["# This is an Asset Catalog Definition file for Blender.",
             "# Written by Spectral Materials from a spectral material library.", "",
             "VERSION 1", ""]
    for path in catalog_paths(paths):
        simple = path.replace("/", "-")
        lines.append(f"{catalog_id(path)}:{path}:{simple}")
    return "\n".join(lines) + "\n"


def write_catalogs(folder: Path, paths: set[str]) -> Path:
    target = Path(folder) / CATALOG_FILE
    target.write_text(catalog_text(paths), encoding="utf-8")
    return target
