"""Spectral OpenEXR images in the layout of Fichet, Pacanowski and Wilkie (JCGT 2021).

Reference: A. Fichet, R. Pacanowski, A. Wilkie, "An OpenEXR Layout for Spectral
Images", Journal of Computer Graphics Techniques 10(3), 2021, and its reference
code github.com/afichet/spectral-exr (``lib/EXRSpectralImage.cpp``,
``lib/include/EXRSpectralImage.h``, ``lib/Util.h``). Details checked there:

Channels
    One channel per wavelength, ``<layer>.<value><prefix><unit>``:

    * layer ``S0`` .. ``S3``: emissive spectra, one layer per Stokes component
      (``S0`` alone when the image is not polarised); ``T``: reflective /
      transmissive (attenuation, unitless) spectra;
    * value: a positive decimal written with a **comma** as decimal separator
      (OpenEXR reserves ``.`` for layers), optionally an exponent
      ``[Ee][+-]?digits``;
    * an optional SI prefix (``Y Z E P T G M k h da d c m u n p``) and the unit,
      ``m`` (wavelength) or ``Hz`` (frequency; λ = c / ν).

    The reference writer formats nm with C++ ``std::to_string`` (``%f``), e.g.
    ``S0.550,000000nm`` and ``T.412,500000nm``; this module writes the same.
    Bi-spectral (fluorescent) re-radiation channels are
    ``T.<λin><unit>.<λout><unit>``; they are recognised and skipped here.
Header attributes
    ``spectralLayoutVersion`` = ``"1.0"`` (string), ``emissiveUnits`` (string,
    emissive images only; the reference writes and expects ``"W.m^-2.sr^-1"``,
    meaning spectral radiance per band), ``polarisationHandedness``
    (``"left"``/``"right"``, polarised images only), ``EV`` (float, exposure
    compensation applied to the RGB preview), and optionally ``lensTransmission``,
    ``cameraResponse`` and per-``S0``-channel sensitivities, strings of
    ``<λ><unit>:<value>;`` pairs (kept verbatim in :attr:`SpectralImage.attributes`).
    The reference header also declares a ``spectrumType`` attribute name but never
    writes or reads it: the spectrum type is given by the channel layers alone, so
    this module does not write it either.
RGB preview
    The reference writer always stores ``R``, ``G``, ``B`` beside the spectral
    channels: CIE 1931 2° XYZ (1 nm CMF steps, the spectrum linearly
    interpolated, only over the spectrum's own range; emissive: ∫L·x̄ dλ without
    the 683 lm/W factor; reflective: under D65, divided by ∫D65·ȳ dλ) to linear
    sRGB (D65), negatives clamped to 0, times 2^EV. :func:`write_spectral_exr`
    does the same through colour-science.

Conventions of this module
--------------------------
* Samples are written as 32-bit float: half floats overflow above 65504 (easily
  reached by radiance in W·m⁻²·sr⁻¹·nm⁻¹ of bright sources) and keep 11 bits.
* Arrays are ``(H, W, L)`` with row 0 at the **bottom**, as in
  :mod:`spectral_materials.core.formats.exr`; files store the top row first.
* OpenEXR stores channels sorted by name (``T.1000,000000nm`` before
  ``T.400,000000nm``), so file order says nothing about wavelength order: the
  reader sorts by wavelength and refuses two channels of one layer that give the
  same wavelength (e.g. ``T.550nm`` and ``T.0,55um``).
* Negative samples: ``S0`` is a radiance and ``T`` an attenuation, both
  non-negative physically (only ``S1``–``S3`` may be negative, and they are not
  read). Negative, NaN and inf samples are counted in
  :attr:`SpectralImage.defects` and kept (``on_invalid="keep"``, default: a reader
  should not alter measured data silently), refused (``"raise"``) or set to 0
  (``"clamp"``).

Reading validates the file before reading any pixel: the magic number, the bytes
the pixels declare against the file's size (:func:`.exr.check_decoded_size`: an
uncompressed part cannot hold more than the file, compressed pixels at most
:data:`.exr.MAX_COMPRESSION_RATIO` times it), then the header alone
(``OpenEXR.File(..., header_only=True)``): part type, channel names, sampling,
wavelengths within :data:`WAVELENGTH_LIMITS_NM`, and ``width × height ×
channels`` against :data:`MAX_SAMPLES`. After decoding, finite samples beyond
±:data:`MAX_SAMPLE` are refused whatever ``on_invalid`` says: they are no
measurement, and arithmetic on them overflows far from the file. Every sort of
damage becomes :class:`InvalidSpectralImage` (a ``ValueError``) naming the file.
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..sample_limits import MAX_SAMPLE, WAVELENGTH_LIMITS_NM, extreme_mask
from . import exr as _exr
from ._files import atomic_path

__all__ = [
    "EMISSIVE_UNITS",
    "LAYOUT_VERSION",
    "MAX_CHANNELS",
    "MAX_SAMPLE",
    "MAX_SAMPLES",
    "WAVELENGTH_LIMITS_NM",
    "InvalidSpectralImage",
    "SpectralEXRFileNotFound",
    "SpectralImage",
    "channel_name",
    "parse_channel_name",
    "read_spectral_exr",
    "spectral_image_to_rgb",
    "spectral_image_to_xyz",
    "write_spectral_exr",
]

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
_MAGIC = b"\x76\x2f\x31\x01"
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
_CMF_GRID = np.arange(360.0, 831.0, 1.0)


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


# --------------------------------------------------------------------------- colour


def _interp_on_cmf_grid(wavelengths: np.ndarray, values: np.ndarray) -> tuple[np.ndarray,
                                                                              np.ndarray]:
    """(mask of the 1 nm CMF grid inside the spectrum's range, values (N, k) there)."""
    inside = (_CMF_GRID >= wavelengths[0]) & (_CMF_GRID <= wavelengths[-1])
    grid = _CMF_GRID[inside]
    flat = values.reshape(-1, values.shape[-1]).astype(np.float64)
    if grid.size == 0 or wavelengths.size < 2:
        return inside, np.zeros((flat.shape[0], 0))
    # Linear interpolation of every pixel: weights of the two bracketing samples.
    upper = np.clip(np.searchsorted(wavelengths, grid, side="right"), 1, wavelengths.size - 1)
    lower = upper - 1
    t = (grid - wavelengths[lower]) / (wavelengths[upper] - wavelengths[lower])
    out = flat[:, lower] * (1.0 - t) + flat[:, upper] * t
    return inside, out


def spectral_image_to_xyz(image: SpectralImage, illuminant=None) -> np.ndarray:
    """CIE 1931 2° XYZ (H, W, 3) of a spectral image, as the reference's preview.

    The spectrum is linearly interpolated onto 1 nm steps over 360–830 nm, within
    its own wavelength range only (zero outside; a single-wavelength image gives
    0). Emissive images: ``XYZ = Σ L(λ) x̄(λ) Δλ`` (no 683 lm/W factor, like the
    reference), ``illuminant`` must be None. Reflective images: lit by
    ``illuminant`` (a CIE name known to :func:`spectra.illuminant`, or any
    :data:`spectra.SpectrumLike`; default ``"D65"``) and divided by
    ``Σ E(λ) ȳ(λ) Δλ`` over the same range, so a perfect white has Y = 1.
    """
    from ..colour import spectra

    wl = np.asarray(image.wavelengths, dtype=np.float64)
    values = np.asarray(image.values)
    if values.ndim != 3 or values.shape[-1] != wl.size:
        raise ValueError(f"values of shape {values.shape} do not match {wl.size} wavelengths")
    inside, samples = _interp_on_cmf_grid(wl, values)
    cmf = np.asarray(spectra.cmfs(_CMF_GRID))[inside]
    if image.kind == "emissive":
        if illuminant is not None:
            raise ValueError("an emissive image is not lit: illuminant must be None")
        xyz = samples @ cmf if samples.shape[1] else np.zeros((samples.shape[0], 3))
    elif image.kind == "reflective":
        source = "D65" if illuminant is None else illuminant
        if isinstance(source, str):
            light = spectra.illuminant(source, _CMF_GRID)
        else:
            light = spectra.spectrum_values(source, _CMF_GRID)
        light = light[inside]
        if samples.shape[1] == 0:
            xyz = np.zeros((samples.shape[0], 3))
        else:
            white = float(light @ cmf[:, 1])
            if not white > 0:
                raise ValueError("the illuminant has no luminance over the image's wavelengths")
            xyz = (samples * light) @ cmf / white
    else:
        raise ValueError(f"unknown kind {image.kind!r}")
    return xyz.reshape(values.shape[:2] + (3,))


def spectral_image_to_rgb(image: SpectralImage, illuminant=None, ev: float = 0.0
                          ) -> np.ndarray:
    """Linear sRGB (D65) preview (H, W, 3): :func:`spectral_image_to_xyz`, the sRGB
    matrix of colour-science, negatives clamped to 0, times 2^ev (as the reference)."""
    import colour

    xyz = spectral_image_to_xyz(image, illuminant)
    matrix = np.asarray(colour.RGB_COLOURSPACES["sRGB"].matrix_XYZ_to_RGB)
    rgb = np.maximum(xyz @ matrix.T, 0.0) * 2.0 ** float(ev)
    return rgb


# --------------------------------------------------------------------------- writing


def write_spectral_exr(
    path: str | Path,
    wavelengths_nm,
    values,
    *,
    kind: str = "reflective",
    units: str | None = None,
    rgb_preview: bool = True,
    attributes: dict | None = None,
    allow_invalid: bool = False,
) -> Path:
    """Write an (H, W, L) spectral image (row 0 at the bottom) in the spectral layout.

    Parameters
    ----------
    wavelengths_nm : array (L,)
        Strictly increasing, within :data:`WAVELENGTH_LIMITS_NM` (nm).
    values : array (H, W, L)
        Stored as float32 (see the module docstring); emissive → ``S0`` channels,
        reflective → ``T`` channels.
    kind : {"reflective", "emissive"}
    units : str or None
        ``emissiveUnits`` of an emissive image; default :data:`EMISSIVE_UNITS`
        (the reference's value). Reflective spectra are unitless: must be None.
    rgb_preview : bool
        Also store ``R``, ``G``, ``B`` (:func:`spectral_image_to_rgb`; reflective
        spectra under D65), as the reference writer always does.
    attributes : dict or None
        Extra header attributes (str, int or float values); the layout's own
        (``spectralLayoutVersion``, ``emissiveUnits``, ``polarisationHandedness``,
        ``EV``) are written by this function and refused here.
    allow_invalid : bool
        Write NaN/inf samples and samples beyond ±:data:`MAX_SAMPLE` instead of raising
        (for testing readers).

    The file is written under a temporary name beside ``path`` and renamed.
    """
    import OpenEXR

    path = Path(path)
    if kind not in KINDS:
        raise ValueError(f"kind must be 'reflective' or 'emissive', got {kind!r}")
    wl = np.asarray(wavelengths_nm, dtype=np.float64)
    if wl.ndim != 1 or wl.size == 0:
        raise ValueError(f"wavelengths must be a non-empty 1-D array, got shape {wl.shape}")
    if not (np.isfinite(wl).all() and (wl > 0).all()):
        raise ValueError("wavelengths must be finite and positive")
    low, high = WAVELENGTH_LIMITS_NM
    if wl.min() < low or wl.max() > high:
        raise ValueError(f"wavelengths must lie within {low:g}–{high:g} nm (the reader "
                         f"refuses others), got {wl.min():g}–{wl.max():g}")
    if wl.size > 1 and np.any(np.diff(wl) <= 0):
        raise ValueError("wavelengths must be strictly increasing (no duplicates)")
    data = np.asarray(values)
    if data.ndim != 3 or data.shape[-1] != wl.size or 0 in data.shape:
        raise ValueError(f"values must be (H, W, {wl.size}) with H, W ≥ 1, got {data.shape}")
    if data.size > MAX_SAMPLES:
        raise ValueError(f"{data.size:,} samples exceed the {MAX_SAMPLES:,} limit")
    with np.errstate(over="ignore", invalid="ignore"):
        stored = np.asarray(data, dtype=np.float32)
    if not allow_invalid and not np.isfinite(stored).all():
        bad = int((~np.isfinite(stored)).sum())
        raise ValueError(f"{path}: refusing to write {bad} non-finite samples (after "
                         "conversion to float32)")
    if not allow_invalid:  # all finite here: only the magnitude is left to check
        extreme = int(np.count_nonzero(extreme_mask(stored)))
        if extreme:
            raise ValueError(f"{path}: refusing to write {extreme} samples beyond "
                             f"±{MAX_SAMPLE:g} (the reader refuses them)")
    if kind == "reflective" and units is not None:
        raise ValueError("reflective spectra are unitless: pass units=None")
    header_extra: dict = {"spectralLayoutVersion": LAYOUT_VERSION, "EV": 0.0}
    if kind == "emissive":
        header_extra["emissiveUnits"] = EMISSIVE_UNITS if units is None else str(units)
    for key, value in (attributes or {}).items():
        if not isinstance(key, str) or not key:
            raise ValueError(f"attribute names must be non-empty strings, got {key!r}")
        if key in _RESERVED or key in _STRUCTURAL:
            raise ValueError(f"attribute {key!r} is set by the layout or by OpenEXR")
        if isinstance(value, bool) or not isinstance(value, str | int | float):
            raise ValueError(f"attribute {key!r}: only str, int and float values are written")
        header_extra[key] = value

    names = [channel_name(kind, w) for w in wl]
    parsed = [parse_channel_name(n) for n in names]
    if any(p is None or p[2] != w for p, w in zip(parsed, wl)):  # belt and braces
        raise ValueError("internal error: channel names do not give back the wavelengths")
    flipped = stored[::-1]
    channels = {name: np.ascontiguousarray(flipped[:, :, i]) for i, name in enumerate(names)}
    if rgb_preview:
        image = SpectralImage(wl, np.nan_to_num(stored, nan=0.0, posinf=0.0, neginf=0.0),
                              kind)
        rgb = spectral_image_to_rgb(image).astype(np.float32)[::-1]
        for c, name in enumerate("RGB"):
            channels[name] = np.ascontiguousarray(rgb[:, :, c])
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    header.update(header_extra)
    with atomic_path(path, ".tmp.exr") as temporary, OpenEXR.File(header, channels) as exr:
        exr.write(os.fsencode(temporary))
    return path


# --------------------------------------------------------------------------- reading


class _Invalid(Exception):
    """Internal: a problem found while reading, raised again with the path."""


def _plain(value):
    """Header values as plain Python (numpy scalars/arrays → float/int/list)."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, tuple | list):
        return [_plain(v) for v in value]
    return value


def _window_size(header: dict) -> tuple[int, int]:
    window = header.get("dataWindow")
    try:
        (x0, y0), (x1, y1) = ((int(a), int(b)) for a, b in window)
    except (TypeError, ValueError) as exc:
        raise _Invalid(f"no usable dataWindow ({exc})") from None
    width, height = x1 - x0 + 1, y1 - y0 + 1
    if width < 1 or height < 1:
        raise _Invalid(f"dataWindow {(x0, y0)}–{(x1, y1)} is empty")
    return height, width


def _select(names: list[str], kind: str | None) -> tuple[str, list[tuple[float, str]], list[str]]:
    """Pick the kind to read; (kind, sorted [(nm, channel)], notes). Raises _Invalid."""
    layers: dict[str, list[tuple[float, str]]] = {}
    bispectral = 0
    for name in names:
        try:
            parsed = parse_channel_name(name)
        except ValueError as exc:
            raise _Invalid(str(exc)) from None
        if parsed is None:
            bispectral += bool(_BISPECTRAL.fullmatch(name))
            continue
        low, high = WAVELENGTH_LIMITS_NM
        if not low <= parsed[2] <= high:
            raise _Invalid(f"channel {name!r} gives wavelength {parsed[2]:g} nm, outside "
                           f"{low:g}–{high:g} nm (a damaged name or a wrong unit)")
        layer = "T" if parsed[0] == "reflective" else f"S{parsed[1]}"
        layers.setdefault(layer, []).append((parsed[2], name))
    for layer, entries in layers.items():
        entries.sort()
        wl = np.array([w for w, _ in entries])
        same = np.nonzero(np.isclose(wl[1:], wl[:-1], rtol=1e-9, atol=0.0))[0]
        if same.size:
            a, b = entries[same[0]][1], entries[same[0] + 1][1]
            raise _Invalid(f"channels {a!r} and {b!r} of layer {layer} give the same "
                           f"wavelength ({entries[same[0]][0]:g} nm)")
    present = [k for k in KINDS if _LAYER[k] in layers]
    stokes = [s for s in ("S1", "S2", "S3") if s in layers]
    if not layers:
        raise _Invalid("no spectral channels (S0–S3.<λ> or T.<λ>): not a spectral image "
                       f"(channels: {', '.join(names[:8])}{'...' if len(names) > 8 else ''})")
    if stokes and "S0" not in layers:
        raise _Invalid(f"Stokes layers {', '.join(stokes)} without S0")
    notes: list[str] = []
    if kind is None:
        if len(present) > 1:
            raise _Invalid("holds both emissive (S0) and reflective (T) spectra: choose one "
                           "with kind='emissive' or kind='reflective'")
        kind = present[0]
    elif kind not in present:
        raise _Invalid(f"has no {kind} channels ({_LAYER[kind]}.<λ>); it holds "
                       f"{' and '.join(present)}")
    other = [k for k in present if k != kind]
    if other:
        notes.append(f"{other[0]} channels also present, not read (kind={kind!r} chosen)")
    if kind == "emissive" and stokes:
        if len(stokes) != 3:
            raise _Invalid(f"polarised image with Stokes layers S0, {', '.join(stokes)}: "
                           "the layout needs all of S0–S3")
        s0 = [w for w, _ in layers["S0"]]
        for s in stokes:
            ws = [w for w, _ in layers[s]]
            if len(ws) != len(s0) or not np.allclose(ws, s0, rtol=1e-9, atol=0.0):
                raise _Invalid(f"Stokes layer {s} has other wavelengths than S0")
        notes.append("polarised: Stokes components S1–S3 present, only S0 (total radiance) "
                     "read")
    if bispectral:
        notes.append(f"bi-spectral: {bispectral} re-radiation channels T.<λi>.<λo> "
                     "skipped, only the diagonal T read")
    return kind, layers[_LAYER[kind]], notes


def _scan(values: np.ndarray, clamp: bool) -> dict:
    """Counts of NaN, inf and negative samples (set to 0 with ``clamp``), chunk by chunk;
    raises _Invalid for finite samples beyond ±MAX_SAMPLE, which no mode keeps."""
    counts = {"nan": 0, "inf": 0, "negative": 0}
    extreme, largest = 0, 0.0
    flat = values.reshape(-1)
    step = 1 << 22
    for begin in range(0, flat.size, step):
        chunk = flat[begin: begin + step]
        nan, inf = np.isnan(chunk), np.isinf(chunk)
        with np.errstate(invalid="ignore"):
            neg = chunk < 0
        huge = extreme_mask(chunk)
        counts["nan"] += int(nan.sum())
        counts["inf"] += int(inf.sum())
        counts["negative"] += int(neg.sum())
        if huge.any():
            extreme += int(huge.sum())
            largest = max(largest, float(np.abs(chunk[huge]).max()))
        if clamp:
            chunk[nan | inf | neg] = 0.0
    if extreme:
        raise _Invalid(f"{extreme:,} samples beyond ±{MAX_SAMPLE:g} (largest magnitude "
                       f"{largest:g}): not a measurement, and they overflow later arithmetic")
    return counts


def _read(path: Path, kind: str | None, on_invalid: str) -> SpectralImage:
    import OpenEXR

    with open(path, "rb") as stream:
        magic = stream.read(4)
    if magic != _MAGIC:
        raise _Invalid("not an OpenEXR file (bad magic number)")
    # 1. The header alone: names, sizes, limits.
    _exr.check_decoded_size(path, _exr.read_layout(path, error=InvalidSpectralImage),
                            max_pixels=MAX_SAMPLES, error=InvalidSpectralImage)
    try:
        with _exr.open_exr(path, header_only=True) as exr:
            parts = len(exr.parts)
            header = dict(exr.header()) if parts == 1 else {}
            listed = list(header.get("channels") or [])
            names = [str(c.name) for c in listed]
            sampling = {n: (int(c.xSampling), int(c.ySampling)) for n, c in zip(names, listed)}
    except Exception as exc:  # RuntimeError, UnicodeDecodeError... from the library
        raise _Invalid(f"damaged or truncated OpenEXR header ({type(exc).__name__}: {exc})"
                       ) from None
    if parts != 1:
        raise _Invalid(f"multi-part file ({parts} parts); one part expected")
    storage = header.get("type")
    if storage is not None and storage not in (OpenEXR.scanlineimage, OpenEXR.tiledimage):
        raise _Invalid(f"{storage} parts are not supported (flat scanline or tiled only)")
    height, width = _window_size(header)
    if not 1 <= len(names) <= MAX_CHANNELS:
        raise _Invalid(f"header lists {len(names)} channels (1..{MAX_CHANNELS} accepted)")
    if len(set(names)) != len(names):
        raise _Invalid("header lists a channel twice")
    total = width * height * len(names)
    if total > MAX_SAMPLES:
        raise _Invalid(f"header declares {width}×{height} pixels × {len(names)} channels = "
                       f"{total:,} samples, over the {MAX_SAMPLES:,} limit")
    kind, entries, notes = _select(names, kind)
    for _, name in entries:
        if sampling[name] != (1, 1):
            raise _Invalid(f"channel {name!r} is subsampled ({sampling[name]})")
    # 2. The pixels.
    try:
        exr = _exr.open_exr(path, separate_channels=True)
        channels = exr.channels()
    except Exception as exc:
        raise _Invalid(f"damaged or truncated pixel data ({type(exc).__name__}: {exc})"
                       ) from None
    with exr:
        values = np.empty((height, width, len(entries)), dtype=np.float32)
        for i, (_, name) in enumerate(entries):
            channel = channels.get(name)
            if channel is None:
                raise _Invalid(f"channel {name!r} listed in the header but not read")
            pixels = np.asarray(channel.pixels)
            if pixels.shape != (height, width) or pixels.dtype.kind not in "fu":
                raise _Invalid(f"channel {name!r} read as {pixels.dtype} {pixels.shape}, "
                               f"expected ({height}, {width}) floats")
            values[:, :, i] = pixels[::-1]
    counts = _scan(values, clamp=on_invalid == "clamp")
    if on_invalid == "raise" and any(counts.values()):
        raise _Invalid(f"{counts['nan']} NaN, {counts['inf']} inf and {counts['negative']} "
                       f"negative samples of {values.size:,}")
    attributes = {k: _plain(v) for k, v in header.items() if k not in _STRUCTURAL}
    version = attributes.get("spectralLayoutVersion")
    if version != LAYOUT_VERSION:
        notes.append(f"spectralLayoutVersion is {version!r}, not {LAYOUT_VERSION!r}: read as "
                     f"{LAYOUT_VERSION}")
    if kind == "emissive" and "emissiveUnits" not in attributes:
        notes.append(f"no emissiveUnits attribute: {EMISSIVE_UNITS} assumed")
    handedness = attributes.get("polarisationHandedness")
    if handedness is not None and handedness not in ("left", "right"):
        raise _Invalid(f"polarisationHandedness is {handedness!r}, not 'left' or 'right'")
    wavelengths = np.array([w for w, _ in entries], dtype=np.float64)
    return SpectralImage(wavelengths=wavelengths, values=values, kind=kind,
                         attributes=attributes, defects=counts, notes=notes, path=path)


def read_spectral_exr(path: str | Path, *, kind: str | None = None,
                      on_invalid: str = "keep") -> SpectralImage:
    """Read one kind of spectra from a spectral OpenEXR file (see the module docstring).

    Parameters
    ----------
    kind : {"reflective", "emissive"} or None
        Which spectra to read; None (default) reads the only kind present and
        refuses files that hold both.
    on_invalid : {"keep", "raise", "clamp"}
        NaN, inf and negative samples are always counted in ``defects``; keep
        them, raise, or set them to 0.

    Raises
    ------
    SpectralEXRFileNotFound
        If there is no such file (a ValueError and a FileNotFoundError).
    InvalidSpectralImage
        (a ``ValueError``) for anything else: not an OpenEXR file, truncated or
        damaged, no spectral channels, malformed or duplicate wavelengths, both
        kinds and no ``kind``, sizes over the limits... The message names the file.
    """
    if kind is not None and kind not in KINDS:
        raise ValueError(f"kind must be None, 'reflective' or 'emissive', got {kind!r}")
    if on_invalid not in ("keep", "raise", "clamp"):
        raise ValueError(f"on_invalid must be 'keep', 'raise' or 'clamp', got {on_invalid!r}")
    path = Path(path)
    if not path.exists():
        raise SpectralEXRFileNotFound(f"{path}: no such file")
    if not path.is_file():
        raise InvalidSpectralImage(f"{path}: not a regular file")
    try:
        return _read(path, kind, on_invalid)
    except InvalidSpectralImage:
        raise
    except _Invalid as exc:
        raise InvalidSpectralImage(f"{path}: {exc}") from None
    except PermissionError:
        raise
    except MemoryError:
        raise InvalidSpectralImage(f"{path}: not enough memory to read its pixels") from None
    except Exception as exc:  # OpenEXR raises RuntimeError & co for damaged files
        raise InvalidSpectralImage(f"{path}: unreadable or damaged OpenEXR file "
                                   f"({type(exc).__name__}: {exc})") from None
