"""RGB quantities for renderers without spectra (EEVEE): the key light's per-term weights,
light colours, and a Lambert + GGX fit prefiltered under a light's spectrum, in Blender's
scene-linear working space.

``scene_linear_matrix(adaptation_white, working_space)`` maps protocol XYZ to scene-
linear RGB as the draw path's display pipeline does before its tone map: Bradford from
the scene's adaptation white to D65, then the working space's primaries.
"""

from __future__ import annotations

import colour
import numpy as np

from ..colour import pipeline as colour_pipeline, spectra
from ..lights import SpectralLight
from . import metrics
from .factored import FactoredBRDF

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


def key_light_lobe_rgb_weights(model: FactoredBRDF, light: SpectralLight,
                               to_rgb: np.ndarray) -> np.ndarray | None:
    """(2, 3): RGB reflected per unit irradiance by each of the analytic lobe's two terms
    (``core.brdf.lobe``), as :func:`key_light_rgb_weights` for the packs; None without
    a lobe."""
    if model.lobe is None:
        return None
    xyz = np.asarray(model.lobe.spectral, dtype=np.float64).T @ light.weights(
        model.wavelengths, model.basis)
    return xyz @ np.asarray(to_rgb, dtype=np.float64).T


def light_rgb(light: SpectralLight, to_rgb: np.ndarray) -> np.ndarray:
    """The scene-linear RGB of a light's SPD, normalised as the protocol (Y = 1): the colour
    an RGB renderer must give the light so that a white surface matches the spectral path."""
    white = light.weights(light.wavelengths, None).sum(axis=0) / np.pi
    return np.asarray(to_rgb, dtype=np.float64) @ white


def clamped_xyz(xyz: np.ndarray, to_rgb: np.ndarray) -> np.ndarray:
    """XYZ after a renderer that clamps negative scene-linear RGB (as EEVEE does)."""
    to_rgb = np.asarray(to_rgb, dtype=np.float64)
    return np.clip(np.asarray(xyz) @ to_rgb.T, 0.0, None) @ np.linalg.inv(to_rgb).T


def key_light_error(brdf, model: FactoredBRDF, light: SpectralLight, to_rgb: np.ndarray,
                    count: int = 4000) -> dict:
    """ΔE94 of the key-light term as EEVEE shows it (the factors with their XYZ clamped at
    0, then the clamp of negative RGB) against the 5 nm reference under the light's SPD,
    at the protocol's random pairs."""
    wi, wo = metrics.random_direction_pairs(count)
    reference_spd = light.spd_on(spectra.WAVELENGTHS_REFERENCE)
    reference = metrics.reference_xyz(brdf, wi, wo, reference_spd)
    test = clamped_xyz(model.xyz(wi, wo, light.spd_on(model.wavelengths)), to_rgb)
    return metrics.delta_e94_stats(reference, test, reference_spd)


def _ggx_basis(wi: np.ndarray, wo: np.ndarray, alpha: float) -> np.ndarray:
    """π · D·G / (4 cos θo) (Smith GGX, no Fresnel): a specular lobe's ``XYZ`` per unit F0
    in the protocol's normalisation (``f·cosθi`` times π)."""
    h = wi + wo
    h = h / np.linalg.norm(h, axis=1, keepdims=True)
    a2 = alpha * alpha
    cos_h = np.clip(h[:, 2], 0.0, 1.0)
    d = a2 / (np.pi * (cos_h * cos_h * (a2 - 1.0) + 1.0) ** 2)

    def g1(cos):
        return 2.0 * cos / (cos + np.sqrt(a2 + (1.0 - a2) * cos * cos))

    return np.pi * d * g1(wi[:, 2]) * g1(wo[:, 2]) / (4.0 * wo[:, 2])


def fill_light(lights: list[tuple[SpectralLight, float]],
               wavelengths: np.ndarray = spectra.WAVELENGTHS_REFERENCE) -> SpectralLight | None:
    """A sun whose SPD mixes ``lights`` (light, irradiance at the material) by irradiance,
    each SPD scaled to unit luminance; None when none brings light.

    The EEVEE path shades every light but its key light in RGB through a Principled BSDF
    (``fit_principled``); fitted under this spectrum, the fit's von Kries colour is exact
    for a single such light and weighted towards the brightest of several.
    """
    wl = spectra.check_wavelengths(wavelengths)
    y_bar = spectra.cmfs(wl)[:, 1] * spectra.sample_weights(wl)
    mixed = np.zeros(wl.size)
    for light, irradiance in lights:
        spd = light.spd_on(wl)
        luminance = float(spd @ y_bar)
        if irradiance > 0 and luminance > 0:
            mixed += irradiance * spd / luminance
    if not mixed.any():
        return None
    return SpectralLight("SUN", mixed / float(mixed @ y_bar), wl, name="fill")


def fit_principled(model: FactoredBRDF, light: SpectralLight, to_rgb: np.ndarray,
                   count: int = 20000) -> dict:
    """A Lambert + GGX fit of the model under ``light`` for an RGB Principled BSDF.

    Least squares over the protocol's uniform pairs: luminance first, for the lobe's
    roughness α (a grid search) and its white specular weight, then each RGB channel's
    diffuse weight with the lobe fixed. The diffuse colour is divided by the light's own
    RGB (``light_rgb``; von Kries), so that an RGB renderer multiplying it by a light's
    colour gets the spectral product exactly for this light and approximately for
    others. Returns ``base_color`` (RGB),
    ``roughness`` (Blender's: √α), ``specular`` (F0), and the fit's relative RMS.
    """
    from scipy.optimize import nnls

    wi, wo = metrics.random_direction_pairs(count)
    xyz = model.xyz(wi, wo, light.spd_on(model.wavelengths))
    rgb = xyz @ np.asarray(to_rgb, dtype=np.float64).T
    luminance = xyz[:, 1]
    diffuse = wi[:, 2]
    best = None
    for alpha in np.geomspace(0.02, 1.0, 40):
        basis = np.stack([diffuse, _ggx_basis(wi, wo, alpha)], axis=1)
        weights, residual = nnls(basis, luminance)
        if best is None or residual < best[2]:
            best = (alpha, weights, residual)
    alpha, (kd, ks), residual = best
    lobe = ks * _ggx_basis(wi, wo, alpha)
    base = np.array([max(float(np.dot(diffuse, rgb[:, c] - lobe) / np.dot(diffuse, diffuse)),
                         0.0) for c in range(3)])
    base = base / np.maximum(light_rgb(light, to_rgb), 1e-6)
    return {"base_color": np.clip(base, 0.0, 1.0), "roughness": float(np.sqrt(alpha)),
            "specular": float(ks),
            "relative_rms": float(residual / max(np.linalg.norm(luminance), 1e-12))}
