"""Factor precision (issue 19): the fast draw paths' 16-bit factors against the exact path.

Each precision of ``core.brdf.filtered_factors.FACTOR_PRECISIONS`` other than
``"exact"`` is measured in two ways against the exact path (float32 factors, two
``texelFetch`` and a mix per axis and pack):

* **Colour error**: ΔE94 mean / p95 / max over the protocol's 20 000 random pairs,
  under D65 and FL11. The fast path is its float64 mirror with the hardware filter's
  8-bit weights (``drawn_model``), and the reference is the exact path's XYZ, not the
  BRDF's. The materials are the demo materials at the demo's settings and the measured
  AS32 (MERL) case at the defaults, as ``benchmarks.colour_targets`` factors them.
* **Frame time**: the draw benchmark's sphere (1.0 M px at 1200²), synthetic io_iso packs
  90×180×90, pre-contracted, one light. Timings interleaved B C B C … B, with the
  exact path as B. Here on llvmpipe; a texture unit's are in docs/bench_gpu.md
  (benchmarks/gpu_replay exports these draws).

Also printed: the bytes and fetches per axis and pack, counted from
glsl/brdf/factor_packs.glsl (:func:`fetch_counts`).

Writes ``docs/bench_factor_precision.md``/``.json`` (``--quick``: 12 θ cells, 2 packs,
400², 3 reps).

Usage::

    python -m benchmarks.factor_precision [--quick]
"""

from __future__ import annotations

import re
import time

import numpy as np

from spectral_materials.blender.brdf.gpu_material import GPUMaterial
from spectral_materials.blender.gpu import shaders
from spectral_materials.blender.gpu.context import ensure_gpu
from spectral_materials.core.brdf import metrics
from spectral_materials.core.brdf.filtered_factors import (
    FACTOR_PRECISIONS,
    PRECISION_TEXELS,
    TEXTURE_FORMATS,
    drawn_model,
)
from spectral_materials.core.brdf.job import factor_material

from . import colour_targets as targets, harness
from .draw import Bench, bench_target, make_lights, sphere_batch, view_projection
from .draw_variants import material_binder
from .synthetic import DISC_FRACTION, synthetic_model

FAST = tuple(p for p in FACTOR_PRECISIONS if p != "exact")
#: (packs, lights) timed.
DRAW_CASES = ((4, 1), (22, 1), (22, 4))
TEXEL_BYTES = {"float32": 16, **{enc: 8 for enc in TEXTURE_FORMATS}}


def fetch_counts() -> list[dict]:
    """Per axis and pack: fetches, bytes fetched and shader lane operations, per precision.

    The fetch sites are counted in glsl/brdf/factor_packs.glsl's ``sm_pack_product_axes``
    (``texelFetch`` in the shader-interpolated branch, ``textureLod`` in the filtered one);
    lane operations: a mix4 is 4 sub + 4 FMA, the product 4 mul, unorm16's decode 4 FMA.
    """
    source = shaders.glsl_source("brdf/factor_packs.glsl")
    body = source[source.index("vec4 sm_pack_product_axes"):]
    body = body[: body.index("\n}")]
    fetched = len(re.findall(r"texelFetch\(\s*factor_tex", body))
    filtered = len(re.findall(r"textureLod\(\s*factor_tex", body))
    if (fetched, filtered) != (2, 1):
        # The lane counts below are written for these sites: a changed shader must be
        # recounted, not published with them.
        raise RuntimeError(f"factor_packs.glsl has {fetched} texelFetch and {filtered} "
                           "textureLod sites on factor_tex; fetch_counts assumes 2 and 1")
    rows = []
    for precision in FACTOR_PRECISIONS:
        encoding, hardware = PRECISION_TEXELS.get(precision, ("float32", False))
        fetches = filtered if hardware else fetched
        lanes = (0 if hardware else 8) + 4 + (4 if encoding == "unorm16" else 0)
        rows.append({"precision": precision, "format": TEXTURE_FORMATS.get(encoding, "RGBA32F"),
                     "fetches": fetches, "bytes": fetches * TEXEL_BYTES[encoding],
                     "lane_ops": lanes, "weights": "8-bit (texture unit)" if hardware
                     else "float (shader)"})
    return rows


def colour_rows(quick: bool) -> list[dict]:
    """ΔE94 of each fast precision against the exact path, per material and illuminant."""
    cases, _ = targets.build_cases()
    pairs = targets.Pairs()
    demo_cases = [c for c in cases if c.demo_packs is not None]
    demo_choice = targets.choose_basis(demo_cases, targets.DEMO_LIGHTS)
    rows = []
    for case in cases:
        demo = case.demo_packs is not None
        theta = targets.QUICK_THETA_CELLS if quick else (
            targets.DEMO_THETA_CELLS if demo else targets.DEFAULT_THETA_CELLS)
        packs = case.demo_packs if demo else targets.DEFAULT_PACKS
        packs = min(packs, targets.QUICK_MAX_PACKS) if quick else packs
        choice = demo_choice if demo else targets.choose_basis([case], targets.CASE_LIGHTS)
        options = targets.addon_options(case, theta, packs)
        harness.log(f"{case.name}: {options.parameterization} {options.resolution}, "
                    f"{packs} packs")
        model = factor_material(case.brdf, choice.basis, options).model
        # The stored layout: Automatic may put packs beside a lobe on io_iso.
        row = {"case": case.name, "settings": "demo" if demo else "default",
               "parameterization": model.parameterization,
               "resolution": list(model.resolution), "packs": model.packs,
               "lobe": model.lobe is not None, "errors": {},
               "bytes": {"exact": GPUMaterial(model).nbytes}}
        exact = {ill: model.xyz(pairs.wi, pairs.wo, ill) for ill in targets.ILLUMINANTS}
        for precision in FAST:
            fast = drawn_model(model, precision)
            row["errors"][precision] = {
                ill: metrics.delta_e94_stats(exact[ill], fast.xyz(pairs.wi, pairs.wo, ill), ill)
                for ill in targets.ILLUMINANTS}
            row["bytes"][precision] = GPUMaterial(model, precision).nbytes
        rows.append(row)
    return rows


