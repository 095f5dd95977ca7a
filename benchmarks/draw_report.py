"""The draw benchmark's Markdown report (``docs/bench_draw.md``)."""

from __future__ import annotations

from pathlib import Path

from .draw_summary import MODES, PAPER_FPS, SERIES
from .harness import write_markdown as write_lines
from .synthetic import BASIS_SIZE, LAYOUTS, PACK_SIZE, RINGS, SEGMENTS


def fmt_bytes(n: int) -> str:
    return f"{n:,}".replace(",", " ")


def main_table(rows: list[dict]) -> list[str]:
    lines = ["| layout | packs | lights | mode | ms/frame | FPS | baseline ms/frame | ratio | "
             "covered pixels | texture bytes |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['layout']} | {r['packs']} | {r['lights']} | {r['mode']} | "
                     f"{r['ms']:.1f} | {r['fps']:.2f} | {r['baseline_ms']:.1f} | "
                     f"{r['ratio']:.1f} | {fmt_bytes(r['covered_pixels'])} | "
                     f"{fmt_bytes(r['texture_bytes'])} |")
    return lines


def ordered(rows: list[dict]) -> list[dict]:
    series = {(layout, MODES[pre]): i for i, (layout, pre) in enumerate(SERIES)}
    return sorted(rows, key=lambda r: (r["lights"] > 1, series[(r["layout"], r["mode"])],
                                       r["packs"], r["lights"]))


def paper_table(results: dict) -> list[str]:
    rows = results["rows"]
    head = "| packs | paper FPS (GTX 280) | paper ms/frame | paper t(P)/t(4) |"
    rule = "|---|---|---|---|"
    series = [(layout, MODES[pre]) for layout, pre in SERIES
              if any(r["layout"] == layout and r["mode"] == MODES[pre] for r in rows)]
    for layout, mode in series:
        head += f" {layout} {mode}: ms/frame | FPS | t(P)/t(4) | ratio |"
        rule += "---|---|---|---|"
    lines = [head, rule]
    for p, fps in PAPER_FPS.items():
        line = f"| {p} | {fps:.0f} | {1e3 / fps:.1f} | {PAPER_FPS[4] / fps:.2f} |"
        for layout, mode in series:
            pick = {r["packs"]: r for r in rows if r["layout"] == layout and r["mode"] == mode
                    and r["lights"] == 1}
            r, r4 = pick.get(p), pick.get(4)
            if r is None:
                line += " – | – | – | – |"
                continue
            rel = f"{r['ratio'] / r4['ratio']:.2f}" if r4 else "–"
            line += f" {r['ms']:.1f} | {r['fps']:.2f} | {rel} | {r['ratio']:.1f} |"
        lines.append(line)
    return lines


def rolled_section(results: dict) -> list[str]:
    """The rolled-loop control: the add-on's variant against the same with a rolled loop."""
    rolled = results.get("rolled") or []
    if not rolled:
        return []
    lines = ["### The pack loop, unrolled or not", "",
             "`for (int p = 0; p < SM_PACKS; p++)` has a bound known when the variant is "
             "compiled, so the compiler may unroll it. Control: the same variant with the "
             "bound written `SM_PACKS + sm.misc.w` (misc.w is 0, but unknown to the "
             "compiler), io_iso, precontract, one light, on the same material and target, "
             "the two timed alternately; unrolled / rolled is the median of each rolled "
             "timing against the mean of the add-on's timings on either side.", "",
             "| packs | add-on's shader ms/frame | rolled loop ms/frame | unrolled / rolled |",
             "|---|---|---|---|"]
    for r in rolled:
        lines.append(f"| {r['packs']} | {r['unrolled_ms']:.1f} | {r['rolled_ms']:.1f} | "
                     f"{r['unrolled_over_rolled']:.2f} |")
    lines += ["", "Where the two differ the compiler unrolled the loop (Mesa's choice here, "
              "not the shader's), and the unrolled code ran at a different speed on this "
              "machine: that is what makes the sweep uneven at a few packs. The work itself "
              "is linear in the packs, as the rolled column shows.", ""]
    return lines


