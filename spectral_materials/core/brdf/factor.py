"""``factor_brdf``: any spectral BRDF callable → :class:`FactoredBRDF`.

Steps (each reported through ``callback(fraction, message) -> stop?``):

1. choose the parameterisation (isotropic variant when the BRDF is isotropic);
2. build the spectral basis if asked (Peercy's linear model over the BRDF's own
   spectra, sampled every 10°, and the protocol's light × CMF spectra);
3. tabulate ``f·cosθi`` on the grid, projecting each chunk onto the basis;
4. factor: CP packs (``"joint"``, the default, or the paper's ``"greedy"``) on a
   truncated-HOSVD core of the table, lifted back to the full axes; or a
   Kautz–McCool separable form (``"svd"``, ``"nd"``);
5. stop at ``packs`` or once the mean ΔE94 under D65 at the protocol's random
   direction pairs reaches ``target_de94``.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..colour import spectra
from ..colour.basis import LinearModelBasis, light_cmf_spectra, linear_model_basis
from ..decomposition import cp, separable
from ..progress import ProgressCallback, report, scaled
from . import metrics
from .factored import FactoredBRDF
from .lobe import INVISIBLE_REST, LobeResidual, SpecularLobe, resolve_lobe
from .mode_weighting import mode_weights, scale_modes
from .params import Parameterization, get_parameterization
from .tabulate import Grid, Table, tabulate

METHODS = ("joint", "greedy", "svd", "nd")
#: Lights whose light × CMF spectra enter an automatic basis (the protocol's).
BASIS_ILLUMINANTS = ("D65", "A", "FL2", "FL11")
DEFAULT_PACKS = 4
#: Exponent of the perceptual mode weighting (see :func:`mode_weights`); 0 = plain L2.
DEFAULT_WEIGHTING = 0.5
MAX_PACKS = 256


def is_isotropic(brdf, wavelengths: np.ndarray, samples: int = 256, seed: int = 7,
                 rtol: float = 1e-6) -> bool:
    """Whether ``brdf`` is unchanged by rotating both directions about the normal."""
    wi, wo = metrics.random_direction_pairs(samples, seed)
    angle = np.random.default_rng(seed).uniform(0.1, 2 * np.pi - 0.1)
    c, s = np.cos(angle), np.sin(angle)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    wl = np.asarray(wavelengths)[:: max(1, len(wavelengths) // 8)]
    a = np.asarray(brdf(wi, wo, wl), dtype=np.float64)
    b = np.asarray(brdf(wi @ rot.T, wo @ rot.T, wl), dtype=np.float64)
    scale = max(float(np.abs(a).max()), np.finfo(float).tiny)
    return bool(np.all(np.abs(a - b) <= rtol * scale))


def sample_brdf_spectra(brdf, wavelengths: np.ndarray, isotropic: bool,
                        step_deg: float = 10.0) -> np.ndarray:
    """``f·cosθi`` spectra on a sparse angular grid (Schwenk et al.: 10° sampling)."""
    theta = np.radians(np.arange(step_deg / 2, 90.0, step_deg))
    dphi = np.radians(np.arange(0.0, 360.0, step_deg))
    phi_i = np.array([0.0]) if isotropic else np.radians(np.arange(0.0, 360.0, 3 * step_deg))
    ti, to, pi, dp = (a.ravel() for a in np.meshgrid(theta, theta, phi_i, dphi, indexing="ij"))
    po = pi + dp
    wi = np.stack([np.sin(ti) * np.cos(pi), np.sin(ti) * np.sin(pi), np.cos(ti)], axis=-1)
    wo = np.stack([np.sin(to) * np.cos(po), np.sin(to) * np.sin(po), np.cos(to)], axis=-1)
    return np.asarray(brdf(wi, wo, wavelengths), dtype=np.float64) * wi[:, 2:3]


def build_basis(brdf, wavelengths: np.ndarray, isotropic: bool,
                spectral_basis: int | float | LinearModelBasis,
                illuminants: Sequence[str] = BASIS_ILLUMINANTS) -> LinearModelBasis:
    """Resolve ``factor_brdf``'s ``spectral_basis`` argument to a basis."""
    if isinstance(spectral_basis, LinearModelBasis):
        return spectral_basis
    reflectances = sample_brdf_spectra(brdf, wavelengths, isotropic)
    lights = light_cmf_spectra(illuminants, wavelengths)
    if isinstance(spectral_basis, int | np.integer) and not isinstance(spectral_basis, bool):
        return linear_model_basis(wavelengths, reflectances, lights, count=int(spectral_basis))
    if isinstance(spectral_basis, float):
        return linear_model_basis(wavelengths, reflectances, lights, tolerance=spectral_basis)
    raise TypeError("spectral_basis must be None, an int (size), a float (tolerance) or a "
                    f"LinearModelBasis, got {type(spectral_basis).__name__}")


