"""Example pictures of the panel plots in ``spectral_materials.core.raster_plots``.

Writes ``docs/images/plot_error_example.png`` (mean and 95th-percentile ΔE94 against the
number of factor packs, with the target dashed) and ``docs/images/plot_spectrum_example.png``
(CIE FL2, filled with the spectral colours), at the plots' default sizes.

The error data are case b of ``docs/bench_factor.json`` (joint factoring, ΔE94 over the
20 000 random direction pairs under D65) when that file has it, else the same figures as
recorded here. The plots are linear RGB with row 0 at the bottom (Blender's order); a
PNG is sRGB with row 0 at the top, so rows are flipped and the sRGB transfer function is
applied, which is what Blender's standard view shows.

Usage::

    python scripts/make_plot_examples.py
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import imageio.v3 as iio
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from spectral_materials.core import raster_plots
from spectral_materials.core.colour import spectra
from spectral_materials.core.colour.pipeline import srgb_encode

# docs/bench_factor.json, case b (Ashikhmin–Shirley), joint, pairs_D65, as of writing.
FALLBACK = {
    "packs": [1, 2, 4, 8, 16, 22, 32, 48],
    "mean": [3.5347, 1.4324, 0.4589, 0.1477, 0.0706, 0.0572, 0.0534, 0.0533],
    "p95": [5.3631, 3.1936, 1.0511, 0.3843, 0.1596, 0.1137, 0.1060, 0.1058],
    "target": 0.5,
}


def error_data() -> dict:
    """Mean/p95 ΔE94 against packs from the benchmark results, or the recorded copy."""
    try:
        case = json.loads((ROOT / "docs" / "bench_factor.json").read_text())["cases"]["b"]
        rows = case["methods"]["joint"]
        return {"packs": [r["packs"] for r in rows],
                "mean": [r["de94"]["pairs_D65"]["mean"] for r in rows],
                "p95": [r["de94"]["pairs_D65"]["p95"] for r in rows],
                "target": case["target"]["mean"]}
    except (OSError, KeyError, TypeError, ValueError):
        return FALLBACK


def to_png(image: np.ndarray, path: Path) -> None:
    """Write a linear, bottom-row-first RGBA plot as an 8-bit sRGB PNG."""
    rgb = srgb_encode(image[::-1, :, :3])
    path.parent.mkdir(parents=True, exist_ok=True)
    iio.imwrite(path, np.round(rgb * 255.0).astype(np.uint8))
    print(f"wrote {path.relative_to(ROOT)} ({image.shape[1]}×{image.shape[0]})")


def main() -> None:
    data = error_data()
    out = ROOT / "docs" / "images"
    to_png(raster_plots.plot_error_against_packs(data["packs"], data["mean"], data["p95"],
                                                 target=data["target"]),
           out / "plot_error_example.png")
    wl = spectra.wavelength_grid(380.0, 780.0, 1.0)
    to_png(raster_plots.plot_spectrum(wl, spectra.illuminant("FL2", wl)),
           out / "plot_spectrum_example.png")


if __name__ == "__main__":
    main()
