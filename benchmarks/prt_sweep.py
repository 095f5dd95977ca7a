"""The spectral PRT benchmark's error sweep: the Monte Carlo references, and ΔE94 of
spectral and RGB PRT for every bands × rays × basis size × illuminant × window."""

from __future__ import annotations

import time

import numpy as np

from spectral_materials.blender.prt import drawer as prt_gpu, scene as prt
from spectral_materials.core.colour import pipeline as colour_pipeline
from spectral_materials.core.prt import environment as core_environment, transfer as core_prt
from spectral_materials.core.prt.albedo import packed_layer_count

from .harness import log
from .prt_report import DEFAULT_WINDOW, SKIES, WINDOWS

ILLUMINANTS = ("FL4", "D65")
MAIN_BASIS = 8
#: The seed of the second Monte Carlo reference (the noise floor).
NOISE_SEED = 1


def set_sky(env, name: str) -> None:
    env.sky, env.sun_fraction = SKIES[name]


def stats(de: np.ndarray) -> dict:
    return {"mean": float(np.mean(de)), "p95": float(np.percentile(de, 95)),
            "max": float(np.max(de))}


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
            "albedo_texture": int(packed_layer_count(m) * h * w * 16),
            "rgb_environment_texture": int(prt_gpu.environment_texels(np.zeros((k, 3))).nbytes),
            "rgb_albedo_texture": int(h * w * 16)}


class References:
    """The Monte Carlo references (once per illuminant: they depend on none of the swept
    settings), their whites and noise floor, the window sweep's other skies, and the
    whites by basis size."""

    def __init__(self, scene, obj, rays: int, basis_grid: list[int]):
        env = scene.spectral.environment
        self.xyz, self.whites, self.noise = {}, {}, {}
        for illuminant in ILLUMINANTS:
            env.illuminant = illuminant
            start = time.perf_counter()
            self.xyz[illuminant] = prt.vertex_reference_xyz(obj, scene, rays=rays)
            seconds = time.perf_counter() - start
            second = prt.vertex_reference_xyz(obj, scene, rays=rays, seed=NOISE_SEED)
            self.whites[illuminant] = prt.environment_white_xyz(scene)
            self.noise[illuminant] = {"seconds": seconds, **stats(colour_pipeline.delta_e94(
                self.xyz[illuminant], second, self.whites[illuminant]))}
            n = self.noise[illuminant]
            log(f"  reference {illuminant}: {seconds:.1f} s; two seeds differ by ΔE94 mean "
                f"{n['mean']:.3f}, p95 {n['p95']:.3f}, max {n['max']:.3f}")
        # The window sweep's other skies: one reference each, no noise floor.
        self.skies = {}
        for sky in list(SKIES)[1:]:
            set_sky(env, sky)
            for illuminant in ILLUMINANTS:
                env.illuminant = illuminant
                start = time.perf_counter()
                reference = prt.vertex_reference_xyz(obj, scene, rays=rays)
                self.skies[sky, illuminant] = (reference, prt.environment_white_xyz(scene))
                log(f"  reference {sky} {illuminant}: {time.perf_counter() - start:.1f} s")
        set_sky(env, next(iter(SKIES)))
        self.white_by_basis = {}
        for illuminant in ILLUMINANTS:
            env.illuminant = illuminant
            for m in basis_grid:
                env.basis_size = m
                self.white_by_basis[f"{illuminant}/{m}"] = \
                    prt.environment_white_xyz(scene).tolist()

    def of(self, sky: str, illuminant: str) -> tuple[np.ndarray, np.ndarray]:
        """(reference XYZ, white) under ``sky`` (the first sky: the main references)."""
        if sky == next(iter(SKIES)):
            return self.xyz[illuminant], self.whites[illuminant]
        return self.skies[sky, illuminant]


