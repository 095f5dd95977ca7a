"""The demo's spectral PRT section (called by ``demos.main`` after the main scene is saved).

Two scenes, after the spectral PRT paper's two figures:

* **ColorChecker under FL4** (its Figure 2): Suzanne on a floor, the 24 ColorChecker
  patches over its UVs, an overcast FL4 sky. Drawn by the GPU with spectral PRT and with
  RGB PRT, next to a 5 nm reference: the Monte Carlo spectral irradiance at the vertices
  (same visibility, 4096 rays), interpolated as the rasteriser interpolates, times the
  patch spectra per pixel. ΔE94 maps of both against it.
* **Metacow** (its Figure 1): a plane whose albedo (a spectral OpenEXR written here) has
  the ColorChecker on the left and, on the right, metamers that match it under D65 and
  differ as much as possible under A (``core.metamers``). Drawn under D65, A and FL2 skies.
"""

from __future__ import annotations

import time
from pathlib import Path

import bpy
import numpy as np

from benchmarks.scenes import factory_scene
from spectral_materials.blender.lights import scene_lights
from spectral_materials.blender.prt import drawer as prt_gpu, images as prt_images, scene as prt
from spectral_materials.blender.viewport import draw
from spectral_materials.core.colour import metamers, pipeline as colour_pipeline, spectra
from spectral_materials.core.formats.spectral_exr import write_spectral_exr
from spectral_materials.core.prt import reference as prt_reference

from .sizes import DemoSizes

WL = spectra.WAVELENGTHS_REFERENCE


def _fresh_scene(camera_location, camera_rotation, size: int):
    """The factory scene with only its camera, placed, and a square image of ``size``."""
    scene = factory_scene()
    scene.camera.location = camera_location
    scene.camera.rotation_euler = camera_rotation
    scene.render.resolution_x = scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    return scene


def _join(objects, name: str):
    bpy.ops.object.select_all(action="DESELECT")
    for obj in objects:
        obj.select_set(True)
    bpy.context.view_layer.objects.active = objects[0]
    bpy.ops.object.join()
    joined = bpy.context.active_object
    joined.name = name
    return joined


def _display(scene, xyz: np.ndarray) -> np.ndarray:
    """Linear XYZ (…, 3) → display sRGB with the scene's pipeline (adapted from the
    environment's white)."""
    settings = scene_lights.display_settings(scene)
    white = prt.environment_white_xyz(scene)
    return colour_pipeline.xyz_to_display(np.nan_to_num(xyz), white,
                                          exposure=settings.exposure,
                                          tonemap_white=settings.tone_white or 4.0)


def _stats(de: np.ndarray) -> dict:
    return {"mean": float(np.mean(de)), "p95": float(np.percentile(de, 95)),
            "max": float(np.max(de))}


def colorchecker_fl4(images: Path, sizes: DemoSizes) -> dict:
    """Figure 2: spectral and RGB PRT against the 5 nm reference under FL4."""
    scene = _fresh_scene((0.0, -5.2, 1.9), (np.radians(75.0), 0.0, 0.0), sizes.prt_px)
    obj = _suzanne_on_floor(sizes.prt_subdivisions)
    env = scene.spectral.environment
    env.source, env.illuminant, env.sky, env.bands, env.basis_size = \
        "SKY", "FL4", "OVERCAST", 5, 8
    obj.spectral_prt.albedo_kind = "CHART"
    obj.spectral_prt.rays = sizes.prt_bake_rays
    baked = prt.bake_prt(obj, scene)
    start = time.perf_counter()
    spectral_xyz = draw.render_camera(scene, output="XYZ")[0]
    prt_gpu.clear_cache()
    geometry = prt_images.pixel_geometry(scene, obj)
    # RGB PRT through the same draw path.
    rgb_xyz = _render_rgb(scene)
    gpu_seconds = time.perf_counter() - start
    # The reference: 5 nm Monte Carlo irradiance at the vertices, interpolated.
    start = time.perf_counter()
    irradiance = prt.vertex_reference_irradiance(obj, scene, rays=sizes.prt_reference_rays)
    reference_seconds = time.perf_counter() - start
    pixel_e = prt_images.interpolate(geometry, irradiance)                     # (P, L)
    albedo = prt.vertex_albedo_spectra(obj, geometry.uv)                       # (P, L)
    reference = prt_reference.irradiance_xyz(pixel_e, albedo, prt.reference_environment(scene))
    white = prt.environment_white_xyz(scene)
    covered = geometry.covered
    de_spectral = colour_pipeline.delta_e94(reference, spectral_xyz[..., :3][covered], white)
    de_rgb = colour_pipeline.delta_e94(reference, rgb_xyz[..., :3][covered], white)
    panels = [("RGB PRT", _display(scene, rgb_xyz[..., :3])),
              ("ΔE94 RGB PRT", geometry.image(de_rgb)),
              ("reference (5 nm)", _display(scene, geometry.image(reference, 0.0))),
              ("spectral PRT", _display(scene, spectral_xyz[..., :3])),
              ("ΔE94 spectral PRT", geometry.image(de_spectral))]
    _panels_figure(panels, images / "prt_colorchecker_fl4.png")
    bpy.ops.wm.save_as_mainfile(filepath=str(images.parent / "prt_colorchecker.blend"))
    obj.data.calc_loop_triangles()
    return {"vertices": len(obj.data.vertices), "triangles": len(obj.data.loop_triangles),
            "rays": baked.rays, "bake_seconds": baked.seconds,
            "rays_per_second": baked.rays_per_second, "backend": baked.backend,
            "spectral": _stats(de_spectral), "rgb": _stats(de_rgb),
            "pixels": int(covered.sum()), "gpu_seconds": gpu_seconds,
            "reference_seconds": reference_seconds, "basis": int(env.basis_size),
            "reference_rays": sizes.prt_reference_rays,
            "bands": int(env.bands)}


