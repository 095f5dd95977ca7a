"""The spectral layout itself (Fichet et al. 2021): its limits and attribute names, the
errors, :class:`SpectralImage`, and the channel names ``S0.550,000000nm`` / ``T.<λ>``."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

#: ``spectralLayoutVersion`` written, and the only one known to this reader.
LAYOUT_VERSION = "1.0"
#: The ``emissiveUnits`` value the reference code writes and expects.
EMISSIVE_UNITS = "W.m^-2.sr^-1"
#: Refuse files with more samples than this (width × height × channels, all channels).
MAX_SAMPLES = 1 << 28
#: Refuse headers listing more channels than this.
MAX_CHANNELS = 100_000
# WAVELENGTH_LIMITS_NM (10 nm – 100 µm) and MAX_SAMPLE (±10³⁰) are the project's bounds
# (core.sample_limits). For images: spectral cameras and renderers work within
# 200–2500 nm, thermal imagers to about 14 µm, so a wavelength outside is a damaged name or
# a wrong unit (5e14 nm), not a band; radiance in W·m⁻²·sr⁻¹·nm⁻¹ stays below about 10⁵
# even for the Sun's disc, and at 10³⁰ a float32 sum over the largest image read
# (MAX_SAMPLES = 2²⁸ samples) still stays finite (2.7 × 10³⁸ < 3.4 × 10³⁸).

KINDS = ("reflective", "emissive")
_LAYER = {"reflective": "T", "emissive": "S0"}
#: Layout attributes this module writes itself; refused in ``attributes``.
_RESERVED = frozenset({"spectralLayoutVersion", "emissiveUnits", "polarisationHandedness", "EV"})
#: Structural OpenEXR header entries, not reported as attributes.
_STRUCTURAL = frozenset({
    "channels", "compression", "dataWindow", "displayWindow", "lineOrder",
    "pixelAspectRatio", "screenWindowCenter", "screenWindowWidth", "type", "tiles",
    "chunkCount", "version", "name",
})


_SPEED_OF_LIGHT = 299_792_458.0
_PREFIX = {"Y": 1e24, "Z": 1e21, "E": 1e18, "P": 1e15, "T": 1e12, "G": 1e9, "M": 1e6,
           "k": 1e3, "h": 1e2, "da": 1e1, "d": 1e-1, "c": 1e-2, "m": 1e-3, "u": 1e-6,
           "n": 1e-9, "p": 1e-12}
_VALUE = r"(\d+(?:,\d*)?|,\d+)([Ee][+-]?\d+)?"
_UNIT = r"(Y|Z|E|P|T|G|M|k|h|da|d|c|m|u|n|p)?(m|Hz)"
_SPECTRAL = re.compile(rf"(S[0-3]|T)\.{_VALUE}{_UNIT}")
_BISPECTRAL = re.compile(rf"T\.{_VALUE}{_UNIT}\.{_VALUE}{_UNIT}")
#: A name in a spectral layer: anything after it must parse, or the file is refused.
_LAYERED = re.compile(r"(S\d+|T)\..*", re.DOTALL)


class InvalidSpectralImage(ValueError):
    """A spectral OpenEXR file is unusable; the message names the file and the problem."""


class SpectralEXRFileNotFound(InvalidSpectralImage, FileNotFoundError):
    """The file does not exist (both a ValueError and a FileNotFoundError)."""


@dataclass
class SpectralImage:
    """A spectral image read from (or to be written to) a spectral OpenEXR file.

    Attributes
    ----------
    wavelengths : ndarray (L,) float64
        nm, strictly increasing.
    values : ndarray (H, W, L) float32
        Row 0 at the bottom. Emissive: ``S0`` (radiance, in :attr:`units`);
        reflective: ``T`` (unitless).
    kind : {"reflective", "emissive"}
    attributes : dict
        Header attributes other than OpenEXR's structural ones (the layout's
        ``spectralLayoutVersion``, ``emissiveUnits``, ``EV``... and any others).
    defects : dict
        ``{"nan": n, "inf": n, "negative": n}`` samples found in ``values``.
    notes : list of str
        What the reader skipped or assumed (Stokes S1–S3, the other kind, ...).
    path : Path or None
    """

    wavelengths: np.ndarray
    values: np.ndarray
    kind: str
    attributes: dict = field(default_factory=dict)
    defects: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)
    path: Path | None = None

    @property
    def units(self) -> str | None:
        """``emissiveUnits`` of an emissive image (None for reflective images)."""
        if self.kind != "emissive":
            return None
        return str(self.attributes.get("emissiveUnits", EMISSIVE_UNITS))

    @property
    def polarised(self) -> bool:
        """Whether the file held Stokes components S1–S3 (not read)."""
        return any(note.startswith("polarised") for note in self.notes)


# --------------------------------------------------------------------------- names


def _format_value(wavelength_nm: float) -> str:
    """``%f`` with a decimal comma (as the reference), more digits if ``%f`` loses some."""
    text = f"{wavelength_nm:f}"
    if float(text) != wavelength_nm:
        text = repr(float(wavelength_nm))
        if "e" in text or "E" in text:
            raise ValueError(f"wavelength {wavelength_nm!r} nm cannot be written exactly")
    return text.replace(".", ",")


def channel_name(kind: str, wavelength_nm: float, stokes: int = 0) -> str:
    """The layout's channel name, e.g. ``S0.550,000000nm`` or ``T.412,500000nm``."""
    if kind not in KINDS:
        raise ValueError(f"kind must be 'reflective' or 'emissive', got {kind!r}")
    wl = float(wavelength_nm)
    if not (math.isfinite(wl) and wl > 0):
        raise ValueError(f"wavelength must be finite and positive, got {wavelength_nm!r}")
    if kind == "reflective":
        if stokes != 0:
            raise ValueError("reflective channels have no Stokes component")
        layer = "T"
    else:
        if stokes not in (0, 1, 2, 3):
            raise ValueError(f"Stokes component must be 0..3, got {stokes!r}")
        layer = f"S{stokes}"
    return f"{layer}.{_format_value(wl)}nm"


