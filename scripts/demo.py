#!/usr/bin/env python3
"""The main job: build the demo scene, analyse and factor it headless, save and report.

Writes ``out/demo.blend`` and ``out/report.md`` (with ``out/images/``): the scene
analysis (basis size, what was left out), and per material the error against time
table, the error-against-packs plot the panel shows, and sphere pictures under D65
and FL2 (5 nm reference | stored factors | ΔE94) at 60° incidence; then the GPU
section (``demo_gpu.py``): the scene drawn offscreen by the spectral shaders next to
its 5 nm reference and ΔE94 map, the protocol sphere per material through the GPU,
and the frame time against an RGB baseline; the EEVEE section (``demo_eevee.py``); the
spectral PRT section (``demo_prt.py``: the ColorChecker under FL4 against RGB PRT and a
5 nm reference, the Metacow); the BTF section (``demo_btf.py``: a corduroy cushion drawn
from per-view reflectance fields, and the BTF paper's error table). Everything is
measured in this run; the report says how.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "scripts"))

import bpy
import demo_btf
import demo_eevee  # noqa: E402  (scripts/, next to this file)
import demo_gpu
import demo_prt
from demo_sizes import DemoSizes, sizes_for

from spectral_materials import blender as addon
from spectral_materials.blender.brdf import jobs, sources, storage
from spectral_materials.blender.eevee import apply as eevee
from spectral_materials.core.brdf import metrics
from spectral_materials.core.colour import pipeline as colour_pipeline
from spectral_materials.core.colour import spectra
from spectral_materials.core.progress import TerminalProgress

# name: (model, scalar parameters, diffuse patch, specular constant, packs)
MATERIALS = {
    "Red clay": ("OREN_NAYAR", {"sigma": 0.52}, "15", None, 2),
    "Blue felt": ("OREN_NAYAR", {"sigma": 0.3}, "13", None, 2),
    "Orange gloss": ("ASHIKHMIN_SHIRLEY", {"nu": 32.0, "nv": 32.0}, "12", 0.05, 8),
    "Teal brushed": ("ASHIKHMIN_SHIRLEY", {"nu": 8.0, "nv": 64.0}, "6", 0.05, 16),
}


def build_scene(sizes: DemoSizes) -> None:
    """Spheres and a Suzanne with ColorChecker materials, a D65 sun and an FL2 point light."""
    bpy.ops.wm.read_homefile(use_factory_startup=True)
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)
    for material in list(bpy.data.materials):
        bpy.data.materials.remove(material)
    placements = {"Red clay": (-3.0, 0.0, 1.0), "Blue felt": (-1.0, 0.0, 1.0),
                  "Orange gloss": (1.0, 0.0, 1.0), "Teal brushed": (3.2, 0.0, 1.0)}
    for name, (model, scalars, patch, specular, packs) in MATERIALS.items():
        if name == "Teal brushed":
            bpy.ops.mesh.primitive_monkey_add(location=placements[name])
        else:
            bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24,
                                                 location=placements[name], radius=0.9)
        bpy.ops.object.shade_smooth()
        obj = bpy.context.active_object
        obj.name = name.split()[1].capitalize() if name != "Teal brushed" else "Suzanne"
        if sizes.max_packs is not None:
            packs = min(packs, sizes.max_packs)
        obj.data.materials.append(_material(name, model, scalars, patch, specular, packs,
                                            sizes.theta_cells))
    # Left out on purpose: a hidden object and a material nobody uses.
    bpy.ops.mesh.primitive_cube_add(location=(0.0, 3.0, 1.0))
    spare = bpy.context.active_object
    spare.name = "Spare cube"
    spare.data.materials.append(_material("Spare", "LAMBERT", {}, "2", None, 1,
                                         sizes.theta_cells))
    spare.hide_render = True
    spare.hide_set(True)
    _material("Unused swatch", "LAMBERT", {}, "7", None, 1, sizes.theta_cells)
    bpy.ops.mesh.primitive_plane_add(size=20.0)
    sun = bpy.data.lights.new("Sun D65", "SUN")
    sun.energy = 3.0
    sun.spectral.illuminant = "D65"
    sun_obj = bpy.data.objects.new("Sun D65", sun)
    sun_obj.rotation_euler = (0.7, 0.2, 0.5)
    shop = bpy.data.lights.new("Shop FL2", "POINT")
    shop.energy = 500.0
    shop.spectral.illuminant = "FL2"
    shop_obj = bpy.data.objects.new("Shop FL2", shop)
    shop_obj.location = (2.0, -3.0, 4.0)
    for obj in (sun_obj, shop_obj):
        bpy.context.scene.collection.objects.link(obj)
    # Only the two lights: the reference, the draw handler and EEVEE then see the same light.
    bpy.context.scene.world = eevee.black_world("Black")
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location = (0.0, -11.0, 3.5)
    camera.rotation_euler = (1.33, 0.0, 0.0)
    bpy.context.scene.collection.objects.link(camera)
    bpy.context.scene.camera = camera


def _material(name, model, scalars, patch, specular, packs, theta_cells):
    material = bpy.data.materials.new(name)
    s = material.spectral
    s.enabled = True
    s.model = model
    for key, value in scalars.items():
        setattr(s, key, value)
    s.diffuse.kind = "COLORCHECKER"
    s.diffuse.patch = patch
    if specular is not None:
        s.specular.kind = "CONSTANT"
        s.specular.constant = specular
    s.packs = packs
    s.theta_cells = theta_cells
    return material


def _png(pixels_bottom_up: np.ndarray, path: Path) -> None:
    import imageio.v3 as iio

    rgb = colour_pipeline.srgb_encode(np.clip(pixels_bottom_up[::-1, :, :3], 0.0, 1.0))
    iio.imwrite(path, (np.clip(rgb, 0, 1) * 255 + 0.5).astype(np.uint8))


def sphere_figure(name: str, material, path: Path, size: int = 128) -> dict:
    """Reference | stored factors | ΔE94 under D65 and FL2, light at 60°."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    brdf = sources.material_inputs(material).brdf()
    model = storage.load_factored(material)
    view = metrics.sphere_directions(60.0, size)
    fig, axes = plt.subplots(2, 3, figsize=(8.4, 5.6))
    stats = {}
    for row, illum in enumerate(("D65", "FL2")):
        ref = metrics.reference_xyz(brdf, view.wi, view.wo, illum)
        test = model.xyz(view.wi, view.wo, illum)
        white = colour_pipeline.white_xyz(illum, spectra.WAVELENGTHS_REFERENCE)
        de = metrics.delta_e94_image(ref, test, illum)
        stats[illum] = {"mean": float(de.mean()), "p95": float(np.percentile(de, 95)),
                        "max": float(de.max())}
        for col, xyz in enumerate((ref, test)):
            image = np.zeros((size, size, 3))
            image[view.mask] = colour_pipeline.xyz_to_display(xyz, white)
            axes[row, col].imshow(image)
        heat = np.full((size, size), np.nan)
        heat[view.mask] = de
        shown = axes[row, 2].imshow(heat, cmap="magma", vmin=0.0,
                                    vmax=max(1.0, float(np.nanmax(heat))))
        fig.colorbar(shown, ax=axes[row, 2], fraction=0.046)
        axes[row, 0].set_title(f"{illum}: reference (5 nm)", fontsize=8)
        axes[row, 1].set_title(f"{illum}: {model.packs} packs, {model.spectral_size} coeffs",
                               fontsize=8)
        axes[row, 2].set_title(f"ΔE94 mean {de.mean():.2f}", fontsize=8)
    for ax in axes.ravel():
        ax.axis("off")
    fig.suptitle(f"{name}, light at 60°", fontsize=10)
    fig.savefig(path, dpi=80, bbox_inches="tight")
    plt.close(fig)
    return stats


