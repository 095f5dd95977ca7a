"""Frame cost of shader choices, each against the path it replaced, on the same packs.

* **Edge rule** (issue 18): the "horizon" rule (f·cosθi falls to 0 at θi = 90°) against the
  "linear" rule. The rule is a uniform (``misc.x``): both draws run the same compiled
  variant, and the difference is the horizon scale computed per θi lookup.
* **Light rows** (issue 19): the light rows (header, then the pre-contracted weights
  K = Sᵀ Ĩ, 3 vec4 per pack) read from the uniform buffer ``sm_lights`` against the same
  rows fetched from the light texture (glsl/common/light_rows.glsl). Two variants.
* **Light loop** (issue 19): with several lights, packs outermost and the view's axes
  (θo for io_iso) fetched once per pack for all lights (:func:`hoisted_shader`, whatever
  ``shaders.shares_view_axes`` would choose), against the light-by-light loop (the same
  variant with that branch compiled out, :func:`light_by_light_shader`).
* **Specular lobe** (issue 18): the same packs with an analytic Ashikhmin–Shirley lobe
  beside them (``core/brdf/lobe.py``, ``glsl/brdf/specular_lobe.glsl``: closed-form ALU
  per light and two more light-row texels) against the packs alone.
* **Measured cells** (issue 18): packs and lobe drawn in MERL's 90×90×180 cells
  (``core/brdf/measured_cells.py``, ``glsl/brdf/measured_cells.glsl``: Rusinkiewicz's
  angles, the cell's centre and the inverse per light, and the light-by-light loop)
  against the same packs and lobe drawn smooth.
* **Texel blend** (issue 19): BTF texels blended across their edges
  (``render.EDGE_BLEND``) against nearest texels (the same variant compiled with a band
  of 0), on :mod:`benchmarks.btf`'s corduroy fits and UV sphere (800², 4 repeats).

The benchmark sphere of :mod:`benchmarks.draw` (about 1.0 M pixels at 1200²), synthetic
io_iso packs in the paper's 90×180×90 layout, pre-contracted; timings interleaved
B C B C … B (shared/PROTOCOL.md, "Time and memory"). Neither choice changes the factor
texture; the light rows are the same bytes in either place.

Writes ``docs/bench_draw_variants.md``/``.json`` (``--quick``: 400², 3 reps).

Usage::

    python -m benchmarks.draw_variants [--quick]
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from spectral_materials.blender.brdf.gpu_material import GPUMaterial
from spectral_materials.blender.gpu import shaders
from spectral_materials.blender.gpu.context import ensure_gpu
from spectral_materials.blender.gpu.display import DisplaySettings
from spectral_materials.blender.gpu.textures import float_texture
from spectral_materials.core.brdf.lobe import SpecularLobe
from spectral_materials.core.brdf.measured_cells import MERL_SHAPE
from spectral_materials.core.brdf.shading import light_texels

from . import harness
from .draw import Bench, bench_target, make_lights, sphere_batch, view_projection
from .draw_baseline import VIEW_ORIGIN
from .synthetic import DISC_FRACTION, synthetic_model

if TYPE_CHECKING:
    import gpu

#: (comparison, packs, lights) measured.
CASES = (("edge rule", 4, 1), ("edge rule", 22, 1),
         ("light rows", 4, 1), ("light rows", 22, 1), ("light rows", 4, 4),
         ("light loop", 4, 4), ("light loop", 22, 4), ("light loop", 4, 8),
         ("specular lobe", 4, 1), ("specular lobe", 4, 4),
         ("Oren–Nayar term", 4, 1), ("Oren–Nayar term", 4, 4),
         ("measured cells", 4, 1), ("measured cells", 4, 4))
#: BTF cases: (comparison, reflectance-field kind, lights), on their own target.
BTF_CASES = (("texel blend", "RFP", 1), ("texel blend", "RFNL", 1), ("texel blend", "RFNL", 4))
LABELS = {"edge rule": ("linear", "horizon"), "light rows": ("texture", "uniform buffer"),
          "light loop": ("light by light", "view axes once per pack"),
          "specular lobe": ("packs alone", "packs + lobe"),
          "Oren–Nayar term": ("packs alone", "packs + Oren–Nayar term"),
          "measured cells": ("packs + lobe, smooth", "packs + lobe in MERL cells"),
          "texel blend": ("nearest texel", "blended edges")}
#: The branch of glsl/brdf/surface_frag.glsl that draws every light per pack, up to
#: the rule choosing it for the variant (shaders.shares_view_axes).
HOISTED_BRANCH = "#  if SM_PRECONTRACT && SM_SHARE_VIEW"


def _loop_shader(key: shaders.ShaderKey, condition: str) -> gpu.types.GPUShader:
    import gpu

    source = shaders.fragment_source()
    if HOISTED_BRANCH not in source:
        raise ValueError("glsl/brdf/surface_frag.glsl has no per-pack light loop any more")
    patched = source.replace(HOISTED_BRANCH, condition)
    return gpu.shader.create_from_info(shaders.create_info(key, fragment=patched))


def light_by_light_shader(key: shaders.ShaderKey) -> gpu.types.GPUShader:
    """The variant ``key`` with the per-pack light loop compiled out: every light through
    its own pack loop, as before issue 19."""
    return _loop_shader(key, "#  if 0")


def hoisted_shader(key: shaders.ShaderKey) -> gpu.types.GPUShader:
    """The variant ``key`` with the per-pack light loop whatever the pack count (the
    rule takes it only from 2·lights + 4 packs)."""
    return _loop_shader(key, "#  if SM_PRECONTRACT")


def material_binder(bench: Bench, material: GPUMaterial, key, light_rows, shader=None):
    """A bind function drawing ``material`` with variant ``key`` (or ``shader``) and these
    light rows on the benchmark's target."""
    shader = shader or shaders.get_shader(key)
    params = material.params(DisplaySettings(), view_origin=VIEW_ORIGIN,
                             view_projection=bench.vp)

    def bind():
        material.bind(shader, light_rows, params)
        return shader
    return bind


