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

:func:`sky_reference` and :func:`equirect_reference` give the same lights unprojected
(``core.prt_reference.ReferenceEnvironment``) for the Monte Carlo reference, and
:func:`read_environment_map` reads a map from an RGB or spectral OpenEXR.

Ringing: a truncated SH series of a sharp light (a sun) dips below zero. A window
(``sh.window``: "cesaro" keeps every band-limited reconstruction of a non-negative
light non-negative, "hanning"/"lanczos" only damp the ringing) is applied per band.

Directions are world directions, z up; equirectangular maps follow Blender's world
mapping: u = atan2(y, −x)/2π + 1/2, v = atan2(z, √(x² + y²))/π + 1/2, row 0 at the top.

References
----------
CIE S 011/E:2003, Spatial distribution of daylight — CIE standard general sky.
Smits, B. (1999). An RGB-to-spectrum conversion for reflectances. J. Graphics Tools 4(4).
Fichet, A., Pacanowski, R., Wilkie, A. (2021). An OpenEXR layout for spectral images.
JCGT 10(3).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..colour import spectra
from . import sh
from .reference import ReferenceEnvironment

#: CIE standard general sky parameters (a, b, c, d, e) of the types used here.
CIE_SKIES = {
    "overcast": (4.0, -0.70, 0.0, -1.0, 0.0),      # type 1: steep gradation, no sun effect
    "clear": (-1.0, -0.32, 10.0, -3.0, 0.45),      # type 12: CIE standard clear sky
}
#: The sun's angular radius (rad).
SUN_HALF_ANGLE = 0.00465


def _world_up() -> np.ndarray:
    return np.array([0.0, 0.0, 1.0])


@dataclass
class SpectralEnvironment:
    """SH × spectral coefficients of an environment, and how they were made.

    ``up`` is the world's up (+z of the frame the light was defined in) as seen in the
    frame the coefficients are now in: +z until :meth:`rotated` turns the environment into
    another frame (an object's, where its transfer was baked). The colour white is the
    light on a white Lambertian facing *world* up (``core.prt.white_y``), so it must not
    change when the environment is merely expressed in a turned frame.
    """

    coefficients: np.ndarray          # (K, m): SH index first
    bands: int
    wavelengths: np.ndarray
    basis: np.ndarray | None          # (L, m) or None (m = L wavelength samples)
    window: str
    source: str
    up: np.ndarray = field(default_factory=_world_up)

    def rotated(self, rotation: np.ndarray) -> SpectralEnvironment:
        """The same light in a frame turned by ``rotation`` (3 × 3 orthogonal), by SH
        rotation matrices: ``L'(ω) = L(Rᵀω)``, and world up goes to ``R up`` with it, so
        the white is unchanged. A reflection (det −1: a mirrored object's frame) is exact
        too: SH band ``l`` then follows the O(3) representation (``core.sh``). Turning
        about +z (the scene's environment rotation) leaves ``up`` at +z."""
        rotation = np.asarray(rotation, dtype=np.float64)
        coefficients = sh.rotate(self.coefficients.T, rotation).T     # checks orthogonality
        return SpectralEnvironment(coefficients, self.bands, self.wavelengths, self.basis,
                                   self.window, self.source, rotation @ self.up)

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


@dataclass
class _SkyScales:
    """The scale factors of a CIE sky with an optional sun, shared by :func:`sky_environment`
    and :func:`sky_reference` so that the SH projection and the Monte Carlo reference light
    the scene identically."""

    wavelengths: np.ndarray      # (L,)
    spd: np.ndarray              # (L,) the illuminant, peak 1
    sky_scale: float             # sky radiance = sky_scale · cie_sky_luminance · spd
    sun_axis: np.ndarray | None  # unit direction towards the sun, None without a sun
    sun_irradiance: float        # the sun's irradiance at normal incidence = this · spd
    directions: np.ndarray       # the sphere quadrature the sky was normalised with...
    weights: np.ndarray
    luminance: np.ndarray        # ...and the relative sky luminance there


