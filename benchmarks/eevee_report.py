"""The EEVEE benchmark's Markdown report (``docs/bench_eevee.md``) and the figures
derived from its rows (lines against packs, what limits the pack count)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .harness import write_markdown as write_lines
from .synthetic import BASIS_SIZE, DISC_FRACTION, LAYOUTS, PACK_SIZE, RINGS, SEGMENTS

#: The scene's sun, from the view axis; EEVEE's samples per render (benchmarks.eevee).
SUN_INCIDENCE_DEG = 30.0
SAMPLES = 1


def fmt(value, spec: str = ".2f", missing: str = "–") -> str:
    return missing if value is None else format(value, spec)


def to_ms(value) -> float | None:
    return None if value is None else 1e3 * value


def main_table(rows: list[dict]) -> list[str]:
    lines = ["| layout | packs | group nodes | image nodes | images (samplers) | apply s | "
             "first render s | later render s | compile s | render / Principled | "
             "render / draw path | ms per extra sample | sample / Principled | "
             "sample / draw path | draw-path ms | status |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        status = r["status"]
        if r.get("uniform_block"):
            u = r["uniform_block"]
            status += f": uniform block {u['bytes']} B > {u['limit']} B"
        lines.append(
            f"| {r['layout']} | {r['packs']} | {r.get('nodes', '–')} | "
            f"{r.get('image_nodes', '–')} | {r.get('images', '–')} | "
            f"{fmt(r.get('apply_seconds'), '.1f')} | {fmt(r.get('first_seconds'))} | "
            f"{fmt(r.get('later_median'))} | {fmt(r.get('compile_seconds'), '.1f')} | "
            f"{fmt(r.get('over_principled'))} | {fmt(r.get('over_draw'), '.0f')} | "
            f"{fmt(to_ms(r.get('per_sample_seconds')), '.0f')} | "
            f"{fmt(r.get('per_sample_over_principled'))} | "
            f"{fmt(r.get('per_sample_over_draw'), '.1f')} | "
            f"{fmt(to_ms(r.get('draw_median')), '.1f')} | {status} |")
    return lines


def per_pack(rows: list[dict]) -> list[dict]:
    """Least-squares lines against packs over the rows that compiled: (slope, intercept)."""
    out = []
    for layout in LAYOUTS:
        series = [r for r in rows if r["layout"] == layout and r.get("compiled")
                  and r.get("later_median") is not None]
        if len(series) < 2:
            continue
        packs = np.array([r["packs"] for r in series], dtype=np.float64)
        fit = {"layout": layout, "packs": [int(p) for p in packs]}
        for key in ("nodes", "image_nodes", "apply_seconds", "first_seconds", "later_median",
                    "over_principled", "per_sample_seconds", "draw_median"):
            values = [r.get(key) for r in series]
            if all(v is not None for v in values):
                fit[key] = tuple(float(v) for v in np.polyfit(packs, values, 1))
        out.append(fit)
    return out


def findings(results: dict) -> list[str]:
    rows = results["rows"]
    lines = []
    for layout in LAYOUTS:
        series = [r for r in rows if r["layout"] == layout]
        if not series:
            continue
        ok = [r["packs"] for r in series if r["compiled"]]
        bad = [r for r in series if not r["compiled"]]
        axes = series[0]["axes"]
        text = (f"**{layout}** ({axes} angular axes): "
                + (f"compiled and rendered at {', '.join(map(str, ok))} packs of the grid"
                   if ok else "compiled at no pack count of the grid"))
        if bad:
            text += "; failed at " + ", ".join(
                f"{r['packs']} ({r['status']}"
                + (f": uniform block `{r['uniform_block']['name']}` of "
                   f"{r['uniform_block']['bytes']} bytes over the {r['uniform_block']['limit']}"
                   "-byte limit" if r.get("uniform_block") else "") + ")" for r in bad)
        limit = results["limits"].get(layout)
        if limit is not None:
            probes = ", ".join(f"{p['packs']} ({'ok' if p['compiled'] else 'failed'}, "
                               f"apply {fmt(p.get('apply_seconds'), '.0f')} s, first render "
                               f"{fmt(p['first_seconds'], '.1f')} s)" for p in limit["probes"])
            text += (f". Limit search (first renders only): compiles at {limit['compiles_at']}, "
                     f"fails at {limit['fails_at']} packs"
                     + ("" if limit["exact"] else " (not narrowed further)")
                     + (f"; probes: {probes}" if probes else ""))
            if limit["uniform_bytes_per_pack"]:
                sizes = ", ".join(f"{k} packs: {v} B" for k, v in limit["uniform_bytes"].items())
                text += (f"; the uniform block grows by {limit['uniform_bytes_per_pack']:.0f} "
                         f"bytes per pack ({sizes}), "
                         f"which puts the last pack count under {limit['limit_bytes']} bytes at "
                         f"{limit['predicted_limit']}")
        elif not bad and results["settings"]["find_limit"]:
            text += "; no failure in the grid, so no limit search"
        lines.append(text + ".")
    return lines


def notes(rows: list[dict], principled: dict) -> list[str]:
    """Observations computed from this run's numbers."""
    out = []
    for r in [r for r in rows if not r["compiled"]]:
        u = r.get("uniform_block")
        what = (f"the GLSL program did not link: the material's uniform block "
                f"`{u['name']}` (the values of the node tree's unlinked sockets) is "
                f"{u['bytes']} bytes, over the driver's {u['limit']}-byte limit" if u else
                "; ".join(r["error_lines"][:3]) or r.get("exception") or r["status"])
        image = r.get("image") or {}
        out.append(
            f"- {r['layout']} at {r['packs']} packs ({r.get('nodes')} group nodes): {what}. "
            f"`bpy.ops.render.render` returned normally after {fmt(r['first_seconds'], '.1f')} s "
            f"and EEVEE drew its magenta error material on "
            f"{100 * image.get('magenta_share', 0.0):.0f} % of the sphere: only the console "
            "says why; nothing reaches Python. The draw path draws this material "
            f"({fmt(to_ms(r.get('draw_median')), '.0f')} ms a frame).")
    ok = [r for r in rows if r["compiled"] and r.get("apply_seconds") is not None]
    if ok:
        small = min(ok, key=lambda r: r["nodes"])
        big = max(ok, key=lambda r: r["nodes"])
        per_node = [1e3 * r["apply_seconds"] / r["nodes"] for r in (small, big)]
        out.append(
            f"- Building the group (`apply_eevee`) grows faster than its node count: "
            f"{small['apply_seconds']:.2f} s for {small['nodes']} nodes "
            f"({small['layout']}, {small['packs']} pack{'s' * (small['packs'] != 1)}), "
            f"{big['apply_seconds']:.0f} s for "
            f"{big['nodes']} ({big['layout']}, {big['packs']}): {per_node[0]:.1f} → "
            f"{per_node[1]:.1f} ms per node.")
        longest = max(ok, key=lambda r: r["first_seconds"])
        out.append(
            f"- The longest first render that compiled: {longest['first_seconds']:.1f} s "
            f"({longest['layout']}, {longest['packs']} packs, later renders "
            f"{fmt(longest.get('later_median'))} s); the Principled material's: "
            f"{principled['first_seconds']:.1f} s.")
        sampled = [r for r in ok if r.get("per_sample_seconds") is not None]
        if sampled:
            fixed = [r["fixed_seconds"] for r in sampled]
            out.append(
                f"- An EEVEE render at 1 sample is mostly fixed cost: render time − the cost "
                f"of one sample = {min(fixed):.2f} … {max(fixed):.2f} s over the rows, "
                "against the draw path's whole frame (draw and read-back) in the draw-path "
                "column; the per-sample columns compare shading work.")
    return out


