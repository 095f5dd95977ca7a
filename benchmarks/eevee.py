"""EEVEE benchmark: the node-group reconstruction's cost against packs and two baselines.

One smooth UV sphere (128 segments × 64 rings, with UVs, so the group takes its
tangent from the UV map), one sun (strength 1, D65, 30° from the view axis), an
orthographic camera (the sphere's diameter is 94 % of the image side, as in
``benchmarks.draw``) and a black world (``eevee.render.black_world``). The sphere's material is
a synthetic CP model in the factor-pack paper's layouts (io_iso 90×180×90, hd
90×45×90×45, spectral basis of 8, packs of 4 terms), stored with
``storage.store_factored`` and given the EEVEE node group with ``eevee.apply_eevee``.

For every layout and pack count: the group's node count, image-texture nodes and
distinct images (samplers: Blender binds one sampler per distinct image and sampler
state, so every texel node of the group shares the factor image's); the seconds
``apply_eevee`` takes (building the group); the first EEVEE render (``bpy.ops.render
.render``, ``write_still=False``; it compiles the material's shaders) and the later
ones. Baselines, in the same run, scene, camera and image size (shared/PROTOCOL.md,
"Time and memory"): (a) a plain Principled BSDF material on the same sphere rendered
by EEVEE, its renders interleaved with the spectral ones (P E P E … P), (b) the add-on's
draw-handler path, ``draw.render_camera(..., output="DISPLAY")`` on the same material
(offscreen draw and full read-back), timed after every EEVEE render. EEVEE renders with
``taa_render_samples = 1``. Whether a render compiled is read from Blender's console
output during the first render (captured at the file-descriptor level) and from the
image: EEVEE replaces a material that fails to compile by a magenta emission. The GL
driver's disk shader caches are off for the run, so that a first render compiles
(``--shader-cache`` keeps them). Writes ``docs/bench_eevee.md`` and ``.json``
(``--quick``: ``bench_eevee_quick.*``; ``--device-out DIR``: to DIR, not ``docs/``).

Usage::

    python -m benchmarks.eevee             # the default grid (~10 min on 2 cores, llvmpipe)
    python -m benchmarks.eevee --quick     # 128 × 128, packs 1, 4, 16 (~2 min)
    python -m benchmarks.eevee --device-out out/gpu   # on a machine with a GPU
"""

# ruff: noqa: E402  (the GL driver's environment is set before anything imports bpy)

from __future__ import annotations

import os
import sys

if "--shader-cache" not in sys.argv:
    # Read by the GL driver when Blender makes its context: set before bpy starts the GPU.
    os.environ["MESA_SHADER_CACHE_DISABLE"] = "true"
    os.environ["__GL_SHADER_DISK_CACHE"] = "0"

import math
import re
import time
from pathlib import Path

import bpy
import numpy as np

from spectral_materials import blender as addon
from spectral_materials.blender import compat
from spectral_materials.blender.brdf import storage
from spectral_materials.blender.eevee import apply as eevee, render as eevee_render
from spectral_materials.blender.gpu.context import ensure_gpu
from spectral_materials.blender.lights.visibility import SHADOW_TWIN_KEY
from spectral_materials.blender.viewport import draw

from . import eevee_lights, harness
from .eevee_render import draw_seconds, eevee_settings, inspect_render, render_once
from .eevee_report import (
    SAMPLES,
    SUN_INCIDENCE_DEG,
    findings,
    fmt,
    main_table,
    notes,
    per_pack,
    to_ms,
    write_markdown,
)
from .harness import log
from .scenes import factory_scene
from .synthetic import (
    BASIS_SIZE,
    DISC_FRACTION,
    LAYOUTS,
    PACK_SIZE,
    RINGS,
    SEGMENTS,
    synthetic_model,
)

