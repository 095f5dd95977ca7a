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
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Iterator

import numpy as np
from colour.colorimetry import planck_law
from numpy.typing import ArrayLike

from ..sample_limits import MAX_SAMPLE, WAVELENGTH_LIMITS_NM
from . import spectra

#: The visible range that a plain list of typed values is spread over, in nm.
TEXT_RANGE_NM = (380.0, 780.0)

#: Wavelengths typed as ``wl:value`` pairs must lie in this range (nm).
TEXT_WAVELENGTH_LIMITS_NM = (300.0, 900.0)

#: Longest spectrum text accepted, in characters.
MAX_TEXT_CHARS = 1_000_000

#: Largest spectrum CSV file read, in bytes (10 MB).
MAX_CSV_BYTES = 10 * 1024 * 1024

#: Most samples (data lines) read from a spectrum CSV file: 1 nm steps over 10 nm – 100 µm
#: (the same cap as ``formats.tabulated.MAX_WAVELENGTHS``).
MAX_CSV_ROWS = 100_000

#: Blackbody temperatures accepted by :func:`blackbody_spd`, in K.
BLACKBODY_LIMITS_K = (500.0, 1.0e6)

#: :func:`blackbody_spd` is 1 at this wavelength (nm).
BLACKBODY_NORMALISATION_NM = 560.0

# A plain decimal number, ASCII digits only (``float`` alone would accept "nan",
# "1_000" and non-ASCII digits such as "١٢"). The fraction needs its point, so a run of
# digits can be matched one way only: "[0-9]+\.?[0-9]*" backtracked quadratically on a
# long run of digits that is not a number (100,000 digits: minutes).
_NUMBER = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
# A text token: a ``wl:value`` pair (spaces allowed around the colon) or a bare value.
_TEXT_TOKEN = re.compile(r"[^\s,;:]*[ \t]*:[ \t]*[^\s,;:]*|[^\s,;]+")
# The line boundaries of ``str.splitlines``.
_LINE_BREAK = re.compile(r"\r\n|[\n\r\v\f\x1c\x1d\x1e\x85\u2028\u2029]")
# Fields split off one line at most: enough to tell two from "too many".
_MAX_SPLIT = 8
# Characters of a token quoted in a message.
_SHOWN_CHARS = 40


class SpectrumFileError(ValueError):
    """A spectrum file cannot be used; the message names the file (and line) and why."""


def _shown(token: str) -> str:
    """``repr`` of a token for a message, cut short: a token can be megabytes long."""
    if len(token) <= _SHOWN_CHARS:
        return repr(token)
    return repr(token[:_SHOWN_CHARS]) + f"… ({len(token):,} characters)"


def _parse_number(token: str) -> float | None:
    """The value of a plain decimal number, ``nan`` for a non-finite one, else ``None``."""
    if _NUMBER.fullmatch(token):
        value = float(token)
        return value if math.isfinite(value) else math.nan  # "1e999" overflows to inf
    try:
        float(token)
    except ValueError:
        return None
    return math.nan if token.strip().lower().lstrip("+-") in {"nan", "inf", "infinity"} else None


def _number_or_raise(token: str, what: str, error: type[ValueError] = ValueError) -> float:
    value = _parse_number(token)
    if value is None:
        raise error(f"{what}: {_shown(token)} is not a number")
    if math.isnan(value):
        raise error(f"{what}: {_shown(token)} is not finite (NaN and inf are not allowed)")
    if abs(value) > MAX_SAMPLE:
        raise error(f"{what}: {_shown(token)} is beyond ±{MAX_SAMPLE:g}; no spectrum holds "
                    "such values (sample_limits)")
    return value


