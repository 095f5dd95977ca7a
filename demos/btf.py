"""The demo's BTF section (called by ``demos.main``): generated corduroy on a cushion.

A cushion (a smooth cylinder on its side, UV mapped) gets a corduroy BTF generated here
(``core/btf/generate.py``: ridges with deep grooves, self-shadowing and masking,
spectral dyes), fitted as per-view reflectance fields (RFNL, 2 lobes) through the same
function the Fit BTF operator calls, and drawn by the spectral draw handler under a
fluorescent FL2 spot and a D65 sun. The section reports the fit's ε, the four-way error
table of the BTF paper (LAF, RFP, RFNL, CP) on the same corduroy, the GPU bytes, and how
much of them this camera needs (the measured views that get any weight in the picture).
"""

from __future__ import annotations

import time
from pathlib import Path

import bpy
import numpy as np

from benchmarks.btf import fit_all
from benchmarks.scenes import factory_scene
from spectral_materials.blender.btf import fit as blender_btf, storage as btf_storage
from spectral_materials.blender.viewport import draw
from spectral_materials.core.brdf.shading import shading_frame, to_local
from spectral_materials.core.btf import fit as btf_fit, generate as btf_generate
from spectral_materials.core.colour import spectra

from .images import write_display_png
from .sizes import DemoSizes


def build_scene(sizes: DemoSizes):
    """The cushion with its corduroy material, the camera, an FL2 spot and a sun."""
    scene = factory_scene()
    bpy.ops.mesh.primitive_cylinder_add(vertices=96, radius=0.6, depth=2.2,
                                        end_fill_type="NOTHING")
    cushion = bpy.context.active_object
    cushion.rotation_euler = (0.0, np.pi / 2, 0.0)
    cushion.name = "Cushion"
    bpy.ops.object.shade_smooth()
    material = bpy.data.materials.new("Corduroy")
    cushion.data.materials.append(material)
    s = material.spectral_btf
    s.source, s.texels, s.model, s.lobes = "CORDUROY", sizes.btf_texels, "RFNL", 2
    s.uv_scale = (12.0, 3.0)
    camera = scene.camera
    camera.location = (0.0, -4.8, 1.9)
    camera.rotation_euler = (np.radians(68.0), 0.0, 0.0)
    scene.render.resolution_x, scene.render.resolution_y = sizes.btf_px
    scene.render.resolution_percentage = 100
    spot_data = bpy.data.lights.new("Shop light", "SPOT")
    spot_data.energy = 400.0
    spot_data.spot_size = np.radians(70.0)
    spot_data.spectral.kind = "ILLUMINANT"
    spot_data.spectral.illuminant = "FL2"
    spot = bpy.data.objects.new("Shop light", spot_data)
    spot.location = (1.6, -1.2, 2.2)
    spot.rotation_euler = (np.radians(35.0), np.radians(30.0), 0.0)
    scene.collection.objects.link(spot)
    sun_data = bpy.data.lights.new("Sun", "SUN")
    sun_data.energy = 1.5
    sun = bpy.data.objects.new("Sun", sun_data)
    sun.rotation_euler = (np.radians(60.0), 0.0, np.radians(-120.0))
    scene.collection.objects.link(sun)
    return scene, cushion, material


def views_used(scene, material) -> dict:
    """Measured views that get weight at the cushion's visible pixels, and their bytes."""
    width, height = scene.render.resolution_x, scene.render.resolution_y
    gbuffer = {out: draw.render_camera(scene, width=width, height=height, output=out)[0]
               for out in ("POSITION", "NORMAL", "TANGENT")}
    covered = gbuffer["POSITION"][..., 3] > 0
    _, view = draw.camera_view(scene.camera, width, height,
                               bpy.context.evaluated_depsgraph_get())
    points = gbuffer["POSITION"][covered, :3].astype(np.float64)
    t, b, n = shading_frame(gbuffer["NORMAL"][covered, :3], gbuffer["TANGENT"][covered, :3])
    local = to_local((t, b, n), view.directions(points))
    drawable = btf_storage.load_btf(material)
    used = drawable.views_used(local)
    h, w = drawable.texels
    per_view = drawable.records_per_view * h * w * 16
    albedo = drawable.albedo_records * h * w * 16
    return {"views": len(drawable.views), "used": int(len(used)),
            "bytes_all": int(drawable.nbytes), "bytes_used": int(albedo + len(used) * per_view),
            "pixels": int(covered.sum())}


