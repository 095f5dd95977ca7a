"""Metamers: reflectances that match under one illuminant and differ under another.

For the spectral-PRT "Metacow" demo (Fairchild & Johnson 2004): each ColorChecker
patch next to a metamer that has *the same XYZ under D65* but differs as much as
possible (CIE 1994 ΔE*ab) under illuminant A.

Conventions (as :mod:`.colour_pipeline` and :mod:`.metrics`): the XYZ of a
Lambertian reflectance ``r`` under an illuminant is ``Σ_λ (r/π) · W`` with
``W = xyz_weights(illuminant)`` normalised so that ``r = 1`` gives ``Y = 1``;
CIELAB and ΔE94 use that white (:func:`.colour_pipeline.white_xyz`). Writing
``A = Wᵀ/π`` (3 × L), ``XYZ = A r``.

Method
------
*Metameric blacks* (Cohen & Kappauf 1982): ``R = Aᵀ (A Aᵀ)⁻¹ A`` projects a
spectrum onto its *fundamental metamer* ``R r``; ``r − R r`` is a metameric black
(``A (r − R r) = 0``). The blacks span the null space of ``A``
(:func:`metameric_black_basis`, an orthonormal basis from the SVD).

:func:`metamer` looks for ``r' = r + Φ N d``: ``Φ`` (L × K) is an orthonormal
basis of the K lowest-frequency cosines ``cos(π k (λ − λ₀)/(λ₁ − λ₀))``,
``k = 0..K−1``, and ``N`` a basis of the null space of ``A Φ``, so every ``d``
gives a smooth metameric black and the match is exact by construction (to
rounding, ~1e-16), not an optimiser tolerance. The basis, not a penalty, carries
the smoothness: the constraints stay linear and few (K − 3 unknowns), the linear
programs below are tiny, and no penalty weight trades colour difference against
wiggles. ``smoothness`` is the shortest half-period (nm) of the cosines, so
``K = floor((λ₁ − λ₀) / smoothness) + 1``. The default, 40 nm (11 cosines on
380–780 nm, an 8-dimensional space of smooth blacks), keeps the metamers about as
smooth as the ColorChecker itself (max |Δ²r| per 5 nm: ≈ 0.06 against 0.04) while
still reaching ΔE94 ≈ 6–34 under A; 20 nm (21 cosines) adds ~20 % more ΔE at
four times the curvature.

The set of XYZ under ``differ`` reachable by bounded metamers is a convex
polytope (the metamer mismatch volume restricted to the smooth basis); ΔE94 from
the original is largest on its boundary. Deterministically, for a fixed set of
directions ``u`` on the sphere (Fibonacci lattice), a linear program (HiGHS)
maximises ``u · J ΔXYZ`` (``J``: Jacobian of CIELAB at the original's XYZ under
``differ``) subject to ``lo ≤ r' ≤ hi``; the vertex with the largest true ΔE94
then starts an SLSQP refinement of the exact ΔE94 under the same linear
constraints. A last clean-up projects onto the bounds and the three match
equations alternately so both hold to rounding.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from scipy import linalg, optimize

from . import pipeline as colour_pipeline, spectra

#: Default shortest half-period (nm) of the cosine basis of the metameric black.
SMOOTHNESS_NM = 40.0

#: Number of linear-program directions on the sphere (Fibonacci lattice).
DIRECTIONS = 32

#: The match under ``match`` is accepted when |ΔXYZ| ≤ this (absolute; Y_white = 1).
MATCH_TOLERANCE = 1e-10


@dataclass(frozen=True)
class Metamer:
    """A metamer of ``original`` under ``match`` that differs under ``differ``."""

    wavelengths: np.ndarray          # (L,) nm
    original: np.ndarray             # (L,) the input reflectance
    spectrum: np.ndarray             # (L,) the metamer, lo ≤ r ≤ hi
    match: str                       # illuminant name (or "custom")
    differ: str
    xyz_match_original: np.ndarray   # (3,) XYZ under ``match`` (white Y = 1)
    xyz_match_metamer: np.ndarray
    xyz_differ_original: np.ndarray  # (3,) XYZ under ``differ``
    xyz_differ_metamer: np.ndarray
    delta_e94_match: float           # ≈ 0
    delta_e94_differ: float          # the achieved difference
    success: bool                    # SLSQP converged (the result is valid either way)
    status: int                      # scipy.optimize SLSQP status
    message: str
    basis_size: int                  # K, number of cosines


# -- linear algebra ---------------------------------------------------------------------------

def _illuminant_label(illuminant) -> str:
    return str(illuminant).upper() if isinstance(illuminant, str) else "custom"


def _xyz_matrix(illuminant, wavelengths: np.ndarray, observer: str) -> np.ndarray:
    """``A`` (3, L) with ``XYZ = A r`` for a reflectance ``r`` (protocol-normalised)."""
    return colour_pipeline.xyz_weights(illuminant, wavelengths, observer=observer).T / np.pi


def metameric_black_basis(illuminant: str | np.ndarray = "D65",
                          wavelengths: np.ndarray = spectra.WAVELENGTHS_REFERENCE, *,
                          observer: str = spectra.OBSERVER) -> np.ndarray:
    """Orthonormal basis (L, L − 3) of the metameric blacks under ``illuminant``.

    The null space (SVD, :func:`scipy.linalg.null_space`) of the 3 × L matrix of
    illuminant × CMF weights: any combination of the columns added to a
    reflectance leaves its XYZ under ``illuminant`` unchanged.
    """
    wl = spectra.check_wavelengths(wavelengths)
    if wl.size < 4:
        raise ValueError(f"need at least 4 wavelengths for metameric blacks, got {wl.size}")
    return linalg.null_space(_xyz_matrix(illuminant, wl, observer))


def fundamental_metamer(reflectance: np.ndarray, illuminant: str | np.ndarray = "D65",
                        wavelengths: np.ndarray = spectra.WAVELENGTHS_REFERENCE, *,
                        observer: str = spectra.OBSERVER) -> tuple[np.ndarray, np.ndarray]:
    """Cohen & Kappauf's decomposition ``r = R r + (r − R r)`` → (fundamental, black).

    ``R = Aᵀ (A Aᵀ)⁻¹ A`` is the orthogonal projector onto the row space of the
    weights ``A``; the fundamental has the XYZ of ``r`` and the black has XYZ 0.
    """
    wl = spectra.check_wavelengths(wavelengths)
    r = _check_reflectance(reflectance, wl, bounds=None)
    a = _xyz_matrix(illuminant, wl, observer)
    fundamental = a.T @ np.linalg.solve(a @ a.T, a @ r)
    return fundamental, r - fundamental


def cosine_basis(wavelengths: np.ndarray, count: int) -> np.ndarray:
    """Orthonormal (L, count) basis of the ``count`` lowest cosines over the grid's span."""
    wl = spectra.check_wavelengths(wavelengths)
    if not 1 <= count <= wl.size:
        raise ValueError(f"cosine basis size must be 1..{wl.size}, got {count}")
    x = (wl - wl[0]) / max(wl[-1] - wl[0], 1e-12)
    raw = np.cos(np.pi * np.outer(x, np.arange(count)))
    q, _ = np.linalg.qr(raw)
    return q