def factor_brdf(
    brdf,
    *,
    parameterization: str = "io",
    isotropic: bool | None = None,
    resolution: Sequence[int] | None = None,
    wavelengths: np.ndarray | None = None,
    packs: int | None = None,
    target_de94: float | None = None,
    pack_size: int = 4,
    spectral_basis: int | float | LinearModelBasis | None = None,
    callback: ProgressCallback | None = None,
    seed: int = 0,
    method: str = "joint",
    cosine_weighted: bool = True,
    compress_tolerance: float | None = 3e-4,
    weighting: float = DEFAULT_WEIGHTING,
    nd_norm: float = 2.0,
    smoothing: int = 0,
    settings: cp.ALSSettings | None = None,
    lobe: str | SpecularLobe | None = None,
    cells: tuple[int, int, int] | None = None,
) -> FactoredBRDF:
    """Factor a spectral BRDF into CP factor packs or a Kautz–McCool separable form.

    Parameters
    ----------
    brdf : callable
        ``brdf(wi, wo, wavelengths) -> (N, L)`` as in shared/PROTOCOL.md.
    parameterization : {"io", "hd", "gs", "ea"} or an isotropic key ("io_iso", "hd_iso")
    isotropic : bool, optional
        ``None`` tests the BRDF (rotation about the normal) and uses the
        isotropic layout when it is: IO → (θi, φo−φi, θo), HD → (θh, θd, φd).
    resolution : sequence of int, optional
        Cells per axis; the parameterisation's default otherwise (io_iso: 90×180×90).
    wavelengths : ndarray, optional
        Tabulation grid in nm; default 380–780 nm every 5 nm.
    packs : int, optional
        Number of packs (an upper bound when ``target_de94`` is given). For
        ``"svd"``/``"nd"`` it is the number of separable terms.
    target_de94 : float, optional
        Stop at the first pack count whose mean ΔE94 (D65, 4000 random pairs of
        the protocol) is ≤ this.
    pack_size : int
        Terms per pack (4 = one RGBA texel).
    spectral_basis : None, int, float or LinearModelBasis
        ``None``: factor the wavelength samples directly. ``int``: Peercy basis of
        that size; ``float``: basis sized by that projection tolerance.
    callback : callable, optional
        ``callback(fraction, message) -> stop?``; a true return raises ``Cancelled``.
    seed : int
        Seeds every random choice: same inputs and seed, same factors.
    method : {"joint", "greedy", "svd", "nd"}
        ``"joint"`` (default, measured better per term, see docs/bench_factor.md)
        refines all terms together after each pack; ``"greedy"`` is the paper's
        residual-per-pack scheme.
    cosine_weighted : bool
        Factor ``f·cosθi`` (default, as the paper) rather than ``f``.
    weighting : float
        Perceptual weighting exponent γ (default 0.5): before fitting, each angular
        axis is scaled by ``(rms(i)/max rms)^−γ`` (clipped to [1, 1000]), so dim
        regions, where ΔE94 is most sensitive to an absolute error, weigh more.
        The weights are diagonal per axis, so they fold back into the factors
        exactly: storage and evaluation do not change. 0 = plain least squares.
    compress_tolerance : float or None
        Relative error of the HOSVD core the CP packs are fitted on; ``None``
        fits the full table (slower, same answer to within this tolerance).
    smoothing : int
        Width of a moving-average filter applied to the angular CP factors
        (paper §4.1, Fig. 4); 0 = off. Periodic axes wrap.
    lobe : str, SpecularLobe or None
        An analytic specular lobe beside the packs (:mod:`.lobe`): a family of
        ``LOBE_FAMILIES`` is fitted, a ``SpecularLobe`` on the basis used as given; the
        packs then factor the residual. None (default): packs alone.
    cells : (n_θh, n_θd, n_φd), optional
        Draw the model in a measured table's cells, as the table's readers look it up
        (:mod:`.measured_cells`; ``merl.MERLBRDF.lookup_cells``). None: drawn smooth.

    Returns
    -------
    FactoredBRDF
        With ``.report`` holding error and time figures.
    """
    series = factor_brdf_series(
        brdf, pack_counts=None, parameterization=parameterization, isotropic=isotropic,
        resolution=resolution, wavelengths=wavelengths, packs=packs, target_de94=target_de94,
        pack_size=pack_size, spectral_basis=spectral_basis, callback=callback, seed=seed,
        method=method, cosine_weighted=cosine_weighted, compress_tolerance=compress_tolerance,
        weighting=weighting, nd_norm=nd_norm, smoothing=smoothing, settings=settings,
        lobe=lobe, cells=cells,
    )
    return series[-1]


