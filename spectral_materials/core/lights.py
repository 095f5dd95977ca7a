"""Spectral lights: where light comes from and how much arrives, for drawing.

A :class:`SpectralLight` is a sun, point, spot or area light with an SPD. Its
``incidence(points)`` gives, at each shaded point, the unit direction toward the
light and the irradiance it brings to a surface facing it; the SPD only sets
the colour (it is normalised as shared/PROTOCOL.md says, so that a white
Lambertian facing a sun of strength 1 reflects Y = 1). ``glsl/common/lights.glsl`` is
the same code for the GPU, and tests hold the two together.

Strengths follow Blender's units: a sun's strength is its irradiance (W/m²); a
point or spot light of power P has intensity P / 4π (W/sr), so a sun of strength
E lights a surface as a point light of power 4π r² E at distance r does. A spot
is a point light masked by Blender's cone: ``smoothstep`` of
``(cos α − cos(size/2)) / ((1 − cos(size/2))·blend)`` with α the angle off its
axis. An area light is drawn as a small one-sided Lambertian emitter of power
P, intensity ``P cos θe / π``, where θe is the angle off its axis: exact far from
the light, an approximation within a few light sizes of it (its shape and size
are left out).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .colour import pipeline as colour_pipeline, spectra

LIGHT_CODES = {"SUN": 0, "POINT": 1, "SPOT": 2, "AREA": 3}
#: Closer than this (squared distance) a point light sits on the shaded point and
#: its direction is undefined: it contributes nothing there.
MIN_DISTANCE_SQ = 1e-10


def _unit(vector, name: str) -> np.ndarray:
    v = np.asarray(vector, dtype=np.float64).reshape(3)
    length = float(np.linalg.norm(v))
    if not np.isfinite(v).all() or length == 0.0:
        raise ValueError(f"{name} must be a finite non-zero 3-vector, got {v}")
    return v / length


@dataclass(frozen=True, eq=False)
class SpectralLight:
    """One light; see the module docstring for the units and the falloffs.

    ``axis`` is the direction the light points (Blender's −Z of the light
    object); ``spot_size`` is the full cone angle in radians.
    """

    kind: str
    spd: np.ndarray = field(repr=False)
    wavelengths: np.ndarray = field(default_factory=lambda: spectra.WAVELENGTHS_REFERENCE,
                                   repr=False)
    strength: float = 1.0
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    axis: tuple[float, float, float] = (0.0, 0.0, -1.0)
    spot_size: float = np.pi / 4
    spot_blend: float = 0.15
    name: str = ""

    def __post_init__(self) -> None:
        if self.kind not in LIGHT_CODES:
            raise ValueError(f"light {self.name!r}: kind must be one of {sorted(LIGHT_CODES)}, "
                             f"got {self.kind!r}")
        spd = np.asarray(self.spd, dtype=np.float64)
        wl = spectra.check_wavelengths(self.wavelengths)
        if spd.shape != wl.shape or not np.isfinite(spd).all() or np.any(spd < 0):
            raise ValueError(f"light {self.name!r}: SPD must be finite, non-negative and "
                             f"match its {wl.size} wavelengths, got shape {spd.shape}")
        object.__setattr__(self, "spd", spd)
        object.__setattr__(self, "wavelengths", wl)
        if not (np.isfinite(self.strength) and self.strength >= 0):
            raise ValueError(f"light {self.name!r}: strength must be finite and ≥ 0, "
                             f"got {self.strength}")
        object.__setattr__(self, "axis", tuple(_unit(self.axis, f"light {self.name!r} axis")))
        position = np.asarray(self.position, dtype=np.float64).reshape(3)
        if not np.isfinite(position).all():
            raise ValueError(f"light {self.name!r}: position must be finite, got {position}")
        object.__setattr__(self, "position", tuple(position))
        if not 0.0 < self.spot_size <= np.pi:
            raise ValueError(f"light {self.name!r}: spot size must be in (0, π], "
                             f"got {self.spot_size}")
        if not 0.0 <= self.spot_blend <= 1.0:
            raise ValueError(f"light {self.name!r}: spot blend must be in [0, 1], "
                             f"got {self.spot_blend}")

    @property
    def code(self) -> int:
        return LIGHT_CODES[self.kind]

    @property
    def spot_cos(self) -> float:
        return float(np.cos(self.spot_size / 2.0))

    @property
    def spot_blend_width(self) -> float:
        return float((1.0 - self.spot_cos) * self.spot_blend)

    def weights(self, wavelengths: np.ndarray, basis: np.ndarray | None) -> np.ndarray:
        """Ĩ (S, 3): the SPD × CMFs, protocol-normalised, on ``basis`` (or per wavelength)."""
        wl = spectra.check_wavelengths(wavelengths)
        return colour_pipeline.xyz_weights(self.spd_on(wl), wl, basis)

    def spd_on(self, wavelengths: np.ndarray) -> np.ndarray:
        """The SPD on ``wavelengths``: linear interpolation, 0 outside its own range."""
        wl = np.asarray(wavelengths, dtype=np.float64)
        if wl.shape == self.wavelengths.shape and np.array_equal(wl, self.wavelengths):
            return self.spd
        return np.interp(wl, self.wavelengths, self.spd, left=0.0, right=0.0)

    def incidence(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(wi (N, 3) toward the light, irradiance (N,))`` at world ``points (N, 3)``.

        ``wi`` is zero (and the irradiance 0) where a point light sits on the point.
        """
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        axis = np.asarray(self.axis)
        if self.kind == "SUN":
            return np.broadcast_to(-axis, points.shape).copy(), np.full(len(points),
                                                                       float(self.strength))
        d = np.asarray(self.position) - points
        r2 = np.einsum("ij,ij->i", d, d)
        near = r2 < MIN_DISTANCE_SQ
        safe = np.where(near, 1.0, r2)
        wi = np.where(near[:, None], 0.0, d / np.sqrt(safe)[:, None])
        if self.kind == "AREA":
            cos_e = np.clip(-(wi @ axis), 0.0, None)
            irradiance = self.strength * cos_e / (np.pi * safe)
        else:
            irradiance = self.strength / (4.0 * np.pi * safe)
            if self.kind == "SPOT":
                irradiance = irradiance * self.spot_mask(-(wi @ axis))
        return wi, np.where(near, 0.0, irradiance)

    def spot_mask(self, cos_angle: np.ndarray) -> np.ndarray:
        """Blender's spot cone: a smoothstep over the blend band, a hard edge at blend 0."""
        width = self.spot_blend_width
        if width > 0:
            t = np.clip((cos_angle - self.spot_cos) / width, 0.0, 1.0)
        else:
            t = (cos_angle >= self.spot_cos).astype(np.float64)
        return t * t * (3.0 - 2.0 * t)
