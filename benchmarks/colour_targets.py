"""Colour targets (issue 18): ΔE94 of today's factor packs at the add-on's default settings.

For every demo material and every protocol case, factored as the add-on factors it, this
prints issue 18's table: ΔE94 (shared/PROTOCOL.md: 5 nm reference, the 20 000 seeded random
pairs) under D65 and FL11, mean / p95 / max below 89.5° / max beyond, the mean and max per
band of max(θi, θo), the fitting seconds and the texture bytes, each row marked against the
issue's goals (mean ≤ 0.5, p95 ≤ 1.0, max ≤ 5 below 89.5°). Measurement only.

Cases:

* the demo materials (demos/scene.py): Red clay, Blue felt (Oren–Nayar), Orange gloss
  (Ashikhmin–Shirley 32/32, the protocol's analytic isotropic glossy case, bench_factor (b))
  and Teal brushed (Ashikhmin–Shirley 8/64, the protocol's anisotropic case);
* the measured case: Ashikhmin–Shirley 32/32 written as MERL and read back
  (``benchmarks.measured``).

Settings:

* "default": the material properties' defaults (blender/brdf/properties.py: θ cells 32,
  4 packs, pack size 4, no smoothing, no target, parameterisation Automatic) mapped to the
  core options as ``blender/brdf/jobs.py`` ``factor_options`` maps them, on the basis the
  scene analysis chooses (scene defaults: tolerance 0.05, max size 16, CIE 1931 2°) for a
  scene holding that material alone, lit by D65 and FL11;
* "demo": the demo's own settings (its packs per material, the full demo's 64 θ cells) on
  the basis of the demo scene (its four materials, lit by D65 and FL2).

Usage::

    python -m benchmarks.colour_targets            # full size
    python -m benchmarks.colour_targets --quick    # 12 θ cells, at most 2 packs
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from spectral_materials.core.brdf import metrics, models
from spectral_materials.core.brdf.factor import (
    is_isotropic,
    resolve_parameterization,
    sample_brdf_spectra,
)
from spectral_materials.core.brdf.job import FactorOptions, factor_material
from spectral_materials.core.brdf.params import get_parameterization
from spectral_materials.core.colour import scene_basis, spectra

from . import harness, measured

WAVELENGTHS = spectra.WAVELENGTHS_REFERENCE     # blender/lights/spd.py WAVELENGTHS
ILLUMINANTS = ("D65", "FL11")
GRAZING_DEG = 89.5
BAND_EDGES_DEG = (0.0, 80.0, 85.0, 89.0, 89.5, 89.9, 90.0)
GOALS = {"mean": 0.5, "p95": 1.0, "max_below": 5.0}

# The add-on's defaults: material properties (blender/brdf/properties.py) and scene
# properties (blender/scene_properties.py).
DEFAULT_THETA_CELLS = 32
DEFAULT_PACKS = 4
DEFAULT_PACK_SIZE = 4
DEFAULT_SMOOTHING = 0
BASIS_TOLERANCE = float(np.float32(0.05))        # as the float property holds it
BASIS_MAX_SIZE = 16
#: Models that "Automatic" factors in half/difference angles when anisotropic
#: (blender/brdf/sources.py GLOSSY_MODELS).
GLOSSY_MODELS = ("ashikhmin_shirley", "ward", "ggx")

#: demos/scene.py MATERIALS, in core names: model, scalars, diffuse patch, specular, packs.
DEMO_MATERIALS = {
    "Red clay": ("oren_nayar", {"sigma": 0.52}, 15, None, 2),
    "Blue felt": ("oren_nayar", {"sigma": 0.3}, 13, None, 2),
    "Orange gloss": ("ashikhmin_shirley", {"nu": 32.0, "nv": 32.0}, 12, 0.05, 8),
    "Teal brushed": ("ashikhmin_shirley", {"nu": 8.0, "nv": 64.0}, 6, 0.05, 16),
}
DEMO_THETA_CELLS = 64                            # demos/sizes.py FULL
#: The demo scene's lights, in the order the scene analysis lists them (by name).
DEMO_LIGHTS = {"Shop FL2": "FL2", "Sun D65": "D65"}
#: A scene holding one material, lit by the illuminants measured.
CASE_LIGHTS = {ill: ill for ill in ILLUMINANTS}
MEASURED = "Measured AS32 (MERL)"
QUICK_THETA_CELLS = 12
QUICK_MAX_PACKS = 2


@dataclass
class Case:
    """One material to factor: its BRDF, whether "Automatic" treats it as an analytic
    glossy model, its demo packs (None: not a demo material) and what it stands for."""

    name: str
    brdf: object
    glossy_analytic: bool
    demo_packs: int | None
    note: str = ""


def demo_brdf(model: str, scalars: dict, patch: int, specular: float | None):
    """A demo material's BRDF as ``sources.MaterialInputs.brdf`` builds it: spectra on the
    5 nm grid, passed as (wavelengths, values); numbers as the float properties hold them
    (float32)."""
    scalars = {key: float(np.float32(value)) for key, value in scalars.items()}
    diffuse = spectra.colorchecker(patch, WAVELENGTHS)
    if model == "ashikhmin_shirley":
        roles = {"diffuse": diffuse,
                 "specular": np.full(WAVELENGTHS.shape, float(np.float32(specular)))}
    else:
        roles = {"albedo": diffuse}
    return models.make_model(model, **scalars,
                             **{k: (WAVELENGTHS, v) for k, v in roles.items()})


def build_cases() -> tuple[list[Case], dict]:
    """The demo materials and the measured case; the MERL round trip's timings."""
    notes = {"Orange gloss": "protocol analytic isotropic (bench_factor (b))",
             "Teal brushed": "protocol anisotropic (AS 8/64)"}
    cases = [Case(name, demo_brdf(model, scalars, patch, specular),
                  model in GLOSSY_MODELS, packs, notes.get(name, "demo"))
             for name, (model, scalars, patch, specular, packs) in DEMO_MATERIALS.items()]
    rgb = measured.RGBModel(measured.patch_rgb(measured.PATCH))
    brdf, timings = measured.merl_round_trip(rgb)
    cases.append(Case(MEASURED, brdf, False, None,
                      "protocol measured (bench_measured): AS 32/32 → MERL → Smits"))
    return cases, timings


