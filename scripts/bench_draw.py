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

    python scripts/bench_draw.py              # the default grid (~6 min on 2 cores, llvmpipe)
    python scripts/bench_draw.py --quick      # 400 × 400 target, small grid (< 1 min)
    python scripts/bench_draw.py --device-out out/gpu   # on a machine with a GPU
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

from spectral_materials.blender.brdf.gpu_material import DisplaySettings, GPUMaterial
from spectral_materials.blender.gpu import batches as mesh_batches
from spectral_materials.blender.gpu import shaders
from spectral_materials.blender.gpu.context import ensure_gpu
from spectral_materials.blender.gpu.offscreen import Target
from spectral_materials.blender.viewport.draw import set_matrix
from spectral_materials.core.brdf import prefilter
from spectral_materials.core.brdf.factored import FactoredBRDF
from spectral_materials.core.brdf.shading import light_texels, sphere_pixels
from spectral_materials.core.colour import pipeline as colour_pipeline
from spectral_materials.core.colour import spectra
from spectral_materials.core.lights import SpectralLight

PACKS = [1, 2, 4, 8, 16, 22, 32, 48]
LIGHTS = [1, 2, 4, 8]
LIGHT_PACKS = [4, 22]
QUICK_PACKS = [1, 4, 22]
QUICK_LIGHTS = [1, 2, 4]
QUICK_LIGHT_PACKS = [4]
#: Packs of the rolled-loop control (io_iso, precontract, 1 light): see rolled_shader.
ROLLED_PACKS = [2, 4, 6, 8]
QUICK_ROLLED_PACKS = [4]
#: The factor-pack paper's frame rates on ~1 M pixels (GeForce GTX 280), by packs.
PAPER_FPS = {4: 126.0, 22: 35.0, 48: 18.0}
LAYOUTS = {"io_iso": (90, 180, 90), "hd": (90, 45, 90, 45)}
BASIS_SIZE = 8
PACK_SIZE = 4
#: (layout, precontract) of the packs sweep at one light.
SERIES = (("io_iso", True), ("io_iso", False), ("hd", True))
MODES = {True: "precontract", False: "coefficients"}
#: The sphere's projected radius per pixel of target side: 565 px on 1200 → π·565² ≈ 1.0 M.
DISC_FRACTION = 565.0 / 1200.0
SEGMENTS, RINGS = 128, 64
#: Lights beyond the first sit this far off the view axis, around it, at LIGHT_DISTANCE.
LIGHT_TILT_DEG = 10.0
LIGHT_DISTANCE = 10.0
VIEW_ORIGIN = (0.0, 0.0, 1.0, 0.0)       # orthographic, looking down −z

#: The baseline's parameter block (std140), packed by :func:`baseline_params`.
BASELINE_MAX_LIGHTS = 8
BASELINE_PARAMS = f"""
struct BpParams {{
  mat4 view_projection;
  vec4 view_origin;                              /* as SmParams.view_origin */
  vec4 diffuse;                                  /* rgb: albedo, w: exposure */
  vec4 specular;                                 /* rgb: ks, w: Blinn-Phong exponent */
  vec4 light_position[{BASELINE_MAX_LIGHTS}];    /* w = 0: sun (xyz toward it), 1: point */
  vec4 light_colour[{BASELINE_MAX_LIGHTS}];      /* rgb: linear sRGB x strength */
}};
"""
BASELINE_BYTES = 64 + 3 * 16 + 2 * 16 * BASELINE_MAX_LIGHTS


def log(message: str) -> None:
    print(message, flush=True)


# ------------------------------------------------------------------------ scene


def sphere_arrays() -> mesh_batches.MeshArrays:
    """A smooth UV sphere of radius 1 at the origin, read as the draw path reads meshes."""
    bpy.ops.wm.read_homefile(use_factory_startup=True)
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)
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


def synthetic_model(layout: str, packs: int) -> FactoredBRDF:
    """Factor packs of random positive values: speed does not depend on them."""
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


# --------------------------------------------------------------------- baseline