# -- input checks -----------------------------------------------------------------------------

def _check_reflectance(reflectance, wl: np.ndarray, bounds) -> np.ndarray:
    r = np.asarray(reflectance, dtype=np.float64)
    if r.ndim != 1:
        raise ValueError(f"reflectance must be 1-D (one spectrum), got shape {r.shape}")
    if r.shape != wl.shape:
        raise ValueError(f"reflectance has {r.size} samples, the wavelength grid {wl.size}")
    if not np.isfinite(r).all():
        raise ValueError(f"reflectance has {int((~np.isfinite(r)).sum())} non-finite values")
    if bounds is not None and (r.min() < 0.0 or r.max() > 1.0):
        raise ValueError(f"reflectance must lie in [0, 1], got {r.min():.4g}..{r.max():.4g}")
    return r


def _check_bounds(bounds) -> tuple[float, float]:
    try:
        lo, hi = (float(b) for b in bounds)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"bounds must be a pair (lo, hi), got {bounds!r}") from exc
    if not (np.isfinite([lo, hi]).all() and 0.0 <= lo < hi <= 1.0):
        raise ValueError(f"bounds must satisfy 0 <= lo < hi <= 1, got ({lo}, {hi})")
    return lo, hi


def _fibonacci_sphere(count: int) -> np.ndarray:
    i = np.arange(count) + 0.5
    z = 1.0 - 2.0 * i / count
    phi = np.pi * (3.0 - np.sqrt(5.0)) * i
    r = np.sqrt(1.0 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=-1)


