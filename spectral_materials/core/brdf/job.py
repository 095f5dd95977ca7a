"""Factor one material for the add-on: fit, measure by the protocol, draw the error plot.

Pure NumPy (no ``bpy``): the add-on runs it in a worker thread, and headless scripts
call it directly. The error figures are the protocol's (shared/PROTOCOL.md): ΔE94
under D65 at the 20 000 seeded random direction pairs, against the 5 nm reference of
the BRDF itself, never against the factorisation.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from ..colour import spectra
from ..colour.basis import LinearModelBasis
from ..progress import ProgressCallback, report, scaled
from ..raster_plots import plot_error_against_packs
from . import grazing, metrics
from .factor import factor_brdf_series
from .factored import FactoredBRDF, fit_seconds
from .lobe import LOBE_FAMILIES, SpecularLobe, fit_lobe, residual_anisotropy
from .params import get_parameterization

#: Lobe settings of :class:`FactorOptions`: none, chosen by the fit, or a family forced.
LOBE_SETTINGS = ("off", "auto", *LOBE_FAMILIES)
#: "auto" tries a fitted lobe when it makes the fit's weighted RMS at least this many times
#: smaller than a smooth surface alone: glossy analytic models measure 3–70 with the
#: Ashikhmin–Shirley lobe, the MERL round trip 12, Oren–Nayar 1.3 with it but 10–20 at
#: σ 0.1 and over 100 at 0.52 with its own family's, glossy models under 1.1 with that
#: one, Lambert 1 with either (tests/core/brdf/test_lobe.py, test_oren_nayar_lobe.py).
LOBE_MIN_GAIN = 2.0
#: ... and keeps it without measuring the packs both ways when the gain is at least this:
#: the lobe's family is then the BRDF's own (60–70 measured), and the second series would
#: double the time.
LOBE_SURE_GAIN = 20.0
#: Pairs on which "auto" compares the packs with and without the lobe: not the protocol's
#: (seed), so that the choice never sees the pairs it is measured at.
LOBE_CHECK_PAIRS = 4000
LOBE_CHECK_SEED = 424242
#: With a lobe, an anisotropic material's packs take the isotropic layout (io → io_iso,
#: the same θ cells) when the rest turns about the normal by at most this
#: (``lobe.residual_anisotropy``; Ashikhmin–Shirley with its own lobe: 0.002–0.003).
ISOTROPIC_RESIDUAL = 0.01
#: The version of what Automatic chooses (its checks, their pairs, the order of its
#: choices), named in the input hash of a material under Automatic
#: (blender/brdf/sources.py): a change to it marks the materials it chose for before out of
#: date. 2: the θ-cell check's pairs where the view alone grazes, and each series settled
#: (edge rule, pack count in cells) before it is compared (issue 18).
AUTOMATIC_RULES = 2


@dataclass
class FactorOptions:
    """The factorisation settings a material carries."""

    parameterization: str = "io"
    resolution: tuple[int, ...] | None = None
    isotropic: bool | None = None
    packs: int = 4
    target_de94: float | None = None
    pack_size: int = 4
    smoothing: int = 0
    seed: int = 0
    #: An analytic specular lobe beside the packs (:data:`LOBE_SETTINGS`, core/brdf/lobe.py).
    lobe: str = "off"
    #: The layout is the add-on's Automatic: packs beside a lobe whose rest is isotropic
    #: may take the isotropic layout (:func:`residual_layout`); an explicit choice stays.
    automatic: bool = False
    #: (parameterisation, resolution) of packs without a lobe, where Automatic picks
    #: another layout for them (half/difference for an anisotropic glossy model); None:
    #: the same as with a lobe.
    plain_layout: tuple | None = None
    #: Under ``automatic``: the choices at the horizon (core/brdf/grazing.py), twice the θ
    #: cells where the packs' error there is the cells', and the view-horizon edge rule.
    horizon_choices: bool = True
    #: :data:`CELL_SETTINGS`: whether a measured table's model is drawn in its cells, as
    #: its readers look it up (core/brdf/measured_cells.py).
    cells: str = "auto"


#: "auto": in the cells of a source that looks pairs up in cells (``lookup_cells``: MERL
#: files), smooth otherwise; "cells": in them, an error for a source without; "smooth".
CELL_SETTINGS = ("auto", "cells", "smooth")


def drawn_cells(brdf, setting: str) -> tuple[int, int, int] | None:
    """The cells ``setting`` draws a model of ``brdf`` in (:data:`CELL_SETTINGS`), or None."""
    if setting not in CELL_SETTINGS:
        raise ValueError(f"cells must be one of {CELL_SETTINGS}, got {setting!r}")
    cells = getattr(brdf, "lookup_cells", None)
    if setting == "cells" and cells is None:
        raise ValueError(f"cells: {type(brdf).__name__} is not a table looked up in cells "
                         "(a MERL file is); choose 'auto' or 'smooth'")
    return None if setting == "smooth" or cells is None else tuple(int(n) for n in cells)


@dataclass
class MaterialJobResult:
    """A factored material and its measured figures."""

    model: FactoredBRDF
    series: list[dict] = field(default_factory=list)   # per pack count: packs, ΔE94, seconds
    plot: np.ndarray | None = None                     # RGBA float32, row 0 at the bottom
    seconds: float = 0.0
    #: Without a target: the model of each row of ``series``. With one: the final model
    #: only (the earlier rows are the stopping rule's estimates, with no model kept).
    models: list[FactoredBRDF] = field(default_factory=list)


def factor_material(brdf, basis: LinearModelBasis | None, options: FactorOptions,
                    callback: ProgressCallback | None = None) -> MaterialJobResult:
    """Factor ``brdf`` on ``basis`` and measure every pack count up to the final one.

    Without a target, one incremental fit yields the models for 1 … ``packs`` packs
    and each is measured; with ``target_de94`` the fit stops at the first count that
    meets it (its own 4000-pair estimate) and that count is measured in full.
    """
    start = time.perf_counter()
    report(callback, 0.0, "reference colours")
    error = metrics.ProtocolError(brdf)
    cells = drawn_cells(brdf, options.cells)
    lobe, lobe_report = choose_lobe(brdf, basis, options, scaled(callback, 0.05, 0.1))
    counts = None if options.target_de94 is not None else list(range(1, options.packs + 1))
    lobe_options = options if lobe is None else residual_layout(brdf, lobe, basis, options,
                                                                lobe_report)
    plain_options = options
    if options.plain_layout is not None:
        name, resolution = options.plain_layout
        plain_options = replace(options, parameterization=name, resolution=tuple(resolution),
                                isotropic=str(name).endswith("_iso") or options.isotropic)

    def fit(with_lobe, low, high, chosen=None):
        chosen = chosen or (lobe_options if with_lobe is not None else plain_options)
        return _settle(brdf, _distinct_counts(factor_brdf_series(
            brdf, pack_counts=counts, packs=options.packs, target_de94=options.target_de94,
            pack_size=options.pack_size, smoothing=options.smoothing, seed=options.seed,
            parameterization=chosen.parameterization, isotropic=chosen.isotropic,
            resolution=chosen.resolution, spectral_basis=basis, lobe=with_lobe, cells=cells,
            callback=scaled(callback, low, high))), options, cells is not None)

    undecided = lobe is not None and options.lobe == "auto" \
        and lobe_report["lobe_fit_gain"] < LOBE_SURE_GAIN
    if undecided:
        models, lobe_report = _keep_the_better(brdf, fit(lobe, 0.1, 0.5), fit(None, 0.5, 0.9),
                                               lobe_report)
    else:
        models = fit(lobe, 0.1, 0.9)
    if options.automatic and options.horizon_choices:
        models, lobe_report = _automatic_horizon(brdf, models, lobe_report, fit,
                                                 lobe_options, plain_options, callback)
    report(callback, 0.95, "measuring ΔE94")
    series = _measured_series(models, error, lobe_report)
    final = models[-1]
    if options.target_de94 is not None:
        # The stopping rule's cheaper estimate, for the plot's earlier counts.
        for row in final.report.get("per_pack", [])[:-1]:
            series.insert(-1, {"packs": row["packs"],
                               "de94": {"mean": row.get("mean_de94_d65", float("nan"))},
                               "seconds": row["seconds"]})
    seconds = time.perf_counter() - start
    final.report["de94"] = series[-1]["de94"]
    final.report["seconds"] = seconds
    final.report["series"] = series
    packs = [row["packs"] for row in series]
    means = [row["de94"]["mean"] for row in series]
    p95 = [row["de94"].get("p95", row["de94"]["mean"]) for row in series]
    plot = plot_error_against_packs(packs, means, p95, target=options.target_de94)
    report(callback, 1.0, "done")
    return MaterialJobResult(model=final, series=series, plot=plot, seconds=seconds,
                             models=list(models) if options.target_de94 is None else [final])


def _automatic_horizon(brdf, models: list[FactoredBRDF],
                       figures: dict, fit, lobe_options: FactorOptions,
                       plain_options: FactorOptions, callback) -> tuple[list, dict]:
    """Automatic's choice at the horizon (core/brdf/grazing.py): twice the θ cells where
    the packs' error there is the cells' (each grid settled, with its own edge rule)."""
    report(callback, 0.9, "checking the horizon")
    kept_lobe = models[-1].lobe
    chosen = lobe_options if kept_lobe is not None else plain_options
    models, refined = grazing.refine_theta(
        brdf, models, chosen, lambda finer: fit(kept_lobe, 0.9, 0.95, finer))
    return models, {**figures, **refined}


def _distinct_counts(models: list[FactoredBRDF]) -> list[FactoredBRDF]:
    """The series without the counts past where the fit stopped at its error floor, which
    repeat its final model (``factor_brdf_series``): an Oren–Nayar rest beside its own
    lobe is one exact pack. Of equal counts the last is kept: the final model, whose
    report says why the fit stopped (``stopped``, ``requested_packs``)."""
    kept: list[FactoredBRDF] = []
    for model in models:
        if kept and model.packs == kept[-1].packs:
            kept[-1] = model
        else:
            kept.append(model)
    return kept


def _settle(brdf, series: list[FactoredBRDF], options: FactorOptions, in_cells: bool
            ) -> list[FactoredBRDF]:
    """What Automatic would store of a fitted series, settled before it is compared with
    another (lobe or not, θ cells), so that what is compared is what would be stored: its
    edge rule at the view's horizon (``grazing.choose_edge``), then, in cells, the pack
    count that measures best under that rule, and the rule chosen again for that count.
    The figures, and the seconds spent on them and on the pack counts fitted past the one
    kept (``settle_seconds``), go in the report of the model kept last."""
    if not options.automatic:
        return series
    start = time.perf_counter()
    fitted = series[-1]
    figures = grazing.choose_edge(brdf, series) if options.horizon_choices else {}
    if in_cells and options.target_de94 is None:
        series, means = _best_packs_in_cells(brdf, series)
        figures.update(cells_check_de94=means, cells_packs_kept=series[-1].packs)
        if "edge_choice" in figures and series[-1] is not fitted:
            figures.update(grazing.choose_edge(brdf, series))
    past = (float(fitted.report.get("factor_seconds", 0.0))
            - float(series[-1].report.get("factor_seconds", 0.0)))
    series[-1].report.update(figures, settle_seconds=time.perf_counter() - start + past)
    return series


def _best_packs_in_cells(brdf, models: list[FactoredBRDF]
                         ) -> tuple[list[FactoredBRDF], list[float]]:
    """Automatic in cells keeps the pack count that measures best at the check pairs:
    the series up to it, and the mean ΔE94 of every count.

    The packs are fitted to the table's steps at their own grid's points and read at the
    cells' centres, which lie elsewhere: past the first packs, more of them follow the
    steps between those points more closely and can measure worse at the centres (the
    MERL round trip: docs/bench_colour_targets.md, "Error against time")."""
    check = metrics.ProtocolError(brdf, count=LOBE_CHECK_PAIRS, seed=LOBE_CHECK_SEED)
    means = [check.stats(model)["mean"] for model in models]
    return models[: int(np.argmin(means)) + 1], means


def _measured_series(models: list[FactoredBRDF], error: metrics.ProtocolError,
                     figures: dict) -> list[dict]:
    """Per model: its pack count, protocol ΔE94 and seconds, the choices' own included
    (the lobe's fit and the series Automatic measured and dropped)."""
    series = []
    for model in models:
        model.report.update(figures)
        spent = fit_seconds(model) + sum(float(figures.get(key, 0.0)) for key in (
            "lobe_fit_seconds", "lobe_choice_seconds", "grazing_seconds"))
        series.append({"packs": model.packs, "de94": error.stats(model), "seconds": spent})
    return series


def _wavelengths(basis: LinearModelBasis | None) -> np.ndarray:
    """The wavelengths the job's tables use: the basis's, or the 5 nm reference."""
    return spectra.WAVELENGTHS_REFERENCE if basis is None else basis.wavelengths


def choose_lobe(brdf, basis: LinearModelBasis | None, options: FactorOptions,
                callback: ProgressCallback | None = None
                ) -> tuple[SpecularLobe | None, dict]:
    """The analytic lobe ``options.lobe`` asks for, on ``basis``, and its fit's figures.

    "off": none. A family: that family's fitted lobe. "auto": every family is fitted
    and the one with the highest gain (``LobeFit.gain``, ties to the first) kept when it
    explains the BRDF :data:`LOBE_MIN_GAIN` times better than a smooth surface alone,
    else none; below :data:`LOBE_SURE_GAIN`, :func:`factor_material` then keeps it only
    where the packs with it measure better than without.
    """
    if options.lobe not in LOBE_SETTINGS:
        raise ValueError(f"lobe must be one of {LOBE_SETTINGS}, got {options.lobe!r}")
    if options.lobe == "off":
        return None, {"lobe": "off"}
    families = LOBE_FAMILIES if options.lobe == "auto" else (options.lobe,)
    wavelengths = _wavelengths(basis)
    isotropic = bool(options.isotropic) or str(options.parameterization).endswith("_iso")
    fits = []
    for i, family in enumerate(families):
        fits.append(fit_lobe(brdf, wavelengths, basis, isotropic=isotropic, family=family,
                             callback=scaled(callback, i / len(families),
                                             (i + 1) / len(families))))
    fit = max(fits, key=lambda candidate: candidate.gain)
    kept = options.lobe != "auto" or fit.gain >= LOBE_MIN_GAIN
    figures = {"lobe": options.lobe, "lobe_kept": kept, "lobe_family": fit.lobe.family,
               "lobe_fit_gain": fit.gain,
               "lobe_family_gains": {f.lobe.family: f.gain for f in fits},
               "lobe_fit_seconds": sum(f.seconds for f in fits),
               "lobe_fit_evaluations": sum(f.evaluations for f in fits)}
    return (fit.lobe if kept else None), figures


def _keep_the_better(brdf, with_lobe: list[FactoredBRDF], without: list[FactoredBRDF],
                     figures: dict) -> tuple[list[FactoredBRDF], dict]:
    """The series whose final model has the lower mean ΔE94 (D65) at the check pairs.

    A lobe of the wrong shape can cost more than it saves (an Ashikhmin–Shirley lobe on
    GGX: docs/bench_colour_targets.md), so "auto" measures both rather than assume.
    """
    start = time.perf_counter()
    check = metrics.ProtocolError(brdf, count=LOBE_CHECK_PAIRS, seed=LOBE_CHECK_SEED)
    means = [check.stats(series[-1])["mean"] for series in (with_lobe, without)]
    kept = means[0] < means[1]
    other = (without if kept else with_lobe)[-1]
    # The check's own time and the series not kept.
    seconds = time.perf_counter() - start + fit_seconds(other)
    figures = {**figures, "lobe_kept": kept, "lobe_check_de94": means[0],
               "no_lobe_check_de94": means[1], "lobe_choice_seconds": seconds}
    return (with_lobe if kept else without), figures


def residual_layout(brdf, lobe: SpecularLobe, basis: LinearModelBasis | None,
                    options: FactorOptions, figures: dict) -> FactorOptions:
    """The options the packs beside ``lobe`` are fitted with: ``options``, or for an
    Automatic anisotropic input/output layout whose rest is isotropic
    (:data:`ISOTROPIC_RESIDUAL`) the isotropic one with the same θ cells. Writes what it
    measured into ``figures``."""
    if not options.automatic or options.isotropic or options.parameterization != "io":
        return options
    wavelengths = _wavelengths(basis)
    anisotropy = residual_anisotropy(brdf, lobe, wavelengths,
                                     None if basis is None else basis.vectors)
    figures["residual_anisotropy"] = anisotropy
    if anisotropy > ISOTROPIC_RESIDUAL:
        return options
    theta_cells = grazing.theta_cells("io", False, options.resolution)
    return replace(options, parameterization="io_iso", isotropic=True,
                   resolution=get_parameterization("io", True).theta_resolution(theta_cells))
