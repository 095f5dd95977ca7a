"""The GPU draw path's maths in float64: the Python mirror that the shaders are tested against.

``glsl/`` evaluates, per pixel, the same steps as :func:`shade_xyz`: a shading
frame from the interpolated normal and tangent (:func:`shading_frame`), the view
direction, and for every light its direction and irradiance
(:meth:`SpectralLight.incidence`) times the factored BRDF's reflected XYZ
(:meth:`FactoredBRDF.xyz` with the light's spectral weights). The GPU reads its
inputs from two textures: the material's factor image and the light texture
built by :func:`light_texels`.

Images follow the GPU's convention: row 0 is the bottom row.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..colour import spectra
from ..lights import SpectralLight
from .factored import FactoredBRDF

#: Texels before the spectral weights in a light-texture row (glsl/common/lights.glsl).
LIGHT_HEADER = 3
#: Texels after the packs' light weights in the row of a model with an analytic lobe: the
#: XYZ weights of its two spectra (glsl/brdf/specular_lobe.glsl).
LOBE_TEXELS = 2
#: A tangent whose part orthogonal to n is this short (squared) carries no direction.
TANGENT_EPS_SQ = 1e-8


def _normalize(v: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    len2 = np.einsum("ij,ij->i", v, v)
    ok = len2 > 1e-30
    out = v / np.sqrt(np.where(ok, len2, 1.0))[:, None]
    return np.where(ok[:, None], out, fallback)


def generated_tangent(normals: np.ndarray) -> np.ndarray:
    """``normalize(ŷ × n)``, and x̂ where that is undefined (n = ±ŷ): the protocol's field."""
    n = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    g = np.stack([n[:, 2], np.zeros(len(n)), -n[:, 0]], axis=-1)
    len2 = np.einsum("ij,ij->i", g, g)
    ok = len2 > 1e-24
    g = g / np.sqrt(np.where(ok, len2, 1.0))[:, None]
    return np.where(ok[:, None], g, np.array([1.0, 0.0, 0.0]))


def shading_frame(normals: np.ndarray, tangents: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t, b, n) per point: the tangent made orthogonal to n, or the generated field.

    A zero, missing (pass zeros) or normal-parallel tangent falls back to
    :func:`generated_tangent`; a zero normal to +z. ``b = n × t``.
    """
    n = _normalize(np.asarray(normals, dtype=np.float64).reshape(-1, 3), np.array([0, 0, 1.0]))
    tangents = np.asarray(tangents, dtype=np.float64).reshape(-1, 3)
    t = tangents - n * np.einsum("ij,ij->i", n, tangents)[:, None]
    len2 = np.einsum("ij,ij->i", t, t)
    ok = len2 > TANGENT_EPS_SQ
    t = np.where(ok[:, None], t / np.sqrt(np.where(ok, len2, 1.0))[:, None],
                 generated_tangent(n))
    return t, np.cross(n, t), n


def to_local(frame: tuple[np.ndarray, np.ndarray, np.ndarray], v: np.ndarray) -> np.ndarray:
    t, b, n = frame
    return np.stack([np.einsum("ij,ij->i", t, v), np.einsum("ij,ij->i", b, v),
                     np.einsum("ij,ij->i", n, v)], axis=-1)


@dataclass(frozen=True)
class View:
    """The camera as the shaders see it: ``origin`` is the eye position (perspective)
    or the unit direction toward the viewer (orthographic)."""

    origin: tuple[float, float, float] = (0.0, 0.0, 1.0)
    perspective: bool = False

    def directions(self, points: np.ndarray) -> np.ndarray:
        """Unit directions from ``points (N, 3)`` toward the viewer."""
        origin = np.asarray(self.origin, dtype=np.float64)
        if not self.perspective:
            return np.broadcast_to(origin / np.linalg.norm(origin), points.shape).copy()
        return _normalize(origin - points, np.array([0.0, 0.0, 1.0]))

    def uniform(self) -> tuple[float, float, float, float]:
        """The shaders' ``view_origin`` (w = 1 for a perspective eye)."""
        return (*map(float, self.origin), 1.0 if self.perspective else 0.0)


