"""Colour: protocol normalisation, XYZ ↔ CIELAB, ΔE94, and the display pipeline.

The display pipeline follows Schwenk et al. (2010) §3.1: XYZ → Bradford
chromatic adaptation from the scene white to the display white (D65) → linear
sRGB → sigmoid tone map → sRGB encoding.

Measurement follows ``shared/PROTOCOL.md``: the illuminant is scaled so that a
white Lambertian surface lit at normal incidence reflects Y = 1, and CIELAB uses
that surface's XYZ as its white point (no adaptation enters the metric).

References
----------
CIE 116-1995 (CIE94 colour difference). IEC 61966-2-1:1999 (sRGB).
Lam, K. M. (1985), the Bradford transform, as shipped by colour-science.
"""

from __future__ import annotations

import colour
import numpy as np
from colour.difference import delta_E_CIE1994

from . import spectra

_SRGB = colour.RGB_COLOURSPACES["sRGB"]
#: XYZ of the sRGB/D65 display white, Y = 1.
DISPLAY_WHITE_XYZ = colour.xy_to_XYZ(_SRGB.whitepoint)


def illuminant_spd(illuminant: str | np.ndarray, wavelengths: np.ndarray) -> np.ndarray:
    """An illuminant by CIE name or as an SPD array on ``wavelengths``."""
    wl = spectra.check_wavelengths(wavelengths)
    if isinstance(illuminant, str):
        return spectra.illuminant(illuminant, wl)
    spd = np.asarray(illuminant, dtype=np.float64)
    if spd.shape != wl.shape:
        raise ValueError(f"illuminant SPD has shape {spd.shape}, expected {wl.shape}")
    if not np.isfinite(spd).all() or np.any(spd < 0):
        raise ValueError("illuminant SPD must be finite and non-negative")
    return spd


def xyz_weights(illuminant: str | np.ndarray, wavelengths: np.ndarray,
                basis: np.ndarray | None = None, *,
                observer: str = spectra.OBSERVER) -> np.ndarray:
    """Weights W (L, 3) with XYZ = Σ_λ f·cosθi·W, normalised as the protocol says.

    ``W = k · E(λ) · cmf(λ) · Δλ`` with k chosen so that a white Lambertian
    (f = 1/π) at normal incidence gives Y = 1. With an orthonormal ``basis``
    (L, m) the weights are its coefficients Ψᵀ W (m, 3): the light × CMF side
    of the factor-pack paper's coefficient dot product (eq. 9). ``observer``
    picks the CMFs (see :func:`spectra.cmfs`; the protocol's 1931 2° by default);
    with the 1964 10° observer it is Y₁₀ that the white reflects as 1.
    """
    wl = spectra.check_wavelengths(wavelengths)
    spd = illuminant_spd(illuminant, wl)
    weights = spd[:, None] * spectra.cmfs(wl, observer) * spectra.sample_weights(wl)[:, None]
    white_y = weights[:, 1].sum() / np.pi
    if not white_y > 0:
        raise ValueError("illuminant has no luminance on this wavelength grid")
    weights = weights / white_y
    return weights if basis is None else np.asarray(basis).T @ weights


def white_xyz(illuminant: str | np.ndarray, wavelengths: np.ndarray, *,
              observer: str = spectra.OBSERVER) -> np.ndarray:
    """XYZ of the white Lambertian under the normalised illuminant (Y = 1)."""
    return xyz_weights(illuminant, wavelengths, observer=observer).sum(axis=0) / np.pi


def xyz_to_lab(xyz: np.ndarray, white: np.ndarray) -> np.ndarray:
    """CIELAB of ``xyz (..., 3)`` relative to the white ``white (3,)`` (its Y is the reference)."""
    white = np.asarray(white, dtype=np.float64)
    if white.shape != (3,) or not np.isfinite(white).all() or not white[1] > 0:
        raise ValueError(f"the white point must be a finite XYZ with Y > 0, got {white}")
    return colour.XYZ_to_Lab(np.asarray(xyz, dtype=np.float64) / white[1], colour.XYZ_to_xy(white))


def delta_e94(xyz_reference: np.ndarray, xyz_test: np.ndarray, white: np.ndarray) -> np.ndarray:
    """ΔE*94 (graphic arts weights) between two XYZ arrays, per sample."""
    ref = np.asarray(xyz_reference, dtype=np.float64)
    test = np.asarray(xyz_test, dtype=np.float64)
    for label, arr in (("reference", ref), ("test", test)):
        if not np.isfinite(arr).all():
            raise ValueError(f"{label} XYZ has {int((~np.isfinite(arr)).sum())} non-finite values")
    return delta_E_CIE1994(xyz_to_lab(ref, white), xyz_to_lab(test, white))


def bradford_adapt(xyz: np.ndarray, white_source: np.ndarray,
                   white_target: np.ndarray = DISPLAY_WHITE_XYZ) -> np.ndarray:
    """Von Kries adaptation with the Bradford cone space, ``white_source → white_target``."""
    return colour.adaptation.chromatic_adaptation_VonKries(
        np.asarray(xyz, dtype=np.float64), white_source, white_target, transform="Bradford"
    )


def xyz_to_linear_srgb(xyz: np.ndarray) -> np.ndarray:
    """Linear sRGB (D65) from D65-adapted XYZ; no adaptation inside."""
    return np.asarray(xyz, dtype=np.float64) @ _SRGB.matrix_XYZ_to_RGB.T


def tonemap_sigmoid(rgb: np.ndarray, white: float = 4.0) -> np.ndarray:
    """Extended Reinhard curve ``x (1 + x / w²) / (1 + x)``, per channel.

    A sigmoid in log exposure: linear near black, 1 at ``x = white`` (so values up
    to ``white`` keep detail), negative input clamped to 0. ``white`` must be > 0.
    """
    if not white > 0:
        raise ValueError(f"tone-map white must be > 0, got {white}")
    x = np.maximum(np.asarray(rgb, dtype=np.float64), 0.0)
    return np.minimum(x * (1.0 + x / (white * white)) / (1.0 + x), 1.0)


def srgb_encode(rgb: np.ndarray) -> np.ndarray:
    """The sRGB transfer function (IEC 61966-2-1) on values clipped to [0, 1]."""
    return colour.models.eotf_inverse_sRGB(np.clip(np.asarray(rgb, dtype=np.float64), 0.0, 1.0))


def xyz_to_display(xyz: np.ndarray, scene_white: np.ndarray, *, exposure: float = 1.0,
                   tonemap_white: float = 4.0) -> np.ndarray:
    """The full display pipeline: XYZ → Bradford → linear sRGB → tone map → sRGB (0..1)."""
    adapted = bradford_adapt(np.asarray(xyz, dtype=np.float64) * exposure, scene_white)
    return srgb_encode(tonemap_sigmoid(xyz_to_linear_srgb(adapted), white=tonemap_white))


def bradford_matrix(white_source: np.ndarray,
                    white_target: np.ndarray = DISPLAY_WHITE_XYZ) -> np.ndarray:
    """The 3 × 3 matrix of :func:`bradford_adapt` (XYZ column vectors), for the shaders."""
    return colour.adaptation.matrix_chromatic_adaptation_VonKries(
        np.asarray(white_source, dtype=np.float64), np.asarray(white_target, dtype=np.float64),
        transform="Bradford")


def xyz_to_linear_srgb_matrix() -> np.ndarray:
    """The 3 × 3 matrix of :func:`xyz_to_linear_srgb` (XYZ column vectors)."""
    return np.array(_SRGB.matrix_XYZ_to_RGB, dtype=np.float64)
