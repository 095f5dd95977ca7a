"""Analytic spectral BRDF models.

Every model is a small class built from keyword parameters and called as
``f(wi, wo, wavelengths) -> ndarray (N, L)``:

* ``wi`` points from the surface towards the light, ``wo`` towards the viewer;
  both are unit vectors ``(N, 3)`` in the local shading frame (z the surface
  normal, x the primary tangent, y = z × x);
* ``wavelengths`` is a 1-D array of L wavelengths in nm;
* the result is the BRDF itself (sr⁻¹), *without* the cosine factor, and is
  exactly 0 wherever cos θi <= 0 or cos θo <= 0.

Spectral parameters are :data:`~spectral_materials.core.colour.spectra.SpectrumLike`
and are evaluated once per wavelength grid (cached on the instance), because a
model is called many times on chunks of directions over the same grid.

All models here are reciprocal, ``f(wi, wo) == f(wo, wi)``. Their common
numerical rules: everything is float64 and vectorised; half-vector quantities
are formed from ``v = wi + wo`` (whose z component ``cos θi + cos θo`` is
positive wherever the BRDF is non-zero); denominators that can only vanish in
the limit of both directions on the horizon are floored at ``1e-300`` so the
result stays finite; exponentials that underflow give 0 silently.

Models
------
:class:`Lambert`
    ρ/π.
:class:`OrenNayar`
    Rough diffuse, qualitative model.
:class:`AshikhminShirley`
    Anisotropic Phong lobe with Schlick Fresnel and a coupled diffuse term.
:class:`WardAnisotropic`
    Elliptical Gaussian lobe.
:class:`CookTorranceGGX`
    Microfacet: anisotropic GGX distribution, height-correlated Smith
    masking-shadowing, exact conductor Fresnel.

References
----------
.. [1] Lambert, J. H. (1760). *Photometria*. Augsburg.
.. [2] Oren, M., Nayar, S. K. (1994). Generalization of Lambert's reflectance
   model. SIGGRAPH '94, 239–246 (the "qualitative model", eq. 30).
.. [3] Ashikhmin, M., Shirley, P. (2000). An anisotropic Phong BRDF model.
   Journal of Graphics Tools 5(2), 25–32.
.. [4] Ward, G. J. (1992). Measuring and modeling anisotropic reflection.
   SIGGRAPH '92, 265–272.
.. [5] Walter, B., Marschner, S. R., Li, H., Torrance, K. E. (2007).
   Microfacet models for refraction through rough surfaces. EGSR 2007.
.. [6] Heitz, E. (2014). Understanding the masking-shadowing function in
   microfacet-based BRDFs. Journal of Computer Graphics Techniques 3(2),
   48–107 (anisotropic GGX Λ, eq. 86; height-correlated G2, eq. 99).
.. [7] Born, M., Wolf, E. (1999). *Principles of Optics*, 7th ed., §14.2
   (Fresnel equations for an absorbing medium).
.. [8] Dür, A. (2006). An improved normalization for the Ward reflectance
   model. Journal of Graphics Tools 11(1), 51–59 (the original Ward lobe's
   albedo falls off at grazing incidence).

The base class and the helpers live in :mod:`.model_base`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..colour.spectra import SpectrumLike
from .model_base import (
    _TINY,
    _UNIT,
    BRDFModel,
    _check_scalar,
    _Interval,
    _norm,
    fresnel_conductor,
)

__all__ = [
    "MODELS",
    "AshikhminShirley",
    "BRDFModel",
    "CookTorranceGGX",
    "Lambert",
    "OrenNayar",
    "WardAnisotropic",
    "fresnel_conductor",
    "make_model",
]


class Lambert(BRDFModel):
    """Lambertian diffuse reflector, f = ρ/π.

    Parameters
    ----------
    albedo : SpectrumLike
        Reflectance ρ, in [0, 1].
    """

    name = "lambert"

    def __init__(self, albedo: SpectrumLike = 0.8):
        self._init_spectra(albedo=(albedo, _UNIT))

    def _evaluate(self, wi, wo, params):
        rho = params["albedo"] / np.pi
        return np.broadcast_to(rho, (wi.shape[0], rho.size)).copy()


class OrenNayar(BRDFModel):
    """Oren–Nayar rough diffuse reflector, qualitative model (Oren & Nayar 1994).

    f = ρ/π (A + B max(0, cos(φi − φo)) sin α tan β), α = max(θi, θo),
    β = min(θi, θo), A = 1 − 0.5σ²/(σ² + 0.33), B = 0.45σ²/(σ² + 0.09).

    The angular term is evaluated without any angle: for unit vectors
    ``sin θi sin θo cos(φi − φo) = xi xo + yi yo`` and
    ``sin α tan β = sin θi sin θo / max(cos θi, cos θo)``, so the term is
    ``max(0, xi xo + yi yo) / max(cos θi, cos θo)``, which is 0 at the poles
    (where the azimuth is undefined) with no special case.

    Parameters
    ----------
    albedo : SpectrumLike
        Reflectance ρ, in [0, 1].
    sigma : float
        Standard deviation of the facet slope angle in radians, >= 0 (any
        finite value; A → 1/2 and B → 0.45 as σ → ∞). σ = 0 is exactly
        :class:`Lambert`.

    Notes
    -----
    The qualitative model is only approximately energy conserving. Measured
    directional albedo ∫ f cos θo dωo with ρ = 1: for σ >= 0.35 it stays
    below 1 at every incidence angle (0.83 at most for σ = 1, 0.72 for
    σ = 10); for 0 < σ < 0.35 it exceeds 1 at grazing incidence, from θi ≈ 60°
    (small σ) to θi ≈ 86° (σ = 0.3), by at most 1.5 % (σ ≈ 0.2, θi → 90°).
    """

    name = "oren_nayar"

    def __init__(self, albedo: SpectrumLike = 0.8, sigma: float = 0.3):
        self.sigma = _check_scalar("sigma", sigma, _Interval(0.0, np.inf, hi_open=True))
        if self.sigma == 0.0:
            self._a, self._b = 1.0, 0.0
        else:  # s²/(s² + c) written so that huge sigma cannot overflow
            self._a = 1.0 - 0.5 / (1.0 + (0.33 / self.sigma) / self.sigma)
            self._b = 0.45 / (1.0 + (0.09 / self.sigma) / self.sigma)
        self._init_spectra(albedo=(albedo, _UNIT))

    def _scalar_params(self):
        return {"sigma": self.sigma}

    def _evaluate(self, wi, wo, params):
        rho = params["albedo"] / np.pi
        projected = wi[:, 0] * wo[:, 0] + wi[:, 1] * wo[:, 1]
        term = np.maximum(projected, 0.0) / np.maximum(wi[:, 2], wo[:, 2])
        return rho[None, :] * (self._a + self._b * term)[:, None]


class AshikhminShirley(BRDFModel):
    """Ashikhmin–Shirley anisotropic Phong BRDF (Ashikhmin & Shirley 2000).

    With h the half vector and k = wi (h·wi = h·wo):

    f_s = √((nu+1)(nv+1)) / (8π) · (n·h)^E / ((h·k) max(cos θi, cos θo)) · F(h·k),
    E = (nu hx² + nv hy²) / (1 − hz²), F(c) = Rs + (1 − Rs)(1 − c)⁵,

    f_d = 28 Rd / (23π) (1 − Rs) (1 − (1 − cos θi / 2)⁵) (1 − (1 − cos θo / 2)⁵).

    Numerics: E is computed as ``(nu hx² + nv hy²) / (hx² + hy²)``, which
    stays within [nu, nv]; where hx² + hy² = 0 (h = n) the lobe is exactly 1.
    (n·h)^E is ``exp(E log hz)`` with ``log hz = ½ log1p(−(hx² + hy²))``,
    accurate near hz = 1; large exponents underflow to 0, never overflow.

    Parameters
    ----------
    nu, nv : float
        Phong exponents along the tangent x and the bitangent y, in [0, 1e6].
    diffuse : SpectrumLike
        Diffuse reflectance Rd, in [0, 1].
    specular : SpectrumLike
        Specular reflectance at normal incidence Rs, in [0, 1].

    Notes
    -----
    Rd and Rs can be chosen independently; the (1 − Rs) factor already couples
    the diffuse layer to the specular one.
    """

    name = "ashikhmin_shirley"

    def __init__(
        self,
        nu: float = 100.0,
        nv: float = 100.0,
        diffuse: SpectrumLike = 0.5,
        specular: SpectrumLike = 0.05,
    ):
        exponent = _Interval(0.0, 1e6)
        self.nu = _check_scalar("nu", nu, exponent)
        self.nv = _check_scalar("nv", nv, exponent)
        self._norm = np.sqrt((self.nu + 1.0) * (self.nv + 1.0)) / (8.0 * np.pi)
        self._init_spectra(diffuse=(diffuse, _UNIT), specular=(specular, _UNIT))

    def _scalar_params(self):
        return {"nu": self.nu, "nv": self.nv}

    def _evaluate(self, wi, wo, params):
        rd, rs = params["diffuse"], params["specular"]
        cos_i, cos_o = wi[:, 2], wo[:, 2]
        v = wi + wo
        length = _norm(v)
        h = v / length[:, None]
        h_dot_k = np.minimum(0.5 * length, 1.0)  # |wi + wo| / 2 for unit vectors
        hx2, hy2 = h[:, 0] ** 2, h[:, 1] ** 2
        s2 = hx2 + hy2  # sin² θh
        off_pole = s2 > 0.0
        ratio = np.divide(hy2, s2, out=np.zeros_like(s2), where=off_pole)
        exponent = self.nu + (self.nv - self.nu) * np.clip(ratio, 0.0, 1.0)
        log_hz = 0.5 * np.log1p(-np.minimum(s2, 0.5))
        far = s2 >= 0.5
        log_hz[far] = np.log(np.maximum(h[far, 2], np.finfo(np.float64).tiny))
        lobe = np.exp(exponent * log_hz)
        denominator = np.maximum(h_dot_k * np.maximum(cos_i, cos_o), _TINY)
        schlick = (1.0 - h_dot_k) ** 5
        fresnel = rs[None, :] + (1.0 - rs)[None, :] * schlick[:, None]
        specular = (self._norm * lobe / denominator)[:, None] * fresnel
        shape = (1.0 - (1.0 - 0.5 * cos_i) ** 5) * (1.0 - (1.0 - 0.5 * cos_o) ** 5)
        diffuse = (28.0 / (23.0 * np.pi)) * (rd * (1.0 - rs))[None, :] * shape[:, None]
        return specular + diffuse


class WardAnisotropic(BRDFModel):
    """Ward's anisotropic elliptical Gaussian BRDF (Ward 1992).

    f = ρd/π + ρs exp(−(hx²/αx² + hy²/αy²)/hz²) / (4π αx αy √(cos θi cos θo)),

    with h the normalised half vector (the ratio in the exponent is computed
    from the unnormalised ``wi + wo``, which gives the same value).

    Parameters
    ----------
    alpha_x, alpha_y : float
        RMS slopes along x and y, in (0, 10].
    diffuse : SpectrumLike
        ρd, in [0, 1].
    specular : SpectrumLike
        ρs, in [0, 1].

    Notes
    -----
    Ward's normalisation is only approximate. For a narrow lobe the
    directional albedo of the specular term is ≈ ρs cos θi (too dark at
    grazing incidence, Dür 2006), while the ``1/√(cos θi cos θo)`` factor
    diverges at the horizon, so the albedo finally exceeds ρs very close to
    it. Measured with ρs = 1, ρd = 0 (quadrature over the outgoing
    hemisphere) for αx, αy in [0.01, 10]: the albedo is <= 1 for every
    θi <= 89° (at most 0.99 at normal incidence, 0.41 at 85°, 0.77 at 89°,
    the worst case being αx = 1, αy <= 0.05 with incidence along x). Beyond,
    it grows like 1/√cos θi and passes 1 at θi ≈ 89.4° (αx = 1, αy = 0.05),
    89.74° (isotropic α ≈ 0.7), 89.9° (α = 0.3 or 2), 89.99° (α = 0.1 or 5).
    With ρd + ρs <= 1 the model is therefore energy-plausible except within
    about 0.6° of the horizon.
    """

    name = "ward"

    def __init__(
        self,
        alpha_x: float = 0.2,
        alpha_y: float = 0.2,
        diffuse: SpectrumLike = 0.5,
        specular: SpectrumLike = 0.05,
    ):
        roughness = _Interval(0.0, 10.0, lo_open=True)
        self.alpha_x = _check_scalar("alpha_x", alpha_x, roughness)
        self.alpha_y = _check_scalar("alpha_y", alpha_y, roughness)
        self._norm = 1.0 / (4.0 * np.pi * self.alpha_x * self.alpha_y)
        self._init_spectra(diffuse=(diffuse, _UNIT), specular=(specular, _UNIT))

    def _scalar_params(self):
        return {"alpha_x": self.alpha_x, "alpha_y": self.alpha_y}

    def _evaluate(self, wi, wo, params):
        rd, rs = params["diffuse"], params["specular"]
        v = wi + wo
        slope2 = (v[:, 0] / self.alpha_x) ** 2 + (v[:, 1] / self.alpha_y) ** 2
        tan2 = slope2 / np.maximum(v[:, 2] ** 2, _TINY)
        root = np.maximum(np.sqrt(wi[:, 2]) * np.sqrt(wo[:, 2]), _TINY)
        lobe = self._norm * np.exp(-tan2) / root
        return (rd / np.pi)[None, :] + rs[None, :] * lobe[:, None]


class CookTorranceGGX(BRDFModel):
    """Cook–Torrance microfacet BRDF with anisotropic GGX and conductor Fresnel.

    f = D(h) G2(wi, wo) F(h·wi) / (4 cos θi cos θo) + diffuse/π, with

    * D: anisotropic GGX / Trowbridge–Reitz,
      D(h) = 1 / (π αx αy (hx²/αx² + hy²/αy² + hz²)²) (Walter et al. 2007);
    * G2: height-correlated Smith, G2 = 1 / (1 + Λ(wi) + Λ(wo)) with
      Λ(ω) = (√(1 + (αx² ωx² + αy² ωy²)/ωz²) − 1) / 2 (Heitz 2014). It is
      evaluated in the equivalent overflow-free form
      G2 / (4 cos θi cos θo) = 1 / (2 (cos θo r_i + cos θi r_o)),
      r = √(ωz² + αx² ωx² + αy² ωy²);
    * F: exact unpolarised Fresnel reflectance from air onto n + ik, see
      :func:`fresnel_conductor`.

    Parameters
    ----------
    alpha_x, alpha_y : float
        GGX roughness along x and y, in [1e-4, 1].
    ior_n : SpectrumLike
        Real part n of the complex refractive index, > 0 (up to 100).
    ior_k : SpectrumLike
        Extinction coefficient k, in [0, 100]; 0 for a dielectric.
    diffuse : SpectrumLike
        Optional Lambertian term's albedo, in [0, 1] (default 0).

    Notes
    -----
    Single scattering only: energy lost to multiple bounces between facets
    is not restored, so rough conductors look slightly dark. The diffuse term
    is simply added (no Fresnel coupling); keep it 0 for metals.
    """

    name = "ggx"

    def __init__(
        self,
        alpha_x: float = 0.2,
        alpha_y: float = 0.2,
        ior_n: SpectrumLike = 1.5,
        ior_k: SpectrumLike = 0.0,
        diffuse: SpectrumLike = 0.0,
    ):
        roughness = _Interval(1e-4, 1.0)
        self.alpha_x = _check_scalar("alpha_x", alpha_x, roughness)
        self.alpha_y = _check_scalar("alpha_y", alpha_y, roughness)
        self._init_spectra(
            ior_n=(ior_n, _Interval(0.0, 100.0, lo_open=True)),
            ior_k=(ior_k, _Interval(0.0, 100.0)),
            diffuse=(diffuse, _UNIT),
        )

    def _scalar_params(self):
        return {"alpha_x": self.alpha_x, "alpha_y": self.alpha_y}

    def _visibility(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """G2 / (4 cos θi cos θo), height-correlated Smith for anisotropic GGX."""
        ax2, ay2 = self.alpha_x**2, self.alpha_y**2

        def r(w: np.ndarray) -> np.ndarray:
            return np.sqrt(w[:, 2] ** 2 + ax2 * w[:, 0] ** 2 + ay2 * w[:, 1] ** 2)

        denominator = wo[:, 2] * r(wi) + wi[:, 2] * r(wo)
        return 0.5 / np.maximum(denominator, _TINY)

    def _evaluate(self, wi, wo, params):
        v = wi + wo
        length = _norm(v)
        h = v / length[:, None]
        h_dot_k = np.minimum(0.5 * length, 1.0)
        stretched = (h[:, 0] / self.alpha_x) ** 2 + (h[:, 1] / self.alpha_y) ** 2 + h[:, 2] ** 2
        d = 1.0 / (np.pi * self.alpha_x * self.alpha_y * stretched**2)
        fresnel = fresnel_conductor(h_dot_k, params["ior_n"], params["ior_k"])
        specular = (d * self._visibility(wi, wo))[:, None] * fresnel
        return specular + (params["diffuse"] / np.pi)[None, :]


#: Model classes by registry name.
MODELS: dict[str, type[BRDFModel]] = {
    "lambert": Lambert,
    "oren_nayar": OrenNayar,
    "ashikhmin_shirley": AshikhminShirley,
    "ward": WardAnisotropic,
    "ggx": CookTorranceGGX,
}


def make_model(name: str, **params: Any) -> BRDFModel:
    """Build a model from its registry name and keyword parameters.

    ``make_model(**model.describe())`` rebuilds an equivalent model (spectra
    described as sampled lists are passed back as ``(wavelengths, values)``).
    """
    key = str(name).lower()
    if key not in MODELS:
        raise ValueError(f"unknown BRDF model {name!r}; choose one of {', '.join(MODELS)}")
    cls = MODELS[key]
    kwargs = {
        k: (tuple(np.asarray(v[f], dtype=np.float64) for f in ("wavelengths", "values"))
            if isinstance(v, dict) else v)
        for k, v in params.items()
    }
    try:
        return cls(**kwargs)
    except TypeError as exc:  # unknown keyword
        raise ValueError(f"{key}: {exc}") from None