# -- the optimisation -------------------------------------------------------------------------

def metamer(reflectance: np.ndarray, match: str | np.ndarray = "D65",
            differ: str | np.ndarray = "A",
            wavelengths: np.ndarray = spectra.WAVELENGTHS_REFERENCE, *,
            bounds: tuple[float, float] = (0.0, 1.0), smoothness: float = SMOOTHNESS_NM,
            observer: str = spectra.OBSERVER, directions: int = DIRECTIONS) -> Metamer:
    """A smooth bounded metamer of ``reflectance`` under ``match``, max ΔE94 under ``differ``.

    Parameters
    ----------
    reflectance : ndarray (L,)
        The original, in [0, 1], on ``wavelengths``.
    match, differ : str or ndarray (L,)
        Illuminants by CIE name (see :data:`.spectra.ILLUMINANT_NAMES`) or as SPDs.
    bounds : (lo, hi)
        The metamer stays in ``lo ≤ r ≤ hi`` (0 ≤ lo < hi ≤ 1) at every wavelength.
    smoothness : float
        Shortest half-period (nm) of the cosine basis of the metameric black;
        larger is smoother (fewer cosines, smaller ΔE under ``differ``).
    directions : int
        Number of linear programs (directions in CIELAB) seeding the refinement.

    Raises
    ------
    ValueError
        Bad inputs (shape, NaN, outside [0, 1], unknown illuminant, bad bounds or
        smoothness), ``match`` equal to ``differ``, or an infeasible problem: no
        bounded smooth metamer, or only the original itself (a single point).
    """
    wl = spectra.check_wavelengths(wavelengths)
    r0 = _check_reflectance(reflectance, wl, bounds=True)
    lo, hi = _check_bounds(bounds)
    _check_options(match, differ, smoothness, directions)

    a_match = _xyz_matrix(match, wl, observer)
    a_differ = _xyz_matrix(differ, wl, observer)
    white = colour_pipeline.white_xyz(differ, wl, observer=observer)
    white_match = colour_pipeline.white_xyz(match, wl, observer=observer)

    count, g = _smooth_black_space(wl, a_match, smoothness)   # r = r0 + g d
    m = a_differ @ g                   # (3, n): ΔXYZ under differ
    xyz0 = a_differ @ r0

    def delta_e(d: np.ndarray) -> float:
        return float(colour_pipeline.delta_e94(xyz0, xyz0 + m @ d, white))

    # Linear constraints lo - r0 ≤ g d ≤ hi - r0 as A_ub d ≤ b_ub.
    a_ub = np.vstack([g, -g])
    b_ub = np.concatenate([hi - r0, r0 - lo])
    feasible_at_zero = r0.min() >= lo and r0.max() <= hi

    best_d, best_de = _best_vertex(_lab_jacobian(xyz0, white), m, a_ub, b_ub, delta_e,
                                   int(directions), (lo, hi), match)
    res = _refine(best_d, xyz0, m, white, a_ub, b_ub)
    d = res.x if np.isfinite(res.x).all() and delta_e(res.x) >= best_de else best_d
    spectrum = _polish(r0 + g @ d, a_match, a_match @ r0, lo, hi,
                       r0 if feasible_at_zero else None)

    xyz_match0 = a_match @ r0
    xyz_match1 = a_match @ spectrum
    if np.abs(xyz_match1 - xyz_match0).max() > MATCH_TOLERANCE:
        raise ValueError("could not hold the match and the bounds together "
                         f"(|ΔXYZ| = {np.abs(xyz_match1 - xyz_match0).max():.3g})")
    xyz_differ1 = a_differ @ spectrum
    return Metamer(
        wavelengths=wl.copy(), original=r0.copy(), spectrum=spectrum,
        match=_illuminant_label(match), differ=_illuminant_label(differ),
        xyz_match_original=xyz_match0, xyz_match_metamer=xyz_match1,
        xyz_differ_original=xyz0, xyz_differ_metamer=xyz_differ1,
        delta_e94_match=float(colour_pipeline.delta_e94(xyz_match0, xyz_match1, white_match)),
        delta_e94_differ=float(colour_pipeline.delta_e94(xyz0, xyz_differ1, white)),
        success=bool(res.success), status=int(res.status), message=str(res.message),
        basis_size=count,
    )


