"""BTF benchmark: the BTF paper's Table 1 on generated materials, held-out images,
GPU memory, and frame time of the reflectance-field shaders.

For each procedural material (corduroy, knit, stones; ``core/btf/generate.py``, so the
truth is known), a spectral BTF of T × T texels over the UBO 81 × 81 directions and 16
bands is fitted four ways: a per-texel Lafortune model with 4 lobes (LAF), per-view
biquadratic reflectance fields (RFP), per-view non-linear lobes (RFNL, 2 lobes, batched
Levenberg–Marquardt) and CP factor packs of the whole tensor (CP, the engine). Reported,
as in the paper (eq. 2): ε, the mean absolute error per texel over all measured
directions (and channels), avg / min / max over texels; ε at held-out directions (views
and lights the fits never saw, rendered by the generator; RF models interpolate between
the 3 nearest views as the shader does); fit seconds, also as a ratio to RFP in the
same run; GPU bytes at T² and at the paper's 256² (paper: 365 MB for RFNL-style fields
of 256² texels × 81 views). The RFNL solver is compared with scipy's ``least_squares``
(method "lm", per texel) on a subset. Frame time: a UV sphere covering ~0.5 M pixels drawn
by the BTF shader (RFP and RFNL, 1 and 4 lights) against the RGB Blinn–Phong baseline of
``benchmarks.draw`` in the same run, interleaved.

Writes ``docs/bench_btf.md``, ``docs/bench_btf.json`` and ``docs/images/btf_heldout_*.png``.

Usage::

    python -m benchmarks.btf               # T = 16 (~10 min on 2 cores)
    python -m benchmarks.btf --texels 8 --quick
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from spectral_materials.core.btf import (
    container as btf,
    fit as btf_fit,
    generate as btf_generate,
    job as btf_job,
)
from spectral_materials.core.colour import pipeline as colour_pipeline, spectra

from . import harness
from .harness import DOCS, log

MATERIALS = ("corduroy", "knit", "stones")
METHODS = ("LAF", "RFP", "RFNL", "CP")
PAPER_BYTES = 365e6
PAPER_TEXELS = 256
#: Held-out directions (θ°, φ°): between the measured rings and azimuths.
HELD_VIEWS = ((37.0, 20.0), (68.0, 200.0))
HELD_LIGHTS = ((8.0, 40.0), (22.0, 300.0), (37.0, 130.0), (52.0, 75.0), (67.0, 250.0),
               (52.0, 190.0))


def directions(pairs) -> np.ndarray:
    a = np.radians(np.asarray(pairs, dtype=np.float64))
    return np.stack([np.sin(a[:, 0]) * np.cos(a[:, 1]), np.sin(a[:, 0]) * np.sin(a[:, 1]),
                     np.cos(a[:, 0])], axis=-1)


def fit_all(data: btf.BTF, *, cp_packs: int) -> dict:
    models = {}
    models["LAF"] = btf_fit.fit_lafortune(data, lobes=4)
    models["RFP"] = btf_fit.fit_rfp(data)
    models["RFNL"] = btf_fit.fit_rfnl(data, lobes=2)
    models["CP"] = btf_fit.fit_cp(data, packs=cp_packs)
    return models


def held_out_values(data: btf.BTF, model, views: np.ndarray, lights: np.ndarray
                    ) -> np.ndarray:
    """(V, L, H, W, C) of a model at held-out directions, as a renderer would draw it."""
    if model.kind in ("RFP", "RFNL"):
        drawable = btf_job.drawable_from_fit(model, model.albedo, data.wavelengths)
        h, w = data.texels
        rows, cols = np.meshgrid(np.arange(h), np.arange(w), indexing="ij")
        out = np.empty((len(views), len(lights), h, w, data.shape[-1]), np.float32)
        for i, v in enumerate(views):
            for j, light in enumerate(lights):
                y = drawable.interpolated_luminance(
                    rows.ravel(), cols.ravel(), np.broadcast_to(light, (h * w, 3)),
                    np.broadcast_to(v, (h * w, 3))).reshape(h, w)
                out[i, j] = y[..., None] * model.albedo
        return out
    return model.evaluate(lights, views)


def gpu_bytes_at(model, data: btf.BTF, texels: int) -> int:
    """GPU bytes of the same model at texels × texels (the texel-resolution cut)."""
    h, w = data.texels
    if model.kind == "CP":
        tex, views, lights, chans = model.factors
        rank = tex.shape[1]
        return int(rank * (texels * texels + len(views) + len(lights) + len(chans)) * 4)
    return int(round(model.nbytes_gpu * texels * texels / (h * w)))


def display_image(values: np.ndarray, wavelengths: np.ndarray) -> np.ndarray:
    """Spectral reflectance factors (…, C) → display sRGB under D65, exposure 1."""
    weights = colour_pipeline.xyz_weights("D65", wavelengths)
    xyz = values.astype(np.float64) @ weights / np.pi
    white = colour_pipeline.white_xyz("D65", spectra.WAVELENGTHS_REFERENCE)
    return colour_pipeline.xyz_to_display(xyz, white)


def write_images(material: str, truth: np.ndarray, predictions: dict, wavelengths,
                 path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pairs = [(0, 2), (1, 4)]
    columns = ["truth", *predictions]
    fig, axes = plt.subplots(len(pairs), len(columns), figsize=(2.0 * len(columns),
                                                                 2.2 * len(pairs)))
    for r, (vi, li) in enumerate(pairs):
        for c, name in enumerate(columns):
            values = truth if name == "truth" else predictions[name]
            tile = np.tile(values[vi, li], (2, 2, 1))
            axes[r, c].imshow(np.clip(display_image(tile, wavelengths), 0, 1)[::-1],
                              interpolation="nearest")
            axes[r, c].set_xticks([])
            axes[r, c].set_yticks([])
            if r == 0:
                axes[r, c].set_title(name)
        v, light = HELD_VIEWS[vi], HELD_LIGHTS[li]
        axes[r, 0].set_ylabel(f"v {v[0]:.0f}°/{v[1]:.0f}°\nl {light[0]:.0f}°/{light[1]:.0f}°",
                              fontsize=8)
    fig.suptitle(f"{material}: held-out directions (2 × 2 tiles)", fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=80)
    plt.close(fig)


def solver_comparison(data: btf.BTF) -> dict:
    """RFNL batched LM against scipy least_squares (lm, per texel) on a subset."""
    subset = data.subset(views=np.arange(0, 81, 9), texels=(slice(0, 4), slice(0, 4)))
    out = {}
    for solver in ("batched", "scipy"):
        start = time.perf_counter()
        model = btf_fit.fit_rfnl(subset, lobes=2, solver=solver)
        out[solver] = {"seconds": time.perf_counter() - start,
                       "epsilon_avg": float(btf_fit.epsilon(subset, model)["avg"])}
    out["problems"] = int(subset.shape[0] * subset.shape[2] * subset.shape[3])
    out["speedup"] = out["scipy"]["seconds"] / out["batched"]["seconds"]
    return out


def material_rows(material: str, texels: int, cp_packs: int, images: bool) -> dict:
    start = time.perf_counter()
    data = btf_generate.generate_btf(material, texels=texels)
    generate_seconds = time.perf_counter() - start
    log(f"{material}: generated {data.shape} in {generate_seconds:.1f} s")
    models = fit_all(data, cp_packs=cp_packs)
    views, lights = directions(HELD_VIEWS), directions(HELD_LIGHTS)
    truth = btf_generate.generate_btf(material, texels=texels, views=views, lights=lights)
    predictions = {name: held_out_values(data, models[name], views, lights)
                   for name in METHODS}
    rows = []
    rfp_seconds = models["RFP"].fit_seconds
    for name in METHODS:
        model = models[name]
        eps = btf_fit.epsilon(data, model)
        held = float(np.mean(np.abs(predictions[name] - truth.values)))
        rows.append({"method": name, "avg": eps["avg"], "min": eps["min"], "max": eps["max"],
                     "heldout": held, "fit_seconds": model.fit_seconds,
                     "fit_ratio_rfp": model.fit_seconds / max(rfp_seconds, 1e-9),
                     "gpu_bytes": int(model.nbytes_gpu),
                     "gpu_bytes_256": gpu_bytes_at(model, data, PAPER_TEXELS)})
        log(f"  {name:5s} ε {eps['avg']:.4f} [{eps['min']:.4f}, {eps['max']:.4f}] held-out "
            f"{held:.4f}  fit {model.fit_seconds:.1f} s  {model.nbytes_gpu / 2**20:.2f} MiB")
    if images:
        write_images(material, truth.values, predictions, data.wavelengths,
                     DOCS / "images" / f"btf_heldout_{material}.png")
    return {"material": material, "shape": list(data.shape),
            "generate_seconds": generate_seconds, "rows": rows,
            "mean_value": float(np.nanmean(data.values))}


# ------------------------------------------------------------------- frame time


def btf_binder(model, data: btf.BTF, lights, vp: np.ndarray):
    """The drawable BTF material of a fit, and a function binding its shader."""
    from spectral_materials.blender.btf import drawer as btf_gpu

    resource = btf_gpu.BTFMaterial(btf_job.drawable_from_fit(
        model, model.albedo, data.wavelengths), (4.0, 4.0))
    return resource, resource_binder(resource, lights, vp)


def resource_binder(resource, lights, vp: np.ndarray, edge: float | None = None):
    """A function binding ``resource``'s variant for ``lights`` (compiled with the texel
    blend band ``edge`` instead of the resource's own when given)."""
    from dataclasses import replace

    from spectral_materials.blender.btf import drawer as btf_gpu
    from spectral_materials.blender.gpu.display import DisplaySettings

    from .draw_baseline import VIEW_ORIGIN

    key = resource.key(lights, output="DISPLAY")
    shader = btf_gpu.get_shader(key if edge is None else replace(key, edge=edge))
    light_texture = resource.light_texture(lights)
    params = resource.params(DisplaySettings(), VIEW_ORIGIN, vp)

    def bind_btf():
        resource.bind(shader, light_texture, params)
        return shader

    return bind_btf


