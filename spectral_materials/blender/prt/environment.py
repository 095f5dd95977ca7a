"""The scene's spectral environment as samples: a CIE sky, an HDR image or a spectral EXR
(cached by its inputs), projected on SH × a basis, and unprojected for the reference."""

from __future__ import annotations

from dataclasses import dataclass

import bpy
import numpy as np

from ...core.prt import environment as core_environment
from .inputs import BASIS_SAMPLES, WAVELENGTHS, PRTError, cached, file_key, image_rgb


def sun_direction(env) -> np.ndarray:
    el, az = float(env.sun_elevation), float(env.sun_azimuth)
    return np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])


def environment_inputs(scene) -> tuple[tuple, dict]:
    """(key, inputs) of the scene's environment source, without projecting anything."""
    env = scene.spectral.environment
    if env.source == "SKY":
        key = ("SKY", env.illuminant, env.sky, round(env.sun_fraction, 6),
               round(env.sun_elevation, 6), round(env.sun_azimuth, 6))
        sun = sun_direction(env) if env.sun_fraction > 0 else None
        if sun is not None and sun[2] <= 0:
            raise PRTError("Environment: the sun is below the horizon; raise its elevation")
        return key, {"kind": "SKY", "illuminant": env.illuminant, "sky": env.sky.lower(),
                     "sun_direction": sun, "sun_fraction": float(env.sun_fraction)}
    if env.source == "IMAGE":
        image = env.image
        if image is None:
            raise PRTError("Environment: choose an HDR image")
        key = ("IMAGE", image.name, tuple(image.size), image.filepath, image.is_dirty)
        return key, {"kind": "IMAGE", "image": image}
    if not env.filepath:
        raise PRTError("Environment: choose a spectral EXR file")
    return ("SPECTRAL_EXR",) + file_key(env.filepath), {"kind": "SPECTRAL_EXR",
                                                          "path": bpy.path.abspath(
                                                              env.filepath)}


@dataclass
class EnvironmentData:
    """The environment's radiance as samples the projections start from."""

    key: tuple
    kind: str
    spd: np.ndarray | None = None          # SKY: the illuminant on WAVELENGTHS
    values: np.ndarray | None = None       # maps: (H, W, C), row 0 at the top
    wavelengths: np.ndarray | None = None  # spectral maps: the file's wavelengths
    rgb: bool = False
    sky: dict | None = None

    def basis_spectra(self) -> np.ndarray:
        """Spectra (n, L) on WAVELENGTHS that the PRT basis must represent."""
        if self.kind == "SKY":
            return self.spd[None]
        h, w = self.values.shape[:2]
        step = max(1, int(np.sqrt(h * w / BASIS_SAMPLES)))
        block = np.clip(self.values[::step, ::step].reshape(-1, self.values.shape[2]), 0, None)
        if self.rgb:
            from ...core.colour.uplift import SmitsUplift

            block = SmitsUplift()(block, WAVELENGTHS)
        # Black pixels carry no spectrum (and would be refused as an illuminant).
        lit = block[block.sum(axis=1) > 0]
        return lit if len(lit) else np.ones((1, WAVELENGTHS.size))


def environment_data(scene) -> EnvironmentData:
    """The scene environment's samples (cached by its inputs)."""
    key, inputs = environment_inputs(scene)

    def build() -> EnvironmentData:
        from ...core.colour.pipeline import illuminant_spd

        if inputs["kind"] == "SKY":
            return EnvironmentData(key, "SKY", spd=illuminant_spd(inputs["illuminant"],
                                                                  WAVELENGTHS),
                                   sky=inputs)
        if inputs["kind"] == "IMAGE":
            rgb = image_rgb(inputs["image"], "Environment")[::-1]      # row 0 at the top
            return EnvironmentData(key, "IMAGE", values=np.ascontiguousarray(rgb), rgb=True)
        try:
            values, wl, rgb = core_environment.read_environment_map(inputs["path"])
        except (ValueError, OSError) as exc:
            raise PRTError(f"Environment: {exc}") from None
        if rgb:
            return EnvironmentData(key, "SPECTRAL_EXR", values=values, rgb=True)
        # Spectral maps are resampled once to the PRT wavelengths.
        resampled = np.stack([np.interp(WAVELENGTHS, wl, row) for row in
                              values.reshape(-1, values.shape[2])])
        return EnvironmentData(key, "SPECTRAL_EXR",
                               values=resampled.reshape(values.shape[:2] + (-1,)),
                               wavelengths=WAVELENGTHS)

    return cached("environment_data", key, build)


def project(data: EnvironmentData, basis: np.ndarray | None, bands: int,
             window: str) -> core_environment.SpectralEnvironment:
    if data.kind == "SKY":
        s = data.sky
        return core_environment.sky_environment(
            s["illuminant"], WAVELENGTHS, basis, sky=s["sky"], sun_direction=s["sun_direction"],
            sun_fraction=s["sun_fraction"], bands=bands, window=window)
    return core_environment.equirect_environment(data.values, WAVELENGTHS, basis, rgb=data.rgb,
                                                 bands=bands, window=window)


def rotation_z(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def reference_environment(scene):
    """The scene environment unprojected (``core.prt_reference.ReferenceEnvironment``),
    world frame, scene rotation applied: what the PRT colours are measured against."""
    data = environment_data(scene)
    rotation = float(scene.spectral.environment.rotation)
    if data.kind == "SKY":
        s = data.sky
        reference = core_environment.sky_reference(
            s["illuminant"], WAVELENGTHS, sky=s["sky"], sun_direction=s["sun_direction"],
            sun_fraction=s["sun_fraction"])
    else:
        reference = core_environment.equirect_reference(data.values, WAVELENGTHS, rgb=data.rgb)
    return reference.rotated(rotation_z(rotation)) if rotation else reference