def _header(results: dict) -> list[str]:
    s = results["settings"]
    m = results["machine"]
    return [
        "# EEVEE benchmark: the node-group reconstruction against packs", "",
        f"- Machine: {m['renderer']} ({m['backend']}), {m['cpu_count']} CPU cores, "
        f"load {m['load_start']:.1f} → {m['load_end']:.1f}",
        f"- Date: {results['date']}",
        f"- Command: `{results['command']}`",
        f"- Run time: {results['seconds']:.0f} s",
        f"- Blender {m['blender']}, Python {m['python']}, NumPy {m['numpy']}",
        f"- GL driver disk shader cache: {'on' if s['shader_cache'] else 'off'} "
        "(off: a first render compiles everything it needs)",
        "",
    ]


def _method(results: dict) -> list[str]:
    """What is measured: the scene, the materials and every column."""
    s = results["settings"]
    return [
        "## What is measured", "",
        f"Scene: one smooth UV sphere ({SEGMENTS} segments × {RINGS} rings, with UVs), a "
        f"sun of strength 1 (D65) {SUN_INCIDENCE_DEG:.0f}° from the view axis, a black world "
        f"and an orthographic camera; {s['size']} × {s['size']} pixels, of which the "
        f"sphere's disc covers {100 * math.pi * DISC_FRACTION ** 2:.0f} %. EEVEE "
        f"(`BLENDER_EEVEE`) renders with **`taa_render_samples = {SAMPLES}`**, other settings "
        "at Blender's defaults (listed in the JSON: shadows on, ray tracing off).",
        "",
        "Materials: synthetic CP models (random positive factors: the cost does not depend "
        f"on their values), io_iso {'×'.join(map(str, LAYOUTS['io_iso']))} (3 angular axes) "
        f"and hd {'×'.join(map(str, LAYOUTS['hd']))} (4 axes), spectral basis m = "
        f"{BASIS_SIZE}, packs of {PACK_SIZE} terms, stored with `storage.store_factored` "
        "and given the node group by `eevee.apply_eevee(material, scene, light_object=sun)` "
        "(which excludes the sphere from the sun by light linking: the group carries the "
        "sun's light; and, the add-on's default, reads the sun's EEVEE shadow through its "
        "twin lights, a refraction probe and Shader to RGB: docs/eevee.md).",
        "",
        *_columns(results),
    ]


