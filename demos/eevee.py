"""The demo's EEVEE section: every demo material through its EEVEE node group, the scene
rendered by EEVEE next to the 5 nm reference and the draw handler. Called by
``demos.main``."""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import bpy
import numpy as np

from spectral_materials.blender import compat
from spectral_materials.blender.eevee import apply as eevee, render as eevee_render
from spectral_materials.blender.lights import scene_lights
from spectral_materials.blender.viewport import draw
from spectral_materials.core.colour import pipeline as colour_pipeline
from spectral_materials.core.formats.exr import read_exr


def render_eevee(scene, width: int, height: int) -> tuple[np.ndarray, float]:
    """EEVEE's render of the scene from its camera as protocol XYZ (row 0 at the bottom)."""
    render = scene.render
    render.engine = compat.EEVEE_ENGINE
    render.resolution_x, render.resolution_y = width, height
    render.resolution_percentage = 100
    render.filter_size = 0.0            # pixel centres, as the draw path and the reference
    scene.eevee.taa_render_samples = 1
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    render.image_settings.file_format = "OPEN_EXR"
    render.image_settings.color_depth = "32"
    with tempfile.TemporaryDirectory() as folder:
        render.filepath = str(Path(folder) / "frame.exr")
        start = time.perf_counter()
        bpy.ops.render.render(write_still=True)
        seconds = time.perf_counter() - start
        channels, _ = read_exr(Path(folder) / "frame.exr")
    rgb = np.stack([channels[c] for c in "RGB"], axis=-1)
    xyz = eevee_render.scene_linear_to_xyz(rgb, scene.spectral.adaptation_white)
    return xyz / scene_lights.display_settings(scene).exposure, seconds


def _measure(scene, comparison, lights: int, shadows: bool = False
             ) -> tuple[dict, np.ndarray, dict]:
    """Apply the EEVEE path with ``lights`` spectral lights (their EEVEE shadows or none)
    to every drawn material, render, compare: (rows per material, XYZ, ΔE94 maps and
    timings)."""
    applied = {}
    for name in comparison.materials:
        material = bpy.data.materials[name]
        counts = eevee.apply_eevee(material, scene, measure=True, lights=lights,
                                   shadows=shadows)
        applied[name] = {**counts, "key_light": eevee.applied(material)["light"]}
    height, width = comparison.material_map.shape
    render_eevee(scene, width, height)                    # compiles the materials
    xyz, seconds = render_eevee(scene, width, height)
    white = comparison.white(scene)
    covered = comparison.material_map >= 0
    de_reference = np.full(covered.shape, np.nan)
    de_reference[covered] = colour_pipeline.delta_e94(comparison.reference[covered],
                                                      xyz[covered], white)
    de_handler = np.full(covered.shape, np.nan)
    de_handler[covered] = colour_pipeline.delta_e94(comparison.gpu[covered], xyz[covered],
                                                    white)
    rows = {}
    for index, name in enumerate(comparison.materials):
        mask = comparison.material_map == index
        rows[name] = {
            "key_light": applied[name]["key_light"], "nodes": applied[name]["nodes"],
            "spectral_lights": applied[name]["lights"],
            "mean": float(np.nanmean(de_reference[mask])),
            "p95": float(np.nanpercentile(de_reference[mask], 95)),
            "max": float(np.nanmax(de_reference[mask])),
            "handler_mean": float(np.nanmean(de_handler[mask])),
            "handler_p95": float(np.nanpercentile(de_handler[mask], 95)),
            "key_light_de94": applied[name]["de94"]}
    return rows, xyz, {"de_reference": de_reference, "de_handler": de_handler,
                       "render_seconds": seconds}