# ------------------------------------------------------------- the add-on's mapping


def addon_options(case: Case, theta_cells: int, packs: int) -> FactorOptions:
    """``jobs.factor_options`` for a material with these settings (no ``bpy``): "Automatic"
    is half/difference for an anisotropic analytic glossy model, input/output otherwise;
    the parameterisation's default grid is scaled so that θ has ``theta_cells`` cells."""
    isotropic = is_isotropic(case.brdf, WAVELENGTHS)
    name = "hd" if case.glossy_analytic and not isotropic else "io"
    param, isotropic = resolve_parameterization(case.brdf, name, isotropic, WAVELENGTHS)
    resolution = get_parameterization(name, isotropic).theta_resolution(theta_cells)
    return FactorOptions(parameterization=param.name, resolution=resolution,
                         isotropic=isotropic, packs=packs, target_de94=None,
                         pack_size=DEFAULT_PACK_SIZE, smoothing=DEFAULT_SMOOTHING)


def choose_basis(cases: list[Case], lights: dict[str, str]) -> scene_basis.SceneBasisChoice:
    """The scene analysis's basis for these materials and lights (name → illuminant), at
    the scene defaults, as ``jobs.run_scene_job`` chooses it: each material's
    ``sources.sampled_spectra``, materials by name, each light's SPD at power 1. (The
    order matters: it moves the basis by ~1e-12, and the fit follows such changes.)"""
    materials = {}
    for case in sorted(cases, key=lambda c: c.name):
        values = sample_brdf_spectra(case.brdf, WAVELENGTHS, is_isotropic(case.brdf,
                                                                          WAVELENGTHS))
        keep = np.abs(values).max(axis=1) > 0
        materials[case.name] = values[keep] if keep.any() else values[:1]
    return scene_basis.choose_scene_basis(
        materials, {name: spectra.illuminant(ill, WAVELENGTHS) for name, ill in lights.items()},
        WAVELENGTHS,
        tolerance_de94=BASIS_TOLERANCE, max_size=BASIS_MAX_SIZE, observer=spectra.OBSERVER)


# ------------------------------------------------------------------- measuring


class Pairs:
    """The protocol's random pairs and the grazing angle max(θi, θo) of each, in degrees."""

    def __init__(self):
        self.wi, self.wo = metrics.random_direction_pairs()
        lowest = np.minimum(self.wi[:, 2], self.wo[:, 2])
        self.angle = np.degrees(np.arccos(np.clip(lowest, -1.0, 1.0)))

    def reference(self, brdf) -> dict:
        """5 nm reference XYZ under each illuminant."""
        return {ill: metrics.reference_xyz(brdf, self.wi, self.wo, ill) for ill in ILLUMINANTS}

    def errors(self, model, reference: dict) -> dict:
        """Per illuminant, the ΔE94 statistics of ``model`` (see :func:`error_stats`)."""
        return {ill: error_stats(metrics.delta_e94_image(
                    reference[ill], model.xyz(self.wi, self.wo, ill), ill), self.angle)
                for ill in ILLUMINANTS}


