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
"""

from __future__ import annotations

from typing import Any, ClassVar

import colour
import numpy as np

from ..colour import spectra
from ..colour.spectra import SpectrumLike

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

#: Floor for denominators that vanish only with both directions on the horizon.
_TINY = 1e-300

#: Relative tolerance on |wi| = |wo| = 1.
_UNIT_TOLERANCE = 1e-3

#: Wavelength grids whose evaluated spectra a model keeps.
_CACHE_SIZE = 16


class _Interval:
    """A closed or half-open interval of allowed parameter values."""

    def __init__(self, lo: float, hi: float, lo_open: bool = False, hi_open: bool = False):
        self.lo, self.hi, self.lo_open, self.hi_open = lo, hi, lo_open, hi_open

    def contains(self, values: np.ndarray) -> bool:
        values = np.asarray(values, dtype=np.float64)
        above = values > self.lo if self.lo_open else values >= self.lo
        below = values < self.hi if self.hi_open else values <= self.hi
        return bool(np.all(np.isfinite(values) & above & below))

    def __str__(self) -> str:
        left = "(" if self.lo_open else "["
        right = ")" if self.hi_open else "]"
        return f"{left}{self.lo:g}, {self.hi:g}{right}"


_UNIT = _Interval(0.0, 1.0)


def _check_scalar(name: str, value: float, interval: _Interval) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number in {interval}, got {value!r}") from None
    if not interval.contains(number):
        raise ValueError(f"{name} must lie in {interval}, got {number!r}")
    return number


def _describe_spectrum(spectrum: SpectrumLike) -> float | dict[str, list[float]]:
    """A JSON-serialisable form of a spectrum: a scalar or sampled lists."""
    if isinstance(spectrum, int | float | np.integer | np.floating):
        return float(spectrum)
    if isinstance(spectrum, colour.SpectralDistribution):
        wl, values = spectrum.wavelengths, spectrum.values
    elif isinstance(spectrum, tuple) and len(spectrum) == 2:
        wl, values = spectrum
    else:  # a callable: sample it on the reference grid
        wl = spectra.WAVELENGTHS_REFERENCE
        values = spectra.spectrum_values(spectrum, wl)
    return {
        "wavelengths": [float(x) for x in np.asarray(wl, dtype=np.float64)],
        "values": [float(x) for x in np.asarray(values, dtype=np.float64)],
    }


def _norm(v: np.ndarray) -> np.ndarray:
    """Row lengths of ``(N, 3)`` vectors without underflow (hypot, not a sum of squares)."""
    return np.hypot(np.hypot(v[:, 0], v[:, 1]), v[:, 2])


def _check_directions(vectors: Any, name: str) -> np.ndarray:
    """Validate ``(N, 3)`` unit vectors and return them renormalised, float64."""
    try:
        array = np.asarray(vectors, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a numeric array of shape (N, 3)") from None
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f"{name} must have shape (N, 3), got {array.shape}")
    if not np.isfinite(array).all():
        bad = int((~np.isfinite(array).all(axis=1)).sum())
        raise ValueError(f"{name} contains NaN or inf in {bad} of {array.shape[0]} rows")
    norm = np.sqrt(np.einsum("ij,ij->i", array, array))
    if np.any(np.abs(norm - 1.0) > _UNIT_TOLERANCE):
        worst = float(norm[np.argmax(np.abs(norm - 1.0))])
        raise ValueError(f"{name} must hold unit vectors; found a row of length {worst:.6g}")
    return array / norm[:, None]


def fresnel_conductor(
    cos_theta: np.ndarray, n: np.ndarray | float, k: np.ndarray | float
) -> np.ndarray:
    """Exact unpolarised Fresnel reflectance from air onto a medium ``n + ik``.

    Parameters
    ----------
    cos_theta : array_like (M,)
        Cosine of the angle of incidence, in [0, 1].
    n, k : array_like (L,) or float
        Real and imaginary parts of the complex refractive index (n > 0,
        k >= 0; k = 0 is a dielectric).

    Returns
    -------
    ndarray (M, L)
        ``(|r_s|² + |r_p|²) / 2``. Equals ``((n−1)² + k²) / ((n+1)² + k²)`` at
        normal incidence and 1 at grazing incidence.

    Notes
    -----
    With η = n + ik and w = √(η² − sin²θ) = η cos θt (principal root, which
    has Re ≥ 0 and Im ≥ 0 here, the physical branch),
    r_s = (cos θ − w) / (cos θ + w) and r_p = (η² cos θ − w) / (η² cos θ + w)
    (Born & Wolf §14.2). For k = 0 and n < 1 the root becomes imaginary past
    the critical angle, which gives |r| = 1 (total reflection).
    """
    c = np.clip(np.asarray(cos_theta, dtype=np.float64), 0.0, 1.0)[..., None]
    eta = np.asarray(n, dtype=np.float64) + 1j * np.asarray(k, dtype=np.float64)
    eta2 = eta * eta
    w = np.sqrt(eta2 - (1.0 - c * c))
    # The denominators vanish only for η = 1 at exactly grazing incidence (no
    # interface at all): return 0 there, the value for every other angle.
    r_s = _divide(c - w, c + w)
    r_p = _divide(eta2 * c - w, eta2 * c + w)
    return 0.5 * (np.abs(r_s) ** 2 + np.abs(r_p) ** 2)


def _divide(numerator: np.ndarray, denominator: np.ndarray) -> np.ndarray:
    """Complex ``numerator / denominator``, 0 where the denominator is 0."""
    numerator, denominator = np.broadcast_arrays(numerator, denominator)
    out = np.zeros(numerator.shape, dtype=np.complex128)
    return np.divide(numerator, denominator, out=out, where=denominator != 0)


class BRDFModel:
    """Base class: input validation, horizon masking and the spectrum cache.

    Subclasses set :attr:`name`, list their spectral parameters with their
    allowed ranges in ``_spectrum_ranges`` and implement ``_evaluate`` for
    directions that are both strictly above the horizon.
    """

    #: Registry name, also the ``name`` entry of :meth:`describe`.
    name: ClassVar[str] = ""
    #: Whether ``f(wi, wo) == f(wo, wi)``.
    reciprocal: ClassVar[bool] = True

    def _init_spectra(self, **params: tuple[SpectrumLike, _Interval]) -> None:
        """Store and validate spectral parameters (on the reference grid)."""
        self._spectra_in: dict[str, SpectrumLike] = {}
        self._spectrum_ranges: dict[str, _Interval] = {}
        self._cache: dict[tuple, dict[str, np.ndarray]] = {}
        for key, (spectrum, interval) in params.items():
            self._spectra_in[key] = spectrum
            self._spectrum_ranges[key] = interval
        self._spectra(spectra.WAVELENGTHS_REFERENCE)

    def _spectra(self, wavelengths: np.ndarray) -> dict[str, np.ndarray]:
        """Spectral parameters evaluated at ``wavelengths``, cached per grid."""
        key = tuple(wavelengths.tolist())
        cached = self._cache.get(key)
        if cached is not None:
            return cached
        values: dict[str, np.ndarray] = {}
        for name, spectrum in self._spectra_in.items():
            interval = self._spectrum_ranges[name]
            try:
                array = spectra.spectrum_values(spectrum, wavelengths)
            except (TypeError, ValueError) as exc:
                raise ValueError(f"{name}: not a valid spectrum ({exc})") from None
            if not interval.contains(array):
                raise ValueError(
                    f"{name} must lie in {interval} at every wavelength; "
                    f"got values in [{array.min():g}, {array.max():g}]"
                )
            array.setflags(write=False)
            values[name] = array
        if len(self._cache) >= _CACHE_SIZE:
            self._cache.pop(next(iter(self._cache)))
        self._cache[key] = values
        return values

    def __call__(self, wi: np.ndarray, wo: np.ndarray, wavelengths: np.ndarray) -> np.ndarray:
        """Evaluate the BRDF (no cosine factor).

        Parameters
        ----------
        wi, wo : array_like (N, 3)
            Unit vectors towards the light and the viewer, local frame. Rows
            must have length 1 within 1e-3 (they are renormalised).
        wavelengths : array_like (L,)
            Strictly increasing wavelengths in nm.

        Returns
        -------
        ndarray (N, L), float64
            f(wi, wo, λ) in sr⁻¹; exactly 0 where cos θi <= 0 or cos θo <= 0.

        Raises
        ------
        ValueError
            Wrong shapes, NaN/inf, non-unit vectors, invalid wavelengths, or a
            spectral parameter out of its range on this wavelength grid.
        """
        wi = _check_directions(wi, "wi")
        wo = _check_directions(wo, "wo")
        if wi.shape != wo.shape:
            raise ValueError(f"wi and wo must have the same shape, got {wi.shape} and {wo.shape}")
        wl = spectra.check_wavelengths(wavelengths)
        params = self._spectra(wl)
        valid = (wi[:, 2] > 0.0) & (wo[:, 2] > 0.0)
        with np.errstate(under="ignore"):
            if valid.all():
                return self._evaluate(wi, wo, params)
            out = np.zeros((wi.shape[0], wl.size))
            if valid.any():
                out[valid] = self._evaluate(wi[valid], wo[valid], params)
        return out

    def _evaluate(
        self, wi: np.ndarray, wo: np.ndarray, params: dict[str, np.ndarray]
    ) -> np.ndarray:
        raise NotImplementedError

    def _scalar_params(self) -> dict[str, float]:
        return {}

    def describe(self) -> dict[str, Any]:
        """JSON-serialisable parameters, with the model ``name``."""
        out: dict[str, Any] = {"name": self.name}
        out.update(self._scalar_params())
        for key, spectrum in self._spectra_in.items():
            out[key] = _describe_spectrum(spectrum)
        return out

    def __repr__(self) -> str:
        scalars = ", ".join(f"{k}={v!r}" for k, v in self._scalar_params().items())
        return f"{type(self).__name__}({scalars})"


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