def binders(bench: Bench, comparison: str, packs: int, n_lights: int,
            output: str = "DISPLAY"):
    """(before, after) bind functions of one comparison; ``output="XYZ"`` draws linear XYZ,
    which the display's tone map does not clip (the GPU replay's correctness twins)."""
    lights = make_lights(n_lights)
    model = synthetic_model("io_iso", packs)
    if comparison == "edge rule":
        out = []
        for rule in LABELS[comparison]:
            material = GPUMaterial(replace(model, edge=rule))
            key = material.key(lights, precontract=True, output=output)
            out.append(material_binder(bench, material, key, material.light_texture(lights, True)))
        return out
    if comparison in ("specular lobe", "Oren–Nayar term", "measured cells"):
        lobe = benchmark_lobe(model.spectral_size, "oren_nayar" if comparison.startswith(
            "Oren") else "ashikhmin_shirley")
        variants = ([replace(model, lobe=lobe), replace(model, lobe=lobe, cells=MERL_SHAPE)]
                    if comparison == "measured cells" else
                    [replace(model, lobe=None), replace(model, lobe=lobe)])
        out = []
        for variant in variants:
            material = GPUMaterial(variant)
            key = material.key(lights, precontract=True, output=output)
            out.append(material_binder(bench, material, key, material.light_texture(lights, True)))
        return out
    material = GPUMaterial(model)
    key = material.key(lights, precontract=True, output=output)
    if comparison == "light loop":
        rows = material.light_texture(lights, True)
        return (material_binder(bench, material, key, rows, light_by_light_shader(key)),
                material_binder(bench, material, key, rows, hoisted_shader(key)))
    if not key.light_stride:
        raise ValueError(f"{packs} packs × {n_lights} lights do not fit the uniform buffer")
    texture = float_texture(light_texels(model, lights, precontract=True))
    return (material_binder(bench, material, replace(key, light_stride=0), texture),
            material_binder(bench, material, key, material.light_texture(lights, True)))


def benchmark_lobe(spectral_size: int, family: str = "ashikhmin_shirley") -> SpecularLobe:
    """An Orange-gloss-like lobe (nu = nv = 32), or a Red-clay-like Oren–Nayar term, with
    positive spectra: the cost does not depend on the values."""
    spectral = np.full((spectral_size, 2), 0.05, dtype=np.float32)
    if family == "oren_nayar":
        spectral[:, 1] = 0.0
        return SpecularLobe(family, 0.0, 0.0, spectral)
    spectral[:, 1] = 1.0
    return SpecularLobe(family, 32.0, 32.0, spectral)


def btf_binders(fits: dict, data, kind: str, n_lights: int, vp):
    """(nearest, blended) bind functions of one BTF fit: the same resource, its variant
    compiled with a blend band of 0 (nearest texels only) and with its own."""
    from .btf import btf_binder, resource_binder

    lights = make_lights(n_lights)
    resource, blended = btf_binder(fits[kind], data, lights, vp)
    return resource_binder(resource, lights, vp, edge=0.0), blended


def measure(bench: Bench, comparison: str, packs, n_lights: int, pair=None) -> dict:
    before, after = pair or binders(bench, comparison, packs, n_lights)
    bench.warm(before)
    bench.warm(after)
    timings = harness.interleave(lambda: bench.seconds_per_frame(after),
                                 lambda: bench.seconds_per_frame(before), bench.reps)
    ratios = timings.ratios()
    names = LABELS[comparison]
    what = f"BTF {packs}" if comparison == "texel blend" else f"io_iso, {packs} packs"
    return {"comparison": comparison, "case": what, "packs": packs, "lights": n_lights,
            "before": names[0], "after": names[1],
            "before_ms": 1e3 * float(np.median(timings.baseline)),
            "after_ms": 1e3 * float(np.median(timings.candidate)),
            "after_over_before": float(np.median(ratios)), "paired": ratios}