def resolve_parameterization(brdf, name: str, isotropic: bool | None,
                             wavelengths: np.ndarray) -> tuple[Parameterization, bool]:
    """The parameterisation for ``name`` ("io", "hd_iso", …) and whether it is isotropic.

    An ``_iso`` suffix forces the isotropic layout; ``isotropic=None`` tests the BRDF.
    """
    if name.endswith("_iso"):
        isotropic = True
        name = name.removesuffix("_iso")
    if isotropic is None:
        isotropic = is_isotropic(brdf, wavelengths)
    return get_parameterization(name, isotropic), bool(isotropic)


def prepare_table(brdf, *, parameterization="io", isotropic=None, resolution=None,
                  wavelengths=None, spectral_basis=None, cosine_weighted=True,
                  lobe: str | SpecularLobe | None = None, cells=None, callback=None) -> Table:
    """Steps 1–3 of :func:`factor_brdf`: parameterisation, basis and tabulation.

    ``lobe``: a family of :data:`.lobe.LOBE_FAMILIES` fits an analytic lobe
    (:func:`.lobe.fit_lobe`) after the basis, a :class:`.lobe.SpecularLobe` (on that
    basis) is used as given; the table then holds the residual ``f − lobe`` (0 below
    :data:`.lobe.INVISIBLE_REST` of ``f``) and carries the lobe (``Table.lobe``).
    ``cells``: the models are drawn in a measured table's (θh, θd, φd) cells
    (:mod:`.measured_cells`; ``Table.cells``), and the lobe is taken out as drawn there.
    """
    if not callable(brdf):
        raise TypeError(f"brdf must be callable f(wi, wo, wavelengths), got {type(brdf).__name__}")
    wl = spectra.check_wavelengths(
        spectra.WAVELENGTHS_REFERENCE if wavelengths is None else wavelengths)
    param, isotropic = resolve_parameterization(brdf, parameterization, isotropic, wl)
    grid = Grid(param, tuple(resolution) if resolution is not None else param.default_resolution)
    report(callback, 0.0, "spectral basis" if spectral_basis is not None else "tabulating")
    basis = None if spectral_basis is None else build_basis(brdf, wl, isotropic, spectral_basis)
    cells = None if cells is None else tuple(int(n) for n in cells)
    if lobe is None:
        table = tabulate(brdf, grid, wl, cosine_weighted=cosine_weighted, basis=basis,
                         callback=callback)
    else:
        lobe, fit_report = resolve_lobe(brdf, lobe, wl, basis, isotropic,
                                        scaled(callback, 0.0, 0.5))
        residual = LobeResidual(brdf, lobe, wl, None if basis is None else basis.vectors,
                                cells, invisible=INVISIBLE_REST)
        table = tabulate(residual, grid, wl, cosine_weighted=cosine_weighted, basis=basis,
                         callback=scaled(callback, 0.5 if fit_report else 0.0, 1.0),
                         signed=True)
        table.lobe, table.lobe_report = lobe, fit_report
    table.cells = cells
    return table