class Baseline:
    """The RGB Blinn–Phong shader for ``count`` lights, with the same lights' colours."""

    _shaders: dict = {}

    def __init__(self, lights: list[SpectralLight], vp: np.ndarray):
        import gpu

        count = len(lights)
        if count > BASELINE_MAX_LIGHTS:
            raise ValueError(f"the baseline draws at most {BASELINE_MAX_LIGHTS} lights")
        shader = self._shaders.get(count)
        if shader is None:
            shader = gpu.shader.create_from_info(self.create_info(count))
            self._shaders[count] = shader
        self.shader = shader
        self.params = gpu.types.GPUUniformBuf(baseline_params(lights, vp))

    @staticmethod
    def create_info(count: int):
        import gpu

        info = gpu.types.GPUShaderCreateInfo()
        info.define("BP_LIGHTS", str(count))
        info.typedef_source(BASELINE_PARAMS)
        info.uniform_buf(0, "BpParams", "bp")
        info.push_constant("MAT4", "model_matrix")
        info.push_constant("MAT4", "normal_matrix")
        info.vertex_in(0, "VEC3", "position")
        info.vertex_in(1, "VEC3", "normal")
        interface = gpu.types.GPUStageInterfaceInfo("bp_surface_interface")
        interface.smooth("VEC3", "world_position")
        interface.smooth("VEC3", "world_normal")
        info.vertex_out(interface)
        info.vertex_source(shaders.glsl_source("brdf/baseline_blinn_phong_vert.glsl"))
        info.fragment_out(0, "VEC4", "frag_colour")
        info.fragment_source(shaders.glsl_source("brdf/baseline_blinn_phong_frag.glsl"))
        return info

    def bind(self) -> None:
        self.shader.bind()
        self.shader.uniform_block("bp", self.params)


def baseline_params(lights: list[SpectralLight], vp: np.ndarray) -> bytes:
    """The std140 bytes of ``BpParams``; matrices column-major."""
    positions = np.zeros((BASELINE_MAX_LIGHTS, 4))
    colours = np.zeros((BASELINE_MAX_LIGHTS, 4))
    for i, light in enumerate(lights):
        if light.kind == "SUN":
            positions[i] = (*(-np.asarray(light.axis)), 0.0)
        else:                      # spot and area lights are drawn as point lights
            positions[i] = (*light.position, 1.0)
        colours[i, :3] = prefilter.light_rgb(
            light, colour_pipeline.xyz_to_linear_srgb_matrix()) * light.strength
    parts = [np.asarray(vp, dtype=np.float64).T, np.asarray(VIEW_ORIGIN),
             np.array([0.6, 0.5, 0.4, 1.0]), np.array([0.04, 0.04, 0.04, 64.0]),
             positions, colours]
    data = b"".join(np.ascontiguousarray(p, dtype=np.float32).tobytes() for p in parts)
    assert len(data) == BASELINE_BYTES
    return data


# ---------------------------------------------------------------------- timing


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
        light_bytes = int(light_texels(model, lights, precontract=precontract).nbytes)
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
        base = [self.seconds_per_frame(bind_baseline, base_frames)]
        spectral = []
        for _ in range(self.reps):
            spectral.append(self.seconds_per_frame(bind_spectral))
            base.append(self.seconds_per_frame(bind_baseline, base_frames))
        paired = [s / (0.5 * (b0 + b1)) for s, b0, b1 in zip(spectral, base[:-1], base[1:])]
        ms = 1e3 * float(np.median(spectral))
        base_ms = 1e3 * float(np.median(base))
        return {
            "layout": layout, "resolution": list(LAYOUTS[layout]), "packs": packs,
            "terms": model.terms, "lights": len(lights),
            "light_kinds": [light.name for light in lights],
            "mode": MODES[precontract],
            "baseline_frames": base_frames,
            "ms": ms, "fps": 1e3 / ms, "baseline_ms": base_ms,
            "ratio": float(np.median(paired)), "paired_ratios": paired,
            "spectral_seconds": spectral, "baseline_seconds": base,
            "first_frame_seconds": warm_s, "covered_pixels": covered,
            "baseline_covered_pixels": base_covered, "lit_pixels": lit,
            "lit_share": lit_share(lights),
            "factor_texture_bytes": int(material.nbytes), "light_texture_bytes": light_bytes,
            "texture_bytes": int(material.nbytes) + light_bytes,
        }


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
    times_unrolled = [bench.seconds_per_frame(bind_unrolled)]
    times_rolled = []
    for _ in range(bench.reps):
        times_rolled.append(bench.seconds_per_frame(bind_rolled))
        times_unrolled.append(bench.seconds_per_frame(bind_unrolled))
    paired = [0.5 * (u0 + u1) / r for r, u0, u1 in
              zip(times_rolled, times_unrolled[:-1], times_unrolled[1:])]
    return {"layout": layout, "packs": packs, "lights": 1, "mode": "precontract",
            "unrolled_ms": 1e3 * float(np.median(times_unrolled)),
            "rolled_ms": 1e3 * float(np.median(times_rolled)),
            "unrolled_over_rolled": float(np.median(paired)), "paired": paired,
            "unrolled_seconds": times_unrolled, "rolled_seconds": times_rolled}


