"""Factor benchmark: error against run time for the three cases of the paper's Figure 3.

Writes ``docs/bench_factor.md``, ``docs/bench_factor.json``, ``docs/bench_factor.png`` and
sphere images ``docs/images/bench_<case>_<illuminant>.png`` (reference | result | ΔE94).

Every figure is measured as shared/PROTOCOL.md says; times are wall seconds on this
machine and are read against baselines from the same run (tensorly, the memory floor).

Usage::

    python -m benchmarks.factor              # the full benchmark (~15 min on 2 cores)
    python -m benchmarks.factor --quick      # coarse grids, for a smoke test
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from spectral_materials.core import FactoredBRDF
from spectral_materials.core.brdf import metrics, models
from spectral_materials.core.brdf.factor import factor_brdf_series, prepare_table
from spectral_materials.core.colour import spectra
from spectral_materials.core.colour.pipeline import white_xyz, xyz_to_display
from spectral_materials.core.decomposition import cp

from . import harness
from .harness import ROOT

PACKS = [1, 2, 4, 8, 16, 22, 32, 48]
ILLUMINANTS = ("D65", "FL2")
SPHERE_ILLUMINANTS = ("D65", "A", "FL2", "FL11")


def cases(quick: bool) -> dict:
    s = 3 if quick else 1
    return {
        "a": dict(
            title="Oren–Nayar σ = 0.52, patch 9, isotropic IO",
            brdf=models.OrenNayar(albedo=spectra.colorchecker_spectrum(9), sigma=0.52),
            parameterization="io", isotropic=True, resolution=(90 // s, 180 // s, 90 // s),
            basis=8, target=dict(packs=2, mean=0.15, p95=0.3)),
        "b": dict(
            title="Ashikhmin–Shirley nu = nv = 32, patch 12 diffuse, Rs = 0.05, isotropic IO",
            brdf=models.AshikhminShirley(nu=32, nv=32, diffuse=spectra.colorchecker_spectrum(12),
                                         specular=0.05),
            parameterization="io", isotropic=True, resolution=(90 // s, 180 // s, 90 // s),
            basis=8, target=dict(packs=8, mean=0.5, p95=1.5)),
        "c": dict(
            title="Ashikhmin–Shirley nu = 1, nv = 8, patch 6 specular, no diffuse, HD",
            brdf=models.AshikhminShirley(nu=1, nv=8, diffuse=0.0,
                                         specular=spectra.colorchecker_spectrum(6)),
            parameterization="hd", isotropic=False,
            resolution=(90 // s, 45 // s, 90 // s, 45 // s), basis=8,
            target=dict(packs=24, mean=1.0, p95=None)),
    }


class Evaluation:
    """Reference XYZ at the protocol's random pairs and sphere pixels, per illuminant."""

    def __init__(self, brdf, sphere_size: int):
        self.pairs = metrics.random_direction_pairs()
        self.views = {a: metrics.sphere_directions(a, sphere_size)
                      for a in metrics.SPHERE_INCIDENCES_DEG}
        self.sphere_wi = np.concatenate([v.wi for v in self.views.values()])
        self.sphere_wo = np.concatenate([v.wo for v in self.views.values()])
        self.ref_pairs = {i: metrics.reference_xyz(brdf, *self.pairs, i) for i in ILLUMINANTS}
        self.ref_sphere = {i: metrics.reference_xyz(brdf, self.sphere_wi, self.sphere_wo, i)
                           for i in SPHERE_ILLUMINANTS}

    def score(self, xyz_fn) -> dict:
        out = {}
        for illum in ILLUMINANTS:
            out[f"pairs_{illum}"] = metrics.delta_e94_stats(self.ref_pairs[illum],
                                                            xyz_fn(*self.pairs, illum), illum)
        for illum in SPHERE_ILLUMINANTS:
            out[f"sphere_{illum}"] = metrics.delta_e94_stats(
                self.ref_sphere[illum], xyz_fn(self.sphere_wi, self.sphere_wo, illum), illum)
        return out


