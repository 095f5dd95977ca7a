"""EEVEE benchmark: the node-group reconstruction's cost against packs and two baselines.

One smooth UV sphere (128 segments × 64 rings, with UVs, so the group takes its
tangent from the UV map), one sun (strength 1, D65, 30° from the view axis), an
orthographic camera (the sphere's diameter is 94 % of the image side, as in
``bench_draw.py``) and a black world (``eevee._black_world``). The sphere's material is
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
image: EEVEE replaces a material that fails to compile by a magenta emission.

The disk shader caches of the GL driver (Mesa, NVIDIA) are switched off for the run
so that a first render compiles (``--shader-cache`` keeps them).

Writes ``docs/bench_eevee.md`` and ``docs/bench_eevee.json`` (``--quick``:
``bench_eevee_quick.*``; ``--device-out DIR`` writes to DIR instead of ``docs/``).

Usage::

    python scripts/bench_eevee.py             # the default grid (~10 min on 2 cores, llvmpipe)
    python scripts/bench_eevee.py --quick     # 128 × 128, packs 1, 4, 16 (~2 min)
    python scripts/bench_eevee.py --device-out out/gpu   # on a machine with a GPU
"""

from __future__ import annotations

import os
import sys

if "--shader-cache" not in sys.argv:
    # Read by the GL driver when Blender makes its context: set before bpy starts the GPU.
    os.environ["MESA_SHADER_CACHE_DISABLE"] = "true"
    os.environ["__GL_SHADER_DISK_CACHE"] = "0"

import argparse
import ctypes
import datetime
import json
import math
import re
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import bpy
from bench_common import gpu_machine  # noqa: E402  (scripts/, next to this file)

from spectral_materials import blender as addon
from spectral_materials.blender import compat
from spectral_materials.blender.brdf import storage
from spectral_materials.blender.eevee import apply as eevee
from spectral_materials.blender.gpu.context import ensure_gpu
from spectral_materials.blender.viewport import draw
from spectral_materials.core.brdf.factored import FactoredBRDF
from spectral_materials.core.colour import spectra
from spectral_materials.core.formats.exr import read_exr

PACKS = [1, 2, 4, 8, 16, 22, 32, 48]
QUICK_PACKS = [1, 4, 16]
LAYOUTS = {"io_iso": (90, 180, 90), "hd": (90, 45, 90, 45)}
BASIS_SIZE = 8
PACK_SIZE = 4
SEGMENTS, RINGS = 128, 64
#: The sphere's projected radius per pixel of image side (as bench_draw.py).
DISC_FRACTION = 565.0 / 1200.0
SUN_INCIDENCE_DEG = 30.0
SAMPLES = 1
#: EEVEE's stand-in for a material that failed to compile: an emission of (1, 0, 1).
MAGENTA = np.array([1.0, 0.0, 1.0])
#: A render whose sphere is magenta on more than this share of its pixels failed.
MAGENTA_SHARE = 0.5
ERROR_PATTERN = re.compile(r"error", re.IGNORECASE)
UBO_PATTERN = re.compile(r"Uniform block (\w+) too big \((\d+)/(\d+)\)")


def log(message: str) -> None:
    print(message, flush=True)


# ------------------------------------------------------------------------ scene


def synthetic_model(layout: str, packs: int) -> FactoredBRDF:
    """Factor packs of random positive values: the cost does not depend on them."""
    rng = np.random.default_rng(1000 * list(LAYOUTS).index(layout) + packs)
    wl = spectra.WAVELENGTHS_REFERENCE
    terms = PACK_SIZE * packs
    basis = np.linalg.qr(rng.standard_normal((wl.size, BASIS_SIZE)))[0]
    return FactoredBRDF(
        parameterization=layout, resolution=LAYOUTS[layout], wavelengths=wl, basis=basis,
        cosine_weighted=True, pack_size=PACK_SIZE,
        factors=[rng.uniform(0.5, 1.5, (n, terms)).astype(np.float32)
                 for n in LAYOUTS[layout]],
        spectral=rng.uniform(0.5, 1.5, (BASIS_SIZE, terms)).astype(np.float32))


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
    bpy.ops.wm.read_homefile(use_factory_startup=True)
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)
    for material in list(bpy.data.materials):
        bpy.data.materials.remove(material)
    scene = bpy.context.scene
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
    black_world = getattr(eevee, "black_world", None) or eevee._black_world
    scene.world = black_world("Bench black")
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