def rolled_shader(key: shaders.ShaderKey):
    """The variant ``key`` with the pack loop's bound unknown to the compiler.

    ``p < SM_PACKS + sm.misc.w`` (misc.w is 0) stops the compiler unrolling the loop
    over packs; everything else is the add-on's shader. A control for the cost of
    unrolling on this machine; None where the GLSL has no such loop any more.
    """
    import gpu

    original = shaders.fragment_source
    source = original()
    patched = source.replace("p < SM_PACKS", "p < SM_PACKS + sm.misc.w")
    if patched == source:
        return None
    shaders.fragment_source = lambda: patched   # create_info reads it; put back below
    try:
        info = shaders.create_info(key)
    finally:
        shaders.fragment_source = original
    return gpu.shader.create_from_info(info)


# ------------------------------------------------------------ per-pack counts


def _between(text: str, start: str, end: str) -> str:
    head = text.index(start) + len(start)
    return text[head:text.index(end, head)]


def glsl_counts() -> dict:
    """Texture fetches and ALU per pack and light, counted from glsl/ (see the Markdown).

    The fetch sites are counted in the sources; the formulas say how often each runs.
    """
    packs_src = _between(shaders.glsl_source("brdf/factor_packs.glsl"), "vec4 sm_pack_product",
                         "\n}")
    basis_src = shaders.glsl_source("brdf/spectral_basis.glsl")
    precontract_src = _between(basis_src, "#if SM_PRECONTRACT", "#else")
    coefficient_src = _between(basis_src, "#else", "#endif")
    sites = {"per_axis": packs_src.count("texelFetch("),
             "precontract": precontract_src.count("texelFetch("),
             "coefficients": coefficient_src.count("texelFetch(")}
    expected = {"per_axis": 2, "precontract": 3, "coefficients": 2}
    if sites != expected:
        log(f"warning: texelFetch sites in glsl/ are {sites}, the counts below assume "
            f"{expected}; recount them")
    m = BASIS_SIZE
    out = {"sites": sites, "rows": []}
    for layout, shape in LAYOUTS.items():
        d = len(shape)
        for precontract in (True, False):
            spectral_fetches = 3 if precontract else m
            # Scalar lane operations, an FMA counted as one: mix4 = 4 sub + 4 FMA,
            # mul4 = 4, dot4 = 1 mul + 3 FMA = 4; accumulation: vec3 add (3) or m adds.
            lanes = 8 * d + 4 * d + 4 * spectral_fetches + (3 if precontract else m)
            out["rows"].append({
                "layout": layout, "axes": d, "mode": MODES[precontract],
                "fetches": 2 * d + spectral_fetches, "mix4": d, "mul4": d,
                "dot4": spectral_fetches, "adds": "1 vec3" if precontract else f"{m} scalar",
                "lane_ops": lanes,
                "per_light_extra_fetches": 0 if precontract else m,
                "paper_fetches": f"{d} filtered + spectral factor",
            })
    return out


# ----------------------------------------------------------------- summaries


def fit_line(x, y) -> tuple[float, float]:
    slope, intercept = np.polyfit(np.asarray(x, dtype=np.float64),
                                  np.asarray(y, dtype=np.float64), 1)
    return float(slope), float(intercept)


