"""Library builds (issue 20): throughput per executor, bytes and ΔE94 per material, and the
Asset Browser previews as one sheet.

The generated library of ``tests/helpers/library_sources.py`` (8 project .npz tables, a
MERL .binary, an RGL .bsdf), twice over in two source folders (20 files), factored at
the CLI's defaults (4 packs, 32 θ cells, basis 8). In the same run, with the same files:

* a plain sequential loop calling ``entry.factor_entry`` in this process (the baseline);
* ``build_library`` on the local process pool with 1 and with 2 workers;
* ``build_library`` on a Dask ``LocalCluster`` of 2 worker processes, with Dask's default
  worker environment and without its ``MALLOC_TRIM_THRESHOLD_`` (``DASK_ENVIRONMENTS``).

Each builds into a new folder. Materials per hour = files / wall seconds · 3600. The local
pool's worker start-up is inside the time; the LocalCluster is started before the clock,
as a cluster given with ``--scheduler`` is already running. Bytes per material: the entry's
factor file against the source file and against a neural BRDF of 675 float32 weights
(Sztrajman et al. 2021: 2,700 bytes).
The RGL file here is generated (no network): its size stands for the layout, not for
the RGL database's files. For those, RGL's own figure is used: "approximately 16KiB and
544KiB per channel for isotropic and anisotropic materials", spectral "360 (UV) - 1000nm
(NIR) range with ~4nm sample spacing" (rgl.epfl.ch/pages/lab/material-database), that is
161 channels per spectral file.

Writes ``docs/bench_library.md``/``.json`` and ``docs/images/library_previews.png``
(``--quick``: one source folder, 1 pack, 8 θ cells).

Usage::

    python -m benchmarks.library [--quick]
"""

from __future__ import annotations

import contextlib
import json
import os
import sys
import tempfile
import time
from pathlib import Path

from spectral_materials.core.library import layout
from spectral_materials.core.library.build import build_library
from spectral_materials.core.library.entry import factor_entry
from spectral_materials.core.library.settings import LibrarySettings
from spectral_materials.core.library.sources import find_sources

from . import harness

ROOT = Path(__file__).resolve().parents[1]
NEURAL_BRDF_BYTES = 675 * 4
#: RGL's stated bytes per channel (isotropic, anisotropic) and its spectral channel count
#: (360–1000 nm at ~4 nm), from the material database's FAQ (module doc).
RGL_BYTES_PER_CHANNEL = {"isotropic": 16 * 1024, "anisotropic": 544 * 1024}
RGL_SPECTRAL_CHANNELS = (1000 - 360) // 4 + 1
SHEET = ROOT / "docs" / "images" / "library_previews.png"
#: The environments a Dask nanny gives its workers: Dask's default, and the same without
#: MALLOC_TRIM_THRESHOLD_=65536, under which the 4-D RGL factorisation ran much slower.
_ONE_THREAD = {"OMP_NUM_THREADS": 1, "MKL_NUM_THREADS": 1, "OPENBLAS_NUM_THREADS": 1}
DASK_ENVIRONMENTS = {
    "Dask's default worker environment": {"MALLOC_TRIM_THRESHOLD_": 65536, **_ONE_THREAD},
    "without MALLOC_TRIM_THRESHOLD_": _ONE_THREAD,
}


def _sources(tmp: Path, copies: int) -> Path:
    sys.path.insert(0, str(ROOT / "tests" / "helpers"))
    from library_sources import make_sources, write_merl_file

    merl = write_merl_file(tmp / "red.binary")
    for copy in range(copies):
        make_sources(tmp / "src" / f"set{copy + 1}", merl)
    return tmp / "src"


def _sequential(sources: Path, settings: LibrarySettings) -> float:
    started = time.perf_counter()
    for source in find_sources([sources]):
        factor_entry(source.name, source.path.suffix, source.path.read_bytes(),
                     settings.as_dict())
    return time.perf_counter() - started


def _timed_build(sources: Path, out: Path, settings: LibrarySettings, **kw) -> dict:
    started = time.perf_counter()
    result = build_library([sources], out, settings, **kw)
    seconds = time.perf_counter() - started
    if result.failed:
        raise RuntimeError(f"benchmark files failed: {result.failed}")
    return {"executor": result.executor, "seconds": seconds, "written": len(result.written)}


