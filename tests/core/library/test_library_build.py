"""Library builds (core/library): a generated library of 10 materials (8 project tables, a
MERL file, an RGL file) on the local process pool; resuming, failures, cancellation and a
folder that is not a library. The Dask cluster and its dead worker are in
test_library_dask.py.

References: each entry's ΔE94 row is checked by measuring the stored factors again
against the source file read directly (not through the library); the thumbnail by
drawing the protocol sphere from the stored factors.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
from library_sources import make_sources, write_merl_file

from spectral_materials.core.brdf import metrics
from spectral_materials.core.brdf.factored import FactoredBRDF
from spectral_materials.core.errors import Cancelled
from spectral_materials.core.formats import merl
from spectral_materials.core.formats.brdf_files import read_brdf_file
from spectral_materials.core.library import layout
from spectral_materials.core.library.build import build_library
from spectral_materials.core.library.executors import Job, LocalPool
from spectral_materials.core.library.settings import LibrarySettings
from spectral_materials.core.library.thumbnail import thumbnail_rgb

SETTINGS = LibrarySettings(packs=1, theta_cells=8, basis=4, thumbnail_size=24)


@pytest.fixture(scope="session")
def merl_file(tmp_path_factory) -> Path:
    return write_merl_file(tmp_path_factory.mktemp("merl") / "red.binary")


@pytest.fixture
def sources(tmp_path, merl_file) -> Path:
    make_sources(tmp_path / "src", merl_file)
    return tmp_path / "src"


@pytest.fixture(scope="module")
def built(tmp_path_factory, merl_file):
    root = tmp_path_factory.mktemp("built")
    make_sources(root / "src", merl_file)
    result = build_library([root / "src"], root / "lib", SETTINGS, workers=2)
    return root, result


def _entry_folders(lib: Path) -> list[Path]:
    return sorted(p for p in (lib / layout.MATERIALS).iterdir())


def test_every_file_becomes_one_complete_entry(built):
    root, result = built
    lib = root / "lib"
    assert len(result.written) == 10 and not result.failed and not result.skipped
    folders = _entry_folders(lib)
    assert len(folders) == 10 and not any(p.name.startswith(".") for p in folders)
    index = json.loads((lib / layout.INDEX_FILE).read_text())
    assert index["format"] == layout.FORMAT and len(index["entries"]) == 10
    assert {e["catalog"] for e in index["entries"]} == {"src/studio/paints", "src/merl",
                                                        "src/rgl"}
    markdown = (lib / layout.MARKDOWN_FILE).read_text()
    assert markdown.count("thumbnail.png") == 10 and "red plastic" in markdown


def test_report_rows_measure_the_stored_factors_against_the_file(built):
    root, _ = built
    index = json.loads((root / "lib" / layout.INDEX_FILE).read_text())
    for entry in index["entries"]:
        if not entry["source"].endswith((".binary", ".bsdf", "red clay.npz")):
            continue
        folder = root / "lib" / layout.MATERIALS / entry["id"]
        model = FactoredBRDF.load(folder / "factors.npz")
        stats = metrics.ProtocolError(read_brdf_file(entry["source"])).stats(model)
        for key in ("mean", "p95", "max"):
            assert entry["de94"][key] == pytest.approx(stats[key], rel=1e-9)
        assert entry["packs"] == model.packs == 1 and entry["bytes"] > 0
        assert entry["file_bytes"] == os.path.getsize(entry["source"])
        # A MERL entry is drawn in the file's cells, as its readers look it up.
        assert model.cells == (merl.MERL_SHAPE if entry["source"].endswith(".binary")
                               else None)


def test_thumbnails_are_the_stored_spheres(built):
    from PIL import Image

    root, _ = built
    folder = _entry_folders(root / "lib")[0]
    with Image.open(folder / "thumbnail.png") as image:
        pixels = np.asarray(image)
    assert pixels.shape == (24, 48, 3)
    expected = thumbnail_rgb(FactoredBRDF.load(folder / "factors.npz"), 24)
    assert np.array_equal(pixels, expected)
    # D65 and FL2 differ for a coloured material (the two halves are not copies).
    assert np.abs(pixels[:, :24].astype(int) - pixels[:, 24:].astype(int)).max() > 0


def test_a_second_build_factors_nothing_and_a_changed_file_once(sources, tmp_path):
    lib = tmp_path / "lib"
    first = build_library([sources], lib, SETTINGS, workers=1)
    stamps = {p.name: p.stat().st_mtime_ns for p in _entry_folders(lib)}
    again = build_library([sources], lib, SETTINGS, workers=1)
    assert again.written == [] and len(again.skipped) == 10
    assert {p.name: p.stat().st_mtime_ns for p in _entry_folders(lib)} == stamps
    changed = sources / "studio" / "paints" / "red clay.npz"
    changed.write_bytes((sources / "studio" / "paints" / "blue felt.npz").read_bytes())
    third = build_library([sources], lib, SETTINGS, workers=1)
    assert len(third.written) == 1 and len(third.skipped) == 9
    # new settings make every entry out of date
    fourth = build_library([sources], lib, LibrarySettings(packs=2, theta_cells=8, basis=4,
                                                           thumbnail_size=24), workers=1)
    assert len(fourth.written) == 10
    assert len(_entry_folders(lib)) == len(first.written)       # replaced, not added
    index = json.loads((lib / layout.INDEX_FILE).read_text())
    assert len({e["id"] for e in index["entries"]}) == len(index["entries"])


def test_bad_files_are_named_and_skipped(sources, tmp_path):
    bad = sources / "bad"
    bad.mkdir()
    (bad / "truncated.binary").write_bytes((sources / "merl" / "red plastic.binary")
                                           .read_bytes()[:5000])
    (bad / "garbage.npz").write_bytes(b"PK\x03\x04 not a zip at all")
    (bad / "bomb.bsdf").write_bytes(b"tensor_file\x00\x01\x00" + (10**9).to_bytes(4, "little"))
    (bad / "notes.txt").write_text("ignored: not a BRDF file")
    result = build_library([sources], tmp_path / "lib", SETTINGS, workers=2)
    assert len(result.written) == 10
    failed = {Path(f["source"]).name: f["error"] for f in result.failed}
    assert set(failed) == {"truncated.binary", "garbage.npz", "bomb.bsdf"}
    for name, error in failed.items():
        assert Path(name).stem in error, error
    index = json.loads((tmp_path / "lib" / layout.INDEX_FILE).read_text())
    assert len(index["failed"]) == 3 and len(index["entries"]) == 10
    assert "truncated.binary" in (tmp_path / "lib" / layout.MARKDOWN_FILE).read_text()


def test_cancelling_leaves_a_consistent_library_that_resumes(sources, tmp_path):
    lib = tmp_path / "lib"
    seen = []

    def stop_after_three(fraction, message):
        seen.append(message)
        return sum(m[:1].isdigit() for m in seen) >= 3

    with pytest.raises(Cancelled):
        build_library([sources], lib, SETTINGS, workers=1, callback=stop_after_three)
    index = json.loads((lib / layout.INDEX_FILE).read_text())
    assert len(index["entries"]) == 3
    assert len(_entry_folders(lib)) == 3
    rest = build_library([sources], lib, SETTINGS, workers=1)
    assert len(rest.skipped) == 3 and len(rest.written) == 7


def test_a_folder_that_is_not_a_library_is_refused_and_untouched(sources, tmp_path):
    other = tmp_path / "photos"
    other.mkdir()
    (other / "holiday.jpg").write_bytes(b"\xff\xd8")
    with pytest.raises(layout.NotALibrary, match="photos"):
        build_library([sources], other, SETTINGS, workers=1)
    assert sorted(p.name for p in other.iterdir()) == ["holiday.jpg"]
    broken = tmp_path / "broken"
    broken.mkdir()
    (broken / layout.INDEX_FILE).write_text("{not json")
    with pytest.raises(layout.NotALibrary, match="broken"):
        build_library([sources], broken, SETTINGS, workers=1)
    with pytest.raises(FileNotFoundError, match="nowhere"):
        build_library([tmp_path / "nowhere"], tmp_path / "lib", SETTINGS, workers=1)


def test_a_partial_entry_from_a_dead_build_is_removed(sources, tmp_path):
    lib = tmp_path / "lib"
    build_library([sources / "rgl"], lib, SETTINGS, workers=1)
    partial = lib / layout.MATERIALS / ".partial-fabric-123"
    partial.mkdir()
    (partial / "factors.npz").write_bytes(b"half")
    result = build_library([sources / "rgl"], lib, SETTINGS, workers=1)
    assert result.skipped and not partial.exists()


def _die_once(marker: str, value: int) -> int:
    """Kills its worker process the first time it runs for value 2 (a marker file says)."""
    if value == 2 and not os.path.exists(marker):
        Path(marker).write_text("died")
        os._exit(1)
    return value * 10


def test_a_local_worker_that_dies_is_replaced_and_its_jobs_rerun(tmp_path):
    marker = str(tmp_path / "marker")
    jobs = [Job(str(v), lambda v=v: (marker, v), v) for v in range(6)]
    results = {job.data: (value, error) for job, value, error in
               LocalPool(2).run(_die_once, jobs)}
    assert Path(marker).exists()
    assert {k: v for k, (v, _) in results.items()} == {v: v * 10 for v in range(6)}
    assert all(error is None for _, error in results.values())


def test_absurd_settings_are_refused():
    for bad in ({"packs": 0}, {"theta_cells": 1000}, {"basis": -1}, {"thumbnail_size": 4}):
        with pytest.raises(ValueError):
            LibrarySettings(**bad)


def _die_always(marker: str, value: int) -> int:
    """Value 3 kills its worker every time (a file that takes its worker down)."""
    if value == 3:
        os._exit(1)
    return value * 10


def test_a_file_that_always_kills_its_worker_fails_alone(tmp_path):
    jobs = [Job(str(v), lambda v=v: ("", v), v) for v in range(8)]
    results = {job.data: (value, error) for job, value, error in
               LocalPool(2).run(_die_always, jobs)}
    assert set(results) == set(range(8))
    assert isinstance(results[3][1], RuntimeError) and "died" in str(results[3][1])
    assert {k: v for k, (v, e) in results.items() if k != 3} == \
        {v: v * 10 for v in range(8) if v != 3}


def test_a_file_that_vanishes_before_its_job_is_named(tmp_path):
    gone = tmp_path / "gone.npz"
    gone.write_bytes(b"x")
    jobs = [Job("gone", lambda: gone.read_bytes(), 0)]
    gone.unlink()
    [(job, value, error)] = list(LocalPool(1).run(_die_once, jobs))
    assert value is None and isinstance(error, FileNotFoundError)
    with pytest.raises(ValueError, match="at least 1"):
        LocalPool(0)


def test_a_first_build_stopped_before_its_index_can_be_resumed(sources, tmp_path):
    lib = tmp_path / "lib"
    (lib / layout.MATERIALS / ".partial-x-1").mkdir(parents=True)   # killed at once
    result = build_library([sources / "rgl"], lib, SETTINGS, workers=1)
    assert len(result.written) == 1
    # a new library has its (empty) index before anything is factored
    fresh = tmp_path / "fresh"
    layout.open_library(fresh, create=True)
    assert json.loads((fresh / layout.INDEX_FILE).read_text())["entries"] == []


def test_one_build_at_a_time(sources, tmp_path):
    lib = tmp_path / "lib"
    layout.open_library(lib, create=True)
    with layout.build_lock(lib):
        with pytest.raises(layout.LibraryBusy, match=str(os.getpid())):
            build_library([sources / "rgl"], lib, SETTINGS, workers=1)
    (lib / layout.LOCK_FILE).write_text("999999999")       # a build that was killed
    assert build_library([sources / "rgl"], lib, SETTINGS, workers=1).written
    assert not (lib / layout.LOCK_FILE).exists()


def test_ids_do_not_depend_on_how_sources_are_named(sources, tmp_path):
    lib = tmp_path / "lib"
    first = build_library([sources / "studio", sources / "merl"], lib, SETTINGS, workers=2)
    again = build_library([sources], lib, SETTINGS, workers=2)
    # the same files keep their entries (not factored again); their catalogs follow
    assert len(again.skipped) == len(first.written) == 9
    assert [w.split("-")[0] for w in again.written] == ["fabric"]
    assert len(_entry_folders(lib)) == 10
    index = json.loads((lib / layout.INDEX_FILE).read_text())
    assert {e["catalog"] for e in index["entries"]} == {"src/studio/paints", "src/merl",
                                                        "src/rgl"}
    twin = tmp_path / "other" / "merl"
    twin.mkdir(parents=True)
    (twin / "red plastic.binary").write_bytes(
        (sources / "merl" / "red plastic.binary").read_bytes())
    both = build_library([sources, tmp_path / "other"], lib, SETTINGS, workers=2)
    assert len(both.written) == 1 and len(_entry_folders(lib)) == 11


def test_a_library_inside_a_source_folder_is_not_read_back(sources):
    inside = sources / "built"
    build_library([sources / "rgl"], inside, SETTINGS, workers=1)
    result = build_library([sources], inside, SETTINGS, workers=2)
    assert not result.failed and len(result.written) == 9 and len(result.skipped) == 1


def test_an_unreadable_file_is_named_and_the_rest_go_on(sources, tmp_path, monkeypatch):
    """A file the build may not read (injected: the tests run as root, who reads any file)."""
    from spectral_materials.core.library import build

    real = build.file_digest

    def digest(path):
        if Path(path).name == "red clay.npz":
            raise PermissionError(13, "Permission denied", str(path))
        return real(path)

    monkeypatch.setattr(build, "file_digest", digest)
    result = build_library([sources], tmp_path / "lib", SETTINGS, workers=2)
    assert len(result.written) == 9
    assert [Path(f["source"]).name for f in result.failed] == ["red clay.npz"]
    assert "Permission denied" in result.failed[0]["error"]
