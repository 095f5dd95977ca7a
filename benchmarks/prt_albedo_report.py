"""The PRT benchmark's report on the albedo texture's forms (core/prt/albedo_forms.py):
each timed against RGB PRT and its image compared with the exact layers', in one run."""

from __future__ import annotations

_FORM_NAMES = {"UNORM16": "16-bit layers", "BASIS": "basis", "EXACT": "exact layers"}


def albedo_form_lines(h: dict) -> list[str]:
    """The albedo texture's forms (core/prt/albedo_forms.py) timed and compared in the
    same run."""
    if "albedo" not in h:
        return []
    forms = h["albedo"]
    illuminants = list(forms["UNORM16"].get("delta_e94", {}))
    lines = [
        f"The headline draws the albedo as *Automatic* chose: **{forms['AUTO']['form']}**. "
        "Each form in the same run (frame time against RGB PRT on llvmpipe; colours of the "
        "drawn image against the exact layers' image, ΔE94 mean / p95 / max over the "
        "covered pixels):", "",
        "| albedo texture | layers × bytes a texel | spectral / RGB | "
        + " | ".join(f"ΔE94 {ill}" for ill in illuminants) + " |",
        "|---|---|---|" + "---|" * len(illuminants)]
    for form in ("UNORM16", "BASIS", "EXACT"):
        f = forms[form]
        errors = [f"{e['mean']:.4f} / {e['p95']:.4f} / {e['max']:.4f}"
                  for e in f.get("delta_e94", {}).values()] or ["0 (the reference)"] * len(
                      illuminants)
        what = _FORM_NAMES[form] + (f" ({f['rank']} weights)" if "rank" in f else "")
        lines.append(f"| {what} | {f['texture_layers']} × {f['texel_bytes']} | "
                     f"{f['ratio']:.2f} | " + " | ".join(errors) + " |")
    lines += ["", "On llvmpipe, a CPU rasteriser, the ranking is not a GPU's: "
              "docs/bench_gpu.md has the NVIDIA H200's.", ""]
    return lines
