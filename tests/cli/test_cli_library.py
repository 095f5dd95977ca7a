"""``python -m spectral_materials library build | import`` (spectral_materials/cli/library.py),
run as a user runs them: in a subprocess, with their exit statuses and messages."""

from __future__ import annotations

import json
import sys

import pytest
from library_sources import make_sources
from test_cli import interrupt_when, run_cli

from spectral_materials.core.library import layout

SMALL = ("--packs", "1", "--theta-cells", "8", "--basis", "4")


@pytest.fixture
def sources(tmp_path):
    make_sources(tmp_path / "src")
    return tmp_path / "src"


def test_build_then_rebuild(sources, tmp_path):
    lib = tmp_path / "lib"
    done = run_cli("library", "build", sources, "--out", lib, "--workers", "2", *SMALL,
                   "--quiet", timeout=300)
    assert done.returncode == 0, done.stderr
    assert "10 factored, 0 current, 0 failed" in done.stdout
    assert len(json.loads((lib / layout.INDEX_FILE).read_text())["entries"]) == 10
    again = run_cli("library", "build", sources, "--out", lib, "--workers", "1", *SMALL,
                    "--quiet", timeout=300)
    assert again.returncode == 0 and "0 factored, 10 current" in again.stdout
    imported = run_cli("library", "import", lib, "--blend", tmp_path / "assets" / "lib.blend",
                       "--quiet", timeout=300)
    assert imported.returncode == 0, imported.stderr
    assert "10 materials in 3 catalogs" in imported.stdout
    assert (tmp_path / "assets" / "lib.blend").is_file()
    assert (tmp_path / "assets" / "blender_assets.cats.txt").is_file()


def test_a_bad_file_is_named_and_the_status_says_so(sources, tmp_path):
    (sources / "broken.bsdf").write_bytes(b"tensor_file\x00garbage")
    done = run_cli("library", "build", sources, "--out", tmp_path / "lib", "--workers", "2",
                   *SMALL, "--quiet", timeout=300)
    assert done.returncode == 1
    assert "10 factored" in done.stdout and "broken.bsdf" in done.stderr
    assert "Traceback" not in done.stderr


@pytest.mark.parametrize("args,needle", [
    (("--scheduler", "tcp://127.0.0.1:9"), "tcp://127.0.0.1:9"),
    (("--packs", "0"), "packs"),
])
def test_refusals_are_one_line(sources, tmp_path, args, needle):
    done = run_cli("library", "build", sources, "--out", tmp_path / "lib", *args, "--quiet",
                   timeout=120)
    assert done.returncode == 2 and needle in done.stderr and "Traceback" not in done.stderr


def test_an_output_folder_that_is_not_a_library(sources, tmp_path):
    other = tmp_path / "music"
    other.mkdir()
    (other / "song.flac").write_bytes(b"fLaC")
    done = run_cli("library", "build", sources, "--out", other, "--quiet")
    assert done.returncode == 2 and "music" in done.stderr
    assert [p.name for p in other.iterdir()] == ["song.flac"]
    imported = run_cli("library", "import", other, "--quiet")
    assert imported.returncode == 2 and "music" in imported.stderr


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
def test_ctrl_c_leaves_a_consistent_library(sources, tmp_path):
    lib = tmp_path / "lib"
    status, err = interrupt_when(["library", "build", sources, "--out", lib, "--workers", "1",
                                  *SMALL], "1/10", timeout=120)
    assert status == 130, err
    index = json.loads((lib / layout.INDEX_FILE).read_text())
    folders = [p for p in (lib / layout.MATERIALS).iterdir()]
    assert 1 <= len(index["entries"]) == len(folders) < 10
    assert not any(p.name.startswith(".") for p in folders)