def uv_sphere_batch():
    """The draw benchmark's sphere with longitude/latitude UVs, as one batch."""
    from spectral_materials.blender.gpu import batches as mesh_batches

    from .draw import sphere_arrays

    arrays = sphere_arrays()
    # UVs: the sphere's own map would need Blender's; the longitude/latitude of the
    # position is what a UV sphere's map is.
    p = arrays.positions
    arrays.uvs = np.stack([(np.arctan2(p[:, 1], p[:, 0]) / (2 * np.pi)) % 1.0,
                           np.arccos(np.clip(p[:, 2], -1, 1)) / np.pi], -1).astype(np.float32)
    return mesh_batches.MeshBatches.build(arrays).batches[0]


def frame_times(frames: int, reps: int) -> list[dict]:
    """BTF frames (RFP, RFNL; 1 and 4 lights) against the draw benchmark's baseline,
    timed alternately on the same target."""
    from spectral_materials.blender.gpu.context import ensure_gpu
    from spectral_materials.blender.gpu.offscreen import Target

    from .draw import Bench, make_lights, view_projection
    from .draw_baseline import Baseline

    ensure_gpu()
    batch = uv_sphere_batch()
    size = 800
    vp = view_projection(1.0)
    rows = []
    data = btf_generate.generate_btf("corduroy", texels=16)
    fits = {"RFP": btf_fit.fit_rfp(data), "RFNL": btf_fit.fit_rfnl(data, lobes=2)}
    with Target(size, size) as target:
        bench = Bench(target, batch, vp, frames, reps)
        for count in (1, 4):
            lights = make_lights(count)
            baseline = Baseline(lights, vp)

            def bind_baseline(baseline=baseline):
                baseline.bind()
                return baseline.shader

            for kind, model in fits.items():
                resource, bind_btf = btf_binder(model, data, lights, vp)
                _, covered, lit = bench.warm(bind_btf)
                bench.warm(bind_baseline)
                t_btf, t_base = [], []
                for _ in range(reps):
                    t_btf.append(bench.seconds_per_frame(bind_btf))
                    t_base.append(bench.seconds_per_frame(bind_baseline))
                btf_ms, base_ms = 1e3 * np.median(t_btf), 1e3 * np.median(t_base)
                rows.append({"model": kind, "lights": count, "pixels": covered,
                             "btf_ms": btf_ms, "baseline_ms": base_ms,
                             "ratio": btf_ms / base_ms, "gpu_bytes": resource.nbytes})
                log(f"  frame {kind} {count} light(s): {btf_ms:.1f} ms, baseline "
                    f"{base_ms:.1f} ms, ×{btf_ms / base_ms:.2f} ({covered} px)")
    return rows