@contextlib.contextmanager
def _environ_restored():
    """A LocalCluster's nannies write their workers' environment (OMP_NUM_THREADS=1,
    MALLOC_TRIM_THRESHOLD_) into this process's ``os.environ`` and leave it there
    (distributed 2026.8.0): every later cluster's workers, and this process's own
    threads, would inherit it."""
    saved = dict(os.environ)
    try:
        yield
    finally:
        os.environ.clear()
        os.environ.update(saved)


def throughput(sources: Path, tmp: Path, settings: LibrarySettings) -> tuple[list[dict], Path]:
    import dask
    from distributed import LocalCluster

    count = len(find_sources([sources]))
    rows = [{"executor": "sequential loop (this process)",
             "seconds": _sequential(sources, settings), "written": count}]
    rows.append(_timed_build(sources, tmp / "pool1", settings, workers=1))
    rows.append(_timed_build(sources, tmp / "pool2", settings, workers=2))
    for label, environ in DASK_ENVIRONMENTS.items():
        with _environ_restored(), \
                dask.config.set({"distributed.nanny.pre-spawn-environ": environ}), \
                LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                             dashboard_address=None) as cluster:
            row = _timed_build(sources, tmp / f"dask-{len(rows)}", settings,
                               scheduler=cluster.scheduler_address)
        row["executor"] = f"Dask LocalCluster, 2 worker processes, {label}"
        rows.append(row)
    base = rows[0]["seconds"]
    for row in rows:
        row["materials_per_hour"] = count / row["seconds"] * 3600.0
        row["speed_over_sequential"] = base / row["seconds"]
        harness.log(f"  {row['executor']}: {row['seconds']:.1f} s, "
                    f"{row['materials_per_hour']:.0f} materials/h")
    return rows, tmp / "pool2"