def error_stats(de: np.ndarray, angle: np.ndarray) -> dict:
    """Mean, p95, max below / beyond 89.5°, per-band mean and max, and the goals met."""
    below, beyond = de[angle < GRAZING_DEG], de[angle >= GRAZING_DEG]
    stats = {"mean": float(de.mean()), "p95": float(np.percentile(de, 95)),
             "max": float(de.max()), "count": int(de.size),
             "max_below": float(below.max()) if below.size else 0.0,
             "max_beyond": float(beyond.max()) if beyond.size else 0.0, "bands": []}
    for lo, hi in zip(BAND_EDGES_DEG[:-1], BAND_EDGES_DEG[1:]):
        inside = de[(angle >= lo) & (angle < hi)] if hi < 90.0 else de[angle >= lo]
        stats["bands"].append({"from": lo, "to": hi, "count": int(inside.size),
                               "mean": float(inside.mean()) if inside.size else None,
                               "max": float(inside.max()) if inside.size else None})
    stats["goals"] = {key: stats[key] <= limit for key, limit in GOALS.items()}
    stats["goals"]["falls"] = falls_to_90(stats["bands"])
    return stats


def falls_to_90(bands: list[dict]) -> bool:
    """Whether errors fall towards 90° rather than grow: each band beyond 89.5° has a mean
    and a max no larger than the band just below 89.5° (89–89.5°). Empty bands pass."""
    last = next(b for b in bands if b["to"] == GRAZING_DEG)
    if last["mean"] is None:
        return True
    return all(b["mean"] <= last["mean"] and b["max"] <= last["max"]
               for b in bands if b["from"] >= GRAZING_DEG and b["mean"] is not None)


def run_case(case: Case, settings: str, options: FactorOptions,
             choice: scene_basis.SceneBasisChoice, pairs: Pairs, reference: dict) -> dict:
    """Factor ``case`` as the add-on's job does and measure it under each illuminant."""
    harness.log(f"{case.name} ({settings}): {options.parameterization} "
                f"{options.resolution}, {options.packs} packs, basis {choice.size}")
    job = factor_material(case.brdf, choice.basis, options)
    model = job.model
    # The edge rule is a lookup rule: the same packs, measured under the rule before
    # issue 18 ("linear") and the one they are stored with.
    before = replace(model, edge="linear")
    return {"edge": model.edge, "errors_linear_edge": pairs.errors(before, reference),
            "curve": error_curve(job, pairs, reference),
            "case": case.name, "note": case.note, "settings": settings,
            "parameterization": options.parameterization,
            "resolution": list(options.resolution), "packs": model.packs,
            "basis_size": choice.size, "basis_max_de94": choice.max_de94,
            "fit_seconds": float(job.series[-1]["seconds"]), "job_seconds": job.seconds,
            "bytes": model.nbytes, "errors": pairs.errors(model, reference)}


def error_curve(job, pairs: Pairs, reference: dict) -> list[dict]:
    """Error against time under D65, one row per pack count of the incremental fit: its
    seconds (tabulation and fitting up to that count) and mean / p95 ΔE94 of that
    count's packs under the linear rule and under the stored one."""
    ill = ILLUMINANTS[0]
    if len(job.models) != len(job.series):
        raise ValueError("an error curve needs a model per pack count: factor without a "
                         "target ΔE94")
    rows = []
    for row, cut in zip(job.series, job.models):
        packs = int(row["packs"])
        stats = {}
        for rule in ("linear", cut.edge):
            de = metrics.delta_e94_image(reference[ill],
                                         replace(cut, edge=rule).xyz(pairs.wi, pairs.wo, ill),
                                         ill)
            stats[rule] = {"mean": float(de.mean()), "p95": float(np.percentile(de, 95))}
        rows.append({"packs": packs, "seconds": float(row["seconds"]), "edge": cut.edge,
                     **stats})
    return rows