PACKS = [1, 2, 4, 8, 16, 22, 32, 48]
QUICK_PACKS = [1, 4, 16]
#: A render whose sphere is magenta on more than this share of its pixels failed.
MAGENTA_SHARE = 0.5
UBO_PATTERN = re.compile(r"Uniform block (\w+) too big \((\d+)/(\d+)\)")


# ------------------------------------------------------------------------ scene


def _diffuse_material(name: str):
    """A material whose surface is a Diffuse BSDF (the warm-up render's)."""
    material = bpy.data.materials.new(name)
    tree = material.node_tree
    tree.nodes.clear()
    diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (0.5, 0.5, 0.5, 1.0)
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    tree.links.new(diffuse.outputs[0], output.inputs["Surface"])
    return material


def _principled_material(name: str):
    """Blender's default material: a Principled BSDF into the material output."""
    material = bpy.data.materials.new(name)
    principled = next(n for n in material.node_tree.nodes
                      if n.bl_idname == "ShaderNodeBsdfPrincipled")
    principled.inputs["Base Color"].default_value = (0.6, 0.5, 0.4, 1.0)
    return material


def build_scene(size: int):
    """(scene, sphere, sun): the benchmark's scene in the factory start-up file."""
    scene = factory_scene(keep=(), materials=False)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=SEGMENTS, ring_count=RINGS, radius=1.0)
    sphere = bpy.context.active_object
    bpy.ops.object.shade_smooth()
    light = bpy.data.lights.new("Bench sun", "SUN")
    light.energy = 1.0
    light.spectral.illuminant = "D65"
    sun = bpy.data.objects.new("Bench sun", light)
    sun.rotation_euler = (0.0, math.radians(SUN_INCIDENCE_DEG), 0.0)   # toward it: +x, +z
    camera_data = bpy.data.cameras.new("Bench camera")
    camera_data.type = "ORTHO"
    camera_data.ortho_scale = 1.0 / DISC_FRACTION
    camera = bpy.data.objects.new("Bench camera", camera_data)
    camera.location = (0.0, 0.0, 5.0)
    for obj in (sun, camera):
        scene.collection.objects.link(obj)
    scene.camera = camera
    scene.world = eevee_render.black_world("Bench black")
    render = scene.render
    render.engine = compat.EEVEE_ENGINE
    render.resolution_x = render.resolution_y = size
    render.resolution_percentage = 100
    render.image_settings.file_format = "OPEN_EXR"
    render.image_settings.color_depth = "32"
    scene.eevee.taa_render_samples = SAMPLES
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    return scene, sphere, sun


# ---------------------------------------------------------------------- timing


