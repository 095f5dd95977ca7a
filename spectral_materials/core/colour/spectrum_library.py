"""Where the UI's spectra come from: typed text, CSV files, blackbodies, and checks.

Every entry point validates before it trusts: malformed input of any kind raises a
:class:`ValueError` whose message names the problem (the offending token, line or
wavelength), never a bare ``IndexError`` or ``UnicodeDecodeError``, so the add-on can
show the message to the user as it is. A file's problems raise
:class:`SpectrumFileError` (a ``ValueError``) naming the file.

Values beyond ±10³⁰ and file wavelengths outside 10 nm – 100 µm are refused where they are
read (:mod:`spectral_materials.core.sample_limits` says why). Reading a file costs memory
in proportion to it: at most :data:`MAX_CSV_BYTES` are read, lines are taken one at a
time, at most :data:`MAX_CSV_ROWS` samples are kept, and a line is split into no more
fields than it takes to see that it has too many.

Spectra are handed around as ``(wavelengths, values)`` pairs of 1-D float64 arrays,
wavelengths in nm and strictly increasing: the tuple form of
:data:`spectra.SpectrumLike`. :func:`spectrum_to_grid` puts them on the project's
wavelength grid.

References
----------
CIE 015:2018 Colorimetry, 4th ed., §9.6 (Planck's law, c₂ = 1.4388 × 10⁻² m·K), as
implemented by ``colour.colorimetry.planck_law`` in colour-science 0.4.6.

Typed text is parsed in :mod:`.spectrum_text`; blackbodies, the checks and the resampling
live in :mod:`.spectrum_checks`. Their names are re-exported here; the CSV reader stays
here (its limits are read from this module).
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterator

import numpy as np

from ..sample_limits import MAX_SAMPLE, WAVELENGTH_LIMITS_NM  # noqa: F401  (importable as before)
from .spectrum_checks import (
    BLACKBODY_LIMITS_K,
    BLACKBODY_NORMALISATION_NM,
    blackbody_spd,
    check_reflectance,
    check_spd,
    spectrum_to_grid,
)
from .spectrum_text import (
    MAX_TEXT_CHARS,
    TEXT_RANGE_NM,
    TEXT_WAVELENGTH_LIMITS_NM,
    _number_or_raise,
    _parse_number,
    _shown,
    parse_spectrum_text,
)

__all__ = [
    "BLACKBODY_LIMITS_K",
    "BLACKBODY_NORMALISATION_NM",
    "MAX_CSV_BYTES",
    "MAX_CSV_ROWS",
    "MAX_TEXT_CHARS",
    "TEXT_RANGE_NM",
    "TEXT_WAVELENGTH_LIMITS_NM",
    "SpectrumFileError",
    "blackbody_spd",
    "check_reflectance",
    "check_spd",
    "parse_spectrum_text",
    "read_spectrum_csv",
    "spectrum_to_grid",
]

#: Largest spectrum CSV file read, in bytes (10 MB).
MAX_CSV_BYTES = 10 * 1024 * 1024

#: Most samples (data lines) read from a spectrum CSV file: 1 nm steps over 10 nm – 100 µm
#: (the same cap as ``formats.tabulated.MAX_WAVELENGTHS``).
MAX_CSV_ROWS = 100_000

# The line boundaries of ``str.splitlines``.
_LINE_BREAK = re.compile(r"\r\n|[\n\r\v\f\x1c\x1d\x1e\x85\u2028\u2029]")
# Fields split off one line at most: enough to tell two from "too many".
_MAX_SPLIT = 8


class SpectrumFileError(ValueError):
    """A spectrum file cannot be used; the message names the file (and line) and why."""



def _decode(raw: bytes, label: str) -> str:
    """Text of a CSV file: UTF-8 (BOM optional), UTF-16 with a BOM, else Latin-1."""
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        try:
            return raw.decode("utf-16")
        except UnicodeDecodeError as exc:
            raise SpectrumFileError(f"spectrum file {label} has a UTF-16 mark but is not "
                                    "valid UTF-16 text") from exc
    if b"\x00" in raw:
        raise SpectrumFileError(f"spectrum file {label} is not a text file (it contains NUL "
                                "bytes); save it as a UTF-8 CSV")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        return raw.decode("latin-1")  # spectrometer exports in Windows code pages


def _lines(text: str) -> Iterator[str]:
    """``text.splitlines()`` one line at a time: as a list, millions of short lines would
    cost about 60 bytes each."""
    start = 0
    for match in _LINE_BREAK.finditer(text):
        yield text[start : match.start()]
        start = match.end()
    if start < len(text):
        yield text[start:]


def _split_fields(line: str) -> tuple[list[str], str]:
    """Fields of one CSV line and the separator used (``;``, tab, ``,`` or blanks).

    At most ``_MAX_SPLIT + 1`` fields: the last then holds the unsplit rest, so that a line
    of a million separators costs a copy of the line, not a million strings.
    """
    for sep in (";", "\t", ","):
        if sep in line:
            fields = [f.strip() for f in line.split(sep, _MAX_SPLIT)]
            if len(fields) > _MAX_SPLIT and not fields[-1].replace(sep, "").strip():
                fields[-1] = ""  # the rest is separators only: "450,0.2,,,,,,,,,"
            while len(fields) > 1 and not fields[-1]:  # "450,0.2," from spreadsheets
                fields.pop()
            return fields, sep
    return line.split(None, _MAX_SPLIT), " "


def _open_text(path: str | os.PathLike) -> tuple[str, str]:
    """``(label, text)`` of a spectrum file: checked, at most MAX_CSV_BYTES read, decoded."""
    try:
        path_str = os.fspath(path)
    except TypeError as exc:
        raise SpectrumFileError(f"spectrum file path must be a string or path, got "
                                f"{type(path).__name__}") from exc
    if not path_str:
        raise SpectrumFileError("spectrum file path is empty")
    label = repr(path_str)
    if not os.path.exists(path_str):
        raise SpectrumFileError(f"spectrum file {label} does not exist")
    if not os.path.isfile(path_str):
        raise SpectrumFileError(f"spectrum file {label} is not a regular file")
    try:
        size = os.path.getsize(path_str)
        if size > MAX_CSV_BYTES:
            raise SpectrumFileError(f"spectrum file {label} is {size / 1e6:.1f} MB; files over "
                                    f"{MAX_CSV_BYTES / 1e6:.0f} MB are refused")
        with open(path_str, "rb") as handle:
            raw = handle.read(MAX_CSV_BYTES + 1)
    except OSError as exc:
        raise SpectrumFileError(f"spectrum file {label} cannot be read: "
                                f"{exc.strerror or exc}") from exc
    if len(raw) > MAX_CSV_BYTES:  # grew while we looked
        raise SpectrumFileError(f"spectrum file {label} is over {MAX_CSV_BYTES / 1e6:.0f} MB; "
                                "refused")
    return label, _decode(raw, label)


def _data_rows(text: str, label: str) -> list[tuple[float, float, int]]:
    """``(wavelength, value, line number)`` of each data line, at most MAX_CSV_ROWS."""
    rows: list[tuple[float, float, int]] = []
    for number, line in enumerate(_lines(text), start=1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        fields, sep = _split_fields(line)
        if sep in (";", "\t"):
            fields = [f.replace(",", ".") if f.count(",") == 1 and "." not in f else f
                      for f in fields]
        where = f"spectrum file {label}, line {number}"
        if _parse_number(fields[0]) is None:
            if not rows:
                continue  # a header line
            raise SpectrumFileError(f"{where}: {_shown(fields[0])} is not a wavelength (text "
                                    "lines are only allowed before the data)")
        if len(fields) != 2:
            found = str(len(fields)) if len(fields) <= _MAX_SPLIT else f"over {_MAX_SPLIT}"
            hint = ("; a decimal comma needs ';' or tab separators"
                    if sep == "," and len(fields) in (3, 4) else "")
            raise SpectrumFileError(f"{where}: expected two columns (wavelength nm, value), "
                                    f"found {found}{hint}")
        if len(rows) == MAX_CSV_ROWS:
            raise SpectrumFileError(f"{where}: more than {MAX_CSV_ROWS:,} samples; a "
                                    "spectrum needs far fewer")
        wl = _number_or_raise(fields[0], f"{where}, wavelength", SpectrumFileError)
        value = _number_or_raise(fields[1], f"{where}, value", SpectrumFileError)
        rows.append((wl, value, number))
    return rows


def _check_csv_wavelengths(wl: np.ndarray, label: str) -> None:
    if wl[0] <= 0:
        raise SpectrumFileError(f"spectrum file {label}: wavelengths must be positive, "
                                f"found {wl[0]:g}")
    if wl[-1] < 10:
        raise SpectrumFileError(f"spectrum file {label}: wavelengths {wl[0]:g}–{wl[-1]:g} look "
                                "like micrometres; the first column must be in nanometres "
                                "(multiply by 1000)")
    if wl[-1] < TEXT_RANGE_NM[0] or wl[0] > TEXT_RANGE_NM[1]:
        raise SpectrumFileError(f"spectrum file {label}: wavelengths {wl[0]:g}–{wl[-1]:g} nm "
                                f"miss the visible range {TEXT_RANGE_NM[0]:g}–"
                                f"{TEXT_RANGE_NM[1]:g} nm; the first column must be the "
                                "wavelength in nm")
    low, high = WAVELENGTH_LIMITS_NM
    if wl[0] < low or wl[-1] > high:
        raise SpectrumFileError(f"spectrum file {label}: wavelengths {wl[0]:g}–{wl[-1]:g} nm "
                                f"reach outside {low:g}–{high:g} nm, where no optical "
                                "measurement lies; check the first column and its unit")


def read_spectrum_csv(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray]:
    """Read a two-column spectrum file (wavelength in nm, value) → ``(wavelengths, values)``.

    Format: one sample per line, the two fields separated by a comma, a semicolon, a
    tab or blanks. ``#`` starts a comment; blank lines are skipped; lines before the
    first data line whose first field is not a number are headers and skipped. With
    ``;`` or tab separators a decimal comma is accepted (``0,25``). A trailing empty
    field (``450,0.2,``) is ignored. Files written in strictly *decreasing* wavelength
    order are reversed; values are returned as read (negative values are allowed:
    callers check ranges with :func:`check_reflectance` or :func:`check_spd`).

    Parameters
    ----------
    path
        The file to read; at most :data:`MAX_CSV_BYTES` (10 MB) and :data:`MAX_CSV_ROWS`
        data lines. UTF-8 (with or without BOM) or UTF-16 with BOM; other bytes are read
        as Latin-1.

    Returns
    -------
    wavelengths, values
        1-D float64 arrays of equal length ≥ 2, wavelengths strictly increasing.

    Raises
    ------
    SpectrumFileError
        (a ``ValueError``) The file is missing, not a file, unreadable, larger than 10 MB
        or binary; a data line does not have exactly two numeric fields, or holds NaN/inf
        or a value beyond ±10³⁰; fewer than two or more than 100,000 data lines; duplicate
        or non-monotonic wavelengths; wavelengths that look like micrometres (all < 10),
        are not positive, do not reach the visible range 380–780 nm or reach outside
        10 nm – 100 µm. Every message names the file, and the line where there is one.
    """
    label, text = _open_text(path)
    rows = _data_rows(text, label)
    del text
    if len(rows) < 2:
        raise SpectrumFileError(f"spectrum file {label} has {len(rows)} data line(s); a "
                                "spectrum needs at least two (wavelength nm, value) lines")
    wl = np.array([r[0] for r in rows])
    values = np.array([r[1] for r in rows])
    lines = [r[2] for r in rows]
    step = np.diff(wl)
    if np.any(step == 0):
        i = int(np.flatnonzero(step == 0)[0])
        raise SpectrumFileError(f"spectrum file {label}: wavelength {wl[i]:g} nm appears twice "
                                f"(lines {lines[i]} and {lines[i + 1]})")
    if np.all(step < 0):
        wl, values = wl[::-1].copy(), values[::-1].copy()
    elif np.any(step < 0):
        direction = np.sign(step[0])
        i = int(np.flatnonzero(np.sign(step) != direction)[0])
        raise SpectrumFileError(f"spectrum file {label}, line {lines[i + 1]}: wavelength "
                                f"{wl[i + 1]:g} nm after {wl[i]:g} nm; wavelengths must be "
                                "monotonic")
    _check_csv_wavelengths(wl, label)
    return wl, values