def run(quick: bool) -> dict:
    """Every case at the default settings, the demo materials also at the demo's."""
    start = time.perf_counter()
    theta = QUICK_THETA_CELLS if quick else DEFAULT_THETA_CELLS
    demo_theta = QUICK_THETA_CELLS if quick else DEMO_THETA_CELLS
    cap = QUICK_MAX_PACKS if quick else None
    cases, merl_timings = build_cases()
    pairs = Pairs()
    demo_cases = [c for c in cases if c.demo_packs is not None]
    demo_choice = choose_basis(demo_cases, DEMO_LIGHTS)
    rows = []
    for case in cases:
        reference = pairs.reference(case.brdf)
        packs = DEFAULT_PACKS if cap is None else min(DEFAULT_PACKS, cap)
        rows.append(run_case(case, "default", addon_options(case, theta, packs),
                             choose_basis([case], CASE_LIGHTS), pairs, reference))
        if case.demo_packs is not None:
            packs = case.demo_packs if cap is None else min(case.demo_packs, cap)
            rows.append(run_case(case, "demo", addon_options(case, demo_theta, packs),
                                 demo_choice, pairs, reference))
    return {"quick": quick, "theta_cells": {"default": theta, "demo": demo_theta},
            "illuminants": list(ILLUMINANTS), "goals": GOALS, "grazing_deg": GRAZING_DEG,
            "band_edges_deg": list(BAND_EDGES_DEG), "pairs": int(pairs.angle.size),
            "merl_timings": merl_timings, "rows": rows,
            "seconds": time.perf_counter() - start}


# ------------------------------------------------------------------- the report


def _yes(flag: bool) -> str:
    return "yes" if flag else "**no**"


def _band_label(band: dict) -> str:
    lo, hi = band["from"], band["to"]
    return f"<{hi:g}°" if lo == 0 else (f">{lo:g}°" if hi == 90 else f"{lo:g}–{hi:g}°")