def _check_options(match, differ, smoothness: float, directions: int) -> None:
    if not (np.isfinite(smoothness) and smoothness > 0):
        raise ValueError(f"smoothness must be a positive number of nm, got {smoothness}")
    if int(directions) < 6:
        raise ValueError(f"need at least 6 directions, got {directions}")
    if isinstance(match, str) and isinstance(differ, str) and match.upper() == differ.upper():
        raise ValueError(f"match and differ are the same illuminant ({match!r}): a metamer "
                         "cannot differ under the illuminant it matches under")


def _smooth_black_space(wl: np.ndarray, a_match: np.ndarray, smoothness: float
                        ) -> tuple[int, np.ndarray]:
    """(cosines used, g (L, n)): the smooth metameric blacks under ``a_match`` are
    ``g d``, g spanning the null space of ``a_match`` within the cosine basis."""
    count = min(int(np.floor((wl[-1] - wl[0]) / smoothness + 1e-9)) + 1, wl.size)
    if count < 5:
        raise ValueError(f"smoothness {smoothness} nm leaves {count} cosines; a metameric black "
                         "needs at least 5 (use a smaller smoothness)")
    phi = cosine_basis(wl, count)
    null = linalg.null_space(a_match @ phi)
    if null.shape[1] == 0:
        raise ValueError("no smooth metameric black exists on this grid (null space is empty)")
    return count, phi @ null


def _best_vertex(lab_jac: np.ndarray, m: np.ndarray, a_ub: np.ndarray, b_ub: np.ndarray,
                 delta_e, directions: int, bounds: tuple[float, float], match
                 ) -> tuple[np.ndarray, float]:
    """The vertex of the bounded set with the largest ΔE94 among linear programs that push
    the CIELAB change (``lab_jac @ m @ d``) along ``directions`` directions of a sphere."""
    lo, hi = bounds
    best_d, best_de = None, -1.0
    for u in _fibonacci_sphere(directions):
        c = -(u @ lab_jac @ m)
        res = optimize.linprog(c, A_ub=a_ub, b_ub=b_ub, bounds=(None, None), method="highs")
        if res.status == 2:
            raise ValueError(f"no metamer within bounds ({lo}, {hi}) matches the reflectance "
                             f"under {_illuminant_label(match)} with this smoothness "
                             "(the constraints are infeasible)")
        if res.status != 0:
            continue
        de = delta_e(res.x)
        if de > best_de + 1e-12:
            best_d, best_de = res.x, de
    if best_d is None:
        raise ValueError("the metamer linear programs failed in every direction")
    if best_de < 1e-6:
        raise ValueError("the metamer set is a single point: under these bounds the only "
                         "metamer is the reflectance itself (e.g. it sits on the bounds)")
    return best_d, best_de


