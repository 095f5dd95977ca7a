"""``build_library``: find, factor and write a library's entries, resumably (see ``__init__``)."""

from __future__ import annotations

import hashlib
import time
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import Cancelled
from ..formats.brdf_files import READERS
from ..progress import ProgressCallback, report
from . import layout
from .entry import FACTORS_FILE, THUMBNAIL_FILE, factor_entry
from .executors import Job, executor_for
from .settings import LibrarySettings, entry_key, file_digest
from .sources import SourceFile, find_sources, slug


@dataclass
class BuildReport:
    """What a build did: entries written, skipped as current, failed (source → error)."""

    library: Path
    executor: str
    written: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    failed: list[dict] = field(default_factory=list)
    seconds: float = 0.0
    cancelled: bool = False


def _job(source: SourceFile, digest: str, key: str, settings: LibrarySettings) -> Job:
    def load() -> tuple:
        return source.name, source.path.suffix, source.path.read_bytes(), settings.as_dict()
    return Job(label=str(source.path), load=load, data=(source, digest, key))


def build_library(sources: list[str | Path], out: str | Path,
                  settings: LibrarySettings | None = None, *, scheduler: str | None = None,
                  workers: int | None = None,
                  callback: ProgressCallback | None = None) -> BuildReport:
    """Factor every BRDF file under ``sources`` into the library folder ``out``.

    An entry whose input bytes and settings are unchanged is kept. A file that fails is
    reported by name in the report and the index, and the others go on. ``scheduler``
    (``tcp://host:port``) runs on that Dask cluster, else on ``workers`` local processes.
    ``callback`` returning true cancels (:class:`Cancelled` is raised after the index is
    written): the folder is a consistent library at every moment.
    """
    started = time.perf_counter()
    settings = settings or LibrarySettings()
    files = find_sources(sources)
    root = layout.open_library(out, create=True)
    layout.remove_partials(root)
    current = {row["id"]: row.get("key") for row in layout.read_entries(root)}
    executor = executor_for(scheduler, workers)
    result = BuildReport(root, executor.name)
    jobs = []
    report(callback, 0.0, f"hashing {len(files)} files")
    for source in files:
        digest = file_digest(source.path)
        key = entry_key(digest, settings)
        if current.get(entry_id(source)) == key:
            result.skipped.append(str(source.path))
        else:
            jobs.append(_job(source, digest, key, settings))
    try:
        if jobs:
            with executor:
                result.executor = executor.name
                report(callback, 0.0, f"factoring {len(jobs)} of {len(files)} on "
                                      f"{executor.name}")
                for count, (job, payload, error) in enumerate(
                        executor.run(factor_entry, jobs), start=1):
                    _finish(root, job, payload, error, result)
                    report(callback, count / len(jobs),
                           f"{count}/{len(jobs)} {job.data[0].name}"
                           + (" failed" if error else ""))
    except Cancelled:
        result.cancelled = True
        raise
    finally:
        layout.write_index(root, settings.as_dict(), result.failed)
        result.seconds = time.perf_counter() - started
    return result


def _finish(root: Path, job: Job, payload: dict | None, error: BaseException | None,
            result: BuildReport) -> None:
    source, digest, key = job.data
    if error is not None:
        message = " ".join(str(error).split()) or type(error).__name__
        if source.name not in message:
            message = f"{type(error).__name__}: {message}"
        result.failed.append({"source": str(source.path), "error": message})
        return
    row = {**payload["row"], "name": source.name, "catalog": source.catalog,
           "source": str(source.path), "format": READERS[source.path.suffix.lower()][0],
           "file_bytes": source.path.stat().st_size, "input_sha256": digest, "key": key,
           "files": [FACTORS_FILE, THUMBNAIL_FILE]}
    if layout.write_entry(root, entry_id(source), payload["files"], row):
        result.written.append(entry_id(source))


def entry_id(source: SourceFile) -> str:
    """A source's entry folder: its name, and a hash of where it sits in the catalogs (two
    files of the same name in different folders are two entries; a file whose content
    changes keeps its entry, which is replaced)."""
    where = f"{source.catalog}/{source.name}{source.path.suffix.lower()}"
    return f"{slug(source.name)}-{hashlib.sha1(where.encode()).hexdigest()[:10]}"
