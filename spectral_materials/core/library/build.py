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
from .entry import factor_entry
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

    An entry whose input bytes and settings are unchanged is kept (its catalog follows
    how the sources are named). A file that fails (unreadable, corrupt, or killing its
    worker) is reported by name in the report and the index, and the others go on.
    ``scheduler`` (``tcp://host:port``) runs on that Dask cluster, else on ``workers``
    local processes. ``callback`` returning true cancels (:class:`Cancelled` is raised
    after the index is written). The folder is a consistent library at every moment,
    and one build at a time writes it (a lock file).
    """
    started = time.perf_counter()
    settings = settings or LibrarySettings()
    files = find_sources(sources)
    root = layout.open_library(out, create=True)
    executor = executor_for(scheduler, workers)
    result = BuildReport(root, executor.name)
    with layout.build_lock(root):
        layout.remove_partials(root)
        current = {row["id"]: (row.get("key"), row.get("catalog"))
                   for row in layout.read_entries(root)}
        try:
            jobs = _jobs_to_run(files, settings, current, result, callback)
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


def _jobs_to_run(files: list[SourceFile], settings: LibrarySettings, current: dict,
                 result: BuildReport, callback: ProgressCallback | None) -> list[Job]:
    """The files whose entry is missing or out of date, hashed; the rest are skipped."""
    jobs = []
    for count, source in enumerate(files):
        report(callback, 0.0, f"hashing {source.name} ({count + 1} of {len(files)})")
        try:
            digest = file_digest(source.path)
        except OSError as exc:             # vanished or unreadable since it was found
            _fail(result, source, exc)
            continue
        key = entry_key(digest, settings)
        known_key, known_catalog = current.get(entry_id(source), (None, None))
        if known_key != key:
            jobs.append(_job(source, digest, key, settings))
            continue
        if known_catalog != source.catalog:
            # The sources were named from another folder: the factors stand, the catalog
            # (and the path it shows) follow.
            layout.update_entry(result.library / layout.MATERIALS / entry_id(source),
                                catalog=source.catalog, source=str(source.path))
        result.skipped.append(str(source.path))
    return jobs


def _fail(result: BuildReport, source: SourceFile, error: BaseException) -> None:
    message = " ".join(str(error).split()) or type(error).__name__
    if source.name not in message:
        message = f"{type(error).__name__}: {message}"
    result.failed.append({"source": str(source.path), "error": message})


def _finish(root: Path, job: Job, payload: dict | None, error: BaseException | None,
            result: BuildReport) -> None:
    source, digest, key = job.data
    if error is not None:
        _fail(result, source, error)
        return
    try:
        file_bytes = source.path.stat().st_size
    except OSError as exc:
        _fail(result, source, exc)
        return
    row = {**payload["row"], "name": source.name, "catalog": source.catalog,
           "source": str(source.path), "format": READERS[source.path.suffix.lower()][0],
           "file_bytes": file_bytes, "input_sha256": digest, "key": key,
           "files": [layout.FACTORS_FILE, layout.THUMBNAIL_FILE]}
    if layout.write_entry(root, entry_id(source), payload["files"], row):
        result.written.append(entry_id(source))


def entry_id(source: SourceFile) -> str:
    """A source's entry folder: its name and a hash of its resolved path. However the
    sources are spelled on the command line, a file keeps its entry (replaced when its
    content, the settings or its catalog change); two files of one name are two entries."""
    where = str(source.path.resolve())
    return f"{slug(source.name)}-{hashlib.sha1(where.encode()).hexdigest()[:10]}"