def comparison_table(texels: int) -> list[dict]:
    """The BTF paper's Table 1 on this corduroy: LAF, RFP, RFNL, CP, fitted as
    ``benchmarks.btf`` fits them."""
    data = btf_generate.generate_btf("corduroy", texels=texels)
    rows = []
    for name, model in fit_all(data, cp_packs=8).items():
        eps = btf_fit.epsilon(data, model)
        rows.append({"method": name, "avg": eps["avg"], "min": eps["min"], "max": eps["max"],
                     "fit_seconds": model.fit_seconds, "gpu_bytes": int(model.nbytes_gpu)})
    return rows


def btf_section(images: Path, sizes: DemoSizes) -> dict:
    start = time.perf_counter()
    scene, cushion, material = build_scene(sizes)
    result = blender_btf.fit_btf(material)
    fit_wall = time.perf_counter() - start
    display, stats = draw.render_camera(scene, output="DISPLAY")
    xyz, _ = draw.render_camera(scene, output="XYZ")
    write_display_png(display, images / "btf_cushion.png")
    section = {"figures": result.figures, "fit_wall_seconds": fit_wall,
               "drawn": material.name in stats.materials,
               "finite": bool(np.isfinite(xyz).all()),
               "max_y": float(xyz[..., 1].max()), "memory": views_used(scene, material),
               "table": comparison_table(sizes.btf_texels), "texels": sizes.btf_texels,
               "bands": len(btf_generate.DEFAULT_WAVELENGTHS),
               "illuminants": ["FL2 spot", "D65 sun"], "white": "D65",
               "wavelengths": [float(spectra.WAVELENGTHS_REFERENCE[0]),
                               float(spectra.WAVELENGTHS_REFERENCE[-1])]}
    return section


def report_lines(section: dict) -> list[str]:
    f, m = section["figures"], section["memory"]
    lines = ["", "## BTF material", "",
             f"A cushion covered with generated corduroy ({section['texels']}² texels, "
             f"81 views × 81 lights, {section['bands']} bands; ridges, grooves, "
             "self-shadowing and masking), fitted as per-view reflectance fields "
             f"({f['model']}, {f['lobes']} lobes, luminance × spectral albedo) and drawn by the "
             "spectral draw handler with 3-view interpolation, under an FL2 spot and a D65 "
             "sun.", "",
             "![Corduroy cushion, RFNL BTF, FL2 spot and D65 sun](images/btf_cushion.png)", "",
             f"Fit: ε {f['epsilon_avg']:.4f} (min {f['epsilon_min']:.4f}, max "
             f"{f['epsilon_max']:.4f}) in {f['fit_seconds']:.1f} s; "
             f"{f['gpu_bytes'] / 2**20:.2f} MiB on the GPU. This camera needs {m['used']} of "
             f"the {m['views']} measured views ({m['bytes_used'] / 2**20:.2f} MiB of "
             f"{m['bytes_all'] / 2**20:.2f} MiB).", "",
             "The BTF paper's Table 1 on this corduroy (ε: mean |BTF − model| per texel over "
             "the measured directions, reflectance-factor units):", "",
             "| method | ε avg | ε min | ε max | fit s | GPU |", "|---|---|---|---|---|---|"]
    for r in section["table"]:
        lines.append(f"| {r['method']} | {r['avg']:.4f} | {r['min']:.4f} | {r['max']:.4f} | "
                     f"{r['fit_seconds']:.1f} | {r['gpu_bytes'] / 2**20:.2f} MiB |")
    lines += ["", "Held-out directions, the other materials and frame times: "
              "`docs/bench_btf.md`.", ""]
    return lines