class Bench:
    """The scene, its sphere and sun, the Principled baseline; measures one configuration."""

    def __init__(self, scene, sphere, sun, size: int, reps: int, draw_calls: int,
                 extra_samples: int):
        self.scene, self.sphere, self.sun = scene, sphere, sun
        self.size, self.reps, self.draw_calls = size, reps, draw_calls
        self.extra_samples = extra_samples
        self.principled = _principled_material("Bench Principled")
        #: The spectral lights' light-linking collections of the material under test.
        self.receivers: dict = {}

    def use(self, material) -> None:
        """Put ``material`` on the sphere: the Principled baseline lit by every light, its
        render without the shadow twins (their shadow maps are the spectral material's
        cost); the spectral one excluded from its spectral lights (``apply_eevee``)."""
        self.sphere.material_slots[0].material = material
        baseline = material == self.principled
        for light, collection in self.receivers.items():
            light.light_linking.receiver_collection = None if baseline else collection
        for twin in self.scene.objects:
            if twin.get(SHADOW_TWIN_KEY):
                twin.hide_render = baseline

    def scene_lights(self) -> list:
        """The scene's lights but the shadow twins."""
        return [o for o in self.scene.objects if o.type == "LIGHT" and not o.get(SHADOW_TWIN_KEY)]

    def render(self, material, samples: int = SAMPLES) -> float:
        self.use(material)
        self.scene.eevee.taa_render_samples = samples
        try:
            return render_once(self.scene)["seconds"]
        finally:
            self.scene.eevee.taa_render_samples = SAMPLES

    def warm_up(self) -> dict:
        """Compile EEVEE's own shaders for this scene (with a Diffuse BSDF), then time the
        Principled baseline's first render (which compiles the Principled material)."""
        diffuse = _diffuse_material("Bench warm-up")
        self.sphere.data.materials.append(diffuse)
        warm = [render_once(self.scene)["seconds"] for _ in range(2)]
        if self.extra_samples:
            warm.append(self.render(diffuse, SAMPLES + self.extra_samples))
        self.use(self.principled)
        first = render_once(self.scene, capture=True)
        image = inspect_render(self.scene, self.size)
        later = [render_once(self.scene)["seconds"] for _ in range(self.reps + 1)]
        bpy.data.materials.remove(diffuse)
        return {"warm_up_seconds": warm, "first_seconds": first["seconds"],
                "first_errors": first["error_lines"], "exception": first["exception"],
                "later_seconds": later, "later_median": float(np.median(later)),
                "image": image}

    def measure(self, layout: str, packs: int, *, timed: bool = True, lights: int = 1,
                shadows: bool = True) -> dict:
        """One layout and pack count with ``lights`` spectral lights, with their EEVEE
        shadows or not; ``timed=False``: the first render only (a probe)."""
        model = synthetic_model(layout, packs)
        material = bpy.data.materials.new(f"Bench {layout} {packs}")
        material.spectral.enabled = True
        row = {"layout": layout, "resolution": list(LAYOUTS[layout]),
               "axes": len(LAYOUTS[layout]), "packs": packs, "terms": model.terms,
               "compiled": False, "status": "not rendered", "first_seconds": None,
               "error_lines": [], "exception": None, "load": harness.load_average(),
               "spectral_lights": lights, "scene_lights": len(self.scene_lights()),
               "shadows": shadows}
        try:
            start = time.perf_counter()
            storage.store_factored(material, model)
            row["store_seconds"] = time.perf_counter() - start
            image = material.spectral.result.image
            row["factor_image"] = list(image.size)
            self.sphere.material_slots[0].material = material
            for light in self.scene_lights():
                light.light_linking.receiver_collection = None
            start = time.perf_counter()
            counts = eevee.apply_eevee(material, self.scene, light_object=self.sun,
                                       lights=lights, shadows=shadows)
            row["shadows"] = counts["shadows"]
            row["apply_seconds"] = time.perf_counter() - start
            row.update({k: counts[k] for k in ("nodes", "image_nodes", "images")})
            self.receivers = {light: light.light_linking.receiver_collection
                              for light in self.scene_lights()
                              if light.light_linking.receiver_collection is not None}
            row["material_nodes"] = sum(1 for n in material.node_tree.nodes
                                        if n.bl_idname != "NodeFrame")
            self._first_render(material, row)
            if timed:
                self._time(material, row)
        except Exception as exc:           # noqa: BLE001 (recorded in the row)
            row["exception"] = f"{type(exc).__name__}: {exc}"
            row["status"] = "exception"
            log(f"  {layout} {packs} packs: {row['exception']}")
        finally:
            self.use(material)
            eevee.remove_eevee(material, self.scene)
            self.receivers = {}
            self.use(self.principled)
            result = material.spectral.result
            for block in (result.image, result.plot):
                storage.remove_image(block)
            bpy.data.materials.remove(material)
            draw.reset()                # the draw path's textures of the removed material
        return row

    def _first_render(self, material, row: dict) -> None:
        self.use(material)
        first = render_once(self.scene, capture=True)
        row["first_seconds"] = first["seconds"]
        row["exception"] = first["exception"]
        row["error_lines"] = first["error_lines"]
        ubo = [m.groups() for line in first["error_lines"] for m in [UBO_PATTERN.search(line)]
               if m]
        row["uniform_block"] = ({"name": ubo[0][0], "bytes": int(ubo[0][1]),
                                 "limit": int(ubo[0][2])} if ubo else None)
        row["image"] = inspect_render(self.scene, self.size) if first["exception"] is None \
            else None
        magenta = row["image"] is not None and row["image"]["magenta_share"] > MAGENTA_SHARE
        row["compiled"] = first["exception"] is None and not first["error_lines"] \
            and not magenta
        row["status"] = ("ok" if row["compiled"] else
                         "exception" if first["exception"] else
                         "magenta (compile failed)" if magenta else "console errors")

    def _draws(self) -> float:
        return float(np.median([draw_seconds(self.scene, self.size)[0]
                                for _ in range(self.draw_calls)]))

    def _time(self, material, row: dict) -> None:
        draw_first, draw_facts = draw_seconds(self.scene, self.size)
        row["draw_first_seconds"] = draw_first
        row["draw"] = draw_facts
        if not row["compiled"]:
            # EEVEE renders its error shader: no point timing it; the draw path still draws.
            row["draw_seconds"] = [self._draws()]
            row["draw_median"] = row["draw_seconds"][0]
            return
        # P E P E … P at 1 sample, each EEVEE render followed by draw_calls draw-path calls;
        # then P and E at 1 + extra_samples samples for the cost of one more sample.
        drawn = []

        def spectral_then_draws() -> float:
            seconds = self.render(material)
            drawn.append(self._draws())
            return seconds

        timings = harness.interleave(spectral_then_draws,
                                     lambda: self.render(self.principled), self.reps)
        principled, spectral = timings.baseline, timings.candidate
        over_p = timings.ratios()
        over_d = [e / d for e, d in zip(spectral, drawn)]
        e1, p1, d1 = (float(np.median(v)) for v in (spectral, principled, drawn))
        row.update({
            "later_seconds": spectral, "later_median": e1,
            "principled_seconds": principled, "principled_median": p1,
            "draw_seconds": drawn, "draw_median": d1,
            "compile_seconds": row["first_seconds"] - e1,
            "over_principled": float(np.median(over_p)), "over_principled_paired": over_p,
            "over_draw": float(np.median(over_d)), "over_draw_paired": over_d,
        })
        if self.extra_samples:
            n = SAMPLES + self.extra_samples
            p_n = self.render(self.principled, n)
            e_n = self.render(material, n)
            e_per = (e_n - e1) / self.extra_samples
            p_per = (p_n - p1) / self.extra_samples
            row.update({
                "samples_n": n, "principled_n_seconds": p_n, "eevee_n_seconds": e_n,
                "per_sample_seconds": e_per, "principled_per_sample_seconds": p_per,
                "fixed_seconds": e1 - e_per,
                "per_sample_over_principled": e_per / p_per if p_per > 0 else None,
                "per_sample_over_draw": e_per / d1,
            })
        self.use(material)