def _sky_scales(illuminant, wavelengths, sky: str, sun_direction, sun_fraction: float,
                quadrature: int) -> _SkyScales:
    """Normalise a CIE sky so that the horizontal irradiance is π in total, the sun (if any)
    carrying ``sun_fraction`` of it: a white Lambertian facing up then reflects radiance 1."""
    from ..colour import pipeline as colour_pipeline

    wl = spectra.WAVELENGTHS_REFERENCE if wavelengths is None else \
        spectra.check_wavelengths(wavelengths)
    spd = colour_pipeline.illuminant_spd(illuminant, wl)
    spd = spd / max(float(np.max(spd)), 1e-30)
    if not 0.0 <= sun_fraction < 1.0:
        raise ValueError(f"sun fraction must be in [0, 1), got {sun_fraction}")
    if sun_direction is not None:
        sun = np.asarray(sun_direction, dtype=np.float64)
        if sun.shape != (3,) or not np.isfinite(sun).all() or not np.linalg.norm(sun) > 0:
            raise ValueError(f"sun_direction must be a finite, non-zero 3-vector, got "
                             f"{sun_direction!r}")
    directions, weights = sh.sphere_quadrature(quadrature)
    luminance = cie_sky_luminance(directions, sky, sun_direction)
    horizontal = float(np.sum(weights * luminance * np.clip(directions[:, 2], 0.0, None)))
    sky_scale = np.pi * (1.0 - sun_fraction) / max(horizontal, 1e-30)
    axis = None
    sun_irradiance = 0.0
    if sun_fraction > 0.0:
        if sun_direction is None:
            raise ValueError("a sun needs a sun_direction")
        axis = np.asarray(sun_direction, dtype=np.float64)
        axis = axis / np.linalg.norm(axis)
        if axis[2] <= 0:
            raise ValueError("the sun is below the horizon")
        # Horizontal irradiance E_n cos z must be π · sun_fraction.
        sun_irradiance = np.pi * sun_fraction / axis[2]
    return _SkyScales(wl, spd, sky_scale, axis, sun_irradiance, directions, weights, luminance)


def sky_environment(illuminant: str | np.ndarray, wavelengths: np.ndarray | None = None,
                    basis: np.ndarray | None = None, *, sky: str = "overcast",
                    sun_direction=None, sun_fraction: float = 0.0,
                    bands: int = sh.DEFAULT_BANDS, window: str = "cesaro",
                    quadrature: int = 64) -> SpectralEnvironment:
    """A CIE illuminant over a CIE sky (and a sun disc carrying ``sun_fraction`` of the
    horizontal irradiance), scaled so that the horizontal irradiance is π (a white
    Lambertian facing up reflects radiance 1). :func:`sky_reference` is the same light,
    unprojected."""
    scales = _sky_scales(illuminant, wavelengths, sky, sun_direction, sun_fraction, quadrature)
    wl, spd = scales.wavelengths, scales.spd
    sky_l = scales.luminance * scales.sky_scale
    environment = project_samples(scales.directions, scales.weights,
                                  sky_l[:, None] * spd[None, :], wl, basis, bands=bands,
                                  window="none", source=f"CIE {sky} sky")
    if scales.sun_axis is not None:
        # A disc of solid angle Ω with radiance s gives irradiance s Ω at normal incidence.
        cap = sh.cap_zonal(bands, SUN_HALF_ANGLE)          # coefficients of the disc's indicator
        solid = 2.0 * np.pi * (1.0 - np.cos(SUN_HALF_ANGLE))
        level = scales.sun_irradiance / solid
        sun_sh = sh.zonal_to_sh(cap * level, scales.sun_axis)          # (K,)
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
    from ..colour.uplift import SmitsUplift

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


# ------------------------------------------------------------------ Monte Carlo reference