def main_table(result: dict) -> list[str]:
    """The issue's table: one line per case, settings and illuminant."""
    lines = ["| case | settings | light | packs | basis | grid | mean | p95 | "
             f"max <{GRAZING_DEG:g}° | max ≥{GRAZING_DEG:g}° | mean ≤ 0.5 | p95 ≤ 1 | "
             f"max ≤ 5 | falls to 90° | fit s | bytes |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in result["rows"]:
        grid = f"{r['parameterization']} {'×'.join(map(str, r['resolution']))}"
        for ill, e in r["errors"].items():
            g = e["goals"]
            lines.append(
                f"| {r['case']} | {r['settings']} | {ill} | {r['packs']} | "
                f"{r['basis_size']} | {grid} | {e['mean']:.3f} | {e['p95']:.3f} | "
                f"{e['max_below']:.2f} | {e['max_beyond']:.2f} | {_yes(g['mean'])} | "
                f"{_yes(g['p95'])} | {_yes(g['max_below'])} | {_yes(g['falls'])} | "
                f"{r['fit_seconds']:.1f} | {r['bytes']:,} |")
    return lines


def edge_table(result: dict) -> list[str]:
    """The same packs under the linear edge rule (before) and their own (after)."""
    lines = ["| case | settings | light | edge | mean | p95 | "
             f"max <{GRAZING_DEG:g}° | max ≥{GRAZING_DEG:g}° | band >89.9° mean / max |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in result["rows"]:
        for ill in r["errors"]:
            for label, e in (("linear (before)", r["errors_linear_edge"][ill]),
                             (f"{r['edge']} (after)", r["errors"][ill])):
                last = e["bands"][-1]
                lines.append(
                    f"| {r['case']} | {r['settings']} | {ill} | {label} | {e['mean']:.3f} | "
                    f"{e['p95']:.3f} | {e['max_below']:.2f} | {e['max_beyond']:.2f} | "
                    f"{last['mean']:.2f} / {last['max']:.2f} |")
    return lines


def curve_table(result: dict) -> list[str]:
    """Error against time under D65: the linear rule (before) and the stored one (after)
    on the same packs, per pack count."""
    lines = ["| case | settings | packs | seconds | linear (before) mean / p95 | "
             "stored rule (after) mean / p95 |", "|---|---|---|---|---|---|"]
    for r in result["rows"]:
        for c in r["curve"]:
            after = c[r["edge"]]
            lines.append(f"| {r['case']} | {r['settings']} | {c['packs']} | "
                         f"{c['seconds']:.2f} | {c['linear']['mean']:.3f} / "
                         f"{c['linear']['p95']:.3f} | {after['mean']:.3f} / "
                         f"{after['p95']:.3f} ({r['edge']}) |")
    return lines


def band_table(result: dict, key: str = "errors") -> list[str]:
    """Mean / max ΔE94 per band of max(θi, θo)."""
    first = result["rows"][0][key][ILLUMINANTS[0]]["bands"]
    heads = [f"{_band_label(b)} (n = {b['count']})" for b in first]
    lines = ["| case | settings | light | " + " | ".join(heads) + " |",
             "|---|---|---|" + "---|" * len(heads)]
    for r in result["rows"]:
        for ill, e in r[key].items():
            cells = ["–" if b["mean"] is None else f"{b['mean']:.2f} / {b['max']:.2f}"
                     for b in e["bands"]]
            lines.append(f"| {r['case']} | {r['settings']} | {ill} | "
                         + " | ".join(cells) + " |")
    return lines


def markdown(result: dict) -> list[str]:
    theta = result["theta_cells"]
    size = ("**Quick run** (θ cells 12, at most 2 packs): a smoke test, not the figures."
            if result["quick"] else "Full run.")
    lines = [
        "# Colour targets (issue 18): today's factor packs against the goals", "",
        f"{size} Printed by `{result['command']}` on {result['date']} at commit "
        f"{result['commit']} ({result['cpu']}, {result['cpu_count']} cores, load "
        f"{result['load_start']:.2f} at the start); the whole run took "
        f"{result['seconds']:.0f} s.", "",
        "ΔE94 per shared/PROTOCOL.md: 5 nm reference of the exact BRDF (the MERL table "
        f"read back, for the measured case), {result['pairs']:,} seeded random pairs, white "
        "Lambertian under the same light. *default*: the add-on's default material settings "
        f"(θ cells {theta['default']}, {DEFAULT_PACKS} packs of {DEFAULT_PACK_SIZE}, "
        "Automatic parameterisation, no smoothing or target) on the basis the scene analysis "
        "chooses (tolerance 0.05, at most 16) for that material alone under D65 and FL11. "
        f"*demo*: the demo's packs and θ cells ({theta['demo']}) on the demo scene's basis "
        "(its four materials under D65 and FL2). Orange gloss is the protocol's analytic "
        "isotropic case (bench_factor (b)), Teal brushed its anisotropic one (AS 8/64).", "",
        "Goals (issue 18): mean ≤ 0.5, p95 ≤ 1.0, max ≤ 5 over pairs with θi and θo < "
        f"{GRAZING_DEG:g}°; *falls to 90°*: every band beyond {GRAZING_DEG:g}° has a mean and a "
        f"max no larger than the band 89–{GRAZING_DEG:g}° (errors fall towards 90°, not grow). "
        "*fit s*: tabulation and fitting seconds of the stored pack count; "
        "*bytes*: the stored factor arrays and basis (float32).", "",
        "The demo rows under D65 are the add-on's own figures for the demo scene (as "
        "docs/demo/report.md shows them): the options, BRDFs and basis here are those of "
        "`jobs.run_scene_job`, bit for bit. The fit follows tiny changes of its input: the "
        "same basis with its materials and lights listed in another order (a change of "
        "~1e-12) gives Orange gloss (demo) a mean of 0.140 instead of 0.147, so read "
        "differences of a few per cent as noise.", "",
        *main_table(result), "",
        "## The edge rule: the same packs before and after", "",
        "New factor packs of a cosine-weighted table are stored with the *horizon* edge "
        "rule (core/brdf/axes.py: beyond the last θi cell centre f·cosθi falls linearly "
        "to 0 at 90°), where before every lookup extrapolated linearly. The rule only "
        "changes lookups, so these are the same packs measured both ways: no fitting "
        "time, no bytes. Materials factored in half/difference angles (hd) have no θi "
        "axis and are unchanged.", "",
        *edge_table(result), "",
        "## Error against time (D65)", "",
        "Each pack count of the incremental fit with its seconds (tabulation and fitting "
        "up to that count, the stored figure of the add-on's job), measured under the "
        "linear rule and under the rule the packs are stored with. The rule costs no time, "
        "so at equal time the two columns compare the methods directly.", "",
        *curve_table(result), "",
        "## ΔE94 mean / max per band of max(θi, θo)", "",
        *band_table(result), "",
        "Before (the linear edge rule on the same packs):", "",
        *band_table(result, "errors_linear_edge"), "",
        "MERL round trip (s): " + ", ".join(f"{k} {v:.2f}"
                                           for k, v in result["merl_timings"].items()), ""]
    return lines


def main(argv: list[str] | None = None) -> None:
    parser = harness.parser(__doc__, quick_help="12 θ cells, at most 2 packs: a smoke test",
                            out_help="write bench_colour_targets.md/.json here, not docs/")
    args = parser.parse_args(argv)
    machine = {"cpu": harness.cpu_model(), "cpu_count": harness.os.cpu_count(),
               "load_start": harness.load_average(), "commit": harness.commit_of(),
               "date": harness.date_stamp(), "command": harness.command_line("colour_targets")}
    result = {**machine, **run(args.quick)}
    harness.publish(args.out, "colour_targets", args.quick, result, markdown(result))


if __name__ == "__main__":
    main()
