"""Factor one material for the add-on: fit, measure by the protocol, draw the error plot.

Pure NumPy (no ``bpy``): the add-on runs it in a worker thread, and headless scripts
call it directly. The error figures are the protocol's (shared/PROTOCOL.md): ΔE94
under D65 at the 20 000 seeded random direction pairs, against the 5 nm reference of
the BRDF itself, never against the factorisation.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..colour.basis import LinearModelBasis
from ..progress import ProgressCallback, report, scaled
from ..raster_plots import plot_error_against_packs
from . import metrics
from .factor import factor_brdf_series
from .factored import FactoredBRDF


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
    counts = None if options.target_de94 is not None else list(range(1, options.packs + 1))
    models = factor_brdf_series(
        brdf, pack_counts=counts, packs=options.packs, target_de94=options.target_de94,
        pack_size=options.pack_size, smoothing=options.smoothing, seed=options.seed,
        parameterization=options.parameterization, isotropic=options.isotropic,
        resolution=options.resolution, spectral_basis=basis,
        callback=scaled(callback, 0.05, 0.9))
    report(callback, 0.9, "measuring ΔE94")
    series = []
    for model in models:
        stats = error.stats(model)
        series.append({"packs": model.packs, "de94": stats,
                       "seconds": float(model.report.get("factor_seconds", 0.0))
                       + float(model.report.get("tabulate_seconds", 0.0))})
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