def sky_reference(illuminant: str | np.ndarray, wavelengths: np.ndarray | None = None, *,
                  sky: str = "overcast", sun_direction=None, sun_fraction: float = 0.0,
                  quadrature: int = 64) -> ReferenceEnvironment:
    """The light of :func:`sky_environment`, unprojected, for the Monte Carlo reference.

    The continuous sky radiance is ``k · cie_sky_luminance(ω) · spd(λ)`` and the sun a
    directional light of irradiance ``π · sun_fraction / cos z · spd(λ)`` at normal
    incidence, with **the same** scale factors as :func:`sky_environment` (one private
    helper computes them for both; ``k`` comes from the same ``quadrature``): horizontal
    irradiance π in total, the sun carrying ``sun_fraction`` of it; ``spd`` is the
    illuminant with its peak scaled to 1. The sun disc itself (0.53°) is never hit by
    random rays, so it is not part of the radiance.

    Returns
    -------
    prt_reference.ReferenceEnvironment
    """
    scales = _sky_scales(illuminant, wavelengths, sky, sun_direction, sun_fraction, quadrature)
    spd, scale = scales.spd.copy(), float(scales.sky_scale)
    sun_for_sky = None if sun_direction is None else np.asarray(sun_direction,
                                                                dtype=np.float64)

    def radiance(directions: np.ndarray) -> np.ndarray:
        luminance = cie_sky_luminance(directions, sky, sun_for_sky)
        return (scale * luminance)[:, None] * spd[None, :]

    suns = () if scales.sun_axis is None else \
        ((scales.sun_axis, scales.sun_irradiance * spd),)
    return ReferenceEnvironment(scales.wavelengths, radiance, suns,
                                f"CIE {sky} sky" + (" + sun" if suns else ""))


def _equirect_pixels(directions: np.ndarray, height: int, width: int
                     ) -> tuple[np.ndarray, np.ndarray]:
    """(row, column) of the equirectangular pixel containing each direction (N, 3), in
    Blender's world mapping (row 0 at the top), as :func:`equirect_directions` lays out."""
    d = np.asarray(directions, dtype=np.float64)
    u = np.arctan2(d[:, 1], -d[:, 0]) / (2.0 * np.pi) + 0.5
    v = np.arctan2(d[:, 2], np.hypot(d[:, 0], d[:, 1])) / np.pi + 0.5
    column = np.floor(u * width).astype(np.int64) % width
    row = np.clip(np.floor((1.0 - v) * height).astype(np.int64), 0, height - 1)
    return row, column


def equirect_reference(values: np.ndarray, wavelengths: np.ndarray | None = None, *,
                       rgb: bool = False, rows_per_chunk: int = 64) -> ReferenceEnvironment:
    """An equirectangular map as a piecewise-constant light, for the Monte Carlo reference.

    The radiance along a direction is the pixel containing it (nearest, no filtering), in
    Blender's world mapping (see :func:`equirect_directions`; row 0 at the top). Spectra
    (H, W, L) on ``wavelengths`` (negative samples taken as 0), or with ``rgb=True`` linear
    Rec.709 radiance (H, W, 3) uplifted with Smits (1999) per looked-up pixel, as
    :func:`equirect_environment` does. The white's irradiance is exact: the map is constant
    over each pixel, so ``∫ L cos θ dω`` over the upper hemisphere is the sum of
    ``L_pixel · Δφ (sin² el_top − sin² el_bottom)/2``.
    """
    from ..colour.uplift import SmitsUplift

    values = np.asarray(values)
    wl = spectra.WAVELENGTHS_REFERENCE if wavelengths is None else \
        spectra.check_wavelengths(wavelengths)
    if values.ndim != 3 or values.shape[2] != (3 if rgb else wl.size) or 0 in values.shape:
        raise ValueError(f"map must be (H, W, {3 if rgb else wl.size}), got {values.shape}")
    bad = int(np.count_nonzero(~np.isfinite(values)))
    if bad:
        raise ValueError(f"map has {bad} non-finite values")
    height, width = values.shape[:2]
    equirect_directions(height, width)                     # the size check
    uplift = SmitsUplift() if rgb else None

    def as_spectra(block: np.ndarray) -> np.ndarray:
        block = block.astype(np.float64)
        return uplift(block, wl) if rgb else np.clip(block, 0.0, None)

    def radiance(directions: np.ndarray) -> np.ndarray:
        row, column = _equirect_pixels(directions, height, width)
        return as_spectra(values[row, column])

    # ∫ z dω over the part of each row above the horizon (rows are top to bottom).
    edges = np.clip(np.pi * (0.5 - np.arange(height + 1) / height), 0.0, None)
    band = 0.5 * (np.sin(edges[:-1]) ** 2 - np.sin(edges[1:]) ** 2) * (2.0 * np.pi / width)
    up = np.zeros(wl.size)
    for begin in range(0, height, rows_per_chunk):
        rows = slice(begin, min(begin + rows_per_chunk, height))
        if not np.any(band[rows] > 0):
            continue
        block = as_spectra(values[rows].reshape(-1, values.shape[2]))
        up += np.repeat(band[rows], width) @ block
    return ReferenceEnvironment(wl, radiance, (), "equirectangular RGB (Smits)" if rgb else
                                "equirectangular spectra", up_irradiance=up)


