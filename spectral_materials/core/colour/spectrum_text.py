"""Spectra typed as text: a list of values spread over the visible range, or
``wavelength:value`` pairs; plain ASCII decimal numbers only."""

from __future__ import annotations

import math
import re

import numpy as np

from ..sample_limits import MAX_SAMPLE

#: The visible range that a plain list of typed values is spread over, in nm.
TEXT_RANGE_NM = (380.0, 780.0)

#: Wavelengths typed as ``wl:value`` pairs must lie in this range (nm).
TEXT_WAVELENGTH_LIMITS_NM = (300.0, 900.0)

#: Longest spectrum text accepted, in characters.
MAX_TEXT_CHARS = 1_000_000


# A plain decimal number, ASCII digits only (``float`` alone would accept "nan",
# "1_000" and non-ASCII digits such as "١٢"). The fraction needs its point, so a run of
# digits can be matched one way only: "[0-9]+\.?[0-9]*" backtracked quadratically on a
# long run of digits that is not a number (100,000 digits: minutes).
_NUMBER = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
# A text token: a ``wl:value`` pair (spaces allowed around the colon) or a bare value.
_TEXT_TOKEN = re.compile(r"[^\s,;:]*[ \t]*:[ \t]*[^\s,;:]*|[^\s,;]+")


# Characters of a token quoted in a message.
_SHOWN_CHARS = 40


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