def unrolled_note(results: dict) -> list[str]:
    """Our scaling with the 4-pack time of the rolled loop, where the control has it."""
    control = {r["packs"]: r for r in results.get("rolled") or []}
    main = {r["packs"]: r for r in results["rows"] if r["layout"] == "io_iso"
            and r["mode"] == "precontract" and r["lights"] == 1}
    if 4 not in control or 4 not in main:
        return []
    ratio4 = main[4]["ratio"] / control[4]["unrolled_over_rolled"]
    scaled = ", ".join(f"t({p})/t(4) = {main[p]['ratio'] / ratio4:.2f}" for p in (22, 48)
                       if p in main)
    return [f"On this machine the 4-pack variant is {control[4]['unrolled_over_rolled']:.2f}× "
            "the rolled loop's time (control above), which flattens our t(P)/t(4). Against "
            f"the rolled 4-pack time, io_iso precontract scales {scaled} (paper: "
            f"{PAPER_FPS[4] / PAPER_FPS[22]:.2f}, {PAPER_FPS[4] / PAPER_FPS[48]:.2f}).", ""]


def _intro(results: dict) -> list[str]:
    """The machine, the run and what is measured."""
    s = results["settings"]
    m = results["machine"]
    return [
        "# Draw benchmark", "",
        f"Machine: `{m['renderer']}` ({m['vendor']}, {m['version']}, {m['backend']} backend; "
        f"{m['cpu_count']} CPU cores, Blender {m['blender']}). Date: {results['date']}. "
        f"Command: `{results['command']}` ({results['seconds']:.0f} s in all). Load "
        f"average (1 min) {m['load_start']:.1f} at the start, {m['load_end']:.1f} at the end: "
        "other jobs share these cores, hence the ratios.",
        "",
        f"A smooth UV sphere ({SEGMENTS} segments × {RINGS} rings, "
        f"{s['triangles']} triangles, {fmt_bytes(s['vertex_bytes'])} vertex + index bytes) "
        f"drawn orthographically into a {s['size']} × {s['size']} RGBA32F target with depth "
        f"test and back faces culled (so every covered pixel is shaded once), through the "
        f"add-on's own path (`GPUMaterial`, `shaders.get_shader`, `MeshBatches`, output "
        f"DISPLAY). Factors are synthetic (speed does not depend on their values): io_iso "
        f"{'×'.join(map(str, LAYOUTS['io_iso']))} and hd {'×'.join(map(str, LAYOUTS['hd']))}, "
        f"spectral basis m = {BASIS_SIZE}, packs of {PACK_SIZE} terms, float32 textures.",
        "",
        "Each frame is a clear and one draw; a frame time is the wall time of "
        f"{s['frames']} frames ended by a 1-pixel read-back (which waits for the GPU), "
        f"divided by {s['frames']}; ms/frame is the median of {s['reps']} repetitions, "
        "after one warm-up frame that compiles the variant. **Baseline**: an RGB "
        "Blinn–Phong shader (`glsl/brdf/baseline_blinn_phong_*.glsl`, suns and 1/(4πr²) point "
        "lights, spots and areas drawn as points) with as many lights as the row, drawing "
        "the same batch into the same target, timed before and after every spectral "
        f"timing (B S B S … S B; {s['frames']} to {4 * s['frames']} baseline frames, so "
        "that a baseline timing lasts about half a spectral one). **ratio** = median over "
        "the repetitions of the spectral time over the mean of the two baseline times "
        "around it, so it compares like with "
        "like while the machine's load changes; it is not exactly the ratio of the two "
        "medians shown. The absolute times are this machine's only (llvmpipe is a CPU "
        "rasteriser: they are not GPU times).",
        "",
        "Modes: **precontract** (the add-on's default) folds the spectral factor into the "
        "light once per light on the CPU, K = Sᵀ Ĩ, 3 texels per pack; **coefficients** is "
        "the paper's per-pixel coefficient dot product (eq. 9), m texels per pack. Texture "
        "bytes = factor texture (all axes, the spectral factor and the basis) + light "
        "texture, float32.",
        "",
    ]


def _frame_time(results: dict) -> list[str]:
    rows = results["rows"]
    lines = ["## Frame time", "", *main_table(ordered(rows)), ""]
    light_rows = [r for r in rows if r["lights"] > 1]
    if light_rows:
        shares = {r["lights"]: (r["light_kinds"], r["lit_share"]) for r in rows}
        lines += ["Lights (io_iso, precontract; the 1-light rows are those of the packs "
                  "sweep): " + "; ".join(
                      f"{n}: {', '.join(kinds)} (each reaches {100 * share:.0f} % of the "
                      "covered pixels on average)" for n, (kinds, share) in sorted(
                          shares.items())) + ". A light that does not reach a pixel costs "
                  "the spectral shader no pack work there; the baseline shades it anyway.",
                  ""]
    return lines


