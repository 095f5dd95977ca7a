"""A light's spectral power distribution, read on the main thread into plain data.

:func:`light_spd` reads and validates what a light's Spectral settings describe (a CIE
illuminant, a blackbody, a typed-in or CSV spectrum) and raises :class:`SourceError`
naming the light and the problem. The factor-pack sources (``brdf.sources``) share the
error, the wavelengths and the typed/CSV reader: a material's spectra are read the same way.
"""

from __future__ import annotations

import math

import bpy
import numpy as np

from ...core.colour import spectra, spectrum_library

WAVELENGTHS = spectra.WAVELENGTHS_REFERENCE


class SourceError(ValueError):
    """A material or light cannot be used as described; the message says why."""


def finite(name: str, value: float) -> float:
    """``value`` as a float; SourceError naming ``name`` when it is not finite."""
    value = float(value)
    if not math.isfinite(value):
        raise SourceError(f"{name} is {value}; type a finite number")
    return value


def abspath(path: str) -> str:
    """A Blender path (``//`` relative to the .blend) made absolute; "" stays ""."""
    return bpy.path.abspath(path) if path else ""


def typed_or_csv(group) -> np.ndarray:
    """A spectrum typed into ``group.text`` (kind TEXT) or read from ``group.filepath``."""
    if group.kind == "TEXT":
        pair = spectrum_library.parse_spectrum_text(group.text)
    else:
        path = abspath(group.filepath)
        if not path:
            raise SourceError("no CSV file chosen")
        pair = spectrum_library.read_spectrum_csv(path)
    return spectrum_library.spectrum_to_grid(*pair, WAVELENGTHS)


def light_spd(light) -> np.ndarray:
    """A light's SPD × power on :data:`WAVELENGTHS` (main thread only)."""
    s = light.spectral
    name = f"Light '{light.name}'"
    power = finite(f"{name}: power", s.power)
    if power < 0:
        raise SourceError(f"{name}: power must be ≥ 0, got {power}")
    try:
        if s.kind == "ILLUMINANT":
            spd = spectra.illuminant(s.illuminant, WAVELENGTHS)
        elif s.kind == "BLACKBODY":
            spd = spectrum_library.blackbody_spd(finite(f"{name}: temperature", s.temperature),
                                                 WAVELENGTHS)
        else:
            spd = typed_or_csv(s)
        spectrum_library.check_spd(spd, name)
    except (ValueError, OSError) as exc:
        message = str(exc)
        raise SourceError(message if message.startswith(name) else f"{name}: {message}") \
            from None
    return spd * power
