"""The main job: build the demo scene, analyse and factor it headless, save and report.

Writes ``out/demo.blend`` and ``out/report.md`` (with ``out/images/``): the scene
analysis (basis size, what was left out), and per material the error against time
table, the error-against-packs plot the panel shows, and sphere pictures under D65
and FL2 (5 nm reference | stored factors | ΔE94) at 60° incidence (``demos.brdf``); then
the GPU section (``demos.gpu_draw``): the scene drawn offscreen by the spectral shaders
next to its 5 nm reference and ΔE94 map, the protocol sphere per material through the
GPU, and the frame time against an RGB baseline; the EEVEE section (``demos.eevee``); the
spectral PRT section (``demos.prt``: the ColorChecker under FL4 against RGB PRT and a
5 nm reference, the Metacow); the BTF section (``demos.btf``: a corduroy cushion drawn
from per-view reflectance fields, and the BTF paper's error table). Everything is
measured in this run; the report says how.

Run as ``scripts/demo`` (sets up the environment), ``python scripts/demo.py`` or
``python -m demos`` from the repository root.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import bpy

from spectral_materials import blender as addon
from spectral_materials.blender.brdf import jobs
from spectral_materials.core.progress import TerminalProgress

from . import btf, eevee, gpu_draw, prt
from .backend import CHOICES
from .brdf import REPO, factor_figures, reload_check
from .report import write_report
from .scene import build_scene
from .sizes import DemoSizes, sizes_for


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    # No abbreviations: --gpu-backend is read before this parser runs (demos/backend.py).
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("--out", type=Path, default=REPO / "out")
    parser.add_argument("--theta-cells", type=int, default=None,
                        help="θ cells per 90° for every material (default 64, quick 12)")
    parser.add_argument("--quick", action="store_true",
                        help="every section at small sizes (a few minutes): proves the main "
                        "job runs; its figures are not results")
    parser.add_argument("--quiet", action="store_true")
    parser.add_argument("--gpu-backend", choices=CHOICES, default="auto",
                        help="auto (default): OpenGL on a Linux machine without a GPU device "
                        "(lavapipe's Vulkan aborts a few %% of processes, docs/vulkan.md), "
                        "else Blender's choice; must be decided before bpy is imported, "
                        "which scripts/demo.py and python -m demos do")
    return parser.parse_args(argv)


def gpu_sections(analysis: dict, out: Path, blend: Path, sizes: DemoSizes) -> dict:
    """The GPU, EEVEE, PRT and BTF sections, in the order the report shows them (the
    PRT and BTF sections load their own scenes, so they come last)."""
    scene = bpy.context.scene
    names = list(analysis["factored"])
    gpu_scene, comparison = gpu_draw.scene_figure(scene, out / "images" / "gpu_scene.png",
                                                  *sizes.scene_px)
    spheres = gpu_draw.sphere_table(names, sizes.sphere_px)
    frame = gpu_draw.frame_time(scene, *sizes.frame_px, frames=sizes.frames,
                                repeats=sizes.repeats)
    eevee_spheres = eevee.sphere_table(names, sizes.sphere_px)
    eevee_section = eevee.eevee_section(scene, comparison, out / "images")
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))        # with the EEVEE node groups
    prt_section = prt.prt_section(out / "images", sizes)   # its own scenes, saved apart
    btf_section = btf.btf_section(out / "images", sizes)   # its own scene too
    return {"gpu_scene": gpu_scene, "gpu_spheres": spheres, "frame": frame,
            "eevee_spheres": eevee_spheres, "eevee": eevee_section, "prt": prt_section,
            "btf": btf_section}


def section_lines(sections: dict, sizes: DemoSizes) -> list[str]:
    return (gpu_draw.report_lines(sections["gpu_scene"], sections["gpu_spheres"],
                                  sections["frame"], sizes.sphere_px)
            + eevee.report_lines(sections["eevee"])
            + eevee.sphere_lines(sections["eevee_spheres"], sizes.sphere_px)
            + prt.report_lines(sections["prt"])
            + btf.report_lines(sections["btf"]))


def _cases(rows: dict) -> list[dict]:
    """Sphere-table rows keyed by (material, illuminant, incidence), as JSON records."""
    return [{"material": k[0], "illuminant": k[1], "incidence": k[2], **v}
            for k, v in rows.items()]


def write_json(path: Path, analysis: dict, figures: dict, reload: dict, sections: dict,
               sizes: DemoSizes, total: float) -> None:
    path.write_text(json.dumps(
        {"analysis": analysis, "figures": figures, "reload_bit_identical": reload,
         "gpu_scene": sections["gpu_scene"], "frame": sections["frame"],
         "eevee": sections["eevee"], "prt": sections["prt"], "btf": sections["btf"],
         "eevee_spheres": _cases(sections["eevee_spheres"]),
         "gpu_spheres": _cases(sections["gpu_spheres"]),
         "sizes": sizes.__dict__, "seconds": total}, indent=2, default=str))


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    sizes = sizes_for(args.quick, args.theta_cells)
    start = time.perf_counter()
    out = args.out.resolve()
    (out / "images").mkdir(parents=True, exist_ok=True)
    addon.register()
    build_scene(sizes)
    built = time.perf_counter() - start
    progress = None if args.quiet else TerminalProgress()
    try:
        result = jobs.factor_scene(bpy.context.scene, progress)
    except (ValueError, OSError) as exc:
        print(f"demo: error: {exc}", file=sys.stderr)
        return 1
    analysis = result.analysis()
    print(analysis["summary"])
    blend = out / "demo.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    figures, expected = factor_figures(list(analysis["factored"]), out, sizes.sphere_px)
    reload = reload_check(blend, expected, out)
    (out / "reload.npz").unlink(missing_ok=True)
    sections = gpu_sections(analysis, out, blend, sizes)
    total = time.perf_counter() - start
    write_report(out / "report.md", analysis, figures, reload, built, total, sizes,
                 section_lines(sections, sizes))
    write_json(out / "report.json", analysis, figures, reload, sections, sizes, total)
    print(f"wrote {blend}, {out / 'report.md'} in {total:.1f} s; reopened bit-identical: "
          f"{all(reload.values())}")
    return 0 if all(reload.values()) else 1


def run() -> None:
    """Run :func:`main` and leave the process as Blender's GPU context needs."""
    from spectral_materials.blender.gpu.context import exit_process

    exit_process(main())


if __name__ == "__main__":
    run()
