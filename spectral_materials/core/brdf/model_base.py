"""What every analytic BRDF model shares: the parameter checks, the exact conductor Fresnel
term, and :class:`BRDFModel` (input validation, horizon masking, the spectrum cache)."""

from __future__ import annotations

from typing import Any, ClassVar

import colour
import numpy as np

from ..colour import spectra
from ..colour.spectra import SpectrumLike

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