# ---------------------------------------------------------------------- report


def markdown(result: dict) -> str:
    t = result["texels"]
    lines = [
        "# BTF benchmark: reflectance fields against Lafortune and CP",
        "",
        f"Written by `scripts/bench_btf.py` on {result['date']} ({result['machine']}). "
        f"Generated spectral BTFs of {t} × {t} texels, the UBO 81 views × 81 lights, "
        f"{result['bands']} bands (400–700 nm); fits of luminance × per-texel spectral "
        "albedo (LAF, RFP, RFNL) or CP packs of the whole tensor "
        f"({result['cp_packs']} packs of 4).",
        "",
        "ε is the BTF paper's eq. 2: mean |BTF − model| per texel over all measured "
        "(view, light) pairs and channels, in reflectance-factor units (a flat white "
        "Lambertian at normal light reads 1); avg / min / max over texels. *Held-out* is "
        "the mean absolute error at 2 views × 6 lights that no fit saw (RF models "
        "interpolate between the 3 nearest views, as the shader does). Fit time is also "
        "given as a ratio to RFP's in the same run. GPU bytes as float32 RGBA textures; "
        f"the last column scales the same model to {PAPER_TEXELS}² texels (the paper: "
        f"{PAPER_BYTES / 1e6:.0f} MB for its fields of 256² texels × 81 views).",
        "",
    ]
    for m in result["materials"]:
        lines += [f"## {m['material']}", "",
                  f"Mean value {m['mean_value']:.3f}; generated in "
                  f"{m['generate_seconds']:.1f} s.", "",
                  "| method | ε avg | ε min | ε max | held-out | fit s | × RFP | GPU | "
                  f"GPU at {PAPER_TEXELS}² |",
                  "|---|---|---|---|---|---|---|---|---|"]
        for r in m["rows"]:
            lines.append(f"| {r['method']} | {r['avg']:.4f} | {r['min']:.4f} | "
                         f"{r['max']:.4f} | {r['heldout']:.4f} | {r['fit_seconds']:.1f} | "
                         f"{r['fit_ratio_rfp']:.0f} | {r['gpu_bytes'] / 2**20:.2f} MiB | "
                         f"{r['gpu_bytes_256'] / 1e6:.0f} MB |")
        lines += ["", f"![held-out directions](images/btf_heldout_{m['material']}.png)", ""]
    s = result.get("solvers")
    if s:
        lines += ["## RFNL solvers", "",
                  f"{s['problems']} per-texel problems (9 views × 4 × 4 texels of "
                  f"corduroy): batched LM {s['batched']['seconds']:.2f} s "
                  f"(ε {s['batched']['epsilon_avg']:.4f}), scipy `least_squares` (lm) per "
                  f"texel {s['scipy']['seconds']:.2f} s (ε {s['scipy']['epsilon_avg']:.4f}): "
                  f"batched is {s['speedup']:.1f}× faster.", ""]
    frames = result.get("frames")
    if frames:
        lines += ["## Frame time", "",
                  "800 × 800 RGBA32F target, UV sphere (128 × 64) covering the pixels "
                  "below, corduroy 16² fits, median of the repetitions, interleaved with "
                  "the RGB Blinn–Phong baseline of `bench_draw.py` on the same batch.", "",
                  "| model | lights | pixels | BTF ms | baseline ms | × baseline | GPU |",
                  "|---|---|---|---|---|---|---|"]
        for r in frames:
            lines.append(f"| {r['model']} | {r['lights']} | {r['pixels']} | "
                         f"{r['btf_ms']:.1f} | {r['baseline_ms']:.1f} | {r['ratio']:.2f} | "
                         f"{r['gpu_bytes'] / 2**20:.2f} MiB |")
        lines.append("")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = harness.parser(__doc__, quick_help="one material, no frame times, no solver "
                            "comparison")
    parser.add_argument("--texels", type=int, default=16)
    parser.add_argument("--cp-packs", type=int, default=8)
    parser.add_argument("--frames", type=int, default=10)
    parser.add_argument("--reps", type=int, default=3)
    args = parser.parse_args(argv)
    materials = MATERIALS[:1] if args.quick else MATERIALS
    result = {"date": harness.date_stamp(day_only=True), "texels": args.texels,
              "bands": len(btf_generate.DEFAULT_WAVELENGTHS), "cp_packs": args.cp_packs,
              "materials": [material_rows(m, args.texels, args.cp_packs, not args.quick)
                            for m in materials]}
    if not args.quick:
        result["solvers"] = solver_comparison(btf_generate.generate_btf("corduroy",
                                                                        texels=4))
        result["frames"] = frame_times(args.frames, args.reps)
        machine = harness.gpu_machine()
        result["machine"] = f"{machine['renderer']}, {machine['cpu_count']} CPUs"
    else:
        result["machine"] = "quick run"
    name = harness.output_stem("btf", args.quick)
    harness.write_json(DOCS / f"{name}.json", result)
    harness.write_markdown(DOCS / f"{name}.md", markdown(result))
    log(f"wrote docs/{name}.md")


if __name__ == "__main__":
    main()