def summaries(rows: list[dict], light_packs: list[int]) -> dict:
    """Lines through the sweeps: the cost of one more pack, and of one more light.

    Slopes are fitted to ms/frame (this machine's absolute cost) and to the ratio
    (the cost in baseline frames, which the machine's load cancels out of).
    """
    out: dict = {"packs": [], "lights": []}
    for layout, precontract in SERIES:
        series = sorted((r for r in rows if r["layout"] == layout and r["lights"] == 1
                         and r["mode"] == MODES[precontract]), key=lambda r: r["packs"])
        if len(series) < 2:
            continue
        packs = [r["packs"] for r in series]
        slope, intercept = fit_line(packs, [r["ms"] for r in series])
        ratio_slope, ratio_intercept = fit_line(packs, [r["ratio"] for r in series])
        pixels = float(np.median([r["covered_pixels"] for r in series]))
        out["packs"].append({
            "layout": layout, "mode": MODES[precontract], "ms_per_pack": slope,
            "ms_at_0_packs": intercept,
            "baseline_ms": float(np.median([r["baseline_ms"] for r in series])),
            "baseline_frames_per_pack": ratio_slope, "ratio_at_0_packs": ratio_intercept,
            "fixed_cost_in_packs": ratio_intercept / ratio_slope,
            "ns_per_pixel_pack": slope * 1e6 / pixels})
    by_packs = {}
    for packs in light_packs:
        series = sorted((r for r in rows if r["layout"] == "io_iso" and r["packs"] == packs
                         and r["mode"] == "precontract"), key=lambda r: r["lights"])
        if len({r["lights"] for r in series}) < 2:
            continue
        lights = [r["lights"] for r in series]
        slope, intercept = fit_line(lights, [r["ms"] for r in series])
        base_slope, _ = fit_line(lights, [r["baseline_ms"] for r in series])
        ratio_slope, _ = fit_line(lights, [r["ratio"] for r in series])
        by_packs[packs] = (slope, ratio_slope)
        out["lights"].append({"layout": "io_iso", "mode": "precontract", "packs": packs,
                              "ms_per_light": slope, "ms_at_0_lights": intercept,
                              "baseline_ms_per_light": base_slope,
                              "ratio_per_light": ratio_slope})
    if len(by_packs) >= 2:
        (p0, (s0, r0)), (p1, (s1, r1)) = sorted(by_packs.items())[0], \
            sorted(by_packs.items())[-1]
        out["per_pack_per_light"] = {"from_packs": [p0, p1],
                                     "ms": (s1 - s0) / (p1 - p0),
                                     "baseline_frames": (r1 - r0) / (p1 - p0)}
    x = list(PAPER_FPS)
    slope, intercept = fit_line(x, [1e3 / PAPER_FPS[p] for p in x])
    out["paper"] = {"ms_per_pack": slope, "ms_at_0_packs": intercept,
                    "fixed_cost_in_packs": intercept / slope,
                    "rows": [{"packs": p, "fps": fps, "ms": 1e3 / fps,
                              "relative_to_4": PAPER_FPS[4] / fps}
                             for p, fps in PAPER_FPS.items()]}
    return out


# ------------------------------------------------------------------ reports


def fmt_bytes(n: int) -> str:
    return f"{n:,}".replace(",", " ")


def main_table(rows: list[dict]) -> list[str]:
    lines = ["| layout | packs | lights | mode | ms/frame | FPS | baseline ms/frame | ratio | "
             "covered pixels | texture bytes |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['layout']} | {r['packs']} | {r['lights']} | {r['mode']} | "
                     f"{r['ms']:.1f} | {r['fps']:.2f} | {r['baseline_ms']:.1f} | "
                     f"{r['ratio']:.1f} | {fmt_bytes(r['covered_pixels'])} | "
                     f"{fmt_bytes(r['texture_bytes'])} |")
    return lines


def ordered(rows: list[dict]) -> list[dict]:
    series = {(layout, MODES[pre]): i for i, (layout, pre) in enumerate(SERIES)}
    return sorted(rows, key=lambda r: (r["lights"] > 1, series[(r["layout"], r["mode"])],
                                       r["packs"], r["lights"]))


def paper_table(results: dict) -> list[str]:
    rows = results["rows"]
    head = "| packs | paper FPS (GTX 280) | paper ms/frame | paper t(P)/t(4) |"
    rule = "|---|---|---|---|"
    series = [(layout, MODES[pre]) for layout, pre in SERIES
              if any(r["layout"] == layout and r["mode"] == MODES[pre] for r in rows)]
    for layout, mode in series:
        head += f" {layout} {mode}: ms/frame | FPS | t(P)/t(4) | ratio |"
        rule += "---|---|---|---|"
    lines = [head, rule]
    for p, fps in PAPER_FPS.items():
        line = f"| {p} | {fps:.0f} | {1e3 / fps:.1f} | {PAPER_FPS[4] / fps:.2f} |"
        for layout, mode in series:
            pick = {r["packs"]: r for r in rows if r["layout"] == layout and r["mode"] == mode
                    and r["lights"] == 1}
            r, r4 = pick.get(p), pick.get(4)
            if r is None:
                line += " – | – | – | – |"
                continue
            rel = f"{r['ratio'] / r4['ratio']:.2f}" if r4 else "–"
            line += f" {r['ms']:.1f} | {r['fps']:.2f} | {rel} | {r['ratio']:.1f} |"
        lines.append(line)
    return lines


