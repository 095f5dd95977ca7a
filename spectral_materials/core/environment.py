"""Spectral environment light projected on SH × a spectral basis (the spectral PRT paper's L̃).

``L̃[k, j] = ∫∫ L(ω, λ) Y_k(ω) ψ_j(λ) dω dλ`` for SH functions ``Y_k`` (core.sh) and an
orthonormal spectral basis ``ψ_j`` (the columns of ``basis``; without one, ``j`` runs
over the wavelength samples). Three sources:

* :func:`sky_environment`: a CIE illuminant's SPD over a CIE standard general sky
  luminance distribution (overcast, clear, or uniform), optionally with a sun disc;
* :func:`equirect_environment`: an equirectangular map of spectra (e.g. a spectral
  OpenEXR read with ``formats.spectral_exr``) or of linear RGB uplifted to spectra with
  Smits (1999);
* :func:`project_samples`: radiance at any quadrature directions.

Ringing: a truncated SH series of a sharp light (a sun) dips below zero. A window
(``sh.window``: "cesaro" keeps every band-limited reconstruction of a non-negative
light non-negative, "hanning"/"lanczos" only damp the ringing) is applied per band.

Directions are world directions, z up; equirectangular maps follow Blender's world
mapping: u = atan2(y, −x)/2π + 1/2, v = atan2(z, √(x² + y²))/π + 1/2, row 0 at the top.

References
----------
CIE S 011/E:2003, Spatial distribution of daylight — CIE standard general sky.
Smits, B. (1999). An RGB-to-spectrum conversion for reflectances. J. Graphics Tools 4(4).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import sh, spectra

#: CIE standard general sky parameters (a, b, c, d, e) of the types used here.
CIE_SKIES = {
    "overcast": (4.0, -0.70, 0.0, -1.0, 0.0),      # type 1: steep gradation, no sun effect
    "clear": (-1.0, -0.32, 10.0, -3.0, 0.45),      # type 12: CIE standard clear sky
}
#: The sun's angular radius (rad).
SUN_HALF_ANGLE = 0.00465


@dataclass
class SpectralEnvironment:
    """SH × spectral coefficients of an environment, and how they were made."""

    coefficients: np.ndarray          # (K, m): SH index first
    bands: int
    wavelengths: np.ndarray
    basis: np.ndarray | None          # (L, m) or None (m = L wavelength samples)
    window: str
    source: str

    def rotated(self, rotation: np.ndarray) -> SpectralEnvironment:
        """The environment turned by ``rotation`` (3 × 3), by SH rotation matrices."""
        coefficients = sh.rotate(self.coefficients.T, rotation).T
        return SpectralEnvironment(coefficients, self.bands, self.wavelengths, self.basis,
                                   self.window, self.source)

    def radiance(self, directions: np.ndarray) -> np.ndarray:
        """The band-limited radiance spectra (N, L) along world ``directions`` (N, 3)."""
        values = sh.sh_basis(directions, self.bands) @ self.coefficients      # (N, m)
        return values if self.basis is None else values @ self.basis.T


def _spectral_coefficients(spd: np.ndarray, basis: np.ndarray | None) -> np.ndarray:
    return spd if basis is None else spd @ basis


def project_samples(directions: np.ndarray, weights: np.ndarray, radiance: np.ndarray,
                    wavelengths: np.ndarray, basis: np.ndarray | None = None, *,
                    bands: int = sh.DEFAULT_BANDS, window: str = "cesaro",
                    source: str = "samples") -> SpectralEnvironment:
    """Project radiance spectra (Q, L) at quadrature ``directions`` (Q, 3), ``weights`` (Q,)."""
    wl = spectra.check_wavelengths(wavelengths)
    radiance = np.asarray(radiance, dtype=np.float64)
    if radiance.shape != (len(directions), wl.size):
        raise ValueError(f"radiance must be ({len(directions)}, {wl.size}), got "
                         f"{radiance.shape}")
    if not np.isfinite(radiance).all():
        raise ValueError(f"radiance has {int((~np.isfinite(radiance)).sum())} non-finite "
                         "values")
    if np.any(radiance < 0):
        raise ValueError("radiance must be non-negative")
    if basis is not None and np.asarray(basis).shape[0] != wl.size:
        raise ValueError(f"basis has {np.asarray(basis).shape[0]} rows for {wl.size} "
                         "wavelengths")
    values = _spectral_coefficients(radiance, None if basis is None else np.asarray(basis))
    coefficients = sh.project(values, sh.sh_basis(directions, bands), weights).T   # (K, m)
    if window != "none":
        coefficients = sh.apply_window(coefficients.T, sh.window(bands, window)).T
    return SpectralEnvironment(coefficients, bands, wl,
                               None if basis is None else np.asarray(basis, dtype=np.float64),
                               window, source)


def cie_sky_luminance(directions: np.ndarray, sky: str = "overcast",
                      sun_direction: np.ndarray | None = None) -> np.ndarray:
    """Relative luminance of a CIE standard general sky along ``directions`` (N, 3), 0 below
    the horizon, 1 at the zenith (sun effect included for sky types that have one)."""
    if sky == "uniform":
        return (np.asarray(directions)[:, 2] > 0).astype(np.float64)
    if sky not in CIE_SKIES:
        raise ValueError(f"unknown sky {sky!r}; choose uniform, {', '.join(CIE_SKIES)}")
    a, b, c, d, e = CIE_SKIES[sky]
    dirs = np.asarray(directions, dtype=np.float64)
    dirs = dirs / np.linalg.norm(dirs, axis=1, keepdims=True)
    cos_z = dirs[:, 2]
    above = cos_z > 0
    sun = np.array([0.0, 0.0, 1.0]) if sun_direction is None else \
        np.asarray(sun_direction, dtype=np.float64) / np.linalg.norm(sun_direction)
    zs = np.arccos(np.clip(sun[2], -1.0, 1.0))

    def gradation(cz):
        return 1.0 + a * np.exp(b / np.maximum(cz, 1e-6))

    def indicatrix(chi):
        return 1.0 + c * (np.exp(d * chi) - np.exp(d * np.pi / 2)) + e * np.cos(chi) ** 2

    chi = np.arccos(np.clip(dirs @ sun, -1.0, 1.0))
    zenith = gradation(1.0) * indicatrix(zs)
    out = np.where(above, gradation(np.where(above, cos_z, 1.0)) * indicatrix(chi) / zenith,
                   0.0)
    return np.clip(out, 0.0, None)


def sky_environment(illuminant: str | np.ndarray, wavelengths: np.ndarray | None = None,
                    basis: np.ndarray | None = None, *, sky: str = "overcast",
                    sun_direction=None, sun_fraction: float = 0.0,
                    bands: int = sh.DEFAULT_BANDS, window: str = "cesaro",
                    quadrature: int = 64) -> SpectralEnvironment:
    """A CIE illuminant over a CIE sky (and a sun disc carrying ``sun_fraction`` of the
    horizontal irradiance), scaled so that the horizontal irradiance is π (a white
    Lambertian facing up reflects radiance 1)."""
    from . import colour_pipeline

    wl = spectra.WAVELENGTHS_REFERENCE if wavelengths is None else \
        spectra.check_wavelengths(wavelengths)
    spd = colour_pipeline.illuminant_spd(illuminant, wl)
    spd = spd / max(float(np.max(spd)), 1e-30)
    if not 0.0 <= sun_fraction < 1.0:
        raise ValueError(f"sun fraction must be in [0, 1), got {sun_fraction}")
    directions, weights = sh.sphere_quadrature(quadrature)
    sky_l = cie_sky_luminance(directions, sky, sun_direction)
    horizontal = float(np.sum(weights * sky_l * np.clip(directions[:, 2], 0.0, None)))
    sky_l = sky_l * (np.pi * (1.0 - sun_fraction) / max(horizontal, 1e-30))
    environment = project_samples(directions, weights, sky_l[:, None] * spd[None, :], wl,
                                  basis, bands=bands, window="none", source=f"CIE {sky} sky")
    if sun_fraction > 0.0:
        if sun_direction is None:
            raise ValueError("a sun needs a sun_direction")
        axis = np.asarray(sun_direction, dtype=np.float64)
        axis = axis / np.linalg.norm(axis)
        if axis[2] <= 0:
            raise ValueError("the sun is below the horizon")
        # A disc of solid angle Ω with radiance s gives horizontal irradiance s Ω cos z.
        cap = sh.cap_zonal(bands, SUN_HALF_ANGLE)          # coefficients of the disc's indicator
        solid = 2.0 * np.pi * (1.0 - np.cos(SUN_HALF_ANGLE))
        level = np.pi * sun_fraction / (solid * axis[2])
        sun_sh = sh.zonal_to_sh(cap * level, axis)          # (K,)
        environment.coefficients = environment.coefficients + \
            np.outer(sun_sh, _spectral_coefficients(spd, None if basis is None else
                                                    np.asarray(basis)))
        environment.source += " + sun"
    if window != "none":
        environment.coefficients = sh.apply_window(environment.coefficients.T,
                                                   sh.window(bands, window)).T
        environment.window = window
    return environment


def equirect_directions(height: int, width: int) -> tuple[np.ndarray, np.ndarray]:
    """Pixel-centre directions (H, W, 3) and exact solid angles (H, W) of an equirectangular
    map in Blender's world mapping (row 0 at the top, +z up). Projecting with them is the
    midpoint rule per pixel: SH coefficients carry an O(1/H²) quadrature error."""
    if not (1 <= height <= 16384 and 1 <= width <= 32768):
        raise ValueError(f"equirectangular size {width}×{height} is out of range")
    v = 1.0 - (np.arange(height) + 0.5) / height                 # row 0 = top
    u = (np.arange(width) + 0.5) / width
    elevation = (v - 0.5) * np.pi
    azimuth = (u - 0.5) * 2.0 * np.pi                            # atan2(y, −x)
    el, az = np.meshgrid(elevation, azimuth, indexing="ij")
    dirs = np.stack([-np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=-1)
    # The exact solid angle of each pixel: Δφ (sin el_top − sin el_bottom).
    edges = np.pi * (0.5 - np.arange(height + 1) / height)       # top to bottom
    band = np.sin(edges[:-1]) - np.sin(edges[1:])
    solid = np.broadcast_to((2.0 * np.pi / width) * band[:, None], (height, width)).copy()
    return dirs, solid


def equirect_environment(values: np.ndarray, wavelengths: np.ndarray | None = None,
                         basis: np.ndarray | None = None, *, rgb: bool = False,
                         bands: int = sh.DEFAULT_BANDS, window: str = "cesaro",
                         rows_per_chunk: int = 64) -> SpectralEnvironment:
    """Project an equirectangular map: spectra (H, W, L) on ``wavelengths``, or with
    ``rgb=True`` linear Rec.709 radiance (H, W, 3) uplifted with Smits (1999)."""
    from .formats.merl import SmitsUplift

    values = np.asarray(values)
    wl = spectra.WAVELENGTHS_REFERENCE if wavelengths is None else \
        spectra.check_wavelengths(wavelengths)
    if values.ndim != 3 or values.shape[2] != (3 if rgb else wl.size):
        raise ValueError(f"map must be (H, W, {3 if rgb else wl.size}), got {values.shape}")
    bad = ~np.isfinite(values)
    if bad.any():
        raise ValueError(f"map has {int(bad.sum())} non-finite values")
    height, width = values.shape[:2]
    dirs, solid = equirect_directions(height, width)
    uplift = SmitsUplift() if rgb else None
    basis_array = None if basis is None else np.asarray(basis, dtype=np.float64)
    m = wl.size if basis_array is None else basis_array.shape[1]
    total = np.zeros((sh.sh_count(bands), m))
    for begin in range(0, height, rows_per_chunk):
        rows = slice(begin, min(begin + rows_per_chunk, height))
        block = values[rows].reshape(-1, values.shape[2]).astype(np.float64)
        spectra_block = uplift(block, wl) if rgb else np.clip(block, 0.0, None)
        coeffs = _spectral_coefficients(spectra_block, basis_array)               # (P, m)
        y = sh.sh_basis(dirs[rows].reshape(-1, 3), bands)                          # (P, K)
        total += (y * solid[rows].reshape(-1)[:, None]).T @ coeffs
    if window != "none":
        total = sh.apply_window(total.T, sh.window(bands, window)).T
    return SpectralEnvironment(total, bands, wl, basis_array, window,
                               "equirectangular RGB (Smits)" if rgb else
                               "equirectangular spectra")