def table_error(table, factors) -> float:
    norm_sq = cp.tensor_norm_sq(table.values)
    return float(np.sqrt(cp.residual_norm_sq(table.values, factors, norm_sq) / norm_sq))


def run_tensorly(table, rank: int, n_iter_max: int, ev) -> dict:
    import tensorly as tl
    from tensorly.decomposition import parafac

    tl.set_backend("numpy")
    start = time.perf_counter()
    cpt = parafac(tl.tensor(table.values), rank, n_iter_max=n_iter_max, init="random", tol=1e-8,
                  random_state=0)
    seconds = time.perf_counter() - start
    weights, factors = cpt
    factors = [np.asarray(f, dtype=np.float64) for f in factors]
    factors[0] = factors[0] * np.asarray(weights)[None, :]
    model = FactoredBRDF(
        parameterization=table.grid.parameterization.name, resolution=table.grid.shape,
        wavelengths=table.wavelengths,
        basis=None if table.basis is None else table.basis.vectors,
        cosine_weighted=table.cosine_weighted,
        factors=[f.astype(np.float32) for f in factors[:-1]],
        spectral=factors[-1].astype(np.float32))
    return {"rank": rank, "seconds": seconds, "table_relative_error": table_error(table, factors),
            "de94": ev.score(model.xyz)}


def sweep_speed(table, repeats: int = 3) -> dict:
    """One ALS sweep of a 4-term pack on the full table vs reading the table twice."""
    tensor = table.values
    rng = np.random.default_rng(0)
    factors = [rng.standard_normal((n, 4)) for n in tensor.shape]
    norm_sq = cp.tensor_norm_sq(tensor)
    sweeps, floors = [], []
    for _ in range(repeats):
        start = time.perf_counter()
        factors, _, _ = cp.als(tensor, factors, norm_sq=norm_sq, sweeps=1)
        sweeps.append(time.perf_counter() - start)
        start = time.perf_counter()
        tensor.sum(dtype=np.float32)
        tensor.sum(dtype=np.float32)
        floors.append(time.perf_counter() - start)
    return {"shape": list(tensor.shape), "sweep_seconds": min(sweeps),
            "read_twice_seconds": min(floors), "ratio": min(sweeps) / min(floors)}


def memory_child() -> None:
    """Factor a 90 × 180 × 90 × 61 tensor (wavelength mode) and print peak RSS."""
    brdf = models.OrenNayar(albedo=spectra.colorchecker_spectrum(9), sigma=0.52)
    wl = spectra.wavelength_grid(400, 700, 5)
    table = prepare_table(brdf, parameterization="io", isotropic=True, resolution=(90, 180, 90),
                          wavelengths=wl)
    factor_brdf_series(brdf, table=table, pack_counts=[4])
    print(json.dumps({"shape": list(table.values.shape), "tensor_bytes": table.values.nbytes,
                      "peak_rss_bytes": peak_rss_bytes()}))


