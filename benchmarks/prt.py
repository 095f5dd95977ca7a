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

    python -m benchmarks.prt              # the full sweep (~4 min on 2 cores, llvmpipe)
    python -m benchmarks.prt --quick      # a small mesh and grid (smoke test, < 1 min)
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import bpy
import numpy as np

from spectral_materials import blender as addon
from spectral_materials.blender.gpu.context import ensure_gpu
from spectral_materials.blender.gpu.offscreen import Target
from spectral_materials.blender.prt import drawer as prt_gpu, scene as prt
from spectral_materials.blender.viewport import draw

from . import harness
from .harness import log
from .prt_report import (
    DEFAULT_WINDOW,
    FLOOR_SIZE,
    GOAL_RATIO,
    PAPER_RATIO,
    SKIES,
    WINDOWS,
    tables,
    write_markdown,
)
from .prt_sweep import ILLUMINANTS, MAIN_BASIS, References, Sweep, set_sky, texture_bytes
from .scenes import factory_scene

#: (full, quick) sweeps.
BANDS = ([2, 3, 4, 5, 6, 7, 8], [2, 5, 8])
RAYS = ([64, 256, 1024, 4096], [64, 256])
BASIS = ([3, 4, 6, 8, 12, 16], [3, 8, 16])
#: The slices the Markdown tables show (rays at most the largest of the sweep).
MAIN_RAYS, MAIN_BANDS = 1024, 5
#: Monte Carlo reference: rays per vertex.
REFERENCE_RAYS = 4096
#: Suzanne's subdivision levels and the floor grid's subdivisions (full, quick).
SUBDIVISIONS = (2, 1)
FLOOR_SUBDIVISIONS = (20, 12)
SIZE = 512
CAMERA_LOCATION = (0.0, -4.6, 2.6)
CAMERA_TARGET = (0.0, 0.0, 0.8)


# ------------------------------------------------------------------------ scene


