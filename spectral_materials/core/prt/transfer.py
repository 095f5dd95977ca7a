"""Precomputed radiance transfer: the per-vertex transfer vector from visibility samples.

The spectral PRT paper (Schwenk et al.) renders diffuse, self-shadowed objects under
distant light by splitting the transfer into an achromatic part per vertex,
``T(ω) = V(ω) max(n·ω, 0)`` projected onto spherical harmonics, and a spectral
albedo. This module computes ``T̃`` from visibility samples along a fixed set of
directions shared by every vertex, so that the SH basis is evaluated once:

    T̃_k = Σ_r V(ω_r) max(n·ω_r, 0) Y_k(ω_r) · 4π / R.

Directions are a spherical Fibonacci set (deterministic, nearly uniform), in the
object's own frame: the environment is rotated into that frame at draw time. Colours are
divided by the white of the *world* frame (a white Lambertian facing world up), which
that rotation must not change: :func:`white_y` follows the environment's ``up``.

References
----------
Sloan, P.-P., Kautz, J., Snyder, J. (2002). Precomputed radiance transfer for real-time
rendering in dynamic, low-frequency lighting environments. SIGGRAPH 2002.
Swinbank, R., Purser, R. J. (2006). Fibonacci grids. Q. J. R. Meteorol. Soc. 132.
"""

from __future__ import annotations

import numpy as np

MAX_RAYS = 1 << 20


def fibonacci_directions(count: int) -> np.ndarray:
    """``count`` unit vectors (count, 3) spread evenly over the sphere (spherical Fibonacci)."""
    count = int(count)
    if not 1 <= count <= MAX_RAYS:
        raise ValueError(f"ray count must be 1..{MAX_RAYS}, got {count}")
    i = np.arange(count, dtype=np.float64) + 0.5
    z = 1.0 - 2.0 * i / count
    r = np.sqrt(np.clip(1.0 - z * z, 0.0, None))
    phi = np.pi * (3.0 - np.sqrt(5.0)) * i
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=-1)


