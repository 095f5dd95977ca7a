"""The colour-targets benchmark's report (``benchmarks/colour_targets.py``): the issue-18
table, the stages, the choices Automatic made, the error-against-time curves and the bands
of angle, from the run's result dict."""

from __future__ import annotations


def _yes(flag: bool) -> str:
    return "yes" if flag else "**no**"


def _band_label(band: dict) -> str:
    lo, hi = band["from"], band["to"]
    return f"<{hi:g}°" if lo == 0 else (f">{lo:g}°" if hi == 90 else f"{lo:g}–{hi:g}°")


def lobe_label(lobe: dict | None) -> str:
    """"–", "ON" (Oren–Nayar's back-scatter term) or "AS nu/nv" (Ashikhmin–Shirley)."""
    if lobe is None:
        return "–"
    if lobe["family"] == "oren_nayar":
        return "ON"
    return f"AS {lobe['nu']:.4g}/{lobe['nv']:.4g}"


def main_table(result: dict, label: str = "after") -> list[str]:
    """The issue's table: one line per case, settings and illuminant."""
    grazing_deg = result["grazing_deg"]
    lines = ["| case | settings | light | packs | lobe | basis | grid | mean | p95 | "
             f"max <{grazing_deg:g}° | max ≥{grazing_deg:g}° | mean ≤ 0.5 | p95 ≤ 1 | "
             f"max ≤ 5 | falls to 90° | falls to 90° (θi) | fit s | bytes |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for row in result["rows"]:
        r = row[label]
        grid = f"{r['parameterization']} {'×'.join(map(str, r['resolution']))}"
        lobe = lobe_label(r["lobe"])
        for ill, e in r["errors"].items():
            g = e["goals"]
            lines.append(
                f"| {row['case']} | {row['settings']} | {ill} | {r['packs']} | {lobe} | "
                f"{row['basis_size']} | {grid} | {e['mean']:.3f} | {e['p95']:.3f} | "
                f"{e['max_below']:.2f} | {e['max_beyond']:.2f} | {_yes(g['mean'])} | "
                f"{_yes(g['p95'])} | {_yes(g['max_below'])} | {_yes(g['falls'])} | "
                f"{_yes(g['falls_incidence'])} | "
                f"{r['fit_seconds']:.1f} | {r['bytes']:,} |")
    return lines


STAGES = (("original", "packs, linear edge, unclamped (before issue 18)"),
          ("before", "packs, horizon edge rule, each light's XYZ ≥ 0"),
          ("lobe", "lobe + packs"),
          ("horizon", "+ Automatic θ cells and edge rule"),
          ("after", "+ measured cells (now)"))


def stage_table(result: dict) -> list[str]:
    """What each means bought: mean / p95 / max below 89.5° per stage, per illuminant."""
    lines = ["| case | settings | light | " + " | ".join(text for _, text in STAGES)
             + " | fit s before → after | bytes before → after |",
             "|---|---|---|" + "---|" * len(STAGES) + "---|---|"]
    for row in result["rows"]:
        before, after = row["before"], row["after"]
        for ill in after["errors"]:
            cells = []
            for key, _ in STAGES:
                e = row[key]["errors"][ill]
                cells.append(f"{e['mean']:.3f} / {e['p95']:.3f} / {e['max_below']:.1f}")
            lines.append(f"| {row['case']} | {row['settings']} | {ill} | " + " | ".join(cells)
                         + f" | {before['fit_seconds']:.2f} → {after['fit_seconds']:.2f} | "
                         f"{before['bytes']:,} → {after['bytes']:,} |")
    return lines


def curve_table(result: dict) -> list[str]:
    """Error against time under D65: packs alone (before) and lobe + packs (after), each
    pack count of each fit with its own seconds."""
    lines = ["| case | settings | packs | before: s | before: mean / p95 | after: s | "
             "after: mean / p95 |", "|---|---|---|---|---|---|---|"]
    for row in result["rows"]:
        before = {c["packs"]: c for c in row["before"]["curve"]}
        after = {c["packs"]: c for c in row["after"]["curve"]}
        for packs in sorted(set(before) | set(after)):
            cells = []
            for curve in (before, after):
                c = curve.get(packs)
                cells += (["–", "–"] if c is None else
                          [f"{c['seconds']:.2f}", f"{c['mean']:.3f} / {c['p95']:.3f}"])
            lines.append(f"| {row['case']} | {row['settings']} | {packs} | "
                         + " | ".join(cells) + " |")
    return lines


def lobe_table(result: dict) -> list[str]:
    """The lobe "Automatic" fitted, what it measured, and whether it was kept."""
    lines = ["| case | settings | fit gain | kept | lobe | residual anisotropy | "
             "packs layout | lobe fit s |", "|---|---|---|---|---|---|---|---|"]
    for row in result["rows"]:
        r = row["after"]
        rep = r["lobe_report"]
        lobe = lobe_label(r["lobe"])
        aniso = rep.get("residual_anisotropy")
        lines.append(f"| {row['case']} | {row['settings']} | {rep.get('lobe_fit_gain', 0):.1f} "
                     f"| {_yes(bool(rep.get('lobe_kept')))} | {lobe} | "
                     f"{'–' if aniso is None else f'{aniso:.4f}'} | {r['parameterization']} | "
                     f"{rep.get('lobe_fit_seconds', 0.0):.2f} |")
    return lines


def _view_means(report: dict) -> str:
    means = report.get("view_horizon_de94")
    return "–" if not means else f"{means['horizon']:.3f} / {means['horizons']:.3f}"


def theta_section(result: dict) -> list[str]:
    """Automatic θ cells (core/brdf/grazing.py): the grazing check and what it kept."""
    lines = [
        "## The θ cells Automatic chose", "",
        "Under the Automatic layout the packs are measured at 2,000 seeded pairs with θi "
        "and θo in [80°, 89.5°) and 2,000 with θo there and θi anywhere (not the "
        "protocol's); where their largest ΔE94 lies between 2 and 20 the material is fitted "
        "again with twice the θ cells (at most 64), and that fit is kept where it measures "
        "lower there. Each grid is measured as it would be stored: in cells at the pack "
        "count it keeps, and under its own edge rule at the view's horizon, *horizons* (the "
        "table falls to 0 as θo reaches 90°, as θi's does) where it measures a lower mean "
        "at 2,000 seeded pairs with θo in [85°, 90°) than *horizon* (core/brdf/grazing.py). "
        "The columns below are the grid kept.", "",
        "| case | settings | θ cells asked | grazing max, asked | grazing max, twice the "
        "cells | kept | grid | view-horizon mean, horizon / horizons | edge rule |",
        "|---|---|---|---|---|---|---|---|---|"]
    for row in result["rows"]:
        r = row["after"]
        rep = r["lobe_report"]
        finer = rep.get("grazing_finer_max_de94")
        coarse = rep.get("grazing_max_de94")
        lines.append(
            f"| {row['case']} | {row['settings']} | {result['theta_cells'][row['settings']]} | "
            f"{'–' if coarse is None else f'{coarse:.2f}'} | "
            f"{'not tried' if finer is None else f'{finer:.2f}'} | "
            f"{'finer' if rep.get('grazing_refined') else 'as asked'} | "
            f"{r['parameterization']} {'×'.join(map(str, r['resolution']))} | "
            f"{_view_means(rep)} | {r['edge']} |")
    return [*lines, ""]


def band_table(result: dict, key: str = "after", bands: str = "bands") -> list[str]:
    """Mean / max ΔE94 per band of max(θi, θo), of the pairs ``bands`` names ("bands":
    all, "bands_incidence": θi ≥ θo, "bands_view": θo > θi)."""
    first = result["rows"][0][key]["errors"][result["illuminants"][0]][bands]
    heads = [f"{_band_label(b)} (n = {b['count']})" for b in first]
    lines = ["| case | settings | light | " + " | ".join(heads) + " |",
             "|---|---|---|" + "---|" * len(heads)]
    for r in result["rows"]:
        for ill, e in r[key]["errors"].items():
            cells = ["–" if b["mean"] is None else f"{b['mean']:.2f} / {b['max']:.2f}"
                     for b in e[bands]]
            lines.append(f"| {r['case']} | {r['settings']} | {ill} | "
                         + " | ".join(cells) + " |")
    return lines


def dense_table(result: dict, key: str = "after") -> list[str]:
    """Mean ± 2 standard errors / max ΔE94 per dense grazing band, per side (none in a
    quick run)."""
    first = result["rows"][0][key]["errors"][result["illuminants"][0]].get("dense")
    if first is None:
        return ["(not measured in a quick run)"]
    heads = [f"{side} {_band_label(b)}" for side in ("incidence", "view")
             for b in first[side]["bands"]]
    lines = ["| case | settings | light | " + " | ".join(heads)
             + " | falls (θi) | falls (θo) | no blow-up (θi) | no blow-up (θo) |",
             "|---|---|---|" + "---|" * (len(heads) + 4)]
    for r in result["rows"]:
        for ill, e in r[key]["errors"].items():
            d = e["dense"]
            cells = [f"{b['mean']:.3f} ± {2 * b['se']:.3f} / {b['max']:.2f}"
                     for side in ("incidence", "view") for b in d[side]["bands"]]
            verdicts = [_yes(d[side][test]) for test in ("falls", "no_blow_up")
                        for side in ("incidence", "view")]
            lines.append(f"| {r['case']} | {r['settings']} | {ill} | " + " | ".join(cells)
                         + " | " + " | ".join(verdicts) + " |")
    return lines


def _header(result: dict) -> list[str]:
    """The title, what was run, and the goals."""
    grazing_deg = result["grazing_deg"]
    defaults = result["defaults"]
    theta = result["theta_cells"]
    size = ("**Quick run** (θ cells 12, at most 2 packs): a smoke test, not the figures."
            if result["quick"] else "Full run.")
    return [
        "# Colour targets (issue 18): the add-on's factorisation against the goals", "",
        f"{size} Printed by `{result['command']}` on {result['date']} at commit "
        f"{result['commit']} ({result['cpu']}, {result['cpu_count']} cores, load "
        f"{result['load_start']:.2f} at the start); the whole run took "
        f"{result['seconds']:.0f} s.", "",
        "ΔE94 per shared/PROTOCOL.md: 5 nm reference of the exact BRDF (the MERL table "
        f"read back, for the measured case), {result['pairs']:,} seeded random pairs, white "
        "Lambertian under the same light. *default*: the add-on's default material settings "
        f"(θ cells {theta['default']}, {defaults['packs']} packs of {defaults['pack_size']}, "
        "Automatic parameterisation, specular lobe Automatic, no smoothing or target) on the "
        "basis the scene analysis chooses (tolerance 0.05, at most 16) for that material "
        "alone under D65 and FL11. "
        f"*demo*: the demo's packs and θ cells ({theta['demo']}) on the demo scene's basis "
        "(its four materials under D65 and FL2). Orange gloss is the protocol's analytic "
        "isotropic case (bench_factor (b)), Teal brushed its anisotropic one (AS 8/64).", "",
        "Goals (issue 18): mean ≤ 0.5, p95 ≤ 1.0, max ≤ 5 over pairs with θi and θo < "
        f"{grazing_deg:g}°; *falls to 90°*: every band beyond {grazing_deg:g}° has a mean and a "
        f"max no larger than the band 89–{grazing_deg:g}° (errors fall towards 90°, not grow); "
        "*(θi)*: the same over the pairs whose incidence grazes (θi ≥ θo), where the "
        "reference f·cosθi itself falls to 0 at 90° (where the view grazes, θo > θi, the "
        "radiance stays as θo reaches 90°, and so may the error: the band tables below "
        "show both). "
        "*fit s*: the lobe's fit, tabulation and fitting seconds of the stored pack count "
        "(under Automatic, with the series it measured and dropped); "
        "*bytes*: the stored factor arrays, basis and lobe (float32).", "",
        "The demo rows under D65 are the add-on's own figures for the demo scene (as "
        "docs/demo/report.md shows them): the options, BRDFs and basis here are those of "
        "`jobs.run_scene_job`. The fit follows tiny changes of its input (a basis moved by "
        "~1e-12 moved a mean by 5 % before), so read differences of a few per cent as noise.",
        ""]


def markdown(result: dict) -> list[str]:
    return [
        *_header(result),
        *main_table(result), "",
        "## What each means bought", "",
        "Mean / p95 / max below 89.5° per stage, all in this run: the packs alone (the "
        "Automatic parameterisation without a lobe: half/difference for an anisotropic "
        "glossy model) under the linear edge rule that every lookup used before issue 18, "
        "and without each light's XYZ clamped at 0; the same packs under the horizon edge "
        "rule (core/brdf/axes.py, a lookup rule: no time, no bytes) with the clamp, as every "
        "stage after it; and the add-on now, an analytic Ashikhmin–Shirley lobe beside "
        "packs of the rest (core/brdf/lobe.py), kept where it measures better; then the "
        "same with Automatic's choices at the horizon (core/brdf/grazing.py): twice the θ "
        "cells where the error there is the cells', and the edge rule at the view's "
        "horizon; last, a measured table drawn in its own cells as its reader looks it up "
        "(core/brdf/measured_cells.py: the MERL case; the others are not tables looked up "
        "in cells and repeat the column before).", "",
        *stage_table(result), "",
        *theta_section(result),
        "## The lobe Automatic chose", "",
        "*fit gain*: how many times smaller the fit's weighted RMS is with the lobe than a "
        "smooth surface alone (below 2 no lobe is tried; from 20 it is kept without "
        "measuring packs both ways). *residual anisotropy*: how much the rest changes when "
        "the directions turn about the normal; at most 0.01 puts an anisotropic material's "
        "packs on the isotropic layout.", "",
        *lobe_table(result), "",
        "## Error against time (D65)", "",
        "Each pack count of each incremental fit with its own seconds (the lobe's fit, "
        "tabulation and fitting up to that count, the add-on job's stored figure): packs "
        "alone (before) and lobe + packs (after), both fitted in this run.", "",
        *curve_table(result), "",
        "## ΔE94 mean / max per band of max(θi, θo)", "",
        *band_table(result), "",
        "The pairs whose incidence grazes (θi ≥ θo, banded by θi): the reference f·cosθi "
        "falls to 0 as θi reaches 90°.", "",
        *band_table(result, bands="bands_incidence"), "",
        "The pairs whose view grazes (θo > θi, banded by θo): the reference stays as θo "
        "reaches 90°.", "",
        *band_table(result, bands="bands_view"), "",
        "Before (packs alone, horizon edge rule):", "",
        *band_table(result, "before"), "",
        "## Dense grazing bands", "",
        f"The protocol's pairs put few pairs near 90° (see the counts above), too few for "
        f"the rare corner where both angles graze. Here each band has "
        f"{result.get('dense_pairs', 0):,} seeded pairs per side, uniform in solid angle given "
        "that the grazing angle (θi for *incidence*, θo for *view*) lies in the band: mean "
        "± 2 standard errors / max ΔE94, the add-on now. *falls*: each band beyond 89.5° has "
        "a mean and a max no larger than 89–89.5°'s. *no blow-up*: each band beyond 89.5° "
        "has a max within the goal's 5 and a mean no larger than 89–89.5°'s by more than "
        "two combined standard errors (a flat error passes it, and fails *falls* about "
        "half the time).", "",
        *dense_table(result), "",
        "Before (packs alone at the θ cells asked for, horizon edge rule, each light's XYZ "
        "≥ 0):", "",
        *dense_table(result, "before"), "",
        "MERL round trip (s): " + ", ".join(f"{k} {v:.2f}"
                                           for k, v in result["merl_timings"].items()), ""]


