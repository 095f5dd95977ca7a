"""The measurement protocol (shared/PROTOCOL.md) in code.

* ``random_direction_pairs``: (wi, wo) uniform over the two hemispheres.
* ``sphere_directions``: the sphere protocol's per-pixel local directions.
* ``reference_xyz``: 5 nm point-sampled XYZ of the exact BRDF.
* ``delta_e94_stats``: mean / p95 / max ΔE94 over lit samples.
* ``cosine_weighted_luminance_rms``: Kautz–McCool's 8000-pair radiometric error.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..colour import pipeline as colour_pipeline, spectra

SPHERE_SIZE = 256
SPHERE_INCIDENCES_DEG = (0.0, 30.0, 60.0, 80.0)
RANDOM_PAIRS = 20_000
RANDOM_PAIRS_SEED = 20100517


def uniform_hemisphere(rng: np.random.Generator, n: int) -> np.ndarray:
    """``n`` unit directions (n, 3) uniform in solid angle on the upper hemisphere, drawn
    from ``rng`` (z, then φ)."""
    z = rng.uniform(0.0, 1.0, n)
    phi = rng.uniform(0.0, 2.0 * np.pi, n)
    r = np.sqrt(np.clip(1.0 - z * z, 0.0, None))
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=-1)


def random_direction_pairs(count: int = RANDOM_PAIRS, seed: int = RANDOM_PAIRS_SEED
                           ) -> tuple[np.ndarray, np.ndarray]:
    """``count`` (wi, wo) pairs, each uniform in solid angle on the upper hemisphere."""
    rng = np.random.default_rng(seed)
    return uniform_hemisphere(rng, count), uniform_hemisphere(rng, count)


@dataclass
class SphereView:
    """Per-pixel local directions of the sphere protocol (row 0 is the top, +y)."""

    wi: np.ndarray      # (P, 3) local light direction for the pixels in ``mask``
    wo: np.ndarray      # (P, 3) local view direction
    mask: np.ndarray    # (size, size) pixels on the sphere and lit (cosθi > 0, cosθo > 0)
    size: int


def sphere_directions(incidence_deg: float, size: int = SPHERE_SIZE) -> SphereView:
    """Local (wi, wo) per pixel for a unit sphere seen orthographically down −z.

    Tangent ``t = normalize(ŷ × n)`` (``(1, 0, 0)`` at the poles), ``b = n × t``;
    light ``l = (sin α, 0, cos α)``, view ``v = (0, 0, 1)``.
    """
    if not 1 <= size <= 8192:
        raise ValueError(f"sphere size must be 1..8192, got {size}")
    alpha = np.radians(incidence_deg)
    centres = (np.arange(size) + 0.5) / size * 2.0 - 1.0
    x, y = np.meshgrid(centres, -centres)
    r2 = x * x + y * y
    inside = r2 < 1.0
    n = np.stack([x[inside], y[inside], np.sqrt(1.0 - r2[inside])], axis=-1)
    t = np.stack([n[:, 2], np.zeros(len(n)), -n[:, 0]], axis=-1)
    length = np.linalg.norm(t, axis=-1, keepdims=True)
    pole = length[:, 0] < 1e-12
    t = np.where(pole[:, None], np.array([1.0, 0.0, 0.0]), t / np.where(pole[:, None], 1, length))
    b = np.cross(n, t)
    light = np.array([np.sin(alpha), 0.0, np.cos(alpha)])
    view = np.array([0.0, 0.0, 1.0])
    wi = np.stack([t @ light, b @ light, n @ light], axis=-1)
    wo = np.stack([t @ view, b @ view, n @ view], axis=-1)
    lit = (wi[:, 2] > 0) & (wo[:, 2] > 0)
    mask = np.zeros((size, size), dtype=bool)
    mask[inside] = lit
    return SphereView(wi[lit], wo[lit], mask, size)


def reference_xyz(brdf, wi: np.ndarray, wo: np.ndarray, illuminant: str | np.ndarray = "D65",
                  chunk: int = 8192) -> np.ndarray:
    """XYZ (N, 3) of the exact BRDF, 5 nm Riemann sum 380–780 nm, protocol-normalised."""
    wl = spectra.WAVELENGTHS_REFERENCE
    weights = colour_pipeline.xyz_weights(illuminant, wl)
    out = np.empty((wi.shape[0], 3))
    for begin in range(0, wi.shape[0], chunk):
        sl = slice(begin, begin + chunk)
        f = np.asarray(brdf(wi[sl], wo[sl], wl), dtype=np.float64)
        out[sl] = (f * np.clip(wi[sl, 2:3], 0.0, None)) @ weights
    return out


def delta_e94_stats(xyz_reference: np.ndarray, xyz_test: np.ndarray,
                    illuminant: str | np.ndarray = "D65") -> dict:
    """Mean, 95th percentile and max ΔE94 (white = the white Lambertian under ``illuminant``)."""
    white = colour_pipeline.white_xyz(illuminant, spectra.WAVELENGTHS_REFERENCE)
    de = colour_pipeline.delta_e94(xyz_reference, xyz_test, white)
    if de.size == 0:
        return {"mean": 0.0, "p95": 0.0, "max": 0.0, "count": 0}
    return {"mean": float(de.mean()), "p95": float(np.percentile(de, 95)),
            "max": float(de.max()), "count": int(de.size)}


def delta_e94_image(xyz_reference: np.ndarray, xyz_test: np.ndarray,
                    illuminant: str | np.ndarray = "D65") -> np.ndarray:
    """Per-sample ΔE94 (for heat maps)."""
    white = colour_pipeline.white_xyz(illuminant, spectra.WAVELENGTHS_REFERENCE)
    return colour_pipeline.delta_e94(xyz_reference, xyz_test, white)


def cosine_weighted_luminance_rms(brdf, model, count: int = 8000, seed: int = 1999) -> float:
    """RMS over ``count`` uniform pairs of the luminance error of ``f·cosθi``.

    Luminance is Y under an equal-energy light (Kautz & McCool 1999 §5.2),
    normalised like the protocol.
    """
    wi, wo = random_direction_pairs(count, seed)
    flat = np.ones(spectra.WAVELENGTHS_REFERENCE.size)
    ref = reference_xyz(brdf, wi, wo, flat)[:, 1]
    test = model.xyz(wi, wo, np.ones(np.asarray(model.wavelengths).size))[:, 1]
    return float(np.sqrt(np.mean((ref - test) ** 2)))


class ProtocolError:
    """ΔE94 under D65 at the protocol's random pairs, the 5 nm reference computed once.

    ``stats(model)`` measures any model with an ``xyz(wi, wo, illuminant)`` method.
    ``pairs`` (wi, wo): measure there instead (the Automatic checks near the horizon).
    """

    def __init__(self, brdf, count: int = RANDOM_PAIRS, seed: int = RANDOM_PAIRS_SEED,
                 pairs: tuple[np.ndarray, np.ndarray] | None = None):
        self.wi, self.wo = random_direction_pairs(count, seed) if pairs is None else pairs
        self.reference = reference_xyz(brdf, self.wi, self.wo, "D65")

    def stats(self, model) -> dict:
        return delta_e94_stats(self.reference, model.xyz(self.wi, self.wo, "D65"), "D65")