def run(args) -> dict:
    started = time.perf_counter()
    ensure_gpu()
    info = harness.gpu_machine()
    rows = []
    vp = view_projection(0.5 / DISC_FRACTION)
    with bench_target(args.size, sphere_batch(), vp, 3, args.reps) as bench:
        for comparison, packs, n_lights in CASES:
            rows.append(measure(bench, comparison, packs, n_lights))
            _log(rows[-1])
    rows += btf_rows(args)
    return {"date": harness.date_stamp(), "command": harness.command_line("draw_variants"),
            "commit": harness.commit_of(), "machine": info, "quick": args.quick,
            "size": args.size, "reps": args.reps, "rows": rows,
            "seconds": time.perf_counter() - started}


def _log(row: dict) -> None:
    harness.log(f"  {row['comparison']}: {row['case']}, {row['lights']} lights: "
                f"{row['before']} {row['before_ms']:.1f} ms, {row['after']} "
                f"{row['after_ms']:.1f} ms, ratio {row['after_over_before']:.3f}")


def btf_rows(args) -> list[dict]:
    """The texel-blend comparison on benchmarks.btf's corduroy fits and UV sphere."""
    from spectral_materials.core.btf import fit as btf_fit, generate as btf_generate

    from .btf import uv_sphere_batch

    data = btf_generate.generate_btf("corduroy", texels=16)
    fits = {"RFP": btf_fit.fit_rfp(data), "RFNL": btf_fit.fit_rfnl(data, lobes=2)}
    size = 800 if not args.quick else 400
    vp = view_projection(1.0)
    rows = []
    with bench_target(size, uv_sphere_batch(), vp, 3, args.reps) as bench:
        for comparison, kind, n_lights in BTF_CASES:
            pair = btf_binders(fits, data, kind, n_lights, vp)
            rows.append(measure(bench, comparison, kind, n_lights, pair))
            _log(rows[-1])
    return rows


def markdown(results: dict) -> list[str]:
    m = results["machine"]
    lines = ["# Frame cost of shader choices, against the paths they replaced", "",
             f"Printed by `{results['command']}` on {results['date']} at commit "
             f"{results['commit']}: {m['renderer']} ({m['backend']}), {m['cpu_count']} cores, "
             f"{results['size']}² target, {results['reps']} interleaved repetitions of 3 "
             f"frames{' (quick run: a smoke test)' if results['quick'] else ''}. No GPU was "
             "at hand: these are llvmpipe's figures; on a GPU they are still open "
             "(llvmpipe's texel fetches are not a texture unit's).", "",
             "*Edge rule*: the horizon rule against linear extrapolation (issue 18), one "
             "compiled variant. *Light rows*: the light rows from the uniform buffer "
             "`sm_lights` against the light texture (issue 19). *Light loop*: with several "
             "lights, packs outermost and θo's factors fetched once per pack for all lights, "
             "against the light-by-light loop (issue 19). *Specular lobe*: the same packs "
             "with an analytic Ashikhmin–Shirley lobe beside them (issue 18). *Oren–Nayar "
             "term*: the same packs with Oren–Nayar's back-scatter term beside them, the "
             "lobe family rough diffuse materials take (issue 18). *Measured cells*: "
             "packs and lobe drawn in MERL's 90×90×180 cells against the same drawn smooth "
             "(issue 18). These six: "
             "io_iso 90×180×90, "
             "pre-contracted, synthetic packs, on the draw benchmark's sphere. *Texel "
             "blend*: BTF texels blended within 1/16 texel of their edges against nearest "
             "texels (issue 19), corduroy fits (16² texels, 4 repeats over the UVs) on an 800² "
             "UV sphere.", "",
             "| comparison | case | lights | before | ms/frame | after | ms/frame | after / "
             "before (median of paired ratios) |",
             "|---|---|---|---|---|---|---|---|"]
    for r in results["rows"]:
        lines.append(f"| {r['comparison']} | {r['case']} | {r['lights']} | {r['before']} | "
                     f"{r['before_ms']:.1f} | {r['after']} | {r['after_ms']:.1f} | "
                     f"{r['after_over_before']:.3f} |")
    return lines + [""]


def main(argv: list[str] | None = None) -> None:
    parser = harness.parser(__doc__, quick_help="400² target, 3 reps (smoke test)",
                            out_help="write bench_draw_variants.md/.json here, not docs/")
    args = parser.parse_args(argv)
    args.size = 400 if args.quick else 1200
    args.reps = 3 if args.quick else 7
    results = run(args)
    harness.publish(args.out, "draw_variants", args.quick, results, markdown(results))


if __name__ == "__main__":
    main()
