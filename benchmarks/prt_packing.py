"""Spectral PRT frame time with the albedo packed four values to a texel, against one RGB
layer per coefficient (issue 19), on the same baked object in the same run.

The benchmark scene of :mod:`benchmarks.prt` (subdivided Suzanne on a floor, the
ColorChecker chart, bands 5, m = 8, 512²). The control is the draw path before the
packing: the albedo uploaded as m RGB layers (each padded to RGBA) and filtered one layer
per coefficient (:data:`CONTROL_LOOP`, patched into glsl/prt/prt_frag.glsl for the
control's variant only). Both draw the same image to float32 rounding (stated). Blocks of
frames alternate U P U P … U (shared/PROTOCOL.md, "Time and memory"); RGB PRT is timed
too, for the spectral-to-RGB ratio of each.

Writes ``docs/bench_prt_packing.md``/``.json`` (``--quick``: a smaller mesh, 3 reps).

Usage::

    python -m benchmarks.prt_packing [--quick]
"""

from __future__ import annotations

import contextlib
import time

import numpy as np

from spectral_materials import blender as addon
from spectral_materials.blender.gpu import shaders
from spectral_materials.blender.gpu.context import ensure_gpu
from spectral_materials.blender.gpu.offscreen import Target
from spectral_materials.blender.prt import drawer as prt_gpu, scene as prt
from spectral_materials.core.prt import albedo_forms
from spectral_materials.core.prt.albedo import packed_layer_count

from . import harness
from .prt import FLOOR_SUBDIVISIONS, SIZE, SUBDIVISIONS, FrameBench, build_scene

BANDS, BASIS, RAYS, FRAMES = 5, 8, 64, 12
#: The fragment loop before the packing: m layers, one per coefficient, RGB = X, Y, Z.
CONTROL_LOOP = """  for (int j = 0; j < SM_PRT_COEFFS; j++) {
    vec3 r = sm_albedo_filtered(c0, w, j).rgb;
    xyz += e[j / 4][j % 4] * r;
  }
"""
PACKED_LOOP_START = "  for (int g = 0; g < SM_PRT_VEC4; g++) {"


@contextlib.contextmanager
def control_path():
    """Draw with the unpacked albedo and :data:`CONTROL_LOOP` inside the block."""
    source, pack = prt_gpu.glsl_source, albedo_forms.layers_to_rgba
    fragment = source("prt/prt_frag.glsl")
    start = fragment.index(PACKED_LOOP_START)
    end = fragment.index("#  endif", start)
    patched = fragment[:start] + CONTROL_LOOP + fragment[end:]
    shaders.clear_cache()
    prt_gpu._OBJECTS.clear()
    prt_gpu.glsl_source = lambda name: patched if name == "prt/prt_frag.glsl" else source(name)
    albedo_forms.layers_to_rgba = lambda layers: layers     # array_texture pads to RGBA
    try:
        yield
    finally:
        prt_gpu.glsl_source, albedo_forms.layers_to_rgba = source, pack
        shaders.clear_cache()
        prt_gpu._OBJECTS.clear()


def block(bench: FrameBench, packed: bool, rgb: bool = False) -> float:
    """Median wall seconds of FRAMES frames (one untimed first)."""
    with contextlib.nullcontext() if packed else control_path():
        bench.frame(rgb)
        return float(np.median([bench.frame(rgb)[0] for _ in range(FRAMES)]))