def factor_brdf_series(
    brdf,
    *,
    pack_counts: Sequence[int] | None,
    table: Table | None = None,
    packs: int | None = None,
    target_de94: float | None = None,
    pack_size: int = 4,
    callback: ProgressCallback | None = None,
    seed: int = 0,
    method: str = "joint",
    compress_tolerance: float | None = 3e-4,
    weighting: float = DEFAULT_WEIGHTING,
    nd_norm: float = 2.0,
    smoothing: int = 0,
    settings: cp.ALSSettings | None = None,
    **table_options,
) -> list[FactoredBRDF]:
    """Like :func:`factor_brdf`, returning a model at each of ``pack_counts``.

    One incremental fit serves every count (the benchmark's error-against-time
    rows); each model's report carries the seconds spent up to its count.
    ``table`` reuses an existing tabulation. Without ``pack_counts`` the list
    holds just the final model.
    """
    _check_options(method, packs, pack_counts, target_de94, pack_size, smoothing)
    if not (np.isfinite(weighting) and 0 <= weighting <= 2):
        raise ValueError(f"weighting must be in [0, 2], got {weighting}")
    start = time.perf_counter()
    if table is None:
        table = prepare_table(brdf, callback=scaled(callback, 0.0, 0.3), **table_options)
    tabulated = time.perf_counter()
    counts = sorted(set(int(c) for c in pack_counts)) if pack_counts else []
    max_packs = max(counts) if counts else (
        packs if packs is not None else (64 if target_de94 is not None else DEFAULT_PACKS))
    # The stopping rule's estimate: the protocol's measure on its first 4000 pairs.
    target = metrics.ProtocolError(brdf, count=4000) if target_de94 is not None else None
    base = dict(
        parameterization=table.grid.parameterization.name, resolution=table.grid.shape,
        wavelengths=table.wavelengths,
        basis=None if table.basis is None else table.basis.vectors.astype(np.float32),
        cosine_weighted=table.cosine_weighted, pack_size=pack_size,
        # f·cosθi is 0 at θi = 90°; an uncosined table is not, and keeps extrapolating.
        edge="horizon" if table.cosine_weighted else "linear",
        lobe=table.lobe,
        cells=table.cells,
    )
    common_report = {
        "method": method, "seed": seed, "grid": table.grid.describe(),
        "spectral_size": int(table.values.shape[-1]),
        "tabulate_seconds": tabulated - start,
        "basis_relative_error": float(np.sqrt(table.basis_error_sq / table.norm_sq))
        if table.norm_sq > 0 else 0.0,
        **table.lobe_report,
    }
    sub = scaled(callback, 0.3, 1.0)
    if method in ("svd", "nd"):
        return _separable_series(table, counts or [max_packs], method, nd_norm, base,
                                 common_report, sub, seed)
    options = _CPOptions(method, compress_tolerance, weighting, smoothing, settings, seed)
    return _cp_series(table, counts, max_packs, options, target, target_de94, base,
                      common_report, tabulated, sub)


def _check_options(method, packs, pack_counts, target_de94, pack_size, smoothing) -> None:
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    if target_de94 is not None and method in ("svd", "nd"):
        raise ValueError("target_de94 applies to CP packs; give the separable methods packs=")
    for count in ([packs] if packs is not None else []) + list(pack_counts or []):
        if not 1 <= int(count) <= MAX_PACKS:
            raise ValueError(f"packs must be 1..{MAX_PACKS}, got {count}")
    if target_de94 is not None and not (np.isfinite(target_de94) and target_de94 > 0):
        raise ValueError(f"target_de94 must be a positive number, got {target_de94}")
    if not 1 <= int(pack_size) <= 64:
        raise ValueError(f"pack_size must be 1..64, got {pack_size}")
    if not 0 <= smoothing <= 64:
        raise ValueError(f"smoothing must be 0..64 samples, got {smoothing}")


def _relative(table: Table, error_sq: float) -> float:
    if table.norm_sq <= 0:
        return 0.0
    return float(np.sqrt((error_sq + table.basis_error_sq) / table.norm_sq))


@dataclass
class _CPOptions:
    method: str
    compress_tolerance: float | None
    weighting: float
    smoothing: int
    settings: cp.ALSSettings | None
    seed: int


