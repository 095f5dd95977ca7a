"""docs/bench_gpu_variants.md: the shader choices of ``benchmarks/draw_variants.py`` timed
on a lent GPU, beside llvmpipe's ratios, and the factor-pack draws with today's shaders
against the replay of the shaders before issue 18.

Inputs, all in ``docs/gpu/``:

* ``<gpu>_variants_results.json``: run_gpu.py over an export with the ``variants`` family
  (``export_cases.py --families draw,precision,variants``): each comparison's before and
  after draw, and XYZ twins where the shader's arithmetic changed;
* ``<gpu>_final_shader_draws.json``: the same draws exported before issue 18;
* ``<gpu>_cells_edge.npz``: the measured-cells twin's images (the reference's strided
  subsample) as the GPU and llvmpipe drew it, unpatched (``*_on_edge``) and with
  ``patch_cases.py --set cells_edge`` (``*_off_edge``).

Usage::

    python -m benchmarks.gpu_replay.variants_report docs/gpu/h200_variants_results.json
"""

from __future__ import annotations

import argparse
import json
import re
from pathlib import Path

import numpy as np

from benchmarks.draw_variants import CASES, LABELS

from . import report
from .run_gpu import BAD_REL, REL_FLOOR

VARIANT_PREFIX = "variant_"


def _ms(case: dict) -> float:
    return case["runs"]["blender"]["draw_ms"]["median"]


def variant_stem(comparison: str, packs: int, lights: int) -> str:
    """export_cases.export_variants's name of one comparison's draws, ASCII (the device
    machine returns no file whose name has other characters: "Oren–Nayar" → "Oren_Nayar")."""
    slug = re.sub(r"[^A-Za-z0-9]+", "_", comparison).strip("_")
    return f"{VARIANT_PREFIX}{slug}_p{packs}_l{lights}"


def variant_table(cases: dict, llvmpipe: dict) -> list[str]:
    """Before and after of every comparison on the GPU, with llvmpipe's paired ratio."""
    rows = {(r["comparison"], r["packs"], r["lights"]): r for r in llvmpipe.get("rows", [])}
    lines = ["| comparison | io_iso packs | lights | before | ms | after | ms | after / before "
             "(GPU) | after / before (llvmpipe) |", "|---|---|---|---|---|---|---|---|---|"]
    for comparison, packs, lights in CASES:
        stem = variant_stem(comparison, packs, lights)
        before, after = cases.get(f"{stem}_before"), cases.get(f"{stem}_after")
        if not (_timed(before) and _timed(after)):
            continue
        soft = rows.get((comparison, packs, lights))
        soft_ratio = f"{soft['after_over_before']:.3f}" if soft else "–"
        names = LABELS[comparison]
        lines.append(f"| {comparison} | {packs} | {lights} | {names[0]} | {_ms(before):.3f} | "
                     f"{names[1]} | {_ms(after):.3f} | {_ms(after) / _ms(before):.3f} | "
                     f"{soft_ratio} |")
    return lines


def _grid_table(pairs: dict) -> list[str]:
    """Ratios by (packs, lights): packs in rows, lights in columns."""
    packs = sorted({k[0] for k in pairs})
    lights = sorted({k[1] for k in pairs})
    lines = ["| io_iso packs | " + " | ".join(f"{n} lights" for n in lights) + " |",
             "|---|" + "---|" * len(lights)]
    for n in packs:
        cells = [f"{pairs[(n, m)]:.3f}" if (n, m) in pairs else "–" for m in lights]
        lines.append(f"| {n} | " + " | ".join(cells) + " |")
    return lines


def _timed(case: dict | None) -> bool:
    return case is not None and "draw_ms" in case["runs"].get("blender", {})


def light_loop_table(cases: dict) -> list[str]:
    """The hoisted light loop (view axes once per pack) over light by light, by packs
    (rows) and lights (columns), from every ``variant_light_loop_*`` pair replayed."""
    pairs = {}
    for name, case in cases.items():
        if name.startswith("variant_light_loop_") and name.endswith("_after"):
            before = cases.get(name[:-len("after")] + "before")
            if _timed(case) and _timed(before):
                p = case["params"]
                pairs[(p["packs"], p["lights"])] = _ms(case) / _ms(before)
    return _grid_table(pairs)


