"""RGB quantities for renderers without spectra (EEVEE): the key light's per-term weights
and a spectrally prefiltered albedo, both in Blender's scene-linear Rec.709 (D65).

``scene_linear_matrix(adaptation_white)`` maps protocol XYZ to scene-linear RGB as
the draw path's display pipeline does before its tone map: Bradford from the scene's
adaptation white to D65, then XYZ → linear sRGB.
"""

from __future__ import annotations

import colour
import numpy as np

from . import colour_pipeline, metrics, spectra
from .factored import FactoredBRDF
from .lights import SpectralLight

#: Blender 5.0 working colour spaces → colour-science RGB colourspaces.
WORKING_SPACES = {"Linear Rec.709": "sRGB", "Linear Rec.2020": "ITU-R BT.2020",
                  "ACEScg": "ACEScg"}


def scene_linear_matrix(adaptation_white: np.ndarray,
                        working_space: str = "Linear Rec.709") -> np.ndarray:
    """3 × 3: protocol XYZ → Blender's scene-linear RGB in ``working_space``.

    Bradford from the adaptation white to D65 (as the draw path's display pipeline),
    then the working space's primaries; ACEScg (white ≈ D60) adds a Bradford D65 → its
    white, as a CAT-based OCIO config does.
    """
    if working_space not in WORKING_SPACES:
        raise ValueError(f"unknown working colour space {working_space!r}; "
                         f"known: {', '.join(WORKING_SPACES)}")
    space = colour.RGB_COLOURSPACES[WORKING_SPACES[working_space]]
    to_d65 = colour_pipeline.bradford_matrix(np.asarray(adaptation_white, dtype=np.float64))
    if working_space == "ACEScg":
        to_d65 = colour_pipeline.bradford_matrix(
            colour_pipeline.DISPLAY_WHITE_XYZ, colour.xy_to_XYZ(space.whitepoint)) @ to_d65
    return np.asarray(space.matrix_XYZ_to_RGB, dtype=np.float64) @ to_d65


def key_light_rgb_weights(model: FactoredBRDF, light: SpectralLight,
                          to_rgb: np.ndarray) -> np.ndarray:
    """(terms, 3): RGB reflected per unit irradiance by each rank-one term under ``light``.

    ``Σ_r product_r · W[r]`` is the key light's reflected scene-linear RGB, protocol-
    normalised (a white Lambertian facing a unit sun gives Y = 1): the spectral factor
    folded with the light's SPD × CMFs on the model's basis, then ``to_rgb``.
    """
    if model.form != "cp":
        raise ValueError("the EEVEE path reconstructs CP factor packs; this model is separable")
    xyz = np.asarray(model.spectral, dtype=np.float64).T @ light.weights(model.wavelengths,
                                                                         model.basis)
    return xyz @ np.asarray(to_rgb, dtype=np.float64).T


def light_rgb(light: SpectralLight, to_rgb: np.ndarray) -> np.ndarray:
    """The scene-linear RGB of a light's SPD, normalised as the protocol (Y = 1): the colour
    an RGB renderer must give the light so that a white surface matches the spectral path."""
    white = light.weights(light.wavelengths, None).sum(axis=0) / np.pi
    return np.asarray(to_rgb, dtype=np.float64) @ white


def prefiltered_albedo(model: FactoredBRDF, light: SpectralLight, to_rgb: np.ndarray,
                       count: int = 8000) -> np.ndarray:
    """Diffuse-equivalent RGB albedo of the model, prefiltered under ``light``'s spectrum.

    ``2 · mean(XYZ(wi, wo))`` over the protocol's uniform hemisphere pairs is the
    cosine-weighted reflectance averaged over view directions (1 for a white
    Lambertian); in RGB, divided channel by channel by the light's own RGB, so that an
    RGB renderer multiplying it by a light's colour (``light_rgb``) gets the spectral
    product exactly for this light and approximately for others (von Kries).
    """
    wi, wo = metrics.random_direction_pairs(count)
    xyz = model.xyz(wi, wo, light.spd if np.array_equal(light.wavelengths, model.wavelengths)
                    else np.interp(model.wavelengths, light.wavelengths, light.spd))
    rgb = np.asarray(to_rgb) @ (2.0 * xyz.mean(axis=0))
    return np.clip(rgb / np.maximum(light_rgb(light, to_rgb), 1e-6), 0.0, None)


def clamped_xyz(xyz: np.ndarray, to_rgb: np.ndarray) -> np.ndarray:
    """XYZ after a renderer that clamps negative scene-linear RGB (as EEVEE does)."""
    to_rgb = np.asarray(to_rgb, dtype=np.float64)
    return np.clip(np.asarray(xyz) @ to_rgb.T, 0.0, None) @ np.linalg.inv(to_rgb).T


def key_light_error(brdf, model: FactoredBRDF, light: SpectralLight, to_rgb: np.ndarray,
                    count: int = 4000) -> dict:
    """ΔE94 of the key-light term as EEVEE shows it (the factors, then the clamp of negative
    RGB) against the 5 nm reference under the light's SPD, at the protocol's random pairs."""
    wi, wo = metrics.random_direction_pairs(count)
    spd = light.spd if np.array_equal(light.wavelengths, model.wavelengths) else \
        np.interp(model.wavelengths, light.wavelengths, light.spd)
    reference_spd = np.interp(spectra.WAVELENGTHS_REFERENCE, light.wavelengths,
                              light.spd)
    reference = metrics.reference_xyz(brdf, wi, wo, reference_spd)
    test = clamped_xyz(model.xyz(wi, wo, spd), to_rgb)
    return metrics.delta_e94_stats(reference, test, reference_spd)