def parse_spectrum_text(text: str) -> tuple[np.ndarray, np.ndarray]:
    """Parse a spectrum typed into a text field → ``(wavelengths_nm, values)``.

    Two styles are accepted, not mixed:

    * ``"wl:value, wl:value, ..."`` pairs, wavelengths in nm, strictly increasing and
      within :data:`TEXT_WAVELENGTH_LIMITS_NM` (300–900 nm). Spaces around ``:`` are
      allowed; a single pair is a one-sample spectrum (constant once resampled).
    * a plain list of values, spread evenly over :data:`TEXT_RANGE_NM` (380–780 nm):
      ``N ≥ 2`` values sit at ``linspace(380, 780, N)`` (two values make a linear
      ramp); a single value is a constant, returned as two samples at 380 and 780 nm.

    Tokens are separated by commas, semicolons and/or white space. Numbers are plain
    ASCII decimals (``0.5``, ``-1``, ``4.5e2``). Values beyond ±10³⁰ are refused (no
    spectrum holds them; see :mod:`spectral_materials.core.sample_limits`); other ranges are
    not checked here: use :func:`check_reflectance` or :func:`check_spd`.

    Parameters
    ----------
    text
        The typed text.

    Returns
    -------
    wavelengths, values
        1-D float64 arrays of equal length.

    Raises
    ------
    ValueError
        Empty text; a token that is not a number, NaN/inf or beyond ±10³⁰ (the message
        gives the token, its number and its character position); wavelengths not strictly
        increasing or outside 300–900 nm; the two styles mixed.

    Examples
    --------
    >>> parse_spectrum_text("400:0.1, 550:0.8, 700:0.3")[1]
    array([0.1, 0.8, 0.3])
    >>> parse_spectrum_text("0.2 0.6")[0]
    array([380., 780.])
    """
    if not isinstance(text, str):
        raise ValueError(f"spectrum text must be a string, got {type(text).__name__}")
    if len(text) > MAX_TEXT_CHARS:
        raise ValueError(f"spectrum text is too long ({len(text)} characters, "
                         f"at most {MAX_TEXT_CHARS})")
    paired: bool | None = None  # set by the first token
    wavelengths: list[float] = []
    values: list[float] = []
    for index, match in enumerate(_TEXT_TOKEN.finditer(text), start=1):
        token = match.group()
        if paired is None:
            paired = ":" in token
        where = f"token {index} {_shown(token)} at character {match.start() + 1}"
        if (":" in token) != paired:
            first = "wavelength:value pairs" if paired else "plain values"
            raise ValueError(f"{where}: the text starts with {first}; use one style only, "
                             "either all 'wl:value' pairs or all plain values")
        if not paired:
            values.append(_number_or_raise(token, where))
            continue
        wl_text, value_text = (part.strip() for part in token.split(":", 1))
        if not wl_text or not value_text:
            raise ValueError(f"{where}: a pair needs both a wavelength and a value, "
                             "as in '550:0.4'")
        wl = _number_or_raise(wl_text, f"{where}, wavelength")
        value = _number_or_raise(value_text, f"{where}, value")
        low, high = TEXT_WAVELENGTH_LIMITS_NM
        if not low <= wl <= high:
            raise ValueError(f"{where}: wavelength {wl:g} nm is outside {low:g}–{high:g} nm")
        if wavelengths and wl <= wavelengths[-1]:
            raise ValueError(f"{where}: wavelength {wl:g} nm does not increase from "
                             f"{wavelengths[-1]:g} nm; list wavelengths in increasing "
                             "order, each once")
        wavelengths.append(wl)
        values.append(value)

    if paired is None:
        raise ValueError("spectrum text is empty: type values such as '0.2, 0.5, 0.8' "
                         "or wavelength:value pairs such as '400:0.2, 700:0.8'")
    if paired:
        return np.asarray(wavelengths, dtype=np.float64), np.asarray(values, dtype=np.float64)
    if len(values) == 1:
        values = values * 2
    return np.linspace(*TEXT_RANGE_NM, len(values)), np.asarray(values, dtype=np.float64)


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


def blackbody_spd(temperature_k: float,
                  wavelengths: ArrayLike = spectra.WAVELENGTHS_REFERENCE) -> np.ndarray:
    """Relative SPD of a blackbody (Planck's law), 1 at 560 nm → array (L,).

    Computed with ``colour.colorimetry.planck_law`` (CIE 015:2018 constants,
    c₂ = 1.4388 × 10⁻² m·K, refractive index 1) and divided by its value at
    :data:`BLACKBODY_NORMALISATION_NM`.

    Parameters
    ----------
    temperature_k
        Temperature in kelvin, finite and within :data:`BLACKBODY_LIMITS_K`
        (500 K to 10⁶ K).
    wavelengths
        Wavelengths in nm (1-D, strictly increasing, 200–2000 nm); the protocol's
        5 nm grid by default.

    Raises
    ------
    ValueError
        The temperature is not a finite number in [500, 10⁶] K, or the wavelengths are
        invalid.
    """
    if isinstance(temperature_k, bool) or not isinstance(
            temperature_k, int | float | np.integer | np.floating):
        raise ValueError(f"blackbody temperature must be a number, got "
                         f"{type(temperature_k).__name__}")
    t = float(temperature_k)
    low, high = BLACKBODY_LIMITS_K
    if not (math.isfinite(t) and low <= t <= high):
        raise ValueError(f"blackbody temperature must be finite and within {low:g}–{high:g} K, "
                         f"got {temperature_k}")
    wl = spectra.check_wavelengths(wavelengths)
    radiance = np.atleast_1d(planck_law(wl * 1e-9, t))
    reference = float(planck_law(BLACKBODY_NORMALISATION_NM * 1e-9, t))
    return np.asarray(radiance / reference, dtype=np.float64)


