"""Frame cost of the horizon edge rule (issue 18): the same factor packs drawn with the
"horizon" rule (f·cosθi falls to 0 at θi = 90°) and with the "linear" rule it replaces.

The rule is a uniform (``misc.x``), so both draws run the same compiled variant; the
difference is the horizon scale computed per θi lookup. The benchmark sphere of
:mod:`benchmarks.draw` (about 1.0 M pixels at 1200²), synthetic io_iso packs in the paper's
90×180×90 layout, one light, pre-contracted; timings interleaved L H L H … L
(shared/PROTOCOL.md, "Time and memory"). Texture bytes do not change: the rule stores
nothing.

Writes ``docs/bench_edge_cost.md``/``.json`` (``--quick``: 400², 3 reps).

Usage::

    python -m benchmarks.edge_cost [--quick]
"""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from spectral_materials.blender.brdf.gpu_material import GPUMaterial
from spectral_materials.blender.gpu import batches as mesh_batches, shaders
from spectral_materials.blender.gpu.context import ensure_gpu
from spectral_materials.blender.gpu.display import DisplaySettings

from . import harness
from .draw import Bench, make_lights, sphere_arrays, view_projection
from .draw_baseline import VIEW_ORIGIN
from .synthetic import DISC_FRACTION, synthetic_model

PACKS = (4, 22)


def measure(bench: Bench, packs: int) -> dict:
    """ms/frame of the linear and the horizon rule on the same packs, and their ratio."""
    model = synthetic_model("io_iso", packs)
    lights = make_lights(1)
    materials = {rule: GPUMaterial(replace(model, edge=rule)) for rule in ("linear", "horizon")}
    key = materials["linear"].key(lights, precontract=True, output="DISPLAY")
    shader = shaders.get_shader(key)

    def binder(material):
        texture = material.light_texture(lights, True)
        params = material.params(DisplaySettings(), view_origin=VIEW_ORIGIN,
                                 view_projection=bench.vp)

        def bind():
            material.bind(shader, texture, params)
            return shader
        return bind

    bind_linear, bind_horizon = binder(materials["linear"]), binder(materials["horizon"])
    bench.warm(bind_linear)
    bench.warm(bind_horizon)
    timings = harness.interleave(lambda: bench.seconds_per_frame(bind_horizon),
                                 lambda: bench.seconds_per_frame(bind_linear), bench.reps)
    ratios = timings.ratios()
    return {"layout": "io_iso", "packs": packs, "lights": 1,
            "linear_ms": 1e3 * float(np.median(timings.baseline)),
            "horizon_ms": 1e3 * float(np.median(timings.candidate)),
            "horizon_over_linear": float(np.median(ratios)), "paired": ratios,
            "factor_texture_bytes": {rule: m.nbytes for rule, m in materials.items()}}


def run(args) -> dict:
    started = time.perf_counter()
    ensure_gpu()
    import gpu

    from spectral_materials.blender.gpu.offscreen import Target

    arrays = sphere_arrays()
    (batch,) = mesh_batches.MeshBatches.build(arrays).batches.values()
    vp = view_projection(0.5 / DISC_FRACTION)
    info = harness.gpu_machine()
    rows = []
    with Target(args.size, args.size) as target:
        gpu.state.face_culling_set("BACK")
        try:
            bench = Bench(target, batch, vp, frames=3, reps=args.reps)
            for packs in PACKS:
                row = measure(bench, packs)
                rows.append(row)
                harness.log(f"  io_iso {packs} packs: linear {row['linear_ms']:.1f} ms, horizon "
                            f"{row['horizon_ms']:.1f} ms, ratio {row['horizon_over_linear']:.3f}")
        finally:
            gpu.state.face_culling_set("NONE")
    return {"date": harness.date_stamp(), "command": harness.command_line("edge_cost"),
            "commit": harness.commit_of(), "machine": info, "quick": args.quick,
            "size": args.size, "reps": args.reps, "rows": rows,
            "seconds": time.perf_counter() - started}


def markdown(results: dict) -> list[str]:
    m = results["machine"]
    lines = ["# Frame cost of the horizon edge rule", "",
             f"Printed by `{results['command']}` on {results['date']} at commit "
             f"{results['commit']}: {m['renderer']} ({m['backend']}), {m['cpu_count']} cores, "
             f"{results['size']}² target, {results['reps']} interleaved repetitions of 3 "
             f"frames{' (quick run: a smoke test)' if results['quick'] else ''}. No GPU was "
             "at hand: these are llvmpipe's figures, the GPU figure is still open.", "",
             "| layout | packs | lights | linear ms/frame | horizon ms/frame | horizon / linear "
             "(median of paired ratios) | factor texture bytes (both) |",
             "|---|---|---|---|---|---|---|"]
    for r in results["rows"]:
        lines.append(f"| {r['layout']} | {r['packs']} | {r['lights']} | {r['linear_ms']:.1f} | "
                     f"{r['horizon_ms']:.1f} | {r['horizon_over_linear']:.3f} | "
                     f"{r['factor_texture_bytes']['horizon']:,} |")
    return lines + [""]


def main(argv: list[str] | None = None) -> None:
    parser = harness.parser(__doc__, quick_help="400² target, 3 reps (smoke test)",
                            out_help="write bench_edge_cost.md/.json here, not docs/")
    args = parser.parse_args(argv)
    args.size = 400 if args.quick else 1200
    args.reps = 3 if args.quick else 7
    results = run(args)
    out, stem = Path(args.out), harness.output_stem("edge_cost", args.quick)
    harness.write_json(out / f"{stem}.json", results, indent=1, default=float)
    lines = markdown(results)
    harness.write_markdown(out / f"{stem}.md", lines)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