_RELOAD = textwrap.dedent("""
    import sys, numpy as np, bpy
    sys.path.insert(0, sys.argv[3])
    from spectral_materials import blender as addon
    from spectral_materials.blender import storage
    from spectral_materials.core.metrics import random_direction_pairs
    addon.register()
    bpy.ops.wm.open_mainfile(filepath=sys.argv[1])
    wi, wo = random_direction_pairs(5000)
    values = {m.name: storage.load_factored(m).evaluate(wi, wo)
              for m in bpy.data.materials if m.spectral.result.image is not None}
    np.savez(sys.argv[2], **values)
""")


def reload_check(blend: Path, expected: dict, scratch: Path) -> dict:
    """Reopen the saved .blend in a fresh process; compare every material bit for bit."""
    out = scratch / "reload.npz"
    subprocess.run([sys.executable, "-c", _RELOAD, str(blend), str(out), str(REPO)],
                   check=True, capture_output=True, timeout=600)
    with np.load(out) as data:
        return {name: bool(name in data.files and np.array_equal(data[name], values))
                for name, values in expected.items()}


def write_report(path: Path, analysis: dict, figures: dict, reload: dict,
                 build_seconds: float, total_seconds: float, sizes: DemoSizes,
                 gpu_lines: list[str]) -> None:
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
    lines += ["", "## Error against time", "",
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
    lines += ["", "## Pictures", ""]
    for name, fig in figures.items():
        lines += [f"### {name}", "", f"![{name} spheres]({fig['spheres']})", "",
                  f"![{name} error against packs]({fig['plot']})", "",
                  "ΔE94 against packs, as the Material panel shows it (orange: mean; blue: "
                  "95th percentile).", ""]
    lines += gpu_lines
    lines += [f"Scene built in {build_seconds:.1f} s; whole demo {total_seconds:.1f} s.", ""]
    path.write_text("\n".join(lines))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=REPO / "out")
    parser.add_argument("--theta-cells", type=int, default=None,
                        help="θ cells per 90° for every material (default 64, quick 12)")
    parser.add_argument("--quick", action="store_true",
                        help="every section at small sizes (a few minutes): proves the main "
                        "job runs; its figures are not results")
    parser.add_argument("--quiet", action="store_true")
    args = parser.parse_args()
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
    figures, expected = {}, {}
    wi, wo = metrics.random_direction_pairs(5000)
    for name in analysis["factored"]:
        material = bpy.data.materials[name]
        slug = name.lower().replace(" ", "_")
        width, height = material.spectral.result.plot.size
        plot_pixels = np.empty(width * height * 4, np.float32)
        material.spectral.result.plot.pixels.foreach_get(plot_pixels)
        _png(plot_pixels.reshape(height, width, 4), out / "images" / f"plot_{slug}.png")
        stats = sphere_figure(name, material, out / "images" / f"spheres_{slug}.png",
                              sizes.sphere_px)
        figures[name] = {"plot": f"images/plot_{slug}.png",
                         "spheres": f"images/spheres_{slug}.png", "stats": stats}
        expected[name] = storage.load_factored(material).evaluate(wi, wo)
    reload = reload_check(blend, expected, out)
    (out / "reload.npz").unlink(missing_ok=True)
    scene = bpy.context.scene
    gpu_scene, comparison = demo_gpu.scene_figure(scene, out / "images" / "gpu_scene.png",
                                                  *sizes.scene_px)
    spheres = demo_gpu.sphere_table(list(analysis["factored"]), sizes.sphere_px)
    frame = demo_gpu.frame_time(scene, *sizes.frame_px, frames=sizes.frames,
                                repeats=sizes.repeats)
    eevee_spheres = demo_eevee.sphere_table(list(analysis["factored"]), sizes.sphere_px)
    eevee_section = demo_eevee.eevee_section(scene, comparison, out / "images")
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))        # with the EEVEE node groups
    prt_section = demo_prt.prt_section(out / "images", sizes)   # its own scenes, saved apart
    btf_section = demo_btf.btf_section(out / "images", sizes)   # its own scene too
    total = time.perf_counter() - start
    write_report(out / "report.md", analysis, figures, reload, built, total, sizes,
                 demo_gpu.report_lines(gpu_scene, spheres, frame, sizes.sphere_px)
                 + demo_eevee.report_lines(eevee_section)
                 + demo_eevee.sphere_lines(eevee_spheres, sizes.sphere_px)
                 + demo_prt.report_lines(prt_section)
                 + demo_btf.report_lines(btf_section))
    (out / "report.json").write_text(json.dumps(
        {"analysis": analysis, "figures": figures, "reload_bit_identical": reload,
         "gpu_scene": gpu_scene, "frame": frame, "eevee": eevee_section,
         "prt": prt_section, "btf": btf_section,
         "eevee_spheres": [{"material": k[0], "illuminant": k[1], "incidence": k[2], **v}
                           for k, v in eevee_spheres.items()],
         "gpu_spheres": [{"material": k[0], "illuminant": k[1], "incidence": k[2], **v}
                         for k, v in spheres.items()],
         "sizes": sizes.__dict__, "seconds": total}, indent=2, default=str))
    print(f"wrote {blend}, {out / 'report.md'} in {total:.1f} s; reopened bit-identical: "
          f"{all(reload.values())}")
    return 0 if all(reload.values()) else 1


if __name__ == "__main__":
    from spectral_materials.blender.gpu.context import exit_process

    exit_process(main())
