"""The draw benchmark's derived figures: texture fetches and ALU per pack counted from
the GLSL, and lines fitted through the sweeps (cost per pack, per light)."""

from __future__ import annotations

import numpy as np

from spectral_materials.blender.gpu import shaders
from spectral_materials.core.brdf.params import get_parameterization

from .harness import log
from .synthetic import BASIS_SIZE, LAYOUTS

#: The factor-pack paper's frame rates on ~1 M pixels (GeForce GTX 280), by packs.
PAPER_FPS = {4: 126.0, 22: 35.0, 48: 18.0}
#: (layout, precontract) of the packs sweep at one light.
SERIES = (("io_iso", True), ("io_iso", False), ("hd", True))
MODES = {True: "precontract", False: "coefficients"}


def _between(text: str, start: str, end: str) -> str:
    head = text.index(start) + len(start)
    return text[head:text.index(end, head)]


def glsl_counts() -> dict:
    """Texture fetches, light-row reads and ALU per pack and light, counted from glsl/
    (see the Markdown). Light rows are read through ``sm_light_texel``
    (glsl/common/light_rows.glsl): uniform-buffer reads when they fit 16 KiB, which every
    configuration of this benchmark does, else texel fetches.

    The fetch sites are counted in the sources; the formulas say how often each runs.
    """
    packs_src = _between(shaders.glsl_source("brdf/factor_packs.glsl"),
                         "vec4 sm_pack_product_axes", "\n}")
    basis_src = shaders.glsl_source("brdf/spectral_basis.glsl")
    precontract_src = _between(basis_src, "#if SM_PRECONTRACT", "#else")
    coefficient_src = _between(basis_src, "#else", "#endif")
    sites = {"per_axis": packs_src.count("texelFetch("),
             "precontract": precontract_src.count("texelFetch("),
             "precontract_light_reads": precontract_src.count("sm_light_texel("),
             "coefficients": coefficient_src.count("texelFetch("),
             "coefficients_light_reads": coefficient_src.count("sm_light_texel(")}
    expected = {"per_axis": 2, "precontract": 0, "precontract_light_reads": 3,
                "coefficients": 1, "coefficients_light_reads": 1}
    if sites != expected:
        log(f"warning: fetch sites in glsl/ are {sites}, the counts below assume "
            f"{expected}; recount them")
    m = BASIS_SIZE
    out = {"sites": sites, "rows": []}
    for layout, shape in LAYOUTS.items():
        d = len(shape)
        # With several lights (precontract) and at least 2·lights + 4 packs
        # (shaders.shares_view_axes), the view's axes are fetched once per pack for all
        # of them (glsl/brdf/surface_frag.glsl, SM_SHARE_VIEW); fewer packs draw light by
        # light, each further light paying every axis.
        view = len(get_parameterization(layout).view_axes)
        for precontract in (True, False):
            dots = 3 if precontract else m
            # Scalar lane operations, an FMA counted as one: mix4 = 4 sub + 4 FMA,
            # mul4 = 4, dot4 = 1 mul + 3 FMA = 4; accumulation: vec3 add (3) or m adds.
            lanes = 8 * d + 4 * d + 4 * dots + (3 if precontract else m)
            out["rows"].append({
                "layout": layout, "axes": d, "mode": MODES[precontract],
                "fetches": 2 * d + (0 if precontract else m),
                "light_reads": 3 if precontract else 0, "mix4": d, "mul4": d,
                "dot4": dots, "adds": "1 vec3" if precontract else f"{m} scalar",
                "lane_ops": lanes,
                "per_light_extra_light_reads": 0 if precontract else m,
                "fetches_per_further_light": 2 * (d - view) if precontract else 2 * d + m,
                "paper_fetches": f"{d} filtered + spectral factor",
            })
    return out


# ----------------------------------------------------------------- summaries


def fit_line(x, y) -> tuple[float, float]:
    slope, intercept = np.polyfit(np.asarray(x, dtype=np.float64),
                                  np.asarray(y, dtype=np.float64), 1)
    return float(slope), float(intercept)


def summaries(rows: list[dict], light_packs: list[int]) -> dict:
    """Lines through the sweeps: the cost of one more pack, and of one more light.

    Slopes are fitted to ms/frame (this machine's absolute cost) and to the ratio
    (the cost in baseline frames, which the machine's load cancels out of).
    """
    out: dict = {"packs": [], "lights": []}
    for layout, precontract in SERIES:
        series = sorted((r for r in rows if r["layout"] == layout and r["lights"] == 1
                         and r["mode"] == MODES[precontract]), key=lambda r: r["packs"])
        if len(series) < 2:
            continue
        packs = [r["packs"] for r in series]
        slope, intercept = fit_line(packs, [r["ms"] for r in series])
        ratio_slope, ratio_intercept = fit_line(packs, [r["ratio"] for r in series])
        pixels = float(np.median([r["covered_pixels"] for r in series]))
        out["packs"].append({
            "layout": layout, "mode": MODES[precontract], "ms_per_pack": slope,
            "ms_at_0_packs": intercept,
            "baseline_ms": float(np.median([r["baseline_ms"] for r in series])),
            "baseline_frames_per_pack": ratio_slope, "ratio_at_0_packs": ratio_intercept,
            "fixed_cost_in_packs": ratio_intercept / ratio_slope,
            "ns_per_pixel_pack": slope * 1e6 / pixels})
    by_packs = {}
    for packs in light_packs:
        series = sorted((r for r in rows if r["layout"] == "io_iso" and r["packs"] == packs
                         and r["mode"] == "precontract"), key=lambda r: r["lights"])
        if len({r["lights"] for r in series}) < 2:
            continue
        lights = [r["lights"] for r in series]
        slope, intercept = fit_line(lights, [r["ms"] for r in series])
        base_slope, _ = fit_line(lights, [r["baseline_ms"] for r in series])
        ratio_slope, _ = fit_line(lights, [r["ratio"] for r in series])
        by_packs[packs] = (slope, ratio_slope)
        out["lights"].append({"layout": "io_iso", "mode": "precontract", "packs": packs,
                              "ms_per_light": slope, "ms_at_0_lights": intercept,
                              "baseline_ms_per_light": base_slope,
                              "ratio_per_light": ratio_slope})
    if len(by_packs) >= 2:
        (p0, (s0, r0)), (p1, (s1, r1)) = sorted(by_packs.items())[0], \
            sorted(by_packs.items())[-1]
        out["per_pack_per_light"] = {"from_packs": [p0, p1],
                                     "ms": (s1 - s0) / (p1 - p0),
                                     "baseline_frames": (r1 - r0) / (p1 - p0)}
    x = list(PAPER_FPS)
    slope, intercept = fit_line(x, [1e3 / PAPER_FPS[p] for p in x])
    out["paper"] = {"ms_per_pack": slope, "ms_at_0_packs": intercept,
                    "fixed_cost_in_packs": intercept / slope,
                    "rows": [{"packs": p, "fps": fps, "ms": 1e3 / fps,
                              "relative_to_4": PAPER_FPS[4] / fps}
                             for p, fps in PAPER_FPS.items()]}
    return out

