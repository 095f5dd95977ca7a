"""A library folder on disk, and the atomic writes that keep it consistent.

::

    LIB/library.json              the index: format, settings, entries, last build's failures
    LIB/index.md                  the same as a Markdown table
    LIB/materials/<id>/           one entry: factors.npz, thumbnail.png, entry.json

An entry is written into ``materials/.partial-<id>-<random>`` (each file flushed to disk)
and renamed into place, so ``materials/<id>`` is always complete; the index files are
replaced by rename, and a new library's index is written before anything else. A build
that dies leaves at most a ``.partial-`` folder, which the next build removes. The index
is made from the entries on disk, so it never names one that is not there. One build at
a time holds ``.build.lock`` (:func:`build_lock`).
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
from pathlib import Path

from ..errors import InvalidBRDFData

FORMAT = "spectral_materials.library"
FORMAT_VERSION = 1
INDEX_FILE = "library.json"
MARKDOWN_FILE = "index.md"
MATERIALS = "materials"
ENTRY_FILE = "entry.json"
#: An entry's factor file and thumbnail (with ENTRY_FILE, its folder's files).
FACTORS_FILE = "factors.npz"
THUMBNAIL_FILE = "thumbnail.png"
LOCK_FILE = ".build.lock"
_PARTIAL = ".partial-"
_STALE = ".stale-"


class NotALibrary(InvalidBRDFData):
    """A folder given as a library that is not one (the message names it)."""


class LibraryBusy(OSError):
    """Another build holds the library's lock (the message names its process)."""


