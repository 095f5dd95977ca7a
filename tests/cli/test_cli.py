"""Tests for ``python -m spectral_materials factor`` (spectral_materials/cli/)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from spectral_materials import cli
from spectral_materials.core.brdf import models
from spectral_materials.core.brdf.factored import FactoredBRDF
from spectral_materials.core.colour import spectra
from spectral_materials.core.formats.tabulated import tabulate_to_file

ROOT = Path(__file__).resolve().parents[2]


def _env() -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    return env


def run_cli(*args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "spectral_materials", *map(str, args)],
                          cwd=ROOT, env=_env(), capture_output=True, text=True, timeout=timeout)


def _check_rows(rows: list[dict], illuminants=("D65", "FL2")) -> None:
    assert rows[-1]["kind"] == "table_floor" and rows[-1]["packs"] is None
    for row in rows:
        assert row["bytes"] > 0 and row["relative_rms"] >= 0
        for illum in illuminants:
            stats = row["de94"][illum]
            assert set(stats) == {"mean", "p95", "max"}
            assert all(np.isfinite(v) and v >= 0 for v in stats.values())
            assert max(stats["mean"], stats["p95"]) <= stats["max"] + 1e-12
    for row in rows[:-1]:
        assert row["kind"] == "factored"
        assert 1 <= row["packs_fitted"] <= row["packs"]
        assert row["terms"] == 4 * row["packs_fitted"] and row["factor_seconds"] >= 0


def test_factor_lambert_end_to_end(tmp_path):
    out, report = tmp_path / "factors.npz", tmp_path / "report.json"
    result = run_cli("factor", "lambert", "--diffuse", "patch:9", "--resolution", 8, 16, 8,
                     "--packs", 1, 2, "--basis", 4, "--out", out, "--json", report)
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr
    doc = json.loads(report.read_text())
    rows = doc["rows"]
    _check_rows(rows)
    factored = [r for r in rows if r["kind"] == "factored"]
    # Lambert is one term: the fit stops at 1 pack; a count of 2 is reported with the
    # 1-pack model (marked in the table) or listed as missing.
    assert {r["packs"] for r in factored} | set(doc["missing_packs"]) == {1, 2}
    assert factored[0]["packs"] == 1 and factored[0]["packs_fitted"] == 1
    assert doc["grid"]["parameterization"] == "io_iso"
    assert doc["grid"]["resolution"] == [8, 16, 8]
    assert doc["spectral_basis"] == 4 and doc["pairs"] == 20_000
    assert doc["input"]["name"] == "lambert"
    # the table on stdout: header, one line per row
    lines = result.stdout.strip().splitlines()
    assert lines[-1].split()[0] == "table" and "mean" in lines[1]
    assert len(lines) == 3 + len(rows)
    model = FactoredBRDF.load(out)
    assert model.parameterization == "io_iso" and model.packs == 1
    wi = np.array([[0.0, 0.0, 1.0], [0.5, 0.0, np.sqrt(0.75)]])
    lambert = models.Lambert(albedo=spectra.colorchecker_spectrum(9))
    assert np.allclose(model.evaluate(wi, wi[::-1]), lambert(wi, wi[::-1], model.wavelengths),
                       rtol=0.05, atol=2e-3)


def test_factor_with_a_lobe(tmp_path):
    """``--lobe``: the saved model carries the lobe, and the table's floor row counts it."""
    out, report = tmp_path / "gloss.npz", tmp_path / "report.json"
    result = run_cli("factor", "ashikhmin_shirley", "--param", "nu=32", "--param", "nv=32",
                     "--resolution", 12, 24, 12, "--packs", 1, "--basis", 6,
                     "--lobe", "ashikhmin_shirley", "--pairs", 3000, "--out", out,
                     "--json", report)
    assert result.returncode == 0, result.stderr
    model = FactoredBRDF.load(out)
    assert model.lobe is not None and abs(model.lobe.nu - 32.0) < 0.5
    rows = json.loads(report.read_text())["rows"]
    _check_rows(rows)
    table = rows[-1]
    # Without the lobe the residual table alone would miss the highlight by ΔE94 ≫ 10.
    assert table["de94"]["D65"]["mean"] < 1.0


