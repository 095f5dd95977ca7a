"""Invisible rest (issue 18): ΔE94 against the fraction of the BRDF below which the rest beside
a lobe is taken as 0.

``core/brdf/lobe.py`` ``INVISIBLE_REST`` sets where the rest beside a specular lobe is left
out of the packs, so that they do not spread the lobe's misfit along the mirror direction
onto the dark flanks beside it. This sweep fits the glossy cases of
``benchmarks.colour_targets`` (Orange gloss and Teal brushed at the demo's settings, the MERL
round trip at the default ones) at each fraction, as the add-on factors them (the fraction
set as the tests set it: the module's one constant), and measures them against the 5 nm
reference on the protocol's pairs and on the dense grazing bands. It shows the window in
which the fraction works and what each end costs. Measurement only.

Usage::

    python -m benchmarks.invisible_rest            # the fractions below, all cases
    python -m benchmarks.invisible_rest --quick    # 0 and the constant, Orange gloss only
"""

from __future__ import annotations

import time

from spectral_materials.core.brdf import factor as factor_module
from spectral_materials.core.brdf.job import factor_material
from spectral_materials.core.brdf.lobe import INVISIBLE_REST

from . import colour_targets as ct, harness

#: The fractions swept (0 keeps every rest).
FRACTIONS = (0.0, 0.002, 0.0025, 0.003, 0.005, 0.007, 0.01)
#: (case, settings) swept: the glossy materials with a lobe.
SWEPT = (("Orange gloss", "demo"), ("Teal brushed", "demo"), (ct.MEASURED, "default"))


def _settings(case: ct.Case, settings: str, cases: list[ct.Case]):
    """The options and basis of ``case`` at ``settings`` as colour_targets measures it."""
    if settings == "demo":
        demo = [c for c in cases if c.demo_packs is not None]
        return (ct.addon_options(case, ct.DEMO_THETA_CELLS, case.demo_packs),
                ct.choose_basis(demo, ct.DEMO_LIGHTS).basis)
    return (ct.addon_options(case, ct.DEFAULT_THETA_CELLS, ct.DEFAULT_PACKS),
            ct.choose_basis([case], ct.CASE_LIGHTS).basis)


def _row(model, errors: dict, fraction: float, seconds: float) -> dict:
    out = {"fraction": fraction, "grid": list(model.resolution), "packs": model.packs,
           "fit_seconds": seconds}
    for ill, stats in errors.items():
        out[ill] = {"mean": stats["mean"], "p95": stats["p95"], "max_below": stats["max_below"],
                    "view_max": [b["max"] for b in stats["dense"]["view"]["bands"]],
                    "incidence_max": [b["max"] for b in stats["dense"]["incidence"]["bands"]]}
    return out


def run(quick: bool) -> dict:
    start = time.perf_counter()
    fractions = (0.0, INVISIBLE_REST) if quick else FRACTIONS
    swept = SWEPT[:1] if quick else SWEPT
    cases, _ = ct.build_cases()
    by_name = {c.name: c for c in cases}
    pairs = ct.Pairs(dense=True)
    results = []
    original = factor_module.INVISIBLE_REST
    try:
        for name, settings in swept:
            case = by_name[name]
            options, basis = _settings(case, settings, cases)
            reference = pairs.reference(case.brdf)
            rows = []
            for fraction in fractions:
                factor_module.INVISIBLE_REST = fraction
                harness.log(f"{name} ({settings}): invisible rest {fraction:g}")
                job = factor_material(case.brdf, basis, options)
                rows.append(_row(job.model, pairs.errors(job.model, reference), fraction,
                                 float(job.series[-1]["seconds"])))
            results.append({"case": name, "settings": settings, "rows": rows})
    finally:
        factor_module.INVISIBLE_REST = original
    return {"quick": quick, "constant": INVISIBLE_REST, "fractions": list(fractions),
            "illuminants": list(ct.ILLUMINANTS), "goals": ct.GOALS,
            "dense_bands_deg": [list(b) for b in ct.DENSE_BANDS_DEG],
            "dense_pairs": ct.DENSE_PAIRS, "results": results,
            "seconds": time.perf_counter() - start}


def _maxima(values: list[float]) -> str:
    return ", ".join(f"**{v:.2f}**" if v > ct.GOALS["max_below"] else f"{v:.2f}"
                     for v in values)


def markdown(result: dict) -> list[str]:
    lines = [
        "# Invisible rest (issue 18): ΔE94 against the fraction left out beside a lobe", "",
        f"{'Quick' if result['quick'] else 'Full'} run. Printed by `python -m "
        f"benchmarks.invisible_rest` on {result['date']} at commit {result['commit']} "
        f"({result['cpu']}, {result['cpu_count']} cores, load {result['load_start']:.2f} "
        f"at the start); the whole run took {result['seconds']:.0f} s.", "",
        "Where the rest beside a lobe is below this fraction of the BRDF (norms over "
        "wavelengths) the packs factor 0 there (`lobe.INVISIBLE_REST`, now "
        f"{result['constant']:g}; 0 keeps every rest). Each case is fitted as the add-on "
        "fits it (benchmarks/colour_targets.py) and measured against the 5 nm reference: "
        "the protocol's 20,000 pairs (mean / p95 / max below 89.5°) and "
        f"{result['dense_pairs']:,} pairs per dense band (max in the view bands and the "
        "incidence bands 89–89.5°, 89.5–89.9°, >89.9°). Bold: over the goal's 5. "
        "*fit s*: the stored pack count's seconds, Automatic's choices included.", ""]
    for ill in result["illuminants"]:
        lines += [f"## {ill}", "",
                  "| case | settings | fraction | grid | packs | mean / p95 / max <89.5° | "
                  "view bands, max | incidence bands, max | fit s |",
                  "|---|---|---|---|---|---|---|---|---|"]
        for res in result["results"]:
            for row in res["rows"]:
                e = row[ill]
                lines.append(
                    f"| {res['case']} | {res['settings']} | {row['fraction'] * 100:g} % | "
                    f"{'×'.join(map(str, row['grid']))} | {row['packs']} | "
                    f"{e['mean']:.3f} / {e['p95']:.3f} / {e['max_below']:.2f} | "
                    f"{_maxima(e['view_max'])} | {_maxima(e['incidence_max'])} | "
                    f"{row['fit_seconds']:.1f} |")
        lines.append("")
    return lines


def main(argv: list[str] | None = None) -> None:
    parser = harness.parser(__doc__, quick_help="0 and the constant, Orange gloss only",
                            out_help="write bench_invisible_rest.md/.json here, not docs/")
    args = parser.parse_args(argv)
    machine = {"cpu": harness.cpu_model(), "cpu_count": harness.os.cpu_count(),
               "load_start": harness.load_average(), "commit": harness.commit_of(),
               "date": harness.date_stamp(), "command": harness.command_line("invisible_rest")}
    result = {**machine, **run(args.quick)}
    harness.publish(args.out, "invisible_rest", args.quick, result, markdown(result))


if __name__ == "__main__":
    main()