def eevee_settings(scene) -> dict:
    out = {}
    for name in ("taa_render_samples", "use_shadows", "shadow_ray_count", "shadow_step_count",
                 "use_raytracing", "use_gtao", "use_volumetric_shadows", "use_fast_gi"):
        value = getattr(scene.eevee, name, None)
        if value is not None:
            out[name] = value
    out["film_filter_size"] = scene.render.filter_size
    system = bpy.context.preferences.system
    out["shader_compilation_method"] = getattr(system, "shader_compilation_method", None)
    return out


# ---------------------------------------------------------------------- timing


@contextmanager
def captured_console():
    """Capture what C code writes to stdout and stderr (fd 1, 2); echo it afterwards."""
    libc = ctypes.CDLL(None)
    sys.stdout.flush()
    sys.stderr.flush()
    text: list[str] = []
    with tempfile.TemporaryFile() as sink:
        saved = os.dup(1), os.dup(2)
        os.dup2(sink.fileno(), 1)
        os.dup2(sink.fileno(), 2)
        try:
            yield text
        finally:
            libc.fflush(None)
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])
            sink.seek(0)
            text.append(sink.read().decode("utf-8", errors="replace"))
            if text[0].strip():
                sys.stderr.write(text[0])
                sys.stderr.flush()


def render_once(scene, *, capture: bool = False) -> dict:
    """One EEVEE render: seconds, and the exception or the console's error lines."""
    start = time.perf_counter()
    error = None
    console = ""
    try:
        if capture:
            with captured_console() as text:
                bpy.ops.render.render(write_still=False, scene=scene.name)
        else:
            bpy.ops.render.render(write_still=False, scene=scene.name)
    except Exception as exc:           # noqa: BLE001 (recorded, not hidden)
        error = f"{type(exc).__name__}: {exc}"
    seconds = time.perf_counter() - start
    if capture:
        console = text[0] if text else ""
    lines = [line.strip() for line in console.splitlines()
             if ERROR_PATTERN.search(line) and "EGL" not in line]
    return {"seconds": seconds, "exception": error, "error_lines": lines}


def sphere_mask(size: int) -> np.ndarray:
    """Pixels well inside the sphere's projected disc."""
    centre = (np.arange(size) + 0.5) - 0.5 * size
    r2 = centre[:, None] ** 2 + centre[None, :] ** 2
    return r2 < (0.97 * DISC_FRACTION * size) ** 2