def peak_rss_bytes() -> int:
    """This process's peak resident memory (VmHWM).

    Not ``getrusage().ru_maxrss``: Linux keeps that across ``execve``, so a child
    started from a large parent reports the parent's peak.
    """
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) * 1024
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def sphere_images(case_id, ev, model, out_dir: Path, size: int) -> list[str]:
    """Reference | result | ΔE94 heat map at 60° incidence, per illuminant."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    view = ev.views[60.0]
    written = []
    for illum in ("D65", "FL2"):
        ref = metrics.reference_xyz(ev.brdf, view.wi, view.wo, illum)
        test = model.xyz(view.wi, view.wo, illum)
        white = white_xyz(illum, spectra.WAVELENGTHS_REFERENCE)
        de = metrics.delta_e94_image(ref, test, illum)
        panels = []
        for xyz in (ref, test):
            img = np.zeros((size, size, 3))
            img[view.mask] = xyz_to_display(xyz, white)
            panels.append(img)
        heat = np.full((size, size), np.nan)
        heat[view.mask] = de
        fig, axes = plt.subplots(1, 3, figsize=(9, 3.2))
        for ax, img, label in zip(axes[:2], panels, ("reference (5 nm)", f"{model.packs} packs")):
            ax.imshow(img)
            ax.set_title(label, fontsize=9)
        im = axes[2].imshow(heat, cmap="magma", vmin=0, vmax=max(2.0, float(np.nanmax(heat))))
        axes[2].set_title(f"ΔE94 (mean {de.mean():.2f})", fontsize=9)
        fig.colorbar(im, ax=axes[2], fraction=0.046)
        for ax in axes:
            ax.axis("off")
        fig.suptitle(f"case ({case_id}), {illum}, light at 60°", fontsize=10)
        name = f"images/bench_{case_id}_{illum}.png"
        fig.savefig(out_dir / name, dpi=80, bbox_inches="tight")
        plt.close(fig)
        written.append(name)
    return written


def tensorly_rows(table, joint: list[dict], ev, log) -> list[dict]:
    """tensorly's parafac at ranks 4, 8, 16 against ``joint`` (the unweighted joint fit:
    the same plain least-squares objective)."""
    rows = []
    for rank in (4, 8, 16):
        row = run_tensorly(table, rank, n_iter_max=100, ev=ev)
        log(f"  tensorly rank {rank}: error {row['table_relative_error']:.5f} "
            f"in {row['seconds']:.1f} s")
        same = next(r for r in joint if r["terms"] >= rank)
        reach = next((r for r in joint if r["table_relative_error"]
                      <= row["table_relative_error"]), None)
        row["ours_equal_rank"] = {"error": same["table_relative_error"],
                                  "seconds": same["seconds"]}
        row["ours_to_reach"] = None if reach is None else {
            "packs": reach["packs"], "seconds": reach["seconds"],
            "time_ratio": reach["seconds"] / row["seconds"]}
        rows.append(row)
    return rows


def bench_case(case_id: str, case: dict, quick: bool, log, out: Path) -> dict:
    brdf = case["brdf"]
    packs = sorted(set(PACKS + [case["target"]["packs"]]))
    log(f"case ({case_id}): {case['title']}")
    start = time.perf_counter()
    table = prepare_table(brdf, parameterization=case["parameterization"],
                          isotropic=case["isotropic"], resolution=case["resolution"],
                          spectral_basis=case["basis"])
    tab_seconds = time.perf_counter() - start
    log(f"  tabulated {table.values.shape} in {tab_seconds:.1f} s")
    ev = Evaluation(brdf, 64 if quick else metrics.SPHERE_SIZE)
    ev.brdf = brdf
    result = {"title": case["title"], "shape": list(table.values.shape), "target": case["target"],
              "tabulate_seconds": tab_seconds, "table_bytes": int(table.values.nbytes),
              "basis_relative_error": float(np.sqrt(table.basis_error_sq / table.norm_sq)),
              "floor": ev.score(table.xyz), "methods": {}}
    variants = {"joint": dict(method="joint"), "greedy": dict(method="greedy"),
                "joint γ=0": dict(method="joint", weighting=0.0)}
    for method, options in variants.items():
        models_ = factor_brdf_series(brdf, table=table, pack_counts=packs, **options)
        rows = []
        for model in models_:
            factors = model.factors + [model.spectral]
            rows.append({"packs": model.report.get("requested_packs", model.report["packs"]),
                         "packs_fitted": model.report["packs"], "terms": model.terms,
                         "seconds": model.report["factor_seconds"], "bytes": model.nbytes,
                         "relative_rms": model.report["relative_rms"],
                         "table_relative_error": table_error(table, factors),
                         "de94": ev.score(model.xyz)})
            log(f"  {method:6s} {rows[-1]['packs']:3d} packs  "
                f"ΔE94 D65 mean {rows[-1]['de94']['pairs_D65']['mean']:.3f}  "
                f"t {rows[-1]['seconds']:.1f} s")
        result["methods"][method] = rows
        if method == "joint":
            target_model = next(m for m in models_ if m.report["packs"] == case["target"]["packs"])
            result["images"] = sphere_images(case_id, ev, target_model, out,
                                             64 if quick else metrics.SPHERE_SIZE)
    for method in ("svd", "nd"):
        rows = []
        for model in factor_brdf_series(brdf, table=table, pack_counts=[1, 2, 4, 8],
                                        method=method):
            rows.append({"terms": model.terms, "seconds": model.report["factor_seconds"],
                         "bytes": model.nbytes, "relative_rms": model.report["relative_rms"],
                         "de94": ev.score(model.xyz)})
            log(f"  {method:6s} {model.terms:3d} terms ΔE94 D65 mean "
                f"{rows[-1]['de94']['pairs_D65']['mean']:.3f}")
        result["methods"][method] = rows
    if table.values.nbytes < 200 * 2**20:
        result["tensorly"] = tensorly_rows(table, result["methods"]["joint γ=0"], ev, log)
        result["sweep"] = sweep_speed(table)
        log(f"  ALS sweep {result['sweep']['ratio']:.2f}× reading the table twice")
    return result


def memory_figure(log) -> dict:
    out = subprocess.run([sys.executable, "-m", "benchmarks.factor", "--memory-child"],
                         cwd=ROOT, capture_output=True, text=True, check=True)
    figure = json.loads(out.stdout.strip().splitlines()[-1])
    log(f"  peak RSS {figure['peak_rss_bytes'] / 2**20:.0f} MiB for {figure['shape']}")
    return figure


def _fmt(s: dict) -> str:
    return f"{s['mean']:.3f} / {s['p95']:.3f} / {s['max']:.1f}"


def _fmt2(s: dict) -> str:
    return f"{s['mean']:.3f} / {s['p95']:.3f}"


def case_lines(cid: str, case: dict) -> list[str]:
    """One case: its table, the error and time of every method and pack count."""
    lines = [f"## ({cid}) {case['title']}", "",
             f"Table {case['shape']} ({case['table_bytes'] / 2**20:.0f} MiB float32), "
             f"tabulated in {case['tabulate_seconds']:.1f} s; "
             f"spectral basis projection error {case['basis_relative_error']:.1e} (relative).",
             ""]
    head = ("| method | packs | terms | rel. RMS | D65 pairs mean / p95 / max | "
            "FL2 pairs mean / p95 / max | D65 sphere mean / p95 | FL2 sphere mean / p95 | "
            "seconds | bytes |")
    lines += [head, "|" + "---|" * 10]
    floor = case["floor"]
    lines.append(f"| table floor | – | – | – | {_fmt(floor['pairs_D65'])} | "
                 f"{_fmt(floor['pairs_FL2'])} | {_fmt2(floor['sphere_D65'])} | "
                 f"{_fmt2(floor['sphere_FL2'])} | – | {case['table_bytes']} |")
    for method, rows in case["methods"].items():
        for r in rows:
            packs = r.get("packs", r["terms"])
            if r.get("packs_fitted", packs) != packs:
                packs = f"{packs} (fit stopped at {r['packs_fitted']})"
            lines.append(
                f"| {method} | {packs} | {r['terms']} | "
                f"{r['relative_rms']:.2e} | {_fmt(r['de94']['pairs_D65'])} | "
                f"{_fmt(r['de94']['pairs_FL2'])} | {_fmt2(r['de94']['sphere_D65'])} | "
                f"{_fmt2(r['de94']['sphere_FL2'])} | {r['seconds']:.2f} | {r['bytes']} |")
    lines.append("")
    if "tensorly" in case:
        lines += tensorly_lines(case)
    for image in case.get("images", []):
        lines.append(f"![{cid}]({image})")
    lines.append("")
    return lines


def tensorly_lines(case: dict) -> list[str]:
    lines = ["tensorly `parafac` (random init, seed 0, at most 100 iterations, "
             "same float32 table) against our unweighted joint fit (`joint γ=0`, "
             "the same least-squares objective):", "",
             "| rank | tensorly error | tensorly ΔE94 D65 mean | tensorly s | "
             "ours at equal rank: error | s | "
             "ours to reach tensorly's error: packs | s | time ratio |",
             "|---|---|---|---|---|---|---|---|---|"]
    for t in case["tensorly"]:
        reach = t["ours_to_reach"] or {"packs": "–", "seconds": float("nan"),
                                       "time_ratio": float("nan")}
        lines.append(
            f"| {t['rank']} | {t['table_relative_error']:.2e} | "
            f"{t['de94']['pairs_D65']['mean']:.3f} | {t['seconds']:.2f} | "
            f"{t['ours_equal_rank']['error']:.2e} | {t['ours_equal_rank']['seconds']:.2f}"
            f" | {reach['packs']} | {reach['seconds']:.2f} | {reach['time_ratio']:.3f} |")
    s = case["sweep"]
    lines += ["", f"One ALS sweep of a 4-term pack on the full {s['shape']} table: "
              f"{s['sweep_seconds'] * 1e3:.1f} ms; reading the table twice: "
              f"{s['read_twice_seconds'] * 1e3:.1f} ms; ratio {s['ratio']:.2f}.", ""]
    return lines


def write_markdown(results: dict, path: Path) -> None:
    lines = ["# Factor benchmark", "", "## Targets", "", *targets_markdown(targets(results)), "",
             "Printed by `scripts/bench_factor.py` (machine: "
             f"{results['machine']}). ΔE94 per shared/PROTOCOL.md: 20 000 random pairs "
             "(mean / p95 / max) and the sphere protocol (all lit pixels at 0°, 30°, 60°, 80°).",
             "Times are fitting seconds after tabulation (HOSVD, weighting and ALS), cumulative "
             "up to each row; the error bookkeeping of the other rows' snapshots is not counted.",
             ""]
    for cid, case in results["cases"].items():
        lines += case_lines(cid, case)
    mem = results.get("memory")
    if mem:
        lines += ["## Memory", "",
                  f"Factoring a {mem['shape']} float32 table ({mem['tensor_bytes'] / 2**20:.0f} "
                  f"MiB, wavelength mode, 4 packs): peak RSS "
                  f"{mem['peak_rss_bytes'] / 2**20:.0f} MiB for the whole process.", ""]
    lines += [f"![error against time]({path.stem}.png)", ""]
    harness.write_markdown(path, lines)


def targets(results: dict) -> list[dict]:
    """The issue's targets, each with the measured figure and whether it is met."""
    out = []
    for cid, case in results["cases"].items():
        goal = case["target"]
        row = next(r for r in case["methods"]["joint"] if r["packs"] == goal["packs"])
        stats = row["de94"]["pairs_D65"]
        met = stats["mean"] <= goal["mean"] and (goal["p95"] is None or stats["p95"] <= goal["p95"])
        want = f"mean ≤ {goal['mean']}" + (f", p95 ≤ {goal['p95']}" if goal["p95"] else "")
        out.append({"target": f"({cid}) ΔE94 D65 random pairs, {goal['packs']} packs: {want}",
                    "measured": f"mean {stats['mean']:.3f}, p95 {stats['p95']:.3f}",
                    "met": bool(met)})
    b = results["cases"].get("b", {})
    for t in b.get("tensorly", []):
        if t["rank"] == 16 and t["ours_to_reach"]:
            ratio = t["ours_to_reach"]["time_ratio"]
            out.append({"target": "(b) time to reach tensorly's rank-16 error ≤ 1/15 of its time",
                        "measured": f"{ratio:.3f} ({t['ours_to_reach']['seconds']:.2f} s vs "
                                    f"{t['seconds']:.2f} s)", "met": ratio <= 1 / 15})
    if "sweep" in b:
        sw = b["sweep"]
        out.append({"target": "one ALS sweep (4-term pack, 90×180×90×8) ≤ 2× reading it twice",
                    "measured": f"{sw['ratio']:.2f}× ({sw['sweep_seconds'] * 1e3:.1f} ms vs "
                                f"{sw['read_twice_seconds'] * 1e3:.1f} ms)",
                    "met": sw["ratio"] <= 2.0})
    mem = results.get("memory")
    if mem:
        out.append({"target": "peak memory ≤ 1.5 GB factoring 90×180×90×61",
                    "measured": f"{mem['peak_rss_bytes'] / 2**30:.2f} GiB",
                    "met": mem["peak_rss_bytes"] <= 1.5e9})
    return out