# ------------------------------------------------------------------------- reading maps


def read_environment_map(path) -> tuple[np.ndarray, np.ndarray | None, bool]:
    """Read an equirectangular environment map from an OpenEXR file.

    A spectral OpenEXR (Fichet et al. 2021 layout, ``formats.spectral_exr``) with an
    emissive ``S0`` layer gives its radiance spectra; any other OpenEXR gives linear RGB
    from its ``R``, ``G``, ``B`` channels (``formats.exr``). Both readers return row 0 at
    the bottom; the rows are flipped here so that **row 0 is the top** (the sky, +z), as
    :func:`equirect_directions` and :func:`equirect_environment` expect.

    Parameters
    ----------
    path : str or Path
        An ``.exr`` file. Radiance ``.hdr`` and other image formats are not read here: the
        Blender side loads them through Blender's image loader.

    Returns
    -------
    values : ndarray (H, W, C) float32
        Spectra (C = L) or linear RGB (C = 3), row 0 at the top.
    wavelengths : ndarray (L,) or None
        nm of a spectral map (the file's own grid); None for RGB.
    rgb : bool
        True for an RGB map.

    Raises
    ------
    ValueError
        Another suffix; a missing, damaged or truncated file; a spectral EXR holding only
        reflectances (``T``: not a light); an RGB EXR without R, G and B; NaN/inf samples
        (with their count).
    """
    from pathlib import Path

    from ..formats import spectral_exr
    from ..formats.exr import read_exr

    path = Path(path)
    if path.suffix.lower() != ".exr":
        raise ValueError(f"{path}: environment maps are read from OpenEXR files here (.exr: "
                         "spectral EXR with an emissive S0 layer, or RGB); Radiance .hdr and "
                         "other images are loaded through Blender's image loader")
    if not path.is_file():
        raise ValueError(f"{path}: no such file")
    layers = _spectral_layers(path)
    if "S0" in layers:
        image = spectral_exr.read_spectral_exr(path, kind="emissive")
        values, wavelengths, rgb = image.values, image.wavelengths, False
    elif layers:
        raise ValueError(f"{path}: a spectral EXR of reflectances (T layer), not of radiance "
                         "(an environment map needs an emissive S0 layer)")
    else:
        try:
            channels, _ = read_exr(path)
        except ValueError as exc:
            message = str(exc)
            if str(path) in message:
                raise
            raise ValueError(f"{path}: damaged or truncated OpenEXR file ({message})") from None
        missing = [c for c in "RGB" if c not in channels]
        if missing:
            raise ValueError(f"{path}: an RGB environment map needs channels R, G and B; "
                             f"missing {', '.join(missing)} (has {', '.join(sorted(channels))})")
        values = np.stack([channels[c] for c in "RGB"], axis=-1).astype(np.float32)
        wavelengths, rgb = None, True
    bad = int(np.count_nonzero(~np.isfinite(values)))
    if bad:
        raise ValueError(f"{path}: {bad} NaN or inf samples in the environment map")
    return np.ascontiguousarray(values[::-1]), wavelengths, rgb


def _spectral_layers(path) -> set[str]:
    """The spectral layers (``S0``..``S3``, ``T``) named in an OpenEXR header, read alone.
    A malformed name in a spectral layer counts as that layer, so that the spectral reader
    reports it."""
    import OpenEXR

    from ..formats import spectral_exr

    try:
        with OpenEXR.File(str(path), header_only=True) as handle:
            names = [str(c.name) for c in handle.header().get("channels") or []]
    except Exception as exc:  # the library raises RuntimeError & co for damaged files
        raise ValueError(f"{path}: not a readable OpenEXR file ({type(exc).__name__}: "
                         f"{exc})") from None
    layers = set()
    for name in names:
        try:
            parsed = spectral_exr.parse_channel_name(name)
        except ValueError:
            layers.add(name.split(".", 1)[0])
            continue
        if parsed is not None:
            layers.add("T" if parsed[0] == "reflective" else f"S{parsed[1]}")
    return layers