def _finite_1d(values: ArrayLike, name: str, wavelengths: ArrayLike | None) -> tuple:
    try:
        arr = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: values are not numbers ({exc})") from exc
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"{name}: expected a non-empty 1-D array of values, "
                         f"got shape {arr.shape}")
    wl = None
    if wavelengths is not None:
        wl = np.asarray(wavelengths, dtype=np.float64)
        if wl.shape != arr.shape:
            raise ValueError(f"{name}: {arr.size} values but wavelengths of shape {wl.shape}")
    return arr, wl


def _report(arr: np.ndarray, bad: np.ndarray, wl: np.ndarray | None, name: str,
            problem: str) -> None:
    if not bad.any():
        return
    i = int(np.flatnonzero(bad)[0])
    at = f"{wl[i]:g} nm" if wl is not None else f"sample {i}"
    raise ValueError(f"{name}: {int(bad.sum())} of {arr.size} values {problem}; "
                     f"the first is {arr[i]:g} at {at}")


def check_reflectance(values: ArrayLike, name: str,
                      wavelengths: ArrayLike | None = None) -> np.ndarray:
    """Check that a reflectance is finite and within [0, 1] → the values as float64.

    Parameters
    ----------
    values
        The reflectance samples, 1-D.
    name
        What to call the spectrum in the error message (e.g. ``"diffuse reflectance"``).
    wavelengths
        Optional wavelengths (nm) of the samples, so the message can say where the first
        offending value is; without them it gives the sample index.

    Raises
    ------
    ValueError
        Any value non-finite or outside [0, 1]; the message counts them and names the
        first one's wavelength (or index).
    """
    arr, wl = _finite_1d(values, name, wavelengths)
    _report(arr, ~np.isfinite(arr), wl, name, "are NaN or inf")
    _report(arr, (arr < 0.0) | (arr > 1.0), wl, name, "are outside the reflectance range [0, 1]")
    return arr


def check_spd(values: ArrayLike, name: str, wavelengths: ArrayLike | None = None) -> np.ndarray:
    """Check that a spectral power distribution is finite, ≥ 0 and not all zero → float64.

    Parameters are as for :func:`check_reflectance`.

    Raises
    ------
    ValueError
        Any value non-finite or negative (counted, the first one located), or every
        value zero.
    """
    arr, wl = _finite_1d(values, name, wavelengths)
    _report(arr, ~np.isfinite(arr), wl, name, "are NaN or inf")
    _report(arr, arr < 0.0, wl, name, "are negative")
    if not np.any(arr > 0.0):
        raise ValueError(f"{name}: every value is zero; a light needs some power")
    return arr


def spectrum_to_grid(wavelengths: ArrayLike, values: ArrayLike,
                     grid: ArrayLike = spectra.WAVELENGTHS_REFERENCE) -> np.ndarray:
    """Resample a ``(wavelengths, values)`` spectrum onto ``grid`` → array (len(grid),).

    Delegates to :func:`spectra.spectrum_values`: piecewise-linear interpolation, exact
    at the input's own samples. **Extrapolation** is constant: grid wavelengths below
    the first sample take the first value, those above the last take the last value
    (so a one-sample spectrum becomes a constant). Nothing is clipped or range-checked
    beyond finiteness.

    Parameters
    ----------
    wavelengths, values
        The spectrum: 1-D arrays of equal length, wavelengths in nm strictly increasing.
    grid
        Target wavelengths in nm (1-D, strictly increasing, 200–2000 nm); the protocol's
        5 nm grid from 380 to 780 nm by default.

    Raises
    ------
    ValueError
        Mismatched or non-1-D inputs, wavelengths not strictly increasing, non-finite
        values, or an invalid grid.
    """
    wl = np.asarray(wavelengths, dtype=np.float64)
    vals = np.asarray(values, dtype=np.float64)
    if wl.ndim != 1 or wl.size == 0 or wl.shape != vals.shape:
        raise ValueError(f"a spectrum needs 1-D wavelengths and values of equal, non-zero "
                         f"length; got shapes {wl.shape} and {vals.shape}")
    if not (np.isfinite(wl).all() and np.isfinite(vals).all()):
        raise ValueError("spectrum wavelengths and values must be finite")
    return spectra.spectrum_values((wl, vals), np.asarray(grid, dtype=np.float64))
