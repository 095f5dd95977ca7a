"""Blender's asset catalog definition file (``blender_assets.cats.txt``) for a library.

Each catalog path gets a UUID derived from the path (uuid5), so the same library always
writes the same catalogs and a user's re-import keeps their assignments."""

from __future__ import annotations

import uuid
from pathlib import Path

from ...core.library.layout import atomic_write

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
    """Write or extend the folder's catalog file atomically. Catalogs already there (the
    user's own, or this library's, perhaps renamed in the Asset Browser) are kept as they
    are; only catalogs whose UUID is missing are added."""
    target = Path(folder) / CATALOG_FILE
    if not target.is_file():
        atomic_write(target, catalog_text(paths).encode("utf-8"))
        return target
    text = target.read_text(encoding="utf-8")
    known = {line.split(":", 1)[0].strip() for line in text.splitlines()
             if line.strip() and not line.lstrip().startswith(("#", "VERSION"))}
    added = [line for line in catalog_text(paths).splitlines()
             if ":" in line and not line.startswith("#") and line.split(":", 1)[0] not in known]
    if added:
        atomic_write(target, (text.rstrip("\n") + "\n" + "\n".join(added) + "\n")
                     .encode("utf-8"))
    return target


def asset_names(entries: list[dict]) -> list[str]:
    """Each entry's material name: its own, or, where entries share one, with the folders
    that tell them apart (and the file type where even those agree); Blender would
    otherwise number them .001, .002."""
    groups: dict[str, list[int]] = {}
    for k, entry in enumerate(entries):
        groups.setdefault(entry["name"], []).append(k)
    names = [entry["name"] for entry in entries]
    for name, members in groups.items():
        if len(members) == 1:
            continue
        paths = [entries[k]["catalog"].split("/") for k in members]
        head = 0
        while all(len(p) > head for p in paths) and len({p[head] for p in paths}) == 1:
            head += 1
        tail = 0
        while (all(len(p) - head > tail for p in paths)
               and len({p[len(p) - 1 - tail] for p in paths}) == 1):
            tail += 1
        for k, parts in zip(members, paths):
            where = "/".join(parts[head:len(parts) - tail]) or "/".join(parts)
            names[k] = f"{name} ({where})"
    seen: dict[str, int] = {}
    for name in names:
        seen[name] = seen.get(name, 0) + 1
    for k, entry in enumerate(entries):
        if seen[names[k]] > 1:
            names[k] = f"{names[k][:-1]}, {Path(entry['source']).suffix.lstrip('.')})" \
                if names[k].endswith(")") else f"{names[k]} ({Path(entry['source']).suffix})"
    return names
