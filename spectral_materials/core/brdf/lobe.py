"""An analytic specular lobe beside the factor packs (issue 18: "an analytic lobe plus a CP
residual").

A glossy lobe near grazing is too narrow for any table: where θi and θo both near 90°,
the half vector swings through the whole lobe within 2° of Δφ, less than one cell, and
the lobe's ``1/max(cosθi, cosθo)`` grows threefold across one θ cell. The packs then miss
it by ΔE94 100–200 (docs/bench_colour_targets.md, before). A lobe evaluated in closed
form resolves it at every angle; the packs factor only what is left (the diffuse layer
and what the lobe's shape misses), which is smooth.

The lobe is Ashikhmin–Shirley's specular term with a Schlick Fresnel whose two spectra
are free::

    f_lobe(wi, wo, λ) = a(wi, wo)·(1 − s)·c₀(λ) + a(wi, wo)·s·c₁(λ),
    a = √((nu+1)(nv+1)) / (8π) · (n·h)^E / ((h·k)·max(cosθi, cosθo)),
    E = (nu·hx² + nv·hy²) / (hx² + hy²),  s = (1 − h·k)⁵,

so Schlick's ``F = F₀ + (1 − F₀)s`` is ``c₀ = F₀``, ``c₁ = 1``, but a measured material
may have any two spectra. ``nu``, ``nv`` and the spectra are fitted to the BRDF by
variable projection (:func:`fit_lobe`): for given exponents the spectra (and a smooth
stand-in for the diffuse layer, discarded afterwards) are a linear least-squares
solution, so only the exponents are searched.

A rough diffuse surface has a ridge of its own: Oren–Nayar's back-scatter term
``B·max(0, cos(φi − φo))·sin α·tan β`` grows without bound as both directions near the
horizon in one azimuth, and ``f·cosθi`` there depends on ``cosθi / cosθo``, which no
table of θ cells follows into the corner (ΔE94 up to 20 at 89.5–90° in 4,000 dense
pairs: docs/bench_colour_targets.md, packs alone). The family ``oren_nayar`` draws that
term in closed form, ``a = max(0, xi·xo + yi·yo) / max(cosθi, cosθo)``, with one free
spectrum ``c₀ = ρ·B/π`` (its second term is 0 and it has no shape parameters); the
packs keep ``ρ·A/π``, which is smooth. The spectrum is a linear least-squares
solution, as the Schlick spectra are.

The GLSL (``glsl/brdf/specular_lobe.glsl``) and the EEVEE node group evaluate
:meth:`SpecularLobe.angular` with the same clamps, for either family.

References
----------
Ashikhmin, M., Shirley, P. (2000). An anisotropic Phong BRDF model. Journal of
Graphics Tools 5(2), 25–32.
Schlick, C. (1994). An inexpensive BRDF model for physically-based rendering.
Computer Graphics Forum 13(3), 233–246.
Oren, M., Nayar, S. K. (1994). Generalization of Lambert's reflectance model.
Proceedings of SIGGRAPH '94, 239–246.
Golub, G., Pereyra, V. (2003). Separable nonlinear least squares: the variable
projection method and its applications. Inverse Problems 19(2), R1–R26.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize

from ..colour.basis import LinearModelBasis
from ..progress import ProgressCallback, report
from . import measured_cells
from .metrics import uniform_hemisphere

#: Lobe families a model can carry (GLSL ``SM_LOBE_FAMILY`` is the index + 1).
LOBE_FAMILIES = ("ashikhmin_shirley", "oren_nayar")
#: Families whose terms have no shape parameters: their ``nu``, ``nv`` are stored as 0.
FAMILIES_WITHOUT_EXPONENTS = ("oren_nayar",)
#: How many of a family's two terms are not 0 everywhere (the other's spectrum is 0).
FAMILY_TERMS = {"ashikhmin_shirley": 2, "oren_nayar": 1}
#: Exponent range searched and accepted (a Phong exponent of 1e4 is a lobe of ~0.6°).
EXPONENT_RANGE = (0.5, 1.0e4)
#: Floor of the lobe's denominator (h·k)·max(cosθi, cosθo); shared with the GLSL. Only
#: pairs within ~0.006° of both horizons reach it.
DENOMINATOR_FLOOR = 1e-8
#: The fit's smooth stand-in for everything but the lobe: cosθi·cosθi^a·cosθo^b.
SMOOTH_DEGREE = 2
#: Residuals below this fraction of the data's RMS count as this in ``LobeFit.gain``. At
#: 1 % an Oren–Nayar material of σ = 0.1, whose smooth stand-in leaves 1.5 % and whose
#: own term leaves 1e-15, gained only 1.5, and its grazing corner (where the term
#: outgrows everything, whatever σ) was left to the packs.
GAIN_FLOOR = 1e-3
#: Where the lobe leaves less than this fraction of the BRDF (the norm over wavelengths of
#: ``f − lobe`` against that of ``f``), the rest that the packs factor is taken as 0
#: (``LobeResidual(invisible=...)``). There the rest is the lobe's own few-per-mille misfit
#: along the mirror direction (and, in a measured table's cells, the table's binning and
#: uplift beside it), invisible beside the lobe, but a ridge: the low-rank packs cannot
#: follow it and spread it onto the dark flanks beside the mirror, where it showed (issue
#: 18: Ashikhmin–Shirley 32, view 89.5–89.9°, ΔE94 up to 5.3 under FL11; the MERL round
#: trip, view 89–89.5°, 6.9). Swept (docs/bench_invisible_rest.md), the rule works from
#: 0.2 % for Orange gloss and from 0.5 % for the MERL round trip (0.3 % left it 6.4), and
#: still at 1 %, where the analytic materials' largest errors begin to grow.
INVISIBLE_REST = 0.005
FIT_PAIRS = 8000
FIT_SEED = 20181  # not the protocol's seed: the fit never sees the pairs it is measured at


@dataclass(frozen=True)
class SpecularLobe:
    """An analytic lobe: Ashikhmin–Shirley's with two free Schlick spectra, or Oren–Nayar's
    back-scatter term with one (see the module docstring).

    Attributes
    ----------
    family : str
        One of :data:`LOBE_FAMILIES`.
    nu, nv : float
        Phong exponents along the tangent and the bitangent (Ashikhmin–Shirley); 0 for a
        family without shape parameters (:data:`FAMILIES_WITHOUT_EXPONENTS`).
    spectral : ndarray (S, 2)
        ``c₀`` and ``c₁`` on the model's spectral axis (wavelength samples or basis
        coefficients), float32 as stored.
    """

    family: str
    nu: float
    nv: float
    spectral: np.ndarray = field(repr=False)

    def validate(self) -> None:
        """ValueError naming what is wrong."""
        if self.family not in LOBE_FAMILIES:
            raise ValueError(f"unknown lobe family {self.family!r}; one of {LOBE_FAMILIES}")
        lo, hi = EXPONENT_RANGE
        for name in ("nu", "nv"):
            value = getattr(self, name)
            if self.family in FAMILIES_WITHOUT_EXPONENTS:
                if value != 0.0:
                    raise ValueError(f"an {self.family} lobe has no exponents; {name} = "
                                     f"{value}, not 0")
            elif not (np.isfinite(value) and lo <= value <= hi):
                raise ValueError(f"lobe exponent {name} = {value} is outside [{lo}, {hi}]")
        spectral = np.asarray(self.spectral)
        if spectral.ndim != 2 or spectral.shape[1] != 2:
            raise ValueError(f"lobe spectra must be (S, 2), got {spectral.shape}")
        if not np.isfinite(spectral).all():
            raise ValueError("lobe spectra hold non-finite values")
        if np.any(spectral[:, FAMILY_TERMS[self.family]:] != 0):
            # The GPU multiplies a term of 0 by its weight in float32: a huge spectrum
            # there would draw NaN where the float64 mirror draws nothing.
            raise ValueError(f"an {self.family} lobe's second spectrum must be 0")

    @property
    def nbytes(self) -> int:
        """Stored bytes: the spectra and the two exponents, float32."""
        return int(np.asarray(self.spectral).size * 4 + 8)

    def angular(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """(N, 2): the family's two terms at unit direction pairs (the BRDF, no cosine):
        ``a·(1 − s)`` and ``a·s`` (Ashikhmin–Shirley), ``a`` and 0 (Oren–Nayar)."""
        return family_terms(self.family, wi, wo, self.nu, self.nv)

    def coefficients(self, wi: np.ndarray, wo: np.ndarray, cosine_weighted: bool
                     ) -> np.ndarray:
        """(N, S) on the spectral axis: the lobe ``f`` (times cosθi when
        ``cosine_weighted``). The two terms are summed in a fixed order, so a model
        evaluates bit-identically from one process to the next."""
        terms = self.angular(wi, wo)
        if cosine_weighted:
            terms = terms * np.clip(np.asarray(wi, np.float64).reshape(-1, 3)[:, 2:3], 0.0,
                                    None)
        spectral = np.asarray(self.spectral, dtype=np.float64)
        return 0.0 + terms[:, :1] * spectral[None, :, 0] + terms[:, 1:] * spectral[None, :, 1]

    def on_wavelengths(self, basis: np.ndarray | None) -> np.ndarray:
        """(L, 2) spectra at the model's wavelengths (``basis`` Ψ (L, m) or None)."""
        spectral = np.asarray(self.spectral, dtype=np.float64)
        return spectral if basis is None else np.asarray(basis, np.float64) @ spectral