def inspect_render(scene, size: int) -> dict:
    """Facts about the last render's image on the sphere (saved as a 32-bit EXR)."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "render.exr"
        bpy.data.images["Render Result"].save_render(str(path), scene=scene)
        channels, _ = read_exr(path)
    rgb = np.stack([channels[c] for c in "RGB"], axis=-1).astype(np.float64)
    on_sphere = rgb[sphere_mask(size)]
    magenta = np.all(np.abs(on_sphere - MAGENTA) < 1e-3, axis=-1)
    finite = np.isfinite(on_sphere).all(axis=-1)
    return {"magenta_share": float(magenta.mean()), "finite_share": float(finite.mean()),
            "mean_rgb": [float(v) for v in np.nanmean(np.where(finite[:, None], on_sphere,
                                                               np.nan), axis=0)],
            "nonzero_share": float((on_sphere.max(axis=-1) > 0).mean())}


def draw_seconds(scene, size: int) -> tuple[float, dict]:
    """One ``draw.render_camera`` call (offscreen draw + full read-back): (seconds, facts)."""
    start = time.perf_counter()
    image, stats = draw.render_camera(scene, width=size, height=size, output="DISPLAY")
    seconds = time.perf_counter() - start
    return seconds, {"covered_pixels": int(np.count_nonzero(image[..., 3] > 0)),
                     "finite": bool(np.isfinite(image).all()),
                     "triangles": stats.triangles}


class Bench:
    """The scene, its sphere and sun, the Principled baseline; measures one configuration."""

    def __init__(self, scene, sphere, sun, size: int, reps: int, draw_calls: int,
                 extra_samples: int):
        self.scene, self.sphere, self.sun = scene, sphere, sun
        self.size, self.reps, self.draw_calls = size, reps, draw_calls
        self.extra_samples = extra_samples
        self.principled = _principled_material("Bench Principled")
        self.receivers = None           # the sun's light-linking collection of the material

    def use(self, material) -> None:
        """Put ``material`` on the sphere. The Principled baseline is lit by the sun like
        any material; the spectral one is excluded from it (``apply_eevee``'s light
        linking: the node group carries the sun)."""
        self.sphere.material_slots[0].material = material
        self.sun.light_linking.receiver_collection = \
            None if material == self.principled else self.receivers

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

    def measure(self, layout: str, packs: int, *, timed: bool = True) -> dict:
        """One layout and pack count; ``timed=False``: the first render only (a probe)."""
        model = synthetic_model(layout, packs)
        material = bpy.data.materials.new(f"Bench {layout} {packs}")
        material.spectral.enabled = True
        row = {"layout": layout, "resolution": list(LAYOUTS[layout]),
               "axes": len(LAYOUTS[layout]), "packs": packs, "terms": model.terms,
               "compiled": False, "status": "not rendered", "first_seconds": None,
               "error_lines": [], "exception": None, "load": os.getloadavg()[0]}
        try:
            start = time.perf_counter()
            storage.store_factored(material, model)
            row["store_seconds"] = time.perf_counter() - start
            image = material.spectral.result.image
            row["factor_image"] = list(image.size)
            self.sphere.material_slots[0].material = material
            self.sun.light_linking.receiver_collection = None
            start = time.perf_counter()
            counts = eevee.apply_eevee(material, self.scene, light_object=self.sun)
            row["apply_seconds"] = time.perf_counter() - start
            row.update({k: counts[k] for k in ("nodes", "image_nodes", "images")})
            self.receivers = self.sun.light_linking.receiver_collection
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
            self.receivers = None
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
        principled, spectral, drawn = [], [], []
        for _ in range(self.reps):
            principled.append(self.render(self.principled))
            spectral.append(self.render(material))
            drawn.append(self._draws())
        principled.append(self.render(self.principled))
        over_p = [e / (0.5 * (p0 + p1)) for e, p0, p1 in
                  zip(spectral, principled[:-1], principled[1:])]
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


# -------------------------------------------------------------------- output


def fmt(value, spec: str = ".2f", missing: str = "–") -> str:
    return missing if value is None else format(value, spec)


def _ms(value) -> float | None:
    return None if value is None else 1e3 * value


def main_table(rows: list[dict]) -> list[str]:
    lines = ["| layout | packs | group nodes | image nodes | images (samplers) | apply s | "
             "first render s | later render s | compile s | render / Principled | "
             "render / draw path | ms per extra sample | sample / Principled | "
             "sample / draw path | draw-path ms | status |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        status = r["status"]
        if r.get("uniform_block"):
            u = r["uniform_block"]
            status += f": uniform block {u['bytes']} B > {u['limit']} B"
        lines.append(
            f"| {r['layout']} | {r['packs']} | {r.get('nodes', '–')} | "
            f"{r.get('image_nodes', '–')} | {r.get('images', '–')} | "
            f"{fmt(r.get('apply_seconds'), '.1f')} | {fmt(r.get('first_seconds'))} | "
            f"{fmt(r.get('later_median'))} | {fmt(r.get('compile_seconds'), '.1f')} | "
            f"{fmt(r.get('over_principled'))} | {fmt(r.get('over_draw'), '.0f')} | "
            f"{fmt(_ms(r.get('per_sample_seconds')), '.0f')} | "
            f"{fmt(r.get('per_sample_over_principled'))} | "
            f"{fmt(r.get('per_sample_over_draw'), '.1f')} | "
            f"{fmt(_ms(r.get('draw_median')), '.1f')} | {status} |")
    return lines


def per_pack(rows: list[dict]) -> list[dict]:
    """Least-squares lines against packs over the rows that compiled: (slope, intercept)."""
    out = []
    for layout in LAYOUTS:
        series = [r for r in rows if r["layout"] == layout and r.get("compiled")
                  and r.get("later_median") is not None]
        if len(series) < 2:
            continue
        packs = np.array([r["packs"] for r in series], dtype=np.float64)
        fit = {"layout": layout, "packs": [int(p) for p in packs]}
        for key in ("nodes", "image_nodes", "apply_seconds", "first_seconds", "later_median",
                    "over_principled", "per_sample_seconds", "draw_median"):
            values = [r.get(key) for r in series]
            if all(v is not None for v in values):
                fit[key] = tuple(float(v) for v in np.polyfit(packs, values, 1))
        out.append(fit)
    return out


def findings(results: dict) -> list[str]:
    rows = results["rows"]
    lines = []
    for layout in LAYOUTS:
        series = [r for r in rows if r["layout"] == layout]
        if not series:
            continue
        ok = [r["packs"] for r in series if r["compiled"]]
        bad = [r for r in series if not r["compiled"]]
        axes = series[0]["axes"]
        text = (f"**{layout}** ({axes} angular axes): "
                + (f"compiled and rendered at {', '.join(map(str, ok))} packs of the grid"
                   if ok else "compiled at no pack count of the grid"))
        if bad:
            text += "; failed at " + ", ".join(
                f"{r['packs']} ({r['status']}"
                + (f": uniform block `{r['uniform_block']['name']}` of "
                   f"{r['uniform_block']['bytes']} bytes over the {r['uniform_block']['limit']}"
                   "-byte limit" if r.get("uniform_block") else "") + ")" for r in bad)
        limit = results["limits"].get(layout)
        if limit is not None:
            probes = ", ".join(f"{p['packs']} ({'ok' if p['compiled'] else 'failed'}, "
                               f"apply {fmt(p.get('apply_seconds'), '.0f')} s, first render "
                               f"{fmt(p['first_seconds'], '.1f')} s)" for p in limit["probes"])
            text += (f". Limit search (first renders only): compiles at {limit['compiles_at']}, "
                     f"fails at {limit['fails_at']} packs"
                     + ("" if limit["exact"] else " (not narrowed further)")
                     + (f"; probes: {probes}" if probes else ""))
            if limit["uniform_bytes_per_pack"]:
                sizes = ", ".join(f"{k} packs: {v} B" for k, v in limit["uniform_bytes"].items())
                text += (f"; the uniform block grows by {limit['uniform_bytes_per_pack']:.0f} "
                         f"bytes per pack ({sizes}), "
                         f"which puts the last pack count under {limit['limit_bytes']} bytes at "
                         f"{limit['predicted_limit']}")
        elif not bad and results["settings"]["find_limit"]:
            text += "; no failure in the grid, so no limit search"
        lines.append(text + ".")
    return lines


def notes(rows: list[dict], principled: dict) -> list[str]:
    """Observations computed from this run's numbers."""
    out = []
    for r in [r for r in rows if not r["compiled"]]:
        u = r.get("uniform_block")
        what = (f"the GLSL program did not link: the material's uniform block "
                f"`{u['name']}` (the values of the node tree's unlinked sockets) is "
                f"{u['bytes']} bytes, over the driver's {u['limit']}-byte limit" if u else
                "; ".join(r["error_lines"][:3]) or r.get("exception") or r["status"])
        image = r.get("image") or {}
        out.append(
            f"- {r['layout']} at {r['packs']} packs ({r.get('nodes')} group nodes): {what}. "
            f"`bpy.ops.render.render` returned normally after {fmt(r['first_seconds'], '.1f')} s "
            f"and EEVEE drew its magenta error material on "
            f"{100 * image.get('magenta_share', 0.0):.0f} % of the sphere: only the console "
            "says why; nothing reaches Python. The draw path draws this material "
            f"({fmt(_ms(r.get('draw_median')), '.0f')} ms a frame).")
    ok = [r for r in rows if r["compiled"] and r.get("apply_seconds") is not None]
    if ok:
        small = min(ok, key=lambda r: r["nodes"])
        big = max(ok, key=lambda r: r["nodes"])
        per_node = [1e3 * r["apply_seconds"] / r["nodes"] for r in (small, big)]
        out.append(
            f"- Building the group (`apply_eevee`) grows faster than its node count: "
            f"{small['apply_seconds']:.2f} s for {small['nodes']} nodes "
            f"({small['layout']}, {small['packs']} pack{'s' * (small['packs'] != 1)}), "
            f"{big['apply_seconds']:.0f} s for "
            f"{big['nodes']} ({big['layout']}, {big['packs']}): {per_node[0]:.1f} → "
            f"{per_node[1]:.1f} ms per node.")
        longest = max(ok, key=lambda r: r["first_seconds"])
        out.append(
            f"- The longest first render that compiled: {longest['first_seconds']:.1f} s "
            f"({longest['layout']}, {longest['packs']} packs, later renders "
            f"{fmt(longest.get('later_median'))} s); the Principled material's: "
            f"{principled['first_seconds']:.1f} s.")
        sampled = [r for r in ok if r.get("per_sample_seconds") is not None]
        if sampled:
            fixed = [r["fixed_seconds"] for r in sampled]
            out.append(
                f"- An EEVEE render at 1 sample is mostly fixed cost: render time − the cost "
                f"of one sample = {min(fixed):.2f} … {max(fixed):.2f} s over the rows, "
                "against the draw path's whole frame (draw and read-back) in the draw-path "
                "column; the per-sample columns compare shading work.")
    return out