def transfer_from_visibility(normals: np.ndarray, directions: np.ndarray,
                             visible: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """Transfer vectors (V, K) from visibility (V, R) along ``directions`` (R, 3).

    ``basis`` (R, K) holds the SH functions at the directions. Each direction carries
    the weight 4π/R; directions below a vertex's horizon contribute nothing.
    """
    normals = np.asarray(normals, dtype=np.float64)
    directions = np.asarray(directions, dtype=np.float64)
    visible = np.asarray(visible, dtype=bool)
    basis = np.asarray(basis, dtype=np.float64)
    if visible.shape != (len(normals), len(directions)) or len(basis) != len(directions):
        raise ValueError(f"shapes disagree: normals {normals.shape}, directions "
                         f"{directions.shape}, visible {visible.shape}, basis {basis.shape}")
    cosine = np.clip(normals @ directions.T, 0.0, None) * visible
    return cosine @ basis * (4.0 * np.pi / len(directions))


def albedo_weights(albedo: np.ndarray, wavelengths: np.ndarray,
                   basis: np.ndarray | None = None, observer: str | None = None) -> np.ndarray:
    """R̃ (m, 3): a diffuse albedo spectrum premultiplied by the CMFs (and 1/π, the
    Lambertian BRDF), projected on the spectral basis — the spectral PRT paper's
    per-texel term, whose dot product with the irradiance coefficients gives XYZ."""
    from ..colour import spectra

    wl = spectra.check_wavelengths(wavelengths)
    albedo = np.asarray(albedo, dtype=np.float64)
    if albedo.shape != wl.shape or not np.isfinite(albedo).all():
        raise ValueError(f"albedo must be {wl.size} finite values, got shape {albedo.shape}")
    cmf = spectra.cmfs(wl) if observer is None else spectra.cmfs(wl, observer)
    weighted = albedo[:, None] * cmf * spectra.sample_weights(wl)[:, None] / np.pi
    return weighted if basis is None else np.asarray(basis, dtype=np.float64).T @ weighted


def white_y(environment) -> float:
    """Y of a white, unoccluded Lambertian facing the world's up under ``environment``: the
    reference every PRT colour is divided by (the environment's white, as the protocol's
    light). World up is ``environment.up`` (+z until the environment is turned into an
    object's frame), so turning the environment leaves the white unchanged."""
    from . import sh

    white = albedo_weights(np.ones(environment.wavelengths.size), environment.wavelengths,
                           environment.basis)
    up = sh.zonal_to_sh(sh.clamped_cosine_zonal(environment.bands),
                        np.asarray(environment.up, dtype=np.float64))
    value = float((up @ environment.coefficients) @ white[:, 1])
    if not value > 0:
        raise ValueError("the environment sends no light onto an upward surface; it has no "
                         "white to normalise by")
    return value


def _check_transfer(transfer: np.ndarray, environment) -> np.ndarray:
    transfer = np.asarray(transfer, dtype=np.float64)
    if transfer.ndim != 2 or transfer.shape[1] != environment.coefficients.shape[0]:
        raise ValueError(f"transfer must be (V, {environment.coefficients.shape[0]}), got "
                         f"{transfer.shape}")
    if not np.isfinite(transfer).all():
        raise ValueError(f"transfer has {int((~np.isfinite(transfer)).sum())} non-finite "
                         "values")
    return transfer


def irradiance(transfer: np.ndarray, environment) -> np.ndarray:
    """Ê (V, m) = T̃ · L̃ / white Y: the spectral irradiance coefficients the vertex shader
    computes, in the environment's spectral basis (``transfer`` in its frame). The white
    is :func:`white_y`, the same number whatever frame the environment was turned into."""
    transfer = _check_transfer(transfer, environment)
    return transfer @ environment.coefficients / white_y(environment)


def vertex_xyz(transfer: np.ndarray, environment, albedo: np.ndarray) -> np.ndarray:
    """Linear XYZ (V, 3) leaving diffuse vertices: ``(T̃ · L̃) · R̃``, normalised so that a
    white, unoccluded Lambertian facing the world's up under the same environment has
    Y = 1 (the environment's white is the reference, as the measurement protocol's light
    is). The white belongs to the world frame: turning ``environment`` into an object's
    frame does not change it.

    ``transfer`` (V, K) from :func:`transfer_from_visibility` in the environment's frame,
    ``environment`` a ``core.environment.SpectralEnvironment``, ``albedo`` (L,) on its
    wavelengths, or R̃ per vertex (V, m, 3) (``core.albedo`` layers sampled at the vertices).
    Negative components, left by the ringing of a band-limited sharp light, are clipped to
    0 (as the shader does): no physical spectrum has a negative XYZ.
    """
    e = irradiance(transfer, environment)
    albedo = np.asarray(albedo, dtype=np.float64)
    if albedo.ndim == 3:
        if albedo.shape != (len(e), e.shape[1], 3):
            raise ValueError(f"albedo weights must be ({len(e)}, {e.shape[1]}, 3), got "
                             f"{albedo.shape}")
        xyz = np.einsum("vm,vmc->vc", e, albedo)
    else:
        xyz = e @ albedo_weights(albedo, environment.wavelengths, environment.basis)
    # A band-limited sharp light (a sun) rings; no physical spectrum has negative XYZ.
    return np.clip(xyz, 0.0, None)


# ----------------------------------------------------------------------------- RGB PRT
# The classical pipeline the spectral PRT paper compares against: the environment and the
# albedo reduced to linear sRGB first, reflection as a per-channel product.


def rgb_environment(environment) -> np.ndarray:
    """L̃ (K, 3) in linear sRGB, divided by π: each SH coefficient's spectrum to XYZ, then to
    sRGB (an RGB environment map holds these values), over π (the Lambertian BRDF's), so
    that (T̃ · L̃) ⊙ albedo is the outgoing radiance as in :func:`vertex_xyz`."""
    from ..colour import pipeline as colour_pipeline, spectra

    wl = environment.wavelengths
    spectral = environment.coefficients if environment.basis is None else \
        environment.coefficients @ environment.basis.T                       # (K, L)
    xyz = spectral @ (spectra.cmfs(wl) * spectra.sample_weights(wl)[:, None])
    return xyz @ colour_pipeline.xyz_to_linear_srgb_matrix().T / np.pi


def rgb_albedo(albedo: np.ndarray, wavelengths: np.ndarray) -> np.ndarray:
    """Linear sRGB (…, 3) of reflectance spectra (…, L) under D65, white → (1, 1, 1): the
    texture an RGB pipeline would be given."""
    from ..colour import pipeline as colour_pipeline, spectra

    wl = spectra.check_wavelengths(wavelengths)
    weights = colour_pipeline.xyz_weights("D65", wl)
    to_rgb = colour_pipeline.xyz_to_linear_srgb_matrix()
    white = to_rgb @ (np.ones(wl.size) @ weights)
    return (np.asarray(albedo, dtype=np.float64) @ weights) @ to_rgb.T / white


def rgb_vertex_xyz(transfer: np.ndarray, environment, albedo_rgb: np.ndarray) -> np.ndarray:
    """XYZ (V, 3) of RGB PRT: ``((T̃ · L̃_rgb) ⊙ albedo_rgb)`` back to XYZ, normalised by
    the same world-frame white as :func:`vertex_xyz` (a white albedo gives identical
    results)."""
    from ..colour import pipeline as colour_pipeline

    transfer = _check_transfer(transfer, environment)
    rgb_e = transfer @ rgb_environment(environment) / white_y(environment)
    rgb = rgb_e * np.asarray(albedo_rgb, dtype=np.float64)
    return np.clip(rgb @ np.linalg.inv(colour_pipeline.xyz_to_linear_srgb_matrix()).T, 0.0,
                   None)