def rolled_section(results: dict) -> list[str]:
    """The rolled-loop control: the add-on's variant against the same with a rolled loop."""
    rolled = results.get("rolled") or []
    if not rolled:
        return []
    lines = ["### The pack loop, unrolled or not", "",
             "`for (int p = 0; p < SM_PACKS; p++)` has a bound known when the variant is "
             "compiled, so the compiler may unroll it. Control: the same variant with the "
             "bound written `SM_PACKS + sm.misc.w` (misc.w is 0, but unknown to the "
             "compiler), io_iso, precontract, one light, on the same material and target, "
             "the two timed alternately; unrolled / rolled is the median of each rolled "
             "timing against the mean of the add-on's timings on either side.", "",
             "| packs | add-on's shader ms/frame | rolled loop ms/frame | unrolled / rolled |",
             "|---|---|---|---|"]
    for r in rolled:
        lines.append(f"| {r['packs']} | {r['unrolled_ms']:.1f} | {r['rolled_ms']:.1f} | "
                     f"{r['unrolled_over_rolled']:.2f} |")
    lines += ["", "Where the two differ the compiler unrolled the loop (Mesa's choice here, "
              "not the shader's), and the unrolled code ran at a different speed on this "
              "machine: that is what makes the sweep uneven at a few packs. The work itself "
              "is linear in the packs, as the rolled column shows.", ""]
    return lines


def unrolled_note(results: dict) -> list[str]:
    """Our scaling with the 4-pack time of the rolled loop, where the control has it."""
    control = {r["packs"]: r for r in results.get("rolled") or []}
    main = {r["packs"]: r for r in results["rows"] if r["layout"] == "io_iso"
            and r["mode"] == "precontract" and r["lights"] == 1}
    if 4 not in control or 4 not in main:
        return []
    ratio4 = main[4]["ratio"] / control[4]["unrolled_over_rolled"]
    scaled = ", ".join(f"t({p})/t(4) = {main[p]['ratio'] / ratio4:.2f}" for p in (22, 48)
                       if p in main)
    return [f"On this machine the 4-pack variant is {control[4]['unrolled_over_rolled']:.2f}× "
            "the rolled loop's time (control above), which flattens our t(P)/t(4). Against "
            f"the rolled 4-pack time, io_iso precontract scales {scaled} (paper: "
            f"{PAPER_FPS[4] / PAPER_FPS[22]:.2f}, {PAPER_FPS[4] / PAPER_FPS[48]:.2f}).", ""]


