"""The demo's report (``report.md``): the scene analysis, error against time, the
pictures, then the sections the other demo modules write."""

from __future__ import annotations

from pathlib import Path

from .sizes import DemoSizes


def analysis_lines(analysis: dict, sizes: DemoSizes) -> list[str]:
    """The title, how figures are measured, and the scene analysis with its basis table."""
    basis = analysis["basis"]
    lines = [
        "# Spectral Materials demo report"
        + (" (quick run: small sizes, not results)" if sizes.label == "quick" else ""),
        "",
        "Written by `scripts/demo` (every figure measured in that run). ΔE94 is measured as "
        "shared/PROTOCOL.md says: against the 5 nm evaluation of the analytic BRDF, D65, the "
        "20 000 seeded random direction pairs; sphere figures use the protocol sphere at 60° "
        "incidence under D65 and FL2.",
        "",
        "## Scene analysis",
        "",
        f"> {analysis['summary']}",
        "",
        f"- Materials used: {', '.join(analysis['materials_used'])}",
        f"- Left out: {', '.join(analysis['materials_unused']) or 'none'} (not on a visible, "
        "renderable object)",
        f"- Lights: {', '.join(analysis['lights'])}"
        + (f"; left out: {', '.join(analysis['lights_left_out'])}"
           if analysis["lights_left_out"] else ""),
        f"- Spectral basis: **{basis['size']} coefficients** (default {basis['full_size']}) "
        f"for tolerance ΔE94 ≤ {basis['tolerance_de94']:.3g}"
        f"; worst light × material pair {basis['max_de94']:.4f} "
        f"({' × '.join(basis['worst_pair'])}). Factoring on all 81 wavelength samples "
        f"would store {81 / basis['size']:.1f}× more spectral data per term.",
        "",
        "| basis size | worst ΔE94 | mean ΔE94 |",
        "|---:|---:|---:|",
    ]
    for row in basis["per_size"]:
        lines.append(f"| {row['size']} | {row['max_de94']:.4f} | {row['mean_de94']:.4f} |")
    return lines


def error_lines(analysis: dict, figures: dict, reload: dict, sizes: DemoSizes) -> list[str]:
    """Error against time per material and pack count, and the stored materials' table."""
    lines = ["", "## Error against time", "",
             f"Grid: θ cells {sizes.theta_cells} (per 90°). Seconds are cumulative (tabulation + "
             "fit up to that pack count).", "",
             "| material | packs | ΔE94 mean | p95 | max | seconds |",
             "|---|---:|---:|---:|---:|---:|"]
    for name, row in analysis["factored"].items():
        for entry in row["series"]:
            de = entry["de94"]
            lines.append(f"| {name} | {entry['packs']} | {de['mean']:.3f} | "
                         f"{de.get('p95', float('nan')):.3f} | {de.get('max', float('nan')):.3f}"
                         f" | {entry['seconds']:.2f} |")
    lines += ["", "| material | stored packs | bytes | total seconds | D65 sphere mean / p95 "
              "| FL2 sphere mean / p95 | reopened bit-identical |",
              "|---|---:|---:|---:|---|---|---|"]
    for name, row in analysis["factored"].items():
        fig = figures[name]["stats"]
        lines.append(f"| {name} | {row['packs']} | {row['bytes']} | {row['seconds']:.1f} | "
                     f"{fig['D65']['mean']:.3f} / {fig['D65']['p95']:.3f} | "
                     f"{fig['FL2']['mean']:.3f} / {fig['FL2']['p95']:.3f} | "
                     f"{'yes' if reload.get(name) else 'NO'} |")
    return lines


def picture_lines(figures: dict) -> list[str]:
    lines = ["", "## Pictures", ""]
    for name, fig in figures.items():
        lines += [f"### {name}", "", f"![{name} spheres]({fig['spheres']})", "",
                  f"![{name} error against packs]({fig['plot']})", "",
                  "ΔE94 against packs, as the Material panel shows it (orange: mean; blue: "
                  "95th percentile).", ""]
    return lines


def write_report(path: Path, analysis: dict, figures: dict, reload: dict,
                 build_seconds: float, total_seconds: float, sizes: DemoSizes,
                 section_lines: list[str]) -> None:
    """``report.md``: the factor-pack sections, then ``section_lines`` (GPU, EEVEE, PRT,
    BTF), then the run time."""
    lines = (analysis_lines(analysis, sizes) + error_lines(analysis, figures, reload, sizes)
             + picture_lines(figures) + section_lines)
    lines += [f"Scene built in {build_seconds:.1f} s; whole demo {total_seconds:.1f} s.", ""]
    path.write_text("\n".join(lines))