class _CPSeries:
    """One CP fit of a table and the models it yields along the way: the table weighted
    and Tucker-compressed first if asked, a model built at each requested pack count (or
    at every pack when a ΔE94 target decides where to stop), then the final model."""

    def __init__(self, table, counts, options: _CPOptions, target, target_de94, base,
                 common_report, tabulated, callback):
        self.table, self.counts, self.options = table, counts, options
        self.target, self.target_de94 = target, target_de94
        self.base, self.common_report, self.tabulated = base, common_report, tabulated
        self.tensor = table.values
        self.weights = None
        self.work = self.tensor
        if options.weighting > 0:
            self.weights = mode_weights(self.tensor, options.weighting)
            self.work = scale_modes(self.tensor, self.weights)
        self.compression = None
        if options.compress_tolerance is not None:
            self.compression = cp.tucker_compress(self.work, options.compress_tolerance,
                                                  callback=scaled(callback, 0.0, 0.2))
            self.work = self.compression.core
        # The stored factors differ from the fitted ones when weighted or smoothed; their
        # error then needs a pass over the table, and its norm (computed once, here).
        self.exact_pass = self.weights is not None or options.smoothing > 1
        self.norm_sq = cp.tensor_norm_sq(self.tensor) if self.exact_pass else None
        self.compressed = time.perf_counter()
        self.results: list[FactoredBRDF] = []
        self.per_pack: list[dict] = []
        self.bookkeeping = 0.0  # seconds spent building snapshot models and their errors
        self.fitted_norm_sq = (self.compression.tensor_norm_sq if self.compression
                               else cp.tensor_norm_sq(self.work))

    def full_factors(self, factors):
        full = self.compression.lift(factors) if self.compression is not None \
            else list(factors)
        if self.weights is not None:
            full = [f / w[:, None] for f, w in zip(full, self.weights)] \
                + full[len(self.weights):]
        return full

    def true_error_sq(self, full, fitted_error_sq):
        """The table error of the stored factors (one float64 pass if weighted or smoothed)."""
        if not self.exact_pass:
            return fitted_error_sq + (self.compression.error_sq if self.compression else 0.0)
        return cp.residual_norm_sq(self.tensor, full, self.norm_sq)

    def _compression_report(self) -> dict | None:
        compression = self.compression
        return None if compression is None else {
            "core_shape": list(compression.core.shape),
            "relative_error": float(np.sqrt(compression.error_sq
                                            / max(compression.tensor_norm_sq, 1e-300))),
            "seconds": self.compressed - self.tabulated}

    def as_model(self, factors, packs_now, fitted_error_sq, seconds):
        begin = time.perf_counter()
        full = self.full_factors(factors)
        full = [_smooth(f, a, self.options.smoothing)
                for f, a in zip(full[:-1], self.table.grid.parameterization.axes)] + full[-1:]
        angular = [f.astype(np.float32) for f in full[:-1]]
        model = FactoredBRDF(factors=angular, spectral=full[-1].astype(np.float32), **self.base)
        model.report = dict(
            self.common_report, packs=packs_now, terms=model.terms, factor_seconds=seconds,
            bytes=model.nbytes,
            relative_rms=_relative(self.table, self.true_error_sq(full, fitted_error_sq)),
            weighting=self.options.weighting, compression=self._compression_report())
        self.bookkeeping += time.perf_counter() - begin
        return model

    def fit_seconds(self):
        """Fitting time so far: snapshots taken for other pack counts do not count."""
        return time.perf_counter() - self.tabulated - self.bookkeeping

    def on_pack(self, pack, factors, error_sq):
        seconds = self.fit_seconds()
        model = None
        total = error_sq + (self.compression.error_sq if self.compression else 0.0)
        # The objective the fit minimises (weighted when weighting > 0); monotone.
        row = {"packs": pack, "seconds": seconds,
               "fitted_relative_error": float(np.sqrt(total / max(self.fitted_norm_sq,
                                                                  1e-300)))}
        stop = False
        if self.target is not None:
            model = self.as_model(factors, pack, error_sq, seconds)
            row["mean_de94_d65"] = self.target.stats(model)["mean"]
            stop = row["mean_de94_d65"] <= self.target_de94
        self.per_pack.append(row)
        if pack in self.counts:
            self.results.append(model or self.as_model(factors, pack, error_sq, seconds))
        return stop

    def finish(self, factors, history, max_packs):
        """The final model, the per-pack rows in every report, and the final model again
        for counts beyond where the fit stopped."""
        pack_size = self.base["pack_size"]
        if not history.error_sq:  # zero BRDF: one pack of zeros
            factors = [np.zeros((n, pack_size)) for n in self.work.shape]
            error_sq = 0.0
        else:
            error_sq = history.error_sq[-1]
        final = self.as_model(factors, max(1, len(history.error_sq)), error_sq,
                              self.fit_seconds())
        per_pack = self.per_pack
        final.report["per_pack"] = per_pack
        final.report["stopped"] = (
            "target reached" if self.target is not None and per_pack and per_pack[-1].get(
                "mean_de94_d65", np.inf) <= self.target_de94
            else "error floor" if len(history.error_sq) < max_packs else "pack limit")
        for model in self.results:
            model.report["per_pack"] = per_pack[: model.report["packs"]]
        # Counts beyond where the fit stopped get the final model: more packs would
        # not lower the error (see report["stopped"]).
        for count in self.counts[len(self.results):]:
            extra = replace(final, report=dict(final.report, requested_packs=count))
            self.results.append(extra)
        return self.results if self.counts else [final]