def atomic_write(path: Path, data: bytes) -> None:
    """Write ``data`` to a temporary file beside ``path`` and rename it over ``path``."""
    path = Path(path)
    handle, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(handle, "wb") as out:
            out.write(data)
            out.flush()
            os.fsync(out.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def open_library(root: str | Path, *, create: bool) -> Path:
    """The library folder ``root``. With ``create``, a missing or empty folder becomes an
    empty library at once (its index written before anything else), and so does one
    holding only what a first build stopped before its index left (``materials/``, dot
    files). NotALibrary when it holds other things, or (reading) has no readable index."""
    root = Path(root)
    index = root / INDEX_FILE
    if index.is_file():
        try:
            document = json.loads(index.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise NotALibrary(f"{root}: {INDEX_FILE} is not readable JSON ({exc})") from None
        if not isinstance(document, dict) or document.get("format") != FORMAT:
            raise NotALibrary(f"{root}: {INDEX_FILE} is not a spectral material library's")
        if int(document.get("version", 0)) > FORMAT_VERSION:
            raise NotALibrary(f"{root}: library version {document.get('version')} is newer "
                              "than this add-on reads; update Spectral Materials")
        return root
    if not create:
        raise NotALibrary(f"{root}: not a spectral material library (no {INDEX_FILE}); "
                          "build one with: python -m spectral_materials library build")
    if root.exists() and (not root.is_dir() or any(
            p.name != MATERIALS and not p.name.startswith(".") for p in root.iterdir())):
        raise NotALibrary(f"{root}: not a spectral material library (no {INDEX_FILE}) and "
                          "not empty; give a new or empty folder")
    (root / MATERIALS).mkdir(parents=True, exist_ok=True)
    write_index(root, {}, [])
    return root


@contextlib.contextmanager
def build_lock(root: Path):
    """One build at a time: ``.build.lock`` holds the building process's pid. A lock whose
    process is gone (killed) is taken over; a live one is refused, naming its pid."""
    lock = root / LOCK_FILE
    for _ in range(2):
        try:
            handle = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
        except FileExistsError:
            try:
                pid = int(lock.read_text().strip() or 0)
            except (OSError, ValueError):
                pid = 0
            if pid and _alive(pid):
                raise LibraryBusy(f"{root}: another build (process {pid}) is writing this "
                                  "library; wait for it, or remove "
                                  f"{LOCK_FILE} if that process is gone") from None
            lock.unlink(missing_ok=True)
            continue
        with os.fdopen(handle, "w") as out:
            out.write(str(os.getpid()))
        break
    else:
        raise LibraryBusy(f"{root}: could not take {LOCK_FILE}")
    try:
        yield
    finally:
        lock.unlink(missing_ok=True)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def remove_partials(root: Path) -> int:
    """Delete what a build that died left behind; returns how many folders."""
    count = 0
    for path in (root / MATERIALS).glob(".*"):
        if path.is_dir() and path.name.startswith((_PARTIAL, _STALE)):
            shutil.rmtree(path, ignore_errors=True)
            count += 1
    return count


def write_entry(root: Path, entry_id: str, files: dict[str, bytes], row: dict) -> bool:
    """Put an entry in place atomically; False when an entry with the same key is already
    there (a task that ran twice), which is left as it is."""
    materials = root / MATERIALS
    target = materials / entry_id
    current = read_entry(target)
    if current is not None and current.get("key") == row.get("key"):
        return False
    partial = Path(tempfile.mkdtemp(prefix=f"{_PARTIAL}{entry_id}-", dir=materials))
    try:
        # Flushed to disk before the rename: after a power loss an entry is whole or absent.
        for name, data in {**files, ENTRY_FILE: _row_bytes(row)}.items():
            with open(partial / name, "wb") as out:
                out.write(data)
                out.flush()
                os.fsync(out.fileno())
        if target.exists():
            # An out-of-date entry: moved aside, then replaced. In between the entry is
            # missing, never half written.
            stale = materials / f"{_STALE}{entry_id}-{os.getpid()}"
            os.replace(target, stale)
            os.replace(partial, target)
            shutil.rmtree(stale, ignore_errors=True)
        else:
            os.replace(partial, target)
    except BaseException:
        shutil.rmtree(partial, ignore_errors=True)
        raise
    return True


def update_entry(folder: Path, **fields) -> None:
    """Rewrite fields of an entry's row (not its files), atomically."""
    row = json.loads((folder / ENTRY_FILE).read_text(encoding="utf-8"))
    row.update(fields)
    atomic_write(folder / ENTRY_FILE, _row_bytes(row))


def _row_bytes(row: dict) -> bytes:
    return json.dumps(row, indent=1, sort_keys=True).encode("utf-8")


def read_entry(folder: Path) -> dict | None:
    """An entry's row, or None when the folder is not a complete entry."""
    try:
        row = json.loads((folder / ENTRY_FILE).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(row, dict) or not all((folder / name).is_file()
                                            for name in row.get("files", [])):
        return None
    return {**row, "id": folder.name}


def read_entries(root: Path) -> list[dict]:
    """Every complete entry's row, sorted by catalog and name."""
    rows = []
    materials = root / MATERIALS
    if materials.is_dir():
        for folder in sorted(materials.iterdir()):
            if folder.is_dir() and not folder.name.startswith("."):
                row = read_entry(folder)
                if row is not None:
                    rows.append(row)
    return sorted(rows, key=lambda r: (r.get("catalog", ""), r.get("name", ""), r["id"]))


def write_index(root: Path, settings: dict, failed: list[dict]) -> dict:
    """library.json and index.md from the entries on disk; returns the index."""
    entries = read_entries(root)
    document = {"format": FORMAT, "version": FORMAT_VERSION, "settings": settings,
                "entries": entries, "failed": failed}
    atomic_write(root / INDEX_FILE, json.dumps(document, indent=1).encode("utf-8"))
    atomic_write(root / MARKDOWN_FILE, "\n".join(markdown(document)).encode("utf-8"))
    return document


def markdown(document: dict) -> list[str]:
    """The index as a Markdown table (and the last build's failures)."""
    lines = ["# Spectral material library", "",
             f"{len(document['entries'])} materials. ΔE94 (D65, the protocol's random "
             "pairs) against each file's own data.", "",
             "| material | catalog | source | packs | ΔE94 mean | p95 | max | bytes | file "
             "bytes | seconds | thumbnail (D65, FL2) |", "|---" * 11 + "|"]
    for e in document["entries"]:
        de = e["de94"]
        lines.append(f"| {e['name']} | {e['catalog']} | {e['format']} | {e['packs']} | "
                     f"{de['mean']:.3f} | {de['p95']:.3f} | {de['max']:.2f} | {e['bytes']:,} "
                     f"| {e['file_bytes']:,} | {e['seconds']:.1f} | "
                     f"![{e['name']}]({MATERIALS}/{e['id']}/{THUMBNAIL_FILE}) |")
    if document["failed"]:
        lines += ["", "## Not in the library (last build)", ""]
        lines += [f"- `{f['source']}`: {f['error']}" for f in document["failed"]]
    return lines + [""]