def test_factor_tabulated_file(tmp_path):
    path = tmp_path / "on.npz"
    brdf = models.OrenNayar(albedo=spectra.colorchecker_spectrum(12), sigma=0.52)
    tabulate_to_file(brdf, path, "io_iso", (8, 16, 8), spectra.wavelength_grid(400, 700, 10))
    report = tmp_path / "report.json"
    result = run_cli("factor", path, "--packs", 1, 2, "--basis", 4, "--pairs", 2000, "--quiet",
                     "--json", report)
    assert result.returncode == 0, result.stderr
    assert result.stderr == ""  # --quiet
    doc = json.loads(report.read_text())
    _check_rows(doc["rows"])
    assert [r["packs"] for r in doc["rows"][:-1]] == [1, 2]
    assert doc["rows"][1]["relative_rms"] < doc["rows"][0]["relative_rms"]
    # defaults come from the file: its parameterisation, grid and wavelengths
    assert doc["grid"]["parameterization"] == "io_iso"
    assert doc["grid"]["resolution"] == [8, 16, 8]
    assert doc["wavelengths"] == {"start": 400.0, "stop": 700.0, "count": 31}
    assert doc["input"]["path"] == str(path)


@pytest.mark.parametrize("args, message", [
    (["nosuchmodel"], "unknown model 'nosuchmodel'"),
    (["lambert", "--param", "nu=3"], "no parameter 'nu'"),
    (["oren_nayar", "--param", "sigma=abc"], "not a number"),
    (["oren_nayar", "--param", "sigma"], "KEY=VALUE"),
    (["lambert", "--specular", "0.2"], "no specular"),
    (["lambert", "--diffuse", "patch:99"], "1..24"),
    (["lambert", "--diffuse", "blue"], "patch:N"),
    (["lambert", "--diffuse", "0.5", "--albedo", "0.4"], "given twice"),
    (["lambert", "--diffuse", "1.5"], "[0, 1]"),
    (["lambert", "--resolution", "4", "4", "4", "4"], "3 axes"),
    (["lambert", "--illuminants", "D99"], "unknown illuminant"),
    (["lambert", "--out", "/nonexistent_dir_xyz/f.npz"], "does not exist"),
])
def test_errors_exit_2_with_one_line(capsys, args, message):
    status = cli.main(["factor", *args, "--quiet"])  # all refused before any tabulation
    err = capsys.readouterr().err
    assert status == 2
    assert message in err, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_bad_model_name_subprocess():
    result = run_cli("factor", "phong", "--quiet")
    assert result.returncode == 2
    assert result.stderr.strip().splitlines() == [
        "python -m spectral_materials factor: error: unknown model 'phong': choose one of "
        "lambert, oren_nayar, ashikhmin_shirley, ward, ggx, or give the path of a tabulated .npz"]
    assert result.stdout == ""


def test_bad_files_exit_2(tmp_path, capsys):
    corrupt = tmp_path / "corrupt.npz"
    corrupt.write_bytes(b"PK\x03\x04" + b"\0" * 100)
    for path in (corrupt, tmp_path / "missing.npz"):
        assert cli.main(["factor", str(path), "--quiet"]) == 2
        err = capsys.readouterr().err
        assert str(path) in err and len(err.strip().splitlines()) == 1
    good = tmp_path / "good.npz"
    tabulate_to_file(models.Lambert(0.5), good, "io_iso", (4, 8, 4), np.array([500.0, 600.0]))
    assert cli.main(["factor", str(good), "--param", "sigma=1", "--quiet"]) == 2
    assert "only apply to analytic models" in capsys.readouterr().err


def test_parse_spectrum(tmp_path):
    wl, values = cli.parse_spectrum("patch:9")
    assert np.allclose(values, spectra.colorchecker(9, wl))
    assert cli.parse_spectrum(" 0.25 ") == 0.25
    csv = tmp_path / "s.csv"
    csv.write_text("wavelength_nm,value\n# comment\n400, 0.1\n550,0.5\n700,0.9\n")
    wl, values = cli.parse_spectrum(f"csv:{csv}")
    assert wl.tolist() == [400.0, 550.0, 700.0] and values.tolist() == [0.1, 0.5, 0.9]
    csv.write_text("400 0.1\n550 0.5\n")
    assert cli.parse_spectrum(f"csv:{csv}")[0].tolist() == [400.0, 550.0]
    # The add-on's reader: a file in decreasing order is reversed, not refused.
    csv.write_text("700,0.9\n550,0.5\n")
    assert cli.parse_spectrum(f"csv:{csv}")[0].tolist() == [550.0, 700.0]
    for text, content in (("400,0.1\nabc,1\n", "line 2"), ("400,0.1\n", "at least two"),
                          ("400,0.1\n500,0.2\n450,0.3\n", "monotonic"),
                          ("400,0.1\n500,1e300\n", "line 2, value: '1e300' is beyond"),
                          ("400,0.1\n1e9,0.2\n", "outside 10–100000 nm"),
                          ("400,nan\n500,0.2\n", "not finite")):
        csv.write_text(text)
        with pytest.raises(cli.UsageError, match=content) as info:
            cli.parse_spectrum(f"csv:{csv}")
        assert str(csv) in str(info.value)
    with pytest.raises(cli.UsageError):
        cli.parse_spectrum("nan")


