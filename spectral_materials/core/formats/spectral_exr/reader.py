"""Reading spectral OpenEXR files: the header checked before any pixel is decoded, one
kind of spectra chosen, the samples scanned for NaN, inf, negative and absurd values."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...sample_limits import MAX_SAMPLE, WAVELENGTH_LIMITS_NM, extreme_mask
from .. import exr as _exr
from .layout import (
    _BISPECTRAL,
    _LAYER,
    _STRUCTURAL,
    EMISSIVE_UNITS,
    KINDS,
    LAYOUT_VERSION,
    MAX_CHANNELS,
    MAX_SAMPLES,
    InvalidSpectralImage,
    SpectralEXRFileNotFound,
    SpectralImage,
    parse_channel_name,
)

_MAGIC = b"\x76\x2f\x31\x01"


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



def _read_header(path: Path) -> tuple[dict, list[str], dict, int, int]:
    """The header alone: names, sizes, limits. Returns (header, channel names, their
    sampling, height, width)."""
    import OpenEXR

    with open(path, "rb") as stream:
        magic = stream.read(4)
    if magic != _MAGIC:
        raise _Invalid("not an OpenEXR file (bad magic number)")
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
    return header, names, sampling, height, width


def _read_pixels(path: Path, entries: list[tuple[float, str]], height: int, width: int
                 ) -> np.ndarray:
    """(H, W, L) float32 of the chosen channels, row 0 at the bottom."""
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
    return values


def _attributes(header: dict, kind: str, notes: list[str]) -> dict:
    """The header's non-structural attributes; notes what the layout's are missing."""
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
    return attributes


def _read(path: Path, kind: str | None, on_invalid: str) -> SpectralImage:
    # 1. The header alone: names, sizes, limits.
    header, names, sampling, height, width = _read_header(path)
    kind, entries, notes = _select(names, kind)
    for _, name in entries:
        if sampling[name] != (1, 1):
            raise _Invalid(f"channel {name!r} is subsampled ({sampling[name]})")
    # 2. The pixels.
    values = _read_pixels(path, entries, height, width)
    counts = _scan(values, clamp=on_invalid == "clamp")
    if on_invalid == "raise" and any(counts.values()):
        raise _Invalid(f"{counts['nan']} NaN, {counts['inf']} inf and {counts['negative']} "
                       f"negative samples of {values.size:,}")
    attributes = _attributes(header, kind, notes)
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