def light_rows(lights: list[SpectralLight], spectral_texels) -> np.ndarray:
    """A light texture (lights, LIGHT_HEADER + K, 4) float32 (glsl/common/lights.glsl).

    Header texels: (position, type code), (axis, strength), (spot cos, spot blend
    width, 0, 0); then ``spectral_texels(light)``, (K, 4), whatever the shader reads after
    the header. Every draw path's light texture is built here.
    """
    if not lights:
        raise ValueError("nothing to draw with: no lights")
    rows = []
    for light in lights:
        header = np.zeros((LIGHT_HEADER, 4))
        header[0] = (*light.position, light.code)
        header[1] = (*light.axis, light.strength)
        header[2, :2] = (light.spot_cos, light.spot_blend_width)
        rows.append(np.concatenate([header, np.asarray(spectral_texels(light), np.float64)]))
    texels = np.stack(rows)
    if not np.isfinite(texels).all() or np.abs(texels).max() > np.finfo(np.float32).max:
        raise ValueError("light data overflow float32: a light's strength or SPD is too large")
    return texels.astype(np.float32)


def light_row_texels(packs: int, coefficients: int, precontract: bool) -> int:
    """Texels in a light row of :func:`light_texels`: the header, then 3 per pack of 4
    terms (``precontract``) or one per spectral coefficient."""
    return LIGHT_HEADER + (3 * int(packs) if precontract else int(coefficients))