def targets_markdown(rows: list[dict]) -> list[str]:
    lines = ["| target | measured | met |", "|---|---|---|"]
    lines += [f"| {r['target']} | {r['measured']} | {'yes' if r['met'] else '**no**'} |"
              for r in rows]
    return lines


def update_readme(rows: list[dict], readme: Path) -> None:
    """Replace the README's benchmark summary block with this run's targets table."""
    marker_start, marker_end = "<!-- BENCH-SUMMARY -->", "<!-- /BENCH-SUMMARY -->"
    text = readme.read_text()
    block = "\n".join([marker_start, "", *targets_markdown(rows), "", marker_end])
    if marker_end in text:
        head, rest = text.split(marker_start, 1)
        text = head + block + rest.split(marker_end, 1)[1]
    else:
        text = text.replace(marker_start, block)
    readme.write_text(text)


def plot(results: dict, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases_ = results["cases"]
    fig, axes = plt.subplots(1, len(cases_), figsize=(5 * len(cases_), 4))
    for ax, (cid, case) in zip(np.atleast_1d(axes), cases_.items()):
        for method, style in (("joint", "o-"), ("joint γ=0", "o:"), ("greedy", "s--"),
                              ("svd", "^:"), ("nd", "v:")):
            rows = case["methods"][method]
            ax.plot([r["seconds"] for r in rows], [r["de94"]["pairs_D65"]["mean"] for r in rows],
                    style, label=method)
        tly = case.get("tensorly", [])
        if tly:
            ax.plot([t["seconds"] for t in tly], [t["de94"]["pairs_D65"]["mean"] for t in tly],
                    "kx", label="tensorly parafac (rank 4, 8, 16)")
        ax.axhline(case["floor"]["pairs_D65"]["mean"], color="grey", lw=0.8, label="table floor")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("fitting seconds (after tabulation)")
        ax.set_ylabel("mean ΔE94, D65, random pairs")
        ax.set_title(f"({cid})", fontsize=10)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def main(argv: list[str] | None = None) -> None:
    parser = harness.parser(__doc__, quick_help="coarse grids (smoke test)",
                            out_help="write bench_factor.md/.json/.png here instead of docs/")
    parser.add_argument("--cases", default="abc")
    parser.add_argument("--memory-child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.memory_child:
        memory_child()
        return
    out = Path(args.out)
    (out / "images").mkdir(parents=True, exist_ok=True)
    log = harness.log
    results = {"machine": f"{os.cpu_count()} cores, numpy {np.__version__}",
               "quick": args.quick, "cases": {}}
    all_cases = cases(args.quick)
    for cid in args.cases:
        results["cases"][cid] = bench_case(cid, all_cases[cid], args.quick, log, out)
    if not args.quick:
        results["memory"] = memory_figure(log)
    stem = harness.output_stem("factor", args.quick)
    harness.write_outputs(out, stem, results, write_markdown)
    if not args.quick and args.cases == "abc":
        update_readme(targets(results), ROOT / "README.md")
    plot(results, out / f"{stem}.png")
    log(f"wrote {out / stem}.md/.json/.png")


if __name__ == "__main__":
    main()
