"""Draw benchmark: frame time of the spectral mesh shader against packs and lights.

A smooth UV sphere (128 segments × 64 rings) covering about 1.0 M pixels of an RGBA32F
offscreen (1200 × 1200, orthographic) is drawn through the add-on's own path
(``GPUMaterial``, ``shaders.get_shader``, ``MeshBatches``) with synthetic factor packs in
the factor-pack paper's layouts (io_iso 90×180×90 and hd 90×45×90×45, spectral basis of
8), for 1 … 48 packs and 1 … 8 lights. Every frame time is stated as a ratio against an
RGB Blinn–Phong shader (``glsl/brdf/baseline_blinn_phong_*.glsl``) drawing the same batch to
the same target with the same number of lights, measured in the same run and
interleaved with the spectral measurements (shared/PROTOCOL.md, "Time and memory"),
and as absolute ms/frame on the machine at hand. The texture memory of every
configuration and the shader's texture fetches and ALU per pack (counted from the
GLSL) are reported next to the factor-pack paper's figures. A control times the add-on's
variant against the same one with its pack loop kept rolled (:func:`rolled_shader`),
since the compiler's unrolling shows in the timings at a few packs.

Writes ``docs/bench_draw.md`` and ``docs/bench_draw.json`` (``--quick``:
``bench_draw_quick.*``; ``--device-out DIR`` writes to DIR instead of ``docs/``).

Usage::

    python -m benchmarks.draw              # the default grid (~6 min on 2 cores, llvmpipe)
    python -m benchmarks.draw --quick      # 400 × 400 target, small grid (< 1 min)
    python -m benchmarks.draw --device-out out/gpu   # on a machine with a GPU
    python -m benchmarks.draw --counts     # the fetch and ALU counts only
"""

from __future__ import annotations

import contextlib
import time
from pathlib import Path

import numpy as np

from spectral_materials.blender.brdf.gpu_material import GPUMaterial
from spectral_materials.blender.gpu import batches as mesh_batches, shaders
from spectral_materials.blender.gpu.context import ensure_gpu
from spectral_materials.blender.gpu.display import DisplaySettings
from spectral_materials.blender.gpu.matrices import set_matrix
from spectral_materials.blender.gpu.offscreen import Target
from spectral_materials.core.brdf.shading import light_texels, sphere_pixels
from spectral_materials.core.colour import spectra
from spectral_materials.core.lights import SpectralLight

from . import harness
from .draw_baseline import VIEW_ORIGIN, Baseline
from .draw_report import glsl_counts_markdown, main_table, ordered, write_markdown
from .draw_summary import MODES, PAPER_FPS, SERIES, glsl_counts, summaries
from .harness import log
from .scenes import factory_scene
from .synthetic import BASIS_SIZE, DISC_FRACTION, LAYOUTS, RINGS, SEGMENTS, synthetic_model

PACKS = [1, 2, 4, 8, 16, 22, 32, 48]
LIGHTS = [1, 2, 4, 8]
LIGHT_PACKS = [4, 22]
QUICK_PACKS = [1, 4, 22]
QUICK_LIGHTS = [1, 2, 4]
QUICK_LIGHT_PACKS = [4]
#: Packs of the rolled-loop control (io_iso, precontract, 1 light): see rolled_shader.
ROLLED_PACKS = [2, 4, 6, 8]
QUICK_ROLLED_PACKS = [4]
#: Lights beyond the first sit this far off the view axis, around it, at LIGHT_DISTANCE.
LIGHT_TILT_DEG = 10.0
LIGHT_DISTANCE = 10.0


# ------------------------------------------------------------------------ scene


def sphere_arrays() -> mesh_batches.MeshArrays:
    """A smooth UV sphere of radius 1 at the origin, read as the draw path reads meshes."""
    import bpy

    factory_scene(keep=())
    bpy.ops.mesh.primitive_uv_sphere_add(segments=SEGMENTS, ring_count=RINGS, radius=1.0)
    obj = bpy.context.active_object
    bpy.ops.object.shade_smooth()
    return mesh_batches.mesh_arrays(obj.data)