def find_limit(bench: Bench, layout: str, rows: list[dict], probes: int) -> dict | None:
    """The largest pack count that still compiles, between the grid's last success and
    first failure, from at most ``probes`` first renders (no timing).

    A failure reports the uniform block's size; two failures give its size as a line in
    the packs (every pack adds the same nodes), which predicts the limit; the next probe
    is that prediction (else the bracket's middle).
    """
    series = sorted((r for r in rows if r["layout"] == layout), key=lambda r: r["packs"])
    failed = [r for r in series if not r["compiled"] and r.get("uniform_block")]
    if not failed:
        return None
    hi = failed[0]["packs"]
    ok = [r["packs"] for r in series if r["compiled"] and r["packs"] < hi]
    lo = max(ok) if ok else 0
    sizes = {r["packs"]: r["uniform_block"]["bytes"] for r in failed}
    limit_bytes = failed[0]["uniform_block"]["limit"]
    tried = []
    predicted = None
    while hi - lo > 1 and len(tried) < probes:
        if len(sizes) >= 2:
            (p0, b0), (p1, b1) = sorted(sizes.items())[:2]
            per_pack = (b1 - b0) / (p1 - p0)
            predicted = int(np.floor(p0 + (limit_bytes - b0) / per_pack))
        guess = predicted if predicted is not None and lo < predicted < hi else (lo + hi) // 2
        if guess in tried or not lo < guess < hi:
            guess = (lo + hi) // 2
        row = bench.measure(layout, guess, timed=False)
        tried.append(row)
        log(f"  limit probe {layout} {guess} packs: {row['nodes']} nodes, apply "
            f"{fmt(row.get('apply_seconds'), '.1f')} s, first render "
            f"{fmt(row['first_seconds'])} s, {row['status']}")
        if row["compiled"]:
            lo = guess
        else:
            hi = guess
            if row.get("uniform_block"):
                sizes[guess] = row["uniform_block"]["bytes"]
    if len(sizes) >= 2:
        (p0, b0), (p1, b1) = sorted(sizes.items())[:2]
        per_pack = (b1 - b0) / (p1 - p0)
        predicted = int(np.floor(p0 + (limit_bytes - b0) / per_pack))
    else:
        per_pack = None
    return {"layout": layout, "compiles_at": lo, "fails_at": hi, "exact": hi - lo == 1,
            "uniform_bytes": {str(k): v for k, v in sorted(sizes.items())},
            "uniform_bytes_per_pack": per_pack, "limit_bytes": limit_bytes,
            "predicted_limit": predicted, "probes": tried}