def _cost_per_pack(results: dict) -> list[str]:
    """Lines through the sweeps, ours and the paper's."""
    summ = results["summaries"]
    lines = ["## Cost per pack", "",
             "Measured: least-squares lines against packs at one light, of ms/frame (this "
             "machine's cost) and of the ratio (the cost in baseline frames); ns per pixel "
             "per pack = ms slope / covered pixels; fixed cost in packs = the ratio line's "
             "intercept over its slope (what a frame costs besides its packs, counted in "
             "packs: comparable across hardware).", "",
             "| layout | mode | ms/frame per pack | ms/frame at 0 packs | baseline ms/frame | "
             "baseline frames per pack | ns per pixel per pack | fixed cost in packs |",
             "|---|---|---|---|---|---|---|---|"]
    for f in summ["packs"]:
        lines.append(f"| {f['layout']} | {f['mode']} | {f['ms_per_pack']:.2f} | "
                     f"{f['ms_at_0_packs']:.1f} | {f['baseline_ms']:.1f} | "
                     f"{f['baseline_frames_per_pack']:.2f} | {f['ns_per_pixel_pack']:.1f} | "
                     f"{f['fixed_cost_in_packs']:.1f} |")
    paper = summ["paper"]
    lines += ["", f"The paper (GTX 280, ~1 M pixels): {paper['ms_per_pack']:.2f} ms/frame per "
              f"pack, {paper['ms_at_0_packs']:.1f} ms at 0 packs (line through its three "
              f"points): a fixed cost of {paper['fixed_cost_in_packs']:.1f} packs.", ""]
    if summ["lights"]:
        lines += ["Lights (io_iso, precontract): lines against the light count.", "",
                  "| packs | ms/frame per light | baseline ms/frame per light | "
                  "baseline frames per light |", "|---|---|---|---|"]
        for f in summ["lights"]:
            lines.append(f"| {f['packs']} | {f['ms_per_light']:.1f} | "
                         f"{f['baseline_ms_per_light']:.2f} | {f['ratio_per_light']:.2f} |")
        per = summ.get("per_pack_per_light")
        if per:
            a, b = per["from_packs"]
            lines += ["", f"Per pack per light, from the difference of the two lines "
                      f"({a} and {b} packs): {per['ms']:.2f} ms/frame, "
                      f"{per['baseline_frames']:.2f} baseline frames (compare the per-pack "
                      "slope at one light above)."]
        lines.append("")
    return lines