def test_csv_spectrum_has_every_check_of_the_addons_reader(tmp_path, monkeypatch):
    """The CLI reads csv:PATH with core.colour.spectrum_library's reader, nothing of its own:
    decimal commas, UTF-16, micrometres and the size limit behave as in the add-on."""
    from spectral_materials.core.colour import spectrum_library

    csv = tmp_path / "s.csv"
    csv.write_text("400;0,25\n700;0,75\n")
    assert cli.parse_spectrum(f"csv:{csv}")[1].tolist() == [0.25, 0.75]
    csv.write_bytes("wl\tvalue\n400\t0.1\n700\t0.9\n".encode("utf-16"))
    assert cli.parse_spectrum(f"csv:{csv}")[0].tolist() == [400.0, 700.0]
    for text, content in (("0.4,0.1\n0.7,0.9\n", "micrometres"),
                          ("400,0,25\n700,0,75\n", "decimal comma needs ';'")):
        csv.write_text(text)
        with pytest.raises(cli.UsageError, match=content):
            cli.parse_spectrum(f"csv:{csv}")
    monkeypatch.setattr(spectrum_library, "MAX_CSV_BYTES", 8)
    csv.write_text("400,0.1\n700,0.9\n")
    with pytest.raises(cli.UsageError, match="refused"):
        cli.parse_spectrum(f"csv:{csv}")


def test_one_progress_bar_and_the_parameterisations_of_the_core():
    from spectral_materials.core.brdf.params import PARAMETERIZATIONS
    from spectral_materials.core.progress import STAGE_STYLE, TerminalProgress

    progress = cli.Progress(quiet=True)
    assert isinstance(progress, TerminalProgress) and progress.style == STAGE_STYLE
    assert sorted(cli.PARAMETERIZATION_CHOICES) == sorted(PARAMETERIZATIONS)


def test_csv_spectrum_reaches_the_model(tmp_path, capsys):
    csv = tmp_path / "s.csv"
    csv.write_text("wavelength_nm,value\n380,0.2\n780,0.6\n")
    report = tmp_path / "r.json"
    status = cli.main(["factor", "oren_nayar", "--param", "sigma=0.3", "--diffuse", f"csv:{csv}",
                       "--resolution", "4", "8", "4", "--packs", "1", "--pairs", "500",
                       "--wavelengths", "400", "700", "20", "--quiet", "--json", str(report)])
    assert status == 0, capsys.readouterr().err
    doc = json.loads(report.read_text())
    assert doc["input"]["sigma"] == 0.3
    assert doc["input"]["albedo"]["values"] == [0.2, 0.6]
    assert doc["wavelengths"]["count"] == 16


def interrupt_when(args: list, needle: str, timeout: float = 60) -> tuple[int, str]:
    """Run the command line with ``args``, send SIGINT once ``needle`` is on stderr; (exit
    status, stderr)."""
    process = subprocess.Popen(
        [sys.executable, "-m", "spectral_materials", *map(str, args)],
        cwd=ROOT, env=_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + timeout
        seen = ""
        while needle not in seen and time.monotonic() < deadline:
            line = process.stderr.readline()
            if not line:
                break
            seen += line
        assert needle in seen, seen
        process.send_signal(signal.SIGINT)
        _, err = process.communicate(timeout=timeout)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    return process.returncode, err


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
def test_ctrl_c_cancels_with_status_130():
    status, err = interrupt_when(["factor", "ggx", "--resolution", "90", "180", "90",
                                  "--packs", "64"], "tabulating")
    assert status == 130, err
    assert err.strip().splitlines()[-1] == "cancelled"
    assert "Traceback" not in err