def view_projection(half_extent: float, distance: float = 5.0, near: float = 0.1,
                    far: float = 10.0) -> np.ndarray:
    """Orthographic camera at (0, 0, distance) looking down −z, ±half_extent across."""
    view = np.eye(4)
    view[2, 3] = -distance
    projection = np.diag([1.0 / half_extent, 1.0 / half_extent, -2.0 / (far - near), 1.0])
    projection[2, 3] = -(far + near) / (far - near)
    return projection @ view



def make_lights(count: int) -> list[SpectralLight]:
    """Sun, point, spot and area lights in turn, D65 and FL2, lighting the visible side.

    One light is a sun on the view axis (every visible pixel lit). More lights sit
    LIGHT_TILT_DEG off the view axis, spread around it, LIGHT_DISTANCE away, with
    strengths giving an irradiance of about 1 on the sphere.
    """
    wl = spectra.WAVELENGTHS_REFERENCE
    kinds = ("SUN", "POINT", "SPOT", "AREA")
    lights = []
    for i in range(count):
        kind = kinds[i % 4]
        spd_name = ("D65", "FL2")[(i + i // 4) % 2]
        tilt = 0.0 if count == 1 else np.radians(LIGHT_TILT_DEG)
        azimuth = 2.0 * np.pi * i / count
        toward = np.array([np.sin(tilt) * np.cos(azimuth), np.sin(tilt) * np.sin(azimuth),
                           np.cos(tilt)])
        r = LIGHT_DISTANCE - 1.0
        strength = {"SUN": 1.0, "POINT": 4 * np.pi * r * r, "SPOT": 4 * np.pi * r * r,
                    "AREA": np.pi * r * r}[kind]
        lights.append(SpectralLight(
            kind, spectra.illuminant(spd_name, wl), wl, strength=float(strength),
            position=tuple(LIGHT_DISTANCE * toward), axis=tuple(-toward),
            spot_size=np.radians(60.0), name=f"{kind} {spd_name}"))
    return lights


def lit_share(lights: list[SpectralLight]) -> float:
    """Mean over lights of the share of visible sphere pixels the light reaches.

    The spectral shader skips the packs where a light brings nothing (irradiance 0 or
    wi below the horizon); the baseline does not. Sampled on the projected disc.
    """
    points, _ = sphere_pixels(200)
    shares = []
    for light in lights:
        wi, irradiance = light.incidence(points)
        shares.append(float(np.mean((irradiance > 0) & (np.einsum("ij,ij->i", wi, points) > 0))))
    return float(np.mean(shares))




# ---------------------------------------------------------------------- timing


def sphere_batch():
    """The benchmark sphere (:func:`sphere_arrays`) as one batch."""
    (batch,) = mesh_batches.MeshBatches.build(sphere_arrays()).batches.values()
    return batch


@contextlib.contextmanager
def bench_target(size: int, batch, vp: np.ndarray, frames: int, reps: int):
    """A :class:`Bench` drawing ``batch`` into a ``size``² target with back faces culled
    (Blender's default, no culling, restored after)."""
    import gpu

    with Target(size, size) as target:
        gpu.state.face_culling_set("BACK")
        try:
            yield Bench(target, batch, vp, frames, reps)
        finally:
            gpu.state.face_culling_set("NONE")


class Bench:
    """One bound offscreen target and the sphere batch; times frames drawn into it."""

    def __init__(self, target: Target, batch, vp: np.ndarray, frames: int, reps: int):
        self.target, self.batch, self.vp = target, batch, vp
        self.frames, self.reps = frames, reps
        self.identity = np.eye(4)

    def frame(self, bind) -> None:
        """Clear and draw the sphere with the shader ``bind`` binds (returns the shader)."""
        self.target.framebuffer.clear(color=(0.0, 0.0, 0.0, 0.0), depth=1.0)
        shader = bind()
        set_matrix(shader, "model_matrix", self.identity)
        set_matrix(shader, "normal_matrix", self.identity)
        self.batch.draw(shader)

    def sync(self) -> None:
        """Wait for the GPU: a 1-pixel read-back cannot return before the frame is done."""
        self.target.framebuffer.read_color(0, 0, 1, 1, 4, 0, "FLOAT")

    def seconds_per_frame(self, bind, frames: int | None = None) -> float:
        frames = frames or self.frames
        start = time.perf_counter()
        for _ in range(frames):
            self.frame(bind)
        self.sync()
        return (time.perf_counter() - start) / frames

    def warm(self, bind) -> tuple[float, int, int]:
        """One frame (compiles the variant); (seconds, covered pixels, lit pixels)."""
        start = time.perf_counter()
        self.frame(bind)
        self.sync()
        seconds = time.perf_counter() - start
        image = self.target.read()
        covered = int(np.count_nonzero(image[..., 3] > 0))
        lit = int(np.count_nonzero(image[..., :3].max(axis=-1) > 0))
        return seconds, covered, lit

    def measure(self, layout: str, packs: int, lights: list[SpectralLight],
                precontract: bool) -> dict:
        """One configuration against the baseline, interleaved repetition by repetition."""
        model = synthetic_model(layout, packs)
        material = GPUMaterial(model)
        key = material.key(lights, precontract=precontract, output="DISPLAY")
        shader = shaders.get_shader(key)
        light_texture = material.light_texture(lights, precontract)
        params = material.params(DisplaySettings(), view_origin=VIEW_ORIGIN,
                                 view_projection=self.vp)

        def bind_spectral():
            material.bind(shader, light_texture, params)
            return shader

        baseline = Baseline(lights, self.vp)

        def bind_baseline():
            baseline.bind()
            return baseline.shader

        warm_s, covered, lit = self.warm(bind_spectral)
        base_warm, base_covered, _ = self.warm(bind_baseline)
        # B S B S … S B: each spectral timing has a baseline timing on either side,
        # long enough (up to 4× the frames) to span about half the spectral timing,
        # so that both see the same share of the other jobs on the machine.
        base_frames = int(np.clip(round(0.5 * self.frames * warm_s / base_warm),
                                  self.frames, 4 * self.frames))
        timings = harness.interleave(
            lambda: self.seconds_per_frame(bind_spectral),
            lambda: self.seconds_per_frame(bind_baseline, base_frames), self.reps)
        return {
            "layout": layout, "resolution": list(LAYOUTS[layout]), "packs": packs,
            "terms": model.terms, "lights": len(lights),
            "light_kinds": [light.name for light in lights],
            "mode": MODES[precontract],
            "baseline_frames": base_frames,
            **_timing_figures(timings),
            "first_frame_seconds": warm_s, "covered_pixels": covered,
            "baseline_covered_pixels": base_covered, "lit_pixels": lit,
            "lit_share": lit_share(lights),
            **_texture_bytes(model, material, lights, precontract),
        }


def _timing_figures(timings: harness.Interleaved) -> dict:
    """ms/frame (medians), FPS and the paired ratios of one configuration."""
    ms = 1e3 * float(np.median(timings.candidate))
    paired = timings.ratios()
    return {"ms": ms, "fps": 1e3 / ms, "baseline_ms": 1e3 * float(np.median(timings.baseline)),
            "ratio": float(np.median(paired)), "paired_ratios": paired,
            "spectral_seconds": timings.candidate, "baseline_seconds": timings.baseline}


def _texture_bytes(model, material: GPUMaterial, lights: list[SpectralLight],
                   precontract: bool) -> dict:
    light_bytes = int(light_texels(model, lights, precontract=precontract).nbytes)
    return {"factor_texture_bytes": int(material.nbytes), "light_texture_bytes": light_bytes,
            "texture_bytes": int(material.nbytes) + light_bytes}


def compare_rolled(bench: Bench, layout: str, packs: int) -> dict | None:
    """The add-on's variant (1 light, precontract) against :func:`rolled_shader`'s.

    The two are timed alternately, U R U R … U, on the same material and target;
    ``unrolled_over_rolled`` is the median of U over the mean of the R on either side.
    """
    model = synthetic_model(layout, packs)
    material = GPUMaterial(model)
    lights = make_lights(1)
    key = material.key(lights, precontract=True, output="DISPLAY")
    rolled = rolled_shader(key)
    if rolled is None:
        return None
    unrolled = shaders.get_shader(key)
    light_texture = material.light_texture(lights, True)
    params = material.params(DisplaySettings(), view_origin=VIEW_ORIGIN, view_projection=bench.vp)

    def binder(shader):
        def bind():
            material.bind(shader, light_texture, params)
            return shader
        return bind

    bind_unrolled, bind_rolled = binder(unrolled), binder(rolled)
    bench.warm(bind_unrolled)
    bench.warm(bind_rolled)
    timings = harness.interleave(lambda: bench.seconds_per_frame(bind_rolled),
                                 lambda: bench.seconds_per_frame(bind_unrolled), bench.reps)
    paired = timings.inverse_ratios()
    return {"layout": layout, "packs": packs, "lights": 1, "mode": "precontract",
            "unrolled_ms": 1e3 * float(np.median(timings.baseline)),
            "rolled_ms": 1e3 * float(np.median(timings.candidate)),
            "unrolled_over_rolled": float(np.median(paired)), "paired": paired,
            "unrolled_seconds": timings.baseline, "rolled_seconds": timings.candidate}


def rolled_shader(key: shaders.ShaderKey):
    """The variant ``key`` with the pack loop's bound unknown to the compiler.

    ``p < SM_PACKS + sm.misc.w`` (misc.w is 0) stops the compiler unrolling the loop
    over packs; everything else is the add-on's shader. A control for the cost of
    unrolling on this machine; None where the GLSL has no such loop any more.
    """
    import gpu

    source = shaders.fragment_source()
    patched = source.replace("p < SM_PACKS", "p < SM_PACKS + sm.misc.w")
    if patched == source:
        return None
    return gpu.shader.create_from_info(shaders.create_info(key, fragment=patched))


# --------------------------------------------------------------------- main


def parse_args(argv: list[str] | None = None):
    parser = harness.parser(
        __doc__, quick_help="400 × 400 target and a small grid (smoke test, < 1 min)",
        out_help="write bench_draw.md/.json here instead of docs/", device_out=True)
    parser.add_argument("--size", type=int, default=None,
                        help="target side in pixels (default 1200: the sphere covers ~1.0 M "
                             "pixels; 400 with --quick)")
    parser.add_argument("--frames", type=int, default=3, help="frames per timing")
    parser.add_argument("--counts", action="store_true",
                        help="print the fetches and ALU per pack counted from glsl/ and stop "
                             "(no drawing)")
    parser.add_argument("--reps", type=int, default=None,
                        help="repetitions per configuration (median; default 5, 3 with "
                             "--quick)")
    args = parser.parse_args(argv)
    args.size = args.size or (400 if args.quick else 1200)
    args.reps = args.reps or (3 if args.quick else 5)
    return args


def sweep(bench: Bench, quick: bool) -> tuple[list[dict], list[dict], list[int]]:
    """The packs and lights sweeps, then the rolled-loop control: (rows, rolled rows,
    the pack counts of the lights sweep)."""
    packs_grid = QUICK_PACKS if quick else PACKS
    lights_grid = QUICK_LIGHTS if quick else LIGHTS
    light_packs = QUICK_LIGHT_PACKS if quick else LIGHT_PACKS
    configs = [(layout, p, 1, pre) for layout, pre in SERIES for p in packs_grid]
    configs += [("io_iso", p, n, True) for p in light_packs for n in lights_grid if n > 1]
    rows, rolled_rows = [], []
    for layout, packs, n_lights, pre in configs:
        row = bench.measure(layout, packs, make_lights(n_lights), pre)
        rows.append(row)
        log(f"  {layout:6s} {packs:2d} packs {n_lights} lights {row['mode']:12s} "
            f"{row['ms']:8.1f} ms  baseline {row['baseline_ms']:6.1f} ms  "
            f"ratio {row['ratio']:6.1f}  covered {row['covered_pixels']}")
    for packs in QUICK_ROLLED_PACKS if quick else ROLLED_PACKS:
        row = compare_rolled(bench, "io_iso", packs)
        if row is None:
            log("  no pack loop to keep rolled in glsl/: control skipped")
            break
        rolled_rows.append(row)
        log(f"  io_iso {packs:2d} packs unrolled {row['unrolled_ms']:8.1f} ms  rolled "
            f"{row['rolled_ms']:8.1f} ms  unrolled/rolled {row['unrolled_over_rolled']:.2f}")
    return rows, rolled_rows, light_packs


def settings(args, arrays: mesh_batches.MeshArrays) -> dict:
    return {"size": args.size, "frames": args.frames, "reps": args.reps,
            "segments": SEGMENTS, "rings": RINGS,
            "triangles": int(sum(len(t) for t in arrays.triangles.values())),
            "corners": len(arrays.positions), "vertex_bytes": arrays.nbytes,
            "disc_radius_px": DISC_FRACTION * args.size,
            "expected_pixels": float(np.pi * (DISC_FRACTION * args.size) ** 2),
            "basis_size": BASIS_SIZE,
            "layouts": {k: list(v) for k, v in LAYOUTS.items()}}


def run(args) -> dict:
    """Build the sphere, time the sweeps into one target and gather the results."""
    started = time.perf_counter()
    ensure_gpu()
    arrays = sphere_arrays()
    vp = view_projection(0.5 / DISC_FRACTION)
    info = harness.gpu_machine()
    log(f"machine: {info['renderer']} ({info['backend']}), {info['cpu_count']} cores; "
        f"target {args.size}² px, {args.reps} reps × {args.frames} frames")
    with bench_target(args.size, sphere_batch(), vp, args.frames, args.reps) as bench:
        rows, rolled_rows, light_packs = sweep(bench, args.quick)
    info["load_end"] = harness.load_average()
    return {
        "date": harness.date_stamp(), "command": harness.command_line("draw"),
        "seconds": time.perf_counter() - started, "machine": info, "quick": args.quick,
        "settings": settings(args, arrays),
        "rows": rows, "rolled": rolled_rows, "summaries": summaries(rows, light_packs),
        "counts": glsl_counts(),
        "paper": {"gpu": "GeForce GTX 280", "pixels": "about 1 M",
                  "fps": {str(k): v for k, v in PAPER_FPS.items()}},
    }


def main(argv: list[str] | None = None) -> None:
    args = parse_args(argv)
    if args.counts:
        print("\n".join(glsl_counts_markdown({"counts": glsl_counts()})))
        return
    results = run(args)
    out, stem = Path(args.out), harness.output_stem("draw", args.quick)
    harness.write_outputs(out, stem, results, write_markdown)
    print()
    print("\n".join(main_table(ordered(results["rows"]))))
    print()
    for f in results["summaries"]["packs"]:
        log(f"{f['layout']} {f['mode']}: {f['ms_per_pack']:.2f} ms/frame per pack "
            f"({f['baseline_frames_per_pack']:.2f} baseline frames, "
            f"{f['ns_per_pixel_pack']:.1f} ns per pixel per pack)")
    for c in results["counts"]["rows"]:
        log(f"{c['layout']} {c['mode']}: {c['fetches']} fetches, {c['lane_ops']} lane ops "
            "per pack per light")
    log(f"wrote {out / stem}.md/.json in {results['seconds']:.0f} s")


if __name__ == "__main__":
    main()
