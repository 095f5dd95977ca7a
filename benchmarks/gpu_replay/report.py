"""docs/bench_gpu.md from a replay's ``gpu_results.json`` (run_gpu.py on a lent GPU).

Issue 19's figures: the draw table with ratios against the RGB Blinn–Phong baseline of
the same run, the factor precisions' milliseconds per pack against the exact path, spectral
against RGB PRT (with the albedo's texture basis and with the packed layers), and how far
each image is from the project's own llvmpipe read-back (cross-GPU agreement).

Usage::

    python -m benchmarks.gpu_replay.report docs/gpu/h200_gpu_results.json [--out docs]

(reads the explored variants' replays, ``docs/gpu/h200_explored_*.json``, beside it).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

#: Issue 19's table, replayed on an NVIDIA H100 before this work: (row, ms, × baseline),
#: quoted for the before/after comparison (another card: only the ratios carry over).
#: Its spectral PRT row drew the then albedo layers; today's default is Automatic.
ISSUE_H100 = {
    "draw_baseline_l1": ("baseline, 1 light", 0.431, 1.0),
    "draw_io_iso_precontract_p1_l1": ("io_iso precontracted, 1 pack", 0.93, 2.2),
    "draw_io_iso_precontract_p4_l1": ("io_iso precontracted, 4 packs", 1.64, 3.8),
    "draw_io_iso_precontract_p22_l1": ("io_iso precontracted, 22 packs", 8.63, 20),
    "draw_io_iso_precontract_p48_l1": ("io_iso precontracted, 48 packs", 18.7, 43),
    "draw_io_iso_precontract_p4_l2": ("io_iso 4 packs, 2 lights", 3.24, 7.5),
    "draw_io_iso_precontract_p4_l4": ("io_iso 4 packs, 4 lights", 6.49, 14.5),
    "draw_io_iso_precontract_p4_l8": ("io_iso 4 packs, 8 lights", 13.0, 16.2),
    "draw_io_iso_coefficients_p48_l1": ("io_iso coefficient mode, 48 packs", 29.1, 68),
    "draw_hd_precontract_p48_l1": ("hd precontracted, 48 packs", 22.4, 52),
    "btf_rfp_l1": ("BTF RFP, 1 light", 1.32, 4.7),
    "btf_rfnl_l1": ("BTF RFNL, 1 light", 1.62, 5.8),
    "btf_rfnl_l4": ("BTF RFNL, 4 lights", 4.69, 13.3),
    "prt_spectral_m8": ("spectral PRT m = 8 (512²; × RGB PRT)", 0.335, 3.41),
    "prt_rgb": ("RGB PRT (512²)", 0.098, 1.0),
}
#: The issue's per-pack cost before (0.39 ms per million pixels per pack, io_iso, 1 light).
ISSUE_MS_PER_PACK = 0.388
PRECISIONS = ("exact", "unorm16", "unorm16_filtered", "half_filtered")


def _ms(case: dict) -> float:
    return case["runs"]["blender"]["draw_ms"]["median"]


def draw_table(cases: dict) -> list[str]:
    lines = ["| case | replayed case | ms / frame | × baseline (same run) | issue's H100 ms | "
             "issue's × |", "|---|---|---|---|---|---|"]
    for name, (label, issue_ms, issue_ratio) in ISSUE_H100.items():
        if name not in cases:
            continue
        c = cases[name]
        base = cases.get(c["ratio_to"]) if c.get("ratio_to") else None
        ratio = f"{_ms(c) / _ms(base):.2f}" if base else "1"
        lines.append(f"| {label} | `{name}` | {_ms(c):.3f} | {ratio} | {issue_ms:g} | "
                     f"{issue_ratio:g} |")
    return lines


def precision_table(cases: dict) -> list[str]:
    lines = ["| packs | lights | precision | ms / frame | ms per pack | per pack × exact | "
             "per pack × issue's 0.388 |", "|---|---|---|---|---|---|---|"]
    for packs, lights in ((4, 1), (22, 1), (48, 1), (22, 4)):
        stem = f"draw_io_iso_precontract_p{packs}_l{lights}"
        base = cases.get(f"draw_baseline_l{lights}")
        if stem not in cases or base is None:
            continue
        exact_pack = (_ms(cases[stem]) - _ms(base)) / packs
        for precision in PRECISIONS:
            name = stem if precision == "exact" else f"{stem}_{precision}"
            if name not in cases:
                continue
            per_pack = (_ms(cases[name]) - _ms(base)) / packs
            issue = f"{per_pack / ISSUE_MS_PER_PACK:.2f}" if lights == 1 else "–"
            lines.append(f"| {packs} | {lights} | {precision} | {_ms(cases[name]):.3f} | "
                         f"{per_pack:.4f} | {per_pack / exact_pack:.2f} | {issue} |")
    return lines


_FORMS = {"unorm16": "16-bit R̃ layers, filtered by the texture unit",
          "basis": "albedo basis", "exact": "exact R̃ layers"}


def prt_table(cases: dict) -> list[str]:
    lines = ["| albedo | drawn as | ms / frame | × RGB PRT (same run) |", "|---|---|---|---|"]
    for prefix, albedo in (("prt", "ColorChecker chart (24 spectra)"),
                           ("prt_image", "RGB image, Smits uplift")):
        rgb = cases.get(f"{prefix}_rgb")
        if rgb is None:
            continue
        for suffix, drawn in (("_rgb", "RGB PRT"),
                              ("_spectral_m8_layers", "exact R̃ layers (filtered by hand)"),
                              ("_spectral_m8_basis", "albedo basis"),
                              ("_spectral_m8", "Automatic")):
            c = cases.get(prefix + suffix)
            if c is None:
                continue
            rank = c["params"].get("albedo_basis_rank")
            form = c["params"].get("albedo_form")
            label = f"{drawn} ({rank} weights)" if rank else drawn
            if suffix == "_spectral_m8" and form:
                label = f"Automatic: {_FORMS.get(form, form)}"
            lines.append(f"| {albedo} | {label} | {_ms(c):.3f} | {_ms(c) / _ms(rgb):.2f} |")
    return lines


def albedo_precision_lines(cases: dict, precision: Path | None) -> list[str]:
    """The PRT albedo's precisions (patch_cases.py --set albedo_precision): frame time, and
    the colours of the GPU's images against the exact layers' on llvmpipe."""
    if precision is None:
        return []
    from .albedo_precision import _stored, markdown, precision_rows

    variants = [n for n in cases if "_layers__" in n and n.startswith("prt")]
    lines = ["### Albedo precisions", "",
             f"`{precision}` (`python -m benchmarks.gpu_replay.albedo_precision` on it): "
             "each image drawn by this GPU against the exact layers' image as the project "
             "draws it on llvmpipe (float filter weights), ΔE94 on the reference's strided "
             "subsample, white FL4. `_layers__half_plain`: the packed layers as RGBA16F; "
             "`__half_lo`: RGBA16F plus the first layer's rounding error in one more layer; "
             "`__unorm16`: RGBA16 over each component's range (what Automatic draws: the "
             "unpatched `prt_spectral_m8`, `prt_image_spectral_m8`).", "",
             *markdown(precision_rows(*_stored(None, precision))), "",
             "| variant | ms / frame | × RGB PRT (same run) |", "|---|---|---|"]
    for name in variants:
        rgb = cases[cases[name]["ratio_to"]]
        lines.append(f"| `{name}` | {_ms(cases[name]):.3f} | {_ms(cases[name]) / _ms(rgb):.2f} |")
    return [*lines, ""]


def final_shader_lines(cases: dict, later: dict | None, source: str) -> list[str]:
    """The factor-pack draws replayed again with later shaders, against this replay."""
    if later is None:
        return []
    lines = ["## Factor-pack draws with the final shaders", "",
             f"`{source}`: the same draws exported after the edge rule *horizons* changed "
             "glsl/brdf/axis_lookup.glsl (the CPU sets the flag saying whether the rule holds "
             "an axis's horizon), replayed on the same kind of GPU.", "",
             "| case | ms / frame, this replay | ms / frame, final shaders | × |",
             "|---|---|---|---|"]
    for c in later["cases"]:
        name = c["name"]
        if name in cases and "draw_ms" in c["runs"].get("blender", {}):
            lines.append(f"| `{name}` | {_ms(cases[name]):.3f} | {_ms(c):.3f} | "
                         f"{_ms(c) / _ms(cases[name]):.3f} |")
    return [*lines, ""]


def btf_table(cases: dict) -> list[str]:
    lines = ["| case | ms / frame | × baseline (same run) |", "|---|---|---|"]
    names = ("btf_rfp_l1", "btf_rfnl_l1", "btf_rfp_l4", "btf_rfnl_l4")
    for name in [*names, *(c for c in cases if c.split("__")[0] in names and "__" in c)]:
        if name in cases:
            base = cases[cases[name]["ratio_to"]]
            lines.append(f"| `{name}` | {_ms(cases[name]):.3f} | "
                         f"{_ms(cases[name]) / _ms(base):.2f} |")
    return lines


def explored_table(runs: list[dict]) -> list[str]:
    """Every patched variant (patch_cases.py) against its unpatched case, same run."""
    lines = ["| run | variant | ms / frame | unpatched ms | × unpatched |", "|---|---|---|---|---|"]
    for k, run in enumerate(runs, 1):
        cases = {c["name"]: c for c in run["cases"]}
        for name, c in cases.items():
            base = cases.get(c.get("variant_of") or name.split("__")[0])
            if "__" in name and base is not None:
                lines.append(f"| {k} | `{name}` | {_ms(c):.3f} | {_ms(base):.3f} | "
                             f"{_ms(c) / _ms(base):.2f} |")
    return lines


def agreement_table(cases: dict) -> list[str]:
    lines = ["| case | max rel | mean rel | pixels > 1e-3 | of those, unexplained | check |",
             "|---|---|---|---|---|---|"]
    for c in cases.values():
        run = c["runs"]["blender"]
        k = run["check"]
        lines.append(f"| {c['name']} | {k['max_rel']:.1e} | {k['mean_rel']:.1e} | "
                     f"{k['pixels_rel_gt_1e-3']} | {k['pixels_rel_gt_1e-3_unexplained']} | "
                     f"{run.get('status', k.get('status', ''))} |")
    return lines


def markdown(results: dict, source: str, explored: list[dict] | None = None,
             prt_paths: list[dict] | None = None, precision: Path | None = None,
             later: dict | None = None, later_source: str = "") -> list[str]:
    cases = {c["name"]: c for c in results["cases"]}
    m, e = results["machine"], results["export"]
    return [
        "# The project's draws on a GPU", "",
        f"Printed by `python -m benchmarks.gpu_replay.report {source}` from a replay by "
        f"`benchmarks/gpu_replay/run_gpu.py` (`device_run.sh`) on **{m['gl_renderer']}** "
        f"({m['gl_version']}), started {results['started']}, of the draws exported at "
        f"commit {str(e.get('project_commit'))[:7]} + the working tree (Blender "
        f"{e['machine']['blender']}, {e['machine']['renderer']}). Times are GL timer "
        f"queries of the draw alone, median of {results['settings']['frames']} frames; "
        "Blender's own GLSL text (Mesa's dump) was compiled.", "",
        "## The issue's table, after", "",
        "Ratios are against the RGB Blinn–Phong baseline (PRT: RGB PRT) of the same run. "
        "The issue's figures were replayed on an H100, whose baseline drew in the same "
        "0.431 ms.", "", *draw_table(cases), "",
        "## Factor precisions: milliseconds per pack", "",
        "(ms − the baseline's ms) / packs, io_iso 90×180×90, pre-contracted, 1.0 M px.", "",
        *precision_table(cases), "",
        "## Spectral against RGB PRT (m = 8, bands 5, 512²)", "",
        *prt_table(cases), "",
        *albedo_precision_lines(cases, precision),
        *final_shader_lines(cases, later, later_source),
        "## BTF (800², texels blended across their edges)", "",
        *btf_table(cases), "",
        *(["## Variants timed on the way (`patch_cases.py --set explored`)", "",
            "Text patches of the shaders of commit b30c25a (albedo basis with G interpolated "
            "per vertex, BTF lights outermost), each timed beside the unpatched case in the "
            "same run; their images are not meant to be right. `no_fetch`, `no_basis_ubo`: "
            "what the albedo fetches and the vertex stage's mixing reads cost; `hw16`/`hw32`: "
            "hardware-filtered weights; `two_layers`: 8 weights; `pixel_g`: Ê interpolated "
            "and G formed per pixel (today's shader with `hw32`); `nearest`: no texel-edge "
            "blend; `texel_outer`: BTF texels outermost (today's RFNL shader).", "",
            *explored_table(explored), ""] if explored else []),
        *(["## PRT albedo paths timed on the way (`patch_cases.py --set prt_paths`)", "",
            "Text patches of the shaders of commit 5223be0, where the albedo basis was the "
            "default, each timed beside the unpatched case in the same run: "
            "`layers_hw32`/`layers_hw16`: the packed R̃ layers filtered by the texture unit "
            "as RGBA32F/RGBA16F instead of by hand; `basis_hw16`: the basis's weights as "
            "RGBA16F; `basis_two_layers`: 8 weights; `rgb_hw32`: RGB PRT filtered by the "
            "texture unit. They led to the 16-bit layers, Automatic's first choice (half floats "
            "were left out: see Albedo precisions).", "",
            *explored_table(prt_paths), ""] if prt_paths else []),
        "## Agreement with the project's llvmpipe read-back", "",
        "Per pixel: max over RGB |GPU − llvmpipe| / max(|llvmpipe|, 1e-4). *Unexplained*: "
        "pixels over 1e-3 that neither move on llvmpipe when the geometry moves by ~1e-3 px "
        "nor lie within the GPU's own 3×3 neighbourhood. The filtered precisions differ "
        "by design: a texture unit interpolates with 8-bit weights, llvmpipe with float "
        "ones (the Python mirror models the 8-bit weights).", "",
        *agreement_table(cases), ""]


def page(results_path: str, explored_paths: list[str] | None = None) -> str:
    """docs/bench_gpu.md's text for ``results_path``: with the replays beside it of the
    explored (``*_explored_*.json``) and PRT-path (``*_prt_paths_*.json``) variants and
    the albedo precisions (``*_albedo_precision.npz``) and a later replay of the draws
    (``*_final_shader_draws.json``)."""
    folder = Path(results_path).parent
    results = json.loads(Path(results_path).read_text())
    if explored_paths is None:
        explored_paths = sorted(str(p) for p in folder.glob("*_explored_*.json"))
    explored = [json.loads(Path(p).read_text()) for p in explored_paths]
    prt_paths = [json.loads(p.read_text()) for p in sorted(folder.glob("*_prt_paths_*.json"))]
    precision = sorted(folder.glob("*_albedo_precision.npz"))
    later = sorted(folder.glob("*_final_shader_draws.json"))
    return "\n".join(markdown(results, results_path, explored, prt_paths,
                               precision[-1] if precision else None,
                               json.loads(later[-1].read_text()) if later else None,
                               str(later[-1]) if later else ""))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results", help="gpu_results.json")
    parser.add_argument("--explored", nargs="*", default=None,
                        help="replays of patch_cases.py's explored set (default: "
                             "RESULTS' folder's *_explored_*.json)")
    parser.add_argument("--out", default="docs", help="folder for bench_gpu.md")
    args = parser.parse_args(argv)
    text = page(args.results, args.explored)
    path = Path(args.out) / "bench_gpu.md"
    path.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