def glsl_counts_markdown(results: dict) -> list[str]:
    """Fetches and ALU per pack, counted from the GLSL, against the paper's shader."""
    counts = results["counts"]
    lines = [
        "Counted from the GLSL (per pack and per light; d angular axes, m = "
        f"{BASIS_SIZE}): `sm_pack_product_axes` (glsl/brdf/factor_packs.glsl) fetches "
        f"{counts['sites']['per_axis']} unfiltered texels per axis (`texelFetch` at i0 and "
        "i1) and interpolates them itself, `product *= mix(a, b, w)`; "
        "`sm_reflected_xyz` (glsl/brdf/spectral_basis.glsl) then reads 3 vec4 of the "
        "light's row (X, Y, Z weights of the pack's 4 terms) and takes 3 dot4 "
        "(precontract), or fetches m texels of the pack's spectral factor and accumulates "
        "m dot4 into the coefficients (coefficients mode; then m light-row reads and m "
        "vec3 FMA per light, not per pack). Light rows are read from the uniform buffer "
        "`sm_lights` where they fit 16 KiB, as in every configuration here, else fetched "
        "from the light texture (glsl/common/light_rows.glsl). "
        "Lane ops count an FMA as one: mix4 = 4 sub + 4 FMA, mul4 = 4, "
        "dot4 = 4. Address arithmetic (one integer multiply-add per axis for the row) is "
        "not counted.", "",
        "| layout | d | mode | texture fetches | … for each further light | light-row reads "
        "(uniform buffer) | vec4 mix | vec4 mul | dot4 | accumulate | lane ops | paper's "
        "fetches |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for c in counts["rows"]:
        lines.append(f"| {c['layout']} | {c['axes']} | {c['mode']} | {c['fetches']} | "
                     f"{c.get('fetches_per_further_light', '–')} | "
                     f"{c.get('light_reads', '–')} | "
                     f"{c['mix4']} | {c['mul4']} | {c['dot4']} | {c['adds']} | "
                     f"{c['lane_ops']} | {c['paper_fetches']} |")
    lines += [
        "",
        "Per light, not per pack: the light's incidence (2–3 light-row reads, a normalise, the "
        "falloff), wi into the shading frame (3 dot3), the parameterisation (io_iso: "
        "4 `atan`, 3 `mod`; hd: the half vector, 4 `atan`, 2 `mod`, 2 sin/cos pairs and "
        "the rotation) and d axis lookups (clamp or `mod`, a divide, `sqrt` on warped "
        "axes, `floor`, index selects). Per pixel: the frame (normalise, Gram–Schmidt, "
        "cross) and the display pipeline (2 mat3, tone map, sRGB `pow`).",
        "",
        "Against the paper: its shader read 1 hardware-filtered texel per axis per pack "
        "(the texture unit interpolates) plus the spectral factor: d angular fetches and "
        "no interpolation ALU per pack. Ours reads 2 unfiltered texels per axis and "
        "interpolates in ALU (d more fetches and d mix4 per pack) so that the GPU agrees "
        "with the Python lookup `FactoredBRDF.coefficients` to float32 rounding: a "
        "hardware linear filter rounds its weights to 8 bits (glsl/brdf/factor_packs.glsl). "
        f"Precontraction takes the spectral side from m fetches to 3 light-row reads per "
        f"pack, saving m = {BASIS_SIZE} fetches, more than the d extra fetches of the exact "
        "interpolation: if the paper's spectral factor of a pack took m RGBA texels, as "
        f"ours does in coefficients mode, it read d + m = {3 + BASIS_SIZE} (io_iso) or "
        f"{4 + BASIS_SIZE} (hd) texels per pack where ours, precontracted, fetches "
        f"{counts['rows'][0]['fetches']} or {counts['rows'][2]['fetches']} (and reads 3 "
        "vec4 of uniforms); "
        "its filtered fetches cost the texture unit more than a `texelFetch` does, and "
        "our d mix4 are ALU it did not spend.",
        "",
    ]
    return lines


def _against_paper(results: dict) -> list[str]:
    return [
        "## Against the factor-pack paper", "",
        "The paper's frame rates were measured on a GeForce GTX 280 (2008) at about 1 M "
        "pixels; ours on the machine above. **Different hardware**: compare the scaling "
        "t(P)/t(4) and the ratios, not the absolute times. The paper gives no baseline; "
        "our ratio is against the Blinn–Phong baseline of the same run, and our t(P)/t(4) "
        "is ratio(P)/ratio(4), so that the machine's changing load cancels out.", "",
        *paper_table(results), "", *unrolled_note(results),
    ]


def _memory(results: dict) -> list[str]:
    rows = results["rows"]
    s = results["settings"]
    lines = [
        "## Memory", "",
        "| layout | packs | mode | factor texture bytes | light texture bytes per light |",
        "|---|---|---|---|---|"]
    seen = set()
    for r in ordered(rows):
        key = (r["layout"], r["packs"], r["mode"])
        if key in seen:
            continue
        seen.add(key)
        lines.append(f"| {r['layout']} | {r['packs']} | {r['mode']} | "
                     f"{fmt_bytes(r['factor_texture_bytes'])} | "
                     f"{fmt_bytes(r['light_texture_bytes'] // r['lights'])} |")
    lines += ["", f"Vertex and index buffers: {fmt_bytes(s['vertex_bytes'])} bytes "
              f"({s['corners']} corners × (position, normal, tangent) float32 + "
              f"{s['triangles']} triangles × 3 int32), the same for every row and for the "
              "baseline.", ""]
    return lines


def write_markdown(results: dict, path: Path) -> None:
    """``docs/bench_draw.md``: every section in turn."""
    write_lines(path, [*_intro(results), *_frame_time(results), *rolled_section(results),
                       *_cost_per_pack(results), *glsl_counts_markdown(results),
                       *_against_paper(results), *_memory(results)])