def _cp_series(table, counts, max_packs, options: _CPOptions, target, target_de94, base,
               common_report, tabulated, callback):
    series = _CPSeries(table, counts, options, target, target_de94, base, common_report,
                       tabulated, callback)
    factors, history = cp.fit_packs(series.work, max_packs, pack_size=base["pack_size"],
                                    method=options.method, settings=options.settings,
                                    seed=options.seed, on_pack=series.on_pack,
                                    callback=scaled(callback, 0.2, 1.0))
    return series.finish(factors, history, max_packs)


def _separable_series(table, counts, method, nd_norm, base, common_report, callback, seed):
    split = table.grid.parameterization.split
    matrix = separable.matrix_view(table.values, split)
    norm_sq = cp.tensor_norm_sq(table.values)
    out = []
    for terms in counts:
        begin = time.perf_counter()
        if method == "svd":
            result = separable.separable_svd(table.values, split, terms, seed=seed,
                                             callback=callback)
        else:
            result = separable.normalized_decomposition(table.values, split, terms, p=nd_norm,
                                                        callback=callback)
        seconds = time.perf_counter() - begin
        error_sq = _separable_error_sq(matrix, norm_sq, result)
        model = FactoredBRDF(form="separable", split=split, g=result.g, h=result.h, **base)
        model.report = dict(common_report, packs=terms, terms=terms, factor_seconds=seconds,
                            bytes=model.nbytes, relative_rms=_relative(table, error_sq))
        out.append(model)
    return out


def _separable_error_sq(matrix: np.ndarray, norm_sq: float, result) -> float:
    """‖M − G Hᵀ‖² = ‖M‖² − 2 Σ G∘(M H) + Σ (GᵀG)∘(HᵀH), float64 sums, no table copy in float64."""
    g = result.g.astype(np.float64)
    h = result.h.astype(np.float64)
    cross = 0.0
    for sl in cp.chunk_slices(matrix.shape[0], 8 * matrix.shape[1]):
        cross += float(np.sum(g[sl] * (matrix[sl].astype(np.float64) @ h)))
    model_sq = float(np.sum((g.T @ g) * (h.T @ h)))
    return max(norm_sq - 2.0 * cross + model_sq, 0.0)


def _smooth(factor: np.ndarray, axis, width: int) -> np.ndarray:
    """Moving average of ``width`` samples along a factor's rows (wrapping on φ axes)."""
    if width <= 1:
        return factor
    kernel = np.ones(width) / width
    mode = "wrap" if axis.periodic else "nearest"
    from scipy.ndimage import convolve1d
    return convolve1d(factor, kernel, axis=0, mode=mode)


__all__ = ["factor_brdf", "factor_brdf_series", "prepare_table", "is_isotropic", "METHODS"]