# --------------------------------------------------------------------- main


def parse_args(argv: list[str] | None = None):
    parser = harness.parser(
        __doc__, quick_help="128 × 128 image, packs 1, 4, 16 (smoke test)",
        out_help="write bench_eevee.md/.json here instead of docs/", device_out=True)
    parser.add_argument("--size", type=int, default=None,
                        help="image side in pixels (default 512; 128 with --quick)")
    parser.add_argument("--packs", type=int, nargs="+", default=None,
                        help=f"pack counts (default {PACKS}; --quick {QUICK_PACKS})")
    parser.add_argument("--layouts", nargs="+", choices=list(LAYOUTS), default=list(LAYOUTS))
    parser.add_argument("--light-packs", type=int, nargs="*", default=None,
                        help="pack counts of the spectral-lights sweep (io_iso, a second "
                             f"sun; default {list(eevee_lights.LIGHT_PACKS)}, --quick "
                             f"{list(eevee_lights.QUICK_LIGHT_PACKS)}; none: no sweep)")
    parser.add_argument("--reps", type=int, default=2,
                        help="spectral renders at 1 sample per configuration, after the "
                             "first (median; default 2)")
    parser.add_argument("--draw-calls", type=int, default=5,
                        help="draw-path calls after each spectral render (median)")
    parser.add_argument("--extra-samples", type=int, default=8,
                        help="the per-sample cost is measured from renders at 1 + this many "
                             "samples (0: not measured)")
    parser.add_argument("--find-limit", type=int, default=0, metavar="PROBES",
                        help="where a layout fails to compile, narrow the last pack count "
                             "that compiles with up to PROBES more first renders (each "
                             "builds a group: ~1 min at 40 packs on 2 cores)")
    parser.add_argument("--shader-cache", action="store_true",
                        help="keep the GL driver's disk shader cache (first renders may then "
                             "not compile)")
    args = parser.parse_args(argv)
    args.size = args.size or (128 if args.quick else 512)
    args.packs = args.packs or (QUICK_PACKS if args.quick else PACKS)
    if args.light_packs is None:
        args.light_packs = (eevee_lights.QUICK_LIGHT_PACKS if args.quick
                            else eevee_lights.LIGHT_PACKS)
    return args