def write_markdown(results: dict, path: Path) -> None:
    rows = results["rows"]
    s = results["settings"]
    m = results["machine"]
    summ = results["summaries"]
    counts = results["counts"]
    lines = [
        "# Draw benchmark", "",
        f"Machine: `{m['renderer']}` ({m['vendor']}, {m['version']}, {m['backend']} backend; "
        f"{m['cpu_count']} CPU cores, Blender {m['blender']}). Date: {results['date']}. "
        f"Command: `{results['command']}` ({results['seconds']:.0f} s in all). Load "
        f"average (1 min) {m['load_start']:.1f} at the start, {m['load_end']:.1f} at the end: "
        "other jobs share these cores, hence the ratios.",
        "",
        f"A smooth UV sphere ({SEGMENTS} segments × {RINGS} rings, "
        f"{s['triangles']} triangles, {fmt_bytes(s['vertex_bytes'])} vertex + index bytes) "
        f"drawn orthographically into a {s['size']} × {s['size']} RGBA32F target with depth "
        f"test and back faces culled (so every covered pixel is shaded once), through the "
        f"add-on's own path (`GPUMaterial`, `shaders.get_shader`, `MeshBatches`, output "
        f"DISPLAY). Factors are synthetic (speed does not depend on their values): io_iso "
        f"{'×'.join(map(str, LAYOUTS['io_iso']))} and hd {'×'.join(map(str, LAYOUTS['hd']))}, "
        f"spectral basis m = {BASIS_SIZE}, packs of {PACK_SIZE} terms, float32 textures.",
        "",
        "Each frame is a clear and one draw; a frame time is the wall time of "
        f"{s['frames']} frames ended by a 1-pixel read-back (which waits for the GPU), "
        f"divided by {s['frames']}; ms/frame is the median of {s['reps']} repetitions, "
        "after one warm-up frame that compiles the variant. **Baseline**: an RGB "
        "Blinn–Phong shader (`glsl/brdf/baseline_blinn_phong_*.glsl`, suns and 1/(4πr²) point "
        "lights, spots and areas drawn as points) with as many lights as the row, drawing "
        "the same batch into the same target, timed before and after every spectral "
        f"timing (B S B S … S B; {s['frames']} to {4 * s['frames']} baseline frames, so "
        "that a baseline timing lasts about half a spectral one). **ratio** = median over "
        "the repetitions of the spectral time over the mean of the two baseline times "
        "around it, so it compares like with "
        "like while the machine's load changes; it is not exactly the ratio of the two "
        "medians shown. The absolute times are this machine's only (llvmpipe is a CPU "
        "rasteriser: they are not GPU times).",
        "",
        "Modes: **precontract** (the add-on's default) folds the spectral factor into the "
        "light once per light on the CPU, K = Sᵀ Ĩ, 3 texels per pack; **coefficients** is "
        "the paper's per-pixel coefficient dot product (eq. 9), m texels per pack. Texture "
        "bytes = factor texture (all axes, the spectral factor and the basis) + light "
        "texture, float32.",
        "",
        "## Frame time", "",
        *main_table(ordered(rows)), "",
    ]
    light_rows = [r for r in rows if r["lights"] > 1]
    if light_rows:
        shares = {r["lights"]: (r["light_kinds"], r["lit_share"]) for r in rows}
        lines += ["Lights (io_iso, precontract; the 1-light rows are those of the packs "
                  "sweep): " + "; ".join(
                      f"{n}: {', '.join(kinds)} (each reaches {100 * share:.0f} % of the "
                      "covered pixels on average)" for n, (kinds, share) in sorted(
                          shares.items())) + ". A light that does not reach a pixel costs "
                  "the spectral shader no pack work there; the baseline shades it anyway.",
                  ""]
    lines += rolled_section(results)
    lines += ["## Cost per pack", "",
              "Measured: least-squares lines against packs at one light, of ms/frame (this "
              "machine's cost) and of the ratio (the cost in baseline frames); ns per pixel "
              "per pack = ms slope / covered pixels; fixed cost in packs = the ratio line's "
              "intercept over its slope (what a frame costs besides its packs, counted in "
              "packs: comparable across hardware).", "",
              "| layout | mode | ms/frame per pack | ms/frame at 0 packs | baseline ms/frame | "
              "baseline frames per pack | ns per pixel per pack | fixed cost in packs |",
              "|---|---|---|---|---|---|---|---|"]
    for f in summ["packs"]:
        lines.append(f"| {f['layout']} | {f['mode']} | {f['ms_per_pack']:.2f} | "
                     f"{f['ms_at_0_packs']:.1f} | {f['baseline_ms']:.1f} | "
                     f"{f['baseline_frames_per_pack']:.2f} | {f['ns_per_pixel_pack']:.1f} | "
                     f"{f['fixed_cost_in_packs']:.1f} |")
    paper = summ["paper"]
    lines += ["", f"The paper (GTX 280, ~1 M pixels): {paper['ms_per_pack']:.2f} ms/frame per "
              f"pack, {paper['ms_at_0_packs']:.1f} ms at 0 packs (line through its three "
              f"points): a fixed cost of {paper['fixed_cost_in_packs']:.1f} packs.", ""]
    if summ["lights"]:
        lines += ["Lights (io_iso, precontract): lines against the light count.", "",
                  "| packs | ms/frame per light | baseline ms/frame per light | "
                  "baseline frames per light |", "|---|---|---|---|"]
        for f in summ["lights"]:
            lines.append(f"| {f['packs']} | {f['ms_per_light']:.1f} | "
                         f"{f['baseline_ms_per_light']:.2f} | {f['ratio_per_light']:.2f} |")
        per = summ.get("per_pack_per_light")
        if per:
            a, b = per["from_packs"]
            lines += ["", f"Per pack per light, from the difference of the two lines "
                      f"({a} and {b} packs): {per['ms']:.2f} ms/frame, "
                      f"{per['baseline_frames']:.2f} baseline frames (compare the per-pack "
                      "slope at one light above)."]
        lines.append("")
    lines += [
        "Counted from the GLSL (per pack and per light; d angular axes, m = "
        f"{BASIS_SIZE}): `sm_pack_product` (glsl/brdf/factor_packs.glsl) fetches "
        f"{counts['sites']['per_axis']} unfiltered texels per axis (`texelFetch` at i0 and "
        "i1) and interpolates them itself, `product *= mix(a, b, w)`; "
        "`sm_reflected_xyz` (glsl/brdf/spectral_basis.glsl) then fetches 3 texels (X, Y, Z "
        "weights of the pack's 4 terms) and takes 3 dot4 (precontract), or fetches m "
        "texels of the pack's spectral factor and accumulates m dot4 into the "
        "coefficients (coefficients mode; then m more fetches and m vec3 FMA per light, "
        "not per pack). Lane ops count an FMA as one: mix4 = 4 sub + 4 FMA, mul4 = 4, "
        "dot4 = 4. Address arithmetic (one integer multiply-add per axis for the row) is "
        "not counted.", "",
        "| layout | d | mode | texture fetches | vec4 mix | vec4 mul | dot4 | accumulate | "
        "lane ops | paper's fetches |", "|---|---|---|---|---|---|---|---|---|---|"]
    for c in counts["rows"]:
        lines.append(f"| {c['layout']} | {c['axes']} | {c['mode']} | {c['fetches']} | "
                     f"{c['mix4']} | {c['mul4']} | {c['dot4']} | {c['adds']} | "
                     f"{c['lane_ops']} | {c['paper_fetches']} |")
    lines += [
        "",
        "Per light, not per pack: the light's incidence (2–3 light texels, a normalise, the "
        "falloff), wi into the shading frame (3 dot3), the parameterisation (io_iso: "
        "4 `atan`, 3 `mod`; hd: the half vector, 4 `atan`, 2 `mod`, 2 sin/cos pairs and "
        "the rotation) and d axis lookups (clamp or `mod`, a divide, `sqrt` on warped "
        "axes, `floor`, index selects). Per pixel: the frame (normalise, Gram–Schmidt, "
        "cross) and the display pipeline (2 mat3, tone map, sRGB `pow`).",
        "",
        "Against the paper: its shader read 1 hardware-filtered texel per axis per pack "
        "(the texture unit interpolates) plus the spectral factor: d angular fetches and "
        "no interpolation ALU per pack. Ours reads 2 unfiltered texels per axis and "
        "interpolates in ALU (d more fetches and d mix4 per pack) so that the GPU agrees "
        "with the Python lookup `FactoredBRDF.coefficients` to float32 rounding: a "
        "hardware linear filter rounds its weights to 8 bits (glsl/brdf/factor_packs.glsl). "
        f"Precontraction takes the spectral side from m to 3 fetches per pack, saving "
        f"m − 3 = {BASIS_SIZE - 3}, more than the d extra fetches of the exact "
        "interpolation: if the paper's spectral factor of a pack took m RGBA texels, as "
        f"ours does in coefficients mode, it read d + m = {3 + BASIS_SIZE} (io_iso) or "
        f"{4 + BASIS_SIZE} (hd) texels per pack where ours, precontracted, reads "
        f"{counts['rows'][0]['fetches']} or {counts['rows'][2]['fetches']}; "
        "its filtered fetches cost the texture unit more than a `texelFetch` does, and "
        "our d mix4 are ALU it did not spend.",
        "",
        "## Against the factor-pack paper", "",
        "The paper's frame rates were measured on a GeForce GTX 280 (2008) at about 1 M "
        "pixels; ours on the machine above. **Different hardware**: compare the scaling "
        "t(P)/t(4) and the ratios, not the absolute times. The paper gives no baseline; "
        "our ratio is against the Blinn–Phong baseline of the same run, and our t(P)/t(4) "
        "is ratio(P)/ratio(4), so that the machine's changing load cancels out.", "",
        *paper_table(results), "", *unrolled_note(results),
        "## Memory", "",
        "| layout | packs | mode | factor texture bytes | light texture bytes per light |",
        "|---|---|---|---|---|"]
    seen = set()
    for r in ordered(rows):
        key = (r["layout"], r["packs"], r["mode"])
        if key in seen:
            continue
        seen.add(key)
        lines.append(f"| {r['layout']} | {r['packs']} | {r['mode']} | "
                     f"{fmt_bytes(r['factor_texture_bytes'])} | "
                     f"{fmt_bytes(r['light_texture_bytes'] // r['lights'])} |")
    lines += ["", f"Vertex and index buffers: {fmt_bytes(s['vertex_bytes'])} bytes "
              f"({s['corners']} corners × (position, normal, tangent) float32 + "
              f"{s['triangles']} triangles × 3 int32), the same for every row and for the "
              "baseline.", ""]
    path.write_text("\n".join(lines))