def lobe_texel(model: FactoredBRDF, precontract: bool) -> int:
    """Where a light row's lobe weights start (after the packs'), 0 without a lobe."""
    if model.lobe is None:
        return 0
    return light_row_texels(-(-model.terms // 4), model.spectral_size, precontract)


def xyz_texels(weights: np.ndarray) -> np.ndarray:
    """(S, 4): spectral XYZ weights (S, 3), one texel each (xyz, w = 0)."""
    out = np.zeros((len(weights), 4))
    out[:, :3] = weights
    return out


def light_texels(model: FactoredBRDF, lights: list[SpectralLight], *,
                 precontract: bool = True) -> np.ndarray:
    """The light texture (lights, width, 4) float32 for drawing ``model`` (glsl/common/lights.glsl).

    After the header (:func:`light_rows`): with ``precontract``, 3 texels per pack holding
    the X, Y, Z weights of its 4 terms, ``K = spectralᵀ Ĩ``; without, the light's
    spectral weights Ĩ_j (one texel each, xyz). A model with an analytic lobe adds
    :data:`LOBE_TEXELS` texels (at :func:`lobe_texel`): its spectra's weights ``cᵀĨ``.
    """
    if model.form != "cp":
        raise ValueError("the GPU path draws CP factor packs; refactor separable models as CP")
    groups = -(-model.terms // 4)
    spectral = np.zeros((model.spectral_size, groups * 4))
    spectral[:, : model.terms] = model.spectral

    def after_header(light: SpectralLight) -> np.ndarray:
        weights = light.weights(model.wavelengths, model.basis)          # (S, 3)
        if not precontract:
            texels = xyz_texels(weights)
        else:
            k = spectral.T @ weights                                      # (4G, 3)
            texels = k.reshape(groups, 4, 3).transpose(0, 2, 1).reshape(3 * groups, 4)
        if model.lobe is None:
            return texels
        lobe = xyz_texels(np.asarray(model.lobe.spectral, np.float64).T @ weights)
        return np.concatenate([texels, lobe])

    return light_rows(lights, after_header)


def _shade(points, normals, tangents, view: View, lights, reflect, two_sided: bool):
    """Σ_lights irradiance · reflect(wi, wo, light) over lit points (the shaders' loop)."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    normals = _normalize(np.asarray(normals, dtype=np.float64).reshape(-1, 3),
                         np.array([0.0, 0.0, 1.0]))
    v = view.directions(points)
    if two_sided:
        normals = np.where((np.einsum("ij,ij->i", normals, v) < 0)[:, None], -normals, normals)
    frame = shading_frame(normals, tangents)
    wo = to_local(frame, v)
    xyz = np.zeros((len(points), 3))
    for light in lights:
        wi_world, irradiance = light.incidence(points)
        wi = to_local(frame, wi_world)
        lit = (irradiance > 0) & (wi[:, 2] > 0) & (wo[:, 2] > 0)
        if lit.any():
            xyz[lit] += irradiance[lit, None] * reflect(wi[lit], wo[lit], light)
    return xyz


def shade_xyz(model: FactoredBRDF, points: np.ndarray, normals: np.ndarray,
              tangents: np.ndarray, view: View, lights: list[SpectralLight],
              *, two_sided: bool = True) -> np.ndarray:
    """Linear XYZ (N, 3) leaving each point toward the viewer: the shaders' maths in float64.

    ``two_sided`` flips normals that face away from the viewer, as the mesh
    shader does.
    """
    def reflect(wi, wo, light):
        return model.reflected_xyz(wi, wo, light.weights(model.wavelengths, model.basis))

    return _shade(points, normals, tangents, view, lights, reflect, two_sided)


def reference_shade_xyz(brdf, points: np.ndarray, normals: np.ndarray, tangents: np.ndarray,
                        view: View, lights: list[SpectralLight], *, two_sided: bool = True,
                        chunk: int = 16384) -> np.ndarray:
    """The same scene with the exact BRDF ``brdf(wi, wo, λ)``, 5 nm Riemann sums (PROTOCOL.md)."""
    wl = spectra.WAVELENGTHS_REFERENCE

    def reflect(wi, wo, light):
        weights = light.weights(wl, None)
        out = np.empty((len(wi), 3))
        for begin in range(0, len(wi), chunk):
            sl = slice(begin, begin + chunk)
            f = np.asarray(brdf(wi[sl], wo[sl], wl), dtype=np.float64)
            out[sl] = (f * wi[sl, 2:3]) @ weights
        return out

    return _shade(points, normals, tangents, view, lights, reflect, two_sided)


def sphere_pixels(size: int) -> tuple[np.ndarray, np.ndarray]:
    """The protocol sphere as the GPU rasterises it: (points (P, 3), mask (size, size)).

    Pixel centres map to [−1, 1]² with row 0 at the bottom; a pixel is on the
    sphere when x² + y² < 1, where the point (and normal) is (x, y, √(1 − r²)).
    """
    if not 1 <= size <= 8192:
        raise ValueError(f"sphere size must be 1..8192, got {size}")
    centres = (np.arange(size) + 0.5) / size * 2.0 - 1.0
    x, y = np.meshgrid(centres, centres)
    r2 = x * x + y * y
    mask = r2 < 1.0
    points = np.stack([x[mask], y[mask], np.sqrt(1.0 - r2[mask])], axis=-1)
    return points, mask


def protocol_sun(incidence_deg: float, spd: np.ndarray | str = "D65",
                 wavelengths: np.ndarray | None = None) -> SpectralLight:
    """The sphere protocol's light: a sun of strength 1 at ``l = (sin α, 0, cos α)``."""
    from ..colour import pipeline as colour_pipeline, spectra

    wl = spectra.WAVELENGTHS_REFERENCE if wavelengths is None else wavelengths
    values = colour_pipeline.illuminant_spd(spd, wl)
    alpha = np.radians(float(incidence_deg))
    return SpectralLight("SUN", values, wl, strength=1.0,
                         axis=(-np.sin(alpha), 0.0, -np.cos(alpha)),
                         name=spd if isinstance(spd, str) else "SPD")


def sphere_xyz(model: FactoredBRDF, incidence_deg: float, illuminant: np.ndarray | str = "D65",
               size: int = 256) -> tuple[np.ndarray, np.ndarray]:
    """The protocol sphere's XYZ image (size, size, 3), row 0 at the bottom, and its lit mask."""
    points, mask = sphere_pixels(size)
    light = protocol_sun(incidence_deg, illuminant, model.wavelengths)
    xyz = shade_xyz(model, points, points, np.zeros_like(points), View(), [light],
                    two_sided=False)
    image = np.zeros((size, size, 3))
    image[mask] = xyz
    return image, mask