def _to_nm(digits: str, exponent: str | None, prefix: str | None, unit: str) -> float:
    value = float(digits.replace(",", ".") + (exponent or ""))
    if prefix == "n" and unit == "m":
        return value  # exact for the common case, as the reference does
    value *= _PREFIX[prefix] if prefix else 1.0
    if unit == "Hz":
        return _SPEED_OF_LIGHT / value * 1e9 if value > 0 else math.inf
    return value * 1e9


def parse_channel_name(name: str) -> tuple[str, int, float] | None:
    """(kind, Stokes component, wavelength in nm) of a spectral channel name.

    Returns None for names outside the spectral layers (``R``, ``G``, ``A``,
    ``foo.Z``...) and for bi-spectral re-radiation channels; raises ValueError
    for a name in an ``S<n>.`` / ``T.`` layer that does not follow the layout, or
    whose wavelength is not finite and positive.
    """
    match = _SPECTRAL.fullmatch(name)
    if match is None:
        if _BISPECTRAL.fullmatch(name) or not _LAYERED.fullmatch(name):
            return None
        raise ValueError(f"channel {name!r} is in a spectral layer but does not follow the "
                         "layout (<S0-S3|T>.<value with decimal comma><prefix><m|Hz>)")
    layer, digits, exponent, prefix, unit = match.groups()
    try:
        with np.errstate(all="ignore"):
            wl = _to_nm(digits, exponent, prefix, unit)
    except (ValueError, OverflowError, ZeroDivisionError):
        wl = math.nan
    if not (math.isfinite(wl) and wl > 0):
        raise ValueError(f"channel {name!r} gives wavelength {wl} nm, not finite and positive")
    if layer == "T":
        return "reflective", 0, wl
    return "emissive", int(layer[1]), wl