def preview_sheet(library: Path, out: Path, columns: int = 5) -> dict:
    """The library's Asset Library .blend written, its materials' previews read back from it
    and laid out with their names: what the Asset Browser shows."""
    import bpy
    import numpy as np
    from PIL import Image, ImageDraw

    from spectral_materials import blender as addon
    from spectral_materials.blender.library.asset_library import write_asset_library
    from spectral_materials.blender.library.catalogs import asset_names

    if not hasattr(bpy.types.Material, "spectral"):
        addon.register()
    written = write_asset_library(library)
    index = json.loads((library / layout.INDEX_FILE).read_text())
    catalogs = dict(zip(asset_names(index["entries"]),
                        (e["catalog"] for e in index["entries"])))
    with bpy.data.libraries.load(str(written.blend), assets_only=True) as (source, target):
        target.materials = list(source.materials)
    tiles = []
    for material in sorted(target.materials, key=lambda m: m.name):
        width, height = material.preview.image_size
        pixels = np.empty(width * height * 4, dtype=np.float32)
        material.preview.image_pixels_float.foreach_get(pixels)
        rgb = (pixels.reshape(height, width, 4)[::-1, :, :3] * 255).round().astype(np.uint8)
        catalog = catalogs[material.name]
        tiles.append((material.name, catalog, Image.fromarray(rgb).resize((width * 2,
                                                                              height * 2))))
    tile_w, tile_h = tiles[0][2].size
    label = 28
    rows = -(-len(tiles) // columns)
    sheet = Image.new("RGB", (columns * (tile_w + 8) + 8, rows * (tile_h + label + 8) + 8),
                      (40, 40, 40))
    draw = ImageDraw.Draw(sheet)
    for k, (name, catalog, tile) in enumerate(tiles):
        x = 8 + (k % columns) * (tile_w + 8)
        y = 8 + (k // columns) * (tile_h + label + 8)
        sheet.paste(tile, (x, y))
        draw.text((x, y + tile_h + 2), name, fill=(230, 230, 230))
        draw.text((x, y + tile_h + 14), catalog, fill=(150, 150, 150))
    out.parent.mkdir(parents=True, exist_ok=True)
    sheet.save(out)
    return {"blend": written.blend.name, "materials": written.materials,
            "catalogs": written.catalogs, "sheet": os.path.relpath(out, ROOT)}


def run(quick: bool, sheet: Path) -> dict:
    started = time.perf_counter()
    settings = (LibrarySettings(packs=1, theta_cells=8, basis=4) if quick
                else LibrarySettings())
    with tempfile.TemporaryDirectory(prefix="sm-bench-library-") as tmp:
        tmp = Path(tmp)
        sources = _sources(tmp, 1 if quick else 2)
        rows, library = throughput(sources, tmp, settings)
        index = json.loads((library / layout.INDEX_FILE).read_text())
        entries = [{"name": e["name"], "catalog": e["catalog"], "format": e["format"],
                    "bytes": e["bytes"], "model_bytes": e["model_bytes"],
                    "file_bytes": e["file_bytes"], "de94": e["de94"], "packs": e["packs"],
                    "seconds": e["seconds"]} for e in index["entries"]
                   if e["catalog"].startswith("src/set1")]
        previews = preview_sheet(library, sheet)
    return {"date": harness.date_stamp(), "command": harness.command_line("library"),
            "commit": harness.commit_of(), "cpu": harness.cpu_model(),
            "cpu_count": os.cpu_count(), "quick": quick, "settings": settings.as_dict(),
            "files": rows[0]["written"], "throughput": rows, "entries": entries,
            "neural_brdf_bytes": NEURAL_BRDF_BYTES, "previews": previews,
            "rgl_spectral_file_bytes": {kind: per_channel * RGL_SPECTRAL_CHANNELS
                                        for kind, per_channel in RGL_BYTES_PER_CHANNEL.items()},
            "seconds": time.perf_counter() - started}


def markdown(r: dict) -> list[str]:
    s = r["settings"]
    lines = ["# Spectral material library builds", "",
             f"Printed by `{r['command']}` on {r['date']} at commit {r['commit']}, "
             f"{r['cpu']}, {r['cpu_count']} cores"
             f"{' (quick run: a smoke test)' if r['quick'] else ''}. "
             f"{r['files']} files (benchmarks/library.py says which), {s['packs']} packs, "
             f"{s['theta_cells']} θ cells, basis {s['basis']}.", "",
             "## Throughput (same files, same run)", "",
             "The local pool's worker start-up (spawned processes importing NumPy, SciPy and "
             "colour-science) is inside its time; the LocalCluster is started before the "
             "clock, as a cluster given with `--scheduler` is already running.", "",
             "| executor | seconds | materials per hour | × sequential |", "|---|---|---|---|"]
    for row in r["throughput"]:
        lines.append(f"| {row['executor']} | {row['seconds']:.1f} | "
                     f"{row['materials_per_hour']:,.0f} | {row['speed_over_sequential']:.2f} |")
    lines += ["", "## Bytes and colour error per material", "",
              f"Factor file (.npz, float32 factors and metadata) against the source file and "
              f"against a neural BRDF of 675 float32 weights ({r['neural_brdf_bytes']:,} "
              "bytes). ΔE94 under D65 at the protocol's random pairs against the file's own "
              "data.", "",
              f"RGL's own spectral files, by its FAQ's figures: "
              f"{r['rgl_spectral_file_bytes']['isotropic']:,} bytes isotropic and "
              f"{r['rgl_spectral_file_bytes']['anisotropic']:,} anisotropic (module doc); "
              "the last column is against the isotropic one.", "",
              "| material | source | file bytes | factor bytes | × file | × neural | × RGL "
              "isotropic | ΔE94 mean / p95 / max |", "|---|---|---|---|---|---|---|---|"]
    for e in r["entries"]:
        de = e["de94"]
        lines.append(f"| {e['name']} | {e['format'].split(' (')[0]} | {e['file_bytes']:,} | "
                     f"{e['bytes']:,} | {e['bytes'] / e['file_bytes']:.4f} | "
                     f"{e['bytes'] / r['neural_brdf_bytes']:.2f} | "
                     f"{e['bytes'] / r['rgl_spectral_file_bytes']['isotropic']:.4f} | "
                     f"{de['mean']:.3f} / "
                     f"{de['p95']:.3f} / {de['max']:.2f} |")
    p = r["previews"]
    lines += ["", "## The Asset Browser's previews", "",
              f"{p['materials']} materials in {p['catalogs']} catalogs, read back from "
              f"`{p['blend']}` (the .blend `library import` writes):", "",
              f"![previews](images/{Path(p['sheet']).name})", ""]
    return lines


def main(argv: list[str] | None = None) -> None:
    parser = harness.parser(__doc__, quick_help="one source folder, 1 pack, 8 θ cells",
                            out_help="write bench_library.md/.json here, not docs/")
    args = parser.parse_args(argv)
    sheet = SHEET if not args.quick else Path(args.out) / "library_previews_quick.png"
    results = run(args.quick, sheet)
    harness.publish(args.out, "library", args.quick, results, markdown(results))


if __name__ == "__main__":
    main()