class Sweep:
    """Bands × rays × basis × illuminant: the error rows, bakes, RGB PRT and windows."""

    def __init__(self, scene, obj, refs: References, basis_grid: list[int], main_rays: int):
        self.scene, self.obj, self.refs = scene, obj, refs
        self.env = scene.spectral.environment
        self.basis_grid, self.main_rays = basis_grid, main_rays
        self.albedo_rgb = albedo_rgb_at_vertices(obj)
        self.errors, self.bakes, self.rgb_rows, self.window_rows = [], [], [], []

    def _delta_e(self, reference, white) -> dict:
        return stats(colour_pipeline.delta_e94(reference, prt.vertex_xyz(self.obj, self.scene),
                                               white))

    def bake(self, bands: int, rays: int):
        """Bake at (bands, rays), then every illuminant's rows; returns the bake."""
        env, obj, scene = self.env, self.obj, self.scene
        env.illuminant, env.basis_size = ILLUMINANTS[0], MAIN_BASIS
        env.window = DEFAULT_WINDOW
        obj.spectral_prt.rays = rays
        start = time.perf_counter()
        baked = prt.bake_prt(obj, scene)
        wall = time.perf_counter() - start
        transfer = np.asarray(baked.coefficients, dtype=np.float64)
        self.bakes.append({"bands": bands, "rays": rays, "seconds": baked.seconds,
                           "wall_seconds": wall, "rays_cast": int(baked.rays_cast),
                           "rays_per_second": baked.rays_per_second,
                           "backend": baked.backend,
                           "sh_coefficients": int(transfer.shape[1])})
        line = [self.illuminant_rows(illuminant, bands, rays, transfer)
                for illuminant in ILLUMINANTS]
        log(f"  bands {bands} rays {rays:5d}: bake {baked.seconds:6.2f} s "
            f"({baked.rays_per_second / 1e6:5.2f} Mrays/s {baked.backend}, wall "
            f"{wall:5.2f} s); ΔE94 mean/p95 at m = {MAIN_BASIS}: {', '.join(line)}")
        return baked

    def illuminant_rows(self, illuminant: str, bands: int, rays: int, transfer) -> str:
        """The basis sweep (and at the main rays: again without a window, and the window
        sweep), RGB PRT; returns the log's summary at the main basis."""
        env = self.env
        env.illuminant = illuminant
        reference, white = self.refs.xyz[illuminant], self.refs.whites[illuminant]
        summary = ""
        for m in self.basis_grid:
            env.basis_size = m
            start = time.perf_counter()
            xyz = prt.vertex_xyz(self.obj, self.scene)
            evaluate = time.perf_counter() - start
            row = {"illuminant": illuminant, "bands": bands, "rays": rays, "basis": m,
                   "window": DEFAULT_WINDOW, "eval_seconds": evaluate,
                   **stats(colour_pipeline.delta_e94(reference, xyz, white))}
            self.errors.append(row)
            if m == MAIN_BASIS:
                summary = f"{illuminant} {row['mean']:.2f}/{row['p95']:.2f}"
        if rays == self.main_rays:
            # The basis sweep again without a window (see the window table).
            env.window = "NONE"
            for m in self.basis_grid:
                env.basis_size = m
                self.errors.append({"illuminant": illuminant, "bands": bands, "rays": rays,
                                    "basis": m, "window": "NONE",
                                    **self._delta_e(reference, white)})
            env.window = DEFAULT_WINDOW
        env.basis_size = MAIN_BASIS
        self.rgb_rows.append({"illuminant": illuminant, "bands": bands, "rays": rays,
                              "basis": MAIN_BASIS,
                              **rgb_errors(self.obj, self.scene, transfer, self.albedo_rgb,
                                           reference, white, bands)})
        if rays == self.main_rays:
            self.windows(illuminant, bands, rays)
        return summary

    def windows(self, illuminant: str, bands: int, rays: int) -> None:
        """Every SH window under every sky of the window sweep."""
        for sky in SKIES:
            set_sky(self.env, sky)
            reference, white = self.refs.of(sky, illuminant)
            for window in WINDOWS:
                self.env.window = window
                self.window_rows.append({
                    "sky": sky, "illuminant": illuminant, "bands": bands, "rays": rays,
                    "basis": MAIN_BASIS, "window": window,
                    **self._delta_e(reference, white)})
        self.env.window = DEFAULT_WINDOW
        set_sky(self.env, next(iter(SKIES)))