def write_markdown(results: dict, path: Path) -> None:
    s = results["settings"]
    m = results["machine"]
    p = results["principled"]
    rows = results["rows"]
    extra = s["extra_samples"]
    per_sample_p = [r["principled_per_sample_seconds"] for r in rows
                    if r.get("principled_per_sample_seconds") is not None]
    lines = [
        "# EEVEE benchmark: the node-group reconstruction against packs", "",
        f"- Machine: {m['renderer']} ({m['backend']}), {m['cpu_count']} CPU cores, "
        f"load {m['load_start']:.1f} → {m['load_end']:.1f}",
        f"- Date: {results['date']}",
        f"- Command: `{results['command']}`",
        f"- Run time: {results['seconds']:.0f} s",
        f"- Blender {m['blender']}, Python {m['python']}, NumPy {m['numpy']}",
        f"- GL driver disk shader cache: {'on' if s['shader_cache'] else 'off'} "
        "(off: a first render compiles everything it needs)",
        "",
        "## What is measured", "",
        f"Scene: one smooth UV sphere ({SEGMENTS} segments × {RINGS} rings, with UVs), a "
        f"sun of strength 1 (D65) {SUN_INCIDENCE_DEG:.0f}° from the view axis, a black world "
        f"and an orthographic camera; {s['size']} × {s['size']} pixels, of which the "
        f"sphere's disc covers {100 * math.pi * DISC_FRACTION ** 2:.0f} %. EEVEE "
        f"(`BLENDER_EEVEE`) renders with **`taa_render_samples = {SAMPLES}`**, other settings "
        "at Blender's defaults (listed in the JSON: shadows on, ray tracing off).",
        "",
        "Materials: synthetic CP models (random positive factors: the cost does not depend "
        f"on their values), io_iso {'×'.join(map(str, LAYOUTS['io_iso']))} (3 angular axes) "
        f"and hd {'×'.join(map(str, LAYOUTS['hd']))} (4 axes), spectral basis m = "
        f"{BASIS_SIZE}, packs of {PACK_SIZE} terms, stored with `storage.store_factored` "
        "and given the node group by `eevee.apply_eevee(material, scene, light_object=sun)` "
        "(which excludes the sphere from the sun by light linking: the group carries the "
        "sun's light).",
        "",
        "- **group nodes / image nodes / images (samplers)**: `eevee_nodes.node_count` of "
        "the group (frames excluded). Every image node reads the one factor image with the "
        "same sampler state (Closest, Extend), and Blender's GLSL generator binds one "
        "sampler per distinct image and state, so the material takes 1 sampler whatever "
        "the packs; its texture *fetches* are the image nodes (2 per axis per pack).",
        "- **apply s**: wall time of `apply_eevee` (prefiltering and building the group).",
        "- **first render s**: the first `bpy.ops.render.render(write_still=False)` with the "
        "material, which compiles its shaders (EEVEE's own shaders were compiled before by "
        "warm-up renders of the same scene with a Diffuse BSDF). **later render s**: the "
        f"median of {s['reps']} later renders. **compile s** = first − later (within the "
        "noise of one render at small pack counts).",
        "- **render / Principled**: baseline (a), Blender's default material (Principled "
        "BSDF) on the same sphere, lit by the same sun, rendered by EEVEE in the same "
        "scene: renders alternate P E P E … P and the ratio is the median, over the "
        "spectral renders, of its time over the mean of the two Principled renders around "
        "it.",
        "- **render / draw path**, **draw-path ms**: baseline (b), the add-on's draw-handler "
        "path, `draw.render_camera(scene, width, height, output=\"DISPLAY\")` on the same "
        "material: an offscreen RGBA32F draw of the scene's factored objects and a read-back "
        "of the whole image (which waits for the GPU); after every spectral render the "
        f"median of {s['draw_calls']} calls. The ratio is the median over the renders of the "
        "render time over the draw time measured right after it. The draw path's first "
        "call (compiling its variant, uploading the factors) is `draw_first_seconds` in "
        "the JSON.",
        f"- **ms per extra sample**: (render at {SAMPLES + extra} samples − render at "
        f"{SAMPLES}) / {extra}, the shading work of one more EEVEE sample without the "
        "render's fixed cost; **sample / Principled** is the same difference for the "
        "Principled material (its renders in the same row), **sample / draw path** is "
        "against the draw path's frame."
        if extra else "- Per-sample columns: not measured (`--extra-samples 0`).",
        "- **status**: `ok` when the first render raised nothing, Blender's console "
        "(captured during the first render) printed no error, and the sphere is not "
        "EEVEE's magenta stand-in for a material that failed to compile (emission "
        "(1, 0, 1) on more than half of the sphere's pixels). Rows that failed are not "
        "timed further (EEVEE would time its error material).",
        "",
        "Absolute times are this machine's only: llvmpipe rasterises on the CPU, and the "
        "machine is shared, so the ratios (measured within a few seconds of each other) "
        "are the figures to compare.",
        "",
        "## Results", "",
        *main_table(rows), "",
        f"Principled BSDF baseline (a): first render {p['first_seconds']:.2f} s (compiles "
        f"the Principled material), later renders {p['later_median']:.2f} s (median of "
        f"{len(p['later_seconds'])} right after it; the per-row P renders are in the JSON)"
        + (f", {1e3 * float(np.median(per_sample_p)):.0f} ms per extra sample (median over "
           "the rows)" if per_sample_p else "")
        + ". Warm-up renders (EEVEE's own shaders, Diffuse BSDF): "
        + ", ".join(f"{t:.1f}" for t in p["warm_up_seconds"]) + " s.",
        "",
        "## Limits", "",
        *[f"- {line}" for line in findings(results)],
        *results["notes"],
        "",
    ]
    fits = results["per_pack"]
    if fits:
        columns = [("nodes", "nodes", ".1f", ".0f", 1.0),
                   ("image_nodes", "image nodes", ".0f", ".0f", 1.0),
                   ("first_seconds", "first render s", ".3f", ".2f", 1.0),
                   ("later_median", "later render s", ".4f", ".2f", 1.0),
                   ("over_principled", "render / Principled", ".4f", ".2f", 1.0),
                   ("per_sample_seconds", "ms per extra sample", ".1f", ".0f", 1e3),
                   ("draw_median", "draw-path ms", ".2f", ".1f", 1e3)]
        columns = [c for c in columns if all(c[0] in f for f in fits)]
        lines += ["## Per pack", "",
                  "Least-squares lines against packs over the rows that compiled: "
                  "slope per pack + value at 0 packs (`apply_eevee`'s time is not linear: see "
                  "above).", "",
                  "| layout | " + " | ".join(c[1] for c in columns) + " |",
                  "|---|" + "---|" * len(columns)]
        for f in fits:
            cells = [f"{format(round(f[key][0] * k, 6) + 0.0, a)} + "
                     f"{format(round(f[key][1] * k, 6) + 0.0, b)}"
                     for key, _, a, b, k in columns]
            lines.append(f"| {f['layout']} | " + " | ".join(cells) + " |")
        lines.append("")
    path.write_text("\n".join(lines))