def sweep(bench: Bench, args) -> tuple[list[dict], dict]:
    """Every layout × pack count, then (``--find-limit``) the limit probes."""
    rows = []
    for layout in args.layouts:
        for packs in args.packs:
            row = bench.measure(layout, packs)
            rows.append(row)
            log(f"  {layout:6s} {packs:2d} packs {row.get('nodes', 0):5d} nodes "
                f"{row.get('image_nodes', 0):4d} image nodes  apply "
                f"{fmt(row.get('apply_seconds'), '5.1f')} s  first "
                f"{fmt(row['first_seconds'], '6.2f')} s  later {fmt(row.get('later_median'))} "
                f"s  /P {fmt(row.get('over_principled'))}  sample "
                f"{fmt(to_ms(row.get('per_sample_seconds')), '.0f')} ms "
                f"/P {fmt(row.get('per_sample_over_principled'))}  draw "
                f"{fmt(to_ms(row.get('draw_median')), '.1f')} ms  {row['status']}")
    limits = {}
    if args.find_limit:
        for layout in args.layouts:
            limit = find_limit(bench, layout, rows, args.find_limit)
            if limit is not None:
                limits[layout] = limit
    return rows, limits


def settings(args, scene) -> dict:
    return {"size": args.size, "reps": args.reps, "draw_calls": args.draw_calls,
            "extra_samples": args.extra_samples, "find_limit": args.find_limit,
            "packs": args.packs, "layouts": {k: list(LAYOUTS[k]) for k in args.layouts},
            "segments": SEGMENTS, "rings": RINGS, "basis_size": BASIS_SIZE,
            "pack_size": PACK_SIZE, "sun_incidence_deg": SUN_INCIDENCE_DEG,
            "disc_radius_px": DISC_FRACTION * args.size,
            "shader_cache": args.shader_cache, "eevee": eevee_settings(scene)}


def run(args) -> dict:
    started = time.perf_counter()
    addon.register()
    ensure_gpu()
    info = harness.gpu_machine()
    log(f"machine: {info['renderer']} ({info['backend']}), {info['cpu_count']} cores; "
        f"{args.size}² px, {args.reps} reps, {args.draw_calls} draw calls, "
        f"+{args.extra_samples} samples; shader cache {'on' if args.shader_cache else 'off'}")
    scene, sphere, sun = build_scene(args.size)
    bench = Bench(scene, sphere, sun, args.size, args.reps, args.draw_calls,
                  args.extra_samples)
    principled = bench.warm_up()
    log(f"  warm-up {', '.join(f'{t:.1f}' for t in principled['warm_up_seconds'])} s; "
        f"Principled first {principled['first_seconds']:.2f} s, later "
        f"{principled['later_median']:.2f} s")
    rows, limits = sweep(bench, args)
    light_rows = eevee_lights.sweep_lights(bench, args.light_packs, log)
    info["load_end"] = harness.load_average()
    return {
        "date": harness.date_stamp(), "command": harness.command_line("eevee"),
        "seconds": time.perf_counter() - started, "machine": info, "quick": args.quick,
        "settings": settings(args, scene),
        "principled": principled, "rows": rows, "limits": limits, "light_rows": light_rows,
        "per_pack": per_pack(rows), "notes": notes(rows, principled),
    }


def main(argv: list[str] | None = None) -> None:
    args = parse_args(argv)
    results = run(args)
    out, stem = Path(args.out), harness.output_stem("eevee", args.quick)
    harness.write_outputs(
        out, stem, results,
        lambda res, path: write_markdown(res, path, eevee_lights.lights_lines(res)), default=str)
    print()
    print("\n".join(main_table(results["rows"])))
    print()
    for line in findings(results) + results["notes"]:
        log(line)
    log(f"wrote {out / stem}.md/.json in {results['seconds']:.0f} s")


if __name__ == "__main__":
    main()