def run(args) -> dict:
    started = time.perf_counter()
    addon.register()
    ensure_gpu()
    info = harness.gpu_machine()
    q = 1 if args.quick else 0
    scene, obj, mesh = build_scene(SUBDIVISIONS[q], FLOOR_SUBDIVISIONS[q])
    env = scene.spectral.environment
    env.bands, env.basis_size = BANDS, BASIS
    obj.spectral_prt.rays = RAYS
    # Both paths filter the float32 layers by hand (the packing's own comparison).
    obj.spectral_prt.albedo_texture = "EXACT"
    prt.bake_prt(obj, scene)
    with Target(SIZE, SIZE) as target:
        bench = FrameBench(scene, obj, target)
        images = {}
        for packed in (False, True):
            with contextlib.nullcontext() if packed else control_path():
                bench.frame(False)
                images[packed] = target.read()[..., :3].astype(np.float64)
        difference = float(np.abs(images[True] - images[False]).max())
        timings = harness.interleave(lambda: block(bench, True),
                                     lambda: block(bench, False), args.reps)
        rgb = [block(bench, True, rgb=True) for _ in range(args.reps)]
    return {"date": harness.date_stamp(), "command": harness.command_line("prt_packing"),
            "commit": harness.commit_of(), "machine": info, "quick": args.quick,
            "mesh": mesh, "bands": BANDS, "basis": BASIS, "size": SIZE, "frames": FRAMES,
            "reps": args.reps, "layers": {"packed": packed_layer_count(BASIS), "control": BASIS},
            "fetches_per_pixel": {"packed": 4 * packed_layer_count(BASIS), "control": 4 * BASIS,
                                  "rgb": 4},
            "max_abs_difference": difference,
            "max_value": float(np.abs(images[False]).max()),
            "control_ms": 1e3 * float(np.median(timings.baseline)),
            "packed_ms": 1e3 * float(np.median(timings.candidate)),
            "packed_over_control": float(np.median(timings.ratios())),
            "paired": timings.ratios(), "rgb_ms": 1e3 * float(np.median(rgb)),
            "seconds": time.perf_counter() - started}


def markdown(r: dict) -> list[str]:
    m = r["machine"]
    fetches = r["fetches_per_pixel"]
    return [
        "# Spectral PRT: the albedo packed four values to a texel", "",
        f"Printed by `{r['command']}` on {r['date']} at commit {r['commit']}: "
        f"{m['renderer']} ({m['backend']}), {m['cpu_count']} cores; "
        f"{r['mesh']['vertices']} vertices, {r['size']}² target, bands {r['bands']}, m = "
        f"{r['basis']}; {r['reps']} interleaved blocks of {r['frames']} frames"
        f"{' (quick run: a smoke test)' if r['quick'] else ''}. No GPU was at hand: these are "
        "llvmpipe's figures; the GPU figure is still open.", "",
        "| path | albedo layers | texel fetches per pixel | ms/frame | × control | × RGB PRT |",
        "|---|---|---|---|---|---|",
        f"| one RGB layer per coefficient (control, before) | {r['layers']['control']} | "
        f"{fetches['control']} | {r['control_ms']:.1f} | 1 | "
        f"{r['control_ms'] / r['rgb_ms']:.2f} |",
        f"| packed (after) | {r['layers']['packed']} | {fetches['packed']} | "
        f"{r['packed_ms']:.1f} | {r['packed_over_control']:.3f} | "
        f"{r['packed_ms'] / r['rgb_ms']:.2f} |",
        f"| RGB PRT | 1 | {fetches['rgb']} | {r['rgb_ms']:.1f} | – | 1 |", "",
        "× control is the median of paired ratios (each packed block against the control "
        "blocks on either side); × RGB PRT divides medians of blocks timed after them. The "
        f"two spectral paths draw the same image to {r['max_abs_difference']:.2g} (largest "
        f"value {r['max_value']:.3g}).", ""]


def main(argv: list[str] | None = None) -> None:
    parser = harness.parser(__doc__, quick_help="smaller mesh, 3 reps (smoke test)",
                            out_help="write bench_prt_packing.md/.json here, not docs/")
    args = parser.parse_args(argv)
    args.reps = 3 if args.quick else 7
    results = run(args)
    harness.publish(args.out, "prt_packing", args.quick, results, markdown(results))


if __name__ == "__main__":
    main()