# --------------------------------------------------------------------- main


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="400 × 400 target and a small grid (smoke test, < 1 min)")
    parser.add_argument("--size", type=int, default=None,
                        help="target side in pixels (default 1200: the sphere covers ~1.0 M "
                             "pixels; 400 with --quick)")
    parser.add_argument("--frames", type=int, default=3, help="frames per timing")
    parser.add_argument("--reps", type=int, default=None,
                        help="repetitions per configuration (median; default 5, 3 with "
                             "--quick)")
    parser.add_argument("--device-out", "--out", dest="out", default=str(ROOT / "docs"),
                        help="write bench_draw.md/.json here instead of docs/")
    args = parser.parse_args()
    size = args.size or (400 if args.quick else 1200)
    reps = args.reps or (3 if args.quick else 5)
    packs_grid = QUICK_PACKS if args.quick else PACKS
    lights_grid = QUICK_LIGHTS if args.quick else LIGHTS
    light_packs = QUICK_LIGHT_PACKS if args.quick else LIGHT_PACKS
    rolled_grid = QUICK_ROLLED_PACKS if args.quick else ROLLED_PACKS
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()

    ensure_gpu()
    import gpu

    arrays = sphere_arrays()
    batches = mesh_batches.MeshBatches.build(arrays)
    (batch,) = batches.batches.values()
    vp = view_projection(0.5 / DISC_FRACTION)
    info = gpu_machine()
    log(f"machine: {info['renderer']} ({info['backend']}), {info['cpu_count']} cores; "
        f"target {size}² px, {reps} reps × {args.frames} frames")
    configs = [(layout, p, 1, pre) for layout, pre in SERIES for p in packs_grid]
    configs += [("io_iso", p, n, True) for p in light_packs for n in lights_grid if n > 1]
    rows, rolled_rows = [], []
    with Target(size, size) as target:
        gpu.state.face_culling_set("BACK")
        try:
            bench = Bench(target, batch, vp, args.frames, reps)
            for layout, packs, n_lights, pre in configs:
                row = bench.measure(layout, packs, make_lights(n_lights), pre)
                rows.append(row)
                log(f"  {layout:6s} {packs:2d} packs {n_lights} lights {row['mode']:12s} "
                    f"{row['ms']:8.1f} ms  baseline {row['baseline_ms']:6.1f} ms  "
                    f"ratio {row['ratio']:6.1f}  covered {row['covered_pixels']}")
            for packs in rolled_grid:
                row = compare_rolled(bench, "io_iso", packs)
                if row is None:
                    log("  no pack loop to keep rolled in glsl/: control skipped")
                    break
                rolled_rows.append(row)
                log(f"  io_iso {packs:2d} packs unrolled {row['unrolled_ms']:8.1f} ms  rolled "
                    f"{row['rolled_ms']:8.1f} ms  unrolled/rolled "
                    f"{row['unrolled_over_rolled']:.2f}")
        finally:
            gpu.state.face_culling_set("NONE")
    seconds = time.perf_counter() - started
    info["load_end"] = os.getloadavg()[0]
    results = {
        "date": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
        "command": " ".join(["python", "scripts/bench_draw.py", *sys.argv[1:]]),
        "seconds": seconds, "machine": info, "quick": args.quick,
        "settings": {"size": size, "frames": args.frames, "reps": reps,
                     "segments": SEGMENTS, "rings": RINGS,
                     "triangles": int(sum(len(t) for t in arrays.triangles.values())),
                     "corners": len(arrays.positions), "vertex_bytes": arrays.nbytes,
                     "disc_radius_px": DISC_FRACTION * size,
                     "expected_pixels": float(np.pi * (DISC_FRACTION * size) ** 2),
                     "basis_size": BASIS_SIZE, "layouts": {k: list(v) for k, v in
                                                           LAYOUTS.items()}},
        "rows": rows, "rolled": rolled_rows, "summaries": summaries(rows, light_packs),
        "counts": glsl_counts(),
        "paper": {"gpu": "GeForce GTX 280", "pixels": "about 1 M",
                  "fps": {str(k): v for k, v in PAPER_FPS.items()}},
    }
    stem = "bench_draw_quick" if args.quick else "bench_draw"
    (out / f"{stem}.json").write_text(json.dumps(results, indent=1))
    write_markdown(results, out / f"{stem}.md")
    print()
    print("\n".join(main_table(ordered(rows))))
    print()
    for f in results["summaries"]["packs"]:
        log(f"{f['layout']} {f['mode']}: {f['ms_per_pack']:.2f} ms/frame per pack "
            f"({f['baseline_frames_per_pack']:.2f} baseline frames, "
            f"{f['ns_per_pixel_pack']:.1f} ns per pixel per pack)")
    for c in results["counts"]["rows"]:
        log(f"{c['layout']} {c['mode']}: {c['fetches']} fetches, {c['lane_ops']} lane ops "
            "per pack per light")
    log(f"wrote {out / stem}.md/.json in {seconds:.0f} s")


if __name__ == "__main__":
    main()