def _columns(results: dict) -> list[str]:
    """What each column of the results table is."""
    s = results["settings"]
    extra = s["extra_samples"]
    return [
        "- **group nodes / image nodes / images (samplers)**: `eevee_nodes.node_count` of "
        "the group (frames excluded). Every image node reads the one factor image with the "
        "same sampler state (Closest, Extend), and Blender's GLSL generator binds one "
        "sampler per distinct image and state, so the material takes 1 sampler whatever "
        "the packs; its texture *fetches* are the image nodes (2 per axis per pack).",
        "- **apply s**: wall time of `apply_eevee` (prefiltering and building the group).",
        "- **first render s**: the first `bpy.ops.render.render(write_still=False)` with the "
        "material, which compiles its shaders (EEVEE's own shaders were compiled before by "
        "warm-up renders of the same scene with a Diffuse BSDF). **later render s**: the "
        f"median of {s['reps']} later renders. **compile s** = first − later (within the "
        "noise of one render at small pack counts).",
        "- **render / Principled**: baseline (a), Blender's default material (Principled "
        "BSDF) on the same sphere, lit by the same sun, rendered by EEVEE in the same "
        "scene: renders alternate P E P E … P and the ratio is the median, over the "
        "spectral renders, of its time over the mean of the two Principled renders around "
        "it.",
        "- **render / draw path**, **draw-path ms**: baseline (b), the add-on's draw-handler "
        "path, `draw.render_camera(scene, width, height, output=\"DISPLAY\")` on the same "
        "material: an offscreen RGBA32F draw of the scene's factored objects and a read-back "
        "of the whole image (which waits for the GPU); after every spectral render the "
        f"median of {s['draw_calls']} calls. The ratio is the median over the renders of the "
        "render time over the draw time measured right after it. The draw path's first "
        "call (compiling its variant, uploading the factors) is `draw_first_seconds` in "
        "the JSON.",
        f"- **ms per extra sample**: (render at {SAMPLES + extra} samples − render at "
        f"{SAMPLES}) / {extra}, the shading work of one more EEVEE sample without the "
        "render's fixed cost; **sample / Principled** is the same difference for the "
        "Principled material (its renders in the same row), **sample / draw path** is "
        "against the draw path's frame."
        if extra else "- Per-sample columns: not measured (`--extra-samples 0`).",
        "- **status**: `ok` when the first render raised nothing, Blender's console "
        "(captured during the first render) printed no error, and the sphere is not "
        "EEVEE's magenta stand-in for a material that failed to compile (emission "
        "(1, 0, 1) on more than half of the sphere's pixels). Rows that failed are not "
        "timed further (EEVEE would time its error material).",
        "",
        "Absolute times are this machine's only: llvmpipe rasterises on the CPU, and the "
        "machine is shared, so the ratios (measured within a few seconds of each other) "
        "are the figures to compare.",
        "",
    ]