def family_code(family: str) -> int:
    """The GLSL's ``SM_LOBE_FAMILY`` for ``family`` (its index in :data:`LOBE_FAMILIES`
    + 1)."""
    return LOBE_FAMILIES.index(family) + 1


def family_terms(family: str, wi: np.ndarray, wo: np.ndarray, nu: float, nv: float
                 ) -> np.ndarray:
    """The two angular terms (N, 2) of ``family``'s lobe (exponents ignored where it has
    none)."""
    if family == "oren_nayar":
        return oren_nayar_terms(wi, wo)
    if family == "ashikhmin_shirley":
        return lobe_terms(wi, wo, nu, nv)
    raise ValueError(f"unknown lobe family {family!r}; one of {LOBE_FAMILIES}")


def _lit_pairs(wi: np.ndarray, wo: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(wi, wo, lit): float64 (N, 3) with non-finite pairs zeroed, and the pairs with both
    directions above the horizon."""
    wi = np.asarray(wi, dtype=np.float64).reshape(-1, 3)
    wo = np.asarray(wo, dtype=np.float64).reshape(-1, 3)
    finite = np.isfinite(wi).all(axis=1) & np.isfinite(wo).all(axis=1)
    wi = np.where(finite[:, None], wi, 0.0)
    wo = np.where(finite[:, None], wo, 0.0)
    return wi, wo, finite & (wi[:, 2] > 0) & (wo[:, 2] > 0)


def oren_nayar_terms(wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
    """Oren–Nayar's back-scatter term ``max(0, cos(φi − φo))·sin α·tan β`` and 0 (N, 2).

    Written without angles, as core/brdf/models.py's ``OrenNayar`` does:
    ``max(0, xi·xo + yi·yo) / max(cosθi, cosθo)``. The denominator's floor is
    :data:`DENOMINATOR_FLOOR`, as the specular lobe's; pairs at or below the horizon, or
    non-finite, give 0.
    """
    wi, wo, lit = _lit_pairs(wi, wo)
    projected = np.maximum(wi[:, 0] * wo[:, 0] + wi[:, 1] * wo[:, 1], 0.0)
    nearer_normal = np.maximum(np.maximum(wi[:, 2], wo[:, 2]), DENOMINATOR_FLOOR)
    a = np.where(lit, projected / nearer_normal, 0.0)
    return np.stack([a, np.zeros_like(a)], axis=-1)


def lobe_terms(wi: np.ndarray, wo: np.ndarray, nu: float, nv: float) -> np.ndarray:
    """The lobe's two angular terms (N, 2) for exponents ``nu``, ``nv``.

    Pairs with either direction at or below the horizon give 0. Non-finite components
    give 0 as well: a lobe never turns bad input into NaN.
    """
    wi, wo, lit = _lit_pairs(wi, wo)
    v = wi + wo
    length = np.sqrt(np.einsum("ij,ij->i", v, v))
    lit = lit & (length > 0)
    h = v / np.where(lit, length, 1.0)[:, None]
    h_dot_k = np.minimum(0.5 * length, 1.0)           # |wi + wo| / 2 for unit vectors
    hx2, hy2 = h[:, 0] ** 2, h[:, 1] ** 2
    s2 = hx2 + hy2
    ratio = np.divide(hy2, s2, out=np.zeros_like(s2), where=s2 > 0)
    exponent = nu + (nv - nu) * ratio
    hz = np.where(lit, np.clip(h[:, 2], np.finfo(float).tiny, 1.0), 1.0)
    peak = np.exp(exponent * np.log(hz))
    norm = np.sqrt((nu + 1.0) * (nv + 1.0)) / (8.0 * np.pi)
    denominator = np.maximum(h_dot_k * np.maximum(wi[:, 2], wo[:, 2]), DENOMINATOR_FLOOR)
    a = np.where(lit, norm * peak / denominator, 0.0)
    s = (1.0 - h_dot_k) ** 5
    return np.stack([a * (1.0 - s), a * s], axis=-1)


# ------------------------------------------------------------------------------- fitting


@dataclass
class LobeFit:
    """What :func:`fit_lobe` found: the lobe, and how much of the BRDF it explains."""

    lobe: SpecularLobe
    #: Weighted RMS of the fit samples themselves, of what a smooth surface alone leaves
    #: of them, and of what it leaves with the lobe.
    rms_data: float
    rms_smooth: float
    rms_with_lobe: float
    evaluations: int
    seconds: float

    @property
    def gain(self) -> float:
        """How many times smaller the weighted RMS is with the lobe (≥ 1), counting
        residuals below :data:`GAIN_FLOOR` of the data's own RMS as that: a BRDF the
        smooth surface fits already (Lambert) gains nothing, however small the lobe makes
        its rounding."""
        floor = max(GAIN_FLOOR * self.rms_data, np.finfo(float).tiny)
        return max(self.rms_smooth, floor) / max(self.rms_with_lobe, floor)


def fit_pairs(count: int = FIT_PAIRS, seed: int = FIT_SEED) -> tuple[np.ndarray, np.ndarray]:
    """The fit's direction pairs: half uniform on the hemisphere, half near the mirror
    direction (where the lobe is), both directions above the horizon."""
    rng = np.random.default_rng(seed)
    half = count // 2
    wi, wo = uniform_hemisphere(rng, count), uniform_hemisphere(rng, count)
    mirror = wi[half:] * np.array([-1.0, -1.0, 1.0]) + 0.2 * uniform_hemisphere(rng,
                                                                                 count - half)
    mirror[:, 2] = np.abs(mirror[:, 2])
    wo[half:] = mirror / np.linalg.norm(mirror, axis=1)[:, None]
    return wi, wo


def _smooth_columns(wi: np.ndarray, wo: np.ndarray) -> list[np.ndarray]:
    ci, co = wi[:, 2], wo[:, 2]
    return [ci * ci ** a * co ** b for a in range(SMOOTH_DEGREE + 1)
            for b in range(SMOOTH_DEGREE + 1)]


def fit_lobe(brdf, wavelengths: np.ndarray, basis: LinearModelBasis | None = None, *,
             isotropic: bool = False, family: str = "ashikhmin_shirley",
             pairs: int = FIT_PAIRS, seed: int = FIT_SEED,
             callback: ProgressCallback | None = None) -> LobeFit:
    """Fit a :class:`SpecularLobe` to ``brdf(wi, wo, λ)`` by variable projection.

    The samples ``f·cosθi`` at :func:`fit_pairs` (on ``basis`` when given) are weighted by
    ``(0.05 + |mean f·cosθi|)^(−2/3)``, a stand-in for ΔE94's cube-root lightness, so
    that bright grazing peaks do not drown the rest. For exponents (nu, nv) the lobe's
    two spectra and a smooth polynomial in cosθi, cosθo (the diffuse layer's stand-in,
    not kept) solve a linear least-squares problem; the exponents are searched on a
    log grid (on a quarter of the samples), then refined by Nelder–Mead. Isotropic
    BRDFs search nu = nv. A family without exponents (Oren–Nayar) is that one solve.

    ``callback(fraction, message) -> stop?`` reports progress; a true return raises
    ``Cancelled``. Raises ValueError for an unknown family or a BRDF returning
    non-finite values.
    """
    if family not in LOBE_FAMILIES:
        raise ValueError(f"unknown lobe family {family!r}; one of {LOBE_FAMILIES}")
    start = time.perf_counter()
    report(callback, 0.0, "fitting the specular lobe")
    wl = np.asarray(wavelengths, dtype=np.float64)
    wi, wo = fit_pairs(pairs, seed)
    values = np.asarray(brdf(wi, wo, wl), dtype=np.float64) * wi[:, 2:3]
    if not np.isfinite(values).all():
        raise ValueError("the BRDF returned non-finite values where the lobe is fitted")
    weight = (0.05 + np.abs(values.mean(axis=1))) ** (-2.0 / 3.0)
    target = values if basis is None else basis.project(values)
    target = target * weight[:, None]
    smooth = np.stack(_smooth_columns(wi, wo), axis=1) * weight[:, None]
    evaluations = 0

    def solve(nu: float, nv: float, step: int = 1) -> tuple[float, np.ndarray]:
        """Loss and lobe spectra at (nu, nv), on every ``step``-th sample."""
        nonlocal evaluations
        evaluations += 1
        rows = slice(None, None, step)
        used = FAMILY_TERMS[family]     # a term that is 0 everywhere gets a spectrum of 0
        terms = family_terms(family, wi[rows], wo[rows], nu, nv)[:, :used] * \
            (wi[rows, 2] * weight[rows])[:, None]
        design = np.concatenate([terms, smooth[rows]], axis=1)
        coefficients, *_ = np.linalg.lstsq(design, target[rows], rcond=None)
        residual = target[rows] - design @ coefficients
        spectra = np.zeros((2, target.shape[1]))
        spectra[:used] = coefficients[:used]
        return float(np.einsum("ij,ij->", residual, residual)), spectra

    nu, nv = (0.0, 0.0) if family in FAMILIES_WITHOUT_EXPONENTS else \
        _search_exponents(solve, isotropic, callback)
    loss, spectra = solve(nu, nv)
    smooth_only, *_ = np.linalg.lstsq(smooth, target, rcond=None)
    smooth_loss = float(np.sum((target - smooth @ smooth_only) ** 2))
    report(callback, 1.0, "specular lobe fitted")
    lobe = SpecularLobe(family, nu, nv, np.ascontiguousarray(spectra.T, dtype=np.float32))
    lobe.validate()
    count = target.size
    return LobeFit(lobe, float(np.sqrt(np.sum(target ** 2) / count)),
                   float(np.sqrt(smooth_loss / count)), float(np.sqrt(loss / count)),
                   evaluations, time.perf_counter() - start)


def _search_exponents(solve, isotropic: bool, callback: ProgressCallback | None
                      ) -> tuple[float, float]:
    """(nu, nv) minimising ``solve(nu, nv, step)[0]``, rounded to float32 (as stored and
    as the GPU evaluates them): a coarse log grid on a quarter of the samples finds the
    basin, Nelder–Mead on all of them refines it."""
    def exponents(log_exponents: np.ndarray) -> tuple[float, float]:
        nu, nv = np.exp(np.clip(log_exponents, *np.log(EXPONENT_RANGE)))[[0, -1]]
        return float(nu), float(nv)

    dims = 1 if isotropic else 2
    grid = np.linspace(np.log(1.0), np.log(EXPONENT_RANGE[1]), 14)
    candidates = (grid[:, None] if dims == 1 else
                  np.stack(np.meshgrid(grid, grid, indexing="ij"), -1).reshape(-1, 2))
    losses = []
    for i, point in enumerate(candidates):
        losses.append(solve(*exponents(point), step=4)[0])
        report(callback, 0.6 * (i + 1) / len(candidates), "fitting the specular lobe")
    best = candidates[int(np.argmin(losses))]
    # fatol relative to the loss: with 0, the search stopped only where its simplex's
    # losses were bit-equal, which depends on the BLAS's rounding (the same fit took
    # 322 evaluations on one machine and 1608, the iteration cap, on another).
    fatol = 1e-9 * solve(*exponents(best))[0]
    refined = minimize(lambda p: solve(*exponents(p))[0], best, method="Nelder-Mead",
                       options={"xatol": 1e-4, "fatol": fatol, "maxiter": 200 * dims})
    nu, nv = (float(np.float32(v)) for v in exponents(refined.x))
    return nu, nv


def residual_anisotropy(brdf, lobe: SpecularLobe, wavelengths: np.ndarray,
                        basis: np.ndarray | None = None, *, pairs: int = 4000,
                        seed: int = FIT_SEED + 1) -> float:
    """How much ``brdf − lobe`` changes when both directions turn about the normal: the
    RMS of that change over the RMS of ``f·cosθi`` (0 for an isotropic rest).

    An anisotropic material whose anisotropy the lobe carries (Ashikhmin–Shirley 8/64:
    0.002) leaves an isotropic rest, which the isotropic layout factors at a fraction of
    the cost; a lobe of another shape leaves anisotropy behind (Ward 0.1/0.3: 0.09, GGX
    0.1/0.4: 0.4). Turns are seeded, between 0.3 and 6 rad.
    """
    rng = np.random.default_rng(seed)
    wi, wo = fit_pairs(pairs, seed)
    angle = rng.uniform(0.3, 6.0, pairs)
    c, s = np.cos(angle), np.sin(angle)

    def turned(v):
        return np.stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1], v[:, 2]], -1)

    wl = np.asarray(wavelengths, dtype=np.float64)
    residual = LobeResidual(brdf, lobe, wl, basis)
    cos_i = wi[:, 2:3]
    change = (residual(wi, wo, wl) - residual(turned(wi), turned(wo), wl)) * cos_i
    scale = np.sqrt(np.mean((np.asarray(brdf(wi, wo, wl), np.float64) * cos_i) ** 2))
    return float(np.sqrt(np.mean(change ** 2)) / max(scale, np.finfo(float).tiny))


def resolve_lobe(brdf, lobe: str | SpecularLobe, wavelengths: np.ndarray,
                 basis: LinearModelBasis | None, isotropic: bool,
                 callback: ProgressCallback | None = None) -> tuple[SpecularLobe, dict]:
    """``lobe`` as given (a :class:`SpecularLobe`), or a family's lobe fitted to ``brdf``
    (:func:`fit_lobe`) with the fit's figures; ValueError for an unknown family."""
    if not isinstance(lobe, str):
        return lobe, {}
    if lobe not in LOBE_FAMILIES:
        raise ValueError(f"lobe must be one of {LOBE_FAMILIES} or a SpecularLobe, got {lobe!r}")
    fit = fit_lobe(brdf, wavelengths, basis, isotropic=isotropic, family=lobe,
                   callback=callback)
    return fit.lobe, {"lobe_fit_seconds": fit.seconds, "lobe_fit_gain": fit.gain,
                      "lobe_fit_evaluations": fit.evaluations}


class LobeResidual:
    """``brdf − lobe`` as a BRDF callable: what the factor packs factor beside a lobe.

    It may be negative (where the lobe overshoots); the tabulation is told so. Other
    attributes are the BRDF's own. ``cells``: the model is drawn in a measured table's
    cells (:mod:`.measured_cells`), so the lobe is taken out as drawn there, in cells:
    the rest is then the table's own binned rest, not the smooth lobe's variation within
    each cell (which near grazing the packs cannot follow). ``invisible``: pairs whose rest
    is below that fraction of the BRDF (norms over wavelengths) get a rest of 0
    (:data:`INVISIBLE_REST` when factoring; 0 keeps every rest).
    """

    def __init__(self, brdf, lobe: SpecularLobe, wavelengths: np.ndarray,
                 basis: np.ndarray | None, cells: tuple[int, int, int] | None = None,
                 invisible: float = 0.0):
        if not (np.isfinite(invisible) and 0.0 <= invisible < 1.0):
            raise ValueError(f"invisible must be in [0, 1), got {invisible}")
        self.brdf, self.lobe, self.cells = brdf, lobe, cells
        self.invisible = float(invisible)
        self._wavelengths = np.asarray(wavelengths, dtype=np.float64)
        self._spectra = lobe.on_wavelengths(basis)                      # (L, 2)

    def __call__(self, wi, wo, wavelengths):
        wl = np.asarray(wavelengths, dtype=np.float64)
        if wl.shape == self._wavelengths.shape and np.array_equal(wl, self._wavelengths):
            spectra = self._spectra
        else:
            spectra = np.stack([np.interp(wl, self._wavelengths, self._spectra[:, k])
                                for k in range(2)], axis=1)
        f = np.asarray(self.brdf(wi, wo, wl), dtype=np.float64)
        if self.cells is None:
            angular = self.lobe.angular(wi, wo)
        else:
            angular = measured_cells.in_cells(self.lobe.angular, wi, wo, False, self.cells)
        rest = f - angular @ spectra.T
        if self.invisible > 0.0:
            hidden = (np.linalg.norm(rest, axis=-1)
                      < self.invisible * np.linalg.norm(f, axis=-1))
            rest[hidden] = 0.0
        return rest

    def __getattr__(self, name):
        if name in ("brdf", "cells", "invisible"):   # not yet set (copy, pickle)
            raise AttributeError(name)
        return getattr(self.brdf, name)
