"""Measured-data benchmark (issue 6 §3): a MERL file through Smits uplift into factor packs.

1. Write a MERL ``.binary`` from an analytic glossy BRDF in RGB: Ashikhmin–Shirley
   nu = nv = 32, Rs = 0.05, diffuse = linear sRGB of ColorChecker patch 12 (D65).
2. Read it back (:func:`read_merl`, Smits 1999 uplift).
3. Tabulate ``f·cosθi`` on io_iso 90 × 180 × 90 at 61 wavelengths (400–700 nm, 5 nm),
   compress the spectra onto 8 basis vectors, factor into 1, 2, 4, 8, 16 packs.

Reference (shared/PROTOCOL.md, "the full-resolution table (measured)"): the MERL table
read back and uplifted by Smits, evaluated on the protocol's 380–780 nm grid. MERL holds no
spectral information, so the analytic *spectral* model is not a reference the pipeline could
reach; it is reported as a separate row (uplift loss), as is the analytic RGB model uplifted
by Smits pointwise (the table's nearest-cell binning), the same in the table's cells
(core/brdf/measured_cells.py: what a model drawn in cells can reach), and the table itself
on 400–700 nm (the band limit of the factored models). The packs are fitted twice: drawn
smooth, and drawn in the table's cells (``cells=``, the add-on's default for MERL files).

Usage::

    python -m benchmarks.measured            # full size
    python -m benchmarks.measured --quick    # 30 × 60 × 30, a smoke test
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import colour
import numpy as np

from spectral_materials.core.brdf import measured_cells, metrics, models
from spectral_materials.core.brdf.factor import factor_brdf_series
from spectral_materials.core.colour import pipeline as colour_pipeline, spectra, uplift
from spectral_materials.core.formats import merl

from . import harness

PACKS = [1, 2, 4, 8, 16]
WAVELENGTHS = np.arange(400.0, 701.0, 5.0)
PATCH = 12


def patch_rgb(patch: int) -> np.ndarray:
    """Linear sRGB of a ColorChecker patch under D65 (white → Y = 1)."""
    wl = spectra.WAVELENGTHS_REFERENCE
    w = colour_pipeline.xyz_weights("D65", wl)
    xyz = spectra.colorchecker(patch, wl) @ w
    # the weights make f = 1/π (a white Lambertian) give Y = 1: a reflectance needs 1/π
    return colour.XYZ_to_RGB(xyz / np.pi, colour.RGB_COLOURSPACES["sRGB"],
                             apply_cctf_encoding=False)


class RGBModel:
    """Ashikhmin–Shirley in RGB (f = Rd·D + S, linear in Rd) and its Smits uplift."""

    def __init__(self, rd_rgb: np.ndarray):
        self.rd = np.asarray(rd_rgb, dtype=np.float64)
        self.one = models.AshikhminShirley(nu=32, nv=32, diffuse=1.0, specular=0.05)
        self.zero = models.AshikhminShirley(nu=32, nv=32, diffuse=0.0, specular=0.05)
        self.smits = uplift.SmitsUplift()

    def rgb(self, wi, wo):
        s = self.zero(wi, wo, np.array([550.0]))
        return (self.one(wi, wo, np.array([550.0])) - s) * self.rd + s

    def __call__(self, wi, wo, wavelengths):
        return self.smits(self.rgb(wi, wo), wavelengths)


class OnGrid:
    """Any spectral BRDF seen through a wavelength grid (for the protocol's ``xyz``)."""

    def __init__(self, brdf, wavelengths):
        self.brdf, self.wavelengths = brdf, np.asarray(wavelengths)

    def xyz(self, wi, wo, illuminant="D65"):
        w = colour_pipeline.xyz_weights(illuminant, self.wavelengths)
        return (self.brdf(wi, wo, self.wavelengths) * np.clip(wi[:, 2:3], 0, None)) @ w


class InCells(OnGrid):
    """A BRDF seen through a grid, evaluated in a measured table's cells."""

    def __init__(self, on_grid: OnGrid, cells):
        super().__init__(on_grid.brdf, on_grid.wavelengths)
        self.cells = cells

    def xyz(self, wi, wo, illuminant="D65"):
        w = colour_pipeline.xyz_weights(illuminant, self.wavelengths)
        f = measured_cells.in_cells(lambda a, b: self.brdf(a, b, self.wavelengths), wi, wo,
                                    cosine_weighted=False, shape=self.cells)
        return (f * np.clip(wi[:, 2:3], 0, None)) @ w


def merl_round_trip(analytic: RGBModel) -> tuple[object, dict]:
    """Write the analytic model as a MERL file, read it back (Smits), uplift the table:
    (the measured BRDF, the seconds of each step)."""
    timings = {}
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "as_patch12.binary"
        t = time.perf_counter()
        merl.write_merl(path, merl.merl_table_from_brdf(analytic.rgb))
        timings["write_seconds"] = time.perf_counter() - t
        t = time.perf_counter()
        brdf = merl.read_merl(path)
        timings["read_seconds"] = time.perf_counter() - t
    t = time.perf_counter()
    brdf.spectral_table(WAVELENGTHS)
    timings["smits_full_table_seconds"] = time.perf_counter() - t
    return brdf, timings


def control_rows(brdf, analytic: RGBModel, reference: metrics.ProtocolError) -> list[dict]:
    """The band limit, the binning and the uplift loss, against the measured table."""
    spectral_truth = models.AshikhminShirley(nu=32, nv=32,
                                             diffuse=spectra.colorchecker_spectrum(PATCH),
                                             specular=0.05)
    return [
        {"name": "table on 400–700 nm (band limit)",
         **reference.stats(OnGrid(brdf, WAVELENGTHS))},
        {"name": "analytic RGB + Smits, no table (binning)",
         **reference.stats(OnGrid(analytic, spectra.WAVELENGTHS_REFERENCE))},
        {"name": "analytic spectral model (RGB + uplift loss)",
         **reference.stats(OnGrid(spectral_truth, spectra.WAVELENGTHS_REFERENCE))},
        {"name": "analytic RGB + Smits in the table's cells (measured_cells)",
         **reference.stats(InCells(OnGrid(analytic, spectra.WAVELENGTHS_REFERENCE),
                                   brdf.lookup_cells))},
    ]


def markdown(result: dict) -> list[str]:
    lines = [
        "# Measured data: MERL → Smits → factor packs", "",
        f"Ashikhmin–Shirley nu = nv = 32, Rs = 0.05, Rd = linear sRGB of ColorChecker patch "
        f"{PATCH}, written as a MERL file and read back; io_iso {tuple(result['resolution'])}, "
        "61 wavelengths 400–700 nm, 8 basis vectors. ΔE94 under D65 at the protocol's random "
        "pairs against the measured table uplifted by Smits (380–780 nm).", "",
        "| row | ΔE94 mean | p95 | max | rel. RMS | factor s | bytes |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in result["rows"]:
        def fmt(key, spec, r=r):
            v = r.get(key)
            return "" if v is None else format(v, spec)
        lines.append(f"| {r['name']} | {fmt('mean', '.3f')} | {fmt('p95', '.3f')} | "
                     f"{fmt('max', '.2f')} | {fmt('relative_rms', '.4f')} | "
                     f"{fmt('factor_seconds', '.1f')} | {fmt('bytes', ',')} |")
    lines += ["", "Timings (s): " + ", ".join(f"{k} {v:.2f}"
                                              for k, v in result["timings"].items()), ""]
    return lines


def main(argv: list[str] | None = None) -> None:
    parser = harness.parser(__doc__, quick_help="30 × 60 × 30, a smoke test",
                            out_help="write bench_measured.md/.json here instead of docs/")
    args = parser.parse_args(argv)
    s = 3 if args.quick else 1
    resolution = (90 // s, 180 // s, 90 // s)
    rd = patch_rgb(PATCH)
    analytic = RGBModel(rd)
    brdf, timings = merl_round_trip(analytic)
    reference = metrics.ProtocolError(brdf)  # the measured table, 380–780 nm
    rows = control_rows(brdf, analytic, reference)
    t = time.perf_counter()
    series = factor_brdf_series(brdf, pack_counts=PACKS, parameterization="io", isotropic=True,
                                resolution=resolution, wavelengths=WAVELENGTHS,
                                spectral_basis=8)
    timings["factor_total_seconds"] = time.perf_counter() - t
    t = time.perf_counter()
    in_cells = factor_brdf_series(brdf, pack_counts=PACKS, parameterization="io", isotropic=True,
                                  resolution=resolution, wavelengths=WAVELENGTHS,
                                  spectral_basis=8, cells=brdf.lookup_cells)
    timings["factor_in_cells_total_seconds"] = time.perf_counter() - t
    for label, models_ in (("", series), (", in cells", in_cells)):
        for model in models_:
            rep = model.report
            rows.append({"name": f"{rep.get('packs')} packs{label}", "packs": rep.get("packs"),
                         "factor_seconds": rep.get("factor_seconds"), "bytes": model.nbytes,
                         "relative_rms": rep.get("relative_rms"), **reference.stats(model)})
    result = {"resolution": list(resolution), "wavelengths": [400, 700, 61], "basis": 8,
              "patch": PATCH, "rd_linear_srgb": rd.tolist(), "timings": timings,
              "defects": brdf.defects, "rows": rows}
    harness.publish(args.out, "measured", args.quick, result, markdown(result), indent=2)


if __name__ == "__main__":
    main()
