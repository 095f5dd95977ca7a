"""Plot images for panels: a light's SPD, drawn outside ``draw()`` (which may not write data).

A panel asks for :func:`light_plot`; when the picture is missing or stale it schedules
a one-shot timer that redraws it, and shows the old picture (or none) meanwhile.
"""

from __future__ import annotations

import hashlib

import bpy

from ...core.raster_plots import plot_spectrum
from ..images import new_float_image, remove_image
from .spd import WAVELENGTHS, SourceError, light_spd

SPD_PREFIX = "SM SPD "
_pending: set[str] = set()


def _key(light) -> str:
    s = light.spectral
    fields = (s.kind, s.illuminant, f"{s.temperature:.6g}", s.text, s.filepath, light.name)
    return hashlib.sha1("|".join(fields).encode()).hexdigest()


def refresh_light_plot(light) -> None:
    """Draw the SPD picture of ``light`` now (not from a panel's draw)."""
    spd = light_spd(light) / max(light.spectral.power, 1e-30)
    pixels = plot_spectrum(WAVELENGTHS, spd)
    old = light.spectral.plot
    light.spectral.plot = new_float_image(SPD_PREFIX + light.name, pixels, data=False)
    light.spectral.plot_key = _key(light)
    remove_image(old)


def _refresh_later(light_name: str) -> None:
    if light_name in _pending:
        return
    _pending.add(light_name)

    def run():
        _pending.discard(light_name)
        light = bpy.data.lights.get(light_name)
        if light is not None:
            try:
                refresh_light_plot(light)
            except SourceError:
                pass              # the panel shows the error itself
        return None

    bpy.app.timers.register(run, first_interval=0.01)


def light_plot(light):
    """The light's SPD picture, scheduling a redraw if it is stale; raises SourceError."""
    light_spd(light)          # validates; the panel shows the message
    if light.spectral.plot is None or light.spectral.plot_key != _key(light):
        _refresh_later(light.name)
    return light.spectral.plot


