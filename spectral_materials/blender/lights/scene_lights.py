"""The scene as the shaders see it: spectral lights and display settings (main thread)."""

from __future__ import annotations

import numpy as np

from ...core.colour import pipeline as colour_pipeline, spectra
from ...core.lights import SpectralLight
from ..gpu.display import DisplaySettings
from .spd import WAVELENGTHS, SourceError, light_spd
from .visibility import scene_lights

DRAWN_TYPES = {"SUN", "POINT", "SPOT", "AREA"}


def spectral_light(obj) -> SpectralLight:
    """A light object as a :class:`SpectralLight`: world position and axis, its SPD (the
    colour), strength = Blender energy × Spectral Power."""
    light = obj.data
    if light.type not in DRAWN_TYPES:
        raise SourceError(f"Light '{obj.name}': type {light.type} is not drawn")
    matrix = np.array(obj.matrix_world)
    axis = -matrix[:3, 2]
    if not np.linalg.norm(axis) > 0:
        raise SourceError(f"Light '{obj.name}': its transform has zero scale")
    kwargs = {}
    if light.type == "SPOT":
        kwargs = {"spot_size": float(light.spot_size), "spot_blend": float(light.spot_blend)}
    # The SPD sets the colour only (it is normalised); Spectral Power scales the energy.
    return SpectralLight(light.type, light_spd(light), WAVELENGTHS,
                         strength=float(light.energy) * float(light.spectral.power),
                         position=tuple(matrix[:3, 3]),
                         axis=tuple(axis), name=obj.name, **kwargs)


def headlight(scene, toward_viewer: np.ndarray) -> SpectralLight:
    """With no light in the scene: a sun from the viewer in the adaptation white."""
    name = scene.spectral.adaptation_white
    return SpectralLight("SUN", spectra.illuminant(name, WAVELENGTHS),
                         WAVELENGTHS, strength=1.0,
                         axis=tuple(-np.asarray(toward_viewer, dtype=np.float64)),
                         name=f"{name} headlight")


def drawn_lights(scene, toward_viewer=(0.0, 0.0, 1.0)) -> tuple[list[SpectralLight], tuple]:
    """(lights, key): the lights that reach the scene (a headlight if none) and a key
    that changes whenever anything the light textures depend on changes."""
    objects, _ = scene_lights(scene)
    objects = [o for o in objects if o.data.type in DRAWN_TYPES]
    if not objects:
        light = headlight(scene, toward_viewer)
        return [light], ("headlight", light.spd.tobytes(), light.axis)
    lights = [spectral_light(o) for o in objects]
    key = tuple((light.name, light.kind, light.position, light.axis, light.strength,
                 light.spot_cos, light.spot_blend_width, light.spd.tobytes())
                for light in lights)
    return lights, key


def display_settings(scene) -> DisplaySettings:
    """Adaptation white, exposure (Blender's Film exposure, in stops) and tone map."""
    s = scene.spectral
    white = colour_pipeline.white_xyz(s.adaptation_white, WAVELENGTHS)
    tone_white = float(s.tone_white) if s.tone_mapping == "SIGMOID" else 0.0
    return DisplaySettings(scene_white=tuple(white),
                           exposure=float(2.0 ** scene.view_settings.exposure),
                           tone_white=tone_white)