def build_scene(subdivisions: int, floor_subdivisions: int):
    """Factory scene, its camera kept, and one joined mesh: subdivided Suzanne on a floor."""
    from mathutils import Vector

    scene = factory_scene()
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

    def frame(self, rgb: bool, output: str = "DISPLAY") -> tuple[float, float]:
        """(wall seconds, seconds until draw_prt_objects returned) of one synced frame."""
        depsgraph = bpy.context.evaluated_depsgraph_get()
        start = time.perf_counter()
        self.target.framebuffer.clear(color=(0.0, 0.0, 0.0, 0.0), depth=1.0)
        vp, _ = draw.camera_view(self.scene.camera, SIZE, SIZE, depsgraph)
        drawn = prt_gpu.draw_prt_objects(self.scene, depsgraph, vp, rgb=rgb, output=output,
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

        def spectral_block() -> float:
            wall, c, f = self.block(False, frames)
            spectral_blocks.append(wall)
            cpu.extend(c)
            first.append(f)
            return float(np.median(wall))

        def rgb_block() -> float:
            rgb_blocks.append(self.block(True, frames)[0])
            return float(np.median(rgb_blocks[-1]))

        paired = harness.interleave(spectral_block, rgb_block, reps).ratios()
        spectral = [t for b in spectral_blocks for t in b]
        rgb = [t for b in rgb_blocks for t in b]
        return {"ms": 1e3 * float(np.median(spectral)), "rgb_ms": 1e3 * float(np.median(rgb)),
                "ratio": float(np.median(paired)), "paired": paired,
                "cpu_ms": 1e3 * float(np.median(cpu)),
                "switch_ms": 1e3 * float(np.median(first)),
                "frames": len(spectral), "rgb_frames": len(rgb),
                "spectral_seconds": spectral, "rgb_seconds": rgb}


# --------------------------------------------------------------------- the run




def frame_rows(bench: FrameBench, scene, obj, bands: int, baked, basis_grid: list[int],
               args) -> list[dict]:
    """Frame time per basis size of the last bake (frame time depends on bands and basis
    only), after checking that the draw path picked up that bake."""
    env = scene.spectral.environment
    env.illuminant = ILLUMINANTS[0]
    rows = []
    for m in basis_grid:
        env.basis_size = m
        bench.frame(False)
        entry = prt_gpu._OBJECTS[obj.name]
        if not np.array_equal(entry["arrays"].transfer, baked.coefficients):
            raise RuntimeError("prt_gpu drew a stale transfer")
        row = {"bands": bands, "basis": m, "covered_pixels": bench.covered(False),
               **bench.measure(args.frames, args.reps),
               "bytes": texture_bytes(obj, scene, baked.coefficients)}
        rows.append(row)
        log(f"  bands {bands} m {m:2d}: {row['ms']:6.1f} ms/frame, RGB "
            f"{row['rgb_ms']:5.1f} ms, ratio {row['ratio']:4.2f} (CPU "
            f"{row['cpu_ms']:.2f} ms, first frame after a switch "
            f"{row['switch_ms']:.1f} ms)")
    return rows


def headline(bench: FrameBench, scene, obj, main_rays: int, args) -> dict:
    """Spectral against RGB PRT at bands 5, basis 8, measured longer."""
    env = scene.spectral.environment
    env.bands, env.basis_size, env.illuminant = MAIN_BANDS, MAIN_BASIS, ILLUMINANTS[0]
    obj.spectral_prt.rays = main_rays
    prt.bake_prt(obj, scene)
    bench.frame(False)
    row = {"bands": MAIN_BANDS, "basis": MAIN_BASIS, "rays": main_rays,
           "covered_pixels": bench.covered(False),
           **bench.measure(args.frames * 2, args.reps * 2)}
    log(f"  headline bands {MAIN_BANDS} m {MAIN_BASIS}: {row['ms']:.1f} ms/frame, "
        f"RGB {row['rgb_ms']:.1f} ms, spectral/RGB {row['ratio']:.2f}")
    # The same with each other albedo form in the same run, and every form's colours
    # against the exact layers'.
    row["albedo"] = {"AUTO": _drawn_form(bench, obj)}
    try:
        for form in ("UNORM16", "BASIS", "EXACT"):
            obj.spectral_prt.albedo_texture = form
            timed = bench.measure(args.frames * 2, args.reps * 2)
            row["albedo"][form] = {**_drawn_form(bench, obj), **{k: timed[k] for k in (
                "ms", "rgb_ms", "ratio", "paired")}}
            log(f"  albedo {form}: spectral/RGB {timed['ratio']:.2f}")
    finally:
        obj.spectral_prt.albedo_texture = "AUTO"
    for form, errors in albedo_form_errors(bench, scene, obj).items():
        row["albedo"][form]["delta_e94"] = errors
        log(f"  albedo {form} against the exact layers: ΔE94 max "
            f"{max(e['max'] for e in errors.values()):.4f}")
    return row


def _drawn_form(bench: FrameBench, obj) -> dict:
    """What the object's spectral albedo texture holds (``core.prt.albedo_forms``)."""
    bench.frame(False)
    drawn = prt_gpu._OBJECTS[obj.name]["albedo_drawn"]
    out = {"form": drawn.form, "texture_layers": int(drawn.texels().shape[0]),
           "texel_bytes": 8 if drawn.texture_format == "RGBA16" else 16,
           "texel_delta_e94": drawn.delta_e94}
    if drawn.basis is not None:
        out.update(rank=drawn.basis.rank, value_error=drawn.basis.error)
    return out


def albedo_form_errors(bench: FrameBench, scene, obj) -> dict:
    """ΔE94 of the drawn image (XYZ output, covered pixels) with the 16-bit layers and
    with the basis against the exact layers, per illuminant, white = the environment's.
    llvmpipe filters with float weights; a GPU's 8-bit filter weights add to this
    (``albedo.sample_layers(..., weight_bits=8)``)."""
    from spectral_materials.core.colour.pipeline import delta_e94

    env = scene.spectral.environment
    illuminant = env.illuminant
    errors = {"UNORM16": {}, "BASIS": {}}
    try:
        for ill in ILLUMINANTS:
            env.illuminant = ill
            images = {}
            for form in ("EXACT", "UNORM16", "BASIS"):
                obj.spectral_prt.albedo_texture = form
                bench.frame(False, output="XYZ")
                images[form] = bench.target.read()
            covered = images["EXACT"][..., 3] > 0
            for form in errors:
                de = delta_e94(images["EXACT"][covered, :3].astype(np.float64),
                               images[form][covered, :3].astype(np.float64),
                               prt.environment_white_xyz(scene))
                errors[form][ill] = {"mean": float(de.mean()),
                                     "p95": float(np.percentile(de, 95)),
                                     "max": float(de.max())}
    finally:
        env.illuminant = illuminant
        obj.spectral_prt.albedo_texture = "AUTO"
    return errors


def settings(args, grids: tuple, main_rays: int, env, mesh_info: dict, obj) -> dict:
    bands_grid, rays_grid, basis_grid = grids
    return {"size": SIZE, "frames_per_block": args.frames, "blocks": args.reps,
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
            "camera": {"location": CAMERA_LOCATION, "target": CAMERA_TARGET}}


def run(args) -> dict:
    q = 1 if args.quick else 0
    grids = bands_grid, rays_grid, basis_grid = BANDS[q], RAYS[q], BASIS[q]
    main_rays = max(r for r in rays_grid if r <= MAIN_RAYS)
    started = time.perf_counter()
    addon.register()
    ensure_gpu()
    info = harness.gpu_machine()
    scene, obj, mesh_info = build_scene(SUBDIVISIONS[q], FLOOR_SUBDIVISIONS[q])
    env = scene.spectral.environment
    log(f"machine: {info['renderer']} ({info['backend']}), {info['cpu_count']} cores; mesh "
        f"{mesh_info['vertices']} vertices, {mesh_info['triangles']} triangles")
    # The bake enables the object, puts its albedo into the scene's basis and stores a
    # transfer: the references need it.
    env.bands, env.basis_size = MAIN_BANDS, max(basis_grid)
    obj.spectral_prt.rays = rays_grid[0]
    prt.bake_prt(obj, scene)
    refs = References(scene, obj, args.reference_rays, basis_grid)
    sweep = Sweep(scene, obj, refs, basis_grid, main_rays)
    frames = []
    with Target(SIZE, SIZE) as target:
        bench = FrameBench(scene, obj, target)
        for bands in bands_grid:
            env.bands = bands
            for rays in rays_grid:
                baked = sweep.bake(bands, rays)
            frames += frame_rows(bench, scene, obj, bands, baked, basis_grid, args)
        head = headline(bench, scene, obj, main_rays, args)
    info["load_end"] = harness.load_average()
    return {
        "date": harness.date_stamp(), "command": harness.command_line("prt"),
        "seconds": time.perf_counter() - started, "machine": info, "quick": args.quick,
        "settings": settings(args, grids, main_rays, env, mesh_info, obj),
        "whites": {k: v.tolist() for k, v in refs.whites.items()},
        "sky_whites": {f"{sky}/{ill}": w.tolist() for (sky, ill), (_, w) in refs.skies.items()},
        "whites_by_basis": refs.white_by_basis, "reference_noise": refs.noise,
        "errors": sweep.errors, "bakes": sweep.bakes, "rgb": sweep.rgb_rows,
        "windows": sweep.window_rows, "frames": frames, "headline": head,
        "paper": {"spectral_over_rgb": list(PAPER_RATIO)}, "goal_ratio": GOAL_RATIO,
    }


# --------------------------------------------------------------------- main


def parse_args(argv: list[str] | None = None):
    parser = harness.parser(
        __doc__, quick_help="Suzanne at 1 subdivision level and a small grid (smoke test)",
        out_help="write bench_prt.md/.json here instead of docs/")
    parser.add_argument("--frames", type=int, default=None,
                        help="frames per timed block (default 6, 4 with --quick)")
    parser.add_argument("--reps", type=int, default=None,
                        help="spectral blocks per setting (default 4, 2 with --quick); the "
                             "headline doubles both")
    parser.add_argument("--reference-rays", type=int, default=REFERENCE_RAYS,
                        help="Monte Carlo rays per vertex of the reference")
    parser.add_argument("--from-json", metavar="JSON", default=None,
                        help="measure nothing: write the Markdown of an earlier run's JSON "
                             "next to it and print its tables")
    args = parser.parse_args(argv)
    args.frames = args.frames or (4 if args.quick else 6)
    args.reps = args.reps or (2 if args.quick else 4)
    return args


def print_tables(results: dict, t: dict) -> None:
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


def main(argv: list[str] | None = None) -> None:
    args = parse_args(argv)
    if args.from_json:
        source = Path(args.from_json)
        results = json.loads(source.read_text())
        out, stem = source.parent, source.stem
    else:
        out, stem = Path(args.out), harness.output_stem("prt", args.quick)
        results = run(args)
        harness.write_json(out / f"{stem}.json", results)
    t = tables(results)
    write_markdown(results, t, out / f"{stem}.md")
    print_tables(results, t)
    h = results["headline"]
    log(f"\nspectral / RGB frame time at bands {h['bands']}, m = {h['basis']}: "
        f"{h['ratio']:.2f} ({h['ms']:.1f} / {h['rgb_ms']:.1f} ms)")
    written = f"{out / stem}.md" if args.from_json else f"{out / stem}.md/.json"
    log(f"wrote {written} (the run took {results['seconds']:.0f} s)")


if __name__ == "__main__":
    main()