def _suzanne_on_floor(subdivisions: int):
    """Suzanne (subdivided ``subdivisions`` times) joined with a 16 × 16 floor grid."""
    bpy.ops.mesh.primitive_monkey_add(size=2.0, location=(0.0, 0.0, 1.0))
    monkey = bpy.context.active_object
    if subdivisions:
        modifier = monkey.modifiers.new("subdivide", "SUBSURF")
        modifier.levels = subdivisions
        bpy.ops.object.modifier_apply(modifier=modifier.name)
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=16, y_subdivisions=16, size=6.0)
    return _join([monkey, bpy.context.active_object], "Suzanne")


def _panels_figure(panels: list, path: Path) -> None:
    """One row of pictures and ΔE94 maps (2-D panels, on one 0–10 colour bar)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 5, figsize=(15, 3.4))
    for ax, (title, data) in zip(axes, panels):
        if data.ndim == 2:
            shown = ax.imshow(data[::-1], cmap="magma", vmin=0, vmax=10)
        else:
            ax.imshow(np.clip(np.nan_to_num(data[::-1]), 0, 1))
        ax.set_title(title)
        ax.axis("off")
    fig.colorbar(shown, ax=axes, shrink=0.8, label="ΔE94")
    fig.savefig(path, dpi=80)
    plt.close(fig)


def _render_rgb(scene) -> np.ndarray:
    from spectral_materials.blender.gpu.offscreen import Target

    width, height = scene.render.resolution_x, scene.render.resolution_y
    depsgraph = bpy.context.evaluated_depsgraph_get()
    view_projection, _ = draw.camera_view(scene.camera, width, height, depsgraph)
    with Target(width, height) as target:
        prt_gpu.draw_prt_objects(scene, depsgraph, view_projection, output="XYZ", rgb=True)
        return target.read()


def metacow(images: Path, sizes: DemoSizes) -> dict:
    """Figure 1: the ColorChecker and its metamers under D65, A and FL2."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    patch_pixels = 8
    found = list(metamers.colorchecker_metamers(match="D65", differ="A",
                                                wavelengths=WL).values())
    checker = np.stack([spectra.colorchecker(i, WL) for i in range(1, 25)]).reshape(4, 6, -1)
    twins = np.stack([m.spectrum for m in found]).reshape(4, 6, -1)
    chart = np.concatenate([checker, twins], axis=1)[::-1]          # row 0 at the bottom
    texture = np.repeat(np.repeat(chart, patch_pixels, 0), patch_pixels, 1)
    path = images / "metacow_albedo.exr"
    write_spectral_exr(path, WL, texture, kind="reflective")
    scene = _fresh_scene((0.0, 0.0, 9.5), (0.0, 0.0, 0.0), sizes.prt_px)
    scene.render.resolution_x = 2 * sizes.prt_px
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    obj = bpy.context.active_object
    obj.scale = (3.0, 1.0, 1.0)
    bpy.ops.object.transform_apply(scale=True)
    obj.spectral_prt.albedo_kind = "SPECTRAL_EXR"
    obj.spectral_prt.filepath = str(path)
    obj.spectral_prt.rays = 64
    env = scene.spectral.environment
    env.source, env.sky, env.bands, env.basis_size = "SKY", "UNIFORM", 3, 12
    prt.bake_prt(obj, scene)
    results, pictures = {}, []
    geometry = prt_images.pixel_geometry(scene, obj)
    for illuminant in ("D65", "A", "FL2"):
        env.illuminant = illuminant
        scene.spectral.adaptation_white = illuminant
        xyz = draw.render_camera(scene, output="XYZ")[0]
        pictures.append((f"spectral PRT, {illuminant}", _display(scene, xyz[..., :3])))
        # Pair each patch with its metamer: the pixels nearest the patch centres' UVs.
        white = prt.environment_white_xyz(scene)
        rgb = _render_rgb(scene)[..., :3]
        de, de_rgb = [], []
        for row in range(4):
            for col in range(6):
                v = 1.0 - (row + 0.5) / 4
                left = _nearest(geometry, ((col + 0.5) / 12, v))
                right = _nearest(geometry, ((col + 6.5) / 12, v))
                de.append(colour_pipeline.delta_e94(xyz[left][None, :3],
                                                    xyz[right][None, :3], white)[0])
                de_rgb.append(colour_pipeline.delta_e94(rgb[left][None], rgb[right][None],
                                                        white)[0])
        de, de_rgb = np.array(de), np.array(de_rgb)
        results[illuminant] = {"spectral": _stats(de), "rgb": _stats(de_rgb)}
    fig, axes = plt.subplots(1, 3, figsize=(15, 2.9))
    for ax, (title, data) in zip(axes, pictures):
        ax.imshow(np.clip(data[::-1], 0, 1))
        ax.set_title(title)
        ax.axis("off")
    fig.savefig(images / "prt_metacow.png", dpi=80)
    plt.close(fig)
    return {"pairs": results,
            "design": {"match_D65_max": float(max(m.delta_e94_match for m in found)),
                       "differ_A_mean": float(np.mean([m.delta_e94_differ for m in found]))}}


