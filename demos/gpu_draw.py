"""The demo's GPU section: the scene drawn by the spectral shaders against 5 nm, and the
protocol sphere per material through the GPU path. Called by ``demos.main``."""

from __future__ import annotations

import time
from pathlib import Path

import bpy
import numpy as np

from spectral_materials.blender.brdf import scene_reference, sources, storage
from spectral_materials.blender.brdf.sphere import render_sphere
from spectral_materials.blender.gpu import batches as mesh_batches
from spectral_materials.blender.gpu.matrices import set_matrix
from spectral_materials.blender.lights import scene_lights
from spectral_materials.core.brdf import metrics, shading
from spectral_materials.core.colour import pipeline as colour_pipeline, spectra

INCIDENCES = (0.0, 30.0, 60.0, 80.0)
ILLUMINANTS = ("D65", "A", "FL2", "FL11")


def scene_figure(scene, path: Path, width: int = 640, height: int = 360) -> tuple:
    """Reference | GPU | ΔE94 of the demo scene from its camera: (per-material statistics,
    the ``SceneComparison``)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    start = time.perf_counter()
    comparison = scene_reference.compare_scene(scene, width, height)
    seconds = time.perf_counter() - start
    display = scene_lights.display_settings(scene)
    de = comparison.delta_e94(scene)
    covered = comparison.material_map >= 0
    fig, axes = plt.subplots(1, 3, figsize=(15, 3.4))
    for ax, xyz, title in ((axes[0], comparison.reference, "5 nm reference (exact BRDFs)"),
                           (axes[1], comparison.gpu, "GPU draw path (factor packs)")):
        rgb = colour_pipeline.xyz_to_display(xyz, np.asarray(display.scene_white),
                                             exposure=display.exposure,
                                             tonemap_white=display.tone_white or 4.0)
        rgb[~covered] = 0.15
        ax.imshow(rgb[::-1])
        ax.set_title(title, fontsize=9)
    shown = axes[2].imshow(de[::-1], cmap="magma", vmin=0.0, vmax=2.0)
    fig.colorbar(shown, ax=axes[2], fraction=0.03)
    axes[2].set_title(f"ΔE94 GPU vs reference (mean {np.nanmean(de):.3f})", fontsize=9)
    for ax in axes:
        ax.axis("off")
    fig.savefig(path, dpi=80, bbox_inches="tight")
    plt.close(fig)
    white = comparison.white(scene)
    rows = {}
    for index, name in enumerate(comparison.materials):
        mask = comparison.material_map == index
        to_mirror = colour_pipeline.delta_e94(comparison.mirror[mask], comparison.gpu[mask],
                                              white)
        rows[name] = {"pixels": int(mask.sum()), "mean": float(np.nanmean(de[mask])),
                      "p95": float(np.nanpercentile(de[mask], 95)),
                      "max": float(np.nanmax(de[mask])), "gpu_vs_mirror_max":
                      float(to_mirror.max())}
    return {"size": [width, height], "seconds": seconds, "materials": rows,
            "lights": [light.name for light in scene_lights.drawn_lights(scene)[0]]}, comparison


def sphere_table(materials: list[str], size: int = 128) -> dict:
    """Per material × incidence × illuminant: GPU vs mirror (max) and vs 5 nm (mean/p95/max)."""
    rows = {}
    for name in materials:
        material = bpy.data.materials[name]
        model = storage.load_factored(material)
        brdf = sources.material_inputs(material).brdf()
        for illuminant in ILLUMINANTS:
            white = colour_pipeline.white_xyz(illuminant, spectra.WAVELENGTHS_REFERENCE)
            for incidence in INCIDENCES:
                gpu = render_sphere(model, incidence, illuminant, size)
                mirror, mask = shading.sphere_xyz(model, incidence, illuminant, size)
                view = metrics.sphere_directions(incidence, size)     # row 0 at the top
                top_down = np.zeros((size, size, 3))
                top_down[view.mask] = metrics.reference_xyz(brdf, view.wi, view.wo, illuminant)
                reference, lit = top_down[::-1], view.mask[::-1]
                test = gpu[..., :3].astype(np.float64)
                to_mirror = colour_pipeline.delta_e94(mirror[mask], test[mask], white)
                to_reference = colour_pipeline.delta_e94(reference[lit], test[lit], white)
                rows[(name, illuminant, incidence)] = {
                    "gpu_vs_mirror_max": float(to_mirror.max()),
                    "mean": float(to_reference.mean()),
                    "p95": float(np.percentile(to_reference, 95)),
                    "max": float(to_reference.max())}
    return rows


def report_lines(scene_stats: dict, spheres: dict, frame: dict | None,
                 sphere_px: int = 128) -> list[str]:
    lines = ["", "## Real-time spectral drawing (GPU path)", "",
             "The demo scene drawn offscreen by the project's GLSL shaders (RGBA32F, from the "
             "scene camera, "
             f"{scene_stats['size'][0]}×{scene_stats['size'][1]}, lights: "
             f"{', '.join(scene_stats['lights'])}) next to the 5 nm reference of the exact BRDFs "
             "at the same pixels, and the ΔE94 map. CIELAB white: the adaptation white (D65) at "
             "the luminance of the brightest reference pixel.", "",
             "![demo scene: reference, GPU, ΔE94](images/gpu_scene.png)", "",
             "| material | pixels | ΔE94 vs 5 nm mean | p95 | max | GPU vs float64 mirror max |",
             "|---|---:|---:|---:|---:|---:|"]
    for name, row in scene_stats["materials"].items():
        lines.append(f"| {name} | {row['pixels']} | {row['mean']:.3f} | {row['p95']:.3f} | "
                     f"{row['max']:.3f} | {row['gpu_vs_mirror_max']:.5f} |")
    lines += ["", f"Protocol sphere through the GPU path ({sphere_px} px; shared/PROTOCOL.md): "
              "ΔE94 against the 5 nm reference, and the largest ΔE94 between the GPU image and the "
              "float64 Python evaluation of the same factors (the issue's bound is 0.1).", "",
              "| material | illuminant | incidence | vs 5 nm mean | p95 | max | "
              "GPU vs mirror max |", "|---|---|---:|---:|---:|---:|---:|"]
    for (name, illuminant, incidence), row in spheres.items():
        lines.append(f"| {name} | {illuminant} | {incidence:.0f}° | {row['mean']:.3f} | "
                     f"{row['p95']:.3f} | {row['max']:.3f} | {row['gpu_vs_mirror_max']:.5f} |")
    worst = max(row["gpu_vs_mirror_max"] for row in spheres.values())
    lines += ["", f"Largest GPU-vs-mirror ΔE94 over all {len(spheres)} sphere cases: "
              f"{worst:.5f}.", ""]
    if frame:
        lines += [f"Frame time of this view at {frame['size'][0]}×{frame['size'][1]} "
                  f"({frame['renderer']}, {frame['backend']}, Blender {frame['blender']}): "
                  f"{frame['ms']:.1f} ms/frame spectral, "
                  f"{frame['baseline_ms']:.1f} ms/frame for an RGB Blinn–Phong shader on the "
                  f"same meshes, ratio {frame['ratio']:.2f}. See docs/bench_draw.md for the "
                  "curves against packs and lights.", ""]
    return lines


def frame_time(scene, width: int = 1280, height: int = 720, frames: int = 3,
               repeats: int = 3) -> dict:
    """Median ms/frame drawing the scene spectrally and with the RGB Blinn–Phong baseline
    of the draw benchmark (``benchmarks.draw_baseline``) on the same meshes, interleaved
    in one run."""
    import gpu

    from benchmarks.draw_baseline import Baseline
    from spectral_materials.blender.gpu.offscreen import Target
    from spectral_materials.blender.viewport import draw

    depsgraph = bpy.context.evaluated_depsgraph_get()
    vp, view = draw.camera_view(scene.camera, width, height, depsgraph)
    lights, key = scene_lights.drawn_lights(scene, np.asarray(view.origin))
    baseline = Baseline(lights, vp)

    def spectral() -> None:
        draw.draw_objects(scene, depsgraph, vp, view, lights=(lights, key))

    def rgb() -> None:
        baseline.bind()
        for obj in draw.drawable_objects(scene):
            batches = mesh_batches.object_batches(obj, depsgraph)
            if batches is None:
                continue
            matrix = np.array(obj.matrix_world)
            set_matrix(baseline.shader, "model_matrix", matrix)
            set_matrix(baseline.shader, "normal_matrix", np.linalg.inv(matrix).T)
            for batch in batches.batches.values():
                batch.draw(baseline.shader)

    def timed(draw_frame) -> float:
        framebuffer = gpu.state.active_framebuffer_get()
        start = time.perf_counter()
        for _ in range(frames):
            framebuffer.clear(color=(0.0, 0.0, 0.0, 0.0), depth=1.0)
            draw_frame()
        framebuffer.read_color(0, 0, 1, 1, 4, 0, "FLOAT")      # waits for the GPU
        return (time.perf_counter() - start) / frames * 1000.0

    with Target(width, height):
        spectral()
        rgb()                                                  # warm-up: compile, upload
        samples = [(timed(spectral), timed(rgb)) for _ in range(repeats)]
    ms = float(np.median([s for s, _ in samples]))
    base = float(np.median([b for _, b in samples]))
    return {"size": [width, height], "ms": ms, "baseline_ms": base, "ratio": ms / base,
            "renderer": gpu.platform.renderer_get(), "backend": gpu.platform.backend_type_get(),
            "blender": bpy.app.version_string, "frames": frames, "repeats": repeats}