# --------------------------------------------------------------------- main


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="128 × 128 image, packs 1, 4, 16 (smoke test)")
    parser.add_argument("--size", type=int, default=None,
                        help="image side in pixels (default 512; 128 with --quick)")
    parser.add_argument("--packs", type=int, nargs="+", default=None,
                        help=f"pack counts (default {PACKS}; --quick {QUICK_PACKS})")
    parser.add_argument("--layouts", nargs="+", choices=list(LAYOUTS), default=list(LAYOUTS))
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
    parser.add_argument("--device-out", "--out", dest="out", default=str(ROOT / "docs"),
                        help="write bench_eevee.md/.json here instead of docs/")
    args = parser.parse_args()
    size = args.size or (128 if args.quick else 512)
    packs_grid = args.packs or (QUICK_PACKS if args.quick else PACKS)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()

    addon.register()
    ensure_gpu()
    info = gpu_machine()
    log(f"machine: {info['renderer']} ({info['backend']}), {info['cpu_count']} cores; "
        f"{size}² px, {args.reps} reps, {args.draw_calls} draw calls, +{args.extra_samples} "
        f"samples; shader cache {'on' if args.shader_cache else 'off'}")
    scene, sphere, sun = build_scene(size)
    bench = Bench(scene, sphere, sun, size, args.reps, args.draw_calls, args.extra_samples)
    principled = bench.warm_up()
    log(f"  warm-up {', '.join(f'{t:.1f}' for t in principled['warm_up_seconds'])} s; "
        f"Principled first {principled['first_seconds']:.2f} s, later "
        f"{principled['later_median']:.2f} s")
    rows = []
    for layout in args.layouts:
        for packs in packs_grid:
            row = bench.measure(layout, packs)
            rows.append(row)
            log(f"  {layout:6s} {packs:2d} packs {row.get('nodes', 0):5d} nodes "
                f"{row.get('image_nodes', 0):4d} image nodes  apply "
                f"{fmt(row.get('apply_seconds'), '5.1f')} s  first "
                f"{fmt(row['first_seconds'], '6.2f')} s  later {fmt(row.get('later_median'))} "
                f"s  /P {fmt(row.get('over_principled'))}  sample "
                f"{fmt(_ms(row.get('per_sample_seconds')), '.0f')} ms "
                f"/P {fmt(row.get('per_sample_over_principled'))}  draw "
                f"{fmt(_ms(row.get('draw_median')), '.1f')} ms  {row['status']}")
    limits = {}
    if args.find_limit:
        for layout in args.layouts:
            limit = find_limit(bench, layout, rows, args.find_limit)
            if limit is not None:
                limits[layout] = limit
    seconds = time.perf_counter() - started
    info["load_end"] = os.getloadavg()[0]
    results = {
        "date": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
        "command": " ".join(["python", "scripts/bench_eevee.py", *sys.argv[1:]]),
        "seconds": seconds, "machine": info, "quick": args.quick,
        "settings": {"size": size, "reps": args.reps, "draw_calls": args.draw_calls,
                     "extra_samples": args.extra_samples, "find_limit": args.find_limit,
                     "packs": packs_grid,
                     "layouts": {k: list(LAYOUTS[k]) for k in args.layouts},
                     "segments": SEGMENTS, "rings": RINGS, "basis_size": BASIS_SIZE,
                     "pack_size": PACK_SIZE, "sun_incidence_deg": SUN_INCIDENCE_DEG,
                     "disc_radius_px": DISC_FRACTION * size,
                     "shader_cache": args.shader_cache, "eevee": eevee_settings(scene)},
        "principled": principled, "rows": rows, "limits": limits,
        "per_pack": per_pack(rows), "notes": notes(rows, principled),
    }
    stem = "bench_eevee_quick" if args.quick else "bench_eevee"
    (out / f"{stem}.json").write_text(json.dumps(results, indent=1, default=str))
    write_markdown(results, out / f"{stem}.md")
    print()
    print("\n".join(main_table(rows)))
    print()
    for line in findings(results) + results["notes"]:
        log(line)
    log(f"wrote {out / stem}.md/.json in {seconds:.0f} s")


if __name__ == "__main__":
    main()