def _nearest(geometry, uv) -> tuple[int, int]:
    """(row, column) of the covered pixel whose UV is nearest ``uv``."""
    best = int(np.argmin(np.sum((geometry.uv - np.asarray(uv)) ** 2, axis=1)))
    rows, cols = np.nonzero(geometry.covered)
    return int(rows[best]), int(cols[best])


def prt_section(images: Path, sizes: DemoSizes) -> dict:
    start = time.perf_counter()
    section = {"colorchecker_fl4": colorchecker_fl4(images, sizes),
               "metacow": metacow(images, sizes)}
    section["seconds"] = time.perf_counter() - start
    return section


def report_lines(section: dict) -> list[str]:
    fl4 = section["colorchecker_fl4"]
    lines = ["", "## Spectral PRT", "",
             "After the spectral PRT paper's Figure 2: Suzanne on a floor (one mesh, "
             f"{fl4['vertices']} vertices, self-shadowed), the 24 ColorChecker patches over "
             f"its UVs, an overcast FL4 sky; {fl4['bands']} SH bands, a spectral basis of "
             f"{fl4['basis']}. Transfer baked with {fl4['rays']} rays per vertex "
             f"({fl4['backend']}, {fl4['bake_seconds']:.1f} s, "
             f"{fl4['rays_per_second'] / 1e6:.2f} M rays/s). Reference: 5 nm Monte Carlo "
             f"spectral irradiance at the vertices ({fl4['reference_rays']} rays, same "
             "visibility), interpolated "
             "per pixel as the rasteriser does, times the patch spectra.", "",
             "![RGB PRT, reference, spectral PRT, ΔE94 maps](images/prt_colorchecker_fl4.png)",
             "", "| FL4, per pixel | ΔE94 mean | p95 | max |", "|---|---:|---:|---:|"]
    for name in ("spectral", "rgb"):
        s = fl4[name]
        label = "spectral PRT (GPU)" if name == "spectral" else "RGB PRT (GPU)"
        lines.append(f"| {label} | {s['mean']:.3f} | {s['p95']:.3f} | {s['max']:.3f} |")
    cow = section["metacow"]
    lines += ["", "After its Figure 1 (Metacow): the ColorChecker (left) next to metamers "
              "computed to match it under D65 and differ most under A (worst D65 ΔE94 of the "
              f"design {cow['design']['match_D65_max']:.3f}, mean A ΔE94 "
              f"{cow['design']['differ_A_mean']:.1f}), as a spectral OpenEXR albedo, under "
              "uniform skies (display adapted to each sky's white).", "",
              "![Metacow under D65, A, FL2](images/prt_metacow.png)", "",
              "| sky | patch vs metamer ΔE94, spectral PRT mean / max | RGB PRT mean / max |",
              "|---|---|---|"]
    for illuminant, row in cow["pairs"].items():
        s, r = row["spectral"], row["rgb"]
        lines.append(f"| {illuminant} | {s['mean']:.2f} / {s['max']:.2f} | "
                     f"{r['mean']:.2f} / {r['max']:.2f} |")
    lines += ["", "RGB PRT sees a patch and its metamer as the same RGB albedo, so it cannot "
              "tell them apart under any light. Section run time "
              f"{section['seconds']:.0f} s.", ""]
    return lines