def clamp_cost_table(cases: dict, unclamped: dict, side: str) -> list[str]:
    """Each light-loop draw of ``side`` ("before": light by light, "after": packs
    outermost) with each light's XYZ clamped, over the same draw without the clamp."""
    pairs = {}
    for name, case in cases.items():
        if name.startswith("variant_light_loop_") and name.endswith(f"_{side}"):
            old = unclamped.get(name)
            if _timed(case) and _timed(old):
                p = case["params"]
                pairs[(p["packs"], p["lights"])] = _ms(case) / _ms(old)
    return _grid_table(pairs)


def draw_table(cases: dict, earlier: dict, label: str = "now") -> list[str]:
    """The factor-pack draws (draw family) of ``cases`` (``label``) against the replay
    before issue 18."""
    before = {c["name"]: c for c in earlier["cases"]}
    lines = [f"| case | ms / frame, before issue 18 | ms / frame, {label} | {label} / before "
             f"| × baseline, {label} |", "|---|---|---|---|---|"]
    for name, case in cases.items():
        if not name.startswith("draw_") or name not in before or not case.get("ratio_to") \
                or not _timed(case):
            continue
        base = cases[case["ratio_to"]]
        lines.append(f"| `{name}` | {_ms(before[name]):.3f} | {_ms(case):.3f} | "
                     f"{_ms(case) / _ms(before[name]):.3f} | {_ms(case) / _ms(base):.2f} |")
    return lines


def agreement_table(cases: dict) -> list[str]:
    """The variants' XYZ twins against the project's llvmpipe read-back (report.py's
    table): a patched copy (``__`` in its name, patch_cases.py) is drawn against the
    unpatched image, and left out."""
    return report.agreement_table({
        name: case for name, case in cases.items()
        if case.get("group") == "variants-xyz" and "__" not in name and _timed(case)})


def image_agreement(gpu: np.ndarray, reference: np.ndarray) -> dict:
    """run_gpu.py's per-pixel relative difference over the covered pixels: max over RGB
    |gpu − reference| / max(max over RGB |reference|, 1e-4)."""
    covered = reference[..., 3] > 0
    rel = (np.abs(gpu[..., :3] - reference[..., :3]).max(axis=-1)
           / np.maximum(np.abs(reference[..., :3]).max(axis=-1), REL_FLOOR))[covered]
    return {"pixels": int(covered.sum()), "over": int((rel > BAD_REL).sum()),
            "over_1e-2": int((rel > 1e-2).sum()), "median": float(np.median(rel)),
            "p99": float(np.percentile(rel, 99))}


def cells_edge_table(images: dict) -> list[str]:
    """The measured-cells twin's agreement as drawn and with θd's index off the edge."""
    lines = ["| θd's cell index | pixels compared | > 1e-3 | > 1e-2 | median rel | p99 rel |",
             "|---|---|---|---|---|---|"]
    for key, label in (("on_edge", "as drawn (θd = 5° on a cell edge)"),
                       ("off_edge", "+ 0.25 cell, both renderers")):
        a = image_agreement(images[f"h200_{key}"], images[f"llvmpipe_{key}"])
        lines.append(f"| {label} | {a['pixels']} | {a['over']} | {a['over_1e-2']} | "
                     f"{a['median']:.1e} | {a['p99']:.1e} |")
    return lines