def eevee_section(scene, comparison, images: Path) -> dict:
    """Apply the EEVEE path to every drawn material, with the key light alone spectral
    and then with every light of the scene spectral (the default, up to the node group's
    limit); render, compare; write the figure of the second."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if bpy.data.colorspace.working_space != "Linear Rec.2020":
        # Saturated reflectances under FL2 fall outside Rec.709; EEVEE clamps them.
        bpy.ops.wm.set_working_color_space(working_space="Linear Rec.2020")
    drawn = [o for o in scene_lights.scene_lights(scene)[0]
             if o.data.type in scene_lights.DRAWN_TYPES]
    every = max(1, min(len(drawn), eevee.MAX_SPECTRAL_LIGHTS))
    settings = {}
    for lights in sorted({1, every}):
        rows, xyz, maps = _measure(scene, comparison, lights)
        settings[lights] = {"materials": rows, "render_seconds": maps["render_seconds"]}
    de_reference, de_handler = maps["de_reference"], maps["de_handler"]
    shadowed = _shadowed(scene, comparison, every, xyz, images)
    height, width = comparison.material_map.shape
    covered = comparison.material_map >= 0
    display = scene_lights.display_settings(scene)
    fig, axes = plt.subplots(2, 3, figsize=(15, 6.6))
    for ax, image, title in ((axes[0, 0], comparison.reference, "5 nm reference"),
                             (axes[0, 1], comparison.gpu, "draw handler (GLSL)"),
                             (axes[0, 2], xyz, "EEVEE (node groups)")):
        _show(ax, image, covered, display, title)
    for ax, de, title in ((axes[1, 1], comparison.delta_e94(scene), "ΔE94 handler vs 5 nm"),
                          (axes[1, 2], de_reference, "ΔE94 EEVEE vs 5 nm")):
        shown = ax.imshow(de[::-1], cmap="magma", vmin=0.0, vmax=5.0)
        fig.colorbar(shown, ax=ax, fraction=0.03)
        ax.set_title(f"{title} (mean {np.nanmean(de):.2f})", fontsize=9)
    shown = axes[1, 0].imshow(de_handler[::-1], cmap="magma", vmin=0.0, vmax=5.0)
    fig.colorbar(shown, ax=axes[1, 0], fraction=0.03)
    axes[1, 0].set_title(f"ΔE94 EEVEE vs handler (mean {np.nanmean(de_handler):.2f})",
                         fontsize=9)
    for ax in axes.ravel():
        ax.axis("off")
    fig.savefig(images / "eevee_scene.png", dpi=80, bbox_inches="tight")
    plt.close(fig)
    return {"settings": {str(k): v for k, v in settings.items()}, "every": every,
            "shadows": shadowed,
            "size": [width, height], "working_space": bpy.data.colorspace.working_space,
            "handler_ms": _handler_ms(scene, width, height)}


def _show(ax, image: np.ndarray, covered: np.ndarray, display, title: str) -> None:
    """An XYZ render shown as the display shows it, the background grey."""
    rgb = colour_pipeline.xyz_to_display(image, np.asarray(display.scene_white),
                                         exposure=display.exposure,
                                         tonemap_white=display.tone_white or 4.0)
    rgb[~covered] = 0.15
    ax.imshow(np.clip(rgb[::-1], 0, 1))
    ax.set_title(title, fontsize=9)


def _shadowed(scene, comparison, lights: int, unshadowed: np.ndarray, images: Path) -> dict:
    """The add-on's default, the spectral lights' EEVEE shadows on: render
    again, count the material pixels a spectral light's shadow darkens (Y below 99 % of
    the render without), measure the others against 5 nm; the figure of both renders."""
    import matplotlib.pyplot as plt

    rows, xyz, maps = _measure(scene, comparison, lights, shadows=True)
    covered = comparison.material_map >= 0
    darker = covered & (xyz[..., 1] < 0.99 * unshadowed[..., 1])
    clear = covered & ~darker
    de = maps["de_reference"]
    display = scene_lights.display_settings(scene)
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.2))
    for ax, image, title in ((axes[0], unshadowed, "spectral lights unshadowed"),
                             (axes[1], xyz, "with their EEVEE shadows (default)")):
        _show(ax, image, covered, display, title)
        ax.axis("off")
    fig.savefig(images / "eevee_shadows.png", dpi=80, bbox_inches="tight")
    plt.close(fig)
    applied = next(iter(rows.values()))
    return {"on": bool(eevee.applied(bpy.data.materials[comparison.materials[0]])
                       .get("shadows")),
            "lights": applied["spectral_lights"], "render_seconds": maps["render_seconds"],
            "shadowed_fraction": float(darker.sum() / max(covered.sum(), 1)),
            "clear_mean": float(np.nanmean(de[clear])) if clear.any() else None,
            "clear_p95": float(np.nanpercentile(de[clear], 95)) if clear.any() else None}


def _handler_ms(scene, width: int, height: int, repeats: int = 3) -> float:
    """Median wall time of one offscreen draw-handler frame (with read-back), same size."""
    times = []
    for _ in range(repeats + 1):
        start = time.perf_counter()
        draw.render_camera(scene, width=width, height=height, output="DISPLAY")
        times.append(time.perf_counter() - start)
    return float(np.median(times[1:]) * 1000.0)


def report_lines(section: dict) -> list[str]:
    every = section["every"]
    lines = ["", "## EEVEE node groups", "",
             "Every material above through its EEVEE node group (`spectral.eevee_apply`), "
             "rendered twice in this run: with the key light (the light bringing the most "
             "irradiance to the material's objects) alone reconstructed spectrally from the "
             "factor packs in nodes (*Spectral lights* 1), and with every light of the scene "
             f"so reconstructed ({every} here), the add-on's default (*Spectral lights* up to "
             f"{eevee.MAX_SPECTRAL_LIGHTS}), both with the spectral lights unshadowed, as the "
             "reference and the draw handler draw them (each spectral light reaches the "
             "material through an Emission); the other lights and the world "
             "reach a Principled BSDF fitted to the factors (Lambert + GGX) under the other "
             "lights' spectrum. "
             f"Rendered by EEVEE at {section['size'][0]}×{section['size'][1]} (1 sample, pixel "
             f"centres), working space {section['working_space']}, black world, at the same "
             "pixels as the reference and the draw handler. The figure shows the second "
             "render.", "",
             "![reference, draw handler, EEVEE and ΔE94 maps](images/eevee_scene.png)", "",
             "| material | spectral lights | nodes | EEVEE vs 5 nm mean | p95 | max | EEVEE vs "
             "handler mean | p95 | key-light term alone vs 5 nm (mean / p95) |",
             "|---|---|---:|---:|---:|---:|---:|---:|---|"]
    for setting in section["settings"].values():
        for name, row in setting["materials"].items():
            key = row["key_light_de94"]
            lights = ", ".join(row["spectral_lights"])
            lines.append(f"| {name} | {lights} | {row['nodes']} | {row['mean']:.3f} | "
                         f"{row['p95']:.3f} | {row['max']:.3f} | {row['handler_mean']:.3f} | "
                         f"{row['handler_p95']:.3f} | {key['mean']:.3f} / {key['p95']:.3f} |")
    times = ", ".join(f"{s['render_seconds']:.2f} s with {k} spectral light(s)"
                      for k, s in section["settings"].items())
    lines += ["", f"EEVEE render {times} (each after a first render that compiles the "
              f"materials); the draw handler's offscreen frame of the same view "
              f"{section['handler_ms']:.0f} ms (with read-back). With the key light alone, "
              "the difference between EEVEE and the handler is the other light, which EEVEE "
              "shades in RGB through the fitted Principled BSDF (see docs/eevee.md).", ""]
    return lines + _shadow_lines(section.get("shadows"))


def _shadow_lines(shadows: dict | None) -> list[str]:
    if not shadows or not shadows["on"]:
        return ["The spectral lights' EEVEE shadows (*Shadows of spectral lights*) were "
                "off in this run.", ""]
    return ["With the add-on's default, the spectral lights' own EEVEE shadows "
            "(docs/eevee.md: twin lights read through a refraction probe), the same "
            f"render took {shadows['render_seconds']:.2f} s. The spectral lights' shadows "
            f"darken {100 * shadows['shadowed_fraction']:.1f} % of the materials' pixels "
            "(Y below 99 % of the unshadowed render), which the unshadowed reference cannot "
            "match; over the other pixels EEVEE against 5 nm is mean "
            f"{shadows['clear_mean']:.3f}, p95 {shadows['clear_p95']:.3f}.", "",
            "![EEVEE without and with the spectral lights' shadows]"
            "(images/eevee_shadows.png)", ""]


SPHERE_CASES = (("D65", 0.0), ("D65", 60.0), ("FL2", 30.0), ("FL11", 80.0))


def sphere_table(materials: list[str], size: int = 128) -> dict:
    """Per material and case: the protocol sphere rendered by EEVEE through the node group,
    against the 5 nm reference and against the draw handler (interior pixels: the
    tessellated sphere's silhouette pixels are left out)."""
    from scipy import ndimage

    from spectral_materials.blender.brdf import sources, storage
    from spectral_materials.blender.brdf.sphere import render_sphere
    from spectral_materials.core.brdf import metrics
    from spectral_materials.core.colour import spectra

    rows = {}
    for name in materials:
        material = bpy.data.materials[name]
        model = storage.load_factored(material)
        brdf = sources.material_inputs(material).brdf()
        for illuminant, incidence in SPHERE_CASES:
            xyz, facts = eevee_render.render_sphere_eevee(model, incidence, illuminant, size)
            handler = render_sphere(model, incidence, illuminant, size)[..., :3]
            view = metrics.sphere_directions(incidence, size)
            top_down = np.zeros((size, size, 3))
            top_down[view.mask] = metrics.reference_xyz(brdf, view.wi, view.wo, illuminant)
            reference, lit = top_down[::-1], view.mask[::-1]
            inner = ndimage.binary_erosion(lit, iterations=2)
            white = colour_pipeline.white_xyz(illuminant, spectra.WAVELENGTHS_REFERENCE)
            to_reference = colour_pipeline.delta_e94(reference[inner], xyz[inner], white)
            to_handler = colour_pipeline.delta_e94(handler[inner].astype(np.float64),
                                                   xyz[inner], white)
            rows[(name, illuminant, incidence)] = {
                "mean": float(to_reference.mean()),
                "p95": float(np.percentile(to_reference, 95)),
                "max": float(to_reference.max()),
                "handler_mean": float(to_handler.mean()),
                "handler_p95": float(np.percentile(to_handler, 95)),
                "seconds": facts["seconds"], "nodes": facts["nodes"]}
    return rows


def sphere_lines(rows: dict, sphere_px: int = 128) -> list[str]:
    lines = [f"Protocol sphere rendered by EEVEE ({sphere_px} px, one sun, black world, "
             "working space Linear Rec.2020 during the render; `render-sphere --engine eevee` "
             "does the same), "
             "against the 5 nm reference and against the draw handler on the same pixels:", "",
             "| material | illuminant | incidence | EEVEE vs 5 nm mean | p95 | max | EEVEE vs "
             "handler mean | p95 | render s |", "|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    for (name, illuminant, incidence), row in rows.items():
        lines.append(f"| {name} | {illuminant} | {incidence:.0f}° | {row['mean']:.3f} | "
                     f"{row['p95']:.3f} | {row['max']:.3f} | {row['handler_mean']:.3f} | "
                     f"{row['handler_p95']:.3f} | {row['seconds']:.2f} |")
    return lines + [""]
