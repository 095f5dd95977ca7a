"""Automatic θ cells: a finer grid where the packs' error near the horizon is the cells'.

With the add-on's default of 32 θ cells, the last cell centre sits at 88.6°. Beyond it
the table follows the edge rule, and a BRDF whose f·cosθi does not vanish there (Oren–
Nayar's retro-reflection: along θi = θo it tends to B, not 0) is interpolated across a
ridge narrower than a cell: Red clay reached ΔE94 7.0 at θi ≈ θo ≈ 89.3°
(docs/bench_colour_targets.md). Under the add-on's *Automatic* layout,
:func:`refine_theta` measures the fitted packs on seeded pairs (never the protocol's)
with both directions in :data:`GRAZING_RANGE_DEG`, and as many with only the view there
(:func:`check_pairs`), and, where their largest ΔE94 lies in
(:data:`REFINE_ABOVE`, :data:`REFINE_BELOW`), fits again with twice the θ cells (where
that is at most :data:`MAX_THETA_CELLS`) and keeps
that fit where it measures lower there. Above :data:`REFINE_BELOW` no refit is spent:
an error that large is not the cells' (the MERL round trip drawn smooth, not in its
table's cells, measures 37 there: docs/bench_colour_targets.json).

Each grid is measured under the lookup's edge rule at the view's horizon that
:func:`choose_edge` picks for it (``job._settle``), which costs no fit: ``"horizons"``
(the table falls to 0 as θo reaches 90°, as a layered surface's diffuse term and the
rest beside a glossy lobe do) where it measures lower than ``"horizon"`` on seeded pairs
with θo in :data:`VIEW_RANGE_DEG`. Oren–Nayar keeps ``"horizon"``: its retro-reflection
does not vanish there.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from . import metrics
from .factored import FactoredBRDF, fit_seconds
from .params import get_parameterization

GRAZING_RANGE_DEG = (80.0, 89.5)
GRAZING_PAIRS = 2000
GRAZING_SEED = 8950
#: Largest ΔE94 at the check's pairs that is left as it is (docs/bench_colour_targets.md,
#: "The θ cells Automatic chose": beside their lobes the demo materials measure under 1 at
#: 32 θ cells and keep them; the MERL round trip, in cells, measures over 2 and is refined).
REFINE_ABOVE = 2.0
REFINE_BELOW = 20.0
#: The finest θ cells the refinement goes to (the demo's).
MAX_THETA_CELLS = 64
#: :func:`choose_edge`'s pairs: θo uniform in this range, θi uniform on the hemisphere.
VIEW_RANGE_DEG = (85.0, 90.0)
VIEW_SEED = 8951
#: The edge rules :func:`choose_edge` chooses between.
EDGE_CHOICES = ("horizon", "horizons")
#: :func:`check_pairs`'s second half (the light anywhere, the view grazing): its own seeds,
#: so that its pairs share no draws with :func:`view_horizon_pairs`'s.
VIEW_CHECK_SEED = 8960


def grazing_pairs(count: int = GRAZING_PAIRS, seed: int = GRAZING_SEED,
                  range_deg: tuple[float, float] = GRAZING_RANGE_DEG
                  ) -> tuple[np.ndarray, np.ndarray]:
    """``count`` seeded (wi, wo) pairs, θ of each uniform in ``range_deg``, φ uniform."""
    rng = np.random.default_rng(seed)

    def directions() -> np.ndarray:
        theta = np.radians(rng.uniform(*range_deg, count))
        phi = rng.uniform(0.0, 2.0 * np.pi, count)
        return np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi),
                         np.cos(theta)], axis=-1)
    return directions(), directions()


def check_pairs(count: int = GRAZING_PAIRS, seed: int = GRAZING_SEED,
                view_seed: int = VIEW_CHECK_SEED) -> tuple[np.ndarray, np.ndarray]:
    """:func:`refine_theta`'s pairs: ``count`` with both θ in :data:`GRAZING_RANGE_DEG`,
    then ``count`` with θo there and wi uniform on the hemisphere (seeded from
    ``view_seed``). The second half is where the view grazes and the light does not: the
    radiance does not fall to 0 there, and the MERL round trip's largest errors at 32 θ
    cells lay there, at low θi, where pairs that both graze do not reach (issue 18)."""
    both_wi, both_wo = grazing_pairs(count, seed)
    view_wi = metrics.uniform_hemisphere(np.random.default_rng(view_seed), count)
    _, view_wo = grazing_pairs(count, view_seed + 1)
    return np.concatenate([both_wi, view_wi]), np.concatenate([both_wo, view_wo])


def theta_cells(parameterization: str, isotropic: bool | None,
                resolution: tuple[int, ...] | None) -> int:
    """θ cells per 90° of ``resolution`` (the parameterisation's default grid if None), read
    from its first axis, which is θ in every layout Automatic picks (io, io_iso, hd,
    hd_iso)."""
    param = get_parameterization(parameterization, bool(isotropic))
    first = (resolution or param.default_resolution)[0]
    return int(round(first * 90.0 / param.default_resolution[0]))


def finer_resolution(parameterization: str, isotropic: bool | None,
                     resolution: tuple[int, ...] | None) -> tuple[int, ...] | None:
    """The grid with twice the θ cells (``theta_resolution``), or None beyond
    :data:`MAX_THETA_CELLS`."""
    cells = 2 * theta_cells(parameterization, isotropic, resolution)
    if cells > MAX_THETA_CELLS:
        return None
    return get_parameterization(parameterization, bool(isotropic)).theta_resolution(cells)


def refine_theta(brdf, models: list[FactoredBRDF], options,
                 refit: Callable[[object], list[FactoredBRDF]]
                 ) -> tuple[list[FactoredBRDF], dict]:
    """``models``, or the series ``refit(finer options)`` returns where the grazing check
    asks for it and it measures lower (module doc). ``options`` are the series' own
    (``FactorOptions``). Returns the series kept and what was measured.

    Both series come settled as they would be stored (``job._settle``: each grid's own
    edge rule, and in cells the pack count it keeps): a finer grid measured at a pack
    count or under an edge rule it would not keep can lose to the coarse one for that
    alone."""
    final = models[-1]
    finer = finer_resolution(final.parameterization, options.isotropic, final.resolution)
    if finer is None:
        return models, {"grazing_refined": False}
    start = time.perf_counter()
    check = metrics.ProtocolError(brdf, pairs=check_pairs())
    coarse = float(check.stats(final)["max"])
    checking = time.perf_counter() - start
    figures = {"grazing_refined": False, "grazing_max_de94": coarse,
               "grazing_seconds": checking}
    if not REFINE_ABOVE < coarse < REFINE_BELOW:
        return models, figures
    candidates = refit(replace(options, parameterization=final.parameterization,
                               resolution=finer))
    start = time.perf_counter()
    fine = float(check.stats(candidates[-1])["max"])
    checking += time.perf_counter() - start
    kept = fine < coarse
    # The check's own time and the series not kept.
    dropped = candidates[-1] if not kept else final
    figures.update(grazing_refined=kept, grazing_finer_max_de94=fine,
                   grazing_seconds=checking + fit_seconds(dropped))
    return (candidates if kept else models), figures


def view_horizon_pairs(count: int = GRAZING_PAIRS, seed: int = VIEW_SEED
                       ) -> tuple[np.ndarray, np.ndarray]:
    """``count`` seeded pairs: wi uniform on the hemisphere, wo with θo uniform in
    :data:`VIEW_RANGE_DEG`."""
    wi = metrics.uniform_hemisphere(np.random.default_rng(seed), count)
    _, wo = grazing_pairs(count, seed + 1, VIEW_RANGE_DEG)
    return wi, wo


def choose_edge(brdf, models: list[FactoredBRDF]) -> dict:
    """Set every model of the series to whichever of :data:`EDGE_CHOICES` measures the
    lower mean ΔE94 (D65) at :func:`view_horizon_pairs` on its last model; returns what was
    measured. A series already chosen for may be chosen for again (``job._settle``, after
    it keeps fewer packs). Models under another rule, or without a θo axis, are left
    alone."""
    final = models[-1]
    axes = final.grid.parameterization.axes
    if final.edge not in EDGE_CHOICES or not any(a.view_horizon for a in axes):
        return {}
    start = time.perf_counter()
    check = metrics.ProtocolError(brdf, pairs=view_horizon_pairs())
    means = {edge: float(check.stats(replace(final, edge=edge))["mean"])
             for edge in EDGE_CHOICES}
    chosen = min(means, key=means.get)
    for model in models:
        model.edge = chosen
    return {"edge_choice": chosen, "view_horizon_de94": means,
            "edge_seconds": time.perf_counter() - start}