def _refine(best_d: np.ndarray, xyz0: np.ndarray, m: np.ndarray, white: np.ndarray,
            a_ub: np.ndarray, b_ub: np.ndarray):
    """SLSQP on the exact ΔE94 from the best vertex. Gradient: chain rule through the
    3 XYZ components (central differences there, exact linear map m after)."""
    def objective(d: np.ndarray) -> tuple[float, np.ndarray]:
        xyz = xyz0 + m @ d
        h = 1e-7
        steps = np.eye(3) * h
        pts = np.concatenate([xyz[None], xyz + steps, xyz - steps])
        de = colour_pipeline.delta_e94(np.broadcast_to(xyz0, pts.shape), pts, white)
        grad_xyz = (de[1:4] - de[4:7]) / (2 * h)
        return -float(de[0]), -(m.T @ grad_xyz)

    return optimize.minimize(
        objective, best_d, jac=True, method="SLSQP",
        constraints=[{"type": "ineq", "fun": lambda d: b_ub - a_ub @ d,
                      "jac": lambda d: -a_ub}],
        options={"maxiter": 200, "ftol": 1e-10},
    )


def _lab_jacobian(xyz: np.ndarray, white: np.ndarray) -> np.ndarray:
    """d Lab / d XYZ (3, 3) at ``xyz`` by central differences."""
    h = 1e-6
    steps = np.eye(3) * h
    plus = colour_pipeline.xyz_to_lab(xyz + steps, white)
    minus = colour_pipeline.xyz_to_lab(xyz - steps, white)
    return ((plus - minus) / (2 * h)).T


def _polish(r: np.ndarray, a: np.ndarray, target: np.ndarray, lo: float, hi: float,
            anchor: np.ndarray | None) -> np.ndarray:
    """Make ``lo ≤ r ≤ hi`` and ``a r = target`` hold to rounding.

    The optimisers meet both to ~1e-9. With a feasible ``anchor`` (the original)
    the step from it is shrunk just enough to respect the bounds, which keeps the
    match exact; then alternating projections (clip / minimal correction on the
    free samples) mop up what rounding leaves.
    """
    if anchor is not None:
        step = r - anchor
        with np.errstate(divide="ignore", invalid="ignore"):
            up = np.where(step > 0, (hi - anchor) / step, np.inf)
            down = np.where(step < 0, (lo - anchor) / step, np.inf)
        t = min(1.0, float(np.min(up)), float(np.min(down)))
        r = anchor + max(t, 0.0) * step
    for _ in range(50):
        r = np.clip(r, lo, hi)
        resid = target - a @ r
        if np.abs(resid).max() <= 1e-14:
            break
        free = (r > lo) & (r < hi)
        if free.sum() < 3:
            break
        r = r.copy()
        r[free] += np.linalg.lstsq(a[:, free], resid, rcond=None)[0]
    return np.clip(r, lo, hi)


def colorchecker_metamers(patches: Iterable[int | str] | None = None,
                          match: str | np.ndarray = "D65", differ: str | np.ndarray = "A",
                          wavelengths: np.ndarray = spectra.WAVELENGTHS_REFERENCE,
                          **kwargs) -> dict[int | str, Metamer]:
    """:func:`metamer` of ColorChecker N Ohta patches (1-based numbers or names; all 24 if None).

    Keys are the patches as given; ``kwargs`` go to :func:`metamer`.
    """
    if patches is None:
        patches = range(1, len(spectra.colorchecker_names()) + 1)
    return {p: metamer(spectra.colorchecker(p, wavelengths), match, differ, wavelengths,
                       **kwargs) for p in patches}