def _binder(bench: Bench, material: GPUMaterial, lights):
    key = material.key(lights, precontract=True, output="DISPLAY")
    return material_binder(bench, material, key, material.light_texture(lights, True))


def draw_rows(size: int, reps: int) -> list[dict]:
    rows = []
    vp = view_projection(0.5 / DISC_FRACTION)
    with bench_target(size, sphere_batch(), vp, 3, reps) as bench:
        for packs, n_lights in DRAW_CASES:
            lights = make_lights(n_lights)
            model = synthetic_model("io_iso", packs)
            exact = _binder(bench, GPUMaterial(model), lights)
            bench.warm(exact)
            for precision in FAST:
                fast = _binder(bench, GPUMaterial(model, precision), lights)
                bench.warm(fast)
                timings = harness.interleave(lambda f=fast: bench.seconds_per_frame(f),
                                             lambda e=exact: bench.seconds_per_frame(e), reps)
                rows.append({"packs": packs, "lights": n_lights, "precision": precision,
                             "exact_ms": 1e3 * float(np.median(timings.baseline)),
                             "fast_ms": 1e3 * float(np.median(timings.candidate)),
                             "ratio": float(np.median(timings.ratios()))})
                harness.log(f"  {packs} packs, {n_lights} lights, {precision}: "
                            f"{rows[-1]['ratio']:.3f} × exact")
    return rows


def run(args) -> dict:
    started = time.perf_counter()
    ensure_gpu()
    return {"date": harness.date_stamp(), "command": harness.command_line("factor_precision"),
            "commit": harness.commit_of(), "machine": harness.gpu_machine(),
            "quick": args.quick, "size": args.size, "reps": args.reps,
            "counts": fetch_counts(), "colour": colour_rows(args.quick),
            "draw": draw_rows(args.size, args.reps), "seconds": time.perf_counter() - started}


def markdown(r: dict) -> list[str]:
    m = r["machine"]
    lines = ["# Factor precision: the fast draw paths against the exact one", "",
             f"Printed by `{r['command']}` on {r['date']} at commit {r['commit']}: "
             f"{m['renderer']} ({m['backend']}), {m['cpu_count']} cores"
             f"{' (quick run: a smoke test)' if r['quick'] else ''}. Precisions: `exact` "
             "(RGBA32F, two texelFetch and a mix per axis and pack, today's default), "
             "`unorm16` (16-bit padded rows, the same two fetches and mix), "
             "`unorm16_filtered` and `half_filtered` (one filtered fetch; the texture unit "
             "interpolates with 8-bit weights). core/brdf/filtered_factors.py says why.", "",
             "## Per axis and pack, from glsl/brdf/factor_packs.glsl", "",
             "| precision | texture | fetches | bytes fetched | lane ops | weights |",
             "|---|---|---|---|---|---|"]
    for c in r["counts"]:
        lines.append(f"| {c['precision']} | {c['format']} | {c['fetches']} | {c['bytes']} | "
                     f"{c['lane_ops']} | {c['weights']} |")
    ills = sorted({ill for row in r["colour"] for e in row["errors"].values() for ill in e})
    lines += ["", "## Colour error against the exact path (ΔE94 mean / p95 / max, protocol "
              "pairs)", "",
              "The issue's bound is 0.05. The filtered paths are modelled with 8-bit "
              "weights, as a texture unit filters (llvmpipe filters with float weights and "
              "would show less).", "",
              "| material | settings | precision | "
              + " | ".join(ills) + " | texture bytes (× exact) |",
              "|---|---|---|" + "---|" * len(ills) + "---|"]
    for row in r["colour"]:
        for precision, by_ill in row["errors"].items():
            cells = " | ".join(f"{by_ill[i]['mean']:.4f} / {by_ill[i]['p95']:.4f} / "
                               f"{by_ill[i]['max']:.3f}" for i in ills)
            ratio = row["bytes"][precision] / row["bytes"]["exact"]
            lines.append(f"| {row['case']} | {row['settings']}, {row['parameterization']} "
                         f"{'×'.join(map(str, row['resolution']))}, {row['packs']} packs | "
                         f"{precision} | {cells} | {row['bytes'][precision]:,} "
                         f"({ratio:.2f}) |")
    lines += ["", f"## Frame time on this machine ({r['size']}², {r['reps']} interleaved "
              "repetitions of 3 frames; on a GPU, docs/bench_gpu.md)", "",
              "| packs | lights | precision | exact ms | fast ms | fast / exact (median of "
              "paired ratios) |", "|---|---|---|---|---|---|"]
    for d in r["draw"]:
        lines.append(f"| {d['packs']} | {d['lights']} | {d['precision']} | "
                     f"{d['exact_ms']:.1f} | {d['fast_ms']:.1f} | {d['ratio']:.3f} |")
    return lines + [""]


def main(argv: list[str] | None = None) -> None:
    parser = harness.parser(__doc__, quick_help="12 θ cells, 2 packs, 400², 3 reps",
                            out_help="write bench_factor_precision.md/.json here, not docs/")
    args = parser.parse_args(argv)
    args.size = 400 if args.quick else 1200
    args.reps = 3 if args.quick else 7
    results = run(args)
    harness.publish(args.out, "factor_precision", args.quick, results, markdown(results))


if __name__ == "__main__":
    main()