def markdown(results: dict, source: str, llvmpipe: dict, earlier: dict | None,
             images: dict | None, unclamped: dict | None = None) -> list[str]:
    """The page's lines from the replay ``results`` and what is beside it: ``earlier``, the
    draws before issue 18; ``unclamped``, a fuller replay of the shaders before each
    light's clamp at 0 and the light-loop rule."""
    cases = {c["name"]: c for c in results["cases"]}
    m, e = results["machine"], results["export"]
    early = str(earlier["export"].get("project_commit"))[:7] if earlier else ""
    old = {c["name"]: c for c in unclamped["cases"]} if unclamped else {}
    old_commit = str(unclamped["export"].get("project_commit"))[:7] if unclamped else ""
    skipped = [c["name"] for c in results["cases"] if not _timed(c)]
    return [
        "# Shader choices on a GPU", "",
        f"Printed by `python -m benchmarks.gpu_replay.variants_report {source}` from a replay "
        f"by `benchmarks/gpu_replay/run_gpu.py` (`device_run.sh`) on **{m['gl_renderer']}** "
        f"({m['gl_version']}), started {results['started']}, of the draws exported at commit "
        f"{str(e.get('project_commit'))[:7]} + the working tree (Blender "
        f"{e['machine']['blender']}, {e['machine']['renderer']}). Times are GL timer queries "
        f"of the draw alone, median of {results['settings']['frames']} frames, on the draw "
        "benchmark's sphere (1200², about 1.0 M pixels), synthetic io_iso packs "
        "(90×180×90), pre-contracted.", "",
        *([f"The run's time budget left {len(skipped)} draws out (the draw family and the "
           f"XYZ twins); the tables that need them read a fuller replay of commit "
           f"{old_commit}'s shaders, before each light's clamp at 0 and the light-loop rule "
           f"(`docs/gpu/{Path(source).name.replace('_results', '_unclamped_results')}`).",
           ""] if skipped else []),
        "## Each choice against the path it replaced", "",
        "`benchmarks/draw_variants.py`'s comparisons (its docstring says what each is). "
        "llvmpipe's column is `docs/bench_draw_variants.json` (2 CPU cores, commit "
        f"{str(llvmpipe.get('commit'))[:7]}, each light clamped at 0, both loop orders "
        "forced); comparisons added since this replay are on that page alone.", "",
        *variant_table(cases, llvmpipe), "",
        "### The light loop's order, by packs and lights", "",
        "Packs outermost (the view's axes once per pack for all lights) over light by "
        "light, same run; `shaders.shares_view_axes` takes the first from 2·lights + 4 "
        "packs with at most 4 lights:", "", *light_loop_table(cases), "",
        *(["### What each light's clamp at 0 costs", "",
           f"Each light-loop draw over the same draw of commit {old_commit} (no clamp), "
           "both replays on this kind of GPU. Light by light:", "",
           *clamp_cost_table(cases, old, "before"), "",
           "Packs outermost (each light's sum kept apart for its clamp):", "",
           *clamp_cost_table(cases, old, "after"), ""] if old else []),
        *(["## The factor-pack draws before and after issue 18", "",
           f"The same draws as exported at commit {early} (the last replay before issue 18: "
           "`docs/gpu/h200_final_shader_draws.json`), on the same kind of GPU, against "
           f"commit {old_commit}'s (before the clamp and the rule; 4 packs with 2–8 lights "
           "now draw light by light: the light-loop table).", "",
           *draw_table(old, earlier, old_commit), ""] if earlier and old else []),
        "## Agreement of the changed arithmetic with llvmpipe", "",
        f"XYZ twins of the edge-rule, lobe and cells draws (commit {old_commit}'s shaders), "
        "per pixel max over RGB |GPU − llvmpipe| / max(|llvmpipe|, 1e-4); *unexplained* "
        "as in `docs/bench_gpu.md`.", "", *agreement_table(old or cases), "",
        *(["### Measured cells: a tie on a cell edge", "",
           "The draw benchmark's sun (light 0 of 4) sits 10° off an orthographic view, so "
           "θd = 5° at every pixel: exactly the edge between two of MERL's θd cells. Each "
           "renderer's rounding picks its own side, pixel by pixel (the twin's FAIL above). "
           "Moving θd's index a quarter cell off the edge in both renderers' shaders "
           "(`patch_cases.py --set cells_edge`) leaves only the other cell edges "
           "(`docs/gpu/h200_cells_edge.npz`, today's shaders, the reference's strided "
           "subsample):", "",
           *cells_edge_table(images), ""] if images else [])]


def page(results_path: str) -> str:
    """docs/bench_gpu_variants.md's text for ``results_path`` and the files beside it."""
    folder = Path(results_path).parent
    results = json.loads(Path(results_path).read_text())
    gpu = Path(results_path).name.split("_")[0]
    llvmpipe_path = folder.parent / "bench_draw_variants.json"
    llvmpipe = json.loads(llvmpipe_path.read_text()) if llvmpipe_path.exists() else {}
    earlier_path = folder / f"{gpu}_final_shader_draws.json"
    earlier = json.loads(earlier_path.read_text()) if earlier_path.exists() else None
    npz_path = folder / f"{gpu}_cells_edge.npz"
    images = dict(np.load(npz_path)) if npz_path.exists() else None
    unclamped_path = folder / f"{gpu}_variants_unclamped_results.json"
    unclamped = json.loads(unclamped_path.read_text()) if unclamped_path.exists() else None
    return "\n".join(markdown(results, results_path, llvmpipe, earlier, images, unclamped))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results", help="<gpu>_variants_results.json")
    parser.add_argument("--out", default="docs", help="folder for bench_gpu_variants.md")
    args = parser.parse_args(argv)
    text = page(args.results)
    (Path(args.out) / "bench_gpu_variants.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
