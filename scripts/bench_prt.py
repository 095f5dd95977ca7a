"""Spectral PRT benchmark: colour error against run time, and spectral against RGB PRT.

One self-shadowing mesh, Suzanne (two levels of subdivision applied) joined with a floor
grid, default UVs, albedo "CHART" (the ColorChecker patches over the UVs), lit by a CIE
overcast sky under FL4 (the spiky fluorescent the spectral PRT paper uses) and under
D65, SH window NONE (the add-on's default). Swept, as shared/PROTOCOL.md ("Error
against run time") asks, one row per setting:

* **error**: ΔE94 mean / p95 / max over the vertices of ``prt.vertex_xyz`` against
  ``prt.vertex_reference_xyz`` (Monte Carlo, 5 nm, the true sky, 4096 cosine-distributed
  rays per vertex; computed once per illuminant), white = the environment's white, for
  every SH bands × rays per vertex × spectral basis size × illuminant; the basis sweep
  again without a window; and the four SH windows under the overcast sky and under a
  clear sky with a sun;
* **bake**: ``prt.bake_prt`` once per (bands, rays): tracing seconds, rays cast, rays/s,
  backend, and the wall time of the whole call;
* **frame time**: the PRT object drawn by ``prt_gpu.draw_prt_objects`` from the camera
  into a 512 × 512 RGBA32F offscreen per (bands, basis size), each frame ended by a
  1-pixel read-back (which cannot return before the frame is done), as a ratio against
  classical RGB PRT (``rgb=True``) drawing the same mesh to the same target, timed in
  blocks alternating with the spectral ones (R S R S … R);
* **RGB PRT**: its error against the same reference (``core.prt.rgb_vertex_xyz`` with
  ``core.prt.rgb_albedo`` of the albedo spectra at the vertices) next to spectral PRT's,
  and the spectral/RGB frame-time ratio at bands 5, basis 8 measured longer.

Writes ``docs/bench_prt.md`` and ``docs/bench_prt.json`` (``--quick``:
``bench_prt_quick.*``; ``--out DIR`` writes to DIR instead of ``docs/``) and prints the
tables.

Usage::

    python scripts/bench_prt.py              # the full sweep (~4 min on 2 cores, llvmpipe)
    python scripts/bench_prt.py --quick      # a small mesh and grid (smoke test, < 1 min)
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import bpy
from bench_common import gpu_machine  # noqa: E402  (scripts/, next to this file)

from spectral_materials import blender as addon
from spectral_materials.blender.gpu.context import ensure_gpu
from spectral_materials.blender.gpu.offscreen import Target
from spectral_materials.blender.prt import drawer as prt_gpu
from spectral_materials.blender.prt import scene as prt
from spectral_materials.blender.viewport import draw
from spectral_materials.core.colour import pipeline as colour_pipeline
from spectral_materials.core.prt import environment as core_environment
from spectral_materials.core.prt import transfer as core_prt

ILLUMINANTS = ("FL4", "D65")
#: The add-on's default window (properties.SPECTRAL_PG_environment.window), first.
DEFAULT_WINDOW = "NONE"
WINDOWS = ("NONE", "LANCZOS", "HANNING", "CESARO")
#: The skies of the window sweep: (sky, share of the horizontal irradiance from the sun
#: disc, at the default 45° elevation). The other sweeps use the first.
SKIES = {"overcast": ("OVERCAST", 0.0), "clear + sun": ("CLEAR", 0.5)}
#: (full, quick) sweeps.
BANDS = ([2, 3, 4, 5, 6, 7, 8], [2, 5, 8])
RAYS = ([64, 256, 1024, 4096], [64, 256])
BASIS = ([3, 4, 6, 8, 12, 16], [3, 8, 16])
#: The slices the Markdown tables show (rays at most the largest of the sweep).
MAIN_RAYS, MAIN_BANDS, MAIN_BASIS = 1024, 5, 8
#: Monte Carlo reference: rays per vertex, and the seed of the second one (noise floor).
REFERENCE_RAYS = 4096
NOISE_SEED = 1
#: Suzanne's subdivision levels and the floor grid's subdivisions (full, quick).
SUBDIVISIONS = (2, 1)
FLOOR_SUBDIVISIONS = (20, 12)
FLOOR_SIZE = 6.0
SIZE = 512
CAMERA_LOCATION = (0.0, -4.6, 2.6)
CAMERA_TARGET = (0.0, 0.0, 0.8)
#: The spectral PRT paper's spectral/RGB frame-time ratio, and the goal here.
PAPER_RATIO = (2.0, 4.0)
GOAL_RATIO = 1.5


def log(message: str) -> None:
    print(message, flush=True)


def set_sky(env, name: str) -> None:
    env.sky, env.sun_fraction = SKIES[name]


def stats(de: np.ndarray) -> dict:
    return {"mean": float(np.mean(de)), "p95": float(np.percentile(de, 95)),
            "max": float(np.max(de))}


# ------------------------------------------------------------------------ scene


def build_scene(subdivisions: int, floor_subdivisions: int):
    """Factory scene, its camera kept, and one joined mesh: subdivided Suzanne on a floor."""
    from mathutils import Vector

    bpy.ops.wm.read_homefile(use_factory_startup=True)
    scene = bpy.context.scene
    for obj in list(bpy.data.objects):
        if obj.type != "CAMERA":
            bpy.data.objects.remove(obj)
    bpy.ops.mesh.primitive_monkey_add(size=2.0, location=(0.0, 0.0, 1.0))
    monkey = bpy.context.active_object
    if subdivisions:
        modifier = monkey.modifiers.new("Subdivision", "SUBSURF")
        modifier.levels = modifier.render_levels = subdivisions
        bpy.ops.object.modifier_apply(modifier=modifier.name)
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=floor_subdivisions,
                                    y_subdivisions=floor_subdivisions, size=FLOOR_SIZE)
    floor = bpy.context.active_object
    bpy.ops.object.select_all(action="DESELECT")
    floor.select_set(True)
    monkey.select_set(True)
    bpy.context.view_layer.objects.active = monkey
    bpy.ops.object.join()
    obj = bpy.context.active_object
    obj.name = "PRT Suzanne"
    camera = scene.camera
    camera.location = CAMERA_LOCATION
    toward = Vector(CAMERA_TARGET) - Vector(CAMERA_LOCATION)
    camera.rotation_euler = toward.to_track_quat("-Z", "Y").to_euler()
    scene.render.resolution_x = scene.render.resolution_y = SIZE
    scene.render.resolution_percentage = 100
    env = scene.spectral.environment
    env.source = "SKY"
    set_sky(env, next(iter(SKIES)))
    env.window, env.rotation = DEFAULT_WINDOW, 0.0
    obj.spectral_prt.albedo_kind = "CHART"
    bpy.context.view_layer.update()
    mesh = obj.data
    mesh.calc_loop_triangles()
    info = {"vertices": len(mesh.vertices), "corners": len(mesh.loops),
            "triangles": len(mesh.loop_triangles),
            "monkey_subdivisions": subdivisions, "floor_subdivisions": floor_subdivisions,
            "uv_map": mesh.uv_layers.active.name if mesh.uv_layers.active else None}
    return scene, obj, info


# ---------------------------------------------------------------------- timing


class FrameBench:
    """Frames of the PRT object drawn into one bound target, spectral and RGB."""

    def __init__(self, scene, obj, target: Target):
        self.scene, self.obj, self.target = scene, obj, target

    def frame(self, rgb: bool) -> tuple[float, float]:
        """(wall seconds, seconds until draw_prt_objects returned) of one synced frame."""
        depsgraph = bpy.context.evaluated_depsgraph_get()
        start = time.perf_counter()
        self.target.framebuffer.clear(color=(0.0, 0.0, 0.0, 0.0), depth=1.0)
        vp, _ = draw.camera_view(self.scene.camera, SIZE, SIZE, depsgraph)
        drawn = prt_gpu.draw_prt_objects(self.scene, depsgraph, vp, rgb=rgb,
                                         objects=[self.obj])
        issued = time.perf_counter()
        self.target.framebuffer.read_color(0, 0, 1, 1, 4, 0, "FLOAT")
        end = time.perf_counter()
        if drawn != [self.obj.name]:
            raise RuntimeError(f"PRT object not drawn: {dict(prt_gpu.FAILED)}")
        return end - start, issued - start

    def block(self, rgb: bool, frames: int) -> tuple[list[float], list[float], float]:
        """One untimed frame (switching modes rebuilds the object's textures), then
        ``frames`` timed ones: (wall seconds, CPU seconds, the first frame's seconds)."""
        first, _ = self.frame(rgb)
        wall, cpu = zip(*(self.frame(rgb) for _ in range(frames)))
        return list(wall), list(cpu), first

    def covered(self, rgb: bool) -> int:
        self.frame(rgb)
        return int(np.count_nonzero(self.target.read()[..., 3] > 0))

    def measure(self, frames: int, reps: int) -> dict:
        """R S R S … S R: ``reps`` spectral blocks, each between two RGB blocks."""
        rgb_blocks, spectral_blocks, cpu, first = [], [], [], []
        rgb_blocks.append(self.block(True, frames)[0])
        for _ in range(reps):
            wall, c, f = self.block(False, frames)
            spectral_blocks.append(wall)
            cpu += c
            first.append(f)
            rgb_blocks.append(self.block(True, frames)[0])
        base = [float(np.median(b)) for b in rgb_blocks]
        paired = [float(np.median(s)) / (0.5 * (b0 + b1))
                  for s, b0, b1 in zip(spectral_blocks, base[:-1], base[1:])]
        spectral = [t for b in spectral_blocks for t in b]
        rgb = [t for b in rgb_blocks for t in b]
        return {"ms": 1e3 * float(np.median(spectral)), "rgb_ms": 1e3 * float(np.median(rgb)),
                "ratio": float(np.median(paired)), "paired": paired,
                "cpu_ms": 1e3 * float(np.median(cpu)),
                "switch_ms": 1e3 * float(np.median(first)),
                "frames": len(spectral), "rgb_frames": len(rgb),
                "spectral_seconds": spectral, "rgb_seconds": rgb}


# -------------------------------------------------------------------- errors


def albedo_rgb_at_vertices(obj) -> np.ndarray:
    """The texture an RGB pipeline is given (``core.prt.rgb_albedo``), at the vertices,
    filtered as the reference's albedo is."""
    uv = prt.vertex_uvs(obj.data)
    return core_prt.rgb_albedo(prt.vertex_albedo_spectra(obj, uv), prt.WAVELENGTHS)


def rgb_errors(obj, scene, transfer, albedo_rgb, reference, white, bands: int) -> dict:
    """RGB PRT's ΔE94: with the environment the add-on draws (``rgb=True`` reduces the
    environment on the scene's basis to sRGB) and, as a control, with the environment
    projected without a basis (all 81 samples)."""
    drawn = core_prt.rgb_vertex_xyz(transfer, prt.object_environment(obj, scene), albedo_rgb)
    env = scene.spectral.environment
    exact = core_environment.sky_environment(env.illuminant, prt.WAVELENGTHS, None,
                                             sky=env.sky.lower(), bands=bands,
                                             window=env.window.lower())
    exact = exact.rotated(prt.object_rotation(obj).T)
    exact_xyz = core_prt.rgb_vertex_xyz(transfer, exact, albedo_rgb)
    return {"drawn": stats(colour_pipeline.delta_e94(reference, drawn, white)),
            "exact_environment": stats(colour_pipeline.delta_e94(reference, exact_xyz, white))}


def texture_bytes(obj, scene, transfer: np.ndarray) -> dict:
    """float32 bytes on the GPU (as prt_gpu uploads them) and in the .blend attributes."""
    layers = prt.albedo_layers(obj, scene).layers                 # (m, H, W, 3)
    m, h, w = layers.shape[:3]
    k = transfer.shape[1]
    return {"transfer_attributes": int(transfer.size * 4),
            "transfer_texture": int(prt_gpu.transfer_texels(transfer).nbytes),
            "environment_texture": int(prt_gpu.environment_texels(np.zeros((k, m))).nbytes),
            "albedo_texture": int(m * h * w * 16),
            "rgb_environment_texture": int(prt_gpu.environment_texels(np.zeros((k, 3))).nbytes),
            "rgb_albedo_texture": int(h * w * 16)}


# --------------------------------------------------------------------- the run


def run(args) -> dict:
    q = 1 if args.quick else 0
    bands_grid, rays_grid, basis_grid = BANDS[q], RAYS[q], BASIS[q]
    main_rays = max(r for r in rays_grid if r <= MAIN_RAYS)
    started = time.perf_counter()
    addon.register()
    ensure_gpu()
    info = gpu_machine()
    scene, obj, mesh_info = build_scene(SUBDIVISIONS[q], FLOOR_SUBDIVISIONS[q])
    env = scene.spectral.environment
    log(f"machine: {info['renderer']} ({info['backend']}), {info['cpu_count']} cores; mesh "
        f"{mesh_info['vertices']} vertices, {mesh_info['triangles']} triangles")

    # The reference, once per illuminant (it depends on none of the swept settings). The
    # bake enables the object, puts its albedo into the scene's basis and stores a transfer.
    env.bands, env.basis_size = MAIN_BANDS, max(basis_grid)
    obj.spectral_prt.rays = rays_grid[0]
    prt.bake_prt(obj, scene)
    references, whites, noise = {}, {}, {}
    for illuminant in ILLUMINANTS:
        env.illuminant = illuminant
        start = time.perf_counter()
        references[illuminant] = prt.vertex_reference_xyz(obj, scene, rays=args.reference_rays)
        seconds = time.perf_counter() - start
        second = prt.vertex_reference_xyz(obj, scene, rays=args.reference_rays, seed=NOISE_SEED)
        whites[illuminant] = prt.environment_white_xyz(scene)
        noise[illuminant] = {"seconds": seconds, **stats(colour_pipeline.delta_e94(
            references[illuminant], second, whites[illuminant]))}
        log(f"  reference {illuminant}: {seconds:.1f} s; two seeds differ by ΔE94 mean "
            f"{noise[illuminant]['mean']:.3f}, p95 {noise[illuminant]['p95']:.3f}, max "
            f"{noise[illuminant]['max']:.3f}")
    # The window sweep's other skies: one reference each, no noise floor.
    sky_references = {}
    for sky in list(SKIES)[1:]:
        set_sky(env, sky)
        for illuminant in ILLUMINANTS:
            env.illuminant = illuminant
            start = time.perf_counter()
            reference = prt.vertex_reference_xyz(obj, scene, rays=args.reference_rays)
            sky_references[sky, illuminant] = (reference, prt.environment_white_xyz(scene))
            log(f"  reference {sky} {illuminant}: {time.perf_counter() - start:.1f} s")
    set_sky(env, next(iter(SKIES)))
    white_by_basis = {}
    for illuminant in ILLUMINANTS:
        env.illuminant = illuminant
        for m in basis_grid:
            env.basis_size = m
            white_by_basis[f"{illuminant}/{m}"] = prt.environment_white_xyz(scene).tolist()
    albedo_rgb = albedo_rgb_at_vertices(obj)

    errors, bakes, rgb_rows, window_rows, frame_rows = [], [], [], [], []
    with Target(SIZE, SIZE) as target:
        bench = FrameBench(scene, obj, target)
        for bands in bands_grid:
            env.bands = bands
            for rays in rays_grid:
                env.illuminant, env.basis_size = ILLUMINANTS[0], MAIN_BASIS
                env.window = DEFAULT_WINDOW
                obj.spectral_prt.rays = rays
                start = time.perf_counter()
                baked = prt.bake_prt(obj, scene)
                wall = time.perf_counter() - start
                transfer = np.asarray(baked.coefficients, dtype=np.float64)
                bakes.append({"bands": bands, "rays": rays, "seconds": baked.seconds,
                              "wall_seconds": wall, "rays_cast": int(baked.rays_cast),
                              "rays_per_second": baked.rays_per_second,
                              "backend": baked.backend,
                              "sh_coefficients": int(transfer.shape[1])})
                line = []
                for illuminant in ILLUMINANTS:
                    env.illuminant = illuminant
                    reference, white = references[illuminant], whites[illuminant]
                    for m in basis_grid:
                        env.basis_size = m
                        start = time.perf_counter()
                        xyz = prt.vertex_xyz(obj, scene)
                        evaluate = time.perf_counter() - start
                        row = {"illuminant": illuminant, "bands": bands, "rays": rays,
                               "basis": m, "window": DEFAULT_WINDOW, "eval_seconds": evaluate,
                               **stats(colour_pipeline.delta_e94(reference, xyz, white))}
                        errors.append(row)
                        if m == MAIN_BASIS:
                            line.append(f"{illuminant} {row['mean']:.2f}/{row['p95']:.2f}")
                    if rays == main_rays:
                        # The basis sweep again without a window (see the window table).
                        env.window = "NONE"
                        for m in basis_grid:
                            env.basis_size = m
                            xyz = prt.vertex_xyz(obj, scene)
                            errors.append({"illuminant": illuminant, "bands": bands,
                                           "rays": rays, "basis": m, "window": "NONE",
                                           **stats(colour_pipeline.delta_e94(reference, xyz,
                                                                             white))})
                        env.window = DEFAULT_WINDOW
                    env.basis_size = MAIN_BASIS
                    rgb_rows.append({"illuminant": illuminant, "bands": bands, "rays": rays,
                                     "basis": MAIN_BASIS,
                                     **rgb_errors(obj, scene, transfer, albedo_rgb, reference,
                                                  white, bands)})
                    if rays == main_rays:
                        for sky in SKIES:
                            set_sky(env, sky)
                            ref, w = (reference, white) if sky == next(iter(SKIES)) else \
                                sky_references[sky, illuminant]
                            for window in WINDOWS:
                                env.window = window
                                xyz = prt.vertex_xyz(obj, scene)
                                window_rows.append({
                                    "sky": sky, "illuminant": illuminant, "bands": bands,
                                    "rays": rays, "basis": MAIN_BASIS, "window": window,
                                    **stats(colour_pipeline.delta_e94(ref, xyz, w))})
                        env.window = DEFAULT_WINDOW
                        set_sky(env, next(iter(SKIES)))
                log(f"  bands {bands} rays {rays:5d}: bake {baked.seconds:6.2f} s "
                    f"({baked.rays_per_second / 1e6:5.2f} Mrays/s {baked.backend}, wall "
                    f"{wall:5.2f} s); ΔE94 mean/p95 at m = {MAIN_BASIS}: {', '.join(line)}")
            # Frame time depends on bands and basis only: the last bake (the most rays) is
            # drawn. Check that the draw path picked up that bake.
            env.illuminant = ILLUMINANTS[0]
            for m in basis_grid:
                env.basis_size = m
                bench.frame(False)
                entry = prt_gpu._OBJECTS[obj.name]
                if not np.array_equal(entry["arrays"].transfer, baked.coefficients):
                    raise RuntimeError("prt_gpu drew a stale transfer")
                row = {"bands": bands, "basis": m, "covered_pixels": bench.covered(False),
                       **bench.measure(args.frames, args.reps),
                       "bytes": texture_bytes(obj, scene, baked.coefficients)}
                frame_rows.append(row)
                log(f"  bands {bands} m {m:2d}: {row['ms']:6.1f} ms/frame, RGB "
                    f"{row['rgb_ms']:5.1f} ms, ratio {row['ratio']:4.2f} (CPU "
                    f"{row['cpu_ms']:.2f} ms, first frame after a switch "
                    f"{row['switch_ms']:.1f} ms)")
        # The headline: spectral against RGB PRT at bands 5, basis 8, measured longer.
        env.bands, env.basis_size, env.illuminant = MAIN_BANDS, MAIN_BASIS, ILLUMINANTS[0]
        obj.spectral_prt.rays = main_rays
        prt.bake_prt(obj, scene)
        bench.frame(False)
        headline = {"bands": MAIN_BANDS, "basis": MAIN_BASIS, "rays": main_rays,
                    "covered_pixels": bench.covered(False),
                    **bench.measure(args.frames * 2, args.reps * 2)}
        log(f"  headline bands {MAIN_BANDS} m {MAIN_BASIS}: {headline['ms']:.1f} ms/frame, "
            f"RGB {headline['rgb_ms']:.1f} ms, spectral/RGB {headline['ratio']:.2f}")
    info["load_end"] = os.getloadavg()[0]
    return {
        "date": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
        "command": " ".join(["python", "scripts/bench_prt.py", *sys.argv[1:]]),
        "seconds": time.perf_counter() - started, "machine": info, "quick": args.quick,
        "settings": {"size": SIZE, "frames_per_block": args.frames, "blocks": args.reps,
                     "reference_rays": args.reference_rays, "bands": bands_grid,
                     "rays": rays_grid, "basis": basis_grid, "illuminants": list(ILLUMINANTS),
                     "windows": list(WINDOWS), "main": {"bands": MAIN_BANDS, "rays": main_rays,
                                                        "basis": MAIN_BASIS},
                     "skies": {k: list(v) for k, v in SKIES.items()},
                     "sun_elevation_deg": float(np.degrees(env.sun_elevation)),
                     "sun_azimuth_deg": float(np.degrees(env.sun_azimuth)),
                     "albedo": "CHART",
                     "mesh": {**mesh_info, "gpu_vertices": len(
                         prt_gpu._OBJECTS[obj.name]["arrays"].positions)},
                     "camera": {"location": CAMERA_LOCATION, "target": CAMERA_TARGET}},
        "whites": {k: v.tolist() for k, v in whites.items()},
        "sky_whites": {f"{sky}/{ill}": w.tolist()
                       for (sky, ill), (_, w) in sky_references.items()},
        "whites_by_basis": white_by_basis, "reference_noise": noise,
        "errors": errors, "bakes": bakes, "rgb": rgb_rows, "windows": window_rows,
        "frames": frame_rows, "headline": headline,
        "paper": {"spectral_over_rgb": list(PAPER_RATIO)}, "goal_ratio": GOAL_RATIO,
    }


# ------------------------------------------------------------------ reports


def fmt_bytes(n: int) -> str:
    return f"{n:,}".replace(",", " ")


def _pick(rows, **where):
    for r in rows:
        if all(r[k] == v for k, v in where.items()):
            return r
    return None


def _err(results: dict, ill: str, bands: int, rays: int, basis: int) -> dict | None:
    """The error row of a setting with the default window."""
    return _pick(results["errors"], window=DEFAULT_WINDOW, illuminant=ill, bands=bands, rays=rays,
                 basis=basis)


def _e(r) -> str:
    return "– | – | –" if r is None else f"{r['mean']:.2f} | {r['p95']:.2f} | {r['max']:.2f}"


def headline_table(results: dict) -> list[str]:
    h = results["headline"]
    main = results["settings"]["main"]
    lines = ["| illuminant | spectral ΔE94 mean | p95 | max | RGB PRT ΔE94 mean | p95 | max | "
             "spectral ms/frame | RGB ms/frame | spectral / RGB |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for ill in results["settings"]["illuminants"]:
        s = _err(results, ill, main["bands"], main["rays"], main["basis"])
        r = _pick(results["rgb"], illuminant=ill, bands=main["bands"], rays=main["rays"])
        lines.append(f"| {ill} | {_e(s)} | {_e(r['drawn'] if r else None)} | {h['ms']:.1f} | "
                     f"{h['rgb_ms']:.1f} | {h['ratio']:.2f} |")
    return lines


def bands_table(results: dict) -> list[str]:
    main = results["settings"]["main"]
    ills = results["settings"]["illuminants"]
    head = "| bands | SH coeffs |"
    rule = "|---|---|"
    for ill in ills:
        head += f" {ill} ΔE94 mean | p95 | max |"
        rule += "---|---|---|"
    head += " bake s | Mrays/s | ms/frame | × RGB | transfer bytes (GPU) |"
    rule += "---|---|---|---|---|"
    lines = [head, rule]
    for bands in results["settings"]["bands"]:
        b = _pick(results["bakes"], bands=bands, rays=main["rays"])
        f = _pick(results["frames"], bands=bands, basis=main["basis"])
        line = f"| {bands} | {bands * bands} |"
        for ill in ills:
            line += f" {_e(_err(results, ill, bands, main['rays'], main['basis']))} |"
        line += (f" {b['seconds']:.2f} | {b['rays_per_second'] / 1e6:.2f} | "
                 + (f"{f['ms']:.1f} | {f['ratio']:.2f} | "
                    f"{fmt_bytes(f['bytes']['transfer_texture'])} |" if f else "– | – | – |"))
        lines.append(line)
    return lines


def basis_table(results: dict) -> list[str]:
    main = results["settings"]["main"]
    ills = results["settings"]["illuminants"]
    head = "| basis m |"
    rule = "|---|"
    for ill in ills:
        head += f" {ill} ΔE94 mean | p95 | max |"
        rule += "---|---|---|"
    head += " ms/frame | RGB ms/frame | × RGB | albedo texture bytes |"
    rule += "---|---|---|---|"
    lines = [head, rule]
    for m in results["settings"]["basis"]:
        f = _pick(results["frames"], bands=main["bands"], basis=m)
        line = f"| {m} |"
        for ill in ills:
            line += f" {_e(_err(results, ill, main['bands'], main['rays'], m))} |"
        line += (f" {f['ms']:.1f} | {f['rgb_ms']:.1f} | {f['ratio']:.2f} | "
                 f"{fmt_bytes(f['bytes']['albedo_texture'])} |" if f else " – | – | – | – |")
        lines.append(line)
    return lines


def rays_table(results: dict) -> list[str]:
    main = results["settings"]["main"]
    ills = results["settings"]["illuminants"]
    head = "| rays | rays cast | bake s (tracing) | bake s (wall) | Mrays/s | backend |"
    rule = "|---|---|---|---|---|---|"
    for ill in ills:
        head += f" {ill} ΔE94 mean | p95 | max |"
        rule += "---|---|---|"
    lines = [head, rule]
    for rays in results["settings"]["rays"]:
        b = _pick(results["bakes"], bands=main["bands"], rays=rays)
        line = (f"| {rays} | {fmt_bytes(b['rays_cast'])} | {b['seconds']:.2f} | "
                f"{b['wall_seconds']:.2f} | {b['rays_per_second'] / 1e6:.2f} | "
                f"{b['backend']} |")
        for ill in ills:
            line += f" {_e(_err(results, ill, main['bands'], rays, main['basis']))} |"
        lines.append(line)
    return lines


def rgb_table(results: dict) -> list[str]:
    main = results["settings"]["main"]
    ills = results["settings"]["illuminants"]
    head = "| bands |"
    rule = "|---|"
    for ill in ills:
        head += f" {ill} spectral mean | p95 | max | {ill} RGB mean | p95 | max |"
        rule += "---|---|---|---|---|---|"
    head += " spectral ms/frame | RGB ms/frame | × RGB |"
    rule += "---|---|---|"
    lines = [head, rule]
    for bands in results["settings"]["bands"]:
        line = f"| {bands} |"
        for ill in ills:
            s = _err(results, ill, bands, main["rays"], main["basis"])
            r = _pick(results["rgb"], illuminant=ill, bands=bands, rays=main["rays"])
            line += f" {_e(s)} | {_e(r['drawn'] if r else None)} |"
        f = _pick(results["frames"], bands=bands, basis=main["basis"])
        line += f" {f['ms']:.1f} | {f['rgb_ms']:.1f} | {f['ratio']:.2f} |" if f else \
            " – | – | – |"
        lines.append(line)
    return lines


def grid(results: dict, rows: list[dict], value, cols: list, col_key: str,
         label: str) -> list[str]:
    """A bands × ``cols`` grid of ``value(row)``."""
    lines = [f"| bands \\ {label} | " + " | ".join(str(c) for c in cols) + " |",
             "|---|" + "---|" * len(cols)]
    for bands in results["settings"]["bands"]:
        cells = []
        for c in cols:
            r = _pick(rows, bands=bands, **{col_key: c})
            cells.append("–" if r is None else value(r))
        lines.append(f"| {bands} | " + " | ".join(cells) + " |")
    return lines


def window_table(results: dict) -> list[str]:
    ills = results["settings"]["illuminants"]
    head = "| sky | bands |"
    rule = "|---|---|"
    for ill in ills:
        for w in WINDOWS:
            head += f" {ill} {w.lower()} |"
            rule += "---|"
    lines = [head, rule]
    for sky in results["settings"]["skies"]:
        for bands in results["settings"]["bands"]:
            line = f"| {sky} | {bands} |"
            for ill in ills:
                for w in WINDOWS:
                    r = _pick(results["windows"], sky=sky, illuminant=ill, bands=bands,
                              window=w)
                    line += " – |" if r is None else f" {r['mean']:.2f} / {r['p95']:.2f} |"
            lines.append(line)
    return lines


def all_rows_table(results: dict) -> list[str]:
    lines = ["| illuminant | window | bands | rays | basis m | ΔE94 mean | p95 | max | bake s | "
             "ms/frame | × RGB |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in results["errors"]:
        b = _pick(results["bakes"], bands=r["bands"], rays=r["rays"])
        f = _pick(results["frames"], bands=r["bands"], basis=r["basis"])
        lines.append(f"| {r['illuminant']} | {r['window'].lower()} | {r['bands']} | "
                     f"{r['rays']} | {r['basis']} | "
                     f"{_e(r)} | {b['seconds']:.2f} | "
                     + (f"{f['ms']:.1f} | {f['ratio']:.2f} |" if f else "– | – |"))
    return lines


def tables(results: dict) -> dict[str, list[str]]:
    main = results["settings"]["main"]
    basis, rays = results["settings"]["basis"], results["settings"]["rays"]
    out = {"headline": headline_table(results), "bands": bands_table(results),
           "basis": basis_table(results), "rays": rays_table(results),
           "rgb": rgb_table(results), "windows": window_table(results)}
    for ill in results["settings"]["illuminants"]:
        for window in (DEFAULT_WINDOW, "LANCZOS"):
            rows = [r for r in results["errors"] if r["illuminant"] == ill and
                    r["rays"] == main["rays"] and r["window"] == window]
            suffix = "" if window == DEFAULT_WINDOW else " lanczos"
            out[f"mean {ill}{suffix}"] = grid(results, rows, lambda r: f"{r['mean']:.2f}",
                                              basis, "basis", "m")
            out[f"p95 {ill}{suffix}"] = grid(results, rows, lambda r: f"{r['p95']:.2f}",
                                             basis, "basis", "m")
    out["bake"] = grid(results, results["bakes"], lambda r: f"{r['seconds']:.2f}", rays,
                       "rays", "rays")
    out["frame"] = grid(results, results["frames"], lambda r: f"{r['ms']:.1f}", basis,
                        "basis", "m")
    out["ratio"] = grid(results, results["frames"], lambda r: f"{r['ratio']:.2f}", basis,
                        "basis", "m")
    return out


def write_markdown(results: dict, t: dict, path: Path) -> None:
    m = results["machine"]
    s = results["settings"]
    main = s["main"]
    h = results["headline"]
    mesh = s["mesh"]
    noise = results["reference_noise"]
    ills = s["illuminants"]
    rgb_control = max(abs(r["drawn"]["mean"] - r["exact_environment"]["mean"])
                      for r in results["rgb"])
    eval_s = float(np.median([r["eval_seconds"] for r in results["errors"]
                              if "eval_seconds" in r]))
    cpu_ms = float(np.median([f["cpu_ms"] for f in results["frames"]]))
    switch_ms = float(np.median([f["switch_ms"] for f in results["frames"]]))
    covered = h["covered_pixels"]
    goal = "meets" if h["ratio"] <= GOAL_RATIO else "misses"
    lines = [
        "# Spectral PRT benchmark: error against run time", "",
        f"Machine: `{m['renderer']}` ({m['vendor']}, {m['version']}, {m['backend']} backend; "
        f"{m['cpu_count']} CPU cores, Blender {m['blender']}, NumPy {m['numpy']}). Date: "
        f"{results['date']}. Command: `{results['command']}` ({results['seconds']:.0f} s in "
        f"all). Load average (1 min) {m['load_start']:.1f} at the start, "
        f"{m['load_end']:.1f} at the end: other jobs share these cores, hence the ratios.",
        "",
        "## What is measured, and how", "",
        f"**Scene.** One self-shadowing mesh: Suzanne with {mesh['monkey_subdivisions']} "
        f"subdivision levels applied, joined with a {FLOOR_SIZE:g} × {FLOOR_SIZE:g} floor "
        f"grid ({mesh['floor_subdivisions']} × {mesh['floor_subdivisions']} subdivisions) "
        f"under it: {fmt_bytes(mesh['vertices'])} vertices, {fmt_bytes(mesh['triangles'])} "
        "triangles, the primitives' default UVs. Albedo \"CHART\": the 24 ColorChecker "
        "patches (colour-science's N Ohta spectra) laid over the UV square. Environment: "
        "a CIE overcast sky (no sun) under **FL4** (a spiky fluorescent, the spectral PRT "
        "paper's case) and under **D65**, SH window NONE (the add-on's default), no "
        "rotation.", "",
        f"**Error.** ΔE94 per vertex (shared/PROTOCOL.md) of `prt.vertex_xyz` (the float64 "
        "evaluation of what the shader draws: T̃ · L̃ per vertex, times the R̃ layers sampled "
        f"at the vertex's UV) against `prt.vertex_reference_xyz`: a Monte Carlo reference on "
        f"the 5 nm grid with the true, unprojected sky and {s['reference_rays']} "
        "cosine-distributed rays per vertex against the same triangles, computed once per "
        "illuminant (it depends on none of the swept settings). Lab white: "
        "`prt.environment_white_xyz` (the white up-facing Lambertian under the "
        f"environment, Y = 1) at basis m = {max(s['basis'])}, one per illuminant for every "
        "row; it moves by less than "
        f"{white_spread(results):.1e} in X and Z between the basis sizes. Mean, 95th "
        "percentile and maximum over all vertices (a Lambertian PRT vertex is always "
        "\"lit\": the sky covers the whole upper hemisphere). **Noise floor** of the "
        "reference: a second reference with another seed differs from the first by "
        + ", ".join(f"{ill} {noise[ill]['mean']:.3f} / {noise[ill]['p95']:.3f} / "
                    f"{noise[ill]['max']:.3f}" for ill in ills)
        + " (mean / p95 / max); that is √2 × one reference's own error, so differences "
        "of a few hundredths in the tables below are not significant.", "",
        "**Bake.** `prt.bake_prt` once per (SH bands, rays per vertex): the tracing "
        "seconds, rays cast and rays/s it reports (`TransferBake`; rays below a vertex's "
        "horizon are not cast), and the wall time of the whole call (mesh read, BVH "
        "build, SH projection, storing the attributes and the albedo layers). The "
        "spectral basis size does not enter the bake: it is varied afterwards (the "
        "add-on's caches are keyed by it). Evaluating `prt.vertex_xyz` takes "
        f"{1e3 * eval_s:.0f} ms (median over the rows).", "",
        f"**Frame time.** The object drawn by `prt_gpu.draw_prt_objects` from the scene "
        f"camera into a {s['size']} × {s['size']} RGBA32F offscreen (`offscreen.Target`, "
        f"depth test), {fmt_bytes(covered)} pixels covered, output DISPLAY. A frame is a "
        "clear, the call, and a 1-pixel read-back, which cannot return before the frame "
        "is done; ms/frame is the median over the frames. Per (SH bands, basis size) "
        f"{s['blocks']} spectral blocks of {s['frames_per_block']} frames alternate with "
        f"{s['blocks'] + 1} RGB blocks (R S R S … R) of classical RGB PRT (`rgb=True`: "
        "L̃ and the albedo reduced to linear sRGB, one albedo layer) drawing the same mesh "
        "to the same target; **× RGB** is the median over the spectral blocks of the "
        "block's median over the mean of the RGB blocks on either side, so that the "
        "machine's changing load cancels. Each block starts with one untimed frame, "
        "because `prt_gpu` keeps one set of textures per object and switching between "
        f"spectral and RGB rebuilds them (that frame took {switch_ms:.0f} ms, median). "
        "The call itself, until it returns, takes "
        f"{cpu_ms:.2f} ms per frame (median; on llvmpipe it includes what the driver does "
        "on the calling thread). `prt_gpu` uploads one GPU vertex per distinct (mesh "
        f"vertex, UV) pair ({fmt_bytes(mesh['gpu_vertices'])} for "
        f"{fmt_bytes(mesh['vertices'])} vertices and {fmt_bytes(mesh['corners'])} corners), "
        "so the vertex stage's T̃ · L̃ runs "
        f"{mesh['gpu_vertices'] / mesh['vertices']:.2f}× per mesh vertex. The headline "
        f"ratio (bands {main['bands']}, m = "
        f"{main['basis']}) is measured separately with {h['frames']} spectral frames. The "
        "absolute times are this machine's only (llvmpipe is a CPU rasteriser: they are "
        "not GPU times).", "",
        "**RGB PRT's error**: `core.prt.rgb_vertex_xyz` with the same transfer, L̃ reduced "
        "to sRGB as `rgb=True` draws it (the environment on the scene's basis m = "
        f"{main['basis']}) and `core.prt.rgb_albedo` (sRGB under D65, white → 1) of the "
        "albedo spectra at the vertices (`prt.vertex_albedo_spectra`, filtered as the "
        "reference's albedo is). Control: with the environment projected without any "
        "basis (all 81 samples) its ΔE94 mean moves by at most "
        f"{rgb_control:.3f}: RGB PRT's error is the RGB reduction's, not the basis'.", "",
        "## Spectral against RGB PRT", "",
        f"Bands {main['bands']}, rays {main['rays']}, basis m = {main['basis']}:", "",
        *t["headline"], "",
        f"Spectral PRT costs **{h['ratio']:.2f}×** the frame time of RGB PRT here "
        f"(the spectral PRT paper measured {PAPER_RATIO[0]:g}–{PAPER_RATIO[1]:g}×; the goal "
        f"is ≤ {GOAL_RATIO:g}×: this run {goal} it).", "",
        f"By SH bands (rays {main['rays']}, m = {main['basis']}):", "",
        *t["rgb"], "",
        "## How to read this", "",
        "- ΔE94 < 1 is invisible, < 2 almost unseeable, 5 clearly noticeable (protocol). "
        "Look at the mean and p95; the maximum is a single vertex.",
        *window_note(results),
        "- Three things limit spectral PRT's accuracy, each swept separately: the SH "
        "bands (the transfer and the light are low-pass filtered: sharp self-shadowing "
        "needs more bands), the rays per vertex of "
        "the bake (the transfer's own noise; it costs bake time only) and the spectral "
        "basis size m (the spectra of the albedo × CMF products and of the illuminant; "
        "it costs frame time and texture bytes). Frame time depends on bands "
        "(vertex stage: ⌈bands²/4⌉ transfer texels × ⌈m/4⌉ environment texels per "
        "vertex) and on m (fragment stage: 4 m albedo texel fetches per pixel, against 4 "
        "for RGB PRT).",
        *rgb_note(results),
        "- Compare the × RGB columns across machines, not the ms.", "",
        f"## SH bands (rays {main['rays']}, m = {main['basis']})", "",
        *t["bands"], "",
        f"## Spectral basis size (bands {main['bands']}, rays {main['rays']})", "",
        *t["basis"], "",
        f"## Rays per vertex (bands {main['bands']}, m = {main['basis']})", "",
        *t["rays"], "",
        "## Grids", "",
        f"ΔE94 mean and p95 over bands × basis size, rays {main['rays']}:", "",
    ]
    for ill in ills:
        lines += [f"{ill}, mean:", "", *t[f"mean {ill}"], "", f"{ill}, p95:", "",
                  *t[f"p95 {ill}"], ""]
    lines += ["The same with a LANCZOS window, whose own error hides the basis size's:", ""]
    for ill in ills:
        lines += [f"{ill}, mean, window LANCZOS:", "", *t[f"mean {ill} lanczos"], "",
                  f"{ill}, p95, window LANCZOS:", "", *t[f"p95 {ill} lanczos"], ""]
    lines += ["Bake seconds (tracing), bands × rays:", "", *t["bake"], "",
              "ms/frame, bands × basis size:", "", *t["frame"], "",
              "Spectral / RGB frame time, bands × basis size:", "", *t["ratio"], "",
              f"## SH window (rays {main['rays']}, m = {main['basis']})", "",
              "ΔE94 mean / p95 per window (the add-on's default is NONE), under the "
              "overcast sky of the other tables and under a CIE clear sky with a sun disc "
              f"carrying {SKIES['clear + sun'][1]:.0%} of the horizontal irradiance at "
              f"{s['sun_elevation_deg']:.0f}° elevation (its own reference, same rays):",
              "", *t["windows"], "", *window_summary(results), "",
              "## Every row", "",
              "<details><summary>All settings (illuminant × bands × rays × basis)</summary>",
              "", *all_rows_table(results), "", "</details>", ""]
    path.write_text("\n".join(lines))


def rgb_note(results: dict) -> list[str]:
    """One bullet: RGB PRT against spectral PRT at the fewest and the most bands."""
    main = results["settings"]["main"]
    lo, hi = results["settings"]["bands"][0], results["settings"]["bands"][-1]
    parts = []
    for ill in results["settings"]["illuminants"]:
        rgb = {b: _pick(results["rgb"], illuminant=ill, bands=b, rays=main["rays"])["drawn"]
               for b in (lo, hi)}
        spectral = {b: _err(results, ill, b, main["rays"], main["basis"]) for b in (lo, hi)}
        parts.append(f"{ill}: RGB {rgb[lo]['mean']:.2f} → {rgb[hi]['mean']:.2f} (p95 "
                     f"{rgb[lo]['p95']:.1f} → {rgb[hi]['p95']:.1f}), spectral "
                     f"{spectral[lo]['mean']:.2f} → {spectral[hi]['mean']:.2f} (p95 "
                     f"{spectral[lo]['p95']:.1f} → {spectral[hi]['p95']:.1f})")
    return [f"- RGB PRT multiplies sRGB light by sRGB albedo: right for a white-ish light "
            f"such as D65, wrong under FL4's spikes whatever the bands. Mean ΔE94 from "
            f"{lo} to {hi} bands (m = {main['basis']}): " + "; ".join(parts) + "."]


def window_note(results: dict) -> list[str]:
    """One bullet: how much of the error the default window makes, at the main setting."""
    main = results["settings"]["main"]
    parts = []
    for ill in results["settings"]["illuminants"]:
        default = _err(results, ill, main["bands"], main["rays"], main["basis"])
        lanczos = _pick(results["errors"], window="LANCZOS", illuminant=ill,
                        bands=main["bands"], rays=main["rays"], basis=main["basis"])
        if lanczos and default:
            parts.append(f"{ill} {default['mean']:.2f} → {lanczos['mean']:.2f}")
    if not parts:
        return []
    return [f"- A window costs accuracy here: at bands {main['bands']}, m = {main['basis']}, "
            "the mean ΔE94 goes " + ", ".join(parts) + " (NONE, the add-on's default → "
            "LANCZOS; see \"SH window\" and the LANCZOS grids)."]


def window_summary(results: dict) -> list[str]:
    """Which window is best per sky at the main bands (mean ΔE94 over the illuminants)."""
    bands = results["settings"]["main"]["bands"]
    parts = []
    for sky in results["settings"]["skies"]:
        means = {w: float(np.mean([r["mean"] for r in results["windows"] if r["sky"] == sky
                                   and r["bands"] == bands and r["window"] == w]))
                 for w in WINDOWS}
        best = min(means, key=means.get)
        parts.append(f"{sky}: {best.lower()} ({means[best]:.2f}; lanczos "
                     f"{means['LANCZOS']:.2f}, none {means['NONE']:.2f})")
    return [f"Lowest mean ΔE94 at bands {bands} (mean over the illuminants): "
            + "; ".join(parts) + ". A window multiplies band l of the light by w_l ≤ 1; the "
            "transfer is not windowed, so the low bands that carry most of a smooth sky's "
            "irradiance onto a diffuse surface are attenuated too: on a smooth sky a window "
            "only adds error, and it pays off only where the ringing of a sharp light "
            "(a sun) costs more than that."]


def white_spread(results: dict) -> float:
    """The largest spread of the white's X and Z across basis sizes, per illuminant."""
    spread = 0.0
    for ill in results["settings"]["illuminants"]:
        values = np.array([v for k, v in results["whites_by_basis"].items()
                           if k.startswith(f"{ill}/")])
        spread = max(spread, float(np.ptp(values[:, [0, 2]], axis=0).max()))
    return spread


# --------------------------------------------------------------------- main


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="Suzanne at 1 subdivision level and a small grid (smoke test)")
    parser.add_argument("--frames", type=int, default=None,
                        help="frames per timed block (default 6, 4 with --quick)")
    parser.add_argument("--reps", type=int, default=None,
                        help="spectral blocks per setting (default 4, 2 with --quick); the "
                             "headline doubles both")
    parser.add_argument("--reference-rays", type=int, default=REFERENCE_RAYS,
                        help="Monte Carlo rays per vertex of the reference")
    parser.add_argument("--out", default=str(ROOT / "docs"),
                        help="write bench_prt.md/.json here instead of docs/")
    parser.add_argument("--from-json", metavar="JSON", default=None,
                        help="measure nothing: write the Markdown of an earlier run's JSON "
                             "next to it and print its tables")
    args = parser.parse_args()
    args.frames = args.frames or (4 if args.quick else 6)
    args.reps = args.reps or (2 if args.quick else 4)
    if args.from_json:
        source = Path(args.from_json)
        results = json.loads(source.read_text())
        out, stem = source.parent, source.stem
        t = tables(results)
    else:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        results = run(args)
        t = tables(results)
        stem = "bench_prt_quick" if args.quick else "bench_prt"
        (out / f"{stem}.json").write_text(json.dumps(results, indent=1))
    write_markdown(results, t, out / f"{stem}.md")
    for title, key in (("Spectral against RGB PRT", "headline"), ("By SH bands", "rgb"),
                       ("SH bands", "bands"), ("Spectral basis size", "basis"),
                       ("Rays per vertex", "rays"), ("SH window", "windows"),
                       ("ms/frame", "frame"), ("spectral / RGB", "ratio")):
        print(f"\n{title}\n")
        print("\n".join(t[key]))
    for ill in results["settings"]["illuminants"]:
        for suffix, what in (("", "no window (default)"), (" lanczos", "window LANCZOS")):
            print(f"\nΔE94 mean {ill}, {what}\n")
            print("\n".join(t[f"mean {ill}{suffix}"]))
    h = results["headline"]
    log(f"\nspectral / RGB frame time at bands {h['bands']}, m = {h['basis']}: "
        f"{h['ratio']:.2f} ({h['ms']:.1f} / {h['rgb_ms']:.1f} ms)")
    written = f"{out / stem}.md" if args.from_json else f"{out / stem}.md/.json"
    log(f"wrote {written} (the run took {results['seconds']:.0f} s)")


if __name__ == "__main__":
    main()