def _results(results: dict) -> list[str]:
    p = results["principled"]
    rows = results["rows"]
    per_sample_p = [r["principled_per_sample_seconds"] for r in rows
                    if r.get("principled_per_sample_seconds") is not None]
    return [
        "## Results", "",
        *main_table(rows), "",
        f"Principled BSDF baseline (a): first render {p['first_seconds']:.2f} s (compiles "
        f"the Principled material), later renders {p['later_median']:.2f} s (median of "
        f"{len(p['later_seconds'])} right after it; the per-row P renders are in the JSON)"
        + (f", {1e3 * float(np.median(per_sample_p)):.0f} ms per extra sample (median over "
           "the rows)" if per_sample_p else "")
        + ". Warm-up renders (EEVEE's own shaders, Diffuse BSDF): "
        + ", ".join(f"{t:.1f}" for t in p["warm_up_seconds"]) + " s.",
        "",
        "## Limits", "",
        *[f"- {line}" for line in findings(results)],
        *results["notes"],
        "",
    ]


def _per_pack_lines(results: dict) -> list[str]:
    """Lines against packs over the rows that compiled (slope + value at 0 packs)."""
    fits = results["per_pack"]
    if not fits:
        return []
    columns = [("nodes", "nodes", ".1f", ".0f", 1.0),
               ("image_nodes", "image nodes", ".0f", ".0f", 1.0),
               ("first_seconds", "first render s", ".3f", ".2f", 1.0),
               ("later_median", "later render s", ".4f", ".2f", 1.0),
               ("over_principled", "render / Principled", ".4f", ".2f", 1.0),
               ("per_sample_seconds", "ms per extra sample", ".1f", ".0f", 1e3),
               ("draw_median", "draw-path ms", ".2f", ".1f", 1e3)]
    columns = [c for c in columns if all(c[0] in f for f in fits)]
    lines = ["## Per pack", "",
             "Least-squares lines against packs over the rows that compiled: "
             "slope per pack + value at 0 packs (`apply_eevee`'s time is not linear: see "
             "above).", "",
             "| layout | " + " | ".join(c[1] for c in columns) + " |",
             "|---|" + "---|" * len(columns)]
    for f in fits:
        cells = [f"{format(round(f[key][0] * k, 6) + 0.0, a)} + "
                 f"{format(round(f[key][1] * k, 6) + 0.0, b)}"
                 for key, _, a, b, k in columns]
        lines.append(f"| {f['layout']} | " + " | ".join(cells) + " |")
    lines.append("")
    return lines


def write_markdown(results: dict, path: Path, extra: list[str] = ()) -> None:
    """The report; ``extra``: more sections at the end (``eevee_lights.lights_lines``)."""
    write_lines(path, [*_header(results), *_method(results), *_results(results),
                       *_per_pack_lines(results), *extra])
